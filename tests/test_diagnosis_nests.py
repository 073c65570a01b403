"""Diagnosis on a table machine with nests (issue 14): the candidate effects' columns on
nest rows (points fixed on the table) against finite differences of the model with the
effect, through the one likelihood; a table-axis effect found alone."""
import copy

import numpy as np
import pytest

from vecpin.diagnosis.diagnose import diagnose
from vecpin.diagnosis.scoring import Kinematics, candidate_effects, effect_columns
from vecpin.identification.linearised import Linearised
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.simulate import Design, simulate

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI


@pytest.fixture(scope="module")
def trunnion_fit(machines):
    m = machines["trunnion_xyzac"]
    c = simulate(m, seed=4, design=Design(n_commands=60, nests=3)).campaign
    noise = NoiseModel.default(m, "spherical")
    base = make_model("6dof", m, 3).fit(c, noise)
    f = Features.from_campaign(c)
    lin = Linearised(base, c, noise, f)
    return m, c, noise, base, f, lin, Kinematics(base, lin, f)


def _fd_columns(base, c, f, eff):
    """-(d metric residual / d parameter) x prior, central differences of the fitted
    model with the effect added (its parameters around zero)."""
    em = base.with_effects([eff])
    em.e0_, em.setup_, em.noise_, em.report_ = base.e0_, copy.deepcopy(base.setup_), base.noise_, base.report_
    prior = np.array([p.prior for p in eff.parameters()])
    cols = []
    for j, s in enumerate(prior):
        out = []
        for sign in (1, -1):
            p = np.zeros(len(prior))
            p[j] = sign * 1e-3 * s
            em.b_ = np.r_[base.b_, p]
            out.append(em.row_residuals(c, f).metric)
        cols.append(-(out[0] - out[1]) / (2e-3 * s) * s)
    return np.stack(cols, axis=-1)


@pytest.mark.parametrize("name", ["backlash", "thermal", "gantry_skew", "rotary_periodic"])
def test_effect_columns_on_nest_rows_equal_finite_differences(trunnion_fit, name):
    m, c, noise, base, f, lin, kin = trunnion_fit
    nest = c.instrument == "nest"
    assert nest.sum() == 180
    cands = candidate_effects(m, f, [name])
    for eff in cands[:2] + cands[-1:]:
        eff.prepare(c, f)
        A, _ = effect_columns(kin, lin, eff, f)
        fd = _fd_columns(base, c, f, eff)
        assert np.abs(A - fd).max() <= 1e-6 * np.abs(fd).max(), eff.label
    # a table axis' backlash moves the nests and not the tool tips (base frame), a tool axis' the reverse
    if name == "backlash":
        by = {e.label: e for e in cands}
        A_t, _ = effect_columns(kin, lin, by["backlash[A]"], f)
        A_x, _ = effect_columns(kin, lin, by["backlash[X]"], f)
        assert np.abs(A_t[nest]).max() > 0 and np.abs(A_t[~nest]).max() == 0
        assert np.abs(A_x[~nest]).max() > 0 and np.abs(A_x[nest]).max() == 0


def test_table_axis_backlash_on_a_campaign_with_nests_is_found_alone(machines):
    """Backlash of the tilting table A of trunnion_xyzac moves the nests (the part), not
    the tool tips: the simulation scales it by the tip's displacement relative to the
    part, and the diagnosis names it alone, with no row flagged as an outlier."""
    m = machines["trunnion_xyzac"]
    spec = TrueEffect("backlash", ("A",), 0.03, seed=2)
    sim = simulate(m, seed=10, design=Design(n_commands=200, nests=3), effects=[spec])
    clean = simulate(m, seed=10, design=Design(n_commands=200, nests=3))
    nest = sim.campaign.instrument == "nest"
    moved = np.linalg.norm(sim.campaign.xyz - clean.campaign.xyz, axis=1)
    assert moved[nest].mean() > 5e-6 and moved[~nest].max() < 1e-12
    d = diagnose(m, sim.campaign)
    assert [e.label for e in d.accepted] == ["backlash[A]"], [e.label for e in d.effects[:3]]
    assert not d.outlier_rows and not d.outlier_lines
    assert d.best[0] < 0.95 * d.base["heldout_mean_mm"]
