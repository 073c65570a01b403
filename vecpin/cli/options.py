"""Library text to command-line text: a parameter the library names becomes the flag that sets it.

The library (everything outside ``cli/``) never writes a command-line flag. A message,
warning or piece of advice that names an option writes the Python parameter name in
backquotes, e.g. ``"`safe_z` 12: not inside the travel of Z"``, so a Python user reads
the keyword they passed. The command line turns each backquoted name into its flag
(``--safe-z 12: ...``) with :func:`as_flags`, from the one table there is: the parser's
own options (``dest`` -> flag of the command being run) plus :data:`ALIASES` for the few
library names that differ from the parser's ``dest``.
"""
from __future__ import annotations

import argparse
import re

#: library parameter name -> the parser's ``dest`` where they differ
ALIASES: dict[str, str] = {
    "mean_error_mm": "mean_error", "max_error_mm": "max_error", "long_term_mm": "long_term",   # assess
    "short_term_mm": "short_term",
    "tools_mm": "tools", "modulo_axes": "modulo",  # tables
    "out_dir": "out",            # a workflow's output folder (plan_to_dir, simulate_to_dir, ...): --out
    "repeat_points": "repeat",   # --repeat POINTS TIMES sets both
    "repeat_times": "repeat",
    "cv": "folds",               # the fit's cross-validation (the estimator's cv=): --folds
}

#: library phrases naming two parameters that one option sets together, or a parameter of the
#: next command: (phrase, the option's dest that marks the command, the phrase as the command
#: line writes it with {flag} for that option's flag)
PHRASES: list[tuple[re.Pattern, str, str]] = [
    (re.compile(r"`repeat_points` (\S+?), `repeat_times` (\S+?):"), "repeat", r"{flag} \1 \2:"),
    (re.compile(r"give that file to the fit \(`nest_heights`\)"), "no_nest_heights",
     "give that file to the fit (vecpin fit --nest-heights FILE)"),
    (re.compile(r"give that file to the fit \(`table_face`\)"), "no_nest_heights",
     "give that file to the fit (vecpin fit --table-face FILE)"),
]

_NAME = re.compile(r"`([a-z][a-z0-9_]*)`")


def flag_table(parser: argparse.ArgumentParser) -> dict[str, str]:
    """``dest`` -> the option's long flag (``--safe-z``) for one command's parser."""
    table: dict[str, str] = {}
    for action in parser._actions:  # argparse has no public accessor for its actions
        longs = [s for s in action.option_strings if s.startswith("--")]
        if longs and action.dest not in table:
            table[action.dest] = longs[0]
    for name, dest in ALIASES.items():
        if dest in table:
            table.setdefault(name, table[dest])
    return table


def as_flags(text: str, table: dict[str, str]) -> str:
    """``text`` with every backquoted parameter the command has replaced by its flag;
    a backquoted name the command does not have loses only its backquotes."""
    text = str(text)
    for pattern, dest, written in PHRASES:
        if dest in table:
            text = pattern.sub(written.format(flag=table[dest]), text)
    return _NAME.sub(lambda m: table.get(m.group(1), m.group(1)), text)
