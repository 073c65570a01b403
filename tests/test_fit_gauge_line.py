"""``vecpin fit`` prints the gauge line ``T_offset`` it found with its standard deviation:
readings of a machine whose every tool tip lies 0.150 mm farther along the tool than its
length (the nominal kinematics at length + 0.150 mm, 2 µm noise) give +0.150 mm within
three standard deviations."""
import csv

import numpy as np
from hostile_helpers import ok

GAUGE_MM = 0.150


def test_fit_prints_the_gauge_line_the_readings_carry(flow, tmp_path, capsys):
    rng = np.random.default_rng(4)
    n = 60
    q = np.column_stack([rng.uniform(a.lower, a.upper, n) for a in flow.axes])
    tools_mm = np.repeat([[214.88, 312.86]], n, axis=0).ravel()
    q = np.repeat(q, 2, axis=0)
    tip_mm = flow.kinematics(q, (tools_mm + GAUGE_MM) / 1000.0).tip * 1000.0 + rng.normal(0, 0.002, (2 * n, 3))
    path = tmp_path / "campaign.csv"
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(flow.axis_names + ["tool", "x", "y", "z"])
        for qk, L, p in zip(q, tools_mm, tip_mm):
            w.writerow([f"{a.to_user(v):.6f}" for a, v in zip(flow.axes, qk)] + [f"{L:.3f}"] + [f"{v:.6f}" for v in p])
    cap = ok(["fit", "flow_xyzcb", path, "--out", tmp_path / "m.json", "--model", "ap", "--order", "1", "--quiet"],
             capsys)
    line = next(s for s in cap.out.splitlines() if "gauge line T_offset:" in s)
    value, sd = (float(s.split()[0]) for s in line.split("T_offset:")[1].split("mm")[0].split("±"))
    assert 0 < sd < 0.02 and abs(value - GAUGE_MM) < 3 * sd + 1e-4, line
