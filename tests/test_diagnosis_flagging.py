"""Rows flagged as gross errors are judged again under the final model within the whole
campaign: an effect that follows the rows' history (a warm-up seen through a lag) gives
the flagged rows the history they had in the fit, not a history made of the flagged rows
alone (which turned three ordinary late rows of a warm-up into 'outliers')."""
import numpy as np

import vecpin
from vecpin.diagnosis.flagging import still_gross
from vecpin.identification.folds import command_folds
from vecpin.identification.linearised import Linearised
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.models.effects.thermal import Thermal
from vecpin.simulation.simulate import Design, simulate


def test_flagged_rows_of_a_lagged_warm_up_are_judged_with_the_whole_history():
    m = vecpin.Machine.load("flow_xyzcb")
    noise = NoiseModel.default(m, "spherical")
    c = simulate(m, seed=3, design=Design(n_commands=120, n_validation=10),
                 effects=[Thermal(m, lag_h=2.0, strength_mm=0.08, seed=1)]).campaign
    late = np.argsort(c.time)[-3:]                       # three ordinary rows at the end of the warm-up
    rows = np.setdiff1d(np.arange(len(c)), late)
    feats = Features.from_campaign(c)
    model = make_model("6dof", m, 3).with_effects([Thermal(m, lag_h=2.0)]).fit(c.subset(rows), noise)
    fold = command_folds(c, 5, np.random.default_rng(0))
    lin = Linearised(model, c.subset(rows), noise, feats.subset(rows))
    ev = lin.folded(fold[rows]).evaluate()
    still, _ = still_gross(model, lin, ev, fold[rows], c, late, noise, feats, rows)
    assert still.size == 0, still
    # the history matters: the late rows' residuals computed from themselves alone are several times larger
    whole = np.linalg.norm(model.row_residuals(c, feats).metric[late], axis=1)
    alone = np.linalg.norm(model.row_residuals(c.subset(late), feats.subset(late)).metric, axis=1)
    assert np.all(alone > 3 * whole), (alone, whole)


def test_rows_an_effect_fitted_to_the_other_rows_predicts_are_not_gross_errors():
    """A backlash of X misfits the rows read after X reversed; before it is in the model the worst of them look
    like gross errors. With backlash fitted to the other rows (the flagged ones left out), those rows are within
    the noise: kept. A real gross error (0.5 mm on one row) is predicted by no candidate fitted without it."""
    from vecpin.diagnosis.flagging import explained_by_effects
    from vecpin.simulation.effects import TrueEffect
    m = vecpin.Machine.load("flow_xyzcb")
    noise = NoiseModel.default(m, "spherical")
    c = simulate(m, seed=12, design=Design(n_commands=60, n_validation=5),
                 effects=[TrueEffect("backlash", ("X",), 0.05, seed=2)]).campaign
    gross = 7
    c.xyz[gross] += 5e-4 / np.sqrt(3)                   # 0.5 mm
    feats = Features.from_campaign(c)
    plain = make_model("6dof", m, 3).fit(c, noise)
    miss = np.linalg.norm(plain.row_residuals(c, feats).metric, axis=1)
    worst = np.setdiff1d(np.argsort(miss)[-6:], [gross])[-3:]   # the backlash rows the plain model misfits most
    flagged = np.r_[worst, gross]
    rows = np.setdiff1d(np.arange(len(c)), flagged)
    base = make_model("6dof", m, 3).fit(c.subset(rows), noise)
    back, by = explained_by_effects(base, c, noise, feats, rows, flagged, ["backlash", "thermal"], 0.01)
    assert gross not in back and set(back) & set(worst), (back, worst)
    assert by and all(b.startswith("backlash") for b in by), by
    # and with no effect that could: nothing is put back
    assert explained_by_effects(base, c, noise, feats, rows, flagged, ["thermal"], 0.01)[0].size == 0


def test_a_first_reading_whose_approach_the_file_does_not_say_is_judged_at_either():
    """A campaign file that starts after X moved: its first row carries half a reversal of backlash the file
    cannot place (approach direction 0, read as the middle of the lost motion). Judged at either approach it
    could have had, the model with backlash explains it; the same row with a 0.5 mm gross error stays."""
    from vecpin.diagnosis.flagging import at_unknown_approach
    from vecpin.diagnosis.grosserrors import beyond, robust_level
    from vecpin.models.effects.backlash import Backlash
    from vecpin.simulation.effects import TrueEffect
    m = vecpin.Machine.load("flow_xyzcb")
    x = m.axis_names.index("X")
    noise = NoiseModel.default(m, "spherical")
    full = simulate(m, seed=12, design=Design(n_commands=60, n_validation=5),
                    effects=[TrueEffect("backlash", ("X",), 0.2, seed=2)]).campaign
    moved = Features.from_campaign(full).direction[:, x] != 0
    k = int(np.argmax(moved[1:])) + 1                      # the file starts at a row X reached by a move
    c = full.subset(np.arange(k, len(full)))
    feats = Features.from_campaign(c)
    unknown = np.flatnonzero(feats.direction[:, x] == 0)
    assert unknown.tolist() == [0]
    model = make_model("6dof", m, 3).with_effects([Backlash(m, ("X",))]).fit(c.subset(np.arange(1, len(c))), noise)
    bad = c.subset(np.arange(len(c)))
    bad.xyz[0] += 5e-4 / np.sqrt(3)                        # the same row with a gross error
    for camp, kept in ((c, []), (bad, [0])):
        ev = model.row_residuals(camp, feats)
        s = np.sum(np.where(ev.valid, ev.w, 0.0) ** 2, axis=1)
        level = robust_level(s[1:], ev.valid[1:])                     # the scatter of the rows fitted
        assert beyond(s[:1], ev.valid[:1], level, len(c)).all()      # beyond the noise as the file reads
        assert at_unknown_approach(model, camp, feats, np.array([0]), level).tolist() == kept
