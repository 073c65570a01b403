"""``vecpin info``: a machine's axes, limits and frames."""
from __future__ import annotations

from vecpin.cli.common import machine


def run_info(args) -> int:
    from vecpin.kinematics.machine import bundled_machines
    m = machine(args.machine)
    print(m.describe())
    if args.machine not in bundled_machines():
        print(f"  (bundled machines: {', '.join(bundled_machines())})")
    return 0


def register(sub) -> None:
    s = sub.add_parser("info", help="axes, limits and frames of a machine (bundled name or URDF path)")
    s.add_argument("machine")
    s.set_defaults(func=run_info)
