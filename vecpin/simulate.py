"""Campaign simulator: measurement designs and simulated laser-tracker campaigns.

The default design is Paper I's: 295 random commands measured with a 214.88 mm
tool, then the same commands with a 312.86 mm tool (rows in that time order),
plus 35 quasi-random validation commands with the short tool. Exclusion zones
(boxes in axis space, as for line-of-sight and collision avoidance in Paper I
Fig. 6) remove commands. A seeded RNG makes the same files for the same seed.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.stats import qmc

from .campaign import Campaign, write_campaign
from .errors import VecpinError
from .machine import Machine
from .truth import TrueMachine

PAPER_I_TOOLS_MM = (214.88, 312.86)


@dataclass
class Design:
    """What to measure. ``exclusion_zones``: list of {axis: (lo, hi)} in mm/deg; a
    command inside every interval of a zone is not measured. ``method``: "random",
    "sobol" or "halton" for the identification commands (validation is always Halton).
    ``seconds_per_point`` (settle + measure) and ``feed_m_per_s`` (moves) make ``time``."""

    n_commands: int = 295
    tools_mm: tuple[float, ...] = PAPER_I_TOOLS_MM
    n_validation: int = 35
    method: str = "random"
    exclusion_zones: list[dict[str, tuple[float, float]]] = field(default_factory=list)
    seconds_per_point: float = 15.0
    feed_m_per_s: float = 0.1
    repeat_points: int = 0   # after the campaign: this many commands, each measured ...
    repeat_times: int = 0    # ... this many times, in a new random order each sequence (eq. 22)


def design_commands(machine: Machine, n: int, rng: np.random.Generator, method: str = "random",
                    exclusion_zones=(), scramble_seed: int | None = None) -> np.ndarray:
    """n commands [m, rad] over the axis limits, outside every exclusion zone."""
    zones = [_zone_si(machine, z) for z in exclusion_zones]
    out = np.empty((0, machine.n_axes))
    for _attempt in range(50):
        m = max(2 * (n - len(out)), 16)
        if method == "random":
            u = rng.random((m, machine.n_axes))
        elif method in ("sobol", "halton"):
            seed = scramble_seed if scramble_seed is not None else int(rng.integers(2**31))
            eng = qmc.Sobol(machine.n_axes, seed=seed) if method == "sobol" else qmc.Halton(machine.n_axes, seed=seed)
            u = eng.random(2 ** math.ceil(math.log2(m))) if method == "sobol" else eng.random(m)
        else:
            raise VecpinError(f"unknown design method '{method}' (random, sobol, halton)")
        q = machine.lower + u * (machine.upper - machine.lower)
        keep = np.ones(len(q), bool)
        for lo, hi in zones:
            keep &= ~np.all((q >= lo) & (q <= hi), axis=1)
        out = np.vstack([out, q[keep]])
        if len(out) >= n:
            return out[:n]
    raise VecpinError("the exclusion zones leave (almost) no room for commands")


def _zone_si(machine: Machine, zone: dict[str, tuple[float, float]]):
    lo = machine.lower.copy() - 1.0
    hi = machine.upper.copy() + 1.0
    for name, (a, b) in zone.items():
        ax = machine.axis(name)
        lo[ax.index], hi[ax.index] = sorted((float(ax.to_si(a)), float(ax.to_si(b))))
    return lo, hi


def parse_zone(text: str) -> dict[str, tuple[float, float]]:
    """'X=0:500,B=-111:-80' -> {'X': (0, 500), 'B': (-111, -80)} (mm/deg)."""
    zone = {}
    for part in text.split(","):
        try:
            name, rng_ = part.split("=")
            a, b = rng_.split(":")
            zone[name.strip()] = (float(a), float(b))
        except ValueError:
            raise VecpinError(f"exclusion zone '{text}': write AXIS=LO:HI[,AXIS=LO:HI...] in mm/deg") from None
    return zone


@dataclass
class Simulation:
    """A simulated campaign: truth, identification and validation campaigns (noisy),
    and the noise-free validation positions (tracker frame)."""

    truth: TrueMachine
    campaign: Campaign
    validation: Campaign
    validation_truth: Campaign

    def write(self, out_dir: str | Path) -> dict[str, Path]:
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        m = self.truth.machine
        paths = {"campaign": out / "campaign.csv", "validation": out / "validation.csv",
                 "validation_truth": out / "validation_truth.csv", "truth": out / "truth.json"}
        write_campaign(paths["campaign"], self.campaign, m)
        write_campaign(paths["validation"], self.validation, m)
        write_campaign(paths["validation_truth"], self.validation_truth, m)
        self.truth.save(paths["truth"])
        return paths


def measurement_times(q: np.ndarray, machine: Machine, design: Design, start: float = 0.0) -> np.ndarray:
    """Time stamps [s] of rows measured in order: settle/measure time plus moves at feed."""
    lin = [a.index for a in machine.axes if a.kind == "linear"]
    moves = np.r_[0.0, np.linalg.norm(np.diff(q[:, lin], axis=0), axis=1)] if lin else np.zeros(len(q))
    return start + np.cumsum(design.seconds_per_point + moves / design.feed_m_per_s)


def workshop_temperature(t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Air temperature [°C]: 20 °C, a slow daily swing, a drift and 0.02 °C sensor noise."""
    phase = rng.uniform(0, 2 * math.pi)
    return 20.0 + 0.6 * np.sin(2 * math.pi * t / 86400 + phase) + 0.2 * t / 28800 + rng.normal(0, 0.02, len(t))


def simulate(machine: Machine, seed: int = 0, design: Design | None = None, truth: TrueMachine | None = None,
             effects: list | None = None, **truth_options) -> Simulation:
    """Simulate a campaign on ``machine`` (a random :class:`TrueMachine` from ``seed``
    unless ``truth`` is given). ``effects``: :class:`~vecpin.trueeffects.TrueEffect`
    list acting on the true machine, scaled to their strength on this campaign; the
    validation files carry them too (except gross errors)."""
    from .features import Features
    design = design or Design()
    rng = np.random.default_rng(seed)
    truth = truth or TrueMachine.random(machine, rng, **truth_options)
    if effects:
        truth.effects = list(effects)
    q = design_commands(machine, design.n_commands, rng, design.method, design.exclusion_zones)
    tools = np.asarray(design.tools_mm, float) * 1e-3
    qs = np.vstack([q] * len(tools))
    tool = np.repeat(tools, len(q))
    if design.repeat_points and design.repeat_times:
        pick = q[rng.choice(len(q), min(design.repeat_points, len(q)), replace=False)]
        seqs = [pick[rng.permutation(len(pick))] for _ in range(design.repeat_times)]
        qs = np.vstack([qs] + seqs)
        tool = np.r_[tool, np.full(len(pick) * design.repeat_times, tools[0])]
    t = measurement_times(qs, machine, design)
    extra = {"time": t, "temperature": workshop_temperature(t, rng)}
    feats = Features.from_campaign(Campaign(machine.axis_names, qs, tool, np.zeros((len(qs), 3)), extra))
    if truth.effects:
        truth.calibrate_effects(qs, tool, feats)
    campaign = Campaign(machine.axis_names, qs, tool, truth.measure(qs, tool, rng, feats), extra, f"simulated seed {seed}")
    qv = design_commands(machine, design.n_validation, rng, "halton", design.exclusion_zones)
    tv = np.full(len(qv), tools[0])
    times_v = measurement_times(qv, machine, design, start=t[-1] + 600.0)
    extra_v = {"time": times_v, "temperature": workshop_temperature(times_v, rng)}
    feats_v = Features.from_campaign(Campaign(machine.axis_names, qv, tv, np.zeros((len(qv), 3)), extra_v))
    clean = [e for e in truth.effects if e.name != "outliers"]
    all_effects, truth.effects = truth.effects, clean
    validation = Campaign(machine.axis_names, qv, tv, truth.measure(qv, tv, rng, feats_v), extra_v,
                          f"simulated seed {seed}, validation")
    exact = Campaign(machine.axis_names, qv, tv, truth.measure(qv, tv, None, feats_v), dict(extra_v),
                     f"simulated seed {seed}, noise-free")
    truth.effects = all_effects
    return Simulation(truth, campaign, validation, exact)
