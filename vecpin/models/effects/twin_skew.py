"""Twin-drive skew: the yaw of a gantry axis that varies with its own position and the
position of the axis it carries, together (a beam driven at both ends turns as the
carriage on it moves: the load on the two drives changes)."""
from __future__ import annotations

import numpy as np

from vecpin.models.basis import normalise
from vecpin.models.effects.base import Effect, Key, ProductOrder, axes_product_chebyshev, register_effect
from vecpin.models.effects.gantry_skew import rotated_tip, rotation_gradient, rotation_tip


def _carries(machine, a: str, b: str) -> bool:
    """True when axis ``b`` rides on axis ``a`` (``a`` is on ``b``'s chain to the base)."""
    model, ja, j = machine.model, machine.axis(a).joint_id, machine.axis(b).joint_id
    while j > 0:
        j = model.parents[j]
        if j == ja:
            return True
    return False


def yaw_axis(machine, a: str, b: str) -> str | None:
    """The frame axis (x, y or z) of ``a``'s joint frame nearest the normal of the plane both axes move in,
    at mid-travel (the axis a twin-drive beam yaws about); None when they move along one line."""
    q = 0.5 * (machine.lower + machine.upper)[None]
    Fa, Fb = machine.joint_frames(q, a)[0], machine.joint_frames(q, b)[0]
    n = np.cross(Fa[:3, :3] @ np.asarray(machine.axis(a).direction), Fb[:3, :3] @ np.asarray(machine.axis(b).direction))
    if np.linalg.norm(n) < 0.5:   # |sin| of the angle between the two directions
        return None
    return "xyz"[int(np.argmax(np.abs(Fa[:3, :3].T @ n)))]


@register_effect
class TwinSkew(ProductOrder, Effect):
    """Rotation after a linear axis ``axes[0]`` (the twin-driven beam) about its frame axis ``about`` by
    ``theta(q) = sum_{i,j=1..m} c_ij T_i(u_a) T_j(u_b)`` [rad]: products only of Chebyshev series in the beam's
    position ``u_a`` and in the position ``u_b`` of the axis it carries (``axes[1]``, the carriage on the beam),
    each normalised to [-1, 1] over its travel. The part that depends on one axis alone is an ordinary error of
    that axis (the base model's); :class:`~vecpin.models.effects.gantry_skew.GantrySkew` is the separable skew.

    Simulated as an exact rotation by an angle ~ sin(pi u_a + phase) sin(pi u_b + phase')."""

    name = "twin_skew"
    summary = "a twin-drive yaw: a rotation after an axis that depends on it and the axis it carries together"
    kinds = ("tip",)
    axis_count = 2
    axis_kinds = ("linear",)
    geometric = True
    keys = (Key("about", None, "", "frame axis of the rotation (default: the normal of the plane both move in)", str,
                ("x", "y", "z")),)

    def __init__(self, machine, axes=(), about: str | None = None, order: int = 3, **kw):
        super().__init__(machine, axes, about=about, order=order, **kw)
        if len(self.axes) == 2 and about is None:
            about = yaw_axis(machine, *self.axes) or "z"
        self.about, self.order = about, int(order)

    @property
    def label(self) -> str:
        return f"{self.name}[{self.axes[0]}/{self.about},{self.axes[1]}]"

    def parameters(self):
        return [self._p(f"{i}{j}", "angle", 1e-3) for i in range(1, self.order + 1) for j in range(1, self.order + 1)]

    def _basis(self, q):
        return axes_product_chebyshev(self.machine, self.axes, q, self.order)

    def tip(self, ctx, feats):
        return rotation_tip(ctx, self.axes[0], self.about, self._basis(ctx.q))

    def tip_gradient(self, ctx, feats, theta):
        return rotation_gradient(ctx, self.axes[0], self.about, self._basis(ctx.q), theta)

    @classmethod
    def candidates(cls, machine, feats):
        """Every linear axis with a linear axis riding on it, not along it, about the normal of their plane."""
        out = []
        for a in machine.axes:
            for b in machine.axes:
                if a.kind == b.kind == "linear" and a.name != b.name and _carries(machine, a.name, b.name):
                    about = yaw_axis(machine, a.name, b.name)
                    if about is not None:
                        out.append(cls(machine, (a.name, b.name), about=about))
        return out

    def simulate_tip(self, q, tip, tool_dir, feats):
        rng = self._rng()
        m = self.machine
        a, b = m.axis(self.axes[0]), m.axis(self.axes[1])
        pa, pb = rng.uniform(0, 2 * np.pi, 2)
        angle = 1e-4 * self.scale * np.sin(np.pi * normalise(q[:, a.index], a.lower, a.upper) + pa) * \
            np.sin(np.pi * normalise(q[:, b.index], b.lower, b.upper) + pb)
        return rotated_tip(m, q, a.name, self.about, angle, tip)

    def advice(self, values, std):
        a, b = self.axes
        u = np.linspace(-1, 1, 41)
        cheb = np.polynomial.chebyshev.chebvander(u, self.order)[:, 1:]
        grid = np.einsum("ai,ij,bj->ab", cheb, np.asarray(values).reshape(self.order, self.order), cheb)
        return [f"{self.label}: the rotation of {a} about its {self.about} axis depends on {a} and {b} together, "
                f"{np.ptp(grid) * 1e6:.1f} µrad peak to peak over both travels (beyond each axis' own part): "
                f"geometric; on a gantry driven at both ends of {a}, the drives' positions depend on where {b} is "
                f"(load, stiffness, a differential that follows {b}); a table on input {a} alone cannot carry it: "
                f"a 2-D (volumetric) table, or a table on {a} multiplied by one on {b} (Siemens $AN_CEC_MULT_BY_TABLE)"]
