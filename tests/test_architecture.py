"""The package's import graph: layers import only downward, and no module imports
itself back through others (no cycles, function-local imports included)."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "vecpin"
# bottom to top; a module may import its own layer and the layers before it
LAYERS = [("errors", "units", "fileio", "threads"), ("kinematics",), ("measurement",), ("identification",), ("models",),
          ("selection",), ("planning",), ("fitting",), ("compensation",), ("export",), ("diagnosis",), ("simulation",),
          ("viz",), ("workflows",), ("cli",)]
LEVEL = {name: k for k, names in enumerate(LAYERS) for name in names}
FACADE = {"vecpin", "vecpin.__main__"}  # the public API may import any layer


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def imports_of(path: Path) -> set[str]:
    """Every vecpin module imported anywhere in the file (function bodies included)."""
    mod = module_name(path)
    package = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "vecpin"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "vecpin":
                continue
            subs = [target + "." + a.name for a in node.names if is_module(target + "." + a.name)]
            out |= set(subs)
            if len(subs) < len(node.names):  # names defined in the package or module itself
                out.add(target)
    out.discard(mod)
    return out


def is_module(name: str) -> bool:
    p = ROOT.parent / Path(*name.split("."))
    return p.with_suffix(".py").exists() or (p / "__init__.py").exists()


def layer(mod: str) -> str | None:
    parts = mod.split(".")
    return parts[1] if len(parts) > 1 else None


GRAPH = {module_name(p): imports_of(p) for p in ROOT.rglob("*.py")}


def test_every_subpackage_has_a_layer():
    missing = {layer(m) for m in GRAPH if m not in FACADE and layer(m) not in LEVEL}
    assert not missing, f"put these in LAYERS (tests/test_architecture.py) and ARCHITECTURE.md: {missing}"


@pytest.mark.parametrize("mod", sorted(m for m in GRAPH if m not in FACADE))
def test_imports_only_go_down(mod):
    up = [t for t in GRAPH[mod] if t not in FACADE and LEVEL[layer(t)] > LEVEL[layer(mod)]]
    assert not up, f"{mod} imports upward: {up}"


def test_no_import_cycles():
    """Tarjan-free check: depth-first search for a back edge among vecpin modules."""
    def resolve(t):  # a package import means its __init__
        return t if t in GRAPH else None
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m):
        state[m] = 1
        stack.append(m)
        for t in sorted(GRAPH[m]):
            t = resolve(t)
            if t is None or t in FACADE:
                continue
            if state.get(t) == 1:
                cycle = stack[stack.index(t):] + [t]
                raise AssertionError("import cycle: " + " -> ".join(cycle))
            if t not in state:
                visit(t)
        stack.pop()
        state[m] = 2
    for m in sorted(GRAPH):
        if m not in state and m not in FACADE:
            visit(m)


def test_the_checker_sees_an_upward_import(tmp_path):
    """The check itself can fail: a kinematics module importing the CLI is caught."""
    p = ROOT / "kinematics" / "machine.py"
    fake = imports_of(p) | {"vecpin.cli.main"}
    assert any(LEVEL[layer(t)] > LEVEL["kinematics"] for t in fake if t not in FACADE)


def test_no_module_is_too_long():
    long = {module_name(p): n for p in ROOT.rglob("*.py") if (n := len(p.read_text().splitlines())) > 520}
    assert not long, f"split these modules (one job each): {long}"


# ARCHITECTURE.md draws the layer graph as the imports make it: `python tests/test_architecture.py`
# prints the block, and the test below fails when the drawing and the code differ.
ARCHITECTURE = ROOT.parent / "ARCHITECTURE.md"
FOUNDATION = "foundation"


def layer_name(mod: str) -> str:
    """The layer of a module as ARCHITECTURE.md names it (the single modules are the foundation)."""
    name = layer(mod)
    return FOUNDATION if LEVEL[name] == 0 else name


def layer_edges() -> dict[str, set[str]]:
    """For every layer, the other layers its modules import (function bodies included)."""
    edges: dict[str, set[str]] = {}
    for mod, targets in GRAPH.items():
        if mod in FACADE:
            continue
        src = layer_name(mod)
        edges.setdefault(src, set())
        edges[src] |= {layer_name(t) for t in targets if t not in FACADE and layer_name(t) != src}
    return edges


def _order(name: str) -> int:
    return 0 if name == FOUNDATION else LEVEL[name]


def drawing() -> str:
    """The layer graph as ARCHITECTURE.md draws it: one line per layer, top layer first."""
    edges = layer_edges()
    width = max(len(n) for n in edges) + 1
    return "\n".join(f"{src:<{width}}-> " + (" ".join(sorted(edges[src], key=_order, reverse=True)) or "(nothing)")
                     for src in sorted(edges, key=_order, reverse=True))


def drawn_edges() -> dict[str, set[str]]:
    """The edges ARCHITECTURE.md draws, read from its block after the line `<!-- layer-graph -->`."""
    text = ARCHITECTURE.read_text(encoding="utf-8")
    block = text.split("<!-- layer-graph -->", 1)[1].split("```text\n", 1)[1].split("```", 1)[0]
    out = {}
    for line in block.strip().splitlines():
        src, _, dst = line.partition("->")
        out[src.strip()] = set(dst.split()) - {"(nothing)"}
    return out


def test_architecture_md_draws_the_real_layer_graph():
    drawn, real = drawn_edges(), layer_edges()
    assert drawn == real, ("ARCHITECTURE.md's layer graph differs from the imports; paste the output of "
                           f"`python tests/test_architecture.py`:\n{drawing()}")


def test_every_drawn_edge_goes_down():
    up = [(s, d) for s, ds in drawn_edges().items() for d in ds if _order(d) >= _order(s)]
    assert not up, f"ARCHITECTURE.md draws edges that are not allowed (upward or sideways): {up}"


if __name__ == "__main__":
    print(drawing())
