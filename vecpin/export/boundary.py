"""What the user does at the controller besides loading the files (issue 39).

Three things a table set needs from the controller that are not in its table files:

* **The gauge-line (T_offset) change** of the set (:attr:`TableSet.gauge_offset_change`):
  vecpin's compensated machine is the actual machine at the compensated commands
  against the controller's nominal kinematics *with the tool length* ``L + dT``
  (:func:`vecpin.compensation.functions.compensated_errors`). So the value is
  **added** to the controller's tool length (or to the datum its 5-axis transformation
  adds the tool length to): the controller then takes the tool tip ``dT`` further from
  the gauge line (the spindle's tool mounting face) and from the rotary pivot; a
  negative ``dT`` takes it closer. :data:`GAUGE_DATUMS` names that datum per
  controller, with the public source where one was seen; the workflow prints it with
  what the value is worth (entered, not entered, entered with the other sign:
  :func:`vecpin.compensation.plan.gauge_effect`).
* **Modulo tables** fold a rotary axis' errors over its whole travel onto one turn;
  :data:`UNFOLDED` names each controller's table over the whole travel, where it has one.
* **Files a user may run without the rest**: LinuxCNC's ``COMP_FILE`` pitch tables
  without the HAL component that carries the cross tables (:data:`PITCH_ALONE`).

Facts marked INFERRED or "from memory" were not read in a public document: check them.
"""
from __future__ import annotations

from dataclasses import dataclass

from vecpin.units import MM_PER_M


@dataclass(frozen=True)
class GaugeDatum:
    """Where a controller takes the gauge-line change: ``where`` (the datum per tool, then
    the one for every tool at once), ``source`` (public documents, or what is not confirmed)."""

    where: str
    source: str


GAUGE_DATUMS = {
    "siemens": GaugeDatum(
        "the tool length L1 ($TC_DP3, geometry) of every tool's cutting edge D, or once for every tool the "
        "component along the tool of the 5-axis transformation's base tool $MC_TRAFO5_BASE_TOOL_1, which the "
        "transformation adds the tool lengths to",
        "L1 = $TC_DP3: SINUMERIK ONE programming manual 12/2019 (6FC5398-2EP40-0BA0) p.821; "
        "$MC_TRAFO5_BASE_TOOL_1 from memory, not in a public page seen by vecpin: check it in the F2 "
        "(multi-axis transformations) manual"),
    "fanuc": GaugeDatum(
        "the tool length offset (H) of every tool, or once for every tool the tool holder offset, parameter "
        "No. 19666 (tool length compensation along the tool axis and tool centre point control; the length from "
        "the rotation centre of the tool's rotary axes to the tool mounting position; No. 7648 on a 15i), in "
        "that parameter's unit",
        "15i/150i-MA operator's manual B-63324EN/03 ch.14 ('the sum of the tool holder offset and tool length "
        "offset is handled as a tool length'); 16i/18i-MB tilted working plane specification A-78712E (point D "
        "'determined by adding the tool length offset and tool holder offset (parameter No. 19666) to the tool "
        "tip'); check No. 19666 in your control's parameter manual"),
    "heidenhain": GaugeDatum(
        "the tool length L (or its oversize DL) of every tool in the tool table TOOL.T, or once for every tool "
        "the length from the last rotary axis to the tool reference point (the spindle's gauge line) in the "
        "kinematics description",
        "TNC 128 user's manual 5/2014 p.163 ('Compensation value = L + DL TOOL CALL + DL TAB'); TNC 640 ISO "
        "user's manual 1/2015 p.171 (a positive DL is an oversize); kinematics description and its tool "
        "carrier: iTNC 530 HSCI technical manual p.726"),
    "linuxcnc": GaugeDatum(
        "the pivot length of a 5-axis head kinematics (5axiskins: HAL pin 5axiskins.pivot-length, the tip "
        "pivot-length + W from the pivot), or, where the tool stays along Z (trivkins, xyzac-trt-kins, "
        "xyzbc-trt-kins and their tool-offset pin), the Z offset of every tool in the tool table (G43)",
        "LinuxCNC source: src/emc/kinematics/5axiskins.c (pin 5axiskins.pivot-length), trtfuncs.c "
        "(<kins>.tool-offset added to the z offset)"),
    "beckhoff": GaugeDatum(
        "the tool length wz[i].laenge of every tool in the tool data (0.1 um), or the tool-length parameter of "
        "the kinematic transformation (wz[i].kinematic.param[j]; which j: your kinematics' description)",
        "TwinCAT CNC tool data example ('wz[5].laenge 6000 # Tool length', 0.1 um) and TF5200 'Tool offset' "
        "(wz[i].kinematic.param[j]), infosys.beckhoff.com; the sign (a longer tool = a larger laenge) INFERRED"),
}
GENERIC_DATUM = GaugeDatum(
    "the tool length of every tool (or the controller's pivot length: the datum its 5-axis transformation adds "
    "the tool length to)", "vecpin's own convention (compensated_errors: nominal tool length L + dT)")


ARM_DATUM = GaugeDatum(
    "the robot controller's TCP (tool centre point) of every tool: its offset along the tool axis in the tool frame "
    "(for a flange tool0 as ROS-Industrial's, its z)", "vecpin's own convention (compensated_errors: nominal tool "
    "length L + dT along the tool axis)")


def joint_labels(axis_names) -> dict[str, str]:
    """An arm's joints as a metrologist reads them: J1, J2, ... in chain order."""
    return {a: f"J{k}" for k, a in enumerate(axis_names, 1)}


def arm_table_label(output_axis: str, input_axis: str, labels: dict[str, str]) -> str:
    """An arm's table as it reads: ``J2(J1)``, the error of J2 as J1 moves (the file keeps
    the joint names: :func:`vecpin.compensation.tables.table_name`)."""
    return f"{labels[output_axis]}({labels[input_axis]})"


def gauge_datum(controller: str) -> GaugeDatum:
    """The gauge-line datum of a controller name (siemens-840d and siemens-828d share one);
    the generic wording for a controller vecpin knows no datum of."""
    return GAUGE_DATUMS.get(controller.split("-")[0], GENERIC_DATUM)


def gauge_direction(value_m: float, arm: bool = False) -> str:
    """The sign of a gauge-line change in words: what the controller then assumes (on an
    ``arm``: from the flange)."""
    mm = abs(value_m) * MM_PER_M
    way = "further from" if value_m > 0 else "closer to"
    return (f"the controller then takes the tool tip {mm:.4f} mm {way} "
            + ("the flange than now" if arm else "the gauge line (and the rotary pivot) than now"))


def gauge_text(controller: str, value_m: float, effect: dict | None = None, arm: bool = False) -> str:
    """One sentence: the gauge-line change, the datum it goes to (on an ``arm`` the robot
    controller's TCP, :data:`ARM_DATUM`), its sign in words and, with ``effect``
    (:func:`vecpin.compensation.plan.gauge_effect`), what entering it is worth."""
    v = value_m * MM_PER_M
    if v == 0.0:
        return ("gauge line (T_offset) change of these tables: 0 mm, nothing to enter: the tool lengths and the "
                + ("TCP stay as they are" if arm else "pivot stay as they are"))
    d = ARM_DATUM if arm else gauge_datum(controller)
    s = (f"gauge line (T_offset) change of these tables: {v:+.4f} mm: add it, with its sign, to {d.where}: "
         f"{gauge_direction(value_m, arm)}")
    if effect:
        s += (f". Model-predicted mean error: {effect['entered']:.4f} mm entered so, {effect['none']:.4f} mm not "
              f"entered, {effect['flipped']:.4f} mm entered with the other sign")
    return s


def gauge_readme(controller: str, value_m: float, effect: dict | None = None) -> list[str]:
    """The README's gauge-line section body (markdown lines, no heading)."""
    v = value_m * MM_PER_M
    if v == 0.0:
        return ["These tables leave the gauge line (T_offset) as it is: nothing to enter (change 0 mm)."]
    d = gauge_datum(controller)
    out = [f"These tables change the gauge line (T_offset) by **{v:+.4f} mm**. Add it, with its sign, to {d.where}: "
           f"{gauge_direction(value_m)}. vecpin's compensated machine is the machine at the compensated commands "
           "against the controller's nominal kinematics with the tool length L + this change."]
    if effect:
        out += ["", f"Model-predicted mean error with these tables: {effect['entered']:.4f} mm with the change entered "
                f"as above, {effect['none']:.4f} mm without it, {effect['flipped']:.4f} mm with the other sign."]
    out += ["", f"Source: {d.source}."]
    return out


#: per controller (name prefix): the table over a rotary axis' whole travel, the alternative to modulo tables
UNFOLDED = {
    "siemens": "tables over the whole travel ($AN_CEC_IS_MODULO / $AA_ENC_COMP_IS_MODULO 0, MIN and MAX the travel) "
               "where the NC does not treat {axes} as a modulo axis (a rotary axis without modulo conversion; "
               "INFERRED: a modulo axis' position runs over one turn only): make the tables without "
               "{option} and without \"modulo\": true in the profile",
    "fanuc": "pitch data of the linear-axis type over the whole travel (3625 = 0.0) where {axes} does not roll "
             "over (its machine coordinate runs over the whole travel; INFERRED: check in the parameter manual): "
             "make the tables without {option} and without \"modulo\": true in the profile",
    "heidenhain": ".COM entries over the whole travel with \"options\": {{\"rotary_any_range\": true}} in the profile "
                  "and no {option}, if your control takes rotary positions outside 0..360 "
                  "(the TNC 407 technical manual p.156 says it recognises 0..360 only: check)",
    "beckhoff": "lists over the whole travel (no kw.ssfk.modulo) where the NC does not treat {axes} as a modulo "
                "axis: make the tables without {option} and without \"modulo\": true in "
                "the profile",
}
UNFOLDED_GENERIC = ("tables over the whole travel: make them without {option} and "
                    "without \"modulo\": true in the profile")


def unfolded_alternative(controller: str, modulo_axes) -> str:
    """The controller's table over the whole travel of ``modulo_axes`` (a sentence); the
    option named as the library names it (the command line turns it into its flag)."""
    axes = ", ".join(modulo_axes)
    option = f"`modulo_axes` {axes}"
    return UNFOLDED.get(controller.split("-")[0], UNFOLDED_GENERIC).format(axes=axes, option=option)


@dataclass(frozen=True)
class PitchAlone:
    """Files of a format that hold the pitch tables and may be run without the rest."""

    label: str      # the report row
    files: str      # the pitch files
    rest: str       # what carries the other tables
    load_rest: str  # how to load it


PITCH_ALONE = {
    "linuxcnc": PitchAlone(
        "comp files without the component (model-predicted)", "the COMP_FILEs (comp_<AXIS>.txt)",
        "the HAL component vecpin_vec",
        "build and load it as README_LINUXCNC.md says (halcompile --install vecpin_vec.comp, HALFILE = "
        "vecpin_vec.hal, the drive nets through it)"),
}
