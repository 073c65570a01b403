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

JSON_FILE, CSV_FILE = "tables.json", "tables.csv"


def write(job: ExportJob) -> list[str]:
    """``tables.json`` and ``tables.csv`` into the job's output set."""
    job.out.write_text(JSON_FILE, json.dumps(job.tables.to_dict(job.machine), indent=1) + "\n")
    job.tables.save_csv(job.out.path(CSV_FILE), job.machine)
    return [JSON_FILE, CSV_FILE]


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
