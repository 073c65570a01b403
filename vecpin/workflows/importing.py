"""Import a tracker export into a campaign file (the ``import`` command)."""
from __future__ import annotations

from pathlib import Path

from vecpin.fileio import check_output_file
from vecpin.kinematics.machine import Machine
from vecpin.measurement.importer import ImportResult, import_export, write_imported


def import_to_file(export: str | Path, machine: Machine, out: str | Path, plan: str | Path | None = None,
                   **options) -> ImportResult:
    """Read ``export`` (see :func:`vecpin.measurement.importer.import_export` for the
    options), join it with ``plan``, write the campaign CSV ``out`` and check it reads
    back as a campaign. The result's ``lines()`` say how the file was read."""
    check_output_file(out)
    res = import_export(export, machine, plan, **options)
    write_imported(res, machine, out)
    return res
