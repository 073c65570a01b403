"""What a diagnosis found: the scores of every candidate, the accepted effects with
their evidence and advice, the outliers, where the residual lies, and three plain
sentences that say it."""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.diagnosis.detection import sightings_text, um_text
from vecpin.fileio import OutputSet
from vecpin.diagnosis.armadvice import BASE_REMEDY
from vecpin.kinematics.axes import is_arm
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.models import ErrorModel
from vecpin.models.effects import Effect


# an effect in time whose shape the model's functions of the axes take this share of is not told apart from
# them: a variance inflation factor 1 / (1 - share) of 5, the usual sign of collinearity too strong to separate
BASE_ALIKE = 0.8


@dataclass
class EffectScore:
    """One candidate's scores. ``significant``: both tests below the threshold and a
    held-out shrink worth a term; ``accepted``: taken into the model (the most
    economical significant candidate of its round)."""

    name: str
    label: str
    axes: list[str]
    n_parameters: int
    delta_chi2: float
    f_statistic: float
    p_value: float
    threshold: float
    heldout_mean_mm_before: float
    heldout_mean_mm_after: float
    heldout_max_mm_before: float
    heldout_max_mm_after: float
    significant: bool = False
    round: int = 1
    evidence: str = ""
    bic_gain: float = float("nan")
    p_heldout: float = float("nan")
    accepted: bool = False
    explains: list[str] = field(default_factory=list)
    advice: list[str] = field(default_factory=list)
    effect: Effect | None = field(default=None, repr=False)
    # the ambiguity group: candidates this campaign cannot tell from this one (one finding)
    alternatives: list[str] = field(default_factory=list)
    alternative_effects: list = field(default_factory=list, repr=False)  # their Effect instances
    dropped: bool = False  # accepted, then dropped by the backward elimination
    # significant, but predicts the ends of the axes measured over part of their travel worse
    worse_beyond: bool = False
    # how much it moves the model's prediction when fitted beside it, RMS over the rows [mm]
    size_mm: float = float("nan")
    # both tests pass, but it takes less off the held-out mean than an effect must earn
    small: bool = False
    # what to measure next to settle it (a :class:`vecpin.planning.discriminate.Discrimination`)
    next_plan: object | None = field(default=None, repr=False)
    # the share of its shape (whitened columns) the model's own functions take on these rows
    base_share: float = float("nan")
    # a drift or step in time, neither test passed, that the model's functions of the axes mimic on
    # these rows (base_share >= BASE_ALIKE): the data cannot tell the two apart
    alike_base: bool = False
    # the accepted effects the figures are given (empty: given none); its first-round figures before them
    given: list[str] = field(default_factory=list)
    before_accepted: dict | None = None
    # named, but carried by the base model's own series (no term added: :mod:`.harmonics`)
    in_base: bool = False

    @property
    def finding(self) -> str:
        """'gantry_skew[Y/x]', or 'gantry_skew[Y/x] or coupled_axes[X,Y] (this campaign cannot tell them
        apart)' for an ambiguity group."""
        if not self.alternatives:
            return self.label
        return f"{' or '.join([self.label] + self.alternatives)} (this campaign cannot tell them apart)"

    @property
    def headword(self) -> str:
        """The label and the size of the effect, e.g. 'backlash[X] (1 term)' (outliers: the label)."""
        if self.name == "outliers":
            return self.label
        return f"{self.label} ({self.n_parameters} term{'' if self.n_parameters == 1 else 's'})"

    @property
    def size_text(self) -> str:
        """:attr:`size_mm` to 0.1 µm, '-' where it has none (outliers, range-only rows)."""
        return f"{self.size_mm:.4f}" if math.isfinite(self.size_mm) else "-"

    @property
    def shrink_pct(self) -> float:
        return 100.0 * (1 - self.heldout_mean_mm_after / self.heldout_mean_mm_before)

    def to_dict(self) -> dict:
        return {"name": self.name, "label": self.label, "axes": self.axes, "significant": bool(self.significant),
                "accepted": bool(self.accepted), "heldout_mean_mm_before": self.heldout_mean_mm_before,
                "heldout_mean_mm_after": self.heldout_mean_mm_after, "heldout_max_mm_before": self.heldout_max_mm_before,
                "heldout_max_mm_after": self.heldout_max_mm_after, "shrink_pct": self.shrink_pct,
                "evidence": self.evidence, "explains": self.explains, "advice": self.advice,
                "n_parameters": self.n_parameters, "delta_chi2": self.delta_chi2, "f_statistic": self.f_statistic,
                "p_value": self.p_value, "p_heldout": self.p_heldout, "p_threshold": self.threshold,
                "round": self.round, "bic_gain": self.bic_gain, "alternatives": self.alternatives,
                "worse_beyond_the_measured_span": self.worse_beyond, "size_rms_mm": self.size_mm,
                "detected_but_small": self.small, "share_in_the_model": self.base_share,
                "not_told_apart_from_the_model": self.alike_base, "significant_given": self.given,
                "before_the_accepted_ones": self.before_accepted, "carried_by_the_base_model": self.in_base,
                "options": self.effect.options if self.effect is not None else {},
                "next_measurement": None if self.next_plan is None else {
                    "candidates": self.next_plan.labels, "points": int(len(self.next_plan.tool)),
                    "chi2_gap": self.next_plan.chi2_gap, "outcome": self.next_plan.outcome(),
                    "files": dict(self.next_plan.files),
                    "beyond_the_measured_range": {k: list(v) for k, v in self.next_plan.beyond.items()}}}


@dataclass
class Diagnosis:
    machine: Machine
    base: dict
    effects: list[EffectScore]
    outlier_rows: list[int]
    localization: dict
    base_model: ErrorModel
    best_model: ErrorModel
    heldout_base: np.ndarray          # (N,3) m, held-out residuals of the base model
    campaign: Campaign
    seconds: float
    best: tuple[float, float] = (float("nan"), float("nan"))  # held-out mean/max [mm] of the best model
    localization_final: dict | None = None
    unexplained: list[str] = field(default_factory=list)
    base_finding: str = ""
    outlier_lines: list[int] = field(default_factory=list)  # the outliers' line numbers in the campaign file
    # rows beyond the noise of the final model that are not gross errors (repeat readings
    # agree, or they crowd one stretch of an axis): {"axis", "from", "to", "unit", "rows",
    # "lines", "rows_there", "where" (short), "text" (with the file lines)}
    misfit_regions: list[dict] = field(default_factory=list)
    folder: str = ""  # where :meth:`write` put the files ("": not written): the printed paths start with it
    # per effect family the smallest size this campaign would detect given the accepted effects
    # (:meth:`vecpin.diagnosis.detection.Sight.families`, µm RMS at the measured points)
    detection: list[dict] = field(default_factory=list)

    def to_settle(self) -> list[EffectScore]:
        """Findings with a discriminating measurement (ambiguity groups, dropped effects)."""
        return [e for e in self.effects if e.next_plan is not None]

    @property
    def accepted(self) -> list[EffectScore]:
        return [e for e in self.effects if e.accepted]

    def best_heldout(self) -> tuple[float, float]:
        return self.best

    def headline(self, folder: str = "") -> list[str]:
        """Three plain sentences: where the gap lies, which effect(s) and how much they
        shrink it, what to do. ``folder``: prefix of the files named (the diagnosis'
        folder as given, for the printout; "": relative to that folder, as diagnosis.json
        holds them)."""
        b = self.base
        at = f"{folder.rstrip('/')}/" if folder else ""
        loc = self.localization
        where = [loc["breakdowns"][k]["coordinate"] for k in loc["most_structured"][:3]]
        s1 = (f"Where: after the base model ({b['label']}) the held-out residual is {b['heldout_mean_mm']:.4f} mm on "
              "average" + (f" and structured along {', '.join(where)}." if where else
                           ", with no structure beyond the scatter along any axis, time, temperature or direction."))
        acc = [e for e in self.accepted if e.name != "outliers" and not e.in_base]
        carried = [e for e in self.accepted if e.in_base]
        beyond = [e for e in self.effects if e.worse_beyond][:3]
        m, _ = self.best
        if acc:
            s2 = (f"Which: {'; '.join(e.finding for e in acc)} explain{'s' if len(acc) == 1 else ''} it: held-out mean "
                  f"{b['heldout_mean_mm']:.4f} -> {m:.4f} mm ({100 * (1 - m / b['heldout_mean_mm']):.0f}% smaller).")
        elif beyond:
            gains = ", ".join(f"{e.label} ({e.heldout_mean_mm_before:.4f} -> {e.heldout_mean_mm_after:.4f} mm)"
                              for e in beyond)
            s2 = (f"Which: {gains} would explain part of it where the axes were measured (held-out mean) but predict "
                  "the ends of the axes measured over part of their travel worse from the rest, so none is accepted "
                  "(the model is used beyond what was measured).")
        else:
            s2 = "Which: no unmodelled effect is needed; the base model explains what the noise allows."
        for e in carried:
            s2 += (f" The base model's own series carry {e.label} (size {e.size_text} mm; held-out mean "
                   f"{e.heldout_mean_mm_after:.4f} mm with it, {e.heldout_mean_mm_before:.4f} mm without).")
        if self.detection:
            s2 += f" Any other effect is below detection here: {sightings_text(self.detection, self.base['rows'])}."
        small = [e for e in self.effects if e.small and not e.accepted][:3]
        if small:
            s2 += (" Detected but too small to name: " + ", ".join(
                f"{e.label} ({e.shrink_pct:.1f}% off the held-out mean, size {e.size_text} mm)" for e in small) + ".")
        alike = [e for e in self.effects if e.alike_base][:3]
        if alike:
            s2 += (" Not told apart from the model's errors along the axes on these rows: " + ", ".join(
                f"{e.label} (size {e.size_text} mm; {e.base_share:.0%} of its shape lies in the model's)"
                for e in alike) + ".")
        if self.outlier_rows:
            n = len(self.outlier_rows)
            s2 += f" {n} {'row is a gross error' if n == 1 else 'rows are gross errors'} and {'was' if n == 1 else 'were'} left out."
        if self.misfit_regions:
            s2 += (" The model does not fit " + "; ".join(g["where"] for g in self.misfit_regions)
                   + " (misfit, not gross errors: a re-measurement would read the same).")
        todo = [e.advice[0] for e in self.accepted if e.advice and not e.in_base]
        todo += [f"To tell {_apart(e.next_plan.labels)} apart, measure the {len(e.next_plan.tool)} points of "
                 f"{at}next_{k}/ right after the campaign and diagnose again with them appended"
                 + (f" (they go beyond the measured range, {e.next_plan.beyond_text()}: nothing inside it tells them "
                    "apart, and the predictions there are extrapolations)" if e.next_plan.beyond else "") + "."
                 for k, e in enumerate(self.to_settle(), 1)]
        todo = [t if t.endswith(".") else t + "." for t in todo]
        base = (f"compensate with the tables of the base model (vecpin tables {at}model_base.json)."
                if not is_arm(self.machine)
                else f"{BASE_REMEDY[0].upper()}{BASE_REMEDY[1:]} (the base model: {at}model_base.json).")
        s3 = "What to do: " + (" ".join(todo) if todo else base) + "".join(f" {e.advice[0]}." for e in carried)
        if beyond and not acc:
            s3 += (f" To settle {', '.join(e.label for e in beyond)}, measure the axes over more of their travel; or, "
                   "if the machine is used only where they were measured, diagnose in a `zone` over their measured ranges.")
        if self.unexplained:
            coords = ", ".join(self.localization_final["breakdowns"][k]["coordinate"] for k in self.unexplained)
            after = f" after {', '.join(e.label for e in acc)}" if acc else ""
            s3 += f" Left{after}: structure along {coords} that no candidate explains."
        return [s1, s2, s3]

    def to_dict(self) -> dict:
        return {"headline": self.headline(), "base": self.base, "base_finding": self.base_finding,
                "effects": [e.to_dict() for e in self.effects], "outlier_rows": self.outlier_rows,
                "outlier_lines": self.outlier_lines, "misfit_regions": self.misfit_regions,
                "localization": self.localization, "localization_final": self.localization_final,
                "unexplained": self.unexplained, "detection": self.detection,
                "best": {"effects": [e.label for e in self.accepted], "heldout_mean_mm": self.best[0],
                         "heldout_max_mm": self.best[1]},
                "units": "mm; p-values are probabilities; localisation bins in the coordinate's unit; outlier_rows "
                         "0-based row indices of the campaign, outlier_lines their line numbers in its file (header = 1)"}

    def summary(self) -> str:
        b = self.base
        lines = self.headline(self.folder) + ([self.base_finding] if self.base_finding else []) + ["",
                                   f"base model {b['label']}: held-out mean {b['heldout_mean_mm']:.4f} mm, max "
                                   f"{b['heldout_max_mm']:.4f} mm ({b['folds']}-fold CV over {b['rows']} rows)"]
        if self.outlier_lines:
            lines.append(f"outliers: file lines {', '.join(map(str, self.outlier_lines))} of {self.campaign.source} "
                         "flagged and left out")
        lines.append(f"  {'rank':>4s} {'effect':<34s} {'signif.':>7s} {'accepted':>8s} {'before':>8s} {'after':>8s} "
                     f"{'shrink':>7s} {'size mm':>8s} {'p (fit)':>9s} {'p (held)':>9s}")
        for k, e in enumerate(self.effects[:12], 1):
            lines.append(f"  {k:4d} {e.label:<34s} {'yes' if e.significant else 'no':>7s} "
                         f"{'yes' if e.accepted else 'no':>8s} {e.heldout_mean_mm_before:8.4f} "
                         f"{e.heldout_mean_mm_after:8.4f} {e.shrink_pct:6.1f}% {e.size_text:>8s} {e.p_value:9.2e} "
                         f"{e.p_heldout:9.2e}")
        lines += [f"could have seen: {f['effect']} from {um_text(f['detectable_rms_um'])} ({f['candidate']}; "
                  f"limited by {f['limited_by']})" for f in self.detection]
        for e in self.accepted:
            lines.append(f"accepted: {e.headword}: {e.evidence}")
            lines += [f"  advice: {a}" for a in e.advice]
        m, x = self.best
        lines.append(f"best model: held-out mean {m:.4f} mm, max {x:.4f} mm "
                     f"({100 * (1 - m / b['heldout_mean_mm']):.1f}% below the base)")
        return "\n".join(lines)

    def write(self, out_dir: str | Path, draw: Callable | None = None) -> dict[str, Path]:
        """diagnosis.json, model_base.json, model_best.json, report.md and, with ``draw``
        (:func:`vecpin.viz.diagnosis.draw_diagnosis`: the figures from their data, into the
        output set), figures/, committed together (an interruption leaves the previous set)."""
        from vecpin.diagnosis.report import figure_data, write_report
        with OutputSet(out_dir) as out:
            paths = {"diagnosis": out.write_text("diagnosis.json", json.dumps(_strict(self.to_dict()), indent=1,
                                                                             default=float, allow_nan=False))}
            self.base_model.save(out.path("model_base.json"))
            self.best_model.save(out.path("model_best.json"))
            paths["model_base"], paths["model_best"] = out.final("model_base.json"), out.final("model_best.json")
            for k, e in enumerate(self.to_settle(), 1):
                paths.update(_write_next(self.machine, e.next_plan, out, f"next_{k}"))
            if draw is not None:
                draw(figure_data(self), out)
            paths["report"] = write_report(self, out, figures=draw is not None)
        self.folder = str(out_dir)
        return paths


def _apart(labels: list[str]) -> str:
    """'A and B', 'A, B and C'."""
    return labels[0] if len(labels) == 1 else f"{', '.join(labels[:-1])} and {labels[-1]}"


def _write_next(machine: Machine, plan, out: OutputSet, folder: str) -> dict[str, Path]:
    """A discriminating plan into ``folder``: the plan template (plan.csv), the expected
    readings under each candidate (expected.csv) and its NC program in every dialect whose
    axis addresses the machine's names allow (:mod:`vecpin.planning.ncprogram`)."""
    from vecpin.errors import InputError
    from vecpin.planning.ncprogram import DIALECTS, program_name
    paths = {f"{folder}/plan": out.write_text(f"{folder}/plan.csv", plan.template().to_csv(machine)),
             f"{folder}/expected": out.write_text(f"{folder}/expected.csv", plan.expected_csv(machine))}
    plan.files = {"plan": f"{folder}/plan.csv", "expected": f"{folder}/expected.csv"}
    if is_arm(machine):  # an arm's programs (:mod:`vecpin.planning.armprogram`), straight to each point
        from vecpin.planning.armprogram import ARM_DIALECTS, arm_program_name, write_arm_program
        for dialect in ARM_DIALECTS:
            name = f"{folder}/{arm_program_name(dialect)}"
            text = write_arm_program(dialect, machine, plan.template(), 0.0)
            paths[f"{folder}/{dialect}"] = out.write_text(name, text)
            plan.files[dialect] = name
        return paths
    for dialect in DIALECTS:
        try:
            text = plan.program(machine, dialect)
        except InputError as err:  # e.g. axis names that are not addresses of this dialect
            plan.files[dialect] = f"not written: {err}"
            continue
        name = f"{folder}/{program_name(dialect)}"
        paths[f"{folder}/{dialect}"] = out.write_text(name, text)
        plan.files[dialect] = name
    return paths


def _strict(value):
    """``value`` (nested dicts, lists, numbers) with every NaN or infinity as None: strict
    JSON (a test that could not run, an F statistic without scatter)."""
    if isinstance(value, dict):
        return {k: _strict(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict(v) for v in value]
    if isinstance(value, (float, np.floating)):
        return float(value) if math.isfinite(value) else None
    return value


SEED_REFERENCE = ("6dof", "chebyshev", 6)  # the seed's model: the yardstick of the base-model finding


def base_finding(choice) -> str:
    """'the base model needed ...' when the chosen model beats the seed's by more than its SE."""
    if choice is None:
        return ""
    kind, family, order = SEED_REFERENCE
    ref = next((c for c in choice.candidates if c.kind == kind
                and all(a.family == family and a.order == order for a in c.axes)), None)
    chosen = choice.chosen
    if ref is None or ref is chosen:
        return ""
    delta = ref.heldout - chosen.heldout
    se = float(np.std(delta, ddof=1) / math.sqrt(delta.size))
    if delta.mean() <= 2 * se:
        return ""
    special = [f"{a.name} {c.label()}" for a, c in zip(choice.machine.axes, chosen.axes)
               if not (c.family == "chebyshev" and c.order <= order)]
    need = f" ({', '.join(special)})" if special else ""
    return (f"The usual fixed model (6-DoF, Chebyshev order 6 on every axis: Paper I's) was too poor a base: {chosen.label()}{need} cuts the held-out "
            f"mean from {ref.mean:.4f} to {chosen.mean:.4f} mm ({100 * (1 - chosen.mean / ref.mean):.0f}% smaller).")
