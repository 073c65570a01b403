"""A controller profile to fill in: every field a controller's files need, nothing guessed.

:func:`template` (the ``profile`` command) writes the machine's axes
with each field the controller's writer needs set to ``null`` and a ``comment`` that
says what each field is and where it is found on the control. A ``null`` is "not given":
``vecpin tables`` refuses it, naming the axis and the field, until it is filled in.
Facts that vecpin knows for sure (the machine's name, the controller) are filled.
"""
from __future__ import annotations

from vecpin.errors import InputError
from vecpin.export.profile import FORMAT, VERSION
from vecpin.export.registry import FORMATS
from vecpin.kinematics.machine import Machine

# per controller: the axis fields its writer needs (required) and those it reads when given
FIELDS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "siemens-840d": (("nc_name", "reference_position"), ("general_name", "program_name", "modulo")),
    "siemens-828d": (("nc_name", "reference_position"), ("general_name", "program_name", "modulo")),
    "fanuc-30i": (("number", "reference_position", "detection_unit"), ("program_name", "modulo")),
    "linuxcnc": ((), ("number", "program_name")),
    "beckhoff": (("number",), ("nc_name", "program_name", "modulo")),
    "heidenhain": (("nc_name",), ("program_name", "modulo")),
    "iso230": ((), ()),
    "generic": ((), ()),
}

WHERE: dict[str, dict[str, str]] = {
    "nc_name": {"siemens": "machine axis name, e.g. X1 (MD10000 $MN_AXCONF_MACHAX_NAME_TAB)",
                "heidenhain": "the axis name of the compensation tables (*.COM column header, e.g. X)",
                "beckhoff": "logical axis name (kopf.log_achs_name of the axis list)"},
    "general_name": {"siemens": "general axis name AXn: n = the axis' position in MD10000 (needed in multi-channel "
                                "systems; CEC tables use it when given)"},
    "program_name": {"any": "the axis address in part programs (the sign-test program; default: the vecpin axis "
                            "name)"},
    "number": {"fanuc": "controlled-axis number: the axis' position in the axis name parameter 1020 (1 = first)",
               "linuxcnc": "joint number from 0: the [JOINT_n] section of the machine's INI file (null on every axis: "
                           "the machine's axis order)",
               "beckhoff": "logical axis number (kopf.achs_nr of the axis list)"},
    "reference_position": {"siemens": "reference point value MD34100 $MA_REFP_SET_POS[0] [mm or deg]; vecpin writes "
                                      "its new value (MD_REFP.INI)",
                           "fanuc": "reference position in machine coordinates, parameter 1240 [mm or deg]; vecpin "
                                    "writes its new value into CNC-PARA.TXT"},
    "detection_unit": {"fanuc": "detection unit [mm or deg], e.g. 0.001 for IS-B: the unit of the pitch data"},
    "modulo": {"any": "true when the NC treats this rotary axis as modulo 0..360 deg (its tables then repeat every "
                      "turn)"},
}


def _family(controller: str) -> str:
    return controller.split("-")[0]


def field_help(field: str, controller: str) -> str:
    w = WHERE[field]
    return w.get(_family(controller)) or w.get("any") or ""


def template(machine: Machine, controller: str) -> dict:
    """The profile template (a dict ready for JSON) of ``machine`` for ``controller``."""
    if controller not in FORMATS:
        raise InputError(f"`controller` {controller}: unknown (choose {', '.join(FORMATS)})")
    required, optional = FIELDS[controller]
    axes = {}
    for a in machine.axes:
        facts = {f: None for f in required}
        for f in optional:
            if f == "modulo" and (a.kind != "rotary" or a.upper_user - a.lower_user < 360.0 - 1e-9):
                continue
            if f in ("number", "program_name", "general_name", "nc_name", "modulo"):
                facts[f] = None
        axes[a.name] = facts
    comment = [f"vecpin controller profile of {machine.name} for {controller}: fill in every null from the control "
               "(vecpin tables refuses a null it needs, naming the axis and the field); units mm and degrees, "
               "machine coordinates."]
    for f in list(required) + [f for f in optional if any(f in v for v in axes.values())]:
        need = "needed" if f in required else "optional, null: not given"
        comment.append(f"{f} ({need}): {field_help(f, controller)}")
    out = {"format": FORMAT, "version": VERSION, "machine": machine.name, "controller": controller,
           "comment": comment, "axes": axes}
    if controller == "linuxcnc":
        comment.append("options.ini: the machine's LinuxCNC INI file (relative to this profile): vecpin checks the "
                       "joint numbers, units and joint types against it; options.comp_file_type: 0 or 1, as "
                       "COMP_FILE_TYPE in the INI")
        out["options"] = {"ini": None, "comp_file_type": 0}
    return out
