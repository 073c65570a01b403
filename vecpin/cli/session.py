"""``vecpin run SESSION``: the day from a session file (the workbench writes one).

A stage of a session is one command line: :func:`stage_argv` writes it from the stage's
fields (each the command's long option without its dashes), and ``run`` hands it to the
same parser and command function as typing it would (:func:`vecpin.cli.main.main`), in the
output folder. So the files ``vecpin run`` writes are the files of the commands run one by
one there, and its messages are theirs.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import os
import re
import sys

from vecpin.errors import InputError
from vecpin.workflows.session import (INPUT_FIELDS, OUTPUTS, STAGES, Session, check_inputs, load_session,
                                     session_error)

#: the command each stage runs
COMMAND = {"plan": "plan", "import": "import", "assess": "assess", "fit": "fit", "evaluate": "evaluate",
           "diagnose": "diagnose", "tables": "tables", "import_before": "import", "import_after": "import",
           "verify": "verify"}
#: options the session sets itself from the output folder (a stage field cannot give them)
MANAGED = {"plan": ("out",), "import": ("machine", "plan", "out"), "assess": ("machine", "json"), "fit": ("out",),
           "evaluate": ("json",), "diagnose": ("base", "out"), "tables": ("out",),
           "import_before": ("machine", "plan", "out"), "import_after": ("machine", "plan", "out"),
           "verify": ("machine", "model-file", "tables", "out")}
#: options that name a file the user brings: a relative path is taken from the session file's folder, as the
#: input fields are (the stages run in the output folder)
PATH_OPTIONS = {"plan": ("compare",), "fit": ("targets", "nest-heights"), "evaluate": ("sign-test-file",),
                "tables": ("thermal",)}


def _head(session: Session, stage: str, f: dict) -> list[str]:
    """The command, its positional arguments and the options the session sets (paths in the
    output folder, inputs absolute)."""
    m, o = session.machine_argument(), OUTPUTS
    inp = lambda key: session.input_path(f[key])
    run = lambda side: inp(side) if f.get(side) else o[f"import_{side}"]   # a validation run: given, or imported
    heads = {
        "plan": lambda: ["plan", m, "--out", o["plan"]],
        "import": lambda: ["import", inp("export"), "--machine", m, "--plan", f"{o['plan']}/plan.csv", "--out",
                           o["import"]],
        "assess": lambda: ["assess", o["import"], "--machine", m, "--json", o["assess"]],
        "fit": lambda: ["fit", m, o["import"], "--out", o["fit"]],
        "evaluate": lambda: ["evaluate", o["fit"], o["import"], "--json", o["evaluate"]],
        "diagnose": lambda: ["diagnose", m, o["import"], "--base", o["fit"], "--out", o["diagnose"]],
        "tables": lambda: ["tables", o["fit"], "--out", o["tables"]] + (["--profile", inp("profile")]
                                                                        if f.get("profile") else []),
        "import_before": lambda: ["import", inp("export"), "--machine", m, "--plan", f"{o['plan']}/validation.csv",
                                  "--out", o["import_before"]],
        "import_after": lambda: ["import", inp("export"), "--machine", m, "--plan", f"{o['plan']}/validation.csv",
                                 "--out", o["import_after"]],
        "verify": lambda: ["verify", run("before"), run("after"), "--model-file", o["fit"], "--tables", o["tables"],
                           "--out", o["verify"]],
    }
    return heads[stage]()


def _subparser(parser: argparse.ArgumentParser, command: str) -> argparse.ArgumentParser:
    sub = next(a for a in parser._actions if a.dest == "command")  # argparse: no public accessor
    return sub.choices[command]


def stage_argv(session: Session, stage: str, parser: argparse.ArgumentParser) -> list[str]:
    """The command line of ``stage`` (without the leading ``vecpin``), run in the output
    folder; ``parser``: vecpin's (:func:`vecpin.cli.main.build_parser`). The session's
    ``machine_options`` the command has come first, the stage's own fields win. A field that is not
    an option of the command, or a value of the wrong shape, raises :class:`InputError`
    naming the session file and the field."""
    where = str(session.path or "session")
    f = session.stages[stage]
    command = COMMAND[stage]
    actions = {o[2:]: a for a in _subparser(parser, command)._actions for o in a.option_strings
               if o.startswith("--")}
    argv = _head(session, stage, f)
    shared = _shared(session, parser, where)
    f = {k: v for k, v in shared.items() if k in actions and k not in MANAGED[stage] and k not in f} | f
    own = session.stages[stage]
    for key, value in f.items():
        name = f"stages.{stage}.{key}" if key in own else f"machine_options.{key}"
        if key in INPUT_FIELDS.get(stage, ()):
            continue
        if key in MANAGED[stage]:
            raise session_error(where, name, "set by the session itself (the stages' files in the output folder, "
                                "the session's machine): leave it out")
        if key not in actions or key == "help":
            known = ", ".join(sorted(k for k in actions if k != "help" and k not in MANAGED[stage]))
            raise session_error(where, name, f"not an option of vecpin {command} (its options: {known})")
        if key in PATH_OPTIONS.get(stage, ()):
            value = _paths(session, value)
        words = _option(where, name, "--" + key, actions[key], value)
        bad = [w for w in words if w.startswith("--") and w != "--" + key]
        if bad:
            raise session_error(where, name, f"{bad[0]!r}: a value, not an option (each option is a field of its own)")
        argv += words
    _check_values(where, stage, argv, parser, set(shared) - set(own))
    return argv


def _shared(session: Session, parser: argparse.ArgumentParser, where: str) -> dict:
    """The session's ``machine_options``, each an option of some stage's command (else refused)."""
    for key in session.machine_options:
        if not any(key in {o[2:] for a in _subparser(parser, c)._actions for o in a.option_strings} - {"help"}
                   - set(MANAGED[s]) for s, c in COMMAND.items()):
            raise session_error(where, f"machine_options.{key}", "not an option of any stage's command (set once "
                                "for the day, it goes to every stage whose command has it)")
    return session.machine_options


def _option(where: str, name: str, flag: str, action: argparse.Action, value) -> list[str]:
    """One field as command-line words: true/false for a switch, a list for a repeatable
    option or one of several values."""
    switch = action.nargs == 0
    if switch:
        if not isinstance(value, bool) and value is not None:
            raise session_error(where, name, f"{value!r}: true or false (a switch)")
        return [flag] if value else []
    if value is None:
        return []
    if isinstance(value, bool):
        raise session_error(where, name, f"{value!r}: this option takes a value, not true or false")
    several = action.nargs in ("+", "*") or (isinstance(action.nargs, int) and action.nargs > 1)
    if isinstance(value, list):
        if isinstance(action, argparse._AppendAction):
            return [w for v in value for w in (flag, _word(v))]
        if several:
            return [flag, *(_word(v) for v in value)]
        raise session_error(where, name, f"{value!r}: one value, not a list")
    if isinstance(action, argparse._AppendAction):
        return [flag, _word(value)]
    return [flag, *(_word(value).split() if several else [_word(value)])]


def _paths(session: Session, value):
    """A path option's value(s) with relative paths taken from the session file's folder
    (``random``, plan's own word for a random design, kept)."""
    one = lambda v: session.input_path(v) if isinstance(v, str) and v and v != "random" else v
    return [one(v) for v in value] if isinstance(value, list) else one(value)


def _word(v) -> str:
    return repr(v) if isinstance(v, float) else str(v)


def _check_values(where: str, stage: str, argv: list[str], parser: argparse.ArgumentParser,
                  shared: set = frozenset()) -> None:
    """The command's own parser over the stage's words: its complaint (a type, a choice, a
    count) comes back naming the session's field instead of the flag."""
    err = io.StringIO()
    try:
        with contextlib.redirect_stderr(err):
            parser.parse_args(argv)
    except SystemExit:
        last = err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else "invalid"
        text = last.split("error: ", 1)[-1]
        m = re.search(r"argument --([a-z0-9-]+)", text)
        field_name = (f"machine_options.{m.group(1)}" if m and m.group(1) in shared else
                      f"stages.{stage}.{m.group(1)}" if m else f"stages.{stage}")
        text = re.sub(r"argument --[a-z0-9-]+(/-\w)?: ", "", text)
        raise session_error(where, field_name, text) from None


def session_commands(session: Session, parser: argparse.ArgumentParser) -> dict[str, list[str]]:
    """stage -> its command line (without ``vecpin``), every stage of the session checked."""
    return {s: stage_argv(session, s, parser) for s in STAGES if s in session.stages}


def run_session(args) -> int:
    from vecpin.cli.common import say
    from vecpin.fileio import check_output_dir
    from vecpin.workflows.record import write_record
    session = load_session(args.session)
    commands = session_commands(session, args.parser_factory())
    if args.stages:
        unknown = [s for s in args.stages.split(",") if s not in commands]
        if unknown:
            raise InputError(f"--stages: {unknown[0]!r} is not a stage of this session (its stages: "
                             f"{', '.join(commands)})")
    chosen = args.stages.split(",") if args.stages else list(commands)
    check_inputs(session, str(args.session), chosen)
    out = check_output_dir(args.out, "out")
    out.mkdir(parents=True, exist_ok=True)
    here = os.getcwd()
    try:
        os.chdir(out)
        for stage in chosen:
            print(f"vecpin run: {stage}: vecpin {' '.join(commands[stage])}", file=sys.stderr, flush=True)
            code = args.entry(commands[stage])
            if code:
                print(f"vecpin run: stopped at the stage {stage} of {args.session} (its message above)",
                      file=sys.stderr)
                return code
    finally:
        os.chdir(here)
    if not args.stages:
        say(args, *(f"wrote {p}" for p in write_record(session, out, commands)))
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("run", help="repeat a day headless from its session file (the workbench writes one; "
                       "docs/workbench.md): every stage's command in the output folder, then the compensation record")
    s.add_argument("session", help="session file (JSON, format vecpin-session)")
    s.add_argument("--out", required=True, help="output folder: each stage's files (plan/, campaign.csv, "
                   "assess.json, model.json, evaluate.json, diagnose/, tables/, verify/) and record.md, record.json")
    s.add_argument("--stages", metavar="STAGE,...", help="run only these stages, comma-separated, in the session's "
                   "order; no record then (default: all)")
    s.set_defaults(func=run_session)
