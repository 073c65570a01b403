"""Table machines judged relative to the table (issue 24): on four table machines of
different kinematics (A-C trunnion, B-C trunnion, head-table B-C, the all-table XYZAC
whose spindle stands on the frame), none tuned to:

1. evaluate: a default campaign with three table nests fitted by the default model choice;
   ``evaluate``'s figures on the validation run (tool and nest rows, 35 commands, each
   point read ``VALIDATION_READS`` times at its standstill and averaged) against
   the simulated truth's own tip-relative-to-table error on the same commands (the true
   machine through its error frames, the nominal tip, the fitted model's tip, registered
   rigidly: nothing of evaluate's path). Noise-free run: like for like. Noisy run: the
   measured figure holds the tracker noise the truth's does not, so it is set against the
   truth evaluated the same way (the noisy readings registered on the *true* nests with
   scipy's ``Rotation.align_vectors``, not vecpin's code), and evaluate's model error net
   of the noise (RMS ± sd) against the truth's noise-free RMS; once more with 1000
   validation commands on the A-C trunnion (how the uncertainty shrinks).
2. verify: before/after, both runs relative to the table, against the truth commanded
   through the tables; on the noisy runs also net of the measurement noise.
3. tables on the campaign ``plan`` proposes (100 commands x 2 holders, 3 nests; default
   nests from one station, and the nests and stations of :mod:`vecpin.planning.nestplacement`),
   simulated as planned (each station reads the tool and the nests it sees), fitted, tables
   against the table floor; the share of each table axis' travel where the campaign read
   three nests at one command, and the error of the tables against the floor inside and
   outside it (what the extrapolation costs); ``--plan-seeds`` true machines each, and on
   the two trunnions true machines of the independent families (spline, bumps) too; the
   plan's validation run's time as its NC program runs it, and read once per point.
4. backlash on the trunnion's A: what the tool rows alone cannot see.

Run: python benchmarks/bench_table_machines.py [--seed N] [--plan-seeds N] [--out docs/results/table_machines.md]
"""
import argparse
import time
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

import vecpin
from vecpin.compensation.functions import truth_as_actual
from vecpin.compensation.report import compensated_errors
from vecpin.compensation.plan import plan_tables
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.features import Features
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.measurement.tableframe import repeated_readings, table_nests, table_tips, tip_noise
from vecpin.models.effects.backlash import Backlash
from vecpin.planning.nests import VALIDATION_READS
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.planning.timing import run_times
from vecpin.simulation.effects import TrueEffect
from vecpin.simulation.floor import table_floor, true_compensated_error, truth_on_its_reference_lines
from vecpin.simulation.independent import IndependentMachine
from vecpin.simulation.judge import validation_commands
from vecpin.simulation.simulate import Design, simulate
from vecpin.units import norm_mm
from vecpin.workflows.evaluation import evaluate
from vecpin.workflows.fitting import fit_campaign
from vecpin.workflows.planning import program_timing
from vecpin.workflows.verifying import verify

MACHINES = ["trunnion_xyzac", "trunnion_xyzbc", "head_table_bc", "xyzac_trt"]
FAMILIES = ["spline", "bumps"]  # true machines outside vecpin's error families (tables on the plan's campaign)


def rigid_residuals(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """q - (R p + t) after the best rigid fit (scipy, not vecpin's registration)."""
    cp, cq = p.mean(axis=0), q.mean(axis=0)
    R = Rotation.align_vectors(q - cq, p - cp)[0].as_matrix()
    return q - ((p - cp) @ R.T + cq)


def truth_errors(truth, model, run) -> tuple[float, float, float]:
    """(uncompensated mean, model mean, model RMS) [mm] relative to the table from the
    truth: true tip relative to the true table against the nominal and the model's tip
    relative to the workpiece, each registered rigidly."""
    c = run.primary()
    feats = Features.from_campaign(run).subset(run.tracker_rows)
    true = truth.tool_tip(c.q, c.tool, feats, frame="workpiece")
    nominal = truth.machine.tool_tip(c.q, c.tool, frame="workpiece")
    mod = model.tool_tip(c.q, c.tool, model.b_, jacobian=False, features=feats if model.effects else None,
                         frame="workpiece").tip
    d = [np.linalg.norm(rigid_residuals(p, true), axis=1) * 1e3 for p in (nominal, mod)]
    return float(d[0].mean()), float(d[1].mean()), float(np.sqrt(np.mean(d[1] ** 2)))


def truth_same_way(run, nests: dict, model) -> float:
    """Mean [mm] of the model's error as a run's readings show it, judged by code that is
    not vecpin's: at each command the true nests registered on their readings (scipy), the
    tool reading taken to the table through it, against the model's tip relative to the
    workpiece, registered rigidly. On a noisy run this is the truth with the run's noise.
    A point read several times at a command (the validation run's readings at standstill)
    counts as the mean of its readings."""
    key = np.unique(np.round(run.q * 1e9), axis=0, return_inverse=True)[1].ravel()
    tips, rows = [], []
    for k in np.unique(key):
        g = np.flatnonzero(key == k)
        tool = g[run.instrument[g] == "tracker"]
        nest = g[run.instrument[g] == "nest"]
        ids = sorted(set(run.target[nest]))
        if len(ids) < 3 or not len(tool):
            continue
        P = np.array([nests[str(t)] for t in ids])
        Q = np.array([run.xyz[nest[run.target[nest] == t]].mean(axis=0) for t in ids])
        rot, _ = Rotation.align_vectors(Q - Q.mean(axis=0), P - P.mean(axis=0))
        R = rot.as_matrix()
        tips.append((run.xyz[tool].mean(axis=0, keepdims=True) - Q.mean(axis=0)) @ R + P.mean(axis=0))
        rows.append(tool[:1])
    rows = np.concatenate(rows)
    c = run.subset(rows)
    mod = model.tool_tip(c.q, c.tool, model.b_, jacobian=False, frame="workpiece").tip
    return float(np.linalg.norm(rigid_residuals(mod, np.vstack(tips)), axis=1).mean() * 1e3)


def machine_rows(name: str, seed: int, n_validation: int = 35) -> tuple[list[str], dict]:
    """(table rows, figures) of one machine: evaluate noise-free and noisy, verify."""
    m = vecpin.Machine.load(name)
    t0 = time.perf_counter()
    sim = simulate(m, seed=seed, design=Design(n_validation=n_validation))
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    model = fit_campaign(m, sim.campaign, noise).model
    t_fit = time.perf_counter() - t0
    unc_t, mod_t, rms_t = truth_errors(sim.truth, model, sim.validation_truth)
    exact, noisy = evaluate(model, sim.validation_truth), evaluate(model, sim.validation)
    same = truth_same_way(sim.validation, sim.nests, model)
    net = noisy.net
    once = sim.validation.subset(np.flatnonzero(repeated_readings(sim.validation)[0]))  # the first reading of each point
    nests_once = table_nests([once], dict(model.setup_.nests))  # as evaluate takes them
    tip_once = float(tip_noise(once, table_tips(once, *nests_once), model.noise_.tracker).mean()) * 1e6
    tables = plan_tables(model, uncertainty=False).tables
    run = simulate(m, seed=seed + 1, truth=sim.truth, tables=tables)
    ver = verify(m, run.validation_truth, run.compensated_truth, model=model, tables=tables, tables_source="t")
    ver_n = verify(m, run.validation, run.compensated, model=model, tables=tables, tables_source="t")
    c = run.validation_truth.primary()
    # like with like: the nests' registration knows the table as the model places it, on the truth the table
    # aligned to its own reference lines; the part's frame (the true table's face) beside it
    true_b, true_a, part_a = (true_compensated_error(sim.truth, tb, c.q, c.tool, j)[0]
                              for tb, j in ((None, "reference"), (tables, "reference"), (tables, "part")))
    ref = truth_on_its_reference_lines(sim.truth)
    rms_true = [float(np.sqrt(np.mean(norm_mm(compensated_errors(ref, m, tb, c.q, c.tool)) ** 2))) for tb in (None, tables)]
    nb, na = ver_n.net
    tag = name if n_validation == 35 else f"{name}, {n_validation} validation commands"
    figures = {"exact": exact.residual.mean() / mod_t, "same": noisy.residual.mean() / same,
               "net": (net.rms - rms_t) / net.sd, "net_sd": net.sd * 1e3, "verify": ver.after.measured.mean() / true_a, "face_ratio": part_a / true_a,
               "rms": rms_t * 1e3, "noise": net.noise_rms * 1e3, "tip": noisy.noise_mm * 1e3, "tip_once": tip_once,
               "resolved": net.resolved,
               "for_10pct": n_validation * (net.ms_sd / (0.2 * rms_t**2)) ** 2}  # commands for an sd of 10 % of the RMS
    return [
        f"| {tag} | {model.label()} | {unc_t:.4f} | {exact.uncompensated.mean():.4f} | {mod_t * 1e3:.1f} | "
        f"{exact.residual.mean() * 1e3:.1f} | {exact.residual.mean() / mod_t:.3f} | {t_fit:.0f} |",
        f"| {tag} | {noisy.residual.mean() * 1e3:.1f} | {same * 1e3:.1f} | {noisy.residual.mean() / same:.3f} | "
        f"{noisy.noise_mm * 1e3:.1f} | {tip_once:.1f} | {net.noise_rms * 1e3:.1f} | {rms_t * 1e3:.1f} | "
        f"{'' if net.resolved else 'not resolved, '}{net.rms * 1e3:.1f} ± {net.sd * 1e3:.1f} | "
        f"{abs(net.rms - rms_t) / net.sd:.1f} |",
        f"| {tag} | {true_b:.4f} | {ver.before.measured.mean():.4f} | {true_a * 1e3:.1f} | {part_a * 1e3:.1f} | "
        f"{ver.after.measured.mean() * 1e3:.1f} | {ver.after.predicted.mean() * 1e3:.1f} | "
        f"{ver.reduction('mean'):.1f} % | {ver_n.before.measured.mean():.4f} | {ver_n.after.measured.mean() * 1e3:.1f} | "
        f"{nb.rms:.4f} ± {nb.sd:.4f} ({rms_true[0]:.4f}) | "
        f"{'' if na.resolved else 'not resolved, '}{na.rms * 1e3:.1f} ± {na.sd * 1e3:.1f} ({rms_true[1] * 1e3:.1f}) |"], \
        figures


def seen_travel(m, campaign: Campaign, q: np.ndarray) -> tuple[str, np.ndarray]:
    """(text, (N,) bool): per table axis the share of its travel (twentieths) where the
    campaign read three nests at one command from one station; which commands q lie in
    a twentieth of some table axis that no such command reached."""
    key = np.unique(np.c_[campaign.station, np.round(campaign.q * 1e9)], axis=0, return_inverse=True)[1].ravel()
    nest = campaign.instrument == "nest"
    counts = np.bincount(key[nest], minlength=key.max() + 1)
    full = counts[key] >= 3
    out, blind = [], np.zeros(len(q), bool)
    for name in m.table_axes:
        a = m.axis(name)
        b = np.clip(((campaign.q[full, a.index] - a.lower) / a.travel * 20).astype(int), 0, 19)
        hit = np.zeros(20, bool)
        hit[b] = True
        out.append(f"{name} {100 * hit.mean():.0f} %")
        bq = np.clip(((q[:, a.index] - a.lower) / a.travel * 20).astype(int), 0, 19)
        blind |= ~hit[bq]
    return ", ".join(out), blind


def validation_minutes(m, plan) -> tuple[float, float]:
    """(minutes of the plan's validation run as its NC program runs it, the same run reading
    every point once), at the program's default settings (4 s dwell, 15 s per nest, 2 s per
    further reading)."""
    timing = program_timing(m, plan, dwell_s=4.0, nest_dwell_s=15.0, feed_mm_min=1000.0, safe_z_mm=None,
                            retract=None, holder_change_s=120.0)
    _, run, once = run_times(m, plan.validation_template, timing, plan.validation_reads)
    return run.total_s / 60, once.total_s / 60


def plan_row(name: str, seed: int, place: bool, family: str | None = None) -> tuple[str, float, str]:
    """(table row, tables / floor, the validation run's time row) on the campaign plan
    proposes (see the module text); ``family``: the true machine from the independent
    family (simulation/independent)."""
    m = vecpin.Machine.load(name)
    plan = make_plan(m, PlanSettings(place_nests=place, seed=0))
    minutes, once = validation_minutes(m, plan)
    v = plan.validation_template
    timed = (f"| {name} | {'placed' if place else 'default'} | {len(v.tool_rows) // plan.validation_reads} | "
             f"{plan.validation_reads} | {len(v)} | {minutes:.1f} | {once:.1f} | {minutes / once:.2f} |")
    stations = plan.placement.stations if plan.placement else [plan.tracker]
    truth = IndependentMachine.random(m, family, seed=seed) if family else None
    # the plan as vecpin writes it: a second station's block of rows (template column station) read from there
    sim = simulate(m, seed=seed, plan=plan.template, station_positions=stations, truth=truth)
    camp = sim.campaign
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    model = fit_campaign(m, camp, noise).model
    tables = plan_tables(model, uncertainty=False).tables
    q, tool = validation_commands(m, 300, seed=7)
    floor = table_floor(sim.truth, q, tool)
    actual = truth_as_actual(sim.truth)
    d_vec = norm_mm(compensated_errors(actual, m, tables, q, tool))
    d_floor = norm_mm(compensated_errors(actual, m, floor.tables, q, tool))
    seen, blind = seen_travel(m, camp, q)
    inside = f"{d_vec[~blind].mean() / d_floor[~blind].mean():.2f}" if (~blind).any() else "-"
    outside = f"{d_vec[blind].mean() / d_floor[blind].mean():.2f} ({100 * blind.mean():.0f} %)" if blind.any() else "-"
    where = "placed" if place else "default"
    return (f"| {name} | {family or 'vecpin'} {seed} | {where} | {len(stations)} | {int(camp.nest_rows.size)} | {seen} | {d_vec.mean():.4f} | "
            f"{d_floor.mean():.4f} | {d_vec.mean() / d_floor.mean():.2f} | {inside} | {outside} |"), \
        float(d_vec.mean() / d_floor.mean()), timed


def backlash_rows(seed: int) -> list[str]:
    """Backlash on the trunnion's A: the model without it and with it, at the tool and
    relative to the table (noise-free validation), against the truth."""
    m = vecpin.Machine.load("trunnion_xyzac")
    sim = simulate(m, seed=seed, design=Design(n_commands=200, n_validation=60),
                   effects=[TrueEffect("backlash", ("A",), 0.03, seed=2)])
    noise = NoiseModel.default(m, "spherical", tracker=sim.truth.tracker.noise)
    v = sim.validation_truth
    out = []
    for label, effects in (("6-DoF, no backlash term", []), ("6-DoF + backlash[A]", [Backlash(m, ("A",))])):
        model = make_model("6dof", m, 4, bases=sim.truth.family_bases(), effects=effects).fit(sim.campaign, noise)
        table, tool = evaluate(model, v), evaluate(model, v.subset(v.tracker_rows))
        out.append(f"| {label} | {tool.residual.mean() * 1e3:.1f} | {table.residual.mean() * 1e3:.1f} | "
                   f"{truth_errors(sim.truth, model, v)[1] * 1e3:.1f} |")
    return out


HEAD = {
    "evaluate": ["| machine | model | truth uncomp. | evaluate uncomp. (noise-free) | truth model um | evaluate model um "
                 "(noise-free) | ratio | fit s |", "|---|---|---|---|---|---|---|---|"],
    "noisy": ["| machine | evaluate model um (noisy) | truth the same way um (noisy readings, true nests, scipy) | ratio | "
              "tracker noise at the tip um | the same, first reading of each point um | noise netted out um RMS | "
              "truth model RMS um (noise-free) | evaluate net of noise RMS um (± sd) | distance in sd |",
              "|---|---|---|---|---|---|---|---|---|---|"],
    "verify": ["| machine | truth before | verify before (noise-free) | truth after um | truth after um, true table's face "
               "| verify after um | predicted after um | reduction | verify before (noisy) | verify after um (noisy) | verify "
               "before RMS net of noise (truth RMS) | verify after RMS um net of noise (truth RMS) |",
               "|---|---|---|---|---|---|---|---|---|---|---|---|"],
    "time": ["| machine | nests | validation commands | readings per point | rows | minutes | minutes reading every "
             "point once | ratio |", "|---|---|---|---|---|---|---|---|"],
    "plan": ["| machine | truth, seed | nests | stations | nest rows | travel with 3 nests read | tables | floor | tables / floor | "
             "seen part / floor | unseen part / floor (share of commands) |", "|---|---|---|---|---|---|---|---|---|---|---|"],
}


def summary(figs: list[dict], ratios: dict) -> list[str]:
    """What the figures meet, counted from them."""
    def n(cond):
        return f"{sum(map(cond, figs))} of {len(figs)}"

    def lo_hi(key, fmt=".1f"):
        v = [f[key] for f in figs]
        return f"{min(v):{fmt}}-{max(v):{fmt}}"
    out = [f"- noise-free: evaluate's model figure within 10 % of the truth's in {n(lambda f: abs(f['exact'] - 1) < 0.1)} "
           "runs; verify's after within 10 % of the truth commanded through the tables in "
           f"{n(lambda f: abs(f['verify'] - 1) < 0.1)} (the truth's table aligned to its own reference lines: what the "
           "nests tell without their heights above the face; on the true face the truth's after is "
           f"{lo_hi('face_ratio', '.2f')}x that, the face's tilt this campaign cannot see);",
           f"- noisy: evaluate's figure within 10 % of the truth evaluated the same way in "
           f"{n(lambda f: abs(f['same'] - 1) < 0.1)}; its model error net of the noise within two standard "
           f"uncertainties of the truth's noise-free RMS in {n(lambda f: abs(f['net']) < 2)}, resolved (at least "
           f"twice its uncertainty) in {n(lambda f: f['resolved'])} (uncertainty {lo_hi('net_sd')} um, a "
           f"{lo_hi('rms')} um model error (RMS) under {lo_hi('noise')} um of noise netted out: 35 validation "
           f"commands, each point read {VALIDATION_READS} times at its standstill; the tracker noise at the tip "
           f"{lo_hi('tip')} um, {lo_hi('tip_once')} um from the first reading of each point; an uncertainty of 10 % "
           f"would take {lo_hi('for_10pct', '.0f')} commands);",
           "- tables on the plan's campaign, at most 1.15x the floor: " + "; ".join(
               f"{label} {sum(r <= 1.15 for r in v)} of {len(v)} (median {np.median(v):.2f}x, max {max(v):.2f}x)"
               for label, v in (("default nests, one station:", ratios["default"]),
                                ("placed nests and stations:", ratios["placed"]))) + "."]
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--plan-seeds", type=int, default=3, help="seeds of the tables on the plan's campaign")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "docs" / "results" / "table_machines.md"))
    args = ap.parse_args()
    rows = {k: [] for k in HEAD}
    figs, ratios = [], {"default": [], "placed": []}
    runs = [(name, 35) for name in MACHINES] + [("trunnion_xyzac", 1000)]
    for name, n_val in runs:
        lines, f = machine_rows(name, args.seed, n_val)
        for key, line in zip(("evaluate", "noisy", "verify"), lines):
            if key != "verify" or n_val == 35:  # verify runs its own 35 commands
                rows[key].append(line)
            print(line, flush=True)
        if n_val == 35:
            figs.append(f)
    cases = [(name, seed, None) for name in MACHINES for seed in range(args.seed, args.seed + args.plan_seeds)]
    cases += [(name, args.seed, fam) for name in MACHINES[:2] for fam in FAMILIES]
    for name, seed, fam in cases:
        for place in (False, True):
            line, r, timed = plan_row(name, seed, place, fam)
            if seed == args.seed and fam is None:
                rows["time"].append(timed)
                print(timed, flush=True)
            rows["plan"].append(line)
            ratios["placed" if place else "default"].append(r)
            print(line, flush=True)
    bl = backlash_rows(10)
    print("\n".join(bl))
    summ = summary(figs, ratios)
    print("\n".join(summ))
    text = "\n".join([
        "# Table machines judged relative to the table",
        "",
        f"`python benchmarks/bench_table_machines.py --seed {args.seed}` (the module text says what each part does). "
        "Default campaign: 295 commands x 2 tools, 3 table nests, default model choice, 35 validation commands each "
        f"read at the tool and at the 3 nests, every point {VALIDATION_READS} times at its standstill (their mean "
        "judged). Truth: the simulated true machine's tip relative to its table against "
        "the nominal / the model's tip, registered rigidly (not evaluate's path). mm unless marked um.",
        "",
        "## summary (counted from the tables below)", "", *summ, "",
        "## evaluate, noise-free validation (like for like)", "", *HEAD["evaluate"], *rows["evaluate"], "",
        "## evaluate, noisy validation",
        "",
        "A noisy run's measured figure is the model error plus the measurement noise (the tracker's on the tool and "
        "on each nest, the axes' positioning noise) through the nest registration, which "
        "the truth's figure does not hold. Like with like: the truth evaluated the same way (the same noisy readings "
        "registered on the true nests by scipy), and evaluate's estimate net of the noise (the noise's expected "
        "contribution per row, from re-noised copies of the run, subtracted in quadrature) against the truth's "
        "noise-free RMS, with its standard uncertainty. 'tracker noise at the tip': evaluate's note (the tracker's "
        "alone, mean, through the nests' registration, each point's readings averaged; beside it the same from the "
        "first reading of each point). 'noise netted out': the tracker's noise divided by the readings plus the "
        "axes' positioning noise, the same for every reading at a standstill (tests/test_standstill.py). The last "
        "row: the same machine and seed with 1000 validation commands (not in the summary).",
        "", *HEAD["noisy"], *rows["noisy"], "",
        "## verify (both runs relative to the table, tables of the model, generic controller)", "",
        "Net of noise: verify's RMS of each noisy run relative to the table with the noise's expected share taken "
        "out (as evaluate), ± one standard uncertainty; in brackets the truth's RMS on the same commands (the true "
        "machine commanded through the tables against the nominal, registered rigidly).", "",
        *HEAD["verify"], *rows["verify"], "",
        "## tables on the campaign plan proposes (100 commands x 2 holders, 3 nests, 300 judging commands x 2 tools)",
        "",
        "'default': the default nests read from the plan's tracker; 'placed': nests and stations from "
        "vecpin.planning.nestplacement (a second station's block of the plan: the tool and the nests it sees at the first holder's commands where it sees a nest). Travel "
        "with 3 nests read: share of each table axis' travel (twentieths) where the campaign read three nests at one "
        "command; the rest the model's table-axis terms and the tables extrapolate; its cost: tables / floor on the "
        "judging commands in such a twentieth.",
        "", *HEAD["plan"], *rows["plan"], "",
        "## the plan's validation run: time as its NC program runs it", "",
        "The plans above (seed 0) at the NC program's defaults (4 s dwell at a point's first reading, 15 s at a "
        "nest's first, 2 s, the tracker's reading time, at every further reading; approach at 1000 mm/min, rapid "
        "moves at the plan's speeds): the run reading every "
        f"point {VALIDATION_READS} times at its standstill, and the same run reading every point once (the moves are "
        "the same).", "", *HEAD["time"], *rows["time"], "",
        "## backlash on A (trunnion_xyzac, 0.03 mm, noise-free validation of 60 commands)",
        "",
        "| model | evaluate at the tool um | evaluate relative to the table um | truth relative to the table um |",
        "|---|---|---|---|",
        *bl,
        ""])
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(text)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
