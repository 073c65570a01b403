"""A measured campaign of an unseen machine, written as vecpin's campaign CSV (mm, deg, s, degC).

Commands are drawn uniformly within every axis' travel; every command is measured with each tool
(one block per tool, a tool change between blocks); on a table machine the tracker also reads
3-4 nests on the table at every command of the first block (``instrument`` = nest, ``target`` = id).
Every campaign carries ``time`` and ``temperature`` (the air: a drift of 1..3 K over the campaign
plus a smooth random history of 0.3..1.5 K RMS), whether or not the machine responds to it. The
tracker stands 1.5..5 m off the work volume, its frame a random rigid transform of the machine base
(z within 3 deg of up). Readings get the axes' repeatability (linear 1..3 um, rotary 5..15 urad)
and tracker noise in spherical coordinates: range 5..10 um + 1 um/m, azimuth and elevation
2..5 urad each.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from .fields import gp_1d
from .kinematics import table_points, tool_points
from .layouts import Layout, to_urdf
from .truth import AxisField, Effect


@dataclass
class Rows:
    """The campaign's rows in measurement order (arrays of the same length)."""

    cmd: np.ndarray          # index of the command
    nest: np.ndarray         # -1 on a tool row, else the nest id
    tool_m: np.ndarray       # tool length, m
    visit: np.ndarray        # the machine's visit (a move to the command) the row belongs to
    time: np.ndarray         # s


@dataclass
class Campaign:
    """An unseen machine, its truth and one measured campaign of it (SI inside)."""

    seed: int
    layout: Layout
    fields: dict[str, AxisField]
    effect: Effect | None
    q: dict[str, np.ndarray]                 # commands (n_cmd,), m / rad
    rows: Rows
    tools_m: list[float]
    nests_m: np.ndarray                      # (k, 3) nest positions in 'workpiece', m
    tracker: np.ndarray                      # 4x4 pose of the tracker frame in the base frame
    noise: dict
    temperature: np.ndarray                  # air reading per row, degC
    delta_t: np.ndarray                      # the machine's lagged temperature change per row, K
    measured: np.ndarray = field(default=None)   # (n_rows, 3) tracker frame, m
    gross_rows: list[int] = field(default_factory=list)

    # -- the truth --------------------------------------------------------------------------------
    def row_commands(self, q_rows: np.ndarray | None = None) -> dict[str, np.ndarray]:
        idx = self.rows.cmd if q_rows is None else q_rows
        return {k: v[idx] for k, v in self.q.items()}

    def errors(self, with_effect: bool = True) -> dict[str, list]:
        out = {name: [f] for name, f in self.fields.items()}
        if with_effect and self.effect is not None:
            for name, terms in self.effect.terms.items():
                out[name] = out[name] + terms
        return out

    def base_points(self, with_effect: bool = True, repeat: bool = True) -> np.ndarray:
        """(n_rows, 3) true measured points in the machine base frame, m (no tracker noise)."""
        q = self.row_commands()
        qa = {k: v.copy() for k, v in q.items()}
        if repeat:
            for k in qa:
                qa[k] += self.noise["v"][k][self.rows.visit]
        eff = self.effect if with_effect else None
        tool = self.rows.tool_m.copy()
        scale = None
        if eff is not None and eff.family == "backlash":
            ax = eff.axes[0]
            qa[ax] -= 0.5 * eff.amplitude * self.noise["direction"][self.rows.visit]
        if eff is not None and eff.family == "thermal":
            qa, tool, scale = self._thermal(qa, tool)
        kw = dict(errors=self.errors(with_effect), q_actual=qa, origin_scale=scale)
        pts = tool_points(self.layout, q, tool, **kw)
        is_nest = self.rows.nest >= 0
        if is_nest.any():
            local = self.nests_m[np.clip(self.rows.nest, 0, None)]
            pts[is_nest] = table_points(self.layout, q, local, **kw)[is_nest]
        return pts

    def _thermal(self, qa, tool):
        p, a = self.effect.params, self.effect.amplitude
        phi = self.delta_t + p["nonlinearity_per_K"] * self.delta_t ** 2
        gains = p["gains_ppm_per_K"]
        if self.layout.kind == "arm":
            scale = {name: 1.0 + a * g * 1e-6 * phi for name, g in gains.items()}
            scale["flange"] = 1.0 + a * np.mean(list(gains.values())) * 1e-6 * phi
            return qa, tool, scale
        for j in self.layout.linear():
            qa[j.name] = qa[j.name] * (1.0 + a * gains[j.name] * 1e-6 * phi)
        tool = tool + a * p["spindle_um_per_K"] * 1e-6 * phi * (self.rows.nest < 0)
        return qa, tool, None

    def to_tracker(self, pts: np.ndarray) -> np.ndarray:
        r, o = self.tracker[:3, :3], self.tracker[:3, 3]
        return (pts - o) @ r

    def shifted(self, trk: np.ndarray) -> np.ndarray:
        """Tracker-frame points after the tracker was knocked (rows at or after the step time)."""
        p, a = self.effect.params, self.effect.amplitude
        after = self.rows.time >= p["at_fraction"] * self.rows.time[-1]
        rot = Rotation.from_rotvec(a * 1e-5 * p["rot_weight"] * p["rot_axis"]).as_matrix()
        move = a * 1e-5 * (1.0 - p["rot_weight"]) * p["direction"]
        out = trk.copy()
        out[after] = trk[after] @ rot.T + move
        return out

    def step_row(self) -> int:
        return int(np.argmax(self.rows.time >= self.effect.params["at_fraction"] * self.rows.time[-1]))

    # -- files ------------------------------------------------------------------------------------
    def csv_text(self, measured: np.ndarray | None = None, rows: Rows | None = None,
                 q: dict[str, np.ndarray] | None = None) -> str:
        """The campaign CSV (commands mm/deg, tool mm, x y z mm in the tracker frame, time s, degC)."""
        rows = rows or self.rows
        measured = self.measured if measured is None else measured
        q = q if q is not None else self.row_commands()
        axes = self.layout.axes
        table = bool(self.layout.table_chain)
        head = [j.name for j in axes] + ["tool", "x", "y", "z", "time", "temperature"]
        head += ["instrument", "target"] if table else []
        lines = [",".join(head)]
        temp = self.temperature if rows is self.rows else np.full(len(rows.cmd), 20.0)
        for i in range(len(rows.cmd)):
            cells = [f"{q[j.name][i] * 1e3:.6f}" if j.kind == "prismatic" else f"{np.degrees(q[j.name][i]):.8f}"
                     for j in axes]
            cells += [f"{rows.tool_m[i] * 1e3:.6f}"] + [f"{v * 1e3:.6f}" for v in measured[i]]
            cells += [f"{rows.time[i]:.3f}", f"{temp[i]:.4f}"]
            if table:
                cells += ["nest", str(int(rows.nest[i]) + 1)] if rows.nest[i] >= 0 else ["tracker", ""]
            lines.append(",".join(cells))
        return "\n".join(lines) + "\n"

    def truth_record(self) -> dict:
        """What the campaign holds, for the scorer: JSON-able, mm / deg / s. ``tracker_noise`` is the
        spherical noise as range mm, range ppm, transverse mm, transverse ppm (= angle urad)."""
        eff = self.effect
        rec = {"seed": self.seed, "kind": self.layout.kind, "axes": [j.name for j in self.layout.axes],
               "rows": int(len(self.rows.cmd)), "commands": int(len(next(iter(self.q.values())))),
               "tools_mm": [t * 1e3 for t in self.tools_m], "nests": int(len(self.nests_m)),
               "family": None if eff is None else eff.family,
               "vecpin_name": None if eff is None else eff.vecpin_name,
               "effect_axes": [] if eff is None else eff.axes,
               "size_mm": None if eff is None else eff.size_mm,
               "gross_lines": [r + 2 for r in self.gross_rows],
               "tracker_range_m": [float(v) for v in self.noise["range_span_m"]],
               "tracker_noise": [self.noise["range_m"] * 1e3, 1.0, 0.0, self.noise["angle_rad"] * 1e6],
               "repeatability_mm": max([self.noise["sigma"][j.name] * 1e3 for j in self.layout.linear()], default=0.0),
               "repeatability_deg": max([np.degrees(self.noise["sigma"][j.name]) for j in self.layout.rotary()],
                                        default=0.0)}
        if eff is not None:
            rec["params"] = {k: (v.tolist() if isinstance(v, np.ndarray) else v)
                             for k, v in eff.params.items() if not k.startswith("_")}
            if eff.family == "shift":
                rec["step_line"] = self.step_row() + 2
        return rec

    def write(self, folder: Path) -> dict[str, Path]:
        """machine.urdf, campaign.csv and truth.json in ``folder``."""
        folder.mkdir(parents=True, exist_ok=True)
        paths = {"urdf": folder / "machine.urdf", "csv": folder / "campaign.csv", "truth": folder / "truth.json"}
        paths["urdf"].write_text(to_urdf(self.layout))
        paths["csv"].write_text(self.csv_text())
        paths["truth"].write_text(json.dumps(self.truth_record(), indent=1, default=float))
        return paths


def commands(rng, layout: Layout, n: int) -> dict[str, np.ndarray]:
    return {j.name: rng.uniform(j.lower, j.upper, n) for j in layout.axes}


def measurement_rows(rng, n_cmd: int, tools: list[float], n_nests: int) -> Rows:
    cmd, nest, tool, visit, time = [], [], [], [], []
    t, v = 0.0, 0
    for b, length in enumerate(tools):
        t += 300.0 if b else 0.0
        for c in range(n_cmd):
            t += rng.uniform(8.0, 25.0)
            cmd.append(c), nest.append(-1), tool.append(length), visit.append(v), time.append(t)
            for k in range(n_nests if b == 0 else 0):
                t += 5.0
                cmd.append(c), nest.append(k), tool.append(length), visit.append(v), time.append(t)
            v += 1
    return Rows(np.array(cmd), np.array(nest), np.array(tool), np.array(visit), np.array(time))


def temperatures(rng, time: np.ndarray, lag_h: float | None) -> tuple[np.ndarray, np.ndarray]:
    """Air reading per row (degC) and the machine's lagged change since the start (K)."""
    end = time[-1] + 1.0
    air = gp_1d(rng, 0.0, end, rng.uniform(0.3, 1.5), rng.uniform(0.1, 0.5))
    base = 20.0 + rng.uniform(-2.0, 3.0)
    drift = rng.choice([-1.0, 1.0]) * rng.uniform(1.0, 3.0) / end       # a workshop's morning: 1..3 K
    grid = np.linspace(0.0, end, 2000)
    amb = base + air(grid) + drift * grid
    machine = np.empty_like(amb)
    machine[0] = amb[0]
    tau = 3600.0 * (lag_h or 1.0)
    dt = grid[1] - grid[0]
    for i in range(1, len(grid)):
        machine[i] = machine[i - 1] + (amb[i] - machine[i - 1]) * (1.0 - np.exp(-dt / tau))
    reading = np.interp(time, grid, amb) + rng.normal(0.0, 0.01, len(time))
    return reading, np.interp(time, grid, machine) - machine[0]


def tracker_pose(rng, centre: np.ndarray, arm: bool) -> np.ndarray:
    dist = rng.uniform(1.5, 3.0) if arm else rng.uniform(2.0, 5.0)
    az = rng.uniform(0, 2 * np.pi)
    pos = centre + np.array([dist * np.cos(az), dist * np.sin(az), rng.uniform(-0.5, 0.5)])
    tilt = Rotation.from_rotvec(np.append(rng.normal(size=2), 0.0) / np.sqrt(2) * np.radians(rng.uniform(0, 3)))
    rot = tilt * Rotation.from_euler("z", rng.uniform(0, 2 * np.pi))
    t = np.eye(4)
    t[:3, :3], t[:3, 3] = rot.as_matrix(), pos
    return t


def spherical_noise(rng, trk: np.ndarray, noise: dict) -> np.ndarray:
    r = np.linalg.norm(trk, axis=1)
    az = np.arctan2(trk[:, 1], trk[:, 0])
    el = np.arcsin(trk[:, 2] / r)
    r = r + rng.normal(size=len(r)) * (noise["range_m"] + 1e-6 * r)
    az = az + rng.normal(size=len(r)) * noise["angle_rad"]
    el = el + rng.normal(size=len(r)) * noise["angle_rad"]
    return np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1)
