"""The model choice's folds on real designs (issue 40): every target read at a pose falls in
that pose's fold, and where the design moves one joint at a time whole sweeps fall in one
fold. The sweeps each row belongs to are known here from how the design was built, not
from vecpin."""
import numpy as np

from vecpin.measurement.campaign import Campaign
from vecpin.measurement.poses import pose_blocks, sweep_folds
from vecpin.selection.choice import choose_model
from vecpin.simulation.simulate import Design, simulate

TARGETS = 3


def _sweeps(machine, n_per=6):
    """Commands moving one axis at a time from a middle pose, each axis swept over the
    middle half of its travel; (commands, the sweep each command belongs to)."""
    mid = 0.5 * (machine.lower + machine.upper)
    q, sweep = [], []
    for a in machine.axes:
        for v in np.linspace(0.3, 0.7, n_per):
            c = mid.copy()
            c[a.index] = a.lower + v * a.travel
            q.append(c)
            sweep.append(a.index)
    return np.array(q), np.array(sweep)


def _campaign(q, targets=TARGETS):
    """Each command read ``targets`` times in a row (one row per reflector)."""
    rows = np.repeat(q, targets, axis=0)
    return Campaign([f"j{i}" for i in range(q.shape[1])], rows, np.zeros(len(rows)), np.zeros((len(rows), 3)))


def test_whole_sweeps_and_every_target_of_a_pose_share_a_fold(flow):
    q, sweep = _sweeps(flow)
    c = _campaign(q)
    block = pose_blocks(c, 5)
    assert block is not None
    truth = np.repeat(sweep, TARGETS)
    # one block per sweep: the blocks and the sweeps partition the rows alike
    pairs = set(zip(block.tolist(), truth.tolist()))
    assert len(pairs) == len(set(truth.tolist())) == len(set(block.tolist()))
    fold = sweep_folds(block, 5, np.random.default_rng(0))
    for s in set(truth.tolist()):
        assert len(set(fold[truth == s].tolist())) == 1          # a sweep is never split
    assert len(set(fold.tolist())) == 5


def test_random_poses_keep_folds_by_pose(flow):
    rng = np.random.default_rng(1)
    q = flow.lower + rng.uniform(size=(60, flow.n_axes)) * (flow.upper - flow.lower)
    assert pose_blocks(_campaign(q), 5) is None


def test_the_choice_says_it_held_out_whole_sweeps(flow):
    q, _ = _sweeps(flow)
    tools = np.tile([0.21488, 0.31286], len(q))
    sim = simulate(flow, seed=3, plan=(np.repeat(q, 2, axis=0), tools), design=Design(n_validation=5))
    choice = choose_model(flow, sim.campaign, kinds=("6dof",), families=("chebyshev",), orders=(0, 1),
                          per_axis=False, screen=False)
    assert choice.grouping.startswith(f"sweep ({flow.n_axes} sweeps")
    assert f"grouped by sweep ({flow.n_axes} sweeps" in choice.table()
    assert "sweep" in choice.to_dict()["method"]
