"""Thermal terms on real data (issue 44): the controllers' form (one sensor, one lag, an
offset per kelvin: what Siemens K3, ISG TEMPCOMP, Heidenhain TEMPCOMP, Klipper's
``z_thermal_adjust`` and vecpin's LinuxCNC component take,
:mod:`vecpin.compensation.thermal`) beside an unconstrained fit (a multiple linear
regression on every temperature channel, and a ridge of it), judged on held-out time
blocks, with times.

The data (``--data``, one or more files; default: the recordings under
``benchmarks/data/frame_expansion/``, their provenance and licence beside them):

- a CSV with a ``time`` column [s], temperature columns [°C] (``--temperatures``,
  default every column whose name starts with ``T``) and one displacement column [µm]
  (``--displacement``), rows in time order: a spindle's thermal drift measured by a
  displacement sensor while the machine warms and cools; or
- a recording of Klipper's frame-expansion measurement script (its first line
  ``### METADATA ###``; alchemyEngine's ``measure_thermal_behavior``): the Z position
  where the nozzle homes, ``mcu_pos_z`` [steps] times the metadata's ``step_dist``
  [mm/step], against the frame, chamber, bed and hot-end temperatures, every minute
  while a 3-D printer's bed heats to 105 °C and then cools; the displacement is that Z
  position less its first value [µm].

For each of ``--blocks`` blocks of consecutive rows (default 5): every form is fitted on
the other blocks and predicts the held-out block; the page gives the RMS [µm] of what
each leaves on the held-out rows (the displacement itself: what no compensation leaves),
and the time per fit.

- controller form: displacement ~ c + a (lagged(T_s) - T0), the sensor ``s`` and the lag
  of :data:`vecpin.models.effects.thermal.LAGS_H` chosen on the training blocks (a
  Klipper recording also: the frame sensor without a lag, what ``z_thermal_adjust`` takes);
- MLR: displacement ~ c + sum_s a_s T_s (least squares, every channel, no lag);
- ridge: the same, standardised channels, the penalty chosen on the training blocks
  (inner time-block split), from 1e-3 to 1e3.

Run: python benchmarks/bench_real_thermal.py [--data FILE ...] [--displacement NAME] [--out PAGE]
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from datetime import datetime
from pathlib import Path

import numpy as np

from vecpin.models.effects.thermal import LAGS_H, lagged

PAGE = Path(__file__).resolve().parents[1] / "docs" / "results" / "real_thermal.md"
DATA = Path(__file__).resolve().parent / "data" / "frame_expansion"
KLIPPER_TEMPS = ("frame_t", "chamber_t", "bed_t", "he_t")   # the script's temperature columns [°C]
ABSENT_C = -100.0   # a channel reading below this [°C] somewhere: the sensor is absent (the script writes -180)
SEARCHED = [
    "search tool, code corpus: 'machine tool spindle thermal error dataset temperature sensors displacement', "
    "'thermal error machine tool dataset github temperature sensors thermal displacement csv', 'thermal error data "
    "spindle temperature sensors T1 T2 displacement Z axis elongation dataset xlsx'",
    "search tool, pages corpus: 'spindle thermal error dataset CSV temperature displacement license', 'zenodo "
    "dataset thermal error machine tool temperature displacement measurements CC-BY' (papers only: MDPI Machines "
    "9(9) 184, Lubricants 13(6) 269, Micromachines 16(5) 563, Sensors 24(7) 2380: data on request or not attached)",
    "repositories by name ('thermal-error', 'thermal_error'): qiliu0701/TECMT and "
    "qiliu0701/Research-on-Thermal-Error-Compensation-of-Machine-Tools (code and figures, no data files), "
    "1366884827-oss/machine-tool-thermal-error (a MATLAB script, no data), darjeeling-Wu/thermal_error_prediction "
    "(MATLAB code, no data)",
    "the project's package lists (PyPI names with 'thermal error', 'spindle'): none ships such data",
    "searched again (issue 44, later session): pages corpus 'machine tool thermal error dataset spindle temperature "
    "displacement CSV open data', 'open dataset thermal errors machine tool measured temperatures TCP displacement "
    "published repository license data availability', 'SFB/TR 96 thermo-energetic design machine tools measurement "
    "data set zenodo thermal deformation' (papers only: Procedia CIRP 58 457, IJAT 19(5) 758 (307 sensors, data not "
    "attached), JMMP 9(8) 267, Precision Engineering 66 21, arXiv 2510.03261 (FEM-generated data, not measured)); "
    "docs corpus 'spindle thermal displacement measurement dataset temperature sensors zenodo CC-BY' (unrelated "
    "sets); code corpus 'thermal error compensation machine tool temperature sensors displacement data csv load', "
    "'dataset thermal drift CNC spindle growth measured hours temperature channels github data folder' (the same "
    "data-less repositories; CNC sets of vibration and tool wear, no thermal displacement); repositories by name "
    "('thermal-error', 'thermal_error'): the same three; package lists grepped for 'thermal error', 'spindle "
    "thermal', 'machine tool thermal': none",
    "searched again (2026-11-29, issue 44): pages corpus 'machine tool thermal error dataset spindle temperature "
    "displacement', 'thermal drift laser tracker dataset temperature', 'Mendeley Data thermal error CNC machine tool "
    "spindle dataset', 'industrial robot thermal drift dataset joint temperature positioning error', 'thermal error "
    "measurement data machine tool open access dataset DOI figshare temperature probe displacement hours warm-up' "
    "(papers only: the same MDPI, IJAT and Procedia set, Appl. Sci. 11(22) 10813 (an ABB IRB1200's drift, data not "
    "attached), arXiv 2509.12739 (robot motor temperatures, no positions)); docs corpus 'CMM temperature measurement "
    "dataset thermal expansion open data' (NIST Hahn1: copper's expansion coefficient, a material, not a machine), "
    "'zenodo machine tool thermal deformation measurement data temperature sensors CC-BY' (unrelated sets); code "
    "corpus 'spindle thermal growth dataset csv temperature sensors eddy current displacement', 'thermal error "
    "dataset temperature displacement csv machine tool github data' (opatiny/predictiveMaintenance: a micro5 mill's "
    "warm-up signals with a spindle temperature but no displacement; a Swiss-type lathe's Gaussian-process thermal "
    "compensation notebook without data), 'laser tracker long term stability temperature data repository "
    "measurement log' (nothing), 'Klipper z_thermal_adjust frame expansion measurement data csv frame temperature z "
    "drift dataset', 'measure_thermal_behavior frame expansion data json results z height frame temperature' "
    "(found: tanaes/whopping_Voron_mods, GPL-3.0, four recordings, the two with a step size used; "
    "ctso/annex_k3_frame_expansion, one recording of an Annex K3, no licence: not used; Deutherius/FrameCompTesting "
    "and JiMcNulty/FDC: notes and code, no recordings); repositories by name ('measure_thermal', 'frame_expansion', "
    "'thermal')",
]


def read(path: Path, temps: list[str] | None, disp: str) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray]:
    """(time [s], temperatures (N, S) [°C], their names, displacement [µm]); bad cells named by row and column."""
    with path.open(encoding="utf-8") as f:
        text = f.read()
    if text.startswith("### METADATA ###"):
        return read_klipper(path, text, temps)
    rows = list(csv.DictReader(text.splitlines()))
    if not rows:
        sys.exit(f"{path}: no rows")
    names = temps or [c for c in rows[0] if c.startswith("T")]
    for c in ["time", disp, *names]:
        if c not in rows[0]:
            sys.exit(f"{path}: no column '{c}' (found: {', '.join(rows[0])})")
    return column(path, rows, "time"), np.column_stack([column(path, rows, c) for c in names]), names, \
        column(path, rows, disp)


def column(path: Path, rows: list[dict], c: str, first_row: int = 2) -> np.ndarray:
    """The column ``c`` as numbers; a cell that is not one named by its row (file line) and column."""
    out = []
    for k, r in enumerate(rows, start=first_row):
        try:
            out.append(float(r[c]))
        except (TypeError, ValueError):
            sys.exit(f"{path}: row {k}, column {c}: '{r[c]}' is not a number")
    return np.array(out)


def read_klipper(path: Path, text: str, temps: list[str] | None):
    """A Klipper frame-expansion recording (see the module text): (time [s], temperatures
    [°C], their names, the homed Z position less its first [µm]); a channel whose sensor
    is absent (readings below :data:`ABSENT_C`) is left out, and said."""
    lines = text.splitlines()
    meta = dict(ln[2:].split("=", 1) for ln in lines if ln.startswith("# ") and "=" in ln)
    if "step_dist" not in meta:
        sys.exit(f"{path}: no '# step_dist=' in the metadata: the Z steps cannot be turned into µm")
    step_mm = float(meta["step_dist"])
    body = [ln for ln in lines if not ln.startswith("#")]
    rows = list(csv.DictReader(body))
    first = len(lines) - len(body) + 2                       # the file line of the first data row
    for c in ["time", "mcu_pos_z", *(temps or KLIPPER_TEMPS)]:
        if c not in rows[0]:
            sys.exit(f"{path}: no column '{c}' (found: {', '.join(rows[0])})")
    try:
        stamps = [datetime.strptime(r["time"], "%Y/%m/%d-%H:%M:%S") for r in rows]
    except ValueError as exc:
        sys.exit(f"{path}: column time: {exc} (expected YYYY/MM/DD-HH:MM:SS)")
    t = np.array([(s - stamps[0]).total_seconds() for s in stamps])
    chans = {c: column(path, rows, c, first) for c in (temps or KLIPPER_TEMPS)}
    absent = [c for c, v in chans.items() if v.min() < ABSENT_C]
    if absent:
        print(f"{path}: left out {', '.join(absent)} (readings below {ABSENT_C:g} degC: no sensor)")
    names = [c for c in chans if c not in absent]
    z = column(path, rows, "mcu_pos_z", first)
    return t, np.column_stack([chans[c] for c in names]), names, (z - z[0]) * step_mm * 1e3


def controller_form(t, T, d, train):
    """The best (sensor, lag) on ``train`` and its prediction function over every row."""
    best = None
    for s in range(T.shape[1]):
        for lag in LAGS_H:
            x = lagged(t, T[:, s], lag)
            X = np.c_[np.ones(len(x)), x - x[train].mean()]
            coef = np.linalg.lstsq(X[train], d[train], rcond=None)[0]
            rms = np.sqrt(np.mean((d[train] - X[train] @ coef) ** 2))
            if best is None or rms < best[0]:
                best = (rms, s, lag, X @ coef)
    return best[1], best[2], best[3]


def mlr(T, d, train, lam=0.0):
    """Least squares (ridge penalty ``lam`` on standardised channels) on every channel: the prediction."""
    mu, sd = T[train].mean(axis=0), T[train].std(axis=0) + 1e-12
    Z = (T - mu) / sd
    X = np.c_[np.ones(len(Z)), Z]
    P = lam * np.eye(X.shape[1])
    P[0, 0] = 0.0
    coef = np.linalg.solve(X[train].T @ X[train] + P, X[train].T @ d[train])
    return X @ coef


def ridge(T, d, train):
    """Ridge with the penalty chosen on the training blocks' last fifth held out."""
    idx = np.flatnonzero(train)
    cut = idx[int(0.8 * len(idx)):]
    inner = train.copy()
    inner[cut] = False
    lam = min(np.logspace(-3, 3, 13), key=lambda v: np.mean((d[cut] - mlr(T, d, inner, v)[cut]) ** 2))
    return mlr(T, d, train, lam)


def run(path: Path, temps, disp: str, blocks: int) -> list[str]:
    t, T, names, d = read(path, temps, disp)
    block = np.minimum((np.arange(len(t)) * blocks) // len(t), blocks - 1)
    forms = {"none (the displacement itself)": lambda tr: np.zeros_like(d),
             "controller form (one sensor, one lag)": lambda tr: controller_form(t, T, d, tr)[2],
             "linear regression on every channel, no lag (MLR)": lambda tr: mlr(T, d, tr),
             "ridge on every channel": lambda tr: ridge(T, d, tr)}
    if "frame_t" in names:          # what Klipper's z_thermal_adjust applies: the frame sensor, no lag
        forms["frame sensor, no lag (Klipper's z_thermal_adjust)"] = lambda tr: mlr(T[:, [names.index("frame_t")]],
                                                                                   d, tr)
    what = "the homed Z position" if "mcu_pos_z" in path.read_text(encoding="utf-8")[:4000] else disp
    lines = [f"### {path.name}", "", f"{len(t)} rows over {np.ptp(t) / 3600:.1f} h, channels {', '.join(names)}, "
             f"displacement {what} (range {np.ptp(d):.1f} µm); {blocks} time blocks held out in turn", "",
             "| form | held-out RMS [µm] per block | all held-out rows [µm] | time per fit [ms] |", "|---|---|---|---|"]
    for label, fit in forms.items():
        left, spent = np.empty_like(d), 0.0
        for b in range(blocks):
            t0 = time.perf_counter()
            pred = fit(block != b)
            spent += time.perf_counter() - t0
            left[block == b] = d[block == b] - pred[block == b]
        per = " ".join(f"{np.sqrt(np.mean(left[block == b] ** 2)):.2f}" for b in range(blocks))
        lines.append(f"| {label} | {per} | {np.sqrt(np.mean(left ** 2)):.2f} | {1e3 * spent / blocks:.1f} |")
    s, lag, _ = controller_form(t, T, d, np.ones(len(t), bool))
    return lines + ["", f"the controller form on every row: sensor {names[s]}, lag {lag:g} h", ""]


FOUND = ("Real thermal data found (searched again, 2026-11-29; the searches are listed below): the Klipper "
         "frame-expansion recordings of a Voron 2.4 (350 mm) 3-D printer, two runs (bed heated to 105 °C for about "
         "3 h, then cooling), published in the repository tanaes/whopping_Voron_mods (GPL-3.0) and committed "
         "unchanged under `benchmarks/data/frame_expansion/` (provenance and licence there). A 3-D printer's Z axis "
         "is a machine axis and its Z drift a thermal error of the kind the controllers compensate (Klipper's "
         "`z_thermal_adjust` takes exactly the controller form: one frame sensor, an offset per kelvin), but it is "
         "not a machine tool: no machine-tool dataset with a licence was found. The first run's metadata states a Z "
         "step five times the second's on the same printer while both runs move by similar step counts: its µm "
         "figures follow that statement; the forms' ratios to each other do not depend on it.")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, nargs="+", help="CSV files: time [s], temperature columns [degC], a "
                    "displacement [um]; or Klipper frame-expansion recordings (default: the committed ones)")
    ap.add_argument("--temperatures", nargs="+", help="temperature columns (default: every column starting with T)")
    ap.add_argument("--displacement", default="displacement", help="displacement column [um] (default displacement)")
    ap.add_argument("--blocks", type=int, default=5, help="time blocks held out in turn (default 5)")
    ap.add_argument("--out", type=Path, default=PAGE)
    args = ap.parse_args()
    data = args.data or sorted(DATA.glob("*.csv"))
    head = ["# Thermal terms on real data", "", "Written by `benchmarks/bench_real_thermal.py` (its docstring says how "
            "each form is fitted and judged).", ""]
    searched = ["What was searched:", ""] + [f"- {s}" for s in SEARCHED]
    if not data:
        body = ["No thermal dataset with a licence that allows its use is here, so this page holds no figures.", ""] + \
            searched + ["", "With a recording of your own (a CSV with `time` [s], temperature columns `T...` [°C] and "
                        "a `displacement` [µm] column, rows in time order):", "", "```text",
                        "python benchmarks/bench_real_thermal.py --data drift.csv --displacement dz", "```"]
    else:
        body = [FOUND, ""] + [ln for path in data for ln in run(path, args.temperatures, args.displacement,
                                                                 args.blocks)] + searched
    print("\n".join(body))
    args.out.write_text("\n".join(head + body) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
