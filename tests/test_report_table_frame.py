"""The report judges a table machine's validation run as ``evaluate`` and ``verify`` do:
the tool tip relative to the table, each command's table pose from its nests. Checked
on a noise-free simulated run against an independent computation: a frame built from
the three nest readings of every command, the nominal tip of head_table_bc written out
by hand from its URDF, a best-fit rigid motion (Kabsch)."""
import csv
import re

import numpy as np
import pytest

from vecpin.cli import main


def _ry(b):
    c, s = np.cos(b), np.sin(b)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def _rz(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def _nominal_on_table(r):
    """head_table_bc (mm): X Y Z, the B pivot 450 mm above the table at Z = 0, gauge line
    300 mm below it; the C table turns about z through (625, 500, 0)."""
    x, y, z, b, c, tool = (float(r[k]) for k in ("X", "Y", "Z", "B", "C", "tool"))
    tip = np.array([x, y, 450 + z]) + _ry(np.radians(b)) @ np.array([0, 0, -(300 + tool)])
    return _rz(np.radians(c)).T @ (tip - np.array([625.0, 500.0, 0.0]))


def _kabsch_distances(a, b):
    a0, b0 = a - a.mean(0), b - b.mean(0)
    u, _, vt = np.linalg.svd(a0.T @ b0)
    d = np.sign(np.linalg.det(u @ vt))
    rot = (u @ np.diag([1, 1, d]) @ vt).T
    return np.linalg.norm(b0 - a0 @ rot.T, axis=1)


def _independent_uncompensated(path):
    """Each standstill (consecutive rows of one command) averaged: the tool's readings, and
    each of the three nests' readings; the tool in the frame of the nests, against the
    nominal tip on the table, after the best rigid fit."""
    rows = list(csv.DictReader(open(path)))
    axes = ("X", "Y", "Z", "B", "C", "tool")
    stops = []
    for r in rows:
        if not stops or any(r[a] != stops[-1][0][a] for a in axes):
            stops.append([])
        stops[-1].append(r)
    measured, nominal = [], []
    for stop in stops:
        xyz = lambda rs: np.mean([[float(n[c]) for c in "xyz"] for n in rs], axis=0)  # noqa: E731
        tool = [r for r in stop if r["instrument"] == "tracker"]
        targets = sorted({r["target"] for r in stop if r["instrument"] == "nest"})
        assert len(tool) >= 1 and len(targets) == 3
        p = np.array([xyz([r for r in stop if r["instrument"] == "nest" and r["target"] == t]) for t in targets])
        e1 = (p[1] - p[0]) / np.linalg.norm(p[1] - p[0])
        e3 = np.cross(e1, p[2] - p[0])
        e3 /= np.linalg.norm(e3)
        frame = np.column_stack([e1, np.cross(e3, e1), e3])
        measured.append(frame.T @ (xyz(tool) - p[0]))
        nominal.append(_nominal_on_table(stop[0]))
    return _kabsch_distances(np.array(nominal), np.array(measured))


@pytest.mark.slow   # a whole report or day: several seconds, in the slow tier
def test_report_validation_is_relative_to_the_table(tmp_path):
    sim = tmp_path / "sim"
    assert main(["simulate", "head_table_bc", "--out", str(sim), "--seed", "2", "--points", "60",
                 "--validation-count", "12"]) == 0
    assert main(["fit", "head_table_bc", str(sim / "campaign.csv"), "--out", str(tmp_path / "m.json"), "--model",
                 "ap", "--order", "1", "--quiet"]) == 0
    assert main(["report", str(tmp_path / "m.json"), str(sim / "campaign.csv"), "--validation",
                 str(sim / "validation_truth.csv"), "--out", str(tmp_path / "r"), "--quiet"]) == 0
    page = (tmp_path / "r" / "index.html").read_text()
    assert "validation: uncompensated" not in page     # not the tool tip in the tracker frame
    cells = re.search(r"validation, tip relative to the table: uncompensated, shape \(best rigid motion removed\)"
                      r"</td><td>all</td><td>([0-9.]+)</td><td>([0-9.]+)</td>", page)
    part = re.search(r"validation, tip relative to the table: uncompensated</td><td>all</td><td>([0-9.]+)</td>", page)
    assert float(part[1]) >= float(cells[1]) - 2e-3   # the part's frame removes less than the best rigid motion
    d = _independent_uncompensated(sim / "validation_truth.csv")
    assert len(d) == 12 and d.mean() > 0.1
    np.testing.assert_allclose([float(cells[1]), float(cells[2])], [d.mean(), d.max()], atol=2e-3)
