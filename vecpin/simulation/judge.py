"""Judging fits against a simulated true machine: noise-free validation errors.

For a machine, a true machine (any :class:`~vecpin.simulation.truth.SimulatedMachine`)
and a campaign design, :func:`judge` simulates the campaign, fits

1. vecpin's default model (``make_model("ap", machine, 6, basis="fourier")``),
2. a grid of fixed choices (6-DoF / AP x Chebyshev / auto x orders 2..8),
3. the oracle: a model whose per-axis bases contain the true error family
   (6-DoF with ``truth.oracle_bases()`` of an :class:`IndependentMachine`; a
   :class:`TrueMachine`'s ``family_bases()`` with its own model kind); for a truth that mixes axes there is none, and the row shows
   the floor of its separable part instead (the same fit on the machine without the
   mixing terms, same seed and design),

and measures each on fresh commands: the distance between the model's prediction,
placed with the tracker pose it identified, and the noise-free true tracker reading
(the way tests/test_identify.py judges fits). Everything printed is mm.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import registered_errors
from vecpin.models import make_model
from vecpin.compensation.plan import plan_tables
from vecpin.selection.choice import choose_or_fix
from vecpin.simulation.floor import table_floor, true_compensated_error
from vecpin.measurement.campaign import PAPER_I_TOOLS_MM
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import uniform_commands
from vecpin.units import M_PER_MM, norm_mm

DEFAULT_CHOICE = ("ap", "fourier", 6)  # what `vecpin fit` uses without model flags (before issue 11)


@dataclass
class Row:
    """One fitted model: ``label``; kind/basis/order (basis "custom" for the oracle);
    parameters; noise-free validation mean and max distance [mm]; fit time [s];
    ``note`` (why a fit failed, or what the row is)."""

    label: str
    kind: str
    basis: str
    order: int
    n_parameters: int = 0
    mean_mm: float = float("nan")
    max_mm: float = float("nan")
    seconds: float = 0.0
    note: str = ""


@dataclass
class Judgement:
    """The rows of one (machine, truth, design) and the uncompensated reference [mm]."""

    machine: str
    family: str
    uncompensated_mean_mm: float
    rows: list[Row] = field(default_factory=list)
    default_key: tuple[str, str, int] = DEFAULT_CHOICE  # ("ap", "chebyshev", 6) where fourier is Chebyshev
    choice: object = None                 # the model choice of the selected row
    tables_mm: tuple[float, float] | None = None   # true compensated error of vecpin's tables (mean, max)
    floor_mm: tuple[float, float] | None = None    # the table floor (mean, max)
    oracle_tables_mm: tuple[float, float] | None = None  # the oracle fit's tables on the true machine (mean, max)
    uncompensated_true_mm: tuple[float, float] | None = None

    @property
    def selected(self) -> Row | None:
        return next((r for r in self.rows if r.basis == "selected"), None)

    def find(self, kind: str, basis: str, order: int) -> Row | None:
        for r in self.rows:
            if (r.kind, r.basis, r.order) == (kind, basis, order) and not r.label.startswith(("oracle", "selected")):
                return r
        return None

    @property
    def default(self) -> Row:
        return self.find(*self.default_key)

    @property
    def grid(self) -> list[Row]:
        return [r for r in self.rows if r.basis in ("chebyshev", "fourier")]

    @property
    def best_fixed(self) -> Row:
        """The grid row with the smallest validation mean."""
        ok = [r for r in self.grid if np.isfinite(r.mean_mm)]
        return min(ok, key=lambda r: r.mean_mm)

    @property
    def oracle(self) -> Row | None:
        for r in self.rows:
            if r.label.startswith("oracle"):
                return r
        return None

    def format(self, grid: bool = True) -> str:
        """A printable table (mm) with the ratio of each row to the oracle row."""
        o = self.oracle
        ref = o.mean_mm if o is not None and np.isfinite(o.mean_mm) else float("nan")
        lines = [f"{self.machine} / {self.family}: uncompensated {self.uncompensated_mean_mm:.4f} mm mean "
                 "(noise-free validation, nominal kinematics registered)",
                 ""]
        best = self.best_fixed
        w = max([34] + [len(r.label) + 12 for r in self.rows])  # a model's name in words can be long

        def line(tag, r):
            ratio = r.mean_mm / ref if np.isfinite(ref) else float("nan")
            note = f"  {r.note}" if r.note else ""
            return (f"  {tag + r.label:<{w}s} {r.n_parameters:6d} {r.mean_mm:9.4f} {r.max_mm:9.4f} "
                    f"{ratio:8.2f} {r.seconds:5.1f}{note}")
        lines[1] = f"  {'fit':<{w}s} {'params':>6s} {'mean mm':>9s} {'max mm':>9s} {'/oracle':>8s} {'s':>5s}"
        lines.append(line("default: ", self.default))
        if grid:
            lines += [line("", r) for r in self.grid if r is not self.default]
        lines.append(line("best fixed: ", best))
        if o is not None:
            lines.append(line("", o))
        return "\n".join(lines)


def validation_commands(machine: Machine, n_commands: int = 500, tools_mm=PAPER_I_TOOLS_MM,
                        seed: int = 99) -> tuple[np.ndarray, np.ndarray]:
    """Fresh commands [m, rad] uniform over the axis limits, each with every tool [m]:
    (q (n_commands * n_tools, n), tool (same rows,))."""
    q = uniform_commands(machine, n_commands, np.random.default_rng(seed))
    tools = np.asarray(tools_mm, float) * M_PER_MM
    return np.vstack([q] * len(tools)), np.repeat(tools, n_commands)


def validation_error(model, truth, q: np.ndarray, tool: np.ndarray) -> tuple[float, float]:
    """(mean, max) [mm] distance between the fitted model's prediction and the truth on
    fresh commands: in the tracker frame (the model's identified pose against the
    noise-free true reading); on a machine with a workpiece, the tool tip relative to
    the workpiece (the error that matters, which a floor tracker alone cannot see)
    after the best rigid registration (a nest's position absorbs where the part sits).
    Every tool point of the machine is judged."""
    m = truth.machine
    P = range(len(m.tool_links))
    if m.has_workpiece:
        pred = np.vstack([model.predict_tip(q, tool, "workpiece", point=k) for k in P])
        true = np.vstack([truth.tool_tip(q, tool, frame="workpiece", point=k) for k in P])
        d = norm_mm(registered_errors(pred, true))
    else:
        d = norm_mm(np.vstack([model.predict_tip(q, tool, point=k) - truth.measure(q, tool, None, point=k) for k in P]))
    return float(d.mean()), float(d.max())


def uncompensated_error(truth, q: np.ndarray, tool: np.ndarray) -> float:
    """Mean [mm] distance of the nominal kinematics from the truth (registered), judged
    as :func:`validation_error` judges a model."""
    m = truth.machine
    P = range(len(m.tool_links))
    if m.has_workpiece:
        nom = np.vstack([m.tool_tip(q, tool, frame="workpiece", point=k) for k in P])
        true = np.vstack([truth.tool_tip(q, tool, frame="workpiece", point=k) for k in P])
    else:
        nom = np.vstack([m.tool_tip(q, tool, frame="base", point=k) for k in P])
        true = np.vstack([truth.measure(q, tool, None, point=k) for k in P])
    return float(norm_mm(registered_errors(nom, true)).mean())


def _oracle_bases(truth):
    if hasattr(truth, "oracle_bases"):
        return truth.oracle_bases()
    if hasattr(truth, "family_bases"):
        return truth.family_bases()
    return None


def judge(machine: Machine, truth, design: Design | None = None, *, seed: int = 0,
          kinds=("6dof", "ap"), bases=("chebyshev", "fourier"), orders=range(2, 9), noise: NoiseModel | None = None,
          n_validation: int = 500, oracle: bool = True, selected: bool = False, tables: bool = False,
          progress=None) -> Judgement:
    """Simulate a campaign (``design``, ``seed``) on ``truth`` and judge the default fit,
    the grid ``kinds x bases x orders`` and the oracle on ``n_validation`` fresh
    commands x the design's tools. ``noise``: the fit's noise model (default: spherical
    tracker noise with the truth's tracker figures and the default axis noise).
    ``fourier`` rows are skipped where they equal ``chebyshev`` (no rotary axis travelling
    more than a turn). ``tables`` (with ``selected``): the true compensated error of the
    selected model's tables and of the oracle's, and the table floor."""
    design = design or Design()
    noise = noise or NoiseModel.default(machine, "spherical", tracker=truth.tracker.noise)
    sim = simulate(machine, seed=seed, design=design, truth=truth)
    q, tool = validation_commands(machine, n_validation, design.tools_mm, seed=seed + 1_000_003)
    unc = uncompensated_error(truth, q, tool)
    out = Judgement(machine.name, getattr(truth, "family", type(truth).__name__), unc)
    multi_turn = any(a.multiturn for a in machine.axes)

    def run(label, kind, basis_name, order, campaign=sim.campaign, judged=truth, keep=None, **kw):
        row = Row(label, kind, basis_name, order)
        t0 = time.perf_counter()
        try:
            model = make_model(kind, machine, order, **kw).fit(campaign, noise)
            row.mean_mm, row.max_mm = validation_error(model, judged, q, tool)
            row.n_parameters = model.n_parameters + 6
            if keep is not None:
                keep.append(model)
        except VecpinError as exc:
            row.note = f"failed: {exc}"
        row.seconds = time.perf_counter() - t0
        out.rows.append(row)
        if progress:
            progress(f"{out.machine} {out.family} {label}: {row.mean_mm:.4f} mm")
        return row

    if selected:  # the model the data choose (vecpin fit's default), and its tables against the floor
        t0 = time.perf_counter()
        proto, choice = choose_or_fix(machine, sim.campaign, noise)
        model = proto.fit(sim.campaign, noise)
        row = Row("selected: " + model.label(), model.kind, "selected", -1, model.n_parameters + 6,
                  *validation_error(model, truth, q, tool), time.perf_counter() - t0)
        row.note = f"held-out {choice.chosen.mean:.4f} mm"
        out.rows.append(row)
        out.choice = choice
        if tables:
            plan = plan_tables(model, uncertainty=False)
            out.tables_mm = true_compensated_error(truth, plan.tables, q, tool, "reference")
            out.floor_mm = (lambda f: (f.mean_mm, f.max_mm))(table_floor(truth, q, tool, judged="reference"))
            out.uncompensated_true_mm = true_compensated_error(truth, None, q, tool, "reference")
    if not multi_turn:
        out.default_key = ("ap", "chebyshev", 6)
    choices = [(k, b, o) for k in kinds for b in bases for o in orders if b == "chebyshev" or multi_turn]
    if out.default_key not in choices:
        choices.insert(0, out.default_key)
    for k, b, o in choices:
        run(f"{k} {b} {o}", k, b, o, basis=b)
    if oracle:
        ob = _oracle_bases(truth)
        if ob is not None:
            kind = "ap" if getattr(truth, "perturbations", None) else "6dof"  # a TrueMachine of the AP family
            kept = []
            run(f"oracle: {kind}, true family bases", kind, "custom", max(B.order for B in ob), keep=kept, bases=ob)
            if tables and kept:  # the share of the table gap that the noise leaves even with perfect bases
                out.oracle_tables_mm = true_compensated_error(truth, plan_tables(kept[0], uncertainty=False).tables,
                                                              q, tool, "reference")
        elif hasattr(truth, "separable_part"):
            part = truth.separable_part()
            sim2 = simulate(machine, seed=seed, design=design, truth=part)
            r = run("oracle: separable part only", "6dof", "custom", max(B.order for B in part.bases),
                    campaign=sim2.campaign, judged=part, bases=part.bases)
            r.note = "errors mix axes: no per-axis oracle; floor of the machine without the mixing terms"
    return out
