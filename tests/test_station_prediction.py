"""The plan's prediction of a two-station plan (issue 24 left it reading station 1's rows
as station 0's, without station 1's pose unknowns): each row is read from where its
station stands and the second set-up's six pose unknowns are counted.

Checked by closed form (a reading's dependence on its station's pose correction does not
depend on which station reads it; a reading from a station is the reading of a tracker
standing there) and against refits of simulated campaigns: the scatter of the fitted
model's tool tip relative to the workpiece over 20 campaigns of one true machine with
fresh noise against the predicted 1-sigma."""
import warnings

import numpy as np
import pytest

from vecpin.errors import VecpinWarning
from vecpin.kinematics.so3 import skew
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.planning.information import Information
from vecpin.planning.plan import PlanSettings, make_plan, score_rows
from vecpin.planning.problem import planned_model
from vecpin.simulation.simulate import simulate
from vecpin.simulation.truth import TrueMachine

POSE = [f"{c}" for c in ("dx", "dy", "dz", "ex", "ey", "ez")]


def test_a_reading_from_the_second_station_is_a_reading_from_where_it_stands(machines):
    """The same tool and nest readings of the A-C trunnion, once from station 1 of a
    two-station problem and once from a one-station problem whose tracker stands where
    station 1 does (spherical noise: the whitening depends on the range): equal rows, with
    station 1's pose columns where the other has E_0's and zeros in E_0's."""
    m = machines["trunnion_xyzac"]
    model = make_model("6dof", m, 2)
    noise = NoiseModel.default(m, "spherical")
    nests = {"1": np.array([-0.1, 0.0, 0.02]), "2": np.array([0.1, 0.0, 0.02]), "3": np.array([0.0, 0.1, 0.02])}
    first, second = np.array([0.0, 2.2, 0.7]), np.array([1.6, 1.6, 1.2])
    two = Information(model, noise, first, [0.2], keep=np.ones(6 + model.n_parameters + 15, bool), nests=nests,
                      stations=[second])
    there = Information(model, noise, second, [0.2], keep=np.ones(6 + model.n_parameters + 9, bool), nests=nests)
    q = m.lower + np.random.default_rng(3).random((8, m.n_axes)) * (m.upper - m.lower)
    q, tool = np.repeat(q, 2, axis=0), np.full(16, 0.2)
    instrument = np.tile(np.array(["tracker", "nest"], dtype=object), 8)
    target = np.where(instrument == "nest", np.tile(["", "2"], 8), "").astype(object)
    W2 = two.measurement_rows(q, tool, instrument, target, np.ones(16, int))
    Wt = there.measurement_rows(q, tool, instrument, target)
    pose = [two.names.index(f"station1.{c}") for c in POSE]
    assert two.names[-6:] == [f"station1.{c}" for c in POSE]
    np.testing.assert_array_equal(W2[:, :, :6], 0.0)
    np.testing.assert_allclose(W2[:, :, pose], Wt[:, :, :6], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(W2[:, :, 6:pose[0]], Wt[:, :, 6:], rtol=1e-12, atol=1e-12)


def _rigid_free(dev: np.ndarray, p: np.ndarray) -> np.ndarray:
    """(S, N, 3) deviations with each draw's best-fit small rigid motion about the points p
    (N,3) removed (least squares on t + w x (p - mean))."""
    A = np.concatenate([np.broadcast_to(np.eye(3), (len(p), 3, 3)), -skew(p - p.mean(axis=0))], axis=2).reshape(-1, 6)
    D = dev.reshape(len(dev), -1)
    x = np.linalg.lstsq(A, D.T, rcond=None)[0]
    return (D - (A @ x).T).reshape(dev.shape)


@pytest.mark.slow
def test_the_two_station_prediction_matches_the_scatter_of_refits(machines):
    """The A-C trunnion's two-station plan of PlanSettings' defaults (AP order 4): 20
    campaigns of one true machine with fresh noise, each read as the plan says (station
    1's block from where it stands), fitted with the plan's model; the scatter of the
    fitted tip relative to the workpiece at the plan's validation commands (rigid motion
    removed, as the prediction does) against the predicted 1-sigma: within 20 % (measured
    6.66 against 6.71 um, 0.99; AP order 6 0.98, the command line's 6-DoF order 6 0.99).
    The second set-up costs: the prediction with station 1's pose unknown is above the
    same rows with it known (measured 6.71 against 6.52 um)."""
    m = machines["trunnion_xyzac"]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", VecpinWarning)
        plan = make_plan(m, PlanSettings(seed=0))
    info, t = plan.information, plan.template
    assert len(info.stations) == 1 and info.names[-6:] == [f"station1.{c}" for c in POSE]
    pred = plan.score.predicted.rms_1sigma
    W = info.compact_rows(t.q, t.tool, t.instrument, t.target, t.stations)
    W[:, -6:] = 0.0  # the pose known: its columns tell nothing
    known = info.predicted_errors(info.posterior(W), plan.validation, float(plan.tools[0])).rms_1sigma
    assert known < pred
    again, _ = score_rows(info, t, plan.validation, float(plan.tools[0]), "again")
    assert again.predicted.rms_1sigma == pred
    truth = TrueMachine.random(m, np.random.default_rng(123))
    q, tool = plan.validation, np.full(len(plan.validation), float(plan.tools[0]))
    tips = []
    for seed in range(1, 21):
        sim = simulate(m, seed=seed, truth=truth, plan=t, station_positions=plan.placement.stations)
        model = planned_model(m, plan.settings)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", VecpinWarning)
            model.fit(sim.campaign, info.noise)
        tips.append(model.tool_tip(q, tool, model.b_, jacobian=False, frame="workpiece").tip)
    tips = np.array(tips)
    dev = _rigid_free(tips - tips.mean(axis=0), tips.mean(axis=0))
    scatter = np.sqrt((dev ** 2).sum(axis=(0, 2)) / (len(tips) - 1)).mean()
    assert 0.8 < scatter / pred < 1.2, (scatter, pred)
