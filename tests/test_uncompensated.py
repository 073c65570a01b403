"""One uncompensated figure per campaign (issue 27): ``import``, ``assess`` and ``fit``
print the same mean and max, computed once; the figure itself is checked against a
registration written here (Kabsch by SVD) of the hand-derived closed-form tool tips of
tests/closed_forms.py (Paper I eq. 20-21), neither vecpin's kinematics nor its registration."""
import re

import numpy as np
import pytest

from vecpin.cli import main
from vecpin.measurement.campaign import write_campaign
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.simulation.simulate import Design, simulate
from vecpin.measurement.uncompensated import uncompensated

from closed_forms import MACHINES
from test_importer import export

FIGURE = re.compile(r"uncompensated error \(nominal kinematics, the part's frame, (\d+) rows\): mean ([\d.]+) mm, "
                    r"max ([\d.]+) mm")


@pytest.fixture(scope="module")
def day(flow, tmp_path_factory):
    d = tmp_path_factory.mktemp("unc")
    plan = make_plan(flow, PlanSettings(n_commands=30, order=1, candidates=200, sight=False, repeat_points=5,
                                        repeat_times=3, validation_points=20))
    (d / "plan.csv").write_text(plan.template.to_csv(flow))
    sim = simulate(flow, 3, plan=(plan.template.q, plan.template.tool))
    write_campaign(d / "c.csv", sim.campaign, flow)
    return d, plan.template, sim.campaign


def kabsch_distances_mm(P, Q):
    """|Q - (R P + t)| [mm] for the least-squares rigid motion (R, t), P, Q (N,3) in m."""
    p0, q0 = P.mean(0), Q.mean(0)
    U, _, Vt = np.linalg.svd((P - p0).T @ (Q - q0))
    D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
    R = Vt.T @ D @ U.T
    return np.linalg.norm(Q - (P - p0) @ R.T - q0, axis=1) * 1000.0


def iso_part_distances_mm(q, tool, P, Q):
    """|errors| [mm] of readings Q against nominal tips P (N,3) [m] of the XYZCB gantry in the
    part's frame, computed here from the definitions alone: Q taken onto P by the best rigid
    motion, then turned so that X's least-squares line (tip against the X command, the
    other axes' commands, sin/cos of the rotaries and the tool length as regressors) runs
    along P's and the plane of X's and Y's lines is P's; then the translation and the turn
    about the spindle (z) that best remain, by least squares over four numbers."""
    from part_frame_judge import part_errors
    p0, q0 = P.mean(0), Q.mean(0)
    U, _, Vt = np.linalg.svd((P - p0).T @ (Q - q0))
    R = Vt.T @ np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))]) @ U.T
    M = (Q - q0) @ R + p0                                          # the readings in the machine frame
    X = np.column_stack([np.ones(len(q)), q[:, :3], np.sin(q[:, 3:]), np.cos(q[:, 3:]), tool])
    lines = np.linalg.lstsq(X, M, rcond=None)[0]

    def frame(a, b):
        x = a / np.linalg.norm(a)
        z = np.cross(a, b)
        z /= np.linalg.norm(z)
        return np.array([x, np.cross(z, x), z])
    nom = np.linalg.lstsq(X, P, rcond=None)[0]
    T = frame(nom[1], nom[2]).T @ frame(lines[1], lines[2])         # takes the readings' lines onto the nominal ones
    M = (M - M.mean(0)) @ T.T + M.mean(0)
    return np.linalg.norm(part_errors(P, M, np.array([0.0, 0.0, -1.0])), axis=1) * 1000.0


def test_the_figure_is_the_part_frame_and_the_shape_a_rigid_registration(flow, day):
    _, _, c = day
    u = uncompensated(flow, c)
    nominal = MACHINES["flow_xyzcb"][0][0](c.q, c.tool)
    np.testing.assert_allclose(u.shape_mm, kabsch_distances_mm(nominal, c.xyz), atol=1e-6)
    np.testing.assert_allclose(u.distances_mm, iso_part_distances_mm(c.q, c.tool, nominal, c.xyz), atol=2e-5)
    assert np.sqrt(np.mean(u.distances_mm**2)) >= np.sqrt(np.mean(u.shape_mm**2))   # the rigid fit is the least
    assert len(u.rows) == len(c) and u.mean_mm > 0.1  # the simulated machine is far from its nominal kinematics


def test_import_assess_and_fit_print_the_same_figure(flow, day, tmp_path, capsys):
    d, template, c = day
    figures = {}
    assert main(["import", str(export(tmp_path / "e.csv", c, template)), "--machine", "flow_xyzcb",
                 "--plan", str(d / "plan.csv"), "--out", str(tmp_path / "imp.csv")]) == 0
    text = capsys.readouterr().out
    mean, mx = re.search(r"the uncompensated error\): mean ([\d.]+) mm, max ([\d.]+) mm", text).groups()
    assert "(where this run went through compensation tables, without their gauge-line change, which verify" in text
    figures["import"] = (mean, mx)
    assert main(["assess", str(tmp_path / "imp.csv"), "--machine", "flow_xyzcb", "--session-gap-min", "5"]) == 0
    figures["assess"] = FIGURE.search(capsys.readouterr().out).groups()[1:]
    assert main(["fit", "flow_xyzcb", str(tmp_path / "imp.csv"), "--out", str(tmp_path / "m.json"),
                 "--model", "6dof", "--basis", "chebyshev", "--order", "2", "--quiet"]) == 0
    figures["fit"] = FIGURE.search(capsys.readouterr().out).groups()[1:]
    assert len(set(figures.values())) == 1, figures
    u = uncompensated(flow, c)
    assert figures["fit"] == (f"{u.mean_mm:.4f}", f"{u.max_mm:.4f}")


def test_the_all_table_machine_has_one_figure_the_tip_relative_to_the_table(machines, tmp_path, capsys):
    """xyzac_trt (every axis moves the table, the tool stands still): assess no longer refuses,
    and assess and fit print the one figure, the tip relative to the table, which evaluate
    (its nests where the fit put them, its own code path) confirms to 1 %."""
    import json
    m = machines["xyzac_trt"]
    sim = simulate(m, 2, design=Design(n_commands=60, n_validation=5, repeat_points=4, repeat_times=3))
    write_campaign(tmp_path / "c.csv", sim.campaign, m)
    u = uncompensated(m, sim.campaign)
    assert u.table and u.mean_mm > 0.1
    table = re.compile(r"the tip relative to the table, the part's frame, (\d+) rows\): mean ([\d.]+) mm, "
                       r"max ([\d.]+) mm")
    assert main(["assess", str(tmp_path / "c.csv"), "--machine", "xyzac_trt"]) == 0
    assessed = table.search(capsys.readouterr().out).groups()
    assert main(["fit", "xyzac_trt", str(tmp_path / "c.csv"), "--model", "6dof", "--order", "3",
                 "--out", str(tmp_path / "m.json")]) == 0
    fitted = table.search(capsys.readouterr().out).groups()
    assert assessed == fitted == (str(len(u.rows)), f"{u.mean_mm:.4f}", f"{u.max_mm:.4f}")
    assert main(["evaluate", str(tmp_path / "m.json"), str(tmp_path / "c.csv"), "--json", str(tmp_path / "e.json")]) == 0
    capsys.readouterr()
    judged = json.loads((tmp_path / "e.json").read_text())["uncompensated"]["all"]
    assert judged["n"] == len(u.rows) and judged["mean"] == pytest.approx(u.mean_mm, rel=0.01)
