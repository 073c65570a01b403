"""The command line: ``vecpin --version``, and help text on every argument of every command
(each module of ``vecpin.cli.main.COMMAND_MODULES``) that states its default and its unit.

The rules checked on every action except -h:
* a non-empty help;
* an option with a default states it, and the value stated is the parser's default
  (``%(default)s`` or the same number written out);
* an optional option without a default says what happens without it ("default: ...");
* a name or metavar carrying a unit (mm, deg, s, min, ppm) has that unit in the help as a
  word, and every float option names a unit or says it is dimensionless;
* every command's help formats (a stray ``%`` would crash ``vecpin CMD --help``).
"""
import argparse
import math
import re
import subprocess
import sys

import pytest

from vecpin.cli.main import COMMAND_MODULES, build_parser

UNIT_WORDS = {"mm": r"\bmm\b", "deg": r"\bdeg\b", "s": r"\bs\b", "min": r"\bmin\b", "ppm": r"\bppm\b"}
FLOAT_UNITS = re.compile(r"\bmm\b|\bdeg\b|\bs\b|\bmin\b|\bppm\b|°C|\bdimensionless\b")


def _commands():
    """(module, command, parser) for every command every CLI module registers."""
    out = []
    for module in COMMAND_MODULES:
        sub = argparse.ArgumentParser().add_subparsers()
        module.add_commands(sub)
        out += [(module.__name__.rsplit(".", 1)[1], name, p) for name, p in sub.choices.items()]
    return out


COMMANDS = _commands()
IDS = [f"{m}:{c}" for m, c, _ in COMMANDS]


def _actions(parser):
    return [a for a in parser._actions if not isinstance(a, argparse._HelpAction)]


def _help(parser, a) -> str:
    """The help as --help prints it (``%(default)s`` etc. expanded)."""
    return parser._get_formatter()._expand_help(a) if a.help else ""


def _name(a) -> str:
    return "/".join(a.option_strings) or a.dest


def test_every_command_module_is_walked():
    names = [c for _, c, _ in COMMANDS]
    top = [a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction)][0].choices
    assert sorted(names) == sorted(top) and len(names) >= 14
    for must in ("info", "plan", "simulate", "import", "fit", "evaluate", "orders", "demo", "tables", "diagnose",
                 "assess", "verify", "view", "report"):
        assert must in names


@pytest.mark.parametrize("module, command, parser", COMMANDS, ids=IDS)
def test_every_argument_has_help(module, command, parser):
    missing = [_name(a) for a in _actions(parser) if not (a.help and a.help.strip())]
    assert not missing, f"vecpin {command}: no help text for {missing}"
    parser.format_help()  # formats (no stray %)


def _stated(value) -> list[tuple[str, ...]]:
    """How a default may be written, per value: 5 -> ('5',); 5.0 -> ('5', '5.0'); 0.01;
    'all'; a list -> each element."""
    if isinstance(value, (list, tuple)):
        return [x for v in value for x in _stated(v)]
    if isinstance(value, float):
        return [(f"{value:g}", repr(value))]
    return [(str(value),)]


def _says(text: str, value: str) -> bool:
    return re.search(rf"(?<![\w.]){re.escape(value)}(?![\w]|\.\d)", text) is not None


@pytest.mark.parametrize("module, command, parser", COMMANDS, ids=IDS)
def test_every_option_states_its_default(module, command, parser):
    bad = []
    for a in _actions(parser):
        if not a.option_strings or isinstance(a, (argparse._VersionAction, argparse._StoreTrueAction)) \
                or a.default is argparse.SUPPRESS or a.required:
            continue
        text = _help(parser, a)
        m = re.search(r"\bdefault\b(.*)", text, re.I | re.S)
        if not m:
            bad.append(f"{_name(a)}: says no default")
            continue
        if a.default not in (None, [], ()):
            after, before = m.group(1), text[:m.start()]
            for forms in _stated(a.default):
                # "(default 5)", "(default: 6dof ap)", or a choice's description ending "... (default)"
                if not any(_says(after, v) or (_says(before, v) and re.match(r"\)", after)) for v in forms):
                    bad.append(f"{_name(a)}: default {a.default!r} not stated in: {text[:120]}")
    assert not bad, f"vecpin {command}:\n" + "\n".join(bad)


def _unit_tokens(a) -> set[str]:
    words = re.split(r"[-_]", a.dest.lower())
    mv = a.metavar if isinstance(a.metavar, tuple) else (a.metavar,) if a.metavar else ()
    for m in mv:
        words += re.split(r"[-_,\[\]]", m.lower())
    return {w for w in words if w in UNIT_WORDS}


@pytest.mark.parametrize("module, command, parser", COMMANDS, ids=IDS)
def test_units_are_named(module, command, parser):
    bad = []
    for a in _actions(parser):
        text = _help(parser, a)
        for unit in _unit_tokens(a):
            if not re.search(UNIT_WORDS[unit], text):
                bad.append(f"{_name(a)}: name says {unit}, the help does not")
        if a.type is float and not FLOAT_UNITS.search(text):
            bad.append(f"{_name(a)}: a number without a unit (or 'dimensionless')")
    assert not bad, f"vecpin {command}:\n" + "\n".join(bad)


def test_the_rules_catch_what_the_reviewer_found():
    """The checks above fail on the kinds of omissions the review listed."""
    p = argparse.ArgumentParser()
    p.add_argument("csv")
    p.add_argument("--folds", type=int, default=5, help="folds (default 4)")
    p.add_argument("--prior-scale", type=float, default=1.0, help="multiply every prior sigma")
    p.add_argument("--dwell-s", type=float, default=4.0, help="dwell at every point (default 4)")
    acts = {a.dest: a for a in _actions(p)}
    assert not acts["csv"].help
    folds = _help(p, acts["folds"])
    assert not _says(folds.split("default", 1)[1], "5") and _says(folds.split("default", 1)[1], "4")
    assert "default" not in _help(p, acts["prior_scale"]) and not FLOAT_UNITS.search(_help(p, acts["prior_scale"]))
    assert _unit_tokens(acts["dwell_s"]) == {"s"} and not re.search(UNIT_WORDS["s"], _help(p, acts["dwell_s"]))


def test_noise_defaults_are_the_noise_models():
    """The defaults the noise options print are those NoiseModel.default uses."""
    from vecpin.cli.common import noise_defaults
    from vecpin.kinematics.machine import Machine
    from vecpin.measurement.noise import NoiseModel
    m = Machine.load("flow_xyzcb")
    nm = NoiseModel.default(m, "spherical")
    d = noise_defaults()
    lin = [s for s, a in zip(nm.axis_sigma, m.axes) if a.kind == "linear"][0]
    rot = [s for s, a in zip(nm.axis_sigma, m.axes) if a.kind == "rotary"][0]
    assert float(d["repeatability_mm"]) == pytest.approx(lin * 1e3)
    assert float(d["repeatability_deg"]) == pytest.approx(math.degrees(rot))
    assert float(d["tracker_sigma_mm"]) == pytest.approx(nm.cartesian_sigma * 1e3)
    assert float(d["ballbar_sigma_mm"]) == pytest.approx(nm.ballbar_sigma * 1e3)
    t = nm.tracker
    assert [float(x) for x in d["tracker_noise"].split()] == pytest.approx(
        [t.range_const * 1e3, t.range_ppm * 1e6, t.transverse_const * 1e3, t.transverse_ppm * 1e6])


def test_version(capsys):
    from importlib.metadata import version
    with pytest.raises(SystemExit) as e:
        build_parser().parse_args(["--version"])
    assert e.value.code == 0
    assert capsys.readouterr().out.strip() == f"vecpin {version('vecpin')}"
    out = subprocess.run([sys.executable, "-m", "vecpin", "--version"], capture_output=True, text=True)
    assert out.returncode == 0 and out.stdout.startswith("vecpin ")


def test_units_are_named_in_the_plan_help():
    plan = [p for _, c, p in COMMANDS if c == "plan"][0]
    text = plan.format_help()
    for needle in ("mm (default", "deg (default", "mm/min", "s (default 4)", "mm/deg"):
        assert needle in text
