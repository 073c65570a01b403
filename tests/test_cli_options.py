"""The one table from library parameter names to command-line flags."""

import pytest

from vecpin.cli.main import build_parser, main
from vecpin.cli.options import ALIASES, as_flags, flag_table


def _commands():
    p = build_parser()
    sub = next(a for a in p._actions if a.dest == "command")
    return sub.choices


def test_a_backquoted_parameter_becomes_the_commands_flag():
    plan = flag_table(_commands()["plan"])
    assert as_flags("`safe_z_mm` 12: outside the travel", plan) == "--safe-z 12: outside the travel"
    assert as_flags("`not_an_option` stays a word", plan) == "not_an_option stays a word"
    assert as_flags("no names here -- none", plan) == "no names here -- none"


def test_every_alias_names_an_option_of_some_command():
    dests = set()
    for command in _commands().values():
        dests |= set(flag_table(command))
    assert set(ALIASES.values()) <= dests


def test_errors_and_warnings_print_flags(capsys, tmp_path):
    rc = main(["plan", "snk_120v", "--safe-z", "1e9", "--out", str(tmp_path / "p")])
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("vecpin: error: --safe-z 1e+09: ")


def test_two_parameters_one_option_sets_are_written_as_that_option():
    plan = flag_table(_commands()["plan"])
    text = "`repeat_points` 5000, `repeat_times` 50: too many"
    assert as_flags(text, plan) == "--repeat 5000 50: too many"
    assert as_flags(text, {}) == "repeat_points 5000, repeat_times 50: too many"


def test_an_option_given_twice_is_refused_not_overwritten(tmp_path, capsys):
    """Issue 42: `--zone X=0:3000 --zone Y=0:1200` kept Y's zone alone without a word. A
    single-valued option given twice (in full or abbreviated) is refused before anything
    runs, naming it; options meant to repeat (--nest-height) still repeat."""
    from vecpin.cli.main import main, repeated_option
    assert main(["fit", "flow_xyzcb", str(tmp_path / "c.csv"), "--zone", "X=0:3000", "--zone", "Y=0:1200",
                 "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert "--zone is given twice" in err and "X=0:3000,Y=0:1200" in err and not (tmp_path / "m.json").exists()
    assert main(["fit", "flow_xyzcb", "c.csv", "--quiet", "--qui", "--out", "m.json"]) == 2
    assert "--quiet is given twice" in capsys.readouterr().err
    once = ("--zone", "--out", "--quiet", "--nest-heights")
    argv = ["--nest-height", "1=2", "--nest-height", "2=3", "--zone", "X=0:1"]   # not --nest-heights abbreviated
    assert repeated_option(argv, once, once + ("--nest-height",)) is None
    assert repeated_option(argv + ["--nest-heights", "h.csv", "--nest-heights", "g.csv"], once) == "--nest-heights"
    assert repeated_option(["--out=a", "--out", "b"], once) == "--out"
    assert repeated_option(["--zone", "X=0:1", "--", "--zone"], once) is None


def test_the_plan_names_the_fits_option_for_the_nest_heights_file():
    """The plan's library text names the fit's `nest_heights` parameter; on plan's command line (whose
    --no-nest-heights marks it) that becomes the fit's flag, not a plan flag or a bare setting name."""
    from vecpin.cli.options import as_flags
    text = "write it in nest_heights.csv; give that file to the fit (`nest_heights`): it then finds the face"
    out = as_flags(text, {"no_nest_heights": "--no-nest-heights"})
    assert "give that file to the fit (vecpin fit --nest-heights FILE): it then" in out
    assert as_flags(text, {}) == text.replace("`", "")


def test_a_nest_height_that_is_not_a_number_is_refused_naming_its_own_option():
    """`--nest-height 3=abc` is refused by that option, before any fit, not by the file option's name."""
    from vecpin.cli.fitting import nest_heights
    from vecpin.errors import InputError
    with pytest.raises(InputError, match=r"`--nest-height` '3=abc': 'abc' is not a height"):
        nest_heights(["1=19.05", "3=abc"])
    assert nest_heights(["1=19.05", " 2 = 20 "]) == {"1": 19.05, "2": 20.0}
