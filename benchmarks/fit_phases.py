"""Where the CPU of one `vecpin fit URDF CSV` goes, phase by phase (issue 43).

Runs the command in this process (the ``vecpin`` on PYTHONPATH) with a CPU clock
(``time.process_time``) around the parts of the fit: the imports, each model kind
linearised with every candidate basis (``Design.__init__``), the common-basis stage
(``Search.common``: one family on every axis at rising orders, scored in nested chains;
again after the noise level is taken from the data), the refinement axis by axis
(``Search.refine``), the other kinds screened at the first kind's bases
(``stage.screen_kind``), the effective terms of penalised splines that the one-standard-error
rule counts, the gross rows and the noise level, the fit of the chosen
model (``ErrorModel.fit``) and the model file (``ErrorModel.save``); the rest (reading,
checks, the reports, the choice's bookkeeping) is the whole less these. A phase run inside
another (the effective terms inside the refinement) counts for the outer one. Prints one JSON
object {phase: [CPU s, calls]}; ``bench_fit_speed.py`` runs it in fresh processes and
takes medians.

Run: python benchmarks/fit_phases.py URDF CSV OUT.json
"""
import time

START = time.process_time()   # the interpreter's own start-up before this line

import contextlib  # noqa: E402 (after the clock: the imports below are measured)
import functools  # noqa: E402
import io  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402

import vecpin.cli.fitting  # noqa: E402,F401
import vecpin.workflows.fitting  # noqa: E402,F401
from vecpin.cli.main import main  # noqa: E402
from vecpin.identification.crossval import FoldedProblem  # noqa: E402
from vecpin.models.base import ErrorModel  # noqa: E402
from vecpin.selection import choice, design, search, stage  # noqa: E402

IMPORTS = time.process_time() - START
PHASES = {"linearising each kind (every candidate basis)": (design.Design, "__init__"),
          "common-basis stage (nested chains)": (search.Search, "common"),
          "refinement axis by axis": (search.Search, "refine"),
          "other kinds screened at the first kind's bases": (stage, "screen_kind"),
          "effective terms of penalised splines (one-SE rule)": (FoldedProblem, "effective_terms_blocks"),
          "gross rows": (choice, "_screened"),
          "noise level from the data": (choice, "_noise_level"),
          "fit of the chosen model (Gauss-Newton)": (ErrorModel, "fit"),
          "model file written": (ErrorModel, "save")}
spent = {name: [0.0, 0] for name in PHASES}
inside: list[str] = []   # the phases under way: a phase inside another counts for the outer one only


def timed(name: str, fn):
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        if inside:
            return fn(*args, **kwargs)
        inside.append(name)
        t = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            spent[name][0] += time.process_time() - t
            spent[name][1] += 1
            inside.pop()
    return wrapper


def run(urdf: str, csv: str, out: str) -> dict:
    for name, (owner, attr) in PHASES.items():
        setattr(owner, attr, timed(name, getattr(owner, attr)))
    sys.argv = ["vecpin", "fit", urdf, csv, "--out", out, "--quiet"]
    t = time.process_time()
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            main()
        except SystemExit as exc:
            if exc.code:
                raise
    whole = time.process_time() - t
    result = {"imports (vecpin fit's modules)": [IMPORTS, 1]} | spent
    result["the rest (reading, checks, reports, bookkeeping)"] = [whole - sum(s for s, _ in spent.values()), 1]
    result["whole process (less the interpreter's start-up)"] = [IMPORTS + whole, 1]
    return result


if __name__ == "__main__":
    print(json.dumps(run(*sys.argv[1:4])))
