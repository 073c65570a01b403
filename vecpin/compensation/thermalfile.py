"""The thermal terms file (``thermal.json``, :class:`~vecpin.compensation.thermal.ThermalTerms`)
checked field by field before anything is computed from it: a hand-edited or truncated
file is refused naming the file and the field, never a traceback or a figure from NaN.

Units as the file holds them: °C, h, mm, µm/K, µm/m/K."""
from __future__ import annotations

import math

from vecpin.errors import InputError

KNOWN = {"format", "machine", "axes", "t0_c", "lag_h", "p0_mm", "offset_um_per_k", "slope_um_per_m_per_k",
         "growth_um_per_k", "offset_std", "slope_std", "growth_std", "t_range_c", "notes", "held_out", "curvature",
         "description"}
PLAUSIBLE = 500.0   # um/K, um/m/K: 40 times steel's expansion; a larger term is a unit typed wrong
PER_AXIS = ("p0_mm", "offset_um_per_k", "slope_um_per_m_per_k")


def _number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def check_terms(path, d) -> None:
    """Refuse (:class:`InputError` naming ``path`` and the field) a parsed thermal terms file
    ``d`` that is not an object of the known fields with finite numbers in their units."""
    def bad(name: str, text: str) -> InputError:
        return InputError(f"{path}, field '{name}': {text}")
    if not isinstance(d, dict):
        raise InputError(f"{path}: not a vecpin thermal terms file (a JSON object with the fields "
                         f"{', '.join(sorted(KNOWN))})")
    unknown = sorted(set(d) - KNOWN)
    if unknown:
        raise bad(unknown[0], "not a field of a thermal terms file")
    for name in ("machine", "axes", "t0_c", "lag_h", *PER_AXIS, "t_range_c"):
        if name not in d:
            raise bad(name, "missing")
    if not isinstance(d["machine"], str):
        raise bad("machine", f"{d['machine']!r}: the machine's name")
    axes = d["axes"]
    if (not isinstance(axes, list) or not axes or not all(isinstance(a, str) for a in axes)
            or len(set(axes)) < len(axes)):
        raise bad("axes", f"{axes!r}: a list of the machine's linear axes, each once")
    if not _number(d["t0_c"]) or not -50.0 <= d["t0_c"] <= 100.0:
        raise bad("t0_c", f"{d['t0_c']!r}: the reference temperature, a number in degC (-50 .. 100)")
    if not _number(d["lag_h"]) or d["lag_h"] < 0:
        raise bad("lag_h", f"{d['lag_h']!r}: the lag in hours, a number >= 0")
    for name in PER_AXIS + ("offset_std", "slope_std"):
        v = d.get(name, {})
        if not isinstance(v, dict):
            raise bad(name, f"{v!r}: an object, axis -> number")
        if name in PER_AXIS or v:
            missing = [a for a in axes if not _number(v.get(a))]
            if missing:
                raise bad(f"{name}.{missing[0]}", f"{v.get(missing[0])!r}: a finite number for every axis of 'axes'")
    for name in ("offset_um_per_k", "slope_um_per_m_per_k"):
        big = [a for a in axes if abs(d[name][a]) > PLAUSIBLE]
        if big:
            raise bad(f"{name}.{big[0]}", f"{d[name][big[0]]:g}: more than {PLAUSIBLE:g} per K, beyond any machine's "
                      "expansion (steel 11.5 um/m/K): a unit typed wrong (mm for um)?")
    for name in ("growth_um_per_k", "growth_std"):
        if d.get(name) is not None and not _number(d[name]):
            raise bad(name, f"{d[name]!r}: a number in um/K, or null")
    r = d["t_range_c"]
    if not isinstance(r, list) or len(r) != 2 or not all(_number(t) for t in r) or r[0] > r[1]:
        raise bad("t_range_c", f"{r!r}: the lowest and the highest temperature the campaign saw, degC")
    if not d.get("held_out") and not (d.get("offset_std") and d.get("slope_std")):
        raise bad("held_out", "missing, and no offset_std and slope_std either: the file records no uncertainty "
                  "of the terms, so what they leave cannot be predicted")
    _check_held_out(d.get("held_out") or {}, axes, bad)
    _check_curvature(d.get("curvature") or {}, axes, bad)


def _check_curvature(c, axes, bad) -> None:
    """The curvature record: per term (names, per_k, cov_per_k, alpha) or, in an older file,
    one for all terms (per_k, std_per_k, alpha), or empty."""
    alpha = isinstance(c, dict) and isinstance(c.get("alpha"), list) and len(c["alpha"]) == 2 \
        and all(_number(a) for a in c["alpha"])
    if isinstance(c, dict) and not c:
        return
    if not alpha:
        raise bad("curvature", "an object with names, per_k, cov_per_k and alpha (two numbers), or {}")
    if "names" not in c:
        if not (_number(c.get("per_k")) and _number(c.get("std_per_k"))):
            raise bad("curvature", "per_k and std_per_k: numbers (one curvature for all terms)")
        return
    names, per_k, cov = c["names"], c.get("per_k"), c.get("cov_per_k")
    known = set(axes) | {"tool_growth"}
    if not isinstance(names, list) or not names or not all(isinstance(n, str) and n in known for n in names):
        raise bad("curvature.names", f"{names!r}: the bent terms, each an axis of 'axes' or tool_growth")
    if "growth_axis" in c and c["growth_axis"] not in axes:
        raise bad("curvature.growth_axis", f"{c['growth_axis']!r}: the axis whose offset carries the tool's growth, "
                  "one of 'axes'")
    n = len(names)
    if not isinstance(per_k, list) or len(per_k) != n or not all(_number(v) for v in per_k):
        raise bad("curvature.per_k", f"{n} finite numbers [1/K], one per name")
    if (not isinstance(cov, list) or len(cov) != n
            or not all(isinstance(row, list) and len(row) == n and all(_number(x) for x in row) for row in cov)):
        raise bad("curvature.cov_per_k", f"a {n} x {n} matrix of finite numbers [1/K^2] (one row and column per name)")


def _check_held_out(h, axes, bad) -> None:
    if not isinstance(h, dict):
        raise bad("held_out", f"{h!r}: an object (names, cov, floor_um)")
    if not h:
        return
    names, cov = h.get("names"), h.get("cov")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise bad("held_out.names", f"{names!r}: the coefficients' names")
    known = {"tool_growth_per_K"} | {f"{a}.{k}_per_K" for a in axes for k in ("offset", "slope")}
    strange = [nm for nm in names if nm not in known]
    if strange:
        raise bad("held_out.names", f"{strange[0]!r}: not a coefficient of these terms ({', '.join(sorted(known))})")
    n = len(names)
    if (not isinstance(cov, list) or len(cov) != n
            or not all(isinstance(row, list) and len(row) == n and all(_number(x) for x in row) for row in cov)):
        raise bad("held_out.cov", f"a {n} x {n} matrix of finite numbers (one row and column per name)")
    b = h.get("blocks", 0)
    if not isinstance(b, int) or isinstance(b, bool) or b < 0:
        raise bad("held_out.blocks", f"{b!r}: the number of time blocks held out, a whole number")
    if not _number(h.get("floor_um")) or h["floor_um"] < 0:
        raise bad("held_out.floor_um", f"{h.get('floor_um')!r}: a length in um >= 0")
