"""Reproduce the shapes of Section 3's Table 3.1 (spherical vs Cartesian tracker
coordinates on a long machine) and Table 3.3 (tracker points with and without 30 ball
bar points, one or two tool lengths) on simulated machines, beside the seed's numbers.

Table 3.1: the 12 m Ingersoll gantry, tracker noise 3 µm + 0.5 ppm in range and
5 µm + 5 ppm across, 212 commands x 2 tools, 6-DoF model of the true error family,
judged on 500 noise-free validation points. Table 3.3: the laboratory XYZCB machine
with an AP-family truth, the seed's variances (Table 3.2: axes 12.7 µm and 0.002 deg,
tracker 25.4 µm, ball bar 2.54 µm), AP order 6, judged on 3000 noise-free points.
The seed's numbers are a different (real or simulated) machine in thousandths of an
inch: compare the shapes.

Run: python examples/instruments_tables.py
"""
import numpy as np

import vecpin
from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.measurement.tracker import TrackerNoise, cartesian_to_spherical
from vecpin.simulation.truth import uniform_commands

THOU = 0.0254  # mm


def table_31():
    m = vecpin.Machine.load("ingersoll_xyzca")
    sim = simulate(m, seed=1, design=Design(n_commands=212, n_validation=50), mean_error_mm=0.4,
                   tracker_noise=TrackerNoise(3e-6, 0.5e-6, 5e-6, 5e-6))
    rng = np.random.default_rng(5)
    q = uniform_commands(m, 500, rng)
    tool = np.full(500, 0.21488)
    exact = sim.truth.measure(q, tool, None)
    print("Table 3.1: spherical vs Cartesian tracker coordinates (validation, mm)")
    print(f"  {'measurement type':<18s} {'seed mean':>10s} {'seed max':>9s} {'seed R':>8s} | {'mean':>8s} {'max':>8s} {'mean |R| resid.':>15s}")
    seed = {"cartesian": (1.70, 4.00, 1.23), "spherical": (1.42, 3.87, -0.02)}
    for inst in ("cartesian", "spherical"):
        noise = NoiseModel.default(m, inst, tracker=sim.truth.tracker.noise)
        model = make_model("6dof", m, 4, bases=sim.truth.family_bases()).fit(sim.campaign, noise)
        y = model.predict_tip(q, tool)
        d = np.linalg.norm(y - exact, axis=1)
        dR = np.abs(cartesian_to_spherical(exact)[:, 0] - cartesian_to_spherical(y)[:, 0])
        s = seed[inst]
        print(f"  {inst:<18s} {s[0] * THOU:10.4f} {s[1] * THOU:9.4f} {s[2] * THOU:8.4f} | {d.mean() * 1e3:8.4f} "
              f"{d.max() * 1e3:8.4f} {dR.mean() * 1e3:15.4f}")


def table_33():
    m = vecpin.Machine.load("flow_xyzcb")
    lt = TrackerNoise(25.4e-6, 0.0, 25.4e-6, 0.0)
    rng = np.random.default_rng(3)
    qv = uniform_commands(m, 3000, rng)
    tv = np.full(3000, 0.21488)
    seed = {(300, 0, 2): (0.6, 2.5), (300, 30, 2): (0.7, 2.4), (100, 0, 2): (1.4, 5.1), (100, 30, 2): (1.3, 5.0),
            (100, 0, 1): (1.7, 6.4), (100, 30, 1): (1.7, 7.1), (50, 0, 1): (13.5, 70.4), (50, 30, 1): (3.9, 17.2),
            (50, 0, 2): (6.7, 28.2), (50, 30, 2): (2.8, 13.1)}
    print("\nTable 3.3: tracker (LT) points with and without 30 ball bar (BB) points (validation, mm)")
    print(f"  {'LT':>4s} {'BB':>3s} {'tools':>5s} | {'seed mean':>9s} {'seed max':>9s} | {'mean':>8s} {'max':>8s}")
    for (n_lt, bb, n_tools), (s_mean, s_max) in seed.items():
        tools = (214.88, 312.86)[:n_tools]
        sim = simulate(m, seed=5, design=Design(n_commands=n_lt, tools_mm=tools, ballbar_points=bb), family="ap",
                       repeatability_mm=0.0127, repeatability_deg=0.002, tracker_noise=lt, mean_error_mm=0.65)
        noise = NoiseModel.default(m, "cartesian", cartesian_sigma=25.4e-6)
        noise.axis_sigma = np.array([12.7e-6] * 3 + [np.radians(0.002)] * 2)
        model = make_model("ap", m, 6).fit(sim.campaign, noise, underdetermined=True)
        d = np.linalg.norm(model.predict_tip(qv, tv) - sim.truth.measure(qv, tv, None), axis=1) * 1e3
        print(f"  {n_lt:4d} {bb:3d} {n_tools:5d} | {s_mean * THOU:9.4f} {s_max * THOU:9.4f} | {d.mean():8.4f} {d.max():8.4f}")


if __name__ == "__main__":
    table_31()
    table_33()
