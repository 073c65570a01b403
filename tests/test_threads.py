"""One BLAS thread while vecpin computes (vecpin/threads.py): the limit is what
threadpoolctl reads back from the loaded OpenBLAS/MKL libraries, inside vecpin's entry
points, and it is undone afterwards; VECPIN_BLAS_THREADS sets another count or none."""
import os
import signal
import sys
from pathlib import Path

import numpy as np
import pytest
from threadpoolctl import threadpool_info

import vecpin.identification.fit as fitmod
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.threads import blas_limited, blas_threads_wanted


UR10_POSES = Path(__file__).resolve().parent / "data" / "ipa_ur10" / "random_poses_400.csv"


def blas_threads() -> list[int]:
    return [d["num_threads"] for d in threadpool_info() if d["user_api"] == "blas"]


@pytest.fixture
def two_threads():
    """The BLAS libraries with two threads (whatever the machine has), restored after."""
    from threadpoolctl import threadpool_limits
    before = blas_threads()
    if not before:
        pytest.skip("no BLAS library that threadpoolctl can see")
    with threadpool_limits(limits=2, user_api="blas"):
        yield
    assert blas_threads() == before


def test_the_block_runs_with_one_thread_and_restores(two_threads, monkeypatch):
    monkeypatch.delenv("VECPIN_BLAS_THREADS", raising=False)
    assert set(blas_threads()) == {2}
    with blas_limited():
        assert set(blas_threads()) == {1}
        with blas_limited():           # nested: unchanged
            assert set(blas_threads()) == {1}
        assert set(blas_threads()) == {1}
    assert set(blas_threads()) == {2}


@pytest.mark.parametrize("value, wanted", [("0", 0), ("3", 3), ("", 1), ("many", 1), ("-2", 1)])
def test_the_environment_sets_the_count(two_threads, monkeypatch, value, wanted):
    monkeypatch.setenv("VECPIN_BLAS_THREADS", value)
    assert blas_threads_wanted() == wanted
    with blas_limited():
        assert set(blas_threads()) == {2 if wanted == 0 else wanted}
    assert set(blas_threads()) == {2}


def test_a_model_fit_runs_with_one_thread(two_threads, flow, monkeypatch):
    """Read inside the likelihood's fit itself, called through ErrorModel.fit."""
    monkeypatch.delenv("VECPIN_BLAS_THREADS", raising=False)
    seen = []
    inner = fitmod.fit

    def spy(*args, **kwargs):
        seen.append(blas_threads())
        return inner(*args, **kwargs)
    import vecpin.models.base as base
    monkeypatch.setattr(base, "ml_fit", spy)
    sim = simulate(flow, seed=0, design=Design(n_commands=40, n_validation=5))
    model = make_model("ap", flow, 1).fit(sim.campaign, NoiseModel.default(flow))
    assert np.all(np.isfinite(model.b_))
    assert seen and set(seen[0]) == {1}
    assert set(blas_threads()) == {2}


def test_the_command_line_limits_scipys_own_blas():
    """The command line enters the limit before a command imports scipy; scipy's wheels
    bundle their own OpenBLAS beside numpy's. In a fresh process, every BLAS library
    threadpoolctl sees once scipy.linalg is loaded runs with one thread inside the block
    (scipy's ran with the machine's count: 10x the CPU time of ``vecpin fit`` on the UR10
    data, 88 s against 8 s)."""
    import json
    import os
    import subprocess
    import sys
    code = ("import json, os; os.environ.pop('VECPIN_BLAS_THREADS', None)\n"
            "from threadpoolctl import threadpool_info, threadpool_limits\n"
            "from vecpin.threads import blas_limited\n"
            "with blas_limited():\n"
            "    import scipy.linalg\n"
            "    inside = [(d['filepath'], d['num_threads']) for d in threadpool_info() if d['user_api'] == 'blas']\n"
            "print(json.dumps(inside))\n")
    with_two = dict(os.environ, OPENBLAS_NUM_THREADS="2")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=with_two, check=True)
    inside = json.loads(out.stdout)
    if not inside:
        pytest.skip("no BLAS library that threadpoolctl can see")
    assert {n for _, n in inside} == {1}, inside


def _pid_and_square(x):
    import os
    return os.getpid(), x * x


def _refuse_three(x):
    if x == 3:
        raise ValueError("three refused")
    return x


@pytest.mark.parametrize("processes", [False, True])
def test_side_by_side_keeps_the_order_and_raises(processes, monkeypatch):
    """side_by_side gives what a loop gives, in the items' order, in forked processes
    when asked (other process ids) and raises what a call raised."""
    import os

    from vecpin.threads import side_by_side
    monkeypatch.setenv("VECPIN_WORKERS", "2")
    out = side_by_side(_pid_and_square, range(5), processes=processes)
    assert [sq for _, sq in out] == [x * x for x in range(5)]
    assert all((pid != os.getpid()) == processes for pid, _ in out)
    with pytest.raises(ValueError, match="three refused"):
        side_by_side(_refuse_three, range(5), processes=processes)


def _refuse_a_row(x):
    from vecpin.errors import CampaignFileError
    if x == 2:
        raise CampaignFileError("c.csv", "the x column is empty", row=3)
    return x


def _die(x):
    import os
    if x == 1:
        os._exit(3)
    return x


def test_a_forked_call_that_fails_or_dies_is_reported(monkeypatch):
    """A vecpin error whose constructor pickle cannot replay comes back as a vecpin error
    with its message (the command line prints it, no traceback); a copy that dies raises
    rather than leaving the caller waiting."""
    from concurrent.futures.process import BrokenProcessPool

    from vecpin.errors import VecpinError
    from vecpin.threads import side_by_side
    monkeypatch.setenv("VECPIN_WORKERS", "2")
    with pytest.raises(VecpinError, match="the x column is empty"):
        side_by_side(_refuse_a_row, range(4), processes=True)
    with pytest.raises(BrokenProcessPool):
        side_by_side(_die, range(3), processes=True)


def _side_by_side_pids(n):
    from vecpin.threads import side_by_side
    return side_by_side(_pid_and_square, range(n), processes=True)


def test_a_pool_worker_runs_the_calls_in_threads(monkeypatch):
    """In a multiprocessing pool's worker (which may not have children) the calls run in
    threads of that worker."""
    import multiprocessing
    monkeypatch.setenv("VECPIN_WORKERS", "2")
    with multiprocessing.get_context("fork").Pool(1) as pool:
        out = pool.apply(_side_by_side_pids, (3,))
        worker = pool.apply(os.getpid)
    assert [sq for _, sq in out] == [0, 1, 4] and {pid for pid, _ in out} == {worker}


def test_no_fork_while_another_thread_runs(monkeypatch):
    """A process running threads of its own is not forked (a lock held by one of them
    would stay locked in the copy): the calls run in threads instead."""
    import os
    import threading

    from vecpin.threads import side_by_side
    monkeypatch.setenv("VECPIN_WORKERS", "2")
    stop = threading.Event()
    other = threading.Thread(target=stop.wait)
    other.start()
    try:
        out = side_by_side(_pid_and_square, range(3), processes=True)
    finally:
        stop.set()
        other.join()
    assert all(pid == os.getpid() for pid, _ in out)


def test_the_choice_is_the_same_side_by_side_or_one_after_another(monkeypatch):
    """The model kinds searched side by side (forked processes) give the choice, every
    candidate and its held-out distances, of the kinds searched one after another, in
    the same order (the UR10's real campaign: its ends judged, the noise from the data)."""
    import vecpin
    from vecpin.measurement.robotaccuracy import read_dataset
    from vecpin.selection.choice import choose_model
    m = vecpin.Machine.load("ur10")
    c = read_dataset(UR10_POSES, m).campaign.subset(np.arange(0, 400, 3))
    runs = []
    for cores in ("1", "2"):
        monkeypatch.setenv("VECPIN_WORKERS", cores)
        ch = choose_model(m, c, NoiseModel.default(m), orders=(0, 1, 2), noise_from_data=True)
        runs.append(ch)
    one, two = runs
    assert [(k.kind, k.axes) for k in one.candidates] == [(k.kind, k.axes) for k in two.candidates]
    for a, b in zip(one.candidates, two.candidates):
        np.testing.assert_array_equal(a.heldout, b.heldout)
    assert (one.chosen.kind, one.chosen.axes) == (two.chosen.kind, two.chosen.axes)
    assert one.reason == two.reason and one.chosen_noise_scale == two.chosen_noise_scale != 1.0


CHILD = """
import os, sys, time
from vecpin.threads import side_by_side

def slow(i):
    with open(os.path.join(sys.argv[1], f"copy{i}"), "w") as f:
        f.write(str(os.getpid()))
    time.sleep(120)
    return i

print(side_by_side(slow, range(2), processes=True))
"""


def _alive(pid: int) -> bool:
    """True while ``pid`` runs (a zombie awaiting its reaper counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="forked copies and prctl are Linux's")
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_forked_copies_die_with_their_parent(tmp_path, sig):
    """Issue 42: SIGTERM or SIGKILL to `vecpin fit` during the forked model choice left both
    copies running (PPID 1). A real run: a parent forks two copies that write their pid and
    sleep 120 s; the parent is killed; both copies end within 5 s."""
    import subprocess
    import time
    env = dict(os.environ, VECPIN_WORKERS="2")
    parent = subprocess.Popen([sys.executable, "-c", CHILD, str(tmp_path)], env=env)
    t0 = time.time()
    while len(list(tmp_path.glob("copy*"))) < 2 and time.time() - t0 < 60:
        time.sleep(0.05)
    pids = [int(p.read_text()) for p in tmp_path.glob("copy*")]
    assert len(pids) == 2 and all(_alive(p) for p in pids)
    parent.send_signal(sig)
    parent.wait(10)
    t0 = time.time()
    while any(_alive(p) for p in pids) and time.time() - t0 < 5:
        time.sleep(0.05)
    left = [p for p in pids if _alive(p)]
    for p in left:
        os.kill(p, signal.SIGKILL)
    assert not left, f"copies {left} outlived their parent"


def _two_steps(x, die_unless=0, fail=""):
    """Step one at once (its process id), step two with what is handed later; a copy
    dies in step one outside process ``die_unless`` if given."""
    import os
    first = os.getpid()
    if die_unless and first != die_unless:
        os._exit(3)
    if fail == "first":
        raise ValueError("first step refused")
    later = yield
    if fail == "second":
        _refuse_a_row(2)
    yield first, os.getpid(), x + later


@pytest.mark.parametrize("workers", ["1", "2"])
def test_background_gives_what_the_steps_give_here(workers, monkeypatch):
    """Background's two steps in a forked copy (another process id, both steps in it)
    give what they give in this process (one worker: both steps here, in finish)."""
    from vecpin.threads import Background
    monkeypatch.setenv("VECPIN_WORKERS", workers)
    first, second, total = Background(_two_steps, 40).finish(2)
    assert total == 42 and first == second and (first != os.getpid()) == (workers == "2")


def test_background_raises_what_a_step_raised_and_survives_a_dead_copy(monkeypatch):
    """An exception of either step is raised by finish (a vecpin error whose constructor
    pickle cannot replay, with its message); a copy that dies leaves both steps to this
    process; close ends a copy never finished."""
    from vecpin.errors import VecpinError
    from vecpin.threads import Background
    monkeypatch.setenv("VECPIN_WORKERS", "2")
    with pytest.raises(ValueError, match="first step refused"):
        Background(_two_steps, 1, 0, "first").finish(2)
    with pytest.raises(VecpinError, match="the x column is empty"):
        Background(_two_steps, 1, 0, "second").finish(2)
    dead = Background(_two_steps, 1, os.getpid())
    dead._proc.join()   # the copy died in its first step
    assert dead._proc.exitcode == 3 and dead.finish(2) == (os.getpid(), os.getpid(), 3)   # both steps here
    idle = Background(_two_steps, 1)
    proc = idle._proc
    idle.close()
    assert proc.exitcode is not None and idle._proc is None
