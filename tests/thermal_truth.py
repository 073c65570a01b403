"""A machine whose thermal behaviour lies outside vecpin's thermal model, and readers of
the controllers' thermal files written from their manuals (not vecpin's writers): the
judges of tests/test_thermal_controllers.py and benchmarks/bench_thermal_truth.py. Own
code only (numpy and the machine's nominal kinematics): nothing of vecpin's thermal
fit, prediction or export. (LinuxCNC: the component's own source, which the real
LinuxCNC runs in tests/test_thermal_linuxcnc.py.)

The truth family: the structure follows the air through a first-order lag ``lag_s``
[s]; per linear axis an offset [m/K] and an expansion [1/K] about its own centre [m],
and a tool that grows along its direction [m/K]; all of them on the temperature change
from 20 °C bent by ``nonlinear`` [1/K] per axis (``g = d (1 + k d)``)."""
import csv
import io
import re
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Truth:
    lag_s: float = 1.5 * 3600.0
    nonlinear: dict = field(default_factory=lambda: {"X": 0.01, "Y": 0.01, "Z": 0.01})   # 1/K
    offset: dict = field(default_factory=lambda: {"X": 6e-6, "Y": -4e-6, "Z": 9e-6})     # m/K
    expand: dict = field(default_factory=lambda: {"X": 11.5e-6, "Y": 9e-6, "Z": 14e-6})  # 1/K about centre
    centre: dict = field(default_factory=lambda: {"X": 0.1, "Y": -0.05, "Z": -0.3})      # m
    growth: float = 5e-6                                                                 # m/K along the tool
    growth_nonlinear: float = 0.01                                                       # 1/K

    def structure(self, time_s, air):
        """The structure's temperature [°C]: the air [°C] through the first-order lag."""
        out = np.empty_like(air)
        out[0] = air[0]
        for k in range(1, len(air)):
            out[k] = out[k - 1] + (1 - np.exp(-(time_s[k] - time_s[k - 1]) / self.lag_s)) * (air[k] - out[k - 1])
        return out

    def tip(self, m, q, tool, temp):
        """The machine's tool tip [m] (base frame) at commands q and structure temperatures [°C]."""
        d = temp - 20.0
        e = np.zeros_like(q)
        for a in self.offset:
            i = m.axis(a).index
            g = d * (1 + self.nonlinear[a] * d)
            e[:, i] = self.offset[a] * g + self.expand[a] * g * (q[:, i] - self.centre[a])
        kin = m.kinematics(q + e, tool, jacobian=False, frame="base")
        return kin.tip + (self.growth * d * (1 + self.growth_nonlinear * d))[:, None] * kin.tool_dir


def commands(m, n, rng):
    """n commands [m, rad] uniform over the travel (C: one turn)."""
    lo, hi = np.array([a.lower for a in m.axes]), np.array([a.upper for a in m.axes])
    if "C" in m.axis_names:
        hi[m.axis("C").index] = lo[m.axis("C").index] + 2 * np.pi
    return lo + (hi - lo) * rng.uniform(0, 1, (n, len(lo)))


def hall_day(m, truth, rng, amplitude_k, n=100, tool_m=0.12):
    """A 10-hour campaign of ``n`` commands in a hall cycling ``amplitude_k`` [K] about 21 degC
    with a 7-hour period, one tool of ``tool_m`` [m]: (commands, tools [m], true tips [m, base
    frame], times [s], air temperatures [degC])."""
    q, t = commands(m, n, rng), np.linspace(0, 10 * 3600, n)
    air = 21 + amplitude_k * np.sin(2 * np.pi * t / (7 * 3600))
    tool = np.full(n, tool_m)
    return q, tool, truth.tip(m, q, tool, truth.structure(t, air)), t, air


def table(text, temperature):
    """A controller CSV's row at ``temperature`` (linear between rows, as the PLC does)."""
    rows = list(csv.DictReader(io.StringIO(text)))
    t = np.array([float(r["temperature_degC"]) for r in rows])
    return {k: float(np.interp(temperature, t, [float(r[k]) for r in rows])) for k in rows[0]}


def siemens(folder, temperature):
    """K3: error line K = SD43900 + SD43910 (P - SD43920) [mm], corrected: the axis moves by -K."""
    ini = (folder / "THERMAL_840D.INI").read_text()
    p0 = {a: float(v) for a, v in re.findall(r"^\$SA_TEMP_COMP_REF_POSITION\[(\w+)\]=([-\d.]+)", ini, re.M)}
    bits = {a: int(v) for a, v in re.findall(r"^\$MA_TEMP_COMP_TYPE\[(\w+)\]=(\d+)", ini, re.M)}
    row = table((folder / "thermal_840D.csv").read_text(), temperature)
    return lambda a, pos: -((row[f"{a}.SD43900_mm"] if bits[a] & 1 else 0.0)
                            + (row[f"{a}.SD43910_tanbeta"] * (pos - p0[a]) if bits[a] & 2 else 0.0))


def beckhoff(folder, temperature):
    """TF5200: ds = offset_0 [0.1 um] + coefficient [um/m] (s - position_0), a deviation: corrected by -ds."""
    blocks = (folder / "thermal_beckhoff.lis").read_text().split("kopf.achs_nr")[1:]
    p0 = [int(re.search(r"temp_comp_position_0\s+(-?\d+)", b).group(1)) * 1e-4 for b in blocks]   # mm
    row = table((folder / "thermal_beckhoff.csv").read_text(), temperature)
    names = [k.split(".")[0] for k in row if k.endswith("offset_0_0.1um")]
    pos0 = dict(zip(names, p0))
    return lambda a, pos: -(row[f"{a}.offset_0_0.1um"] * 1e-4 + row[f"{a}.coefficient_um_per_m"] * 1e-6
                            * (pos - pos0[a]))


def heidenhain(folder, temperature):
    """TEMPCOMP formulas L + k * (W486 - T0) evaluated with W486 = the temperature."""
    text = (folder / "thermal_heidenhain.txt").read_text()
    val = lambda f: float(f[0]) + float(f[1]) * (temperature - float(f[2]))   # noqa: E731
    num = r"([-+\d.e]+)"
    off = {a: val(f) for a, *f in re.findall(rf"^(\w+) OFFSET TEMPCOMP = {num} \+ {num} \* \(W486 - {num}\)", text,
                                             re.M)}
    slope = {a: (float(p0), val(f)) for a, p0, *f in
             re.findall(rf"^(\w+) SLOPE P0 {num} = {num} \+ {num} \* \(W486 - {num}\)", text, re.M)}
    return lambda a, pos: -(off[a] + slope[a][1] * (pos - slope[a][0]) / 1000.0)


def fanuc(folder, temperature, unit=0.001):
    """Absolute data in detection units: offset + slope per m from P0 (P0 from the README's coefficients)."""
    row = table((folder / "thermal_fanuc.csv").read_text(), temperature)
    readme = (folder / "README_thermal_fanuc.md").read_text()
    p0 = {a: float(v) for a, v in re.findall(r"^- (\w+): offset [-+\d.]+ um/K at P0 = ([-\d.e]+) mm", readme, re.M)}
    return lambda a, pos: -(row[f"{a}.offset_units"] + row[f"{a}.slope_units_per_m"] * (pos - p0[a]) / 1000.0) * unit


def linuxcnc(folder, temperature):
    """vecpin_thermal.comp, read as its source computes at a steady temperature (the lag
    settled: T_struct = T): correction_j = a_j dT + b_j dT (pos - p0_j) / 1000 [mm],
    dT = T - VECPIN_T0; the joint of each axis from the source's joint comments."""
    text = (folder / "vecpin_thermal.comp").read_text()
    t0 = float(re.search(r"^#define VECPIN_T0 ([-+\d.e]+)", text, re.M).group(1))
    arr = {k: [float(v) for v in re.search(rf"vecpin_{k}\[\d+\] = \{{([^}}]*)\}}", text).group(1).split(",")]
           for k in ("a", "b", "p0")}
    joint = {a: int(j) for j, a in re.findall(r"^/\* joint (\d+) \((\w+)\):", text, re.M)}
    d = temperature - t0
    return lambda a, pos: arr["a"][joint[a]] * d + arr["b"][joint[a]] * d * (pos - arr["p0"][joint[a]]) / 1000.0


READERS = {"840D": siemens, "beckhoff": beckhoff, "heidenhain": heidenhain, "fanuc": fanuc, "linuxcnc": linuxcnc}


def corrected(m, q, folder, controller, temperature):
    """The commands [m, rad] with the controller's thermal correction read from its files
    in ``folder`` at ``temperature`` [°C] added on the linear axes."""
    correction = READERS[controller](folder, temperature)
    qc = q.copy()
    for a in ("X", "Y", "Z"):
        i = m.axis(a).index
        qc[:, i] += np.array([correction(a, p) for p in q[:, i] * 1e3]) * 1e-3
    return qc


def judged(m, truth, q, tool, qc, temperature, campaign_c):
    """(mean error [m] without the thermal terms, with them) at a steady ``temperature``
    [°C]: the tip's displacement from where the geometric tables, measured over the
    campaign, leave it: the truth's tip averaged over the campaign's structure
    temperatures ``campaign_c`` [°C] (a least-squares geometry takes up the mean of the
    thermal error over its campaign, a curvature's mean included; one number: the tip at
    that temperature)."""
    temps = np.atleast_1d(np.asarray(campaign_c, float))
    n = len(q)
    at = truth.tip(m, np.tile(q, (len(temps), 1)), np.tile(tool, len(temps)), np.repeat(temps, n))
    ref = at.reshape(len(temps), n, 3).mean(axis=0)
    temp = np.full(n, float(temperature))
    without = np.linalg.norm(truth.tip(m, q, tool, temp) - ref, axis=1).mean()
    return without, np.linalg.norm(truth.tip(m, qc, tool, temp) - ref, axis=1).mean()
