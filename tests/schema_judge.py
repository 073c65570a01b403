"""A small JSON Schema (draft 2020-12) validator for the keywords vecpin's schemas use, written
from the specification (json-schema.org, "JSON Schema Validation"), not from vecpin: an
independent judge of the shipped schemas and of the files vecpin writes. Keywords it does
not know are refused, so a schema cannot silently use one it would ignore."""
import re

KNOWN = {"$schema", "$id", "$defs", "$ref", "title", "description", "type", "const", "enum", "required", "properties",
         "additionalProperties", "items", "minItems", "maxItems", "minimum", "maximum", "exclusiveMinimum",
         "pattern", "anyOf"}


def _is_type(value, name: str) -> bool:
    if name == "null":
        return value is None
    if name == "boolean":
        return isinstance(value, bool)
    if name == "integer":  # a number with a zero fractional part is an integer (the spec's data model)
        return not isinstance(value, bool) and isinstance(value, (int, float)) and float(value).is_integer()
    if name == "number":
        return not isinstance(value, bool) and isinstance(value, (int, float))
    return isinstance(value, {"string": str, "array": list, "object": dict}[name])


def _resolve(root: dict, ref: str) -> dict:
    assert ref.startswith("#/"), f"only local references: {ref}"
    node = root
    for part in ref[2:].split("/"):
        node = node[part]
    return node


def errors(schema: dict, value, root: dict | None = None, where: str = "$") -> list[str]:
    """Every way ``value`` breaks ``schema`` (empty: valid), each naming the place."""
    root = root or schema
    unknown = set(schema) - KNOWN
    assert not unknown, f"the judge does not know {unknown}"
    out: list[str] = []
    if "$ref" in schema:
        out += errors(_resolve(root, schema["$ref"]), value, root, where)
    if "type" in schema:
        types = schema["type"] if isinstance(schema["type"], list) else [schema["type"]]
        if not any(_is_type(value, t) for t in types):
            return out + [f"{where}: {value!r} is not {' or '.join(types)}"]
    if "const" in schema and not (value == schema["const"] and type(value) is type(schema["const"])):
        out.append(f"{where}: {value!r} is not {schema['const']!r}")
    if "enum" in schema and value not in schema["enum"]:
        out.append(f"{where}: {value!r} not one of {schema['enum']}")
    if "anyOf" in schema and all(errors(s, value, root, where) for s in schema["anyOf"]):
        out.append(f"{where}: {value!r} matches none of the alternatives")
    if isinstance(value, str) and "pattern" in schema and not re.search(schema["pattern"], value):
        out.append(f"{where}: {value!r} does not match {schema['pattern']}")
    if _is_type(value, "number"):
        if "minimum" in schema and value < schema["minimum"]:
            out.append(f"{where}: {value} < {schema['minimum']}")
        if "maximum" in schema and value > schema["maximum"]:
            out.append(f"{where}: {value} > {schema['maximum']}")
        if "exclusiveMinimum" in schema and value <= schema["exclusiveMinimum"]:
            out.append(f"{where}: {value} <= {schema['exclusiveMinimum']}")
    if isinstance(value, list):
        if len(value) < schema.get("minItems", 0) or len(value) > schema.get("maxItems", len(value)):
            out.append(f"{where}: {len(value)} items")
        for k, v in enumerate(value):
            if "items" in schema:
                out += errors(schema["items"], v, root, f"{where}[{k}]")
    if isinstance(value, dict):
        out += [f"{where}: '{k}' is required" for k in schema.get("required", ()) if k not in value]
        props = schema.get("properties", {})
        for k, v in value.items():
            if k in props:
                out += errors(props[k], v, root, f"{where}.{k}")
            elif schema.get("additionalProperties") is False:
                out.append(f"{where}: '{k}' is not allowed")
            elif isinstance(schema.get("additionalProperties"), dict):
                out += errors(schema["additionalProperties"], v, root, f"{where}.{k}")
    return out
