"""How many threads the BLAS under numpy and scipy may use while vecpin computes.

vecpin's heavy work is thousands of small and medium factorisations (the model choice
solves a few hundred candidates x 5 folds, the fit a Gauss-Newton step per iteration,
the diagnosis and the table search many small solves). A threaded OpenBLAS spends more
on waking and parking its threads than it gains on matrices of that size. Measured on
the 2-core development machine (numpy 2.4 with its bundled OpenBLAS 0.3.31, two
threads by default), ``benchmarks/bench_fit.py``: the default fit of Paper I's 590 rows
4.0 s with two BLAS threads, 1.2 s with one; the default fit of 10,000 rows 14.1 s and
10.0 s; a fixed 6-DoF fit of 10,000 rows 5.4 s and 5.6 s; only an AP fit of 1,000,000
rows gains from the second thread (92 s against 99 s).

So vecpin's entry points (:func:`one_blas_thread` on the model fit, the model choice,
the diagnosis, the table planning and every command of the command line) run with one
BLAS thread, through ``threadpoolctl`` (the scientific Python stack's tool for exactly
this, as scikit-learn uses it). The environment variable ``VECPIN_BLAS_THREADS`` sets
another number (``0``: leave the BLAS as it is, e.g. for a 1,000,000-row fit on a
machine with many cores). Calls nest: an inner entry point inside an outer one costs
nothing.

Work that splits into a few independent heavy parts (the model choice's kinds) runs
them side by side, one per core, each with the BLAS limit above (:func:`side_by_side`):
in threads, or in forked processes where the Python around the factorisations would
make threads wait on each other. A part whose result is wanted later (a report's
figures) runs in a forked copy beside the rest (:class:`Background`).
"""
from __future__ import annotations

import functools
import importlib
import os
import sys
import threading
import warnings
from contextlib import contextmanager
from typing import Callable, Iterable, TypeVar

from vecpin.errors import VecpinError

T = TypeVar("T")

ENV = "VECPIN_BLAS_THREADS"
WORKERS_ENV = "VECPIN_WORKERS"   # how many cores side_by_side uses (default: every core)
_state = threading.local()
_controller = None


def blas_threads_wanted() -> int:
    """The BLAS thread count vecpin works with: ``VECPIN_BLAS_THREADS`` (0 = leave
    the BLAS alone), 1 when unset or not a whole number >= 0."""
    text = os.environ.get(ENV, "").strip()
    try:
        n = int(text)
    except ValueError:
        return 1
    return n if n >= 0 else 1


def _get_controller():
    """One threadpoolctl controller for the process, made at the first use, after
    ``scipy.linalg`` is imported: scipy's wheels bundle their own OpenBLAS, which a
    controller made before it loads does not limit (the command line enters
    :func:`blas_limited` before any command imports scipy: its model choice ran with two
    BLAS threads, 10x the CPU time on a loaded 2-core machine)."""
    global _controller
    if _controller is None:
        importlib.import_module("scipy.linalg")  # its own BLAS loaded before the controller looks
        from threadpoolctl import ThreadpoolController
        _controller = ThreadpoolController()
    return _controller


@contextmanager
def blas_limited():
    """Run the block with :func:`blas_threads_wanted` BLAS threads; nested blocks
    inside it change nothing."""
    depth = getattr(_state, "depth", 0)
    n = blas_threads_wanted() if depth == 0 else 0
    _state.depth = depth + 1
    try:
        if n > 0:
            with _get_controller().limit(limits=n, user_api="blas"):
                yield
        else:
            yield
    finally:
        _state.depth = depth


def one_blas_thread(fn):
    """Decorator: ``fn`` runs inside :func:`blas_limited`."""
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with blas_limited():
            return fn(*args, **kwargs)
    return wrapper


def workers_wanted() -> int:
    """The calls :func:`side_by_side` runs at once: ``VECPIN_WORKERS`` (a whole number;
    0 counts as 1: one after the other, e.g. where parallel test workers share the cores
    out already), else the cores this process may run on."""
    text = os.environ.get(WORKERS_ENV, "").strip()
    if text.isdigit():
        return max(int(text), 1)
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)


def side_by_side(fn: Callable[..., T], items: Iterable, *, processes: bool = False) -> list[T]:
    """``[fn(x) for x in items]``, the calls side by side (:func:`workers_wanted` at once,
    at most one per item), the results in the items' order, each under the caller's BLAS
    limit (:func:`blas_limited`). An exception of a call is raised here (a vecpin error
    as such: its message is what the user reads); ``fn`` must not change what another
    call reads.

    In threads by default: the factorisations release the interpreter lock, the Python
    around them does not. ``processes``: in forked processes (each a copy of this one,
    made in milliseconds; the results come back pickled), for work whose Python share
    would make threads wait on each other and whose results are small. A forked call's
    changes to shared objects, its warnings and anything it reports through a callback
    stay in its copy (printing goes to the same terminal). Threads where forking is not
    safe (:func:`_can_fork`). (The pools' modules are imported here, by the calls that need them.)"""
    items = list(items)
    workers = min(len(items), workers_wanted())
    if workers <= 1:
        return [fn(x) for x in items]
    if processes and _can_fork():
        return _forked(fn, items, workers)
    from concurrent.futures import ThreadPoolExecutor   # here: a command that never runs calls side by side skips it

    def call(x):
        _state.depth = 1   # inside the limit entered below
        return fn(x)

    with blas_limited(), ThreadPoolExecutor(workers) as pool:
        return list(pool.map(call, items))


def _can_fork() -> bool:
    """Fork only on Linux (macOS' system libraries are not fork-safe, which is why Python
    spawns there), from a process that may have children (a multiprocessing pool's
    worker may not) and runs no Python thread of its own (a lock one of them held would
    stay locked in the copy; the BLAS re-creates its own threads in the copy)."""
    import multiprocessing
    return (sys.platform.startswith("linux") and not multiprocessing.current_process().daemon
            and threading.active_count() == 1)


_job: tuple = ()   # (fn, items) of the forked calls under way: the copies find them here


def _run_job(i: int):
    """Call ``i`` of :data:`_job` in a forked copy; an exception that could not travel
    back (a custom constructor) travels as its plain vecpin error, message kept."""
    fn, items = _job
    try:
        return fn(items[i])
    except Exception as exc:
        sent = _travelling(exc)
        if sent is exc:
            raise
        raise sent from None


PR_SET_PDEATHSIG = 1   # Linux prctl(2): the signal a process gets when the thread that made it ends


def _quiet_copy(parent: int) -> None:
    """A forked copy leaves Ctrl-C to the parent: no traceback of its own. The parent's
    interrupt takes effect when the copies have finished their calls (`vecpin fit` on
    2,218 poses: "vecpin: interrupted", exit 130, 3.7 s after Ctrl-C). A copy dies with
    its parent: a SIGTERM or SIGKILL to ``vecpin fit`` left both copies running, 378 MB
    each, for as long as anyone watched (prctl's parent-death signal; a copy whose parent
    ended before it was armed ends at once)."""
    import ctypes
    import signal
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGTERM))
    except (OSError, AttributeError):   # no prctl: the copies end with their calls, as before
        return
    if os.getppid() != parent:
        os._exit(1)


def _forked(fn: Callable[..., T], items: list, workers: int) -> list[T]:
    """:func:`side_by_side` in ``workers`` forked processes (a copy that dies raises
    ``BrokenProcessPool`` here rather than leaving the caller waiting)."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor
    global _job
    _job = (fn, items)
    try:
        with blas_limited(), warnings.catch_warnings():
            # Python 3.12+ warns at a fork from a process with other OS threads; here
            # those are the BLAS' parked threads only (no Python thread runs: _can_fork)
            warnings.filterwarnings("ignore", message=".*multi-threaded.*fork", category=DeprecationWarning)
            with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                                     initializer=_quiet_copy, initargs=(os.getpid(),)) as pool:
                return list(pool.map(_run_job, range(len(items))))
    finally:
        _job = ()


class Background:
    """A generator function's two steps in a forked process, on the second core, while this
    one goes on: ``fn(*args)`` runs at once up to its first ``yield``; :meth:`finish` hands
    it ``later`` and returns what it yields next (e.g. a report's figures: the parts already
    known drawn meanwhile, the rest when known). Results come back pickled. Where forking is
    not safe (:func:`_can_fork`) or :func:`workers_wanted` is 1, or if the copy dies, both
    steps run here, in :meth:`finish`: the same result. An exception of ``fn`` is raised by
    :meth:`finish` (a vecpin error as such). :meth:`close` ends a copy never finished."""

    def __init__(self, fn: Callable, *args):
        self._fn, self._args, self._conn, self._proc = fn, args, None, None
        if workers_wanted() > 1 and _can_fork():
            import multiprocessing
            ctx = multiprocessing.get_context("fork")
            self._conn, child = ctx.Pipe()
            self._proc = ctx.Process(target=_background, args=(os.getpid(), child, self._conn, fn, args), daemon=True)
            with warnings.catch_warnings():   # as in _forked: the BLAS' parked threads only
                warnings.filterwarnings("ignore", message=".*multi-threaded.*fork", category=DeprecationWarning)
                self._proc.start()
            child.close()

    def finish(self, later):
        """``later`` handed to the second step; what it yields."""
        if self._proc is not None:
            try:
                self._conn.send(later)
                ok, value = self._conn.recv()
            except (EOFError, OSError):   # the copy died (killed, out of memory): both steps here
                ok, value = None, None
            finally:
                self._conn.close()
                self._proc.join()   # it has sent its reply, or died
                self._proc = None
            if ok:
                return value
            if ok is False:
                raise value
        steps = self._fn(*self._args)
        next(steps)
        return steps.send(later)

    def close(self) -> None:
        """End a copy never finished (its work is not wanted: e.g. the caller failed) at once."""
        if self._proc is not None:
            self._conn.close()
            self._proc.terminate()
            self._proc.join()
            self._proc = None


def _travelling(exc: Exception) -> Exception:
    """``exc`` if it pickles, else its plain vecpin error (message kept)."""
    import pickle
    try:
        pickle.loads(pickle.dumps(exc))
        return exc
    except Exception:
        return (VecpinError if isinstance(exc, VecpinError) else RuntimeError)(str(exc))


def _background(parent: int, conn, parent_end, fn: Callable, args: tuple) -> None:
    """:class:`Background`'s copy: the first step, then the second with what the parent
    hands; (True, result) or (False, exception) sent back. A closed pipe ends it."""
    parent_end.close()
    _quiet_copy(parent)
    try:
        steps = fn(*args)
        next(steps)
    except Exception as exc:
        conn.send((False, _travelling(exc)))
        return
    try:
        later = conn.recv()
    except EOFError:   # the parent closed the pipe: never finished
        return
    try:
        reply = (True, steps.send(later))
    except Exception as exc:
        reply = (False, _travelling(exc))
    conn.send(reply)
