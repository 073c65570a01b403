"""Volumetric compensation on the real LinuxCNC (issue 22): pitch-only COMP_FILEs against
the HAL component, judged on the true simulated machine through what the controller did.

Per machine: a random true machine (vecpin's 6-DoF family) is measured as in Paper I
(295 commands x 2 tools), the default model is fitted (the data choose it), and
``vecpin tables --controller linuxcnc`` writes its files twice: pitch only (``"limits":
{"max_cross_tables": 0}``) and with the HAL component (the default). LinuxCNC 2.9 runs
each set headless (tests/linuxcnc_sim.py) and is commanded to fresh validation commands;
the joint positions it sends to the drives (pos-cmd + COMP_FILE trim + component
correction) drive the true machine, whose tool tip (relative to the workpiece, rigidly
registered) is compared with the nominal one. Beside it: vecpin's full table set applied
in Python to the same truth. Needs LinuxCNC and root (as the tests).

Run: python benchmarks/bench_linuxcnc.py [--commands N] [--out docs/results/linuxcnc.md]
"""
from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import linuxcnc_sim as lcnc  # noqa: E402  (the harness that runs the real controller)
from results_page import publish  # noqa: E402

import vecpin  # noqa: E402
from vecpin.compensation.functions import truth_as_actual  # noqa: E402
from vecpin.compensation.report import compensated_errors
from vecpin.export import linuxcnc  # noqa: E402
from vecpin.export.profile import ControllerProfile  # noqa: E402
from vecpin.measurement.noise import NoiseModel  # noqa: E402
from vecpin.simulation.judge import validation_commands  # noqa: E402
from vecpin.simulation.simulate import Design, simulate  # noqa: E402
from vecpin.units import norm_mm  # noqa: E402
from vecpin.workflows.fitting import fit_campaign  # noqa: E402
from vecpin.workflows.tables import make_tables  # noqa: E402

MACHINES = ("trunnion_xyzac", "head_table_bc", "snk_120v")


def true_error(truth, m, tables, q, tool) -> tuple[float, float]:
    d = norm_mm(compensated_errors(truth_as_actual(truth), m, tables, q, tool))
    return float(d.mean()), float(d.max())


def through_controller(m, folder: Path, q, tables, component: bool):
    """(commands the controller sent [SI], seconds): vecpin's files in ``folder`` on LinuxCNC."""
    if component:
        lcnc.build_component(folder / "vecpin_vec.comp")
    t0 = time.time()
    joints = linuxcnc.joint_numbers(m, ControllerProfile())
    pos, pitch, cross = lcnc.machine_run(m, folder, q, joints, 0, component)
    return lcnc.to_si(m, pos + pitch + cross), time.time() - t0


def one(name: str, n_commands: int, seed: int = 1) -> dict:
    m = vecpin.Machine.load(name)
    sim = simulate(m, seed=seed, design=Design())
    fit = fit_campaign(m, sim.campaign, NoiseModel.default(m, "spherical"))
    model = fit.model
    q, tool = validation_commands(m, n_commands)
    q1 = q[:n_commands]
    out: dict = {"machine": name, "model": model.display_name}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        pitch_only = ControllerProfile(limits={"max_cross_tables": 0})
        make_tables(model, tmp / "pitch", "linuxcnc", profile=pitch_only, uncertainty=False)
        full = make_tables(model, tmp / "hal", "linuxcnc", uncertainty=False)
        out["tables"] = len(full.plan.tables.tables)
        out["uncompensated"] = true_error(sim.truth, m, None, q, tool)
        out["vecpin full tables"] = true_error(sim.truth, m, full.plan.tables, q, tool)
        for label, folder, component in (("LinuxCNC pitch only", tmp / "pitch", False),
                                         ("LinuxCNC + HAL component", tmp / "hal", True)):
            qc, seconds = through_controller(m, folder, q1, full.plan.tables, component)
            applied = lcnc.ControllerCommands(q1, qc, full.plan.tables.gauge_offset_change)
            out[label] = true_error(sim.truth, m, applied, q, tool)
            out[label + " s"] = seconds
        # what the controller applied against vecpin's tables at the same commands
        want = full.plan.tables.apply(q1)
        applied_hal = lcnc.ControllerCommands(q1, qc, 0.0).apply(q1)
        dev = np.abs(applied_hal - want)
        out["max |controller - tables|"] = max(float(m.axes[k].to_user(dev[:, k]).max()) for k in range(len(m.axes)))
    return out


def table(rows: list[dict], n_commands: int) -> str:
    lines = [f"True compensated error [mm], mean / max over {n_commands} validation commands x 2 tools, tool tip "
             "relative to the workpiece, rigidly registered (written by benchmarks/bench_linuxcnc.py).", "",
             "| machine | tables | uncompensated | LinuxCNC pitch only (COMP_FILE) | LinuxCNC + HAL component | "
             "vecpin full tables | controller - tables [mm or deg] |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        f = lambda k: f"{r[k][0]:.4f} / {r[k][1]:.4f}"  # noqa: E731
        lines.append(f"| {r['machine']} | {r['tables']} | {f('uncompensated')} | {f('LinuxCNC pitch only')} | "
                     f"{f('LinuxCNC + HAL component')} | {f('vecpin full tables')} | "
                     f"{r['max |controller - tables|']:.1e} |")
    return "\n".join(lines) + "\n"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--commands", type=int, default=40)
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "results" / "linuxcnc.md"))
    args = ap.parse_args(argv)
    why = lcnc.unavailable()
    if why:
        sys.exit(f"bench_linuxcnc: {why}")
    rows = []
    for name in MACHINES:
        t0 = time.time()
        r = one(name, args.commands)
        rows.append(r)
        print(f"{name}: uncompensated {r['uncompensated'][0]:.4f}, pitch only {r['LinuxCNC pitch only'][0]:.4f}, "
              f"HAL component {r['LinuxCNC + HAL component'][0]:.4f}, full tables {r['vecpin full tables'][0]:.4f} mm "
              f"mean; controller - tables {r['max |controller - tables|']:.1e}; LinuxCNC runs "
              f"{r['LinuxCNC pitch only s']:.0f} + {r['LinuxCNC + HAL component s']:.0f} s; {time.time() - t0:.0f} s")
    text = table(rows, args.commands)
    publish(text, args.out)


if __name__ == "__main__":
    main()
