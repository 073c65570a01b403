"""Controller names (``controller``) -> controller formats. The built-in formats are listed here;
a plug-in (a module of your own) calls :func:`register_format` with its
:class:`~vecpin.export.common.ControllerFormat` and is then a ``controller`` choice."""
from __future__ import annotations

from vecpin.errors import InputError
from vecpin.export import beckhoff, fanuc, generic, heidenhain, iso230, linuxcnc, siemens
from vecpin.export.common import ControllerFormat

FORMATS: dict[str, ControllerFormat] = {f.name: f for f in (
    siemens.FORMAT_840D, siemens.FORMAT_828D, fanuc.FORMAT, linuxcnc.FORMAT, beckhoff.FORMAT, heidenhain.FORMAT,
    iso230.FORMAT, generic.FORMAT)}


def register_format(fmt: ControllerFormat) -> ControllerFormat:
    """Make a controller format available by its ``name``; returns it."""
    FORMATS[fmt.name] = fmt
    return fmt


def controller_names() -> list[str]:
    return list(FORMATS)


def get_format(name: str) -> ControllerFormat:
    """The format of a controller name."""
    try:
        return FORMATS[name]
    except KeyError:
        raise InputError(f"`controller` {name}: unknown controller (choose {', '.join(FORMATS)})") from None
