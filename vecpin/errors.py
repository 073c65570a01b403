"""Exceptions vecpin raises for bad input.

Every error a user can cause (a malformed URDF, a broken measurement file, a model
file for another machine) is a :class:`VecpinError`; the command line prints its
message and exits with status 2, never a traceback.
"""
from __future__ import annotations


class VecpinError(ValueError):
    """Bad input that the user can fix; the message says what and where."""


class MachineError(VecpinError):
    """A URDF that does not describe a vecpin machine (serial chain to ``spindle``)."""


class CampaignFileError(VecpinError):
    """A measurement file that cannot be read; names the file, row and column.

    ``row`` is the 1-based line number in the file (the header is line 1), or
    ``None`` when the problem concerns the whole file or a whole column.
    """

    def __init__(self, path: str, message: str, row: int | None = None, column: str | None = None):
        self.path = str(path)
        self.row = row
        self.column = column
        self.reason = message
        where = [self.path]
        if row is not None:
            where.append(f"row {row}")
        if column is not None:
            where.append(f"column '{column}'")
        super().__init__(", ".join(where) + ": " + message)
