"""The reference design of --underdetermined (structural redundancy) on a machine with a
workpiece: table points (nests) keep the table axes' terms."""
import numpy as np

from vecpin.identification.fit import REFERENCE_NESTS, reference_nests, structural_redundancy
from vecpin.identification.likelihood import Likelihood
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate


def test_reference_design_with_nests_matches_a_measured_campaign(machines):
    m = machines["trunnion_xyzac"]
    model = make_model("6dof", m, 4)
    noise = NoiseModel.default(m, "spherical")
    red, ratio = structural_redundancy(model, np.array([0.21488, 0.31286]), noise)
    names = model.parameter_names
    assert red.size == ratio.size == 6 + len(names)
    # a measured campaign of tool tips and 3 table nests (simulated, positions unknown to
    # the fit): its own redundancy, from its own rows, is the same set of terms
    sim = simulate(m, seed=1, design=Design(n_commands=300, nests=3))
    assert set(np.unique(sim.campaign.instrument)) == {"tracker", "nest"}
    lik = Likelihood(model, sim.campaign, noise)
    _, G, _, _ = lik.normal_equations(np.zeros(lik.n_unknowns))
    measured, _ = lik.redundancy(np.zeros(lik.n_unknowns), np.sqrt(np.diag(G)))
    assert np.array_equal(red, measured[:red.size])
    # the table axes keep most of their terms (a tool-rows-only design removed all of them)
    for ax in ("A", "C"):
        sel = np.array([n.split(".")[0] == ax for n in names])
        assert red[6:][sel].sum() < 0.5 * sel.sum(), (ax, red[6:][sel].sum())


def test_reference_nests_are_on_the_table_and_not_collinear(machines):
    for name in ("trunnion_xyzac", "flow_xyzcb"):
        m = machines[name]
        p = np.array(list(reference_nests(m).values()))
        assert p.shape == (REFERENCE_NESTS, 3)
        assert np.all(np.linalg.norm(p[:, :2], axis=1) >= 0.05 - 1e-12)
        assert np.linalg.matrix_rank(p[1:] - p[0], tol=1e-6) == 3  # not on one plane, so not on a line
