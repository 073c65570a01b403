"""What a fit tells: χ² against its band, residuals, conditioning, removed terms."""
from __future__ import annotations

import math

from dataclasses import dataclass, field

import numpy as np

#: the words every output uses for what it counts, by the prefix of the unknowns' names
COUNT_WORDS = (("model", "model terms"), ("pose", "tracker-pose unknowns"), ("pivot", "ball-bar pivot unknowns"),
               ("nest", "nest-position unknowns"), ("target", "tool-target unknowns"))


def unknown_counts(names: list[str], n_model: int, mask=None) -> dict[str, int]:
    """How many of a fit's unknowns (``names``: E_0's six, the model's ``n_model`` terms,
    then the instruments' own) are of each kind of :data:`COUNT_WORDS` (only those in
    ``mask`` when given): model terms; tracker-pose unknowns (E_0, the correction of
    station 0's pose, and the pose corrections of the other stations); ball-bar pivots,
    nest positions and tool-target offsets."""
    mask = np.ones(len(names), bool) if mask is None else np.asarray(mask, bool)
    out = {k: 0 for k, _ in COUNT_WORDS}
    for i, (name, m) in enumerate(zip(names, mask)):
        if not m:
            continue
        if i < 6 or name.startswith("station"):
            out["pose"] += 1
        elif i < 6 + n_model:
            out["model"] += 1
        else:
            out[next((k for k, _ in COUNT_WORDS[2:] if name.startswith(k)), "pose")] += 1
    return out


def describe_counts(counts: dict[str, int]) -> str:
    """'163 model terms, 12 tracker-pose unknowns, 3 ball-bar pivot unknowns' (kinds with none left out)."""
    return ", ".join(f"{counts[k]} {words}" for k, words in COUNT_WORDS if counts.get(k))


def _noise_options(instrument: str) -> str:
    """The options that set the instrument noise of ``instrument`` (the Cartesian sigma
    weighs Cartesian readings only)."""
    return "`tracker_sigma_mm`" if instrument == "cartesian" else "`tracker_noise`"


@dataclass
class FitReport:
    """Figures of one fit. Residuals in mm (``residuals_mm``: overall and per tool);
    ``chi2_expected`` is the number of equations less the effective parameters."""

    model: str
    order: int
    instrument: str
    n_rows: int
    n_equations: int
    n_parameters: int
    removed: list[str]
    weak: list[str]
    effective_parameters: float
    chi2: float
    chi2_expected: float
    chi2_sigma: float
    condition_number: float
    iterations: int
    converged: bool
    seconds: float
    residuals_mm: dict
    warnings: list[str]
    tool_lengths_mm: list[float] = field(default_factory=list)
    measured_range: dict = field(default_factory=dict)  # axis -> [lowest, highest] command measured [mm or deg]
    counts: dict = field(default_factory=dict)  # unknowns by kind (:func:`unknown_counts`), n_parameters in all
    label: str = ""  # the model's kind and bases in words (ErrorModel.label); "" in files of older versions

    @property
    def chi2_band(self) -> tuple[float, float]:
        return (self.chi2_expected - 3 * self.chi2_sigma, self.chi2_expected + 3 * self.chi2_sigma)

    @property
    def chi2_in_band(self) -> bool:
        lo, hi = self.chi2_band
        return lo <= self.chi2 <= hi

    def to_dict(self) -> dict:
        d = dict(self.__dict__)
        d["chi2_band"] = list(self.chi2_band)
        d["chi2_in_band"] = self.chi2_in_band
        return d

    def summary(self) -> str:
        lo, hi = self.chi2_band
        verdict = "in band" if self.chi2_in_band else ("ABOVE band: misfit or noise model too optimistic"
                                                        if self.chi2 > hi else "BELOW band: noise model too pessimistic")
        if not self.chi2_in_band and self.chi2_expected > 0:
            scale = (self.chi2 / self.chi2_expected) ** 0.5  # residuals / assumed noise, RMS over the equations
            verdict += (f" (the residuals are {scale:.2f}x the assumed noise; if the model is right, the instrument and "
                        "repeatability sigmas are that much " + ("smaller" if scale < 1 else "larger") +
                        f": {_noise_options(self.instrument)}, `repeatability_mm`)")
        name = self.label or f"{self.model} model, order {self.order}"
        lines = [f"{name}, {self.instrument} instrument noise: {self.n_rows} rows, "
                 f"{self.n_parameters} unknowns ({describe_counts(self.counts) + '; ' if self.counts else ''}"
                 f"{len(self.removed)} redundant removed, "
                 f"{self.effective_parameters:.1f} effective), {self.iterations} iterations in {self.seconds:.2f} s",
                 f"chi2 = {self.chi2:.1f}, expected {self.chi2_expected:.1f} ± {self.chi2_sigma:.1f} "
                 f"(3σ band {lo:.1f} .. {hi:.1f}): {verdict}",
                 f"condition number (prior-scaled, kept terms): {self.condition_number:.3g}"
                 + (" (the data alone leave some kept terms undetermined: their priors hold them)"
                    if not math.isfinite(self.condition_number) else "")]
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)
