"""The table face's parallelism to the linear axes, read with a dial test indicator: the file the operator fills in.

The tracker sees a table that turns only through the nests' reflectors, and the nests'
heights above the face (:mod:`vecpin.measurement.nestheights`) place the face to about
70-150 µrad: a height gauge's 0.01-0.02 mm over the nests' 0.1-0.2 m. The check every
machine's acceptance makes of the table's surface reads it far better: a dial test
indicator (DTI) held in the spindle touches the face, every rotary axis at its zero, and
the machine moves one linear axis across the face; the indicator's change over the
distance moved is the face's slope against that axis' line of motion (the parallelism of
the table's surface to the X and Y motions of the geometric tests for machining centres,
ISO 10791-1/-2; measured as ISO 230-1 describes straightness and parallelism measurements
with a linear displacement sensor; stated as practice here, the clauses not checked). A DTI
reads to 1-2 µm: over 300 mm that is a few µrad. :func:`~vecpin.compensation.faceframe.face_tilt`
weighs it with the nests' face and the prior.

``table_face.csv``, one row per swept axis::

    axis,distance_mm,change_um,sd_um
    X,,,2
    Y,,,2

``axis``: a linear axis of the machine that moves across the face (square to the spindle at
home); ``distance_mm``: how far the axis' command moved during the reading, mm (> 0);
``change_um``: the indicator's change over it, µm, **+ when the indicator is pushed in as
the command increases** (the face rises toward the axis' + travel, i.e. comes closer to the
tool); ``sd_um``: the reading's standard deviation, µm (empty: :data:`SWEEP_SD_UM`; 0:
exact, a simulation's reading). A row with neither distance nor change is an axis not
swept and is skipped. The plan writes the file with the axes to sweep and the default
standard deviation; the fit reads it (:func:`read_table_face`), and every problem names the
file, row and column.

The default standard deviation, :data:`SWEEP_SD_UM` = 2 µm, is an assumption the user
changes in the file: a DTI with 1 or 2 µm graduations (e.g. Mitutoyo's 513 series, 0.002 mm)
read at both ends of the sweep, the face's local flatness under the stylus and the axis'
straightness over the distance, about a micrometre each.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import replace

import numpy as np

from vecpin.errors import CampaignFileError, InputError
from vecpin.measurement.campaign import read_text_file
from vecpin.measurement.nestheights import number
from vecpin.units import M_PER_MM

TABLE_FACE_FILE = "table_face.csv"
COLUMNS = ("axis", "distance_mm", "change_um", "sd_um")
SWEEP_SD_UM = 2.0             # a DTI's reading over a sweep, 1 sigma [µm] (the module text says where it comes from)
MAX_SD_UM = 1000.0            # a reading less certain than a millimetre is no indicator's (a unit mistake)
MAX_SLOPE = 0.01              # rad: a face tilted more than 10 mm per metre is a unit mistake, not a table
MIN_DISTANCE_MM = 10.0        # a sweep shorter than this reads no slope (metres typed?)
ACROSS = 0.5                  # |cos| of an axis' direction against the spindle below which it moves across the face
M_PER_UM = 1e-6


def swept_axes(machine) -> dict[str, np.ndarray]:
    """{linear axis: (3,) its nominal direction of the tip's motion relative to the table, per
    metre of command} of the axes that move across the table's face: square to the spindle
    within :data:`ACROSS` at home (every axis at 0, or the end of its travel nearest 0)."""
    home = np.clip(np.zeros(machine.n_axes), machine.lower, machine.upper)
    k = machine.kinematics(home[None], 0.0, jacobian=True, frame="workpiece")
    s = k.tool_dir[0] / np.linalg.norm(k.tool_dir[0])
    out = {}
    for a in machine.axes:
        d = np.asarray(k.jacobian[0][:, a.index], float)
        if a.kind == "linear" and np.linalg.norm(d) > 0.5 and abs(d @ s) / np.linalg.norm(d) < ACROSS:
            out[a.name] = d
    return out


def sweep_ends(mid: np.ndarray, lo: np.ndarray, hi: np.ndarray, k: int, distance: float) -> np.ndarray:
    """(2, n) [m, rad]: the commands at the start and end of an indicator's sweep of axis ``k`` over
    ``distance`` [m], as the plan asks for it: centred on ``mid[k]`` (the middle of the measured range),
    clipped to [``lo[k]``, ``hi[k]``], every other axis at ``mid`` (the rotaries at zero). The one place the
    sweep's stretch is defined, for the reading a simulation takes and the model's line it is read against."""
    ends = np.tile(np.asarray(mid, float), (2, 1))
    ends[:, k] = [max(lo[k], mid[k] - distance / 2), min(hi[k], mid[k] + distance / 2)]
    return ends


def table_face_csv(axes, readings: dict | None = None) -> str:
    """The file's text for the swept ``axes`` (names): distance and change empty for the operator,
    or filled from ``readings`` {axis: (distance mm, change µm, sd µm)} (a simulation's)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(COLUMNS)
    for a in axes:
        if readings and a in readings:
            d, c, s = readings[a]
            w.writerow([a, f"{d:.3f}", f"{c:.3f}", f"{s:g}"])
        else:
            w.writerow([a, "", "", f"{SWEEP_SD_UM:g}"])
    return out.getvalue()


def axis_reason(name: str, machine) -> str | None:
    """Why ``name`` is no axis to sweep the face with on ``machine``, or None."""
    names = [a.name for a in machine.axes]
    if name not in names:
        return f"the machine has no axis '{name}' (its axes: {', '.join(names)})"
    across = swept_axes(machine)
    if name not in across:
        what = "a rotary axis" if machine.axis(name).kind == "rotary" else "a linear axis along the spindle"
        return (f"{name} is {what}: it does not move the indicator across the table's face (the axes that do: "
                f"{', '.join(across) or 'none'})")
    return None


def reading_reason(distance, change, sd, axis: str, travel_mm: float) -> tuple[tuple, str | None, str]:
    """((distance mm, change µm, sd µm), why refused or None, the column at fault) of one
    sweep along ``axis`` (``sd`` None: :data:`SWEEP_SD_UM`): the one check of a reading, its
    wording shared by the file and the option (each adds where)."""
    d, c = number(distance), number(change)
    s = SWEEP_SD_UM if sd is None or (isinstance(sd, str) and not sd.strip()) else number(sd)
    if not math.isfinite(d) or d <= 0:
        return (d, c, s), f"'{distance}' is not a distance in mm (how far {axis} moved during the reading, > 0)", \
            "distance_mm"
    if d < MIN_DISTANCE_MM:
        return (d, c, s), (f"{distance} mm: a sweep of {axis} shorter than {MIN_DISTANCE_MM:g} mm reads no slope: "
                           f"metres? Distances are mm ({d * 1000:g} if it was in metres)"), "distance_mm"
    if d > travel_mm * (1 + 1e-9):
        return (d, c, s), f"{distance} mm: beyond {axis}'s travel of {travel_mm:g} mm", "distance_mm"
    if not math.isfinite(c):
        return (d, c, s), f"'{change}' is not the indicator's change in µm", "change_um"
    if abs(c) * M_PER_UM > MAX_SLOPE * d * M_PER_MM:
        return (d, c, s), (f"{change} µm over {distance} mm: a face tilted more than {MAX_SLOPE * 1e3:g} mm per "
                           "metre; the change is µm (e.g. 4 for 0.004 mm)"), "change_um"
    if not math.isfinite(s) or not 0.0 <= s <= MAX_SD_UM:
        return (d, c, s), (f"'{sd}': the reading's standard deviation is 0 .. {MAX_SD_UM:g} µm (an indicator: "
                           f"about {SWEEP_SD_UM:g}; 0: exact, a simulation's reading)"), "sd_um"
    return (d, c, s), None, ""


def read_table_face(path, machine) -> dict[str, tuple[float, float, float]]:
    """{axis: (distance [mm], indicator change [µm], its standard deviation [µm])} from a
    filled ``table_face.csv`` of ``machine``; every problem names the file, row (line, header
    = 1) and column: the header, an axis missing, repeated, unknown or not moving across the
    face (:func:`axis_reason`), a reading refused by :func:`reading_reason`, no axis swept."""
    rows = list(csv.reader(io.StringIO(read_text_file(path, "no such file (the plan writes table_face.csv: fill in "
                                                             "distance_mm and change_um and give it to the fit)"))))
    head = [c.strip() for c in rows[0]] if rows else []
    if head[:1] != ["axis"] or "distance_mm" not in head or "change_um" not in head:
        raise CampaignFileError(path, f"the header must name the columns axis, distance_mm and change_um "
                                f"({','.join(COLUMNS)}; sd_um optional)", 1)
    twice = sorted({c for c in head if c and head.count(c) > 1})
    if twice:
        raise CampaignFileError(path, f"the header names {', '.join(twice)} twice; one column each", 1)
    col = {k: head.index(k) if k in head else None for k in COLUMNS}
    out: dict[str, tuple[float, float, float]] = {}
    for line, row in enumerate(rows[1:], start=2):
        def cell(name):
            i = col[name]
            return row[i].strip() if i is not None and i < len(row) else ""
        axis = cell("axis")
        if not any(c.strip() for c in row) or (axis and not cell("distance_mm") and not cell("change_um")):
            continue   # an axis not swept
        if not axis:
            raise CampaignFileError(path, "an axis name is missing", line, "axis")
        if axis in out:
            raise CampaignFileError(path, f"axis {axis} is given twice; one reading per axis", line, "axis")
        why = axis_reason(axis, machine)
        if why:
            raise CampaignFileError(path, why, line, "axis")
        for name in ("distance_mm", "change_um"):
            if not cell(name):
                raise CampaignFileError(path, f"no {name} for axis {axis}: " + (
                    "how far the axis moved while the indicator read the face, mm" if name == "distance_mm" else
                    "the indicator's change over the distance, µm, + when pushed in"), line, name)
        value, why, where = reading_reason(cell("distance_mm"), cell("change_um"), cell("sd_um") or None, axis,
                                           _travel_mm(machine, axis))
        if why:
            raise CampaignFileError(path, why, line, where)
        out[axis] = value
    if not out:
        raise CampaignFileError(path, "no axis swept: fill in distance_mm and change_um of X's (and Y's) sweep")
    return out


def _travel_mm(machine, axis: str) -> float:
    a = machine.axis(axis)
    return float(a.travel) / M_PER_MM


def check_table_face(given: dict | None, machine, option: str = "table_face") -> dict:
    """{axis: (distance [m], change [m], sd [m])} from ``given`` {axis: (distance mm, change µm)
    or (distance mm, change µm, sd µm)} (the fit's setting), refused naming ``option`` as the file
    is (:func:`axis_reason`, :func:`reading_reason`)."""
    out = {}
    for axis, value in (given or {}).items():
        axis = str(axis)
        why = axis_reason(axis, machine)
        if why:
            raise InputError(f"`{option}` {axis}: {why}")
        if not isinstance(value, (tuple, list)) or len(value) not in (2, 3):
            raise InputError(f"`{option}` {axis}: give (distance mm, change µm) or (distance mm, change µm, sd µm)")
        (d, c, s), why, _ = reading_reason(value[0], value[1], value[2] if len(value) == 3 else None, axis,
                                           _travel_mm(machine, axis))
        if why:
            raise InputError(f"`{option}` {axis}: {why}")
        out[axis] = (d * M_PER_MM, c * M_PER_UM, s * M_PER_UM)
    return out


def with_table_face(setup, given: dict | None, machine, option: str = "table_face"):
    """``setup`` (a fitted model's) carrying the indicator's sweeps ``given`` (as
    :func:`check_table_face` takes them) in ``face_sweep`` [m]."""
    if not given:
        return setup
    return replace(setup, face_sweep=check_table_face(given, machine, option))
