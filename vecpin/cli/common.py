"""What several commands share: progress lines, noise options, order lists."""
from __future__ import annotations

import argparse
import sys
import time

from vecpin.errors import InputError


def progress(enabled: bool = True):
    """A progress printer to stderr with the elapsed time, or a no-op."""
    t0 = time.perf_counter()

    def say(msg: str) -> None:
        if enabled:
            print(f"  [{time.perf_counter() - t0:6.1f} s] {msg}", file=sys.stderr, flush=True)
    return say


def machine(name: str, args=None):
    """Load a machine (bundled name or URDF path) with the --tool-link/--tool-axis options
    of ``args`` when the command has them (see :func:`add_machine_args`)."""
    from vecpin.kinematics.machine import Machine
    return Machine.load(name, tool_link=getattr(args, "tool_link", None), tool_axis=getattr(args, "tool_axis", None))


def add_machine_args(s: argparse.ArgumentParser) -> None:
    """--tool-link and --tool-axis, for every command that takes a machine."""
    s.add_argument("--tool-link", metavar="LINK[,LINK2]",
                   help="URDF link the tool is mounted to, its origin on the gauge line (default: 'spindle', plus "
                        "'spindle_2', ... when present; a ROS arm: tool0). Several links, comma-separated, are "
                        "several tool points driven by the same axis commands")
    s.add_argument("--tool-axis", metavar="AXIS",
                   help="axis of the tool link the tool points along: +x, -x, +y, -y, +z or -z (default -z; +z for "
                        "ROS tool flanges 'tool0' and 'flange'); write a negative axis as --tool-axis=-z")


def add_noise_args(s: argparse.ArgumentParser) -> None:
    s.add_argument("--spherical", action="store_true", help="tracker noise in its native spherical coordinates (range dependent)")
    s.add_argument("--multilateration", action="store_true", help="use the tracker ranges only (several stations)")
    s.add_argument("--ballbar-sigma-mm", type=float, help="ball bar radius noise, mm (default 0.0025)")
    s.add_argument("--repeatability-mm", type=float, help="1-sigma positioning noise of linear axes, mm (default 0.006)")
    s.add_argument("--repeatability-deg", type=float, help="1-sigma positioning noise of rotary axes, deg (default 0.0015)")
    s.add_argument("--tracker-sigma-mm", type=float, help="Cartesian tracker noise, mm (default 0.02)")
    s.add_argument("--tracker-noise", type=float, nargs=4, metavar=("R_MM", "R_PPM", "T_MM", "T_PPM"),
                   help="spherical tracker noise: range sigma = R_MM + R_PPM*R, transverse = T_MM + T_PPM*R")
    s.add_argument("--quiet", action="store_true", help="no progress lines")


def add_model_args(s: argparse.ArgumentParser, default_kind: str = "auto") -> None:
    """--model, --basis, --order: what to fix of the model (default: the data choose)."""
    s.add_argument("--model", choices=["auto", "6dof", "ap"], default=default_kind,
                   help="error model: 6dof (Paper I eq. 3-6), ap (axis perturbation, eq. 7-8) or auto: chosen by "
                        f"held-out data (default {default_kind})")
    s.add_argument("--basis", choices=["auto", "chebyshev", "fourier", "fourier_trend", "spline", "pspline"],
                   default="auto",
                   help="basis of the error functions: chebyshev over the travel (the seed's), fourier (per turn on "
                        "rotary axes travelling more than a turn), fourier_trend (per turn plus a trend over the "
                        "travel), spline (cubic B-splines), pspline (penalised cubic B-splines, 31 interior knots "
                        "unless --order, smoothing chosen by held-out data), or auto: chebyshev, fourier, "
                        "fourier_trend or spline, chosen per axis by held-out data (default)")
    s.add_argument("--order", default="auto",
                   help="series order (a whole number: Chebyshev and Fourier series of that order, trends up to it; "
                        "with --basis spline or pspline the number of interior knots per axis), or auto: chosen by held-out "
                        "data, per axis (default)")


def noise(args, m):
    from vecpin.measurement.noise import noise_from_options
    kind = "range" if getattr(args, "multilateration", False) else ("spherical" if args.spherical else "cartesian")
    return noise_from_options(m, kind, repeatability_mm=args.repeatability_mm, repeatability_deg=args.repeatability_deg,
                              tracker_sigma_mm=args.tracker_sigma_mm, tracker_noise=args.tracker_noise,
                              ballbar_sigma_mm=getattr(args, "ballbar_sigma_mm", None))


def parse_orders(text: str) -> list[int]:
    """'0-7' or '2,4,6' -> a list of orders >= 0."""
    out = []
    try:
        for part in text.split(","):
            if "-" in part.strip()[1:]:
                a, b = part.split("-", 1)
                lo, hi = int(a), int(b)
                if hi < lo:
                    raise ValueError
                out += list(range(lo, hi + 1))
            else:
                out.append(int(part))
    except ValueError:
        raise InputError(f"--orders '{text}': write a range like 0-7 or a list like 2,4,6 (orders >= 0)") from None
    if not out or min(out) < 0:
        raise InputError(f"--orders '{text}': orders are whole numbers >= 0")
    return out


def zone_option(text):
    """``--zone AXIS=LO:HI[,...]`` (mm/deg) as a zone, or None."""
    from vecpin.planning.zones import parse_zone
    return parse_zone(text, "--zone") if text else None
