"""The quick-start job: Paper I's campaign simulated on the laboratory XYZCB machine,
both models fitted, the before/after table beside the seed's figures."""
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
    seconds: float | None = None


@dataclass
class DemoResult:
    seed: int
    rows: list[DemoRow]
    files: list[Path] = field(default_factory=list)
    choice: object = None  # the model choice (vecpin.selection.choice.ModelChoice)

    def table(self) -> list[str]:
        lines = [] if self.choice is None else self.choice.table(limit=12).splitlines() + [""]
        lines += [f"vecpin demo: Paper I design on the simulated laboratory XYZCB machine (seed {self.seed}), mm",
                 f"  {'model':<36s} | {'identification (590)':^21s} | {'validation (35)':^21s} | "
                 f"{'noise-free validation':^21s} | fit time",
                 f"  {'':<36s} | {'mean':>10s} {'max':>10s} | {'mean':>10s} {'max':>10s} | {'mean':>10s} {'max':>10s} |"]
        for r in self.rows:
            t = f"{r.seconds:6.2f} s" if r.seconds is not None else ""
            lines.append(f"  {r.label:<36s} | {r.ident.mean():10.4f} {r.ident.max():10.4f} | {r.valid.mean():10.4f} "
                         f"{r.valid.max():10.4f} | {r.exact.mean():10.4f} {r.exact.max():10.4f} | {t}")
        lines.append("  " + SEED_TABLE2)
        return lines


def run_demo(out_dir: str | Path, seed: int = 0, order: int = 6,
             progress: Callable[[str], None] | None = None) -> DemoResult:
    """Simulate, fit the 6-DoF and AP models at ``order``, write the files into ``out_dir``
    (all together, once everything is computed)."""
    say = progress or (lambda s: None)
    m = Machine.load("flow_xyzcb")
    design = Design()
    if int(order) != order or order < 0:
        raise InputError(f"--order {order}: the seed's series order, a whole number >= 0 (default 6)")
    eq = 3 * design.n_commands * len(design.tools_mm)
    for kind in ("6dof", "ap"):
        unknowns = make_model(kind, m, order).n_parameters + 6
        if unknowns > eq:
            raise InputError(f"--order {order}: the {kind} model has {unknowns} unknowns, more than the {eq} equations "
                             "of Paper I's campaign; the seed used order 6")
    check_output_dir(out_dir)
    say("simulating Paper I's campaign on flow_xyzcb (295 commands x 2 tools, 35 validation points)")
    sim = simulate(m, seed=seed, design=design, mean_error_mm=0.65)
    c, v, exact = sim.campaign, sim.validation, sim.validation_truth
    rows = []
    noise = NoiseModel.default(m, "spherical")
    run = fit_campaign(m, c, noise, progress=say)  # the default: the model the data choose
    fits = [("chosen: " + run.model.label(), run.model, "model.json")]
    for kind in ("6dof", "ap"):  # the seed's two models at its order, for Paper I Table 2
        say(f"fitting the {kind} model, order {order} (the seed's choice)")
        fits.append((f"{MODELS[kind].display_name} order {order}", make_model(kind, m, order).fit(c, noise),
                     f"model_{kind}.json"))
    with OutputSet(out_dir) as out:
        files = list(sim.write_into(out).values())
        for label, model, name in fits:
            model.save(out.path(name))
            files.append(out.final(name))
            rows.append(DemoRow(label, norm_mm(model.residuals(c)), norm_mm(model.residuals(v)),
                                norm_mm(model.residuals(exact)), model.report_.seconds))
    # the nominal tracker pose is the registration of the nominal kinematics: the same for both models
    nom = [norm_mm(x.xyz - model.predict_nominal(x.q, x.tool)) for x in (c, v, exact)]
    rows.insert(0, DemoRow("Uncompensated", *nom))
    return DemoResult(seed, rows, files, run.choice)
