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
* the frame, as a metrologist measures each definition of it:

  - ISO 230-1's reference lines: X moved alone, then Y alone, through the middle of the
    box (linear axes at its centre, rotary axes at home), least-squares lines through the
    tips (``numpy.polyfit``); ``turn_urad`` the angle between the frames those lines span
    before and after compensation (the net rotation tables add where they keep the
    lines), ``lines_tilt_urad`` the angle between the plane of X's and Y's lines and the
    true table's face (the nominal plane): uncompensated, the truth's bed against its own
    lines; compensated, the plane the tip traces with the table at home against the face;
  - the volume: the best-fit orientation of the whole working volume (scipy's
    ``Rotation.align_vectors`` on 6000 quasi-random commands of its own: scipy's Halton
    sequence); ``volume_turn_urad`` the angle between it before and after (the net
    rotation where the tables keep the volume's mean orientation: a turning table, an arm),
    ``tilt_urad`` / ``tilt_vector_urad`` its tilt against the true table (the component
    square to the spindle, which a part set up on the table cannot remove), the angle the
    table's face is judged by where the campaign read the face.

Removing a squareness error turns the volume's best-fit orientation by about half the
squareness while the reference lines stay: where tables keep the lines, the volume's turn is
not a rotation they add.

The table face's parallelism as a commissioning engineer reads it (:func:`indicator_sweep`):
a dial test indicator swept along X and Y across the true face, the true tip moving.

Only the truth (the simulated machine) and the nominal kinematics come from vecpin."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.optimize import least_squares
from scipy.spatial.transform import Rotation


def _entry(t: dict) -> tuple:
    return (t["input_axis"], t["output_axis"], float(t["start"]), float(t["step"]), np.asarray(t["values"], float),
            bool(t["modulo"]))


def read_tables(path: Path) -> dict:
    """{gauge_mm, tables: [(input, output, start, step, values, modulo)], products: [(table, factor)]} from
    ``tables.json`` (mm, deg; a product's factor a plain number): the file's "products_convention" adds each
    product term's table value times its factor value to the output axis."""
    d = json.loads(Path(path).read_text())
    if d.get("drives"):
        raise ValueError("twin-drive differentials are not applied by this judge")
    products = [(_entry(p["table"]), _entry(p["factor"])) for p in d.get("products", [])]
    if products and "times its 'factor' value" not in d.get("products_convention", ""):
        raise ValueError("product terms without the convention this judge applies")
    return {"gauge_mm": float(d["gauge_offset_change_mm"]), "tables": [_entry(t) for t in d["tables"]],
            "products": products}


def _value(entry: tuple, q_user: np.ndarray, names: list[str]) -> np.ndarray:
    """One table's interpolated value at the commands (end values hold; modulo repeats every turn)."""
    inp, _, start, step, values, modulo = entry
    x = q_user[:, names.index(inp)]
    if modulo:
        x = start + np.mod(x - start, step * (len(values) - 1))
    return np.interp(x, start + step * np.arange(len(values)), values)


def apply(tables: dict, machine, q_si: np.ndarray) -> np.ndarray:
    """The compensated commands [SI] of ``q_si`` (N, n) under ``tables``."""
    q_user = machine.to_user(np.asarray(q_si, float))
    out = q_user.copy()
    names = machine.axis_names
    for entry in tables["tables"]:
        out[:, names.index(entry[1])] += _value(entry, q_user, names)
    for table, factor in tables.get("products", []):
        out[:, names.index(table[1])] += _value(table, q_user, names) * _value(factor, q_user, names)
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
    X moved alone, then Y alone, through the middle of the box (the other linear axes at
    its centre, every rotary axis at home: 0 or the nearest end of the box), a
    least-squares line through the tips of each; x along X's line, z square to both,
    y = z x x. ``tip_of(q, tool)`` gives the tips (N,3)."""
    lo, hi = box
    rotary = np.array([a.kind == "rotary" for a in machine.axes])
    home = np.where(rotary, np.clip(np.zeros(machine.n_axes), lo, hi), 0.5 * (lo + hi))
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


def tilt(rotvec: np.ndarray, spindle: np.ndarray) -> np.ndarray:
    """The part of a small rotation ``rotvec`` (3,) square to ``spindle``: the tilt a part
    set up on the table sees (the turn about the spindle is removed by aligning an edge)."""
    s = spindle / np.linalg.norm(spindle)
    return rotvec - (rotvec @ s) * s


def _angle(u: np.ndarray, v: np.ndarray) -> float:
    return float(np.arctan2(np.linalg.norm(np.cross(u, v)), u @ v))


def judge(truth, machine, tables_path: Path | None, q: np.ndarray, tool: np.ndarray, box) -> dict:
    """Mean tip errors [mm] of the true machine through the tables in ``tables_path`` (None:
    uncompensated) on commands ``q`` x ``tool`` [m], judged as a part (``part``) and as the
    error's shape (``shape``), and the frame [µrad] (the module text): ``turn_urad`` and
    ``volume_turn_urad`` (0 uncompensated), ``lines_tilt_urad``, ``tilt_urad`` and
    ``tilt_vector_urad`` (3,); ``box`` (lower, upper) [m, rad] where lines are moved and the
    volume is sampled."""
    from scipy.stats import qmc
    tables = read_tables(tables_path) if tables_path is not None else {"gauge_mm": 0.0, "tables": []}
    dT = tables["gauge_mm"] * 1e-3

    def true_tip(qq, tt):
        return truth.tool_tip(qq, tt, frame="workpiece")

    def comp(qq, tt):
        return true_tip(apply(tables, machine, qq), tt)

    def nominal(qq, tt):
        return machine.tool_tip(qq, tt + dT, frame="workpiece")
    spindle = machine.kinematics(np.clip(np.zeros((1, machine.n_axes)), *box), 0.0, jacobian=False,
                                 frame="workpiece").tool_dir[0]
    tip, nom = comp(q, tool), nominal(q, tool)
    out = {"part": float(np.linalg.norm(part_errors(nom, tip, spindle), axis=1).mean() * 1e3),
           "shape": float(np.linalg.norm(shape_errors(nom, tip), axis=1).mean() * 1e3), "turn_urad": 0.0,
           "volume_turn_urad": 0.0}
    # on 6000 quasi-random commands of its own: the best-fit rotation of 600 moves by 50 µrad from one set to the next
    lo, hi = box
    qv = lo + qmc.Halton(len(lo), seed=11).random(6000) * (hi - lo)
    tv = np.resize(np.unique(tool), len(qv))
    after = orientation(nominal(qv, tv), comp(qv, tv))
    w = tilt(after.as_rotvec(), spindle) * 1e6
    out["tilt_urad"], out["tilt_vector_urad"] = float(np.linalg.norm(w)), w.tolist()
    if tables["tables"]:
        before = orientation(machine.tool_tip(qv, tv, frame="workpiece"), true_tip(qv, tv))
        out["volume_turn_urad"] = float((after * before.inv()).magnitude() * 1e6)
    if "X" in machine.axis_names and "Y" in machine.axis_names:
        t0 = float(np.median(tool))
        now = line_frame(comp, machine, box, t0)
        out["lines_tilt_urad"] = _angle(now[2], line_frame(lambda qq, tt: machine.tool_tip(qq, tt, frame="workpiece"),
                                                           machine, box, t0)[2]) * 1e6
        if tables["tables"]:
            before = line_frame(true_tip, machine, box, t0)
            out["turn_urad"] = float(Rotation.from_matrix(now.T @ before).magnitude() * 1e6)
    return out


def indicator_sweep(truth, machine, box, axis: str, distance: float, tool: float, sd: float, rng
                    ) -> tuple[float, float]:
    """(distance moved [m], change [m]) of a dial test indicator in the spindle reading the true
    table's face while ``axis`` moves ``distance`` [m] (centred on the middle of ``box``, clipped to
    it; every rotary axis at home, the other axes mid-box): + when pushed in as the command
    increases, with a normal reading error of standard deviation ``sd`` [m] drawn from ``rng``.
    The change is the true tip's height above the true face (the truth's workpiece frame, its face
    the plane through the origin square to the spindle at home) at the start less at the end."""
    lo, hi = box
    rotary = np.array([a.kind == "rotary" for a in machine.axes])
    q = np.where(rotary, np.clip(np.zeros(machine.n_axes), lo, hi), 0.5 * (lo + hi))
    k = machine.axis_names.index(axis)
    q = np.tile(q, (2, 1))
    q[:, k] = [max(lo[k], q[0, k] - distance / 2), min(hi[k], q[0, k] + distance / 2)]
    up = -machine.kinematics(q[:1], 0.0, jacobian=False, frame="workpiece").tool_dir[0]
    gap = truth.tool_tip(q, np.full(2, tool), frame="workpiece") @ up
    return float(q[1, k] - q[0, k]), float(gap[0] - gap[1] + rng.normal(0.0, sd))
