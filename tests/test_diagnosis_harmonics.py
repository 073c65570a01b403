"""Issue 40: a periodic error the base model's Fourier series carry is named with its order and size
(vecpin.diagnosis.harmonics) when it stands out of the axis' smooth error as a spectral line (a broadband
error with the same content at that order is not), and the twin-drive yaw candidate (twin_skew) moves the
tip as a rotation does."""
from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from vecpin.diagnosis.harmonics import _matters, base_harmonics
from vecpin.identification.folds import command_folds
from vecpin.identification.linearised import Linearised
from vecpin.kinematics.machine import Machine
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.basis import AxisBasis
from vecpin.models.effects import RotaryPeriodic, TipContext, TwinSkew
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import ErrorFunction, TrueMachine


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


def _on_c(line: bool, seed: int = 3):
    """A 6-DoF model with harmonics 1..6 per turn on C fitted to a flow_xyzcb campaign whose C errors (all six
    functions, 40 µm / 80 µrad scales, random phases) have a spectrum exp(-k²/2w²) over 1..8 cycles per turn:
    ``line`` a smooth one (w = 1.2) plus 3 cycles at the broadband one's level there, else the broadband one
    (w = 3: the same content at 3, and at 2, 4, 5 more). Returns (model, linearised, folds)."""
    m = Machine.load("flow_xyzcb")
    rng = np.random.default_rng(seed)
    truth = TrueMachine.random(m, rng)
    k = np.arange(1, 9)
    amp = np.exp(-0.5 * (k / (1.2 if line else 3.0)) ** 2)
    if line:
        amp[2] = math.exp(-0.5 * (3 / 3.0) ** 2)
    for comp in range(6):
        s = (40e-6 if comp < 3 else 80e-6) * rng.uniform(0.5, 1.5)
        ph = rng.uniform(0, 2 * np.pi, len(k))
        truth.errors[m.axis("C").index][comp] = ErrorFunction([], [(float(h), s * a * np.cos(p), s * a * np.sin(p))
                                                                   for h, a, p in zip(k, amp, ph)])
    camp = simulate(m, seed=seed, design=Design(n_commands=90, n_validation=2), truth=truth).campaign
    bases = [AxisBasis(a.lower, a.upper, 12, "fourier", rotary=True) if a.name == "C" else b
             for a, b in zip(m.axes, truth.family_bases(4))]
    noise = NoiseModel.default(m, "spherical")
    model = make_model("6dof", m, bases=bases).fit(camp, noise)
    lin = Linearised(model, camp, noise)
    return model, lin, command_folds(camp, 5, np.random.default_rng(0))


@pytest.mark.parametrize("line", [True, False])
def test_a_line_at_3_cycles_is_named_and_a_broadband_error_with_the_same_content_is_not(line):
    model, lin, fold = _on_c(line)
    settings = SimpleNamespace(alpha=0.01, min_shrink_pct=2.0)
    found = base_harmonics(model, lin, lin.folded(fold).evaluate(), fold, [], settings)
    # harmonic 3 matters to the model in both (significant given the rest, held-out shrink): the content is there
    s, size, _ = _matters(model, lin, fold, "C", 3)
    assert s["p"] < 1e-6 and s["p_heldout"] < 1e-6 and size > 0.03
    if line:
        assert [f.label for f in found] == ["rotary_periodic[C]"]
        assert "3 cycles per turn of C" in found[0].evidence and "stands out" in found[0].evidence
    else:   # 2, 4 and 5 cycles matter too (the old rule named 4): a smooth spectrum, no line
        assert all(_matters(model, lin, fold, "C", h)[0]["p"] < 1e-6 for h in (2, 4, 5))
        assert found == []


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
