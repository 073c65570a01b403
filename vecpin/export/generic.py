"""vecpin's own table files: ``tables.json`` (every table, mm/deg, with its convention) and
``tables.csv`` (one row per table point). Written for every controller, read by
:meth:`vecpin.compensation.tables.TableSet.load_json`.

Convention: compensated command = command + sum of the tables (Paper I eq. 15-16),
linear interpolation, end values hold, modulo tables repeat every turn: a value is
the correction (minus the error) of the output axis.
"""
from __future__ import annotations

import json
from pathlib import Path

from vecpin.compensation.limits import NO_LIMITS
from vecpin.compensation.tables import TableSet
from vecpin.export.common import ControllerFormat, ExportJob, no_check
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine
from vecpin.measurement.partframe import FRAME_TEXT

JSON_FILE, CSV_FILE = "tables.json", "tables.csv"


def write(job: ExportJob) -> list[str]:
    """``tables.json`` and ``tables.csv`` into the job's output set."""
    job.out.write_text(JSON_FILE, json.dumps(job.tables.to_dict(job.machine), indent=1) + "\n")
    job.tables.save_csv(job.out.path(CSV_FILE), job.machine)
    return [JSON_FILE, CSV_FILE]


PREDICTED_SHAPE = "the best rigid motion of the whole volume removed as well (the error's shape)"


def add_prediction(out, report, labels: tuple[str, ...]) -> None:
    """Add to the ``tables.json`` staged in ``out`` (an OutputSet) the model-predicted figures
    of the report's row of the tables the machine gets (the first of ``labels`` the report
    has: the files as written where a controller's files were read back, else the set
    written) and of its first row (the
    uncompensated machine), as the printout states them: mean and max in the part's frame,
    the shape's mean, mm, with the points they are on (``report.basis``)."""
    def row(r) -> dict:
        return {"label": r.label, "tables": r.tables, "mean_mm": round(r.mean, 6), "max_mm": round(r.max, 6),
                "shape_mean_mm": None if r.shape is None else round(r.shape, 6)}
    written = next(r for lb in labels for r in report.rows if r.label == lb)
    d = json.loads(out.path(JSON_FILE).read_text(encoding="utf-8"))
    d["predicted"] = {"basis": report.basis.rstrip(":"), "frame": FRAME_TEXT, "shape": PREDICTED_SHAPE,
                      "written": row(written), "uncompensated": row(report.rows[0])}
    out.write_text(JSON_FILE, json.dumps(d, indent=1) + "\n")


def read(folder: Path, machine: Machine, profile: ControllerProfile) -> TableSet:
    return TableSet.load_json(Path(folder) / JSON_FILE, machine)


FORMAT = ControllerFormat(
    "generic", "vecpin generic files", NO_LIMITS, write, read, no_check,
    files="`tables.json`, `tables.csv` (every table, mm/deg; written for every controller)",
    sign="value = correction added to the command of the output axis (minus the error)",
    source="vecpin (Paper I eq. 13-16)",
    to_check="how your controller takes tables: its sign, zero point and units")


def write_tables(tables: TableSet, machine: Machine, out_dir) -> list[Path]:
    """``tables.json`` and ``tables.csv`` into ``out_dir`` (committed together)."""
    from vecpin.fileio import OutputSet
    with OutputSet(out_dir) as out:
        out.write_text(JSON_FILE, json.dumps(tables.to_dict(machine), indent=1) + "\n")
        tables.save_csv(out.path(CSV_FILE), machine)
    return [out.final(JSON_FILE), out.final(CSV_FILE)]
