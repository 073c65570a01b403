"""Readers of an arm's programs for the tests, written from the vendors' references and
the joint list's columns, with no vecpin code (it imports none).

* URScript (Universal Robots, The URScript Programming Language, Script Manual):
  ``def name():`` ... ``end`` a function of indented statements; ``#`` starts a comment;
  ``movej(q, a=..., v=...)`` a move linear in joint space to the joint positions ``q``
  [rad]; ``sleep(t)`` waits ``t`` [s]; ``popup(msg, title=..., blocking=True)`` stops the
  program until the operator continues (here: where the target holder changes, its
  length in the message). vecpin writes each move with a comment naming its kind
  (approach, measure, retract, or via: a pose on the way between points) and the point.
* The joint list: a CSV, one row per pose, ``pose, kind, point, holder_mm, dwell_s`` (kind as in the program) and
  one ``<joint>_deg`` column per joint, in degrees.
"""
from __future__ import annotations

import csv
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

MOVEJ = re.compile(r"^\s*movej\(\[([^\]]*)\], a=([0-9.]+), v=([0-9.]+)\)\s+# (approach|measure|retract|via) (P\d+)$")
SLEEP = re.compile(r"^\s*sleep\(([0-9.]+)\)\s*$")
HOLDER = re.compile(r"^\s*popup\(\"mount the target holder of ([0-9.]+) mm")


@dataclass
class ArmRun:
    """What a URScript program does: ``moves`` (kind, point, q [rad], holder [m]) in order,
    ``sleeps`` [s] and the holder mounted at each ``popup``."""

    moves: list = field(default_factory=list)
    sleeps: list = field(default_factory=list)
    holders: list = field(default_factory=list)


def run_urscript(text: str) -> ArmRun:
    """Run a URScript program: every statement must be one this reader knows."""
    lines = text.splitlines()
    body = [ln for ln in lines if ln.strip() and not ln.lstrip().startswith("#")]
    assert re.match(r"^def \w+\(\):$", body[0]) and body[-1] == "end", (body[0], body[-1])
    out, holder = ArmRun(), None
    for ln in body[1:-1]:
        if m := MOVEJ.match(ln):
            assert holder is not None, f"a move before a holder is mounted: {ln!r}"
            q = np.array([float(v) for v in m.group(1).split(",")])
            out.moves.append((m.group(4), m.group(5), q, holder))
        elif m := SLEEP.match(ln):
            out.sleeps.append(float(m.group(1)))
        elif m := HOLDER.match(ln):
            holder = float(m.group(1)) / 1000.0
            out.holders.append(holder)
        else:
            raise AssertionError(f"a statement this reader does not know: {ln!r}")
    return out


def read_urscript(text: str) -> list[tuple[str, str, np.ndarray]]:
    """(kind, point, q [rad]) of every movej line, in order."""
    return [(k, p, q) for k, p, q, _ in run_urscript(text).moves]


def read_joint_list(path: Path) -> list[tuple[str, str, float, np.ndarray]]:
    """(kind, point, holder mm, q [deg]) of every row."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    joints = [k for k in rows[0] if k.endswith("_deg")]
    return [(r["kind"], r["point"], float(r["holder_mm"]), np.array([float(r[j]) for j in joints])) for r in rows]


def joint_names(path: Path) -> list[str]:
    """The joints of a joint list, in its column order."""
    with open(path, newline="") as f:
        return [k[:-4] for k in next(csv.reader(f)) if k.endswith("_deg")]
