"""The one table from library parameter names to command-line flags."""

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
