"""Advice that fits a robot arm (issue 40).

An effect's advice (:meth:`vecpin.models.effects.base.Effect.advice`) names the remedies
of a machine tool: a backlash parameter, a cross or 2-D compensation table, the
controller's temperature compensation. A robot controller corrects its arm in other
places: its kinematic calibration (the DH or MDH parameters the controller's kinematics
uses: link lengths and offsets, twists, joint zero offsets), the tool centre point (TCP)
of the tool it carries, and the payload it is told it carries (mass and centre of
gravity, which set the joints' deflection). On an arm (:func:`~vecpin.kinematics.axes.is_arm`)
:func:`arm_advice` keeps the fitted numbers of each line and names these remedies instead.
"""
from __future__ import annotations

from vecpin.kinematics.axes import is_arm

CALIBRATION = ("the robot's kinematic calibration: the DH or MDH parameters in the robot controller (link lengths "
               "and offsets, twists, joint zero offsets), identified from the same campaign")
BASE_REMEDY = (f"correct {CALIBRATION}; calibrate the TCP (the target holder's offset from the flange) in the "
               "controller's tool frame; and set the payload (mass and centre of gravity) the robot carries, since "
               "it sets how far the joints deflect")


def _head(line: str, *cuts: str) -> str:
    """``line`` up to the first of ``cuts`` (the fitted numbers, without the machine tool's remedy)."""
    for c in cuts:
        if c in line:
            return line[:line.index(c)]
    return line


def arm_advice(machine, effect, lines: list[str]) -> list[str]:
    """``lines`` of ``effect``'s advice with robot remedies on an arm (unchanged on any other
    machine): see the module text."""
    if not is_arm(machine) or effect is None:
        return lines
    label, name = effect.label, effect.name
    if name == "backlash":
        return [_head(lines[0], "; enter it") + ": lost motion in the joint's gearbox; the DH or MDH parameters cannot "
                "hold it: approach every working pose from the same direction (as the plan approaches its points) or "
                "have the joint's gearbox checked"]
    if name in ("coupled_axes", "gantry_skew"):
        kept = [ln for ln in lines if "table" not in ln]
        return kept + [f"{label}: geometric: the kind of error {CALIBRATION} describes; enter the identified "
                       "parameters there, not in a compensation table"]
    if name == "rotary_periodic":
        return [_head(lines[0], ": geometric") + ": a gear or encoder error of the joint, beyond the DH or MDH "
                "parameters: worth a mechanical check of the joint; the robot's kinematic calibration holds only its "
                "mean"]
    if name == "thermal":
        kept = [ln for ln in lines if "not in the tables" not in ln]
        return kept + [f"{label}: row-dependent: run the robot's warm-up program before measuring and before work, "
                       "keep the cell's temperature steady, and calibrate the robot warm (its DH or MDH parameters "
                       "hold the warm geometry)"]
    return [ln.replace("; not in the tables", "") for ln in lines]
