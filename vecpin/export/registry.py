"""``--controller`` names -> controller formats."""
from __future__ import annotations

from vecpin.errors import InputError
from vecpin.export import beckhoff, fanuc, generic, heidenhain, iso230, linuxcnc, siemens
from vecpin.export.common import ControllerFormat

FORMATS: dict[str, ControllerFormat] = {f.name: f for f in (
    siemens.FORMAT_840D, siemens.FORMAT_828D, fanuc.FORMAT, linuxcnc.FORMAT, beckhoff.FORMAT, heidenhain.FORMAT,
    iso230.FORMAT, generic.FORMAT)}


def controller_names() -> list[str]:
    return list(FORMATS)


def get_format(name: str) -> ControllerFormat:
    """The format of a ``--controller`` name."""
    try:
        return FORMATS[name]
    except KeyError:
        raise InputError(f"--controller {name}: unknown controller (choose {', '.join(FORMATS)})") from None
