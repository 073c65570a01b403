"""Figures of everything the cross-validation engine decides, to compare two versions of
vecpin digit by digit: the model choice (every candidate's held-out mean and max [mm],
the chosen and the lowest, on five simulated campaigns: Flow XYZCB 590 rows with the
default, a fixed Chebyshev order and penalised splines; two machines of the independent
truth family; a trunnion with table nests), the order sweep (6-DoF and AP, orders 0-6,
one and two tracker stations) and a diagnosis (a backlash on X).

Run: python benchmarks/bench_crossval.py [--no-diag] > figures.txt   (then diff two runs)
"""
import sys
import time

import vecpin
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.simulation.independent import IndependentMachine, layout
from vecpin.selection.choice import choose_model, choose_or_fix
from vecpin.selection.orders import order_sweep


def show_choice(tag: str, ch) -> None:
    """A model choice: its outcome, then every candidate (kind, bases, terms, held-out mean and max [mm])."""
    print(f"== choice {tag}: chosen {ch.chosen.label()} best {ch.best.label()} se {ch.standard_error_mm:.6f} "
          f"n {len(ch.candidates)} left_out {ch.left_out} fixed {ch.fixed_unknowns} eq {ch.equations} rows {ch.rows} "
          f"unc {ch.uncompensated_mm[0]:.6f} {ch.uncompensated_mm[1]:.6f} secs {ch.seconds:.2f}")
    for c in sorted(ch.candidates, key=lambda c: (c.kind, c.label())):
        eff = "" if c.effective_terms is None else f" eff {c.effective_terms:.4f}"
        print(f"   {c.kind:5s} {c.label():60s} {c.n_terms:5d} {c.mean:.7f} {c.max:.7f}{eff}")


def main() -> None:
    flow = vecpin.Machine.load("flow_xyzcb")
    sim = simulate(flow, seed=0, mean_error_mm=0.65)
    sph = NoiseModel.default(flow, "spherical")
    show_choice("flow590", choose_model(flow, sim.campaign, sph))
    _, ch = choose_or_fix(flow, sim.campaign, sph, "auto", "chebyshev", 6)
    show_choice("flow590 auto/chebyshev/6", ch)
    _, ch = choose_or_fix(flow, sim.campaign, sph, "6dof", "pspline", "auto")
    show_choice("flow590 6dof/pspline/auto", ch)
    for name, fam in (("portal_xyzcb_c720", "windup"), ("head_xyzab", "spline")):
        m = layout(name)
        truth = IndependentMachine.random(m, fam, seed=1)
        s = simulate(m, seed=2, design=Design(), truth=truth)
        show_choice(f"{name}/{fam}", choose_model(m, s.campaign, NoiseModel.default(m, "spherical", tracker=truth.tracker.noise)))
    tr = vecpin.Machine.load("trunnion_xyzac")
    s = simulate(tr, seed=5, design=Design(n_commands=60, n_validation=5, nests=3))
    show_choice("trunnion nests", choose_model(tr, s.campaign, NoiseModel.default(tr, "spherical")))
    two = simulate(flow, seed=3, design=Design(n_commands=80, n_validation=5, stations=2))
    for kind in ("6dof", "ap"):
        for tag, camp in (("flow590", sim.campaign), ("flow 2 stations", two.campaign)):
            t0 = time.perf_counter()
            sw = order_sweep(flow, camp, kind, range(0, 7), noise=sph)
            print(f"== order sweep {tag} {kind} ({time.perf_counter() - t0:.1f} s): best order {sw.best.order}")
            print(sw.table())
            print("   raw:", " ".join(f"{r.order}:{r.heldout_mean:.6f}/{r.heldout_max:.6f}" for r in sw.rows),
                  f"unc {sw.uncompensated_heldout[0]:.6f}")
    if "--no-diag" not in sys.argv:
        from vecpin.diagnosis.diagnose import diagnose
        t0 = time.perf_counter()
        from vecpin.simulation.effects import EffectSpec
        dsim = simulate(flow, seed=4, effects=[EffectSpec("backlash", ("X",), 0.03)])
        d = diagnose(flow, dsim.campaign, noise=sph, max_effects=2)
        print(f"== diagnosis ({time.perf_counter() - t0:.1f} s)")
        print("  base", {k: d.base[k] for k in ("label", "heldout_mean_mm", "heldout_max_mm", "rows")})
        for e in d.effects[:8]:
            print(f"   {e.label:40s} {e.heldout_mean_mm_before:.6f} -> {e.heldout_mean_mm_after:.6f} p {e.p_value:.3e} "
                  f"ph {e.p_heldout:.3e} acc {e.accepted}")
        print("  accepted", [e.label for e in d.accepted] if hasattr(d, "accepted") else None, "best", d.best_heldout())


if __name__ == "__main__":
    main()
