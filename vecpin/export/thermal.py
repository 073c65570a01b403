"""Thermal terms where each controller takes them: Siemens 840D sl (K3 temperature
compensation), Beckhoff/ISG (``lr_param.temp_comp*``), Heidenhain (TEMPCOMP formulas),
Fanuc (thermal growth along the tool vector), LinuxCNC (vecpin's HAL component,
:mod:`vecpin.export.thermal_linuxcnc`).

Every controller here takes the thermal error line of an axis as values the PLC (or a
synchronized action) writes while the machine runs; the NC itself knows no temperature
(LinuxCNC's component excepted). vecpin therefore writes, per controller, the fixed
settings (a reference position, the enabling bits) and a table of the values per
temperature of the sensor (``thermal_<controller>.csv``, 1 K steps over the measured
range widened by :data:`WIDEN_K` each side; the terms are linear in T, so the PLC may
interpolate linearly or evaluate the coefficients of the README). All values are the
machine's *errors* (where it is, less where it was commanded), as each manual defines its
value; the controller corrects them. Sources and what is INFERRED: each README.

The structure's lag (``lag_h``) belongs to the PLC: it feeds the table the sensor's
reading through a first-order lag of that time constant (the README says so).
"""
from __future__ import annotations

import numpy as np

from vecpin.compensation.thermal import ThermalTerms
from vecpin.errors import ControllerLimitError, InputError
from vecpin.export.profile import ControllerProfile

WIDEN_K = 10.0           # K: the tables reach this far beyond the measured temperatures
SIEMENS_SLOPE_MAX = 0.01  # MD32760 $MA_COMP_ADD_VELO_FACTOR default, which also bounds tan(beta)
SIEMENS_TOOL_LIMIT_MM = 1.0  # MD20392 $MC_TOOL_TEMP_COMP_LIMIT default: larger values are clamped silently
FANUC_STEP_ALARM = 9999  # detection units: a step of the growth data this large alarms (B-63323EN p.100)
CONTROLLERS = ("840D", "beckhoff", "heidenhain", "fanuc")

SOURCES = {
    "840D": "SINUMERIK 840D sl Extended Functions K3, 03/2013 (6FC5397-1BP40-3BA1), 4.2 Temperature compensation "
            "p.228 (MD32750 bits, MD32760); 840D sl W1 08/2005 2.8 (MD20390, MD20392 limit 1 mm clamped without "
            "alarm, SD42960 written by synchronized actions or the PLC); 840C 12.19.4 (K_TC = K_TCabs + tan(beta) "
            "(P_x - P_0), the error line)",
    "beckhoff": "Beckhoff TF5200 axis parameters P-AXIS-00271..274 (temp_comp, temp_comp_position_0 and "
                "temp_comp_offset_0 in 0.1 um, temp_comp_coefficient in um/m, SGN32) and TEMPC::offset_0 / "
                "TEMPC::coefficient (ADS, written by the PLC); infosys 15266957451, 15327303691, 889202827",
    "heidenhain": "HEIDENHAIN TNC 426/430 technical manual 6.5.3 and iTNC 530 HSCI (07/2013) 6.5.3: TEMPCOMP column "
                  "of the description table, e.g. TEMPCOMP = 300 + 3.45e-3 * (W486 - 20), W486 the PLC's temperature",
    "fanuc": "FANUC Series 15i/150i-MA connection manual B-63323EN-1/03 p.100 and 16i-MB A-79097E: thermal growth "
             "along the tool vector, data from the PMC (G178-G179), absolute, positive = tool extension, a change of "
             "9999 detection units or more alarms",
}


def temperature_grid(terms: ThermalTerms) -> np.ndarray:
    """Temperatures [°C] of the tables: whole degrees over the measured range widened by WIDEN_K."""
    lo, hi = np.floor(terms.t_range_c[0] - WIDEN_K), np.ceil(terms.t_range_c[1] + WIDEN_K)
    return np.arange(lo, hi + 0.5, 1.0)


def _nc(profile: ControllerProfile, axis: str) -> str:
    a = profile.axis(axis)
    return a.nc_name or axis


def _csv(header: list[str], rows: list[list[float]], digits: int = 6) -> str:
    return ",".join(header) + "\n" + "".join(",".join(f"{v:.{digits}f}" for v in r) + "\n" for r in rows)


def _lag_note(terms: ThermalTerms) -> str:
    if terms.lag_h <= 0:
        return "The PLC enters the sensor's reading itself (the campaign supported no lag)."
    return (f"The PLC enters the sensor's reading through a first-order lag of {terms.lag_h:g} h (the structure "
            f"follows the air that slowly): T_s += (1 - exp(-dt / {terms.lag_h * 3600:g} s)) (T - T_s) each cycle, "
            "T_s starting at the first reading.")


def _readme(controller: str, terms: ThermalTerms, body: list[str], warnings: list[str]) -> str:
    head = [*(f"WARNING: {w}" for w in warnings), f"# Thermal compensation: {controller}", "",
            f"vecpin thermal terms of {terms.machine}: T0 {terms.t0_c:.3f} degC, fitted over "
            f"{terms.t_range_c[0]:.2f} .. {terms.t_range_c[1]:.2f} degC (values beyond are extrapolated).",
            "", "Values are the machine's errors (actual less commanded), which the controller corrects.", ""]
    coef = [f"- {a}: offset {terms.offset_um_per_k[a]:+.4f} um/K at P0 = {terms.p0_mm[a]:g} mm, slope "
            f"{terms.slope_um_per_m_per_k[a]:+.4f} um/m/K" for a in terms.axes]
    if terms.growth_um_per_k is not None:
        coef.append(f"- tool growth {terms.growth_um_per_k:+.4f} um/K (positive: the tool gets longer)")
    notes = [f"- {n}" for n in terms.notes]
    body = [x for b in body for x in (b, "")]
    return "\n".join(head + ["## Coefficients per temperature input (the PLC's table)", "", *coef, "",
                             _lag_note(terms), "", *body, *(["## What the data could not separate", "", *notes,
                                                              ""] if notes else []),
                             "## Source", "", SOURCES[controller], ""])


def write_siemens(terms: ThermalTerms, profile: ControllerProfile, out) -> list[str]:
    """``THERMAL_840D.INI`` (the machine and setting data), ``thermal_840D.csv`` (SD43900
    [mm] and SD43910 [tan beta] per axis and SD42960 [mm] per temperature) and the README.
    Refuses a slope beyond MD32760's bound or a tool value MD20392 would clamp."""
    T = temperature_grid(terms)
    d = T - terms.t0_c
    warnings = []
    slope = {a: terms.slope_um_per_m_per_k[a] * 1e-6 * d for a in terms.axes}
    worst = max(float(np.abs(v).max()) for v in slope.values())
    if worst > SIEMENS_SLOPE_MAX:
        raise ControllerLimitError(f"840D: tan(beta) reaches {worst:.3g} over {T[0]:g}..{T[-1]:g} degC, beyond "
                                   f"MD32760's bound {SIEMENS_SLOPE_MAX}: check the thermal terms")
    growth = terms.growth_mm(T)
    if np.abs(growth).max() > SIEMENS_TOOL_LIMIT_MM:
        raise ControllerLimitError(f"840D: the tool growth reaches {np.abs(growth).max():.3f} mm over the table, beyond "
                                   f"MD20392 $MC_TOOL_TEMP_COMP_LIMIT {SIEMENS_TOOL_LIMIT_MM} mm, which clamps "
                                   "without alarm: raise MD20392 first")
    bits = 3 + (4 if terms.growth_um_per_k is not None else 0)
    ini = [f"; vecpin thermal terms of {terms.machine} (K3 temperature compensation)"]
    for a in terms.axes:
        ini += [f"$MA_TEMP_COMP_TYPE[{_nc(profile, a)}]={bits} ; MD32750 bits 0, 1"
                + (", 2" if bits & 4 else ""),
                f"$SA_TEMP_COMP_REF_POSITION[{_nc(profile, a)}]={terms.p0_mm[a]:.4f} ; SD43920 P0 [mm]",
                f"$SA_TEMP_COMP_ABS_VALUE[{_nc(profile, a)}]=0.0 ; SD43900 at T0: the PLC writes thermal_840D.csv",
                f"$SA_TEMP_COMP_SLOPE[{_nc(profile, a)}]=0.0 ; SD43910 at T0: the PLC writes thermal_840D.csv"]
    if terms.growth_um_per_k is not None:
        ini += ["$MC_TOOL_TEMP_COMP_ON=1 ; MD20390", "$SC_TOOL_TEMP_COMP[2]=0.0 ; SD42960 at T0 (INFERRED: index 2, "
                "the tool's length direction in G17)"]
    tool = terms.growth_um_per_k is not None
    header = ["temperature_degC"] + [f"{_nc(profile, a)}.SD43900_mm" for a in terms.axes] + \
             [f"{_nc(profile, a)}.SD43910_tanbeta" for a in terms.axes] + (["SD42960_2_mm"] if tool else [])
    rows = [[T[k]] + [terms.offset_um_per_k[a] * 1e-3 * d[k] for a in terms.axes]
            + [slope[a][k] for a in terms.axes] + ([growth[k]] if tool else []) for k in range(len(T))]
    body = ["## Where the values go", "",
            "THERMAL_840D.INI sets MD32750 (bit 0: position-independent, SD43900; bit 1: position-dependent, SD43910 "
            "and SD43920; bit 2: tool direction, MD20390 / SD42960) and the reference positions P0. The PLC (or a "
            "synchronized action) writes SD43900 and SD43910 of each axis, and SD42960, from thermal_840D.csv at the "
            "machine's temperature: the error line K = SD43900 + SD43910 (P - SD43920).",
            "INFERRED: the sign. The values are the error line (840C: 'Error (comp. value)'), which the NC corrects, "
            "as its leadscrew compensation does ('a positive compensation value moves the axis in the negative "
            "direction', K3 p.238); verify with one axis at a known temperature before use.",
            f"MD32760 bounds the change per IPO cycle and tan(beta): the table's largest |tan beta| is {worst:.3g}."]
    out.write_text("THERMAL_840D.INI", "\n".join(ini) + "\n")
    out.write_text("thermal_840D.csv", _csv(header, rows, 9))
    out.write_text("README_thermal_840D.md", _readme("840D", terms, body, warnings))
    return ["THERMAL_840D.INI", "thermal_840D.csv", "README_thermal_840D.md"]


def write_beckhoff(terms: ThermalTerms, profile: ControllerProfile, out) -> list[str]:
    """``thermal_beckhoff.lis`` (``lr_param.temp_comp*`` per axis list), ``thermal_beckhoff.csv``
    (offset_0 [0.1 um] and coefficient [um/m] per axis per temperature) and the README."""
    T = temperature_grid(terms)
    d = T - terms.t0_c
    lis = [f"# vecpin thermal terms of {terms.machine}: one block per axis parameter list (P-AXIS-00271..274)"]
    for k, a in enumerate(terms.axes):
        p0 = int(round(terms.p0_mm[a] * 1e4))
        lis += [f"kopf.achs_nr {profile.axis(a).number or k + 1}", "lr_param.temp_comp 1",
                f"lr_param.temp_comp_position_0 {p0} /* [0.1 um] P0 = {terms.p0_mm[a]:g} mm */",
                "lr_param.temp_comp_offset_0 0 /* [0.1 um] at T0; the PLC writes TEMPC::offset_0 */",
                "lr_param.temp_comp_coefficient 0 /* [um/m] at T0; the PLC writes TEMPC::coefficient */", "#"]
    header = ["temperature_degC"] + [f"{a}.offset_0_0.1um" for a in terms.axes] + \
             [f"{a}.coefficient_um_per_m" for a in terms.axes]
    rows = [[T[k]] + [terms.offset_um_per_k[a] * 10.0 * d[k] for a in terms.axes]
            + [terms.slope_um_per_m_per_k[a] * d[k] for a in terms.axes] for k in range(len(T))]
    body = ["## Where the values go", "",
            "thermal_beckhoff.lis: the lines for each axis' parameter list (temp_comp on, the reference position "
            "temp_comp_position_0). The PLC writes TEMPC::offset_0 [0.1 um] and TEMPC::coefficient [um/m, REAL64] "
            "(ADS, GEO task port 551) from thermal_beckhoff.csv at the machine's temperature: "
            "ds = offset_0 + coefficient (s - position_0). The list's own SGN32 fields take whole numbers only "
            "(offset in 0.1 um, coefficient in um/m): the ADS objects carry the table's decimals.",
            "Sign: the value is the deviation, as in the leadscrew compensation (value = measured - programmed, "
            "TF5200 308695435); INFERRED for the temperature compensation, which the manual calls "
            "'temperature-dependent deviation'. Active only once the axis is referenced."]
    warnings = []
    if terms.growth_um_per_k is not None:
        warnings.append(f"the tool's growth ({terms.growth_um_per_k:+.3f} um/K along a tool that turns) has no "
                        "field in the axis compensation: these files leave it uncorrected (the tool length's wear, "
                        "written by the PLC, could carry it)")
    out.write_text("thermal_beckhoff.lis", "\n".join(lis) + "\n")
    out.write_text("thermal_beckhoff.csv", _csv(header, rows, 4))
    out.write_text("README_thermal_beckhoff.md", _readme("beckhoff", terms, body, warnings))
    return ["thermal_beckhoff.lis", "thermal_beckhoff.csv", "README_thermal_beckhoff.md"]


def write_heidenhain(terms: ThermalTerms, profile: ControllerProfile, out, tool_length_mm: float = 0.0,
                     word: str = "W486") -> list[str]:
    """``thermal_heidenhain.txt``: TEMPCOMP formulas in the PLC's temperature word ``word``
    [°C] (offset per axis [mm], the tool's length with its growth [mm]) and the slope
    formulas [mm/m] for the PLC; ``thermal_heidenhain.csv`` and the README."""
    lines = [f"# vecpin thermal terms of {terms.machine}: TEMPCOMP formulas, {word} = temperature [degC]"]
    t0 = f"{terms.t0_c:.4f}"
    for a in terms.axes:
        lines.append(f"{_nc(profile, a)} OFFSET TEMPCOMP = 0 + {terms.offset_um_per_k[a] * 1e-3:.6e} * ({word} - {t0})")
        lines.append(f"{_nc(profile, a)} SLOPE P0 {terms.p0_mm[a]:.4f} = 0 + "
                     f"{terms.slope_um_per_m_per_k[a] * 1e-3:.6e} * ({word} - {t0})")
    if terms.growth_um_per_k is not None:
        lines.append(f"TOOL TEMPCOMP = {tool_length_mm:g} + {terms.growth_um_per_k * 1e-3:.6e} * ({word} - {t0})")
    T = temperature_grid(terms)
    header = ["temperature_degC"] + [f"{a}.offset_mm" for a in terms.axes] + [f"{a}.slope_mm_per_m" for a in terms.axes]
    rows = [[t] + [float(terms.axis_error_mm(a, terms.p0_mm[a], t)) for a in terms.axes]
            + [terms.slope_um_per_m_per_k[a] * 1e-3 * (t - terms.t0_c) for a in terms.axes] for t in T]
    body = ["## Where the values go", "",
            "thermal_heidenhain.txt: the TEMPCOMP formulas (mm, the documented form L + k * (W486 - T0)). The tool's "
            "growth goes in the TEMPCOMP column of the description table's row of the spindle's length, as in the "
            "manual's example.",
            "INFERRED: each axis' OFFSET formula in the TEMPCOMP column of a row that translates along that axis, "
            "and the SLOPE (mm per m from P0) written by the PLC as the axis' linear expansion: the manuals found "
            "document TEMPCOMP for lengths only. The error line is offset + slope (P - P0) / 1000 mm."]
    out.write_text("thermal_heidenhain.txt", "\n".join(lines) + "\n")
    out.write_text("thermal_heidenhain.csv", _csv(header, rows, 6))
    out.write_text("README_thermal_heidenhain.md", _readme("heidenhain", terms, body, []))
    return ["thermal_heidenhain.txt", "thermal_heidenhain.csv", "README_thermal_heidenhain.md"]


def write_fanuc(terms: ThermalTerms, profile: ControllerProfile, out, detection_unit_mm: float = 0.001) -> list[str]:
    """``thermal_fanuc.csv``: per temperature the growth along the tool vector and each
    axis' error line's offset and slope, in detection units (absolute data the PMC
    writes); refuses a table whose step between two rows reaches the alarm's 9999 units."""
    if not detection_unit_mm > 0:
        raise InputError(f"`detection_unit_mm` {detection_unit_mm}: a length > 0")
    T = temperature_grid(terms)
    growth = np.round(terms.growth_mm(T) / detection_unit_mm)
    offs = {a: np.round(terms.axis_error_mm(a, terms.p0_mm[a], T) / detection_unit_mm) for a in terms.axes}
    step = max([float(np.abs(np.diff(growth)).max())] + [float(np.abs(np.diff(v)).max()) for v in offs.values()])
    if step >= FANUC_STEP_ALARM:
        raise ControllerLimitError(f"fanuc: a 1 K step of the table changes the data by {step:.0f} detection units, "
                                   f"at or beyond the alarm's {FANUC_STEP_ALARM}")
    header = ["temperature_degC", "tool_growth_units"] + [f"{_nc(profile, a)}.offset_units" for a in terms.axes] + \
             [f"{_nc(profile, a)}.slope_units_per_m" for a in terms.axes]
    rows = [[T[k], growth[k]] + [offs[a][k] for a in terms.axes]
            + [terms.slope_um_per_m_per_k[a] * 1e-3 * (T[k] - terms.t0_c) / detection_unit_mm for a in terms.axes]
            for k in range(len(T))]
    body = ["## Where the values go", "",
            f"thermal_fanuc.csv, in detection units of {detection_unit_mm:g} mm. The PMC writes the tool_growth "
            "column (absolute, positive = the tool gets longer) to the thermal growth along the tool vector data "
            "(G178-G179 on the 15i); the CNC moves the difference to the previous value along the tool. It writes "
            f"in steps below {FANUC_STEP_ALARM} units (a larger change alarms; this table's largest 1 K step is "
            f"{step:.0f}).",
            "INFERRED: the per-axis offset and slope columns (error line offset + slope (P - P0) / 1000) go to the "
            "PMC's own axis offset (an external machine zero point shift); no documented Fanuc field for a "
            "position-dependent thermal term was found: check with the machine tool builder."]
    out.write_text("thermal_fanuc.csv", _csv(header, rows, 3))
    out.write_text("README_thermal_fanuc.md", _readme("fanuc", terms, body, []))
    return ["thermal_fanuc.csv", "README_thermal_fanuc.md"]


WRITERS = {"840D": write_siemens, "beckhoff": write_beckhoff, "heidenhain": write_heidenhain, "fanuc": write_fanuc}


def write(controller: str, terms: ThermalTerms, profile: ControllerProfile, out) -> list[str]:
    """The thermal files of ``controller`` (one of :data:`CONTROLLERS`) into the output set ``out``."""
    key = "840D" if controller.startswith("840D") else controller
    if key not in WRITERS:
        raise InputError(f"`controller` {controller}: no thermal files for it (thermal: {', '.join(CONTROLLERS)}, "
                         "linuxcnc)")
    return WRITERS[key](terms, profile, out)
