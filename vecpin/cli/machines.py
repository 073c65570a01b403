"""``vecpin info``: the bundled machines with their layouts, or one machine's axes,
limits, tool points, frames and load notes."""
from __future__ import annotations

from vecpin.cli.common import add_machine_args, machine, say


def run_info(args) -> int:
    from vecpin.kinematics.axes import bundled_machines
    from vecpin.kinematics.machine import Machine
    if args.machine is None:
        print("bundled machines (vecpin info NAME for axes, limits and frames):")
        names = bundled_machines()
        width = max(len(n) for n in names)
        for name in names:
            m = Machine.load(name)
            print(f"  {name:<{width}s}  {m.n_axes} axes  {m.layout}")
        return 0
    m = machine(args.machine, args)
    say(args, m.describe())
    if args.machine not in bundled_machines():
        print(f"  (bundled machines: {', '.join(bundled_machines())})")
    return 0


def add_commands(sub) -> None:
    s = sub.add_parser("info", help="the bundled machines and their layouts, or one machine's axes, limits "
                                    "(mm, deg) and frames (bundled name or URDF path)")
    s.add_argument("machine", nargs="?", help="bundled machine name or URDF file; omit to list the bundled machines")
    add_machine_args(s)
    s.set_defaults(func=run_info)
