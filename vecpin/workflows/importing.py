"""Import a tracker export into a campaign file (the ``import`` command)."""
from __future__ import annotations

from pathlib import Path

from vecpin.errors import InputError
from vecpin.fileio import check_output_file
from vecpin.kinematics.machine import Machine
from vecpin.measurement.importer import ImportResult, import_export
from vecpin.measurement.importwrite import write_imported
from vecpin.measurement.robotaccuracy import TMAC_TOOL_MM, DatasetRead, read_dataset

FORMATS = ("tracker", "ipa-robot-accuracy")


def import_to_file(export: str | Path, machine: Machine, out: str | Path, plan: str | Path | None = None,
                   export_format: str = "tracker", **options) -> ImportResult | DatasetRead:
    """Read ``export``, join it with ``plan``, write the campaign CSV ``out`` and check it
    reads back as a campaign. ``export_format``: "tracker", a tracker program's export
    (see :func:`vecpin.measurement.importer.import_export` for the ``options``), or
    "ipa-robot-accuracy", a measurement file of the public UR10 dataset
    (:mod:`vecpin.measurement.robotaccuracy`: its own columns; of the options only
    ``tool_mm``). The result's ``lines()`` say how the file was read."""
    if export_format not in FORMATS:
        raise InputError(f"`export_format` '{export_format}': one of {', '.join(FORMATS)}")
    if export_format == "ipa-robot-accuracy":
        given = [f"`{k}`" for k, v in (("plan", plan), ("columns", options.get("columns")),
                                       ("time_format", options.get("time_format"))) if v]
        if given:
            raise InputError(f"`export_format` ipa-robot-accuracy reads the dataset's own columns; {', '.join(given)} "
                             "does not apply")
        return import_dataset_to_file(export, machine, out, tool_mm=options.get("tool_mm"))
    check_output_file(out)
    res = import_export(export, machine, plan, **options)
    write_imported(res, machine, out)
    return res


def import_dataset_to_file(path: str | Path, machine: Machine, out: str | Path,
                           tool_mm: float | None = None) -> DatasetRead:
    """One series of the public UR10 tracker dataset (:mod:`vecpin.measurement.robotaccuracy`)
    into the campaign CSV ``out``, checked to read back as a campaign."""
    check_output_file(out)
    res = read_dataset(path, machine, tool_mm=TMAC_TOOL_MM if tool_mm is None else tool_mm)
    write_imported(res.campaign, machine, out)
    return res
