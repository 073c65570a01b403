"""The exceptions vecpin raises: one family, each message naming the place.

Every error a user can cause (a malformed URDF, a broken measurement file, an option
outside its meaning, a model file for another machine, a table set a controller cannot
hold) is a :class:`VecpinError`; the command line prints its message and exits with
status 2, never a traceback. The subclasses say what kind of problem it is:

============================ ==========================================================
:class:`InputError`           an option or value outside its meaning (names the option)
:class:`MachineError`         a URDF that does not describe a vecpin machine
:class:`CampaignFileError`    a measurement file that cannot be read (file, row, column)
:class:`ModelFileError`       a model or table file that cannot be read (file, field)
:class:`ControllerFileError`  a controller file that cannot be parsed (file, line)
:class:`IdentifiabilityError` the data cannot determine the model asked for
:class:`ConvergenceError`     the estimator could not reach a minimum
:class:`ControllerLimitError` a table set the controller cannot hold
:class:`OutputError`          an output path that cannot be written
============================ ==========================================================

Input that is valid but suspicious (rows pasted twice, ...) gives a
:class:`VecpinWarning` (Python's ``warnings``); the command line prints it as one line
``vecpin: warning: ...`` and goes on.
"""
from __future__ import annotations


class VecpinError(ValueError):
    """Bad input that the user can fix; the message says what and where."""


class VecpinWarning(UserWarning):
    """Valid but suspicious input: the work goes on, the message says what to check."""


class InputError(VecpinError):
    """An option or argument outside its meaning (e.g. a negative sigma)."""


class MachineError(VecpinError):
    """A URDF that does not describe a vecpin machine."""


class IdentifiabilityError(VecpinError):
    """The campaign cannot determine the model asked for (too few equations, ...)."""


class ConvergenceError(VecpinError):
    """The estimator could not find a minimum of the likelihood."""


class ControllerLimitError(VecpinError):
    """A table set that the controller cannot hold (tables, points, value range)."""


class OutputError(VecpinError):
    """An output path that cannot be written (missing folder, a file in the way, permissions)."""


class CampaignFileError(VecpinError):
    """A measurement file that cannot be read; names the file, row and column.

    ``row`` is the 1-based line number in the file (the header is line 1), or
    ``None`` when the problem concerns the whole file or a whole column.
    """

    def __init__(self, path, message: str, row: int | None = None, column: str | None = None):
        self.path, self.reason, self.row, self.column = str(path), message, row, column
        super().__init__(_where(path, row=row, column=column) + ": " + message)


class ModelFileError(VecpinError):
    """A model or table file that cannot be read; names the file and the field."""

    def __init__(self, path, message: str, field: str | None = None):
        self.path, self.reason, self.field = str(path), message, field
        super().__init__(_where(path, field=field) + ": " + message)


class ControllerFileError(VecpinError):
    """A controller file that cannot be parsed; names the file and the line."""

    def __init__(self, path, message: str, line: int | None = None):
        self.path, self.reason, self.line = str(path), message, line
        super().__init__(_where(path, line=line) + ": " + message)


def _where(path, **parts) -> str:
    out = [str(path)]
    for k, v in parts.items():
        if v is None:
            continue
        out.append(f"{k} '{v}'" if k in ("column", "field") else f"{k} {v}")
    return ", ".join(out)
