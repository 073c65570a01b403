"""LinuxCNC thermal compensation: vecpin's thermal terms in a HAL component (``vecpin_thermal.comp``).

LinuxCNC has no temperature compensation of its own; vecpin writes one, beside the
cross-table component (:mod:`vecpin.export.linuxcnc_hal`) and built the same way
(``halcompile``, coefficients compiled in). Its input ``temperature`` [°C] is the
sensor's reading (wire it to the pin of the sensor's HAL driver, or ``setp`` it). In
the servo thread, per joint ``n`` of a linear axis, with ``dT = T_struct - T0`` and
``T_struct`` the reading through the first-order lag the campaign supported
(``lag-s`` seconds; 0: the reading itself):

* ``offset-n = A_n dT`` [mm], ``slope-n = B_n dT`` [mm/m],
* ``correction-n = offset-n + slope-n (joint.n.pos-cmd - P0_n) / 1000`` [mm]: the
  negative of vecpin's thermal error line (:class:`~vecpin.compensation.thermal.ThermalTerms`,
  ``A = -a/1000``, ``B = -b/1000``), the tool's growth added on the joint it runs along
  where the tool keeps its direction (the terms say which);
* ``command``, after ``motion-controller``: ``motor-pos-cmd-out-n = motor-pos-cmd-n +
  applied-n``; ``feedback``, before ``motion-command-handler``: ``motor-pos-fb-out-n =
  motor-pos-fb-n - applied-n`` (motion sees the position it commanded, as with the
  cross-table component). ``applied`` follows ``correction`` at most ``max-slew`` mm/s
  (a temperature step does not jump the drive) and fades to 0 while ``enable`` is false.

Where the cross-table component runs too, the two chain: motion -> ``vecpin-vec`` ->
``vecpin-thermal`` -> drive, and back (the HAL file says how).
"""
from __future__ import annotations

from vecpin.compensation.thermal import ThermalTerms
from vecpin.errors import InputError
from vecpin.export.linuxcnc_hal import _number
from vecpin.kinematics.machine import Machine

COMPONENT = "vecpin_thermal"
COMP_FILE = COMPONENT + ".comp"
HAL_FILE = COMPONENT + ".hal"
HAL_NAME = COMPONENT.replace("_", "-")
DEFAULT_SLEW = 1.0     # mm/s: how fast the applied correction may follow a temperature change


def joint_coefficients(terms: ThermalTerms, machine: Machine, joints: dict[str, int], n_joints: int):
    """Per joint (A [mm/K], B [mm/m/K], P0 [mm]) of the correction: minus the error line,
    the tool growth folded into the axis it runs along (joints of other axes: 0)."""
    A, B, P0 = [0.0] * n_joints, [0.0] * n_joints, [0.0] * n_joints
    for a in terms.axes:
        if a not in joints:
            raise InputError(f"the thermal terms name axis {a}, which has no LinuxCNC joint in the profile")
        j = joints[a]
        A[j] = -terms.offset_um_per_k[a] * 1e-3
        B[j] = -terms.slope_um_per_m_per_k[a] * 1e-3
        P0[j] = terms.p0_mm[a]
    return A, B, P0


def growth_warning(terms: ThermalTerms) -> str | None:
    """Why the component leaves the tool's growth alone, when the terms have one (a tool that turns)."""
    if terms.growth_um_per_k is None:
        return None
    return (f"WARNING: the tool's growth ({terms.growth_um_per_k:+.3f} um/K along a tool that turns) is not in "
            "vecpin_thermal: a joint correction cannot follow the tool's direction (LinuxCNC's tool length offset "
            "can: add growth x (T - T0) to it)")


def component_source(terms: ThermalTerms, machine: Machine, joints: dict[str, int], n_joints: int) -> str:
    """The ``halcompile`` source of the thermal component for ``terms`` on ``machine``'s joints."""
    A, B, P0 = joint_coefficients(terms, machine, joints, n_joints)
    arr = lambda v: "{" + ", ".join(_number(x) for x in v) + "}"   # noqa: E731
    by_joint = {j: a for a, j in joints.items()}
    lines = [f'component {COMPONENT} "vecpin thermal compensation of {machine.name}: offset and slope with '
             'temperature, between motion and the drives";',
             'pin in float temperature "the sensor\'s temperature [degC]";',
             'pin out float machine_temperature "the temperature through the lag [degC]";',
             f'pin in float pos_cmd_#[{n_joints}] "joint.N.pos-cmd [mm]";',
             f'pin in float motor_pos_cmd_#[{n_joints}] "joint.N.motor-pos-cmd (or the cross-table component\'s '
             'output)";',
             f'pin out float motor_pos_cmd_out_#[{n_joints}] "to the drive: motor-pos-cmd + applied correction";',
             f'pin in float motor_pos_fb_#[{n_joints}] "the drive\'s position feedback";',
             f'pin out float motor_pos_fb_out_#[{n_joints}] "to joint.N.motor-pos-fb: feedback - applied";',
             f'pin out float offset_#[{n_joints}] "offset of the correction at the temperature [mm]";',
             f'pin out float slope_#[{n_joints}] "slope of the correction at the temperature [mm/m]";',
             f'pin out float correction_#[{n_joints}] "offset + slope * (pos-cmd - P0) / 1000 [mm]";',
             f'pin out float applied_#[{n_joints}] "the correction applied (slew-limited) [mm]";',
             'pin in bit enable = 1 "apply the correction (wire motion.is-all-homed)";',
             f'param rw float lag_s = {_number(terms.lag_h * 3600.0)} "first-order lag of the structure [s]";',
             f'param rw float max_slew = {_number(DEFAULT_SLEW)} "mm/s the applied correction may move";',
             f'variable double held[{n_joints}];',
             'variable double tlag = 0.0;',
             'variable int started = 0;',
             'function feedback fp "after the drives\' feedback is read, before motion-command-handler";',
             'function command fp "after motion-controller";',
             'license "GPL";',
             'author "vecpin";',
             ';;',
             "#include <rtapi_math.h>",
             "/* written by vecpin: the correction of joint n is -(error line) of vecpin's thermal terms:",
             f"   T0 {_number(terms.t0_c)} degC, lag {_number(terms.lag_h)} h */",
             f"#define VECPIN_T0 {_number(terms.t0_c)}"]
    for j in range(n_joints):
        lines.append(f"/* joint {j} ({by_joint.get(j, 'no axis')}): A {_number(A[j])} mm/K, B {_number(B[j])} "
                     f"mm/m/K, P0 {_number(P0[j])} mm */")
    lines += [f"static const double vecpin_a[{n_joints}] = {arr(A)};",
              f"static const double vecpin_b[{n_joints}] = {arr(B)};",
              f"static const double vecpin_p0[{n_joints}] = {arr(P0)};",
              _FUNCTION.replace("N_JOINTS", str(n_joints)), ""]
    return "\n".join(lines)


_FUNCTION = r"""
FUNCTION(feedback) {
    int j;
    for (j = 0; j < N_JOINTS; j++) motor_pos_fb_out(j) = motor_pos_fb(j) - held[j];
}

FUNCTION(command) {
    double dmax = max_slew * fperiod, dT;
    int j;
    if (!started || !(lag_s > 0.0)) tlag = temperature;
    else tlag += (1.0 - exp(-fperiod / lag_s)) * (temperature - tlag);
    started = 1;
    machine_temperature = tlag;
    dT = tlag - VECPIN_T0;
    for (j = 0; j < N_JOINTS; j++) {
        double target, d;
        offset(j) = vecpin_a[j] * dT;
        slope(j) = vecpin_b[j] * dT;
        correction(j) = offset(j) + slope(j) * (pos_cmd(j) - vecpin_p0[j]) / 1000.0;
        target = enable ? correction(j) : 0.0;
        d = target - held[j];
        if (d > dmax) held[j] += dmax;
        else if (d < -dmax) held[j] -= dmax;
        else held[j] = target;
        applied(j) = held[j];
        motor_pos_cmd_out(j) = motor_pos_cmd(j) + held[j];
    }
}"""


def hal_lines(n_joints: int, chained: bool) -> list[str]:
    """HAL commands that load the thermal component and wire its motion side (``chained``:
    after the cross-table component ``vecpin-vec``, whose drive side it takes)."""
    p = f"{HAL_NAME}.0"
    out = [f"loadrt {COMPONENT}",
           "# feedback: after the function that reads the drives' feedback (see vecpin_vec.hal), before motion"
           + (" and before vecpin-vec's feedback (loaded after vecpin_vec.hal, position 1 puts it there)"
              if chained else ""),
           f"addf {p}.feedback servo-thread 1",
           f"addf {p}.command servo-thread",
           (f"net vecpin-all-homed => {p}.enable" if chained
            else f"net vecpin-thermal-homed motion.is-all-homed => {p}.enable"),
           f"# net vecpin-temperature <the temperature sensor's pin, degC> => {p}.temperature"]
    for n in range(n_joints):
        # a pin joins one signal: chained, the joint's command is already on vecpin_vec.hal's signal
        out.append(f"net vecpin-j{n}-pos-cmd => {p}.pos-cmd-{n}" if chained
                   else f"net vecpin-t{n}-pos-cmd joint.{n}.pos-cmd => {p}.pos-cmd-{n}")
        if chained:
            out += [f"# chained after vecpin-vec: its drive nets (vecpin-j{n}-drive-cmd, vecpin-j{n}-drive-fb) go here",
                    f"net vecpin-t{n}-in vecpin-vec.0.motor-pos-cmd-out-{n} => {p}.motor-pos-cmd-{n}",
                    f"net vecpin-t{n}-fb-out {p}.motor-pos-fb-out-{n} => vecpin-vec.0.motor-pos-fb-{n}"]
        else:
            out += [f"net vecpin-t{n}-motor-cmd joint.{n}.motor-pos-cmd => {p}.motor-pos-cmd-{n}",
                    f"net vecpin-t{n}-motor-fb {p}.motor-pos-fb-out-{n} => joint.{n}.motor-pos-fb"]
        out += [f"# net vecpin-t{n}-drive-cmd {p}.motor-pos-cmd-out-{n} => <joint {n}'s drive command pin>",
                f"# net vecpin-t{n}-drive-fb <joint {n}'s drive feedback pin> => {p}.motor-pos-fb-{n}"]
    return out


def write(terms: ThermalTerms, machine: Machine, joints: dict[str, int], n_joints: int, out, chained: bool) -> list[str]:
    """``vecpin_thermal.comp`` and ``vecpin_thermal.hal`` into the output set ``out``."""
    out.write_text(COMP_FILE, component_source(terms, machine, joints, n_joints))
    warn = growth_warning(terms)
    out.write_text(HAL_FILE, "\n".join(([f"# {warn}"] if warn else []) + hal_lines(n_joints, chained)) + "\n")
    return [COMP_FILE, HAL_FILE]
