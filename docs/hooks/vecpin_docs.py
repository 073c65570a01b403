"""MkDocs hook: pages that cannot drift from the code or the benchmarks.

A page's Markdown may hold these markers, replaced when the site is built:

* ``<!-- vecpin:cli -->``: every ``vecpin`` command's ``--help``, from the CLI's own parser;
* ``<!-- vecpin:controller-results NAME -->``: the rows of ``docs/results/controller_files.md``
  (written by ``benchmarks/bench_controller_files.py``) for the controller ``NAME``;
* ``<!-- vecpin:controller-facts NAME -->``: the controller format's own record in the code
  (``vecpin.export.registry.FORMATS``: files, sign, source, what to check);
* ``<!-- vecpin:results-list -->``: every page under ``docs/results/`` with its first line.
"""
from __future__ import annotations

import argparse
import io
import re
from contextlib import redirect_stdout
from pathlib import Path

DOCS = Path(__file__).resolve().parents[1]
RESULTS = DOCS / "results"
CONTROLLER_FILES = RESULTS / "controller_files.md"


def cli_reference() -> str:
    """Markdown: one section per ``vecpin`` command, its help as argparse prints it."""
    from vecpin.cli.main import build_parser
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    parts = ["```text\n" + _help(parser) + "```\n"]
    for name, command in sub.choices.items():
        parts.append(f"## vecpin {name}\n\n```text\n{_help(command)}```\n")
    return "\n".join(parts)


def _help(parser: argparse.ArgumentParser) -> str:
    """The help text at a fixed width, so the page does not depend on the terminal."""
    out = io.StringIO()
    parser.formatter_class = lambda prog: argparse.HelpFormatter(prog, width=100)
    with redirect_stdout(out):
        parser.print_help()
    return out.getvalue()


def controller_rows(controller: str, path: Path = CONTROLLER_FILES) -> str:
    """The results file's lead sentence and its table restricted to one controller
    (the column ``controller`` dropped), as Markdown; every figure as the benchmark wrote it."""
    lines = path.read_text(encoding="utf-8").splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.startswith("|"))
    cells = [c.strip() for c in lines[head].strip("|").split("|")]
    k = cells.index("controller")
    keep = lambda row: row[:k] + row[k + 1:]  # noqa: E731 - one column out
    table = ["| " + " | ".join(keep(cells)) + " |", "|" + "---|" * (len(cells) - 1)]
    for ln in lines[head + 2:]:
        row = [c.strip() for c in ln.strip().strip("|").split("|")]
        if ln.startswith("|") and row[k] == controller:
            table.append("| " + " | ".join(keep(row)) + " |")
    if len(table) == 2:
        raise ValueError(f"{path.name} has no row for the controller '{controller}'")
    lead = " ".join(lines[:head]).strip()
    return lead + "\n\n" + "\n".join(table) + "\n"


def controller_facts(controller: str) -> str:
    """The registered format's files, sign, source and what to check, as a Markdown list."""
    from vecpin.export.registry import get_format
    f = get_format(controller)
    return (f"The format's record in the code (`{controller}`: {f.title}):\n\n"
            f"* files: {f.files}\n* sign: {f.sign}\n* source: {f.source}\n* to check: {f.to_check}\n")


def results_list() -> str:
    """A bullet per results page: its link and its first line."""
    items = []
    for p in sorted(RESULTS.glob("*.md")):
        if p.name == "index.md":
            continue
        first = next((ln for ln in p.read_text(encoding="utf-8").splitlines() if ln.strip()), "")
        items.append(f"* [{p.stem}]({p.name}): {first.lstrip('# ').split('. ')[0]}")
    return "\n".join(items) + "\n"


def on_page_markdown(markdown: str, page, config, files) -> str:
    """Replace the markers of this page (see the module docstring)."""
    markdown = markdown.replace("<!-- vecpin:cli -->", cli_reference() if "<!-- vecpin:cli -->" in markdown else "")
    markdown = re.sub(r"<!-- vecpin:controller-results ([\w-]+) -->", lambda m: controller_rows(m.group(1)), markdown)
    markdown = re.sub(r"<!-- vecpin:controller-facts ([\w-]+) -->", lambda m: controller_facts(m.group(1)), markdown)
    if "<!-- vecpin:results-list -->" in markdown:
        markdown = markdown.replace("<!-- vecpin:results-list -->", results_list())
    return markdown
