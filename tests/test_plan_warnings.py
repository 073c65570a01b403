"""Plans that are useless say so, with the fix: the holder in the machine's geometry (a
collision, counted apart from the line of sight; the test itself: tests/test_sightline.py), a predicted error above half the
machine's expected one, a tracker in the work envelope or out of a tracker's range, a
gauge line the plan cannot identify; the campaign's time as the NC program runs it."""
import numpy as np
import pytest

from vecpin.cli import main
from vecpin.planning.candidates import candidate_commands
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.planchecks import TRACKER_RANGE, work_envelope
from vecpin.planning.timing import ProgramTiming, row_times
from vecpin.planning.route import axis_speeds

SMALL = dict(n_commands=24, order=2, candidates=300, validation_points=100)


def test_snk_default_plan_warns_first_about_collision_and_predicted_error(tmp_path, capsys):
    assert main(["plan", "snk_120v", "--out", str(tmp_path / "p"), "--quiet"]) == 0
    cap = capsys.readouterr()
    warns = [w for w in cap.err.splitlines() if w.startswith("vecpin: warning:")]
    assert len(warns) >= 2 and not [e for e in cap.err.splitlines() if not e.startswith("vecpin: warning:")]
    assert "collisions, not line-of-sight losses" in warns[0] and "base_0" in warns[0] and "--tools" in warns[0]
    assert "predicted model error" in warns[1] and "--expected-error" in warns[1] and "--points" in warns[1]
    line = next(x for x in cap.out.splitlines() if x.startswith("  candidates"))
    counts = [int(w) for w in line.replace(",", " ").replace(":", " ").split() if w.isdigit()]
    assert counts[0] == 2000 and counts[2] > 0 and counts[3] > 0 and sum(counts[1:4]) + counts[4] == 2000
    assert "campaign time" in cap.out


def test_a_good_plan_says_nothing(flow, recwarn):
    # the head tilted past 90 deg lifts a holder into the saddle: the zone keeps B below that
    p = make_plan(flow, PlanSettings(**SMALL, tracker_mm=(3000, -2300, -300), zone={"B": (-90.0, 90.0)}))
    assert p.counts()["collision"] == 0 and p.warnings == []


@pytest.mark.parametrize("where, needle", [("inside", "inside the tool tips' work envelope"),
                                           ("far", "a laser tracker reads a target at most")])
def test_tracker_inside_the_envelope_or_out_of_range_is_said(flow, where, needle):
    lo, hi = work_envelope(flow, candidate_commands(flow, 300, flow.lower, flow.upper), [0.2])
    if where == "inside":
        tracker = (lo + hi) / 2 * 1000  # the middle of the tool tips' envelope (no sight test: it stands in the ram)
    else:
        tracker = np.array([1e9, 0.0, 0.0])  # 1,000 km
    p = make_plan(flow, PlanSettings(**SMALL, tracker_mm=tuple(tracker), sight=False))
    hits = [w for w in p.warnings if needle in w]
    assert len(hits) == 1 and "`tracker_mm`" in hits[0]
    if where == "far":
        assert f"{TRACKER_RANGE:.0f} m" in hits[0]


def test_gauge_line_on_a_trunnion_is_said_not_identifiable(machines, tmp_path, capsys):
    # order 4: a term of the table's model follows the gauge line (order 2 identifies it to 0.02 mm)
    args = ["plan", "trunnion_xyzac", "--points", "40", "--order", "4", "--candidates", "400", "--quiet",
            "--out", str(tmp_path / "t")]
    assert main(args) == 0
    cap = capsys.readouterr()
    assert "gauge line T_offset: this plan cannot identify it" in cap.err and "tool presetter" in cap.err
    assert "T_offset: not identifiable with this plan" in cap.out


def test_campaign_time_counts_moves_dwells_and_holder_changes(flow):
    p = make_plan(flow, PlanSettings(**SMALL, tracker_mm=(3000, -2300, -300), repeat_points=3, repeat_times=2))
    speed = axis_speeds(flow)
    slow = ProgramTiming(speed, p.steps, dwell_s=4.0, holder_change_s=120.0)
    t, tm = row_times(flow, p.template, slow)
    tools = p.template.tool
    assert tm.changes == int(np.sum(np.abs(np.diff(tools)) > 1e-9))  # repeated points with the first holder too
    assert tm.dwell_s == pytest.approx(4.0 * len(p.template))
    assert np.all(np.diff(t) > 0) and t[-1] <= tm.total_s and tm.total_s - t[-1] < 60
    # the moves: at least the plan's own move time (the slowest axis; lifts come on top)
    assert tm.moves_s >= p.score.travel_s * 0.99
    fast = ProgramTiming(speed, p.steps, dwell_s=4.0, holder_change_s=0.0)
    assert row_times(flow, p.template, fast)[1].total_s == pytest.approx(tm.total_s - 120.0 * tm.changes)
