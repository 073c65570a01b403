"""The session file: every choice of the engineer's day in one JSON file, so that the day
re-runs headless (``vecpin run``) and the workbench reopens it (issue 45).

A session is the machine, the user's tolerance, the options set once for the whole day
(``machine_options``: each given to every stage whose command has it, unless the stage sets
its own) and, per stage of the day, the options of the command that stage runs, named as
that command's long options (``points``, ``tracker``, ``exclude``; a value ``true`` switches
an option on, a list repeats it or gives its several values). The stages, in the order of the day (docs/whole-day.md)::

    plan -> import -> assess -> fit -> evaluate -> diagnose -> tables
         -> import_before -> import_after -> verify

(``import_before`` and ``import_after``: the two validation runs' tracker exports, without
and with the tables, joined to the plan's validation run as ``import`` joins the campaign.)

Each stage writes its results under fixed names in the output folder (:data:`OUTPUTS`),
and the next stage reads them from there. The files a user brings (the tracker export, the
filled controller profile, the two validation runs, a URDF) are the stage's input fields
(:data:`INPUT_FIELDS`), relative to the session file's folder or absolute.

After the day, :func:`write_record` writes the compensation record (``record.md`` and
``record.json``): what was measured, fitted, written and verified, with the software's
versions, under the headings of ISO/TR 16907:2015 clauses 11 (validation of the numerical
compensation) and 12 (documentation on compensation).

Units: lengths in mm, angles in degrees, as the commands take them.
"""
from __future__ import annotations

import hashlib
import json
import platform
from dataclasses import dataclass, field
from pathlib import Path

from vecpin.errors import InputError
from vecpin.fileio import write_text

FORMAT = "vecpin-session"
VERSION = 1
SESSION_FILE = "session.json"   # the workbench's session in its folder
STAGES = ("plan", "import", "assess", "fit", "evaluate", "diagnose", "tables", "import_before", "import_after",
          "verify")
#: what each stage writes in the output folder (a folder or a file), which later stages read
OUTPUTS = {"plan": "plan", "import": "campaign.csv", "assess": "assess.json", "fit": "model.json",
           "evaluate": "evaluate.json", "diagnose": "diagnose", "tables": "tables",
           "import_before": "validation_before.csv", "import_after": "validation_after.csv", "verify": "verify"}
#: the stage fields that name a file the user brings (not an option of the command but its input)
INPUT_FIELDS = {"import": ("export",), "tables": ("profile",), "import_before": ("export",),
                "import_after": ("export",), "verify": ("before", "after")}
#: input fields the stage cannot run without (verify: each run given, or imported by its stage)
REQUIRED_FIELDS = {"import": ("export",), "import_before": ("export",), "import_after": ("export",)}
#: the stages the day cannot leave out when a later stage is there (what it reads)
NEEDS = {"import": ("plan",), "assess": ("import",), "fit": ("import",), "evaluate": ("fit",), "diagnose": ("fit",),
         "tables": ("fit",), "import_before": ("plan",), "import_after": ("plan",), "verify": ("tables",)}
RECORD_MD, RECORD_JSON = "record.md", "record.json"

_VALUE = (str, int, float, bool, type(None))


@dataclass
class Session:
    """The day's choices: ``machine`` (a bundled name or a URDF path), ``tolerance_mm`` (the
    volumetric error the user accepts after compensation, mm; None: not stated) and
    ``stages``: stage name -> {field: value}. ``path``: the file it was read from (inputs
    with a relative path are relative to its folder)."""
    machine: str
    tolerance_mm: float | None = None
    stages: dict[str, dict] = field(default_factory=dict)
    path: Path | None = None
    machine_options: dict = field(default_factory=dict)   # set once: every stage whose command has the option

    def to_dict(self) -> dict:
        d = {"format": FORMAT, "version": VERSION, "machine": self.machine, "tolerance_mm": self.tolerance_mm}
        if self.machine_options:
            d["machine_options"] = dict(self.machine_options)
        return d | {"stages": {s: self.stages[s] for s in STAGES if s in self.stages}}

    def to_json(self) -> str:
        return json.dumps(self.to_dict(), indent=1) + "\n"

    @property
    def folder(self) -> Path:
        return Path(self.path).parent if self.path else Path.cwd()

    def input_path(self, value: str) -> str:
        """An input file as the commands get it: absolute, a relative one taken from the
        session file's folder (so that the session runs the same from any folder)."""
        p = Path(value).expanduser()
        return str(p if p.is_absolute() else (self.folder / p).resolve())

    def machine_argument(self) -> str:
        """The machine as the commands get it: a bundled name as written, a URDF path absolute."""
        looks_like_path = self.machine.endswith(".urdf") or "/" in self.machine
        return self.input_path(self.machine) if looks_like_path else self.machine


def session_error(where: str, field_name: str, text: str) -> InputError:
    """The one form of a bad session field: the file, the field (dotted), what is wrong."""
    return InputError(f"{where}, field {field_name}: {text}")


def check_inputs(session: Session, where: str, stages: list[str]) -> None:
    """What the day cannot start without, refused before any of ``stages`` runs, naming its
    session field: the machine (a bundled name, or a URDF file that exists) and the files the
    user brings to those stages (:data:`INPUT_FIELDS`)."""
    from vecpin.kinematics.axes import bundled_machines
    arg = session.machine_argument()
    if arg == session.machine and arg not in bundled_machines():
        raise session_error(where, "machine", f"{arg!r}: not a bundled machine ({', '.join(bundled_machines())}); a "
                            "URDF is named by its path (ending in .urdf)")
    if arg != session.machine and not Path(arg).is_file():
        raise session_error(where, "machine", f"{session.machine!r}: no such URDF file ({arg})")
    for stage in stages:
        for name in INPUT_FIELDS.get(stage, ()):
            value = session.stages.get(stage, {}).get(name)
            if isinstance(value, str) and value and not Path(session.input_path(value)).is_file():
                raise session_error(where, f"stages.{stage}.{name}",
                                    f"{value!r}: no such file ({session.input_path(value)})")


def load_session(path: str | Path) -> Session:
    """Read and check a session file (structure and value types; what each option means is
    checked by the command the stage runs). Bad input raises :class:`InputError` naming
    the file and the field."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")   # an editor's byte-order mark is no reason to refuse
    except OSError as exc:
        raise InputError(f"session file {path}: cannot be read ({exc.strerror or exc})") from None
    except UnicodeDecodeError as exc:
        raise InputError(f"session file {path}: not UTF-8 text (byte {exc.start}: {exc.reason}); save it as "
                         "UTF-8") from None
    try:
        d = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(f"session file {path}: not JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from None
    return session_from_dict(d, str(path), path)


def session_from_dict(d, where: str, path: Path | None = None) -> Session:
    """A :class:`Session` from its parsed JSON ``d``; ``where`` names it in messages."""
    if not isinstance(d, dict):
        raise InputError(f"{where}: a session is a JSON object with format {FORMAT!r}")
    if d.get("format") != FORMAT:
        raise session_error(where, "format", f"{d.get('format')!r}: a session file has format {FORMAT!r}")
    if d.get("version") != VERSION or isinstance(d.get("version"), bool):
        raise session_error(where, "version", f"{d.get('version')!r}: this vecpin reads version {VERSION}")
    unknown = sorted(set(d) - {"format", "version", "machine", "tolerance_mm", "machine_options", "stages", "comment"})
    if unknown:
        raise session_error(where, unknown[0], "not a field of a session (fields: format, version, machine, "
                            "tolerance_mm, machine_options, stages, comment)")
    machine = d.get("machine")
    if not isinstance(machine, str) or not machine.strip():
        raise session_error(where, "machine", f"{machine!r}: a bundled machine name or a URDF path")
    tol = d.get("tolerance_mm")
    if tol is not None and (isinstance(tol, bool) or not isinstance(tol, (int, float)) or not 0 < tol < float("inf")):
        raise session_error(where, "tolerance_mm", f"{tol!r}: a length in mm > 0, or null (not stated)")
    shared = d.get("machine_options") or {}
    if not isinstance(shared, dict):
        raise session_error(where, "machine_options", "an object: option -> value, given to every stage whose "
                            "command has the option")
    _check_values(where, "machine_options", shared)
    stages = d.get("stages", {})
    if not isinstance(stages, dict):
        raise session_error(where, "stages", "an object: stage name -> its fields")
    for name, fields in stages.items():
        _check_stage(where, name, fields)
    for name in stages:
        missing = [n for n in NEEDS.get(name, ()) if n not in stages]
        if missing:
            raise session_error(where, f"stages.{name}", f"needs the stage {missing[0]} before it (it reads "
                                f"{OUTPUTS[missing[0]]}); add it to the session")
    for side in ("before", "after"):
        if "verify" in stages and not stages["verify"].get(side) and f"import_{side}" not in stages:
            raise session_error(where, f"stages.verify.{side}", f"missing: the validation run {side} the tables "
                                f"(a campaign CSV), or the stage import_{side} that imports its tracker export")
    return Session(machine=machine.strip(), tolerance_mm=None if tol is None else float(tol),
                   stages={s: dict(stages[s]) for s in STAGES if s in stages}, path=path, machine_options=dict(shared))


def _check_stage(where: str, name: str, fields) -> None:
    if name not in STAGES:
        raise session_error(where, f"stages.{name}", f"not a stage of the day (stages: {', '.join(STAGES)})")
    if not isinstance(fields, dict):
        raise session_error(where, f"stages.{name}", "an object: field -> value ({} for the defaults)")
    _check_values(where, f"stages.{name}", fields)
    for key in INPUT_FIELDS.get(name, ()):
        if key in fields and fields[key] is not None and (not isinstance(fields[key], str) or not fields[key]):
            raise session_error(where, f"stages.{name}.{key}", f"{fields[key]!r}: a file path")
    for key in REQUIRED_FIELDS.get(name, ()):
        if not fields.get(key):
            raise session_error(where, f"stages.{name}.{key}", "missing: the file this stage reads")


def _check_values(where: str, prefix: str, fields: dict) -> None:
    for key, value in fields.items():
        ok = isinstance(value, _VALUE) or (isinstance(value, list) and all(isinstance(v, _VALUE[:3]) for v in value))
        if not ok:
            raise session_error(where, f"{prefix}.{key}", f"{value!r}: a text, a number, true/false, null or a "
                                "list of texts and numbers")


def save_session(session: Session, path: str | Path) -> Path:
    """Write ``session`` as JSON (atomically); returns the path."""
    path = Path(path)
    write_text(path, session.to_json())
    session.path = path
    return path


def sha256(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


def versions() -> dict[str, str]:
    """The software the day ran on: vecpin, Python and the numerical libraries."""
    from importlib.metadata import PackageNotFoundError, version
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name in ("vecpin", "pin", "numpy", "scipy"):
        try:
            out[name] = version(name)
        except PackageNotFoundError:
            out[name] = "not installed"
    return out
