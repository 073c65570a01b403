"""Import a tracker export into a campaign file (the ``import`` command)."""
from __future__ import annotations

from pathlib import Path

from vecpin.fileio import check_output_file
from vecpin.kinematics.machine import Machine
from vecpin.measurement.importer import ImportResult, import_export, write_imported
from vecpin.measurement.robotaccuracy import TMAC_TOOL_MM, DatasetRead, read_dataset
from vecpin.workflows.summary import uncompensated

FORMATS = ("tracker", "ipa-robot-accuracy")


def import_to_file(export: str | Path, machine: Machine, out: str | Path, plan: str | Path | None = None,
                   **options) -> ImportResult:
    """Read ``export`` (see :func:`vecpin.measurement.importer.import_export` for the
    options), join it with ``plan``, write the campaign CSV ``out`` and check it reads
    back as a campaign. The result's ``lines()`` say how the file was read."""
    check_output_file(out)
    res = import_export(export, machine, plan, **options)
    u = uncompensated(machine, res.campaign, strict=False)  # the figure assess and fit print
    res.uncompensated_mm = res.uncompensated_mm if u is None else u.mean_max_mm
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
