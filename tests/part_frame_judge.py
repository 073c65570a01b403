"""A truth-side judge of compensation tables in the part's frame, written without vecpin's
compensation code: it reads vecpin's generic ``tables.json`` with its own parser, applies
the tables by the file's stated convention (compensated command = command + sum of the
tables, linear interpolation, end values hold, modulo tables repeat every turn), commands
the simulated true machine with them and judges the tool tip relative to the true table
(the truth's workpiece frame: where a part is clamped) three ways:

* part: as a part set up by probing its origin and aligning an edge sees it (a translation
  and a rotation about the spindle removed, nothing else; found here by
  ``scipy.optimize.least_squares`` over those four numbers, not by vecpin's closed form);
* shape: the best rigid motion removed (scipy's ``Rotation.align_vectors``);
* the turn the tables give the working volume, two ways: ISO 230-1's reference lines
  measured as a metrologist measures them, by straight moves of X and of Y alone (the
  other axes at home), least-squares lines through the tips (``numpy.polyfit``), before
  and after compensation, the angle between the two frames those lines span
  (``turn_urad``); and the angle between the best-fit orientations of the whole volume
  before and after (``volume_turn_urad``, scipy's ``Rotation.align_vectors``, on 6000
  quasi-random commands of its own: scipy's Halton sequence).

Only the truth (the simulated machine) and the nominal kinematics come from vecpin."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation


def read_tables(path: Path) -> dict:
    """{gauge_mm, tables: [(input, output, start, step, values, modulo)]} from ``tables.json`` (mm, deg)."""
    d = json.loads(Path(path).read_text())
    if d.get("drives"):
        raise ValueError("twin-drive differentials are not applied by this judge")
    return {"gauge_mm": float(d["gauge_offset_change_mm"]),
            "tables": [(t["input_axis"], t["output_axis"], float(t["start"]), float(t["step"]),
                        np.asarray(t["values"], float), bool(t["modulo"])) for t in d["tables"]]}


def apply(tables: dict, machine, q_si: np.ndarray) -> np.ndarray:
    """The compensated commands [SI] of ``q_si`` (N, n) under ``tables``."""
    q_user = machine.to_user(np.asarray(q_si, float))
    out = q_user.copy()
    names = machine.axis_names
    for inp, outp, start, step, values, modulo in tables["tables"]:
        x = q_user[:, names.index(inp)]
        grid = start + step * np.arange(len(values))
        if modulo:
            x = start + np.mod(x - start, step * (len(values) - 1))
        out[:, names.index(outp)] += np.interp(x, grid, values)
    return machine.to_si(out)


def _rot(phi: float, axis: np.ndarray) -> np.ndarray:
    return Rotation.from_rotvec(phi * axis).as_matrix()


def part_errors(nominal: np.ndarray, tip: np.ndarray, spindle: np.ndarray) -> np.ndarray:
    """(N,3) tip - (R_spindle(phi) nominal + t), phi and t by least squares."""
    s = spindle / np.linalg.norm(spindle)
    c = nominal.mean(0)

    def res(x):
        return (tip - ((nominal - c) @ _rot(x[0], s).T + c + x[1:])).ravel()
    x = least_squares(res, np.r_[0.0, tip.mean(0) - c], xtol=1e-15, ftol=1e-15, gtol=1e-15).x
    return res(x).reshape(-1, 3)


def orientation(nominal: np.ndarray, tip: np.ndarray) -> Rotation:
    """The best-fit rotation taking the centred nominal points onto the centred tips."""
    return Rotation.align_vectors(tip - tip.mean(0), nominal - nominal.mean(0))[0]


def shape_errors(nominal: np.ndarray, tip: np.ndarray) -> np.ndarray:
    R = orientation(nominal, tip)
    return tip - (R.apply(nominal - nominal.mean(0)) + tip.mean(0))


def line_frame(tip_of, machine, box, tool: float, n: int = 41) -> np.ndarray:
    """(3,3) rows: the directions x, y, z of the frame ISO 230-1's reference lines span:
    X moved alone, then Y alone (every other axis at home, 0 or the nearest end of the
    box), a least-squares line through the tips of each; x along X's line, z square to
    both, y = z x x. ``tip_of(q, tool)`` gives the tips (N,3)."""
    lo, hi = box
    home = np.clip(np.zeros(machine.n_axes), lo, hi)
    dirs = []
    for name in ("X", "Y"):
        k = machine.axis_names.index(name)
        q = np.tile(home, (n, 1))
        q[:, k] = np.linspace(lo[k], hi[k], n)
        tips = tip_of(q, np.full(n, tool))
        dirs.append(np.array([np.polyfit(q[:, k], tips[:, j], 1)[0] for j in range(3)]))
    x = dirs[0] / np.linalg.norm(dirs[0])
    z = np.cross(dirs[0], dirs[1])
    z /= np.linalg.norm(z)
    return np.array([x, np.cross(z, x), z])


def judge(truth, machine, tables_path: Path | None, q: np.ndarray, tool: np.ndarray, box) -> dict:
    """Mean tip errors [mm] of the true machine through the tables in ``tables_path`` (None:
    uncompensated) on commands ``q`` x ``tool`` [m], judged as a part (``part``) and as the
    error's shape (``shape``), and ``turn_urad``, the angle between the frames of the reference
    lines before and after (0 uncompensated); ``box`` (lower, upper) [m, rad] where lines are moved."""
    tables = read_tables(tables_path) if tables_path is not None else {"gauge_mm": 0.0, "tables": []}
    dT = tables["gauge_mm"] * 1e-3

    def comp(qq, tt):
        return truth.tool_tip(apply(tables, machine, qq), tt, frame="workpiece")

    def nominal(qq, tt):
        return machine.tool_tip(qq, tt + dT, frame="workpiece")
    spindle = machine.kinematics(np.clip(np.zeros((1, machine.n_axes)), *box), 0.0, jacobian=False,
                                 frame="workpiece").tool_dir[0]
    tip, nom = comp(q, tool), nominal(q, tool)
    out = {"part": float(np.linalg.norm(part_errors(nom, tip, spindle), axis=1).mean() * 1e3),
           "shape": float(np.linalg.norm(shape_errors(nom, tip), axis=1).mean() * 1e3), "turn_urad": 0.0,
           "volume_turn_urad": 0.0}
    if tables["tables"]:   # on 6000 quasi-random commands of its own: the best-fit rotation of 600 moves by 50 µrad
        from scipy.stats import qmc
        lo, hi = box
        qv = lo + qmc.Halton(len(lo), seed=11).random(6000) * (hi - lo)
        tv = np.resize(np.unique(tool), len(qv))
        before = orientation(machine.tool_tip(qv, tv, frame="workpiece"), truth.tool_tip(qv, tv, frame="workpiece"))
        after = orientation(nominal(qv, tv), comp(qv, tv))
        out["volume_turn_urad"] = float((after * before.inv()).magnitude() * 1e6)
    if "X" in machine.axis_names and "Y" in machine.axis_names and tables["tables"]:
        t0 = float(np.median(tool))
        before = line_frame(lambda qq, tt: truth.tool_tip(qq, tt, frame="workpiece"), machine, box, t0)
        after = line_frame(comp, machine, box, t0)
        out["turn_urad"] = float(Rotation.from_matrix(after.T @ before).magnitude() * 1e6)
    return out
