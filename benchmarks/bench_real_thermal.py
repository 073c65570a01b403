"""Thermal terms on real machine-tool data (issue 44): the controllers' form (one sensor,
one lag, an offset per kelvin: what Siemens K3, ISG TEMPCOMP, Heidenhain TEMPCOMP and
vecpin's LinuxCNC component take, :mod:`vecpin.compensation.thermal`) beside an
unconstrained fit (a multiple linear regression on every temperature channel, and a
ridge of it), judged on held-out time blocks, with times.

The data: a CSV with a ``time`` column [s], temperature columns [°C] (``--temperatures``,
default every column whose name starts with ``T``) and one displacement column [µm]
(``--displacement``), rows in time order: a spindle's thermal drift measured by a
displacement sensor while the machine warms and cools. No dataset with a licence that
allows its use was found for this benchmark (the page lists the searches); run it on
your own recording and it writes the page with the figures.

For each of ``--blocks`` blocks of consecutive rows (default 5): every form is fitted on
the other blocks and predicts the held-out block; the page gives the RMS [µm] of what
each leaves on the held-out rows (the displacement itself: what no compensation leaves),
and the time per fit.

- controller form: displacement ~ c + a (lagged(T_s) - T0), the sensor ``s`` and the lag
  of :data:`vecpin.models.effects.thermal.LAGS_H` chosen on the training blocks;
- MLR: displacement ~ c + sum_s a_s T_s (least squares, every channel, no lag);
- ridge: the same, standardised channels, the penalty chosen on the training blocks
  (inner time-block split), from 1e-3 to 1e3.

Run: python benchmarks/bench_real_thermal.py [--data CSV] [--displacement NAME] [--out PAGE]
"""
from __future__ import annotations

import argparse
import csv
import sys
import time
from pathlib import Path

import numpy as np

from vecpin.models.effects.thermal import LAGS_H, lagged

PAGE = Path(__file__).resolve().parents[1] / "docs" / "results" / "real_thermal.md"
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
]


def read(path: Path, temps: list[str] | None, disp: str) -> tuple[np.ndarray, np.ndarray, list[str], np.ndarray]:
    """(time [s], temperatures (N, S) [°C], their names, displacement [µm]); bad cells named by row and column."""
    with path.open(encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        sys.exit(f"{path}: no rows")
    names = temps or [c for c in rows[0] if c.startswith("T")]
    for c in ["time", disp, *names]:
        if c not in rows[0]:
            sys.exit(f"{path}: no column '{c}' (found: {', '.join(rows[0])})")

    def col(c):
        out = []
        for k, r in enumerate(rows, start=2):
            try:
                out.append(float(r[c]))
            except ValueError:
                sys.exit(f"{path}: row {k}, column {c}: '{r[c]}' is not a number")
        return np.array(out)
    return col("time"), np.column_stack([col(c) for c in names]), names, col(disp)


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
             "MLR on every channel": lambda tr: mlr(T, d, tr), "ridge on every channel": lambda tr: ridge(T, d, tr)}
    lines = [f"data: {path} ({len(t)} rows, {np.ptp(t) / 3600:.1f} h, channels {', '.join(names)}, displacement "
             f"{disp}); {blocks} time blocks held out in turn", "",
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
    return lines + ["", f"the controller form on every row: sensor {names[s]}, lag {lag:g} h"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, help="CSV: time [s], temperature columns [degC], a displacement [um]")
    ap.add_argument("--temperatures", nargs="+", help="temperature columns (default: every column starting with T)")
    ap.add_argument("--displacement", default="displacement", help="displacement column [um] (default displacement)")
    ap.add_argument("--blocks", type=int, default=5, help="time blocks held out in turn (default 5)")
    ap.add_argument("--out", type=Path, default=PAGE)
    args = ap.parse_args()
    head = ["# Thermal terms on real data", "", "Written by `benchmarks/bench_real_thermal.py` (its docstring says how "
            "each form is fitted and judged).", ""]
    if args.data is None:
        body = ["No machine-tool thermal dataset with a licence that allows its use was found, so this page holds no "
                "figures. What was searched:", ""] + [f"- {s}" for s in SEARCHED] + [
                "", "With a recording of your own (a CSV with `time` [s], temperature columns `T...` [°C] and a "
                "`displacement` [µm] column, rows in time order):", "", "```text",
                "python benchmarks/bench_real_thermal.py --data drift.csv --displacement dz", "```"]
    else:
        body = run(args.data, args.temperatures, args.displacement, args.blocks)
    print("\n".join(body))
    args.out.write_text("\n".join(head + body) + "\n", encoding="utf-8")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
