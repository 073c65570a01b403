"""The library/command-line boundary (issue 23), over every module of vecpin: no command-line flag in the library's text, one noise option
group with one default (the tracker's spherical model) for plan, fit, orders and
diagnose, the library's own default the same, errors naming the Python parameter and the
command line turning it into its flag, command modules that only parse, call a workflow
and print, and no function over 80 lines."""
import ast
import re
from pathlib import Path

import numpy as np
import pytest

from vecpin.cli import main
from vecpin.cli.common import noise
from vecpin.cli.main import build_parser
from vecpin.errors import InputError
from vecpin.measurement.campaign import write_campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.workflows.fitting import fit_campaign

ROOT = Path(__file__).resolve().parents[1] / "vecpin"
LIBRARY = sorted(p for p in ROOT.rglob("*.py") if "cli" not in p.relative_to(ROOT).parts)   # all but cli/
COMMANDS = sorted((ROOT / "cli").glob("*.py"))
NOISE_FLAGS = ("--cartesian", "--multilateration", "--ballbar-sigma-mm", "--repeatability-mm", "--repeatability-deg",
               "--tracker-sigma-mm", "--tracker-noise")
EXTERNAL = ("halcompile --install",)   # another program's command line the LinuxCNC README quotes


def _subparsers():
    p = build_parser()
    return next(a for a in p._actions if a.dest == "command").choices  # argparse: no public accessor


@pytest.mark.parametrize("path", LIBRARY, ids=lambda p: str(p.relative_to(ROOT)))
def test_library_text_names_no_flag(path):
    lines = [(k, line) for k, line in enumerate(path.read_text().splitlines(), 1)
             if re.search(r"--[a-z]", line) and not any(e in line for e in EXTERNAL)]
    assert not lines, f"{path.name}: " + "; ".join(f"line {k}: {t.strip()}" for k, t in lines)


@pytest.mark.parametrize("path", LIBRARY + COMMANDS, ids=lambda p: str(p.relative_to(ROOT)))
def test_no_function_over_80_lines(path):
    long = [(n.name, n.end_lineno - n.lineno + 1) for n in ast.walk(ast.parse(path.read_text()))
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)) and n.end_lineno - n.lineno + 1 > 80]
    assert not long, f"{path.name}: {long}"


def test_command_modules_reach_the_computation_only_through_workflows():
    """fit, orders, diagnose, tables, verify, report: cli/ parses, calls a workflow, prints;
    the model choice, the diagnosis, the identification and the table planning are the
    workflows' business."""
    below = ("vecpin.selection", "vecpin.diagnosis", "vecpin.identification", "vecpin.compensation", "vecpin.viz.report")
    for path in COMMANDS:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module:
                assert not node.module.startswith(below), f"{path.name} imports {node.module}"


def test_one_noise_group_with_the_spherical_default(flow):
    """The same noise options, defaults and help for plan, fit, orders and diagnose (plan
    without the range-only and ball bar options its planner has no rows for); no options
    give the library's default noise model, the tracker's native spherical one."""
    sub = _subparsers()
    helps = {}
    for name in ("plan", "fit", "orders", "diagnose"):
        acts = {a.option_strings[0]: a for a in sub[name]._actions if a.option_strings}
        want = NOISE_FLAGS if name != "plan" else tuple(f for f in NOISE_FLAGS if f not in ("--multilateration",
                                                                                           "--ballbar-sigma-mm"))
        assert set(want) <= set(acts), name
        helps[name] = {f: (acts[f].help, acts[f].default) for f in want}
    assert all(helps[n][f] == helps["fit"][f] for n in helps for f in helps[n])
    argv = {"plan": ["plan", "flow_xyzcb", "--out", "x"], "fit": ["fit", "flow_xyzcb", "c.csv", "--out", "m.json"],
            "orders": ["orders", "flow_xyzcb", "c.csv"], "diagnose": ["diagnose", "flow_xyzcb", "c.csv", "--out", "d"]}
    default = NoiseModel.default(flow)
    assert default.instrument == "spherical"
    for name, a in argv.items():
        nm = noise(build_parser().parse_args(a), flow)
        assert nm.instrument == "spherical", name
        np.testing.assert_array_equal(nm.axis_sigma, default.axis_sigma)
        assert nm.tracker == default.tracker
    assert noise(build_parser().parse_args(argv["fit"] + ["--cartesian"]), flow).instrument == "cartesian"


def test_the_library_fits_with_the_spherical_model_by_default(flow):
    sim = simulate(flow, 1, design=Design(n_commands=60, n_validation=5))
    model = make_model("6dof", flow, 1).fit(sim.campaign)
    assert model.noise_.instrument == "spherical"


def test_errors_name_the_parameter_and_the_command_line_its_flag(flow, tmp_path, capsys):
    sim = simulate(flow, 1, design=Design(n_commands=60, n_validation=5))
    with pytest.raises(InputError, match=r"^`prior_scale` -1\.0: the prior scale"):
        fit_campaign(flow, sim.campaign, NoiseModel.default(flow), kind="6dof", basis="chebyshev", order=1,
                     prior_scale=-1.0)
    with pytest.raises(InputError, match=r"`tracker_noise` 1 1 -1 0: four numbers"):
        from vecpin.measurement.noise import noise_from_options
        noise_from_options(flow, tracker_noise=(1, 1, -1, 0))
    write_campaign(tmp_path / "c.csv", sim.campaign, flow)
    assert main(["fit", "flow_xyzcb", str(tmp_path / "c.csv"), "--out", str(tmp_path / "m.json"), "--prior-scale",
                 "-1", "--model", "6dof", "--basis", "chebyshev", "--order", "1"]) == 2
    err = capsys.readouterr().err
    assert "--prior-scale -1.0: the prior scale" in err and "`" not in err
    assert main(["orders", "flow_xyzcb", str(tmp_path / "c.csv"), "--repeatability-mm", "0"]) == 2
    assert "--repeatability-mm 0.0: a standard deviation" in capsys.readouterr().err
