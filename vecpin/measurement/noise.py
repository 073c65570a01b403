"""Noise models of the maximum-likelihood fit: the machine's positioning noise
``Σ_v`` (repeatability, per axis) and the instrument's ``Σ_ξ``.

The instrument residual is formed in Cartesian tracker coordinates with a static
isotropic variance, or in the tracker's native spherical coordinates (range,
zenith, azimuth) with range-dependent variances (Section 3, eq. 35-36, 41).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vecpin.errors import VecpinError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.tracker import TrackerNoise
from vecpin.units import MM_PER_M, M_PER_MM

from vecpin.measurement.defaults import (DEFAULT_BALLBAR_SIGMA, DEFAULT_CARTESIAN_SIGMA,  # noqa: F401 (re-exported)
                                         DEFAULT_LINEAR_SIGMA, DEFAULT_ROTARY_SIGMA)


@dataclass
class NoiseModel:
    """axis_sigma: (n,) 1-sigma positioning noise [m, rad] (Σ_v diagonal);
    instrument: "cartesian" or "spherical"; cartesian_sigma [m]; tracker: the
    spherical noise model (used when instrument == "spherical")."""

    axis_sigma: np.ndarray
    instrument: str = "spherical"
    cartesian_sigma: float = DEFAULT_CARTESIAN_SIGMA
    tracker: TrackerNoise = field(default_factory=TrackerNoise)
    ballbar_sigma: float = DEFAULT_BALLBAR_SIGMA

    def __post_init__(self):
        if self.instrument not in ("cartesian", "spherical", "range"):
            raise VecpinError(f"tracker noise model is 'cartesian', 'spherical' or 'range' (multilateration), "
                              f"not '{self.instrument}'")
        self.axis_sigma = np.asarray(self.axis_sigma, float)

    @classmethod
    def default(cls, machine: Machine, instrument: str = "spherical", **kw) -> "NoiseModel":
        sig = np.array([DEFAULT_LINEAR_SIGMA if a.kind == "linear" else DEFAULT_ROTARY_SIGMA for a in machine.axes])
        return cls(sig, instrument, **kw)

    def to_dict(self, machine: Machine) -> dict:
        return {"axis_sigma": {a.name: float(a.to_user(s)) for a, s in zip(machine.axes, self.axis_sigma)},
                "axis_sigma_unit": "the axis' unit (mm or deg)",
                "instrument": self.instrument, "cartesian_sigma_mm": self.cartesian_sigma * MM_PER_M,
                "tracker": self.tracker.to_dict(), "ballbar_sigma_mm": self.ballbar_sigma * MM_PER_M}

    @classmethod
    def from_dict(cls, d: dict, machine: Machine) -> "NoiseModel":
        sig = np.array([float(a.to_si(d["axis_sigma"][a.name])) for a in machine.axes])
        return cls(sig, d["instrument"], d["cartesian_sigma_mm"] * M_PER_MM, TrackerNoise.from_dict(d["tracker"]),
                   d.get("ballbar_sigma_mm", DEFAULT_BALLBAR_SIGMA * MM_PER_M) * M_PER_MM)


def _sigma(value, option: str, unit: str) -> float:
    import math
    from vecpin.errors import InputError
    v = float(value)
    if not math.isfinite(v) or v <= 0:
        raise InputError(f"`{option}` {value!r}: a standard deviation must be a positive number of {unit}")
    return v


def noise_from_options(machine: Machine, instrument: str = "spherical", *, repeatability_mm: float | None = None,
                       repeatability_deg: float | None = None, tracker_sigma_mm: float | None = None,
                       tracker_noise: tuple[float, float, float, float] | None = None,
                       ballbar_sigma_mm: float | None = None) -> NoiseModel:
    """The noise model from user options (mm, deg, ppm), each checked: ``instrument`` is
    "cartesian", "spherical" or "range"; ``tracker_noise`` = (range mm, range ppm,
    transverse mm, transverse ppm); None keeps the default."""
    noise = NoiseModel.default(machine, instrument)
    sig = noise.axis_sigma.copy()
    for k, a in enumerate(machine.axes):
        if a.kind == "linear" and repeatability_mm is not None:
            sig[k] = _sigma(repeatability_mm, "repeatability_mm", "mm") * M_PER_MM
        if a.kind == "rotary" and repeatability_deg is not None:
            sig[k] = np.radians(_sigma(repeatability_deg, "repeatability_deg", "degrees"))
    noise.axis_sigma = sig
    if tracker_sigma_mm is not None:
        noise.cartesian_sigma = _sigma(tracker_sigma_mm, "tracker_sigma_mm", "mm") * M_PER_MM
        if instrument != "cartesian":   # the Cartesian sigma weighs no reading of another noise model: refused
            from vecpin.errors import InputError
            takes = ("the ranges take `tracker_noise` (its range terms)" if instrument == "range" else
                     "the tracker's spherical noise model (the default) takes `tracker_noise` (range mm, range ppm, "
                     "transverse mm, transverse ppm)")
            raise InputError(f"`tracker_sigma_mm` {tracker_sigma_mm}: the Cartesian tracker noise applies only with "
                             f"`cartesian` and would change nothing here; {takes}")
    if ballbar_sigma_mm is not None:
        noise.ballbar_sigma = _sigma(ballbar_sigma_mm, "ballbar_sigma_mm", "mm") * M_PER_MM
    if tracker_noise is not None:
        from vecpin.errors import InputError
        vals = [float(v) for v in tracker_noise]
        if not all(np.isfinite(vals)) or min(vals) < 0 or vals[0] + vals[1] <= 0 or vals[2] + vals[3] <= 0:
            raise InputError(f"`tracker_noise` {' '.join(map(str, tracker_noise))}: four numbers >= 0 (range mm, "
                             "range ppm, transverse mm, transverse ppm), with a nonzero range and transverse noise")
        a, b, c, d = vals
        noise.tracker = TrackerNoise(a * M_PER_MM, b * 1e-6, c * M_PER_MM, d * 1e-6)
    return noise


def scaled_noise(noise: NoiseModel, s: float) -> NoiseModel:
    """``noise`` with every standard deviation (positioning, tracker, ball bar) times ``s``:
    the ratio of machine to instrument noise kept, their level from the data."""
    return NoiseModel(noise.axis_sigma * s, noise.instrument, noise.cartesian_sigma * s,
                      TrackerNoise(noise.tracker.range_const * s, noise.tracker.range_ppm * s,
                                   noise.tracker.transverse_const * s, noise.tracker.transverse_ppm * s),
                      noise.ballbar_sigma * s)
