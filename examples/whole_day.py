"""The calibration engineer's whole day on a simulated machine, with vecpin alone.

plan -> measure (the plan simulated on a true machine, as if measured) -> the tracker
software's export in a foreign format (semicolon, decimal comma, inches, its own column
names, a BOM, a comment line, date-time stamps, °F) -> import -> decide (repeatability,
Section 2.4) -> fit -> tables -> the compensated machine measured on the validation
commands -> verify, beside the seed's Paper I Table 3.

    python examples/whole_day.py [OUT_DIR] [--points N] [--order K] [--seed S]

The same steps on the command line:

    vecpin plan flow_xyzcb --points 150 --order 4 --repeat 6 4 --out day/plan
    vecpin simulate flow_xyzcb --plan day/plan/plan.csv --tracker X,Y,Z --seed 3 --out day/sim
    (measure; export from the tracker software)
    vecpin import export.csv --machine flow_xyzcb --plan day/plan/plan.csv --out day/campaign.csv
    vecpin assess day/campaign.csv --machine flow_xyzcb
    vecpin fit flow_xyzcb day/campaign.csv --model ap --order 4 --out day/model_ap.json
    vecpin tables day/model_ap.json --out day/tables
    vecpin simulate flow_xyzcb --truth day/sim/truth.json --plan day/plan/plan.csv --tables day/tables --out day/after
    vecpin verify day/after/validation.csv day/after/validation_compensated.csv --model-file day/model_ap.json \\
        --tables day/tables --out day/verify
"""
from __future__ import annotations

import argparse
import sys
from datetime import datetime, timedelta
from pathlib import Path

import numpy as np

from vecpin import Machine, make_model
from vecpin.compensation.plan import plan_tables
from vecpin.export.generic import write_tables as write_generic
from vecpin.fileio import write_text
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.plantemplate import point_name, read_template
from vecpin.planning.plan import PlanSettings
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.truth import TrueMachine
from vecpin.workflows.assessing import assess_campaign
from vecpin.workflows.importing import import_to_file
from vecpin.workflows.planning import plan_to_dir
from vecpin.workflows.verifying import verify_to_dir

START = datetime(2024, 3, 5, 7, 30, 0)


def write_foreign_export(path: Path, campaign, drop: tuple[int, ...] = ()) -> Path:
    """What a tracker program might export: UTF-8 with BOM, a comment line, semicolons,
    decimal commas, inches, point names, its own column names and order, German-style date
    and time, air temperature in °F. Rows ``drop`` were not measured (say, the beam broke)."""
    lines = ["# Exported by TrackerSoft 7.2; job 'VEC flow_xyzcb'",
             "Name;Air Temp (F);Timestamp;Meas X;Meas Y;Meas Z;Sigma"]
    xyz_in = campaign.xyz * 1000.0 / 25.4
    temp_f = campaign.temperature * 9.0 / 5.0 + 32.0
    for i in range(len(campaign)):
        if i in drop:
            continue
        t = (START + timedelta(seconds=float(campaign.time[i]))).strftime("%d.%m.%Y %H:%M:%S")
        cells = [point_name(int(campaign.extra["point"][i])), f"{temp_f[i]:.3f}", t] + \
                [f"{v:.6f}" for v in xyz_in[i]] + ["0.00040"]
        lines.append(";".join(c.replace(".", ",") if c[0] in "-0123456789" and ":" not in c else c for c in cells))
    return write_text(path, "\ufeff" + "\r\n".join(lines) + "\r\n")


def run(out_dir: str | Path = "whole_day", points: int = 150, order: int = 4, seed: int = 3,
        say=print) -> dict:
    """Every step of the day; returns the objects and figures of each step."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    m = Machine.load("flow_xyzcb")
    tracker_mm = (3000.0, -2300.0, -300.0)

    say("1. plan")
    settings = PlanSettings(n_commands=points, model="ap", order=order, tracker_mm=tracker_mm, repeat_points=6,
                            repeat_times=4, exclude=[{"X": (0.0, 600.0), "B": (-111.0, -60.0)}], seed=seed)
    planned = plan_to_dir(m, out / "plan", settings)
    say("\n".join(planned.lines()))
    template = read_template(out / "plan" / "plan.csv", m)

    say("2. measure: the plan on a simulated true machine (tracker where the plan put it)")
    truth = TrueMachine.random(m, np.random.default_rng(seed), mean_error_mm=0.65)
    design = Design(n_validation=35, exclude=settings.exclude)
    tracker = np.array(tracker_mm) * 1e-3
    sim = simulate(m, seed, design, truth=truth, plan=(template.q, template.tool), tracker_position=tracker)
    measured = sim.campaign
    measured.extra["point"] = template.point.astype(float)

    say("3. the tracker software's export (semicolon, decimal comma, inches, °F, its own names)")
    export = write_foreign_export(out / "tracker_export.csv", measured, drop=(17, 18))

    say("4. import")
    imported = import_to_file(export, m, out / "campaign.csv", out / "plan" / "plan.csv")
    say("\n".join(imported.lines()))
    campaign = imported.campaign

    say("5. decide (Section 2.4)")
    assessment = assess_campaign(campaign, m)
    say("\n".join(assessment.lines()))

    say("6. fit")
    model = make_model("ap", m, order).fit(campaign, NoiseModel.default(m, "spherical"))
    model.save(out / "model_ap.json")
    say(model.report_.summary())

    say("7. tables")
    tables = plan_tables(model).tables
    write_generic(tables, m, out / "tables")

    say("8. the compensated machine measured on the validation commands")
    after = simulate(m, seed + 100, design, truth=truth, plan=(template.q, template.tool), tables=tables,
                     tracker_position=tracker)

    say("9. verify")
    verification = verify_to_dir(m, after.validation, after.compensated, out / "verify", model=model, tables=tables,
                                 tables_source=str(out / "tables" / "tables.json"))
    say("\n".join(verification.lines()))
    return {"plan": planned, "simulation": sim, "export": export, "imported": imported, "assessment": assessment,
            "model": model, "tables": tables, "after": after, "verification": verification, "truth": truth}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", nargs="?", default="whole_day", help="output folder (default whole_day)")
    p.add_argument("--points", type=int, default=150, help="planned commands (default 150)")
    p.add_argument("--order", type=int, default=4, help="AP model order (default 4)")
    p.add_argument("--seed", type=int, default=3, help="seed of the simulated machine (default 3)")
    a = p.parse_args(argv)
    run(a.out, a.points, a.order, a.seed)
    return 0


if __name__ == "__main__":
    sys.exit(main())
