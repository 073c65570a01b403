"""Draw one unseen campaign from a seed: layout, error fields, effect, tracker, noise, readings.

``draw_campaign(seed)`` is deterministic in the seed. A scaled effect is sized so that the RMS
of the tool-tip move it causes over the tool rows (the nest rows for an error of a table axis,
which does not move the tool) is its drawn size (mm; a thermal response is
capped at 4x its drawn gains, and its actual size is recorded). Gross errors are 0.3..1.2 mm.
"""
from __future__ import annotations

import numpy as np

from .campaign import Campaign, Rows, commands, measurement_rows, spherical_noise, temperatures, tracker_pose
from .kinematics import tool_points
from .layouts import Layout, draw_layout
from .truth import SCALED, applicable, draw_effect, draw_fields, unit_vector

CLEAN_SHARE = 0.25
NEEDS_KIND = {"skew": ("gantry",), "harmonic": ("head", "table", "head_table", "gantry"),
              "coupled": ("head", "table", "head_table", "gantry")}     # the layouts that can carry them


def choose_family(rng: np.random.Generator, layout: Layout, family: str | None = "random") -> str | None:
    """The campaign's effect family: ``random`` draws none with probability 1/4, else uniformly."""
    if family != "random":
        return family
    if rng.random() < CLEAN_SHARE:
        return None
    fams = applicable(layout)
    return str(fams[int(rng.integers(len(fams)))])


def _nests(rng, table: bool) -> np.ndarray:
    if not table:
        return np.zeros((0, 3))
    k = int(rng.integers(3, 5))
    ang = np.linspace(0, 2 * np.pi, k, endpoint=False) + rng.uniform(0, 2 * np.pi) + rng.uniform(-0.3, 0.3, k)
    rad = rng.uniform(0.08, 0.25, k)
    return np.stack([rad * np.cos(ang), rad * np.sin(ang), rng.uniform(0.02, 0.1, k)], axis=1)


def _noise(rng, layout: Layout, rows: Rows, q: dict[str, np.ndarray]) -> dict:
    n_visit = int(rows.visit.max()) + 1
    sigma = {j.name: rng.uniform(1e-6, 3e-6) if j.kind == "prismatic" else rng.uniform(5e-6, 15e-6)
             for j in layout.axes}
    v = {name: rng.normal(0.0, s, n_visit) for name, s in sigma.items()}
    return {"v": v, "sigma": sigma, "range_m": rng.uniform(5e-6, 10e-6), "angle_rad": rng.uniform(2e-6, 5e-6),
            "direction": np.ones(n_visit)}


def _directions(camp: Campaign, axis: str) -> np.ndarray:
    """Per visit, the sign of the last move of ``axis`` (+1 for the first visit and for no move)."""
    visit_cmd = np.zeros(int(camp.rows.visit.max()) + 1, dtype=int)
    visit_cmd[camp.rows.visit] = camp.rows.cmd
    pos = camp.q[axis][visit_cmd]
    d = np.sign(np.diff(pos, prepend=pos[0] - 1.0))
    for i in range(1, len(d)):
        d[i] = d[i] if d[i] != 0 else d[i - 1]
    return d


def _rms_mm(d: np.ndarray, tool_rows: np.ndarray) -> float:
    """RMS of the moves over the tool rows, mm; over the nest rows for a move only the table makes."""
    rms = float(np.sqrt(np.mean(np.sum(d[tool_rows] ** 2, axis=1)))) * 1e3
    if rms < 1e-9 and (~tool_rows).any():
        rms = float(np.sqrt(np.mean(np.sum(d[~tool_rows] ** 2, axis=1)))) * 1e3
    return rms


def _size(camp: Campaign) -> None:
    """Scale the effect's amplitude so its tool-tip RMS over the tool rows is its drawn size."""
    eff = camp.effect
    tool_rows = camp.rows.nest < 0
    eff.amplitude = 1e-5 if eff.family == "backlash" else 1.0
    eff.params["_box"][0] = eff.amplitude
    p0 = camp.base_points(with_effect=False, repeat=False)
    if eff.family == "shift":
        t0 = camp.to_tracker(p0)
        unit = _rms_mm(camp.shifted(t0) - t0, tool_rows)
    else:
        unit = _rms_mm(camp.base_points(with_effect=True, repeat=False) - p0, tool_rows)
    factor = eff.size_mm / unit if eff.size_mm > 0 else 0.0
    if eff.family == "thermal":
        factor = min(factor, 4.0)
        eff.size_mm = unit * factor
    eff.amplitude *= factor
    eff.params["_box"][0] = eff.amplitude


def _gross(rng, camp: Campaign, trk: np.ndarray) -> np.ndarray:
    tool_rows = np.flatnonzero(camp.rows.nest < 0)
    if camp.effect.family == "gross_isolated":
        rows = rng.choice(tool_rows, size=int(rng.integers(1, 4)), replace=False)
    else:
        n = int(rng.integers(3, 7))
        start = int(rng.integers(0, len(tool_rows) - n))
        rows = tool_rows[start:start + n]
    mags = rng.uniform(0.3e-3, 1.2e-3, len(rows))
    out = trk.copy()
    for r, m in zip(rows, mags):
        out[r] += m * unit_vector(rng)
    camp.gross_rows = sorted(int(r) for r in rows)
    camp.effect.params["magnitudes_mm"] = [float(m * 1e3) for m in mags]
    camp.effect.size_mm = float(mags.min() * 1e3)
    return out


def draw_campaign(seed: int, kind: str | None = None, family: str | None = "random",
                  n_commands: int | None = None, n_tools: int = 2, size_mm: float | None = None) -> Campaign:
    """One unseen machine and its measured campaign, deterministic in ``seed``.

    kind: a layout kind (None: drawn, among those that can carry the family); family: an effect
    family, None (clean) or ``random`` (none with probability 1/4, else one the layout can carry);
    size_mm: the scaled effect's size instead of the drawn one (every other draw unchanged, so 0 gives
    the same campaign without the effect: same machine, commands and noise).
    """
    rng = np.random.default_rng(seed)
    if kind is None and family in NEEDS_KIND:
        kind = str(rng.choice(NEEDS_KIND[family]))
    layout = draw_layout(rng, kind, name=f"unseen_{seed}")
    if family not in ("random", None) and family not in applicable(layout):
        raise ValueError(f"a {layout.kind} layout cannot carry the effect {family!r}")
    fields = draw_fields(rng, layout)
    fam = choose_family(rng, layout, family)
    n_cmd = int(n_commands or rng.integers(120, 201))
    arm = layout.kind == "arm"
    first = rng.uniform(0.03, 0.08) if arm else rng.uniform(0.08, 0.2)
    tools = [first]
    for _ in range(n_tools - 1):
        tools.append(tools[-1] + (rng.uniform(0.05, 0.15) if arm else rng.uniform(0.08, 0.2)))
    nests = _nests(rng, bool(layout.table_chain))
    q = commands(rng, layout, n_cmd)
    rows = measurement_rows(rng, n_cmd, tools, len(nests))
    effect = draw_effect(rng, layout, fam)
    if effect is not None and size_mm is not None and fam in SCALED:
        effect.size_mm = float(size_mm)
    noise = _noise(rng, layout, rows, q)
    lag = effect.params["lag_h"] if effect is not None and fam == "thermal" else None
    temperature, delta_t = temperatures(rng, rows.time, lag)
    camp = Campaign(seed, layout, fields, effect, q, rows, tools, nests, np.eye(4), noise, temperature, delta_t)
    nominal = tool_points(layout, camp.row_commands(), rows.tool_m)
    camp.tracker = tracker_pose(rng, nominal.mean(axis=0), arm)
    if effect is not None and fam == "backlash":
        noise["direction"] = _directions(camp, effect.axes[0])
    if effect is not None and fam in SCALED:
        _size(camp)
    trk = camp.to_tracker(camp.base_points())
    ranges = np.linalg.norm(trk, axis=1)
    noise["range_span_m"] = (ranges.min(), ranges.max())
    trk = spherical_noise(rng, trk, noise)
    if effect is not None and fam == "shift":
        trk = camp.shifted(trk)
    if effect is not None and fam.startswith("gross"):
        trk = _gross(rng, camp, trk)
    camp.measured = trk
    return camp


def heldout_csv(camp: Campaign, n: int, seed: int) -> str:
    """A noise-free, effect-free campaign of ``n`` fresh commands with every tool: the truth a model
    is judged on (tool rows only, tracker frame of the campaign)."""
    rng = np.random.default_rng(seed)
    q = commands(rng, camp.layout, n)
    cmd = np.tile(np.arange(n), len(camp.tools_m))
    tool = np.repeat(camp.tools_m, n)
    rows = Rows(cmd, -np.ones(len(cmd), dtype=int), tool, np.zeros(len(cmd), dtype=int), np.arange(len(cmd)) * 10.0)
    qr = {k: v[cmd] for k, v in q.items()}
    pts = tool_points(camp.layout, qr, tool, errors=camp.errors(with_effect=True))
    return camp.csv_text(measured=camp.to_tracker(pts), rows=rows, q=qr)
