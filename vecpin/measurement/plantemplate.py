"""The campaign template of a measurement plan: the campaign format with empty x, y, z.

One row per planned measurement, in measurement order, with the columns of a campaign
file (:mod:`vecpin.measurement.campaign`):

* ``point``: the point number (1, 2, ...; the NC programs call it P0001, P0002, ...);
* one column per axis (mm or degrees), ``tool`` (mm from the gauge line);
* ``x``, ``y``, ``z``: empty, to be filled from the tracker (a filled template reads
  as a campaign);
* optional ``approach_<AXIS>``: +1 when the axis reaches the point from below, -1 from
  above, 0 straight from the previous point.

:func:`read_template` checks a template the way :func:`read_campaign` checks a
campaign: every problem names the file, row (line, header = 1) and column.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.kinematics.machine import Machine
from vecpin.units import M_PER_MM, to_mm


@dataclass
class PlanTemplate:
    """Planned rows (SI): ``point`` (N,) int, ``q`` (N,n) [m, rad] in the machine's chain
    order, ``tool`` (N,) [m], ``approach`` (N,n) signs or None."""

    point: np.ndarray
    q: np.ndarray
    tool: np.ndarray
    approach: np.ndarray | None = None
    source: str = "<plan>"

    def __len__(self) -> int:
        return len(self.point)

    def to_csv(self, machine: Machine) -> str:
        """The template CSV text (mm, deg; 6 decimals in mm, 8 in deg, as campaign files)."""
        q_user = machine.to_user(self.q)
        header = ["point"] + machine.axis_names + ["tool", "x", "y", "z"]
        if self.approach is not None:
            header += [f"approach_{a}" for a in machine.axis_names]
        lines = [",".join(header)]
        fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes]
        tool_mm = to_mm(self.tool)
        for i in range(len(self)):
            cells = [str(int(self.point[i]))] + [f % v for f, v in zip(fmts, q_user[i])] + [f"{tool_mm[i]:.6f}", "", "", ""]
            if self.approach is not None:
                cells += [str(int(s)) for s in self.approach[i]]
            lines.append(",".join(cells))
        return "\n".join(lines) + "\n"


def point_name(point: int) -> str:
    """The name of a planned point in NC programs and tracker jobs: P0001, P0002, ..."""
    return f"P{int(point):04d}"


def read_template(path: str | Path, machine: Machine) -> PlanTemplate:
    """Read a plan's campaign template (x, y, z may be empty or filled; they are ignored)."""
    path = Path(path)
    name = str(path)
    if not path.is_file():
        raise CampaignFileError(name, "no such plan file (the campaign template written by 'vecpin plan')")
    try:
        text = path.read_text(encoding="utf-8-sig")
    except UnicodeDecodeError as exc:
        raise CampaignFileError(name, f"not a UTF-8 text file ({exc.reason} at byte {exc.start})") from None
    rows = [r for r in csv.reader(text.splitlines())]
    rows = [(i + 1, r) for i, r in enumerate(rows) if any(c.strip() for c in r)]
    if not rows:
        raise CampaignFileError(name, "the plan file is empty")
    header = [h.strip() for h in rows[0][1]]
    for col in ["point"] + machine.axis_names + ["tool"]:
        if col not in header:
            what = "point number" if col == "point" else ("tool length [mm]" if col == "tool" else
                                                          f"axis of machine '{machine.name}'")
            raise CampaignFileError(name, f"missing column ({what}); is this a plan template for "
                                    f"{machine.name}?", row=1, column=col)
    body = rows[1:]
    if not body:
        raise CampaignFileError(name, "the plan has a header but no rows")
    idx = {h: j for j, h in enumerate(header)}
    app_cols = [f"approach_{a}" for a in machine.axis_names]
    has_app = all(c in idx for c in app_cols)
    cols = ["point"] + machine.axis_names + ["tool"] + (app_cols if has_app else [])
    vals = np.empty((len(body), len(cols)))
    for k, (line, cells) in enumerate(body):
        if len(cells) != len(header):
            raise CampaignFileError(name, f"{len(cells)} cells where the header has {len(header)}", row=line)
        for j, c in enumerate(cols):
            s = cells[idx[c]].strip()
            try:
                v = float(s)
            except ValueError:
                raise CampaignFileError(name, f"'{s}' is not a number" if s else "empty cell", row=line, column=c) from None
            if not math.isfinite(v):
                raise CampaignFileError(name, f"'{s}' is not a finite number", row=line, column=c)
            vals[k, j] = v
    lines = np.array([ln for ln, _ in body])
    point = vals[:, 0]
    bad = np.flatnonzero((point != np.round(point)) | (point < 1))
    if bad.size:
        raise CampaignFileError(name, f"point number {point[bad[0]]:g} is not a whole number >= 1",
                                row=int(lines[bad[0]]), column="point")
    _, first, counts = np.unique(point, return_index=True, return_counts=True)
    if np.any(counts > 1):
        dup = point[first[np.argmax(counts > 1)]]
        rows_dup = lines[point == dup]
        raise CampaignFileError(name, f"point {dup:g} appears on rows {', '.join(map(str, rows_dup))}; point numbers "
                                "must be unique", row=int(rows_dup[1]), column="point")
    n = machine.n_axes
    q_user = vals[:, 1:1 + n]
    for j, a in enumerate(machine.axes):
        tol = 1e-6 * (a.upper_user - a.lower_user)
        out = np.flatnonzero((q_user[:, j] < a.lower_user - tol) | (q_user[:, j] > a.upper_user + tol))
        if out.size:
            raise CampaignFileError(name, f"command {q_user[out[0], j]:g} {a.unit} is outside the axis limits "
                                    f"[{a.lower_user:g}, {a.upper_user:g}] {a.unit}", row=int(lines[out[0]]), column=a.name)
    tool = vals[:, 1 + n]
    bad = np.flatnonzero(tool < 0)
    if bad.size:
        raise CampaignFileError(name, f"negative tool length {tool[bad[0]]:g} mm", row=int(lines[bad[0]]), column="tool")
    approach = vals[:, 2 + n:].astype(int) if has_app else None
    return PlanTemplate(point.astype(int), machine.to_si(q_user), tool * M_PER_MM, approach, name)
