"""Model names a metrologist reads: "Chebyshev order 7 on X", "spline, 15 knots on Y"
in the fit's summary, the model choice's verdict, evaluate and verify, not 'cheb7/...'
nor "order 15" for a 15-knot spline."""
import numpy as np

from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.basis import basis_text, bases_text
from vecpin.selection.choice import Candidate
from vecpin.selection.design import AxisChoice
from vecpin.simulation.simulate import Design, simulate


def test_bases_in_words():
    assert basis_text("chebyshev", 7) == "Chebyshev order 7"
    assert basis_text("bspline", 3, knots=15) == "spline, 15 knots"
    assert basis_text("fourier_trend", 6, trend=2) == "Fourier order 6 with a trend of order 2"
    assert bases_text("AP", ["X", "Y"], ["Chebyshev order 4"] * 2) == "AP with Chebyshev order 4 on every axis"
    assert bases_text("6-DoF", ["X", "Y", "Z"], ["Chebyshev order 7", "spline, 15 knots", "Chebyshev order 7"]) == \
        "6-DoF with Chebyshev order 7 on X and Z; spline, 15 knots on Y"


def test_a_chosen_mixed_model_is_named_in_words_everywhere(flow):
    axes = (AxisChoice("chebyshev", 3), AxisChoice("spline", 15), AxisChoice("chebyshev", 2),
            AxisChoice("fourier", 2), AxisChoice("chebyshev", 2))
    cand = Candidate("ap", axes, 40, np.array([0.01, 0.02]))
    assert cand.label() == "AP cheb3/spline15/cheb2/fourier2/cheb2"  # the choice table keeps its compact column
    words = cand.label(flow.axis_names)
    assert words == ("AP with Chebyshev order 3 on X; spline, 15 knots on Y; Chebyshev order 2 on Z and B; "
                     "Fourier order 2 on C")
    model = cand.model(flow)
    assert model.label() == words and model.order == 15
    sim = simulate(flow, 3, Design(n_commands=150, n_validation=6), mean_error_mm=0.3)
    model.fit(sim.campaign, NoiseModel.default(flow, "spherical"))
    first = model.report_.summary().splitlines()[0]
    assert first.startswith(words + ", ") and "order 15" not in first
    # a plain model keeps its one order, in words
    plain = make_model("6dof", flow, 2)
    assert plain.label().startswith("6-DoF with Chebyshev order 2 on ")
