"""Calibrate a real UR10 from the public laser-tracker dataset, judged on held-out poses.

The data: 400 random poses of a UR10 (CB3) measured by a laser tracker (series C of
github.com/christianlandgraf/ipa-robot-accuracy, MIT licence; tests/data/ipa_ur10/,
PROVENANCE.md there). vecpin reads the dataset's file as it is (semicolons, decimal
commas, joints in rad), fits the model the data choose (the default of ``vecpin fit``:
kind, basis and order by held-out cross-validation, the noise level from the data, printed
as its variance components) on the training poses, and judges it
on poses it never saw, beside the nominal model (the bundled ur10's published DH
kinematics with the tracker pose fitted to the same training poses):

* interleaved: every 4th pose held out (the same workspace, new poses);
* reach: the 20% of poses farthest from joint 1's axis held out (the fit never saw the
  outer workspace: extrapolation);
* joint1: the 20% of poses with the highest joint 1 angle held out (beyond the joint
  range the fit saw: the model's series extrapolate there, unless its errors are held at
  their values at the edge of the measured range, as the tables hold them).

    python examples/ur10_real_data.py [FILE] [--poses N]

FILE: any series' ``measurements_*.csv`` of the dataset (default: the 400 poses in
tests/data); ``--poses N``: the first N poses only (e.g. 48: a 36-pose training set).
The same steps on the command line:

    vecpin import tests/data/ipa_ur10/random_poses_400.csv --machine ur10 --format ipa-robot-accuracy \\
        --out ur10/campaign.csv
    vecpin fit ur10 ur10/campaign.csv --out ur10/model.json
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from vecpin import Machine, VecpinError
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.registration import rigid_registration
from vecpin.measurement.robotaccuracy import read_dataset
from vecpin.units import norm_mm
from vecpin.workflows.fitting import fit_campaign

DATA = Path(__file__).resolve().parents[1] / "tests" / "data" / "ipa_ur10" / "random_poses_400.csv"


def held_out(machine: Machine, campaign, split: str) -> np.ndarray:
    """The held-out rows of a split: ``interleaved`` every 4th pose, ``reach`` the 20%
    of poses whose nominal tool point lies farthest from joint 1's axis, ``joint1`` the
    20% with the highest joint 1 angle."""
    if split == "interleaved":
        return np.arange(len(campaign)) % 4 == 3
    if split == "joint1":
        return campaign.q[:, 0] > np.quantile(campaign.q[:, 0], 0.8)
    tip = machine.tool_tip(campaign.q, campaign.tool)
    reach = np.hypot(tip[:, 0], tip[:, 1])
    return reach > np.quantile(reach, 0.8)


def judge(machine: Machine, campaign, split: str) -> dict:
    """Fit the default model on the training poses of ``split``; held-out distances [mm]
    of the nominal model (tracker pose fitted to the training poses), of the fit, and of
    the fit with its errors held beyond the measured range."""
    t0 = time.perf_counter()
    test = held_out(machine, campaign, split)
    train, held = campaign.subset(~test), campaign.subset(test)
    run = fit_campaign(machine, train, NoiseModel.default(machine, "cartesian"), noise_from_data=True)
    R, t = rigid_registration(machine.tool_tip(train.q, train.tool), train.xyz)
    nominal = norm_mm(held.xyz - (machine.tool_tip(held.q, held.tool) @ R.T + t))
    fitted = norm_mm(run.model.residuals(held))
    kept = norm_mm(run.model.hold_beyond_measured().residuals(held))
    return {"split": split, "train": len(train), "held_out": len(held), "choice": run.choice,
            "nominal_mean": float(nominal.mean()), "nominal_max": float(nominal.max()),
            "fit_mean": float(fitted.mean()), "fit_max": float(fitted.max()),
            "held_mean": float(kept.mean()), "held_max": float(kept.max()), "seconds": time.perf_counter() - t0,
            "noise": run.noise_line()}


def run(path: str | Path = DATA, poses: int | None = None, splits=("interleaved", "reach", "joint1"),
        say=print) -> list[dict]:
    """Read, then :func:`judge` every split; prints as it goes and returns the figures."""
    t0 = time.perf_counter()
    m = Machine.load("ur10")
    read = read_dataset(path, m)
    say("\n".join(read.lines()))
    c = read.campaign if poses is None else read.campaign.subset(np.arange(min(poses, len(read.campaign))))
    if len(c) < len(read.campaign):
        say(f"  the first {len(c)} poses used")
    out = []
    for split in splits:
        try:
            r = judge(m, c, split)
        except VecpinError as exc:  # e.g. a fit that cannot converge: said, and the next split
            say(f"\n{split}: the default fit failed: {exc}")
            continue
        ch = r["choice"]
        say(f"\n{split}: {r['train']} training poses, {r['held_out']} held out")
        say(f"  chosen: {ch.chosen.label()} ({ch.chosen.n_terms} model terms; {len(ch.candidates)} candidates scored"
            + (f", {ch.left_out} larger ones left out: more unknowns than the {ch.equations} equations" if ch.left_out
               else "") + ")")
        if ch.part_turn:
            say(f"  no series per turn on {', '.join(ch.part_turn)} (measured over less than a turn)")
        say("  held-out distance, mm      mean      max")
        say(f"    nominal model        {r['nominal_mean']:8.3f} {r['nominal_max']:8.3f}")
        say(f"    default fit          {r['fit_mean']:8.3f} {r['fit_max']:8.3f}   "
            f"({r['fit_mean'] / r['nominal_mean']:.2f}x the nominal mean; {r['seconds']:.1f} s)")
        say(f"    fit, errors held     {r['held_mean']:8.3f} {r['held_max']:8.3f}   (beyond the measured range)")
        say("  " + r["noise"].replace("\n", "\n  ") if r["noise"] else "  the stated noise kept")
        out.append(r)
    say(f"\nwhole run: {time.perf_counter() - t0:.1f} s")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("file", nargs="?", default=str(DATA), help="a measurements_*.csv of the dataset")
    ap.add_argument("--poses", type=int, help="the first N poses only (default: all)")
    args = ap.parse_args()
    run(args.file, args.poses)


if __name__ == "__main__":
    main()
