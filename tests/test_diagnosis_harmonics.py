"""Issue 40: a periodic error the base model's Fourier series carry is named with its order and size
(vecpin.diagnosis.harmonics), and the twin-drive yaw candidate (twin_skew) moves the tip as a rotation does."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from vecpin.diagnosis.harmonics import base_harmonics
from vecpin.identification.folds import command_folds
from vecpin.identification.linearised import Linearised
from vecpin.kinematics.machine import Machine
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.basis import AxisBasis
from vecpin.models.effects import RotaryPeriodic, TipContext, TwinSkew
from vecpin.simulation.simulate import Design, simulate


def _named(effects, seed: int):
    """base_harmonics on an AP model (command perturbations, as the simulated rotary_periodic is) with Fourier
    order 14 (up to 7 cycles per turn) on C, the truth's bases elsewhere, fitted to a simulated flow_xyzcb
    campaign carrying ``effects``."""
    m = Machine.load("flow_xyzcb")
    sim = simulate(m, seed=seed, design=Design(n_commands=90, n_validation=2), effects=effects)
    camp = sim.campaign
    bases = [AxisBasis(a.lower, a.upper, 14, "fourier", rotary=True) if a.name == "C" else b
             for a, b in zip(m.axes, sim.truth.family_bases(4))]   # the truth's own family elsewhere
    noise = NoiseModel.default(m, "spherical")
    model = make_model("ap", m, bases=bases).fit(camp, noise)
    lin = Linearised(model, camp, noise)
    fold = command_folds(camp, 5, np.random.default_rng(0))
    return base_harmonics(model, lin, lin.folded(fold).evaluate(), fold, [],
                          SimpleNamespace(alpha=0.01, min_shrink_pct=2.0))


@pytest.mark.parametrize("with_effect", [True, False])
def test_a_harmonic_in_the_base_series_is_named_with_its_order(with_effect):
    m = Machine.load("flow_xyzcb")
    # the simulated rotary_periodic: 5 and 7 cycles per turn of C in every command (7 at 0.6 of 5)
    effects = [RotaryPeriodic(m, ("C",), strength_mm=0.1, seed=2)] if with_effect else []
    found = _named(effects, 11)
    if not with_effect:
        assert found == []
        return
    assert [f.label for f in found] == ["rotary_periodic[C]"]
    f = found[0]
    assert f.accepted and f.in_base and "5 cycles per turn of C" in f.evidence
    assert f.heldout_mean_mm_after < f.heldout_mean_mm_before and f.size_mm > 0.02


def test_twin_skew_moves_the_tip_by_a_rotation_of_beam_and_carriage_together():
    m = Machine.load("master_mill")
    cands = {c.axes: c for c in TwinSkew.candidates(m, None)}
    eff = cands[("X", "Y")]                         # Y rides on X
    rng = np.random.default_rng(1)
    q = m.lower + rng.uniform(size=(20, m.n_axes)) * (m.upper - m.lower)
    tip = m.tool_tip(q, 0.1)
    F = m.joint_frames(q, "X")
    axis = F[:, :3, "xyz".index(eff.about)]
    # the rotation axis is the normal of the plane X and Y move in (closed form from their directions)
    dx = F[0, :3, :3] @ np.asarray(m.axis("X").direction)
    dy = m.joint_frames(q[:1], "Y")[0, :3, :3] @ np.asarray(m.axis("Y").direction)
    n = np.cross(dx, dy)
    assert abs(axis[0] @ n) / np.linalg.norm(n) > 0.99
    theta = rng.normal(size=eff.n_parameters) * 1e-6
    moved = eff.tip(TipContext(m, q, tip, np.zeros_like(tip)), None) @ theta
    # the angle: products of Chebyshev T1..T3 of both normalised positions; the move: a small rotation (Rodrigues)
    u = [2 * (q[:, m.axis(a).index] - m.axis(a).lower) / (m.axis(a).upper - m.axis(a).lower) - 1 for a in "XY"]
    T = [np.stack([np.cos(k * np.arccos(np.clip(x, -1, 1))) for k in (1, 2, 3)], axis=1) for x in u]
    angle = np.einsum("pi,pj,ij->p", T[0], T[1], theta.reshape(3, 3))
    arm = tip - F[:, :3, 3]
    exact = (np.cos(angle) - 1)[:, None] * arm + np.sin(angle)[:, None] * np.cross(axis, arm) + \
        (1 - np.cos(angle))[:, None] * axis * np.sum(axis * arm, axis=1)[:, None]
    np.testing.assert_allclose(moved, exact, atol=1e-10)   # the rotation to first order in the angle
