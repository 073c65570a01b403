"""One meaning per option name across the commands: an option several commands share is
the same kind of value everywhere (a count, a file, a model kind, an axis), and its
``dest`` is the library's Python name. Read from the parser itself."""
import argparse

from vecpin.cli.main import build_parser


def options() -> dict[str, list[tuple[str, argparse.Action]]]:
    """--flag -> [(command, action), ...] over every command."""
    sub = next(a for a in build_parser()._actions if isinstance(a, argparse._SubParsersAction))
    out: dict[str, list] = {}
    for name, parser in sub.choices.items():
        for action in parser._actions:
            for flag in action.option_strings:
                if flag.startswith("--"):
                    out.setdefault(flag, []).append((name, action))
    return out


def test_points_and_validation_count_are_counts_of_commands():
    opts = options()
    for flag, dest in (("--points", "n_commands"), ("--validation-count", "n_validation")):
        assert {c for c, _ in opts[flag]} == {"plan", "simulate"}, flag
        assert all(a.type is int and a.dest == dest for _, a in opts[flag]), flag
    assert [(c, a.type, a.dest) for c, a in opts["--table-points"]] == [("tables", int, "points")]


def test_validation_is_a_campaign_file_and_model_a_kind():
    opts = options()
    assert {c for c, _ in opts["--validation"]} == {"orders", "report"}
    assert all(a.type is None and a.nargs is None for _, a in opts["--validation"])
    assert {c for c, _ in opts["--model"]} == {"plan", "fit", "diagnose"}
    assert all(a.nargs is None and {"auto", "6dof", "ap"} <= set(a.choices) for _, a in opts["--model"])
    assert [(c, a.dest, a.nargs) for c, a in opts["--models"]] == [("orders", "kinds", "+")]
    assert [c for c, _ in opts["--model-file"]] == ["verify"]


def test_sign_test_is_an_axis_and_sign_test_file_its_json():
    opts = options()
    assert [(c, a.metavar) for c, a in opts["--sign-test"]] == [("tables", "AXIS|TABLE")]
    assert [(c, a.dest, a.metavar) for c, a in opts["--sign-test-file"]] == [("evaluate", "test_path", "JSON")]


def test_shared_options_take_the_same_kind_of_value():
    """Beyond those: every option two commands share has one type and one nargs (choices
    may differ: --method, --basis list what each command offers)."""
    known = {"--order": {"demo"}, "--tools": {"tables"}}   # demo: a whole order only; tables: floats, no commas
    for flag, uses in options().items():
        kinds = {(a.type, a.nargs if a.nargs not in ("+", "*") else "many") for c, a in uses if c not in known.get(flag, ())}
        assert len(kinds) <= 1, (flag, [(c, a.type, a.nargs) for c, a in uses])
