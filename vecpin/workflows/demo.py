"""The quick-start job: Paper I's campaign simulated on the laboratory XYZCB machine,
the model the data choose fitted (as ``vecpin fit`` does by default) and, for comparison
with the seed, the 6-DoF and AP models at its order 6; the before/after table beside
the seed's figures. Every file is written in one :class:`~vecpin.fileio.OutputSet`."""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.errors import InputError
from vecpin.fileio import OutputSet, check_output_dir
from vecpin.kinematics.machine import Machine
from vecpin.measurement.noise import NoiseModel
from vecpin.models import MODELS, make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm
from vecpin.workflows.fitting import fit_campaign

SEED_TABLE2 = ("seed, Paper I Table 2 (real machine): uncompensated 0.602/1.417 (ident), 0.568/1.110 (valid); "
               "6-DoF order 6 0.027/0.071, 0.062/0.092; AP order 6 0.029/0.091, 0.049/0.132")


@dataclass
class DemoRow:
    label: str
    ident: np.ndarray       # distances [mm] on the identification rows
    valid: np.ndarray       # on the validation rows
    exact: np.ndarray       # on the noise-free validation positions
    seconds: float | None = None         # the maximum-likelihood fit [s]
    choice_seconds: float | None = None  # the model choice before it [s] (the chosen model only)

    def time_cell(self) -> str:
        """'choice + fit' seconds of the chosen model, the fit's of a fixed one."""
        if self.seconds is None:
            return ""
        if self.choice_seconds is None:
            return f"{self.seconds:.2f} s"
        return f"{self.choice_seconds:.2f} + {self.seconds:.2f} s"


@dataclass
class DemoResult:
    seed: int
    rows: list[DemoRow]
    files: list[Path] = field(default_factory=list)
    choice: object = None  # the model choice (vecpin.selection.choice.ModelChoice)

    def table(self) -> list[str]:
        """The model choice, then Paper I Table 2's layout: mean and max distances [mm] on
        the identification rows, the validation rows and the noise-free validation
        positions, and the time of the model choice and of the fit [s]."""
        lines = [] if self.choice is None else self.choice.table(limit=12).splitlines() + [""]
        w = max(len("model"), *(len(r.label) for r in self.rows))
        tw = max(len("time (choice + fit)"), *(len(r.time_cell()) for r in self.rows))
        first = self.rows[0]
        lines += [f"vecpin demo: Paper I design on the simulated laboratory XYZCB machine (seed {self.seed}), mm",
                  f"  {'model':<{w}s} | {f'identification ({len(first.ident)})':^21s} | "
                  f"{f'validation ({len(first.valid)})':^21s} | {'noise-free validation':^21s} | "
                  f"{'time (choice + fit)':>{tw}s}",
                  f"  {'':<{w}s} | {'mean':>10s} {'max':>10s} | {'mean':>10s} {'max':>10s} | {'mean':>10s} {'max':>10s} |"]
        for r in self.rows:
            lines.append(f"  {r.label:<{w}s} | {r.ident.mean():10.4f} {r.ident.max():10.4f} | {r.valid.mean():10.4f} "
                         f"{r.valid.max():10.4f} | {r.exact.mean():10.4f} {r.exact.max():10.4f} | "
                         f"{r.time_cell():>{tw}s}".rstrip())
        lines.append("  " + SEED_TABLE2)
        return lines


def run_demo(out_dir: str | Path, seed: int = 0, order: int = 6,
             progress: Callable[[str], None] | None = None) -> DemoResult:
    """Simulate; choose and fit the default model (``model.json``) and fit the 6-DoF and AP
    models at ``order`` (``model_6dof.json``, ``model_ap.json``); write the files into
    ``out_dir`` (all together, once everything is computed)."""
    say = progress or (lambda s: None)
    m = Machine.load("flow_xyzcb")
    design = Design()
    if int(order) != order or order < 0:
        raise InputError(f"`order` {order}: the seed's series order, a whole number >= 0 (default 6)")
    eq = 3 * design.n_commands * len(design.tools_mm)
    for kind in ("6dof", "ap"):
        unknowns = make_model(kind, m, order).n_parameters + 6
        if unknowns > eq:
            raise InputError(f"`order` {order}: the {kind} model has {unknowns} unknowns, more than the {eq} equations "
                             "of Paper I's campaign; the seed used order 6")
    check_output_dir(out_dir)
    say("simulating Paper I's campaign on flow_xyzcb (295 commands x 2 tools, 35 validation points)")
    sim = simulate(m, seed=seed, design=design, mean_error_mm=0.65)
    c, v, exact = sim.campaign, sim.validation, sim.validation_truth
    rows = []
    noise = NoiseModel.default(m, "spherical")
    run = fit_campaign(m, c, noise, progress=say)  # the default: the model the data choose
    fits = [("chosen: " + run.model.label(), run.model, "model.json",
             run.choice.seconds if run.choice is not None else None)]
    for kind in ("6dof", "ap"):  # the seed's two models at its order, for Paper I Table 2
        say(f"fitting the {kind} model, order {order} (the seed's choice)")
        fits.append((f"{MODELS[kind].display_name} order {order}", make_model(kind, m, order).fit(c, noise),
                     f"model_{kind}.json", None))
    with OutputSet(out_dir) as out:
        files = list(sim.write_into(out).values())
        for label, model, name, choice_seconds in fits:
            model.save(out.path(name))
            files.append(out.final(name))
            rows.append(DemoRow(label, norm_mm(model.residuals(c)), norm_mm(model.residuals(v)),
                                norm_mm(model.residuals(exact)), model.report_.seconds, choice_seconds))
    # the nominal tracker pose is the registration of the nominal kinematics: the same for both models
    nom = [norm_mm(x.xyz - model.predict_nominal(x.q, x.tool)) for x in (c, v, exact)]
    rows.insert(0, DemoRow("Uncompensated", *nom))
    return DemoResult(seed, rows, files, run.choice)
