"""Physical versions of the unmodelled effects, for simulated machines.

They are written independently of the model terms in :mod:`vecpin.effects` (exact
rotations, non-polynomial shapes, a real change of tracker pose), so the diagnosis
is checked against effects it does not describe exactly. ``strength_mm`` is the RMS
tool-tip displacement the effect causes over the campaign it is simulated on.

========================= ===============================================================
``gantry_skew``           exact rotation after ``axes[0]`` about its frame axis ``about``,
                          angle ~ sin(0.8 pi u_k + phase) of axis ``depends``
``coupled_axes``          every command perturbed by sin(pi u_i) sin(pi u_j) (i, j = axes)
``thermal``               linear-axis expansion (steel, 11.5 ppm/K) and spindle growth with
                          the temperature change (or with time when there is no temperature)
``backlash``              an axis lags by half its reversal error against its last move
``rotary_periodic``       5th and 7th harmonics of a rotary axis in every command
``instrument_shift``      the tracker knocked: a rigid step of its pose at ``at`` (fraction of rows)
``outliers``              a fraction of rows with gross errors
========================= ===============================================================
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vecpin.models.basis import normalise
from vecpin.errors import VecpinError
from vecpin.measurement.features import Features
from vecpin.kinematics.so3 import exp3


@dataclass
class TrueEffect:
    """One simulated effect; ``options`` as in the table above; ``seed`` fixes its shape."""

    name: str
    axes: tuple[str, ...] = ()
    strength_mm: float = 0.05
    options: dict = field(default_factory=dict)
    seed: int = 0
    scale: float = 1.0          # set by calibrate()
    outlier_rows: np.ndarray | None = None

    def _rng(self):
        return np.random.default_rng(self.seed)

    def to_dict(self) -> dict:
        d = {"name": self.name, "axes": list(self.axes), "strength_mm": self.strength_mm, "options": self.options,
             "seed": self.seed, "scale": self.scale}
        if self.outlier_rows is not None:
            d["outlier_rows"] = [int(r) for r in self.outlier_rows]
        return d

    # ------------------------------------------------------------------ parts
    def command(self, machine, q: np.ndarray, feats: Features) -> np.ndarray:
        """dq (N, n) [m, rad] or zeros."""
        rng = self._rng()
        dq = np.zeros_like(q)
        n = machine.n_axes
        unit = np.array([1e-3 if a.kind == "linear" else 1e-3 / 0.3 for a in machine.axes])  # ~1 mm at the tip
        if self.name == "coupled_axes":
            ai, aj = machine.axis(self.axes[0]), machine.axis(self.axes[1])
            shape = np.sin(np.pi * normalise(q[:, ai.index], ai.lower, ai.upper)) * \
                np.sin(np.pi * normalise(q[:, aj.index], aj.lower, aj.upper) + 0.5)
            amp = rng.normal(size=n) * unit
            dq = shape[:, None] * amp[None, :]
        elif self.name == "thermal":
            d = self._delta(feats)
            for a in machine.axes:
                if a.kind == "linear":
                    dq[:, a.index] = 11.5e-6 * q[:, a.index] * d
        elif self.name == "backlash":
            k = machine.axis(self.axes[0]).index
            dq[:, k] = -0.5 * feats.direction[:, k] * unit[k]
        elif self.name == "rotary_periodic":
            ang = q[:, machine.axis(self.axes[0]).index]
            for o in range(n):
                c5, s5, c7, s7 = rng.normal(size=4) * unit[o]
                dq[:, o] = c5 * np.cos(5 * ang) + s5 * np.sin(5 * ang) + 0.6 * (c7 * np.cos(7 * ang) + s7 * np.sin(7 * ang))
        return dq * self.scale

    def tip(self, machine, q: np.ndarray, tip: np.ndarray, tool_dir: np.ndarray, feats: Features) -> np.ndarray:
        """The tip (N,3) [m] after the effect (machine frame)."""
        if self.name == "gantry_skew":
            rng = self._rng()
            dep = machine.axis(self.options.get("depends", machine.axis_names[0]))
            phase = rng.uniform(0, 2 * np.pi)
            angle = 1e-4 * self.scale * np.sin(0.8 * np.pi * normalise(q[:, dep.index], dep.lower, dep.upper) + phase)
            F = machine.joint_frames(q, self.axes[0])
            axis_w = F[:, :3, "xyz".index(self.options.get("about", "x"))]
            R = exp3(axis_w * angle[:, None])  # exact rotation of everything after the axis
            return F[:, :3, 3] + np.einsum("pij,pj->pi", R, tip - F[:, :3, 3])
        if self.name == "thermal":
            return tip + tool_dir * (20e-6 * self.scale * self._delta(feats))[:, None]
        return tip

    def tracker(self, y: np.ndarray, feats: Features) -> np.ndarray:
        """Tracker readings (N,3) [m] after the effect."""
        if self.name == "instrument_shift":
            rng = self._rng()
            if "t0" not in self.options:  # fixed on the first (identification) campaign it meets
                self.options["t0"] = float(np.quantile(feats.time, self.options.get("at", 0.5)))
            t0 = self.options["t0"]
            on = feats.time >= t0
            w = rng.normal(size=3)
            w = w / np.linalg.norm(w) * 2e-5 * self.scale
            d = rng.normal(size=3)
            d = d / np.linalg.norm(d) * 1e-4 * self.scale
            out = y.copy()
            out[on] = y[on] @ exp3(w).T + d
            return out
        return y

    def gross(self, y: np.ndarray) -> np.ndarray:
        """Readings with gross errors on a fraction of rows (outliers)."""
        if self.name != "outliers":
            return y
        rng = self._rng()
        n = len(y)
        k = max(1, int(round(self.options.get("fraction", 0.01) * n)))
        rows = np.sort(rng.choice(n, k, replace=False))
        self.outlier_rows = rows
        v = rng.normal(size=(k, 3))
        v = v / np.linalg.norm(v, axis=1)[:, None] * self.strength_mm * 1e-3 * rng.uniform(1.0, 2.0, (k, 1))
        out = y.copy()
        out[rows] += v
        return out

    def _delta(self, feats: Features) -> np.ndarray:
        """Temperature above the reference (20 °C by default), or hours since the start."""
        if feats.temperature is not None:
            return feats.temperature - self.options.get("t_ref", 20.0)
        return feats.time / 3600.0


def parse_true_effect(text: str, machine):
    """'gantry_skew:axes=Y,about=x,depends=X,strength=0.05' -> TrueEffect."""
    name, _, rest = text.partition(":")
    known = ("gantry_skew", "coupled_axes", "thermal", "backlash", "rotary_periodic", "instrument_shift", "outliers")
    if name not in known:
        raise VecpinError(f"--effect '{text}': unknown effect '{name}' (known: {', '.join(known)})")
    axes, strength, seed, options = (), 0.05, 0, {}
    for part in filter(None, rest.split(",")):
        if "=" not in part:
            raise VecpinError(f"--effect '{text}': write NAME:key=value,... (axes=Y+X, strength=MM, seed=N, ...)")
        k, v = part.split("=", 1)
        if k == "axes":
            axes = tuple(a for a in v.split("+") if a)
            for a in axes:
                machine.axis(a)
        elif k == "strength":
            strength = float(v)
        elif k == "seed":
            seed = int(v)
        else:
            try:
                options[k] = float(v)
            except ValueError:
                options[k] = v
    return TrueEffect(name, axes, strength, options, seed)
