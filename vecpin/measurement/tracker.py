"""Laser tracker: pose relative to the machine, native spherical coordinates, noise.

Seed Section 3.2, eq. 33-36. The tracker measures range ``R``, zenith angle ``phi``
(from the tracker's +z) and azimuth ``theta`` (from +x towards +y); Cartesian
tracker coordinates are ``x = R sin(phi) cos(theta)``, ``y = R sin(phi) sin(theta)``,
``z = R cos(phi)`` (eq. 33). Noise is range dependent, the usual form of a
tracker specification: the range (interferometer/ADM) has
``sigma_R = range_const + range_ppm * R`` and each encoder angle has
``sigma_angle = (transverse_const + transverse_ppm * R) / R`` so that the transverse
position noise grows linearly with distance. All values SI (m, rad).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np
from vecpin.units import MM_PER_M, M_PER_MM


@dataclass(frozen=True)
class TrackerNoise:
    """1-sigma noise of a laser tracker in its native coordinates (SI).

    Defaults are of the order of an API T3 / Leica AT960 class instrument
    (MPE about 15 µm + 5 µm/m, of which these are the random parts).
    """

    range_const: float = 3e-6
    range_ppm: float = 0.5e-6
    transverse_const: float = 5e-6
    transverse_ppm: float = 2.5e-6

    def sigma_range(self, R: np.ndarray) -> np.ndarray:
        return self.range_const + self.range_ppm * np.asarray(R, float)

    def sigma_angle(self, R: np.ndarray) -> np.ndarray:
        R = np.asarray(R, float)
        return (self.transverse_const + self.transverse_ppm * R) / R

    def sigma_spherical(self, R: np.ndarray) -> np.ndarray:
        """(N, 3) standard deviations of (R [m], phi [rad], theta [rad])."""
        sa = self.sigma_angle(R)
        return np.stack([self.sigma_range(R), sa, sa], axis=-1)

    def to_dict(self) -> dict:
        return {k: v * MM_PER_M for k, v in asdict(self).items()} | {"units": "mm; *_ppm in mm per m of range"}

    @classmethod
    def from_dict(cls, d: dict) -> "TrackerNoise":
        return cls(**{k: float(d[k]) * M_PER_MM for k in ("range_const", "range_ppm", "transverse_const", "transverse_ppm")})


def cartesian_to_spherical(p: np.ndarray) -> np.ndarray:
    """(N,3) tracker Cartesian [m] -> (N,3) (R, phi, theta) (eq. 35, zenith/azimuth)."""
    p = np.asarray(p, float)
    rho = np.hypot(p[..., 0], p[..., 1])
    return np.stack([np.linalg.norm(p, axis=-1), np.arctan2(rho, p[..., 2]), np.arctan2(p[..., 1], p[..., 0])], -1)


def spherical_to_cartesian(s: np.ndarray) -> np.ndarray:
    """(N,3) (R, phi, theta) -> (N,3) Cartesian (eq. 33)."""
    s = np.asarray(s, float)
    R, phi, th = s[..., 0], s[..., 1], s[..., 2]
    return np.stack([R * np.sin(phi) * np.cos(th), R * np.sin(phi) * np.sin(th), R * np.cos(phi)], -1)


def spherical_jacobian(p: np.ndarray) -> np.ndarray:
    """(N,3,3) d (R, phi, theta) / d (x, y, z) at tracker-frame points p [m]."""
    p = np.asarray(p, float)
    x, y, z = p[..., 0], p[..., 1], p[..., 2]
    rho2 = x * x + y * y
    rho = np.sqrt(rho2)
    R2 = rho2 + z * z
    R = np.sqrt(R2)
    J = np.empty(p.shape[:-1] + (3, 3))
    J[..., 0, :] = p / R[..., None]
    J[..., 1, 0] = x * z / (R2 * rho)
    J[..., 1, 1] = y * z / (R2 * rho)
    J[..., 1, 2] = -rho / R2
    J[..., 2, 0] = -y / rho2
    J[..., 2, 1] = x / rho2
    J[..., 2, 2] = 0.0
    return J


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Wrap angles to (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(a, float)))


@dataclass
class Tracker:
    """Tracker pose: ``p_tracker = rotation @ p_machine + translation`` (SI)."""

    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))
    translation: np.ndarray = field(default_factory=lambda: np.zeros(3))
    noise: TrackerNoise = field(default_factory=TrackerNoise)

    def to_tracker(self, p_machine: np.ndarray) -> np.ndarray:
        return np.asarray(p_machine, float) @ self.rotation.T + self.translation

    @property
    def position_in_machine(self) -> np.ndarray:
        """Where the tracker head stands, machine base frame [m]."""
        return -self.rotation.T @ self.translation

    def measure(self, p_machine: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Tracker-frame Cartesian readings [m] of machine-frame points, with spherical
        noise added in the native coordinates (eq. 34) when ``rng`` is given."""
        p = self.to_tracker(p_machine)
        return p if rng is None else self.add_noise(p, rng)

    def add_noise(self, p_tracker: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Tracker-frame points with range and angle noise added in spherical coordinates."""
        s = cartesian_to_spherical(p_tracker)
        s = s + rng.standard_normal(s.shape) * self.noise.sigma_spherical(s[:, 0])
        return spherical_to_cartesian(s)

    def to_dict(self) -> dict:
        return {"rotation": self.rotation.tolist(), "translation_mm": (self.translation * MM_PER_M).tolist(),
                "noise": self.noise.to_dict()}

    @classmethod
    def from_dict(cls, d: dict) -> "Tracker":
        return cls(np.array(d["rotation"], float), np.array(d["translation_mm"], float) * M_PER_MM,
                   TrackerNoise.from_dict(d["noise"]))
