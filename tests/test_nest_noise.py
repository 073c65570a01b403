"""The tracker noise at the tip through the table nests, from first principles.

A validation run of a table machine judges the tool tip relative to the table: at each
command the nests' known positions p_i (table frame, i = 1..n) are registered rigidly on
their readings q_i = R p_i + t + e_i, and the tool's reading is taken back through that
pose. With the readings' noise e_i independent, N(0, sigma^2 I) per axis, linearise about
the true pose with the nests centred on their centroid (sum p_i = 0): the registration's
error is a translation tau at the centroid and a small rotation w, e_i ~ tau + w x p_i.
Least squares gives tau = mean(e_i), covariance sigma^2 / n I, and w = J^-1 sum p_i x e_i
with J = sum(|p_i|^2 I - p_i p_i^T), covariance sigma^2 J^-1, uncorrelated with tau (the
cross term is sum p_i = 0). A tip at d from the centroid read with its own noise
(sigma_t per axis) is then off by e_tool - tau - w x d, whose mean square is

    E|delta|^2 = 3 sigma_t^2 + 3 sigma^2 / n + sigma^2 tr([d]x J^-1 [d]x^T).

For n >= 3 nests evenly on a circle of radius r in a plane, J = n r^2 diag(1/2, 1/2, 1)
and the last term is sigma^2 (3 rho^2 + 4 h^2) / (n r^2) for a tip at rho in the plane and
h above it: per axis sigma^2 (1/n + k (lever / r)^2 / n), k from 1 (lever in the plane)
to 4/3 (lever across it). Reading every point m times and taking the mean divides sigma^2
and sigma_t^2 by m (the tracker's noise, drawn afresh for every reading; the machine's
positioning noise, the same for every reading at a standstill, is not divided:
tests/test_standstill.py). Checked here by Monte Carlo with scipy's Kabsch
(``Rotation.align_vectors``), not vecpin's registration; vecpin's own figure
(:func:`~vecpin.measurement.tableframe.tip_noise`, what evaluate and verify print) against
the same Monte Carlo; and the default nests of every bundled table machine seen from the
plan's tracker at least where the nests of the former rule (80 % of the table radius) were.
"""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from scipy.stats import qmc

from vecpin.measurement.campaign import Campaign
from vecpin.measurement.tableframe import table_tips, tip_noise
from vecpin.measurement.tracker import TrackerNoise
from vecpin.planning import nestplacement
from vecpin.planning import nests as nests_module
from vecpin.planning.nestplacement import Placement, nests_seen, place_nests
from vecpin.planning.nests import MAX_REACH, NEST_EDGE, TABLE_SHARE, VALIDATION_READS, nest_positions, table_radius
from vecpin.planning.problem import PlanSettings, plan_problem
from vecpin.units import M_PER_MM

TABLE_MACHINES = ["trunnion_xyzac", "trunnion_xyzbc", "head_table_bc", "xyzac_trt"]


def closed_form_ms(P: np.ndarray, tip: np.ndarray, sigma: float, sigma_t: float) -> float:
    """E|delta|^2 [m^2] of the tip (3,) measured relative to the nests P (n,3), both in the
    table frame (module text: d is the tip from the nests' centroid)."""
    c, d = P - P.mean(axis=0), tip - P.mean(axis=0)
    J = np.sum([c_ @ c_ * np.eye(3) - np.outer(c_, c_) for c_ in c], axis=0)
    dx = np.array([[0, -d[2], d[1]], [d[2], 0, -d[0]], [-d[1], d[0], 0]])
    return 3 * sigma_t**2 + 3 * sigma**2 / len(P) + sigma**2 * np.trace(dx @ np.linalg.inv(J) @ dx.T)


def ring_ms(n: int, r: float, rho: float, h: float, sigma: float, sigma_t: float) -> float:
    """The same for n nests evenly on a circle of radius r, the tip at rho in its plane and h above."""
    return 3 * sigma_t**2 + sigma**2 / n * (3 + (3 * rho**2 + 4 * h**2) / r**2)


def scipy_tip_errors(P: np.ndarray, tip: np.ndarray, sigma: float, sigma_t: float, reads: int, draws: int,
                     seed: int = 0) -> np.ndarray:
    """(draws,3) [m] the tip relative to the table measured minus true: a random table pose,
    every nest and the tip read ``reads`` times with per-axis noise and averaged, the nests
    registered by scipy's Kabsch, the tip's reading taken back through it."""
    rng = np.random.default_rng(seed)
    out = np.empty((draws, 3))
    for k in range(draws):
        R = Rotation.random(random_state=rng).as_matrix()
        t = rng.uniform(-2, 2, 3)
        Q = P @ R.T + t + rng.normal(0, sigma, (reads,) + P.shape).mean(axis=0)
        tool = tip @ R.T + t + rng.normal(0, sigma_t, (reads, 3)).mean(axis=0)
        rot, _ = Rotation.align_vectors(Q - Q.mean(axis=0), P - P.mean(axis=0))
        out[k] = (tool - Q.mean(axis=0)) @ rot.as_matrix() + P.mean(axis=0) - tip
    return out


@pytest.mark.parametrize("n, r, rho, h", [(3, 0.128, 0.0, 0.3), (3, 0.14, 0.2, 0.25), (6, 0.3, 0.5, 0.7)])
def test_the_closed_form_of_the_ring_agrees_with_scipys_kabsch(n, r, rho, h):
    """n nests evenly on a circle of radius r [m] (one plane), the tip at rho in the plane and
    h above it, 10 um per axis on the nests, 12 um on the tool: the ring's closed form, the
    general one (J from the positions) and 4000 scipy registrations agree (MC: 3 sd ~ 7 %)."""
    a = 2 * np.pi * np.arange(n) / n + 0.3
    P = np.c_[r * np.cos(a), r * np.sin(a), np.zeros(n)]
    tip = np.array([rho, 0.0, h])
    sigma, sigma_t = 10e-6, 12e-6
    ring = ring_ms(n, r, rho, h, sigma, sigma_t)
    assert closed_form_ms(P, tip, sigma, sigma_t) == pytest.approx(ring, rel=1e-12)
    mc = np.mean(np.sum(scipy_tip_errors(P, tip, sigma, sigma_t, 1, 4000) ** 2, axis=1))
    assert mc == pytest.approx(ring, rel=0.07)


def test_the_default_nests_and_repeated_readings_against_scipys_kabsch(machines):
    """The default nests of the A-C trunnion (not on one plane: 20-80 mm high), a tip 0.3 m
    above the table, every point read VALIDATION_READS times and averaged (tracker noise
    only): the general closed form agrees with scipy's Monte Carlo, and the noise at the
    tip falls by sqrt(reads)."""
    P = np.array(list(nest_positions(machines["trunnion_xyzac"], 3).values()))
    tip = np.array([0.05, -0.1, 0.3])
    sigma = sigma_t = 11e-6
    m = VALIDATION_READS
    mc = np.mean(np.sum(scipy_tip_errors(P, tip, sigma, sigma_t, m, 4000, seed=1) ** 2, axis=1))
    assert mc == pytest.approx(closed_form_ms(P, tip, sigma / np.sqrt(m), sigma_t / np.sqrt(m)), rel=0.07)
    assert closed_form_ms(P, tip, sigma / np.sqrt(m), sigma_t / np.sqrt(m)) == pytest.approx(
        closed_form_ms(P, tip, sigma, sigma_t) / m)


def _run(P: np.ndarray, tips: np.ndarray, reads: int, seed: int = 2) -> Campaign:
    """A noise-free validation run of G commands (tips (G,3) on the table, nests P (n,3)):
    the table at a random pose 2-3 m from the tracker at each command, the tool read
    ``reads`` times, then each nest ``reads`` times."""
    rng = np.random.default_rng(seed)
    q, xyz, inst, target = [], [], [], []
    for g, tip in enumerate(tips):
        R = Rotation.random(random_state=rng).as_matrix()
        t = np.array([2.5, 0.0, 0.0]) + rng.uniform(-0.3, 0.3, 3)
        for what, point, name in [("tracker", tip, "")] + [("nest", p, str(k + 1)) for k, p in enumerate(P)]:
            for _ in range(reads):
                q.append([0.001 * g, 0.0])
                xyz.append(R @ point + t)
                inst.append(what)
                target.append(name)
    N = len(q)
    return Campaign(["X", "A"], np.array(q), np.full(N, 0.2), np.array(xyz), {}, "run.csv",
                    np.array(inst, dtype=object), target=np.array(target, dtype=object))


def test_vecpins_tip_noise_is_the_scipy_monte_carlo_and_falls_with_the_readings():
    """tableframe.tip_noise (evaluate's and verify's 'tracker noise through the nest
    registration') on a run of 150 commands, isotropic tracker noise of 10 um: the mean
    displacement scipy's Monte Carlo gives for the same geometry, once with one reading per
    point and once with VALIDATION_READS in a row averaged (then sqrt(reads) smaller)."""
    a = np.array([0.2, 2.3, 4.4])
    P = np.c_[0.14 * np.cos(a), 0.14 * np.sin(a), [0.02, 0.05, 0.08]]
    tips = np.c_[qmc.Halton(2, seed=3).random(150) * 0.3 - 0.15, np.full(150, 0.25)]
    noise = TrackerNoise(range_const=10e-6, range_ppm=0.0, transverse_const=10e-6, transverse_ppm=0.0)
    got = {}
    for reads in (1, VALIDATION_READS):
        run = _run(P, tips, reads)
        tt = table_tips(run, {str(k + 1): p for k, p in enumerate(P)})
        assert tt.commands == 150 and len(tt.rows) == 150 and not len(tt.unjudged)
        got[reads] = tip_noise(run, tt, noise, draws=20).mean()
        mc = np.mean([np.linalg.norm(scipy_tip_errors(P, tip, 10e-6, 10e-6, reads, 20, seed=k), axis=1).mean()
                      for k, tip in enumerate(tips)])
        assert got[reads] == pytest.approx(mc, rel=0.05)
    assert got[VALIDATION_READS] == pytest.approx(got[1] / np.sqrt(VALIDATION_READS), rel=0.08)


def _former_reach(machine) -> float:
    """The default nests' radius [m] before the nests went to the table's edge: at most
    TABLE_SHARE of the table radius, 40 % of half the tool tips' span and MAX_REACH."""
    q = machine.lower + qmc.Halton(machine.n_axes, seed=0).random(256) * (machine.upper - machine.lower)
    rel = machine.tool_tip(q, 0.2, frame="workpiece")
    reach = min(MAX_REACH, 0.4 * 0.5 * float(np.ptp(rel[:, :2], axis=0).min()))
    table = table_radius(machine)
    return reach if table is None else min(reach, TABLE_SHARE * table)


@pytest.mark.parametrize("name", TABLE_MACHINES)
def test_default_nests_at_the_table_edge_are_seen_where_the_former_ones_were(machines, name, monkeypatch):
    """From the plan's tracker, at the commands the plan's placement samples over the tilt
    range: the default nests (NEST_EDGE inside the table's edge) give three nests seen
    at no fewer commands and in every tenth of the table travel where the former default
    nests (TABLE_SHARE of the radius) did; the placed nests and stations cover as much
    travel as with the former candidate circles."""
    m = machines[name]
    assert m.has_workpiece
    settings = PlanSettings(seed=0)
    problem = plan_problem(m, settings)
    pl, tool = problem.placement, settings.tools_mm[0] * M_PER_MM
    sight = dict(tool_radius=settings.tool_radius_mm * M_PER_MM, target_clearance=settings.target_clearance_mm * M_PER_MM)
    new = nest_positions(m, 3)
    assert np.hypot(*np.array(list(new.values()))[:, :2].T) == pytest.approx(table_radius(m) - NEST_EDGE)
    scale = _former_reach(m) / (table_radius(m) - NEST_EDGE)
    old = {k: np.r_[p[:2] * scale, p[2]] for k, p in new.items()}
    seen = {label: nests_seen(m, problem.tracker, pl.commands, ns, tool, **sight).sum(axis=1) >= 3
            for label, ns in (("new", new), ("old", old))}
    assert seen["new"].sum() >= seen["old"].sum()
    for b in nestplacement._bins(m, pl.commands):
        for k in np.unique(b[seen["old"]]):
            assert seen["new"][b == k].any()
    monkeypatch.setattr(nests_module, "nest_reach", _former_reach)
    monkeypatch.setattr(nestplacement, "nest_reach", _former_reach)
    former = place_nests(m, problem.tracker, 3, tool, seed=0, geometry=settings.geometry, **sight)
    assert Placement.travel_seen(pl.covered) >= Placement.travel_seen(former.covered)
    assert Placement.commands_seen(pl.covered) >= Placement.commands_seen(former.covered) - 0.02
