"""What no table can follow: the share of a model's error that the full table set leaves.

A compensation table corrects one output direction as a function of one input axis. An
error that depends on two axes at once (the squareness of X to Y that changes with the
tilt of A, a tool-direction error whose effect at the tip grows with the tool length, a
rotary axis whose wobble depends on where the linear axes stand) cannot be written as a
sum of such functions: the full table set, the least-squares best of them, leaves it. This
module measures that leftover on the tables' own pseudo-measurements, in the part's frame,
names the inputs it couples (a two-variable Chebyshev fit of the leftover, beside the
one-variable fits of each input alone) and says what would remove it for the machine's
class: a kinematics calibration of the 5-axis transformation or the controller's
volumetric function on a machine tool, the model in the robot controller on an arm.
"""
from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from vecpin.kinematics.machine import Machine
from vecpin.units import norm_mm

ORDER = 3              # Chebyshev order per input of the coupling fits
NAMED_SHARE = 0.25     # a pair named when its products explain this share of the leftover beyond its two inputs alone
MATERIAL = 1.5         # the leftover is worth a word when the full tables leave this times the model's fit residual


@dataclass
class Unfollowed:
    """The model-predicted mean error [mm] before and after the full tables on the same
    commands (the part's frame), the pairs of inputs the leftover couples (label, share of
    the leftover's variance their joint fit explains beyond either alone) and the remedy."""

    before_mm: float
    after_mm: float
    fit_mm: float
    pairs: list[tuple[str, float]]
    remedy: str
    products: str = ""                 # the product terms written with the full tables ('' : none)
    one_axis_mm: float | None = None   # where they are: what the one-axis tables alone leave [mm]

    @property
    def share(self) -> float:
        """The share of the model's mean error that the full tables leave."""
        return self.after_mm / self.before_mm if self.before_mm > 0 else 0.0

    def line(self) -> str:
        """The report's line: what the tables written leave (with their product terms where they carry
        any, the one-axis tables' figure beside it), and what would remove it."""
        tables = "the full tables" + (f" with the product terms {self.products}" if self.products else "")
        alone = ("" if self.one_axis_mm is None else
                 f"; the one-axis tables alone, before the product terms, leave {self.one_axis_mm:.4f} mm")
        if self.after_mm <= MATERIAL * self.fit_mm or self.after_mm < 1e-3:
            return (f"what no table can follow: {tables} leave {self.after_mm:.4f} mm mean, within "
                    f"{MATERIAL:g} x the model's own fit residual ({self.fit_mm:.4f} mm): they follow the model{alone}")
        coupled = ("; the leftover couples " + ", ".join(f"{p} ({s:.0%})" for p, s in self.pairs)
                   if self.pairs else "; the leftover is spread over many inputs at once")
        return (f"what no table can follow: {self.share:.0%} of the model's error ({self.after_mm:.4f} of "
                f"{self.before_mm:.4f} mm mean, after {tables}) depends on two or more inputs at once, which "
                f"{'these tables' if self.products else 'tables of one input axis'} cannot carry{coupled}{alone}. "
                f"What would remove it: {self.remedy}")


def _chebyshev(u: np.ndarray, order: int) -> np.ndarray:
    """(N, order) Chebyshev T1..T_order of u in [-1, 1]."""
    return np.polynomial.chebyshev.chebvander(u, order)[:, 1:]


def _explained(columns: np.ndarray, r: np.ndarray) -> float:
    """Share of the variance of r (N,3) that a least-squares fit on ``columns`` (N,k) explains."""
    A = np.column_stack([np.ones(len(r)), columns])
    coef = np.linalg.lstsq(A, r, rcond=None)[0]
    total = float(((r - r.mean(axis=0)) ** 2).sum())
    return 1.0 - float(((r - A @ coef) ** 2).sum()) / total if total > 0 else 0.0


def coupled_pairs(inputs: dict[str, np.ndarray], leftover: np.ndarray) -> list[tuple[str, float]]:
    """The pairs of ``inputs`` ({name: (N,) values}) whose joint Chebyshev fit (products
    included) explains more of ``leftover`` (N,3) than the sum of a function of each alone,
    by :data:`NAMED_SHARE` of its variance or more, best first (at most three):
    (``"A with C"``, that gain)."""
    basis = {}
    for name, v in inputs.items():
        lo, hi = float(np.min(v)), float(np.max(v))
        if hi - lo > 0:
            basis[name] = _chebyshev(2 * (v - lo) / (hi - lo) - 1, ORDER)
    gains = []
    for a, b in combinations(basis, 2):
        cross = (basis[a][:, :, None] * basis[b][:, None, :]).reshape(len(leftover), -1)
        additive = _explained(np.column_stack([basis[a], basis[b]]), leftover)
        joint = _explained(np.column_stack([basis[a], basis[b], cross]), leftover)
        gains.append((f"{a} with {b}", joint - additive))
    return sorted([g for g in gains if g[1] >= NAMED_SHARE], key=lambda g: -g[1])[:3]


def remedy(machine: Machine) -> str:
    """What removes an error that tables of one axis cannot carry, for the machine's class."""
    kinds = {a.kind for a in machine.axes}
    if "linear" not in kinds:
        return ("the model in the robot controller (its kinematic calibration: joint offsets, link lengths and "
                "twists, or the vendor's absolute-accuracy option), which tables of one joint cannot replace")
    if "rotary" in kinds:
        return ("a kinematics calibration of the controller's 5-axis transformation for the rotary axes' positions "
                "and directions (e.g. Siemens CYCLE996, Heidenhain KinematicsOpt), and the controller's volumetric "
                "function for the rest (e.g. Siemens VCS, Heidenhain KinematicsComp, Fanuc 3-D error compensation)")
    return ("the controller's volumetric function (e.g. Siemens VCS, Heidenhain KinematicsComp, Fanuc 3-D error "
            "compensation): a correction over the working volume, not along one axis")


def unfollowed(machine: Machine, q: np.ndarray, tool: np.ndarray, before: np.ndarray, after: np.ndarray,
               fit_mm: float, products: str = "", one_axis: np.ndarray | None = None) -> Unfollowed:
    """What the full tables leave: ``before`` / ``after`` (N,3) [m] the model-predicted errors
    without and with the full table set written at commands ``q`` (N, n) [m, rad] with tools
    ``tool`` (N,) [m], judged in the part's frame; ``fit_mm`` the model's own mean fit residual
    [mm]. Where the set written carries product terms (``products``, their names), ``after`` is
    with them and ``one_axis`` (N,3) [m] what the one-axis tables alone leave. The tool length is
    an input where the commands carry several."""
    inputs = {a.name: q[:, a.index] for a in machine.axes}
    if len(np.unique(np.round(tool, 9))) > 1:
        inputs["the tool length"] = np.asarray(tool, float)
    return Unfollowed(float(norm_mm(before).mean()), float(norm_mm(after).mean()), fit_mm, coupled_pairs(inputs, after),
                      remedy(machine), products, None if one_axis is None else float(norm_mm(one_axis).mean()))
