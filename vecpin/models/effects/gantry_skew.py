"""Gantry skew: a small rotation after an axis whose angle depends on the other axes
(seed Section 2.3, eq. 23-24: the Ingersoll's twin gantry drives)."""
from __future__ import annotations

import numpy as np

from vecpin.kinematics.so3 import exp3, skew
from vecpin.models.basis import normalise
from vecpin.models.effects.base import Effect, Key, axis_chebyshev, register_effect


@register_effect
class GantrySkew(Effect):
    """Rotation after axis ``axes[0]`` about its frame axis ``about`` (x, y or z) by
    ``theta(q) = sum_k sum_j a_kj T_j(u_k)`` over the other axes k (seed eq. 23-24).

    Simulated as an exact rotation of everything after the axis by an angle
    ~ sin(0.8 pi u + phase) of the axis ``depends``."""

    name = "gantry_skew"
    summary = "a rotation after an axis whose angle depends on the other axes (eq. 23-24)"
    kinds = ("tip",)
    axis_count = 1
    axis_kinds = ("linear",)
    geometric = True
    keys = (Key("about", "x", "", "frame axis of the rotation", str, ("x", "y", "z")),
            Key("depends", None, "", "axis the simulated angle varies along (default: the first axis)", str))

    def __init__(self, machine, axes=(), about: str = "x", order: int = 3, orders: dict | None = None, **kw):
        if orders is not None:
            kw["orders"] = {str(k): int(v) for k, v in orders.items()}
        super().__init__(machine, axes, about=about, order=order, **kw)
        self.about, self.order = about, int(order)
        if self.options.get("depends"):
            machine.axis(self.options["depends"])
        # the series order along each other axis (``orders`` caps it where a campaign visits few positions)
        self.orders = {a.name: int((orders or {}).get(a.name, self.order)) for a in machine.axes
                       if a.name != self.axes[0]}
        self.others = [k for k, o in self.orders.items() if o >= 1]

    @property
    def label(self) -> str:
        return f"{self.name}[{self.axes[0]}/{self.about}]"

    def parameters(self):
        return [self._p(f"{k}.{j}", "angle", 1e-3) for k in self.others for j in range(1, self.orders[k] + 1)]

    def _basis(self, q):
        return np.concatenate([axis_chebyshev(self.machine, k, q, self.orders[k]) for k in self.others], axis=1)

    def tip(self, ctx, feats):
        return rotation_tip(ctx, self.axes[0], self.about, self._basis(ctx.q))

    def tip_gradient(self, ctx, feats, theta):
        return rotation_gradient(ctx, self.axes[0], self.about, self._basis(ctx.q), theta)

    def supported(self, design):
        """The series along each other axis cut to that axis' distinct positions less one
        (an axis visited at one position drops out)."""
        orders = {k: min(o, design.max_order(k)) for k, o in self.orders.items()}
        if not any(o >= 1 for o in orders.values()):
            return None
        if orders == self.orders:
            return self
        return type(self)(self.machine, self.axes, **(self.options | {"orders": orders}))

    @classmethod
    def candidates(cls, machine, feats):
        return [cls(machine, (a.name,), about=c) for a in machine.axes[:-1] if a.kind == "linear" for c in "xyz"]

    def simulate_tip(self, q, tip, tool_dir, feats):
        rng = self._rng()
        m = self.machine
        dep = m.axis(self.options.get("depends") or m.axis_names[0])
        phase = rng.uniform(0, 2 * np.pi)
        angle = 1e-4 * self.scale * np.sin(0.8 * np.pi * normalise(q[:, dep.index], dep.lower, dep.upper) + phase)
        return rotated_tip(m, q, self.axes[0], self.about, angle, tip)

    def advice(self, values, std):
        m = self.machine
        a = self.axes[0]
        # angle range over the travel of each other axis, from its Chebyshev series
        u = np.linspace(-1, 1, 201)
        lines = []
        k = 0
        for other in self.others:
            c = values[k:k + self.orders[other]]
            ang = np.polynomial.chebyshev.chebval(u, np.r_[0.0, c])
            travel = m.axis(other).travel
            if m.axis(other).kind == "linear" and travel > 0 and np.ptp(ang) > 1e-6:
                ends = (ang[-1] - ang[0]) * 1e6        # µrad from one end of the travel to the other
                shape = "" if np.ptp(ang) * 1e6 < 1.1 * abs(ends) + 1.0 else "; the rest is curvature"
                lines.append(f"{self.label}: rotation about {a}'s {self.about} axis varies by "
                             f"{np.ptp(ang) * 1e6:.1f} µrad over {other}'s {travel:.2f} m travel (end to end "
                             f"{ends:+.1f} µrad, {ends / travel:+.1f} µrad/m{shape})")
            k += self.orders[other]
        lines.append(f"{self.label}: geometric; the tables carry it (vecpin tables with model_best.json); on a gantry "
                     f"with two drives it is a differential table between the drives of {a}")
        return lines


def rotation_tip(ctx, axis: str, about: str, basis: np.ndarray) -> np.ndarray:
    """(P, 3, K) d tip / d theta [m per rad] of a rotation after ``axis`` about its frame axis
    ``about`` ("x", "y" or "z") by the angle ``basis @ theta`` [rad] ((P, K) ``basis``)."""
    F = ctx.frames(axis)
    axis_w = F[:, :3, "xyz".index(about)]
    lever = np.cross(axis_w, ctx.tip - F[:, :3, 3])  # d tip / d angle
    return lever[:, :, None] * basis[:, None, :]


def rotation_gradient(ctx, axis: str, about: str, basis: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """(P, 3, 3) the skew matrices of the rotation vectors [rad] of :func:`rotation_tip` at ``theta``."""
    F = ctx.frames(axis)
    return skew(F[:, :3, "xyz".index(about)] * (basis @ theta)[:, None])


def rotated_tip(machine, q: np.ndarray, axis: str, about: str, angle: np.ndarray, tip: np.ndarray) -> np.ndarray:
    """(P, 3) ``tip`` [m] with everything after ``axis`` turned exactly by ``angle`` [rad] about its
    frame axis ``about``, at the commands ``q``."""
    F = machine.joint_frames(q, axis)
    R = exp3(F[:, :3, "xyz".index(about)] * angle[:, None])
    return F[:, :3, 3] + np.einsum("pij,pj->pi", R, tip - F[:, :3, 3])
