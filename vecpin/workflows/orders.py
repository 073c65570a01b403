"""Choose the series order on held-out data (the ``orders`` command; Paper I Table 2).

Without a validation campaign the orders are a view of the model choice: every order of
every kind scored by the linearised k-fold cross-validation of
:func:`vecpin.selection.choice.choose_model` (one basis for every axis, the same order on
every axis). With one, every order is fitted by maximum likelihood and judged on it
(:func:`vecpin.selection.orders.order_sweep`), as Paper I's Table 2.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable, Sequence

from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments.multilateration import check_stations
from vecpin.measurement.noise import NoiseModel
from vecpin.selection.choice import ModelChoice, check_basis, choose_model
from vecpin.selection.orders import OrderSweep, check_orders, order_sweep


@dataclass
class OrdersRun:
    """The orders judged: ``choice`` (linearised CV, no validation campaign) or ``sweeps``
    (one per kind, judged on the validation campaign); :meth:`lines` is the printout."""

    kinds: tuple[str, ...]
    folds: int
    choice: ModelChoice | None = None
    sweeps: list[OrderSweep] = field(default_factory=list)
    orders: tuple[int, ...] = ()     # the orders tried
    per_turn_axes: tuple[str, ...] = ()  # rotary axes travelling more than a turn judged with Chebyshev series

    def best(self, kind: str) -> int:
        """The order of ``kind`` with the smallest held-out error."""
        if self.choice is None:
            return next(s.best.order for s in self.sweeps if s.kind == kind)
        return min((x for x in self.choice.candidates if x.kind == kind), key=lambda x: x.mean).axes[0].order

    def lines(self) -> list[str]:
        if self.choice is not None:
            out = [self.choice.table(limit=len(self.choice.candidates))] + [
                f"best {kind} order on held-out data ({self.folds}-fold CV, linearised): {self.best(kind)}"
                for kind in self.kinds]
        else:
            out = []
            for s in self.sweeps:
                out += [s.table(), f"best {s.kind} order on held-out data ({s.method}): {s.best.order}\n"]
        return out + self.hints()

    def hints(self) -> list[str]:
        """What to try next: higher orders when the highest tried is the best; the per-turn
        basis on rotary axes that travel more than a turn."""
        out = []
        top = max(self.orders, default=None)
        at_top = [k for k in self.kinds if top is not None and len(self.orders) > 1 and self.best(k) == top]
        if at_top:
            out.append(f"note: the best {' and '.join(at_top)} order is the highest tried ({top}): the held-out error "
                       f"may fall further; try higher ones, e.g. `orders` {min(self.orders)}-{top + 4}")
        if self.per_turn_axes:
            verb = "travels" if len(self.per_turn_axes) == 1 else "travel"
            out.append(f"note: {', '.join(self.per_turn_axes)} {verb} more than a turn: these orders are of "
                       "Chebyshev series over the travel there; errors that repeat every turn take Fourier series "
                       "(`basis` fourier), which `fit` may choose")
        return out


def choose_orders(machine: Machine, campaign: Campaign, noise: NoiseModel | None = None, *,
                  kinds: Sequence[str] = ("6dof", "ap"), orders: Sequence[int] = range(8), basis: str = "chebyshev",
                  validation: Campaign | None = None, folds: int = 5,
                  progress: Callable[[str], None] | None = None) -> OrdersRun:
    """Judge the series ``orders`` of each model kind in ``kinds`` on ``campaign``: by
    linearised ``folds``-fold CV, or fitted and judged on ``validation`` when given.
    ``basis``: "chebyshev" everywhere, or "fourier" per turn on the rotary axes travelling
    more than a turn. ``noise`` default: the tracker's spherical model
    (:meth:`NoiseModel.default`). Every check runs once, before any fit."""
    noise = noise or NoiseModel.default(machine)
    kinds, orders = tuple(kinds), list(orders)
    check_basis(machine, basis, "chebyshev")
    per_turn = tuple(a.name for a in machine.axes if a.multiturn) if basis == "chebyshev" else ()
    if noise.instrument == "range":
        check_stations(campaign)
    if validation is not None:  # Paper I Table 2: every order fitted, judged on the validation file
        sweeps = [order_sweep(machine, campaign, kind, orders, validation=validation, folds=folds, noise=noise,
                              basis=basis, progress=progress) for kind in kinds]
        return OrdersRun(kinds, folds, sweeps=sweeps, orders=tuple(orders), per_turn_axes=per_turn)
    check_orders(machine, campaign, kinds, orders, folds=folds, noise=noise, basis=basis)
    choice = choose_model(machine, campaign, noise, kinds=kinds, families=tuple(dict.fromkeys((basis, "chebyshev"))),
                          plans=(basis,), orders=orders, per_axis=False, folds=folds, progress=progress)
    return OrdersRun(kinds, folds, choice=choice, orders=tuple(orders), per_turn_axes=per_turn)
