"""What several commands share: progress lines, noise options, order lists."""
from __future__ import annotations

import argparse
import math
import sys
import time

from vecpin.errors import InputError
from vecpin.measurement.defaults import (DEFAULT_BALLBAR_SIGMA, DEFAULT_CARTESIAN_SIGMA, DEFAULT_LINEAR_SIGMA,
                                         DEFAULT_ROTARY_SIGMA)
from vecpin.measurement.tracker import TrackerNoise
from vecpin.units import MM_PER_M

MACHINE_HELP = "bundled machine name (vecpin info lists them) or URDF file"
CAMPAIGN_HELP = "campaign CSV: commands in mm/deg, tool in mm, measured x, y, z in mm (see docs/measurement.md)"


def noise_defaults() -> dict[str, str]:
    """The noise model's defaults as the options write them (mm, deg, ppm)."""
    t = TrackerNoise()
    return {"repeatability_mm": f"{DEFAULT_LINEAR_SIGMA * MM_PER_M:g}",
            "repeatability_deg": f"{math.degrees(DEFAULT_ROTARY_SIGMA):g}",
            "tracker_sigma_mm": f"{DEFAULT_CARTESIAN_SIGMA * MM_PER_M:g}",
            "ballbar_sigma_mm": f"{DEFAULT_BALLBAR_SIGMA * MM_PER_M:g}",
            "tracker_noise": f"{t.range_const * MM_PER_M:g} {t.range_ppm * 1e6:g} {t.transverse_const * MM_PER_M:g} "
                             f"{t.transverse_ppm * 1e6:g}"}


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
                   help="axis of the tool link the tool points along: +x, -x, +y, -y, +z or -z (default -z; the "
                        "ROS-Industrial flanges: +z of 'tool0', +x of 'flange'); write a negative axis as --tool-axis=-z")


def add_noise_args(s: argparse.ArgumentParser, *, multilateration: bool = True, ballbar: bool = True) -> None:
    """The one noise option group (plan, fit, orders, diagnose): the tracker's native
    spherical model by default (seed Section 3), Cartesian with --cartesian; machine
    repeatability (Σ_v). ``multilateration``, ``ballbar``: False for a command whose
    computation has no range-only or ball bar rows (plan). Read back by :func:`noise`."""
    d = noise_defaults()
    g = s.add_argument_group("noise", "the noise of the readings and of the machine's positioning (default: the "
                             "tracker's native spherical model, growing with the range)")
    g.add_argument("--cartesian", action="store_true",
                   help="tracker noise the same in every direction (--tracker-sigma-mm); default: the tracker's "
                        "native spherical model, growing with the range (--tracker-noise; seed Section 3)")
    if multilateration:
        g.add_argument("--multilateration", action="store_true",
                       help="use the tracker ranges only, one equation per row; needs several stations (default: "
                            "all three coordinates)")
    if ballbar:
        g.add_argument("--ballbar-sigma-mm", type=float,
                       help=f"1-sigma noise of a ball bar's radius reading, mm (default {d['ballbar_sigma_mm']})")
    g.add_argument("--repeatability-mm", type=float,
                   help=f"1-sigma positioning noise of linear axes (Σ_v), mm (default {d['repeatability_mm']})")
    g.add_argument("--repeatability-deg", type=float,
                   help=f"1-sigma positioning noise of rotary axes (Σ_v), deg (default {d['repeatability_deg']})")
    g.add_argument("--tracker-sigma-mm", type=float,
                   help=f"1-sigma Cartesian tracker noise per coordinate, mm (default {d['tracker_sigma_mm']}; with "
                        "--cartesian)")
    add_tracker_noise_arg(g)


def add_tracker_noise_arg(s, what: str = "spherical tracker noise (the default)") -> None:
    """--tracker-noise R_MM R_PPM T_MM T_PPM: the spherical model's four numbers."""
    s.add_argument("--tracker-noise", type=float, nargs=4, metavar=("R_MM", "R_PPM", "T_MM", "T_PPM"),
                   help=f"{what}: 1-sigma range noise = R_MM mm + R_PPM ppm of the range, transverse = T_MM mm + "
                        f"T_PPM ppm of the range (default {noise_defaults()['tracker_noise']})")


def add_quiet_arg(s: argparse.ArgumentParser) -> None:
    s.add_argument("--quiet", action="store_true", help="no progress lines (default: progress on stderr)")


def add_model_args(s: argparse.ArgumentParser, default_kind: str = "auto") -> None:
    """--model, --basis, --order: what to fix of the model (default: the data choose)."""
    s.add_argument("--model", choices=["auto", "6dof", "ap"], default=default_kind,
                   help="error model: 6dof (Paper I eq. 3-6), ap (axis perturbation, eq. 7-8) or auto: chosen by "
                        f"held-out data (default {default_kind})")
    s.add_argument("--basis", choices=["auto", "chebyshev", "fourier", "fourier_trend", "spline", "pspline", "smooth"],
                   default="auto",
                   help="basis of the error functions: chebyshev over the travel (the seed's), fourier (per turn on "
                        "rotary axes travelling more than a turn), fourier_trend (per turn plus a trend over the "
                        "travel), spline (cubic B-splines), pspline (penalised cubic B-splines, 15 interior knots "
                        "unless --order, smoothing chosen by held-out data), or auto: chebyshev, fourier, "
                        "fourier_trend or pspline, chosen per axis by held-out data (default); smooth (fit; a plan "
                        "plans it as spline): "
                        "penalised splines (per turn: Fourier) on every axis with a smoothness prior whose scales the "
                        "evidence chooses")
    s.add_argument("--order", default="auto",
                   help="series order (a whole number: Chebyshev and Fourier series of that order, trends up to it; "
                        "with --basis spline or pspline the number of interior knots per axis), or auto: chosen by held-out "
                        "data, per axis (default)")


def noise_stated(args) -> bool:
    """True when the user gave any noise level (repeatability, tracker, ball bar)."""
    return any(getattr(args, k, None) is not None for k in ("repeatability_mm", "repeatability_deg",
                                                            "tracker_sigma_mm", "tracker_noise", "ballbar_sigma_mm"))


def noise(args, m):
    """The noise model of :func:`add_noise_args`' options (None kept as the default)."""
    from vecpin.measurement.noise import noise_from_options
    kind = "range" if getattr(args, "multilateration", False) else ("cartesian" if args.cartesian else "spherical")
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
    return parse_zone(text, "zone") if text else None


def say(args, *lines: str, file=None) -> None:
    """Print library text (results, warnings, advice) with its backquoted parameters as the
    command's flags (:func:`vecpin.cli.options.as_flags`)."""
    from vecpin.cli.options import as_flags
    for line in lines:
        print(as_flags(line, getattr(args, "flags", {})), file=file or sys.stdout)
