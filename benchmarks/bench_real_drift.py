"""Drift on real data (issue 25): ``vecpin diagnose`` on the UR10's grid series beside what
the series' own repeated poses show.

Series A of ``christianlandgraf/ipa-robot-accuracy`` (``Series_A/measurements_grid.csv``,
MIT; not in vecpin's repository: 2.4 MB) is a grid of 11,911 poses over 100.8 h of time
stamps with the air temperature. Its first stretch of measurement (the rows before the
first pause longer than ``--pause`` hours: 5,257 poses over 18 h, 0.625 °C) is diagnosed
as a user would, ``vecpin diagnose ur10 stretch.csv`` in a fresh process with no options;
the page lists what it accepts and how it judges the time effects (a tracker step, the
thermal drift).

The independent check is the series' own poses read more than once (joint readings within
``--tol-deg``, :func:`vecpin.measurement.repeatability.reading_groups`): the
distance between two readings of one pose contains no model of the robot, only the
reading noise and whatever moved in between (the tracker, the robot's temperature). The
page tabulates them by time apart, with the temperature change between the readings.

Run: python benchmarks/bench_real_drift.py --data Series_A/measurements_grid.csv [--pause H] [--out PAGE]
"""
from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_real_diagnosis import _vecpin  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BINS_H = (0.0, 1.0, 24.0, np.inf)   # time apart of two readings of one pose, h


def first_stretch(time_s: np.ndarray, pause_h: float) -> np.ndarray:
    """Rows (a mask over rows in time order) before the first pause longer than ``pause_h``."""
    gaps = np.flatnonzero(np.diff(time_s) > pause_h * 3600)
    end = gaps[0] + 1 if gaps.size else len(time_s)
    return np.arange(len(time_s)) < end


def read_twice(machine, campaign, tol_deg: float) -> list[dict]:
    """Every two consecutive readings (in time) of one pose (joint readings within
    ``tol_deg`` on every joint): the first reading's time and the time apart [h], the
    temperature change [°C], the largest joint difference [deg], and the distance [mm]
    between the two readings less the move the nominal kinematics give their joint
    readings (rotated into the tracker frame by the registration of every pose): what
    moved between them beyond what the robot was told."""
    from vecpin.measurement.registration import rigid_registration
    from vecpin.measurement.repeatability import reading_groups
    label = reading_groups(campaign.q, campaign.tool, machine.rotary_mask(), rad=np.radians(tol_deg))
    nominal = machine.tool_tip(campaign.q, campaign.tool)
    R, _ = rigid_registration(nominal, campaign.xyz)
    t, xyz = campaign.time, campaign.xyz
    temp = campaign.extra.get("temperature", np.full(len(t), np.nan))
    out = []
    for g in np.flatnonzero(np.bincount(label) > 1):
        rows = np.flatnonzero(label == g)
        rows = rows[np.argsort(t[rows], kind="stable")]
        for a, b in zip(rows[:-1], rows[1:]):
            beyond = (xyz[b] - xyz[a]) - R @ (nominal[b] - nominal[a])
            out.append({"at_h": t[a] / 3600, "apart_h": (t[b] - t[a]) / 3600, "mm": float(np.linalg.norm(beyond)) * 1e3,
                        "dT": float(temp[b] - temp[a]), "deg": float(np.degrees(np.abs(campaign.q[b] - campaign.q[a]).max()))})
    return out


def repeats_table(pairs: list[dict], end_h: float) -> list[str]:
    """Rows of the pairs of :func:`read_twice` by where and how far apart they were read."""
    rows = ["| readings | time apart | pairs | joints apart, deg | distance beyond the nominal move, mean / RMS / "
            "max, mm | temperature change, °C |", "|---|---|---|---|---|---|"]
    for where, keep in (("within the stretch", lambda p: p["at_h"] + p["apart_h"] <= end_h),
                        ("the whole series", lambda p: True)):
        for lo, hi in zip(BINS_H[:-1], BINS_H[1:]):
            sel = [p for p in pairs if keep(p) and lo <= p["apart_h"] < hi]
            if not sel:
                continue
            d = np.array([p["mm"] for p in sel])
            apart = np.array([p["apart_h"] for p in sel])
            dT = np.array([abs(p["dT"]) for p in sel])
            span = (f"{apart.min() * 3600:.0f}-{apart.max() * 3600:.0f} s" if hi <= 1 else
                    f"{apart.min():.1f}-{apart.max():.1f} h")
            rows.append(f"| {where} | {span} | {len(sel)} | {max(p['deg'] for p in sel):.3f} at most | "
                        f"{d.mean():.3f} / {np.sqrt(np.mean(d ** 2)):.3f} / {d.max():.3f} | {dT.max():.3f} at most |")
    return rows


def diagnose(csv: Path, folder: Path) -> tuple[dict, float]:
    """``vecpin diagnose ur10 csv`` in a fresh process: (diagnosis.json, whole-process seconds)."""
    seconds = _vecpin("diagnose", "ur10", str(csv), "--out", str(folder))
    return json.loads((folder / "diagnosis.json").read_text()), seconds


def _mm(x) -> str:
    return "-" if x is None else f"{x:.4f}"


def page(source: str, stretch, diag: dict, seconds: float, pairs: list[dict], tol_deg: float) -> str:
    """The results page: the stretch, what the diagnosis accepted, its time effects, the repeats."""
    accepted = [e["label"] for e in diag["effects"] if e["accepted"]]
    timely = [e for e in diag["effects"] if e["name"] in ("instrument_shift", "thermal")]
    temp, hours = stretch.extra["temperature"], float(stretch.time[-1] / 3600)
    gross = (f" (file lines {', '.join(map(str, diag['outlier_lines']))} of the stretch; the stretch's first row is "
             f"file line 2, joints {np.round(np.degrees(stretch.q[0]), 1).tolist()} deg)") if diag["outlier_lines"] else ""
    out = ["# Real data: drift of the UR10's grid series (ipa-robot-accuracy, series A)", "",
           f"Written by `python benchmarks/bench_real_drift.py` on {source} (module docstring: the data, the check). "
           f"The first stretch of measurement: {len(stretch)} poses over {hours:.1f} h, air temperature "
           f"{temp[0]:.3f} °C at the start, {temp[-1]:.3f} °C at the end ({temp.min():.3f} .. {temp.max():.3f}). "
           f"`vecpin diagnose ur10` on it with no options took {seconds:.1f} s (whole process).", "",
           f"**Accepted**: {', '.join(accepted) or 'nothing'}{gross}. Base model held-out mean "
           f"{diag['base']['heldout_mean_mm']:.4f} mm; best model {diag['best']['heldout_mean_mm']:.4f} mm.", "",
           "The diagnosis' headline:", ""] + [f"> {line}  " for line in diag["headline"]] + ["",
           "## The time effects as the diagnosis judged them", "",
           "Size: how much the effect, fitted beside the base model, moves its prediction of the measured points "
           "(RMS over the rows).", "",
           "| effect | accepted | held-out mean before / after, mm | size, mm | evidence |", "|---|---|---|---|---|"]
    for e in timely:
        lag = f" (lag {e['options']['lag_h']:g} h)" if "lag_h" in e["options"] else ""
        out.append(f"| {e['label']}{lag} | {'yes' if e['accepted'] else 'no'} | {e['heldout_mean_mm_before']:.4f} / "
                   f"{e['heldout_mean_mm_after']:.4f} | {_mm(e['size_rms_mm'])} | {e['evidence'] or '(not significant)'} |")
    out += ["", "## What the series' own repeated poses show", "",
            f"Two readings of one pose: joint readings within {tol_deg:g}° on every joint (the grid reaches some of "
            "its targets again with joint readings up to 0.2° apart; the diagnosis counts a pose as read twice "
            "within 0.02°). The distance between the two readings less the move the nominal kinematics give "
            "their joint readings holds no fitted model: the reading noise and whatever moved in between.", ""]
    out += repeats_table(pairs, hours)
    return "\n".join(out) + "\n"


def main() -> None:
    """Read series A, diagnose its first stretch, tabulate its repeats, write the page."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", required=True, help="series A's Series_A/measurements_grid.csv (fetched)")
    ap.add_argument("--pause", type=float, default=1.0, help="a pause longer than this (h) ends the stretch (default 1)")
    ap.add_argument("--tol-deg", type=float, default=0.2, help="two readings of one pose: joint readings within this, "
                    "deg (default 0.2: the grid's targets reached again)")
    ap.add_argument("--out", default=str(ROOT / "docs" / "results" / "real_data_drift.md"))
    args = ap.parse_args()
    import vecpin
    from vecpin.measurement.robotaccuracy import read_dataset
    m = vecpin.Machine.load("ur10")
    whole = read_dataset(Path(args.data), m).campaign
    stretch = whole.subset(first_stretch(whole.time, args.pause))
    with tempfile.TemporaryDirectory() as d:
        csv = Path(d) / "stretch.csv"
        vecpin.write_campaign(csv, stretch, m)
        diag, seconds = diagnose(csv, Path(d) / "diagnosis")
        diag["headline"] = [line.replace(str(csv), "stretch.csv") for line in diag["headline"]]
    text = page(f"series A ({Path(args.data).name}, fetched)", stretch, diag, seconds,
                read_twice(m, whole, args.tol_deg), args.tol_deg)
    Path(args.out).write_text(text)
    print(text)
    print(f"written {args.out}")


if __name__ == "__main__":
    main()
