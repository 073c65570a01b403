"""The library/CLI boundary of the planning, measurement-import and simulation side: every
parameter the library names (backquoted Python names; no flag text anywhere outside cli/,
tests/test_boundary.py) is one the plan, simulate, import and info commands turn into their flag."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from vecpin.cli.main import build_parser
from vecpin.cli.options import as_flags
from vecpin.cli.planning import parse_tools, plan_order
from vecpin.errors import InputError
from vecpin.planning.plan import make_plan
from vecpin.planning.problem import BASES, PlanSettings, planned_model

ROOT = Path(__file__).resolve().parents[1] / "vecpin"
LIBRARY = sorted({*ROOT.glob("planning/*.py"), *ROOT.glob("simulation/*.py"), *ROOT.glob("kinematics/*.py"),
                  *(p for p in ROOT.glob("measurement/*.py") if p.name not in ("noise.py", "robotaccuracy.py")),
                  ROOT / "fileio.py", ROOT / "workflows" / "planning.py", ROOT / "workflows" / "simulating.py",
                  ROOT / "workflows" / "importing.py"})


def _flags() -> dict[str, dict[str, str]]:
    """Every command's table: library name -> flag."""
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return {c: p.get_default("flags") for c, p in sub.choices.items()}


def test_every_parameter_the_library_names_is_an_option_of_a_command():
    """A backquoted name in a message is a parameter some command sets (plan, simulate,
    import and info, or evaluate for the registration's `reregister`): the CLI prints its flag."""
    flags = _flags()
    known = set().union(*flags.values())
    names = {m for p in LIBRARY for m in re.findall(r"(?<![`:])`([a-z][a-z0-9_]*)`(?!`)", p.read_text())}
    assert names, "the library files name no parameter at all"
    assert not names - known, f"named in the library but no command's option: {sorted(names - known)}"


@pytest.mark.parametrize("command, text, shown", [
    ("plan", "`n_commands` 0: plan at least one command", "--points 0: plan at least one command"),
    ("plan", "`tracker_mm`: outside", "--tracker: outside"),
    ("plan", "`repeat_points` 3, `repeat_times` 1", "--repeat 3, --repeat 1"),
    ("plan", "`safe_z_mm` 9: not inside", "--safe-z 9: not inside"),
    ("plan", "`retract` C", "--retract-axis C"),
    ("plan", "`out_dir` /x: no permission", "--out /x: no permission"),
    ("simulate", "`n_commands` 3", "--points 3"),
    ("simulate", "`exclude`: no room", "--exclude: no room"),
    ("simulate", "`tracker_position` 1,2", "--tracker 1,2"),
    ("import", "`export_format` ipa-robot-accuracy", "--format ipa-robot-accuracy"),
    ("import", "give `units` in", "give --units in"),
])
def test_the_cli_shows_the_library_names_as_its_flags(command, text, shown):
    assert as_flags(text, _flags()[command]) == shown


def test_tools_take_spaces_or_commas_in_plan_and_simulate():
    assert parse_tools(["214.88", "312.86"]) == parse_tools(["214.88,312.86"]) == (214.88, 312.86)
    with pytest.raises(InputError, match="--tools 'a'"):
        parse_tools(["a"])


def _choices(command: str, dest: str):
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    return next(a for a in sub.choices[command]._actions if a.dest == dest).choices


def test_basis_and_order_mean_in_plan_what_they_mean_in_fit():
    """One meaning per option name: plan takes the fit's bases and orders (auto: vecpin
    chooses; before any data a plan fixes them)."""
    assert list(_choices("plan", "basis")) == list(_choices("fit", "basis")) == list(BASES)
    assert plan_order("auto") == "auto" and plan_order("3") == 3
    with pytest.raises(InputError, match="--order 'x'"):
        plan_order("x")


def test_too_few_points_names_the_order_given_or_the_default(flow, tmp_path, capsys):
    """A plan with more unknowns than equations names the order the user gave, or says
    the order is the default auto (and which order that is) when none was given; the
    model kind and the number of commands likewise."""
    from vecpin.cli import main
    args = ["plan", "flow_xyzcb", "--points", "10", "--no-sight", "--out", str(tmp_path / "p")]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "--order auto (the default: order 6 before any data" in err and "--order 6" not in err, err
    assert "(--model auto, the default: ap for a machine without table axes)" in err and "--points 10 x 2" in err
    assert main(args + ["--order", "3", "--model", "ap"]) == 2
    err = capsys.readouterr().err
    assert "--order 3: the ap model of order 3 of flow_xyzcb has" in err and "auto" not in err, err
    with pytest.raises(InputError, match=r"^`order` 30: the ap model .* `n_commands` 100 \(the default\) x 1 holders"):
        make_plan(flow, PlanSettings(order=30, tools_mm=(200.0,), sight=False))


def test_a_plan_for_each_basis_is_the_model_the_fit_fixes(flow):
    """auto and fourier plan the same columns (per turn on the C axis, which travels more
    than a turn); pspline plans its spline's columns; each basis plans."""
    n = {b: planned_model(flow, PlanSettings(model="ap", order=3, basis=b)).n_parameters for b in BASES}
    assert n["auto"] == n["fourier"] == n["chebyshev"] and n["pspline"] == n["spline"] > n["chebyshev"]
    assert n["fourier_trend"] > n["fourier"]
    p = make_plan(flow, PlanSettings(n_commands=40, order=2, basis="fourier_trend", candidates=300, sight=False,
                                     n_validation=5, validation_points=50))
    assert p.information.model.n_parameters == planned_model(flow, p.settings).n_parameters
    with pytest.raises(InputError, match="`basis` 'legendre'"):
        PlanSettings(basis="legendre").check()


def test_the_python_names_page_matches_the_parsers_and_the_functions():
    """docs/plan-simulate-import-in-python.md: each row's flag is the command's flag for
    each Python name, and the name is a field or parameter of the object the row names."""
    import dataclasses
    import inspect

    from vecpin.simulation.simulate import Design, simulate
    from vecpin.simulation.truth import TrueMachine
    from vecpin.workflows.importing import import_to_file
    from vecpin.workflows.planning import plan_to_dir
    from vecpin.workflows.simulating import simulate_to_dir
    where = {"PlanSettings": {f.name for f in dataclasses.fields(PlanSettings)},
             "Design": {f.name for f in dataclasses.fields(Design)},
             "plan_to_dir": set(inspect.signature(plan_to_dir).parameters),
             "simulate_to_dir": set(inspect.signature(simulate_to_dir).parameters)  # and what it passes on
             | set(inspect.signature(simulate).parameters) | set(inspect.signature(TrueMachine.random).parameters),
             "import_to_file": set(inspect.signature(import_to_file).parameters)}
    page = (ROOT.parent / "docs" / "plan-simulate-import-in-python.md").read_text()
    rows = re.findall(r"^\| (plan|simulate|import) \| `(--[a-z-]+)[^|]*\| ([^|]+)\| `(\w+)`", page, re.M)
    assert len(rows) >= 20
    flags = _flags()
    for command, flag, names, obj in rows:
        for name in re.findall(r"`(\w+)`", names):
            assert flags[command].get(name) == flag, (command, flag, name)
            assert name in where[obj], (name, obj)
