"""vecpin's tables on the blind generator's machines, against the best table set that exists (issue 40).

Every run draws fresh machines from ``benchmarks/generator`` (written blind to vecpin: random layouts,
Gaussian-process error fields per axis): every class that takes tables (head, table = trunnion,
head-table, twin-drive gantry), a clean campaign each (tool rows with two tools, nests on a turning
table). vecpin runs as a user following the plan runs it: ``vecpin fit`` (the default model choice,
given the tracker's and the axes' noise as their specs state them, and every table nest's height
above the table's face with ``--nest-height`` as the plan's nest_heights.csv asks: the generator's
true height read by a height gauge with a normal error of GAUGE_SIGMA_MM, the reading's standard
deviation left to vecpin's default as the plan's file states it) and ``vecpin tables`` for the generic
files, Siemens 840D and LinuxCNC. Beside it the same noisy campaign fitted without the heights (*no
heights*), the same without heights fitted with the smoothness prior (*prior*: ``--basis smooth``,
vecpin.fitting.smoothprior) and with the exact heights, stated exact (*exact heights*), generic files only,
each against the best set for its own tables (*no heights* and *prior* also against the oracle's set for them).

The judge is written without vecpin: the generator's own numpy kinematics is the true machine; the
generic ``tables.json`` is read by the parser of tests/part_frame_judge.py, the Siemens and LinuxCNC
files by the controllers' documented rules in tests/controller_appliers.py. The true tip relative
to the true table (the generator's ``workpiece`` link; the base on a head or gantry machine) on 600
fresh random commands x the campaign's tools, against the nominal tip: *part* (a translation and a
rotation about the spindle removed, as a part set up by probing and aligning an edge sees it) and
*shape* (the best rigid motion removed).

The best table set that exists: for the same tables (input and output axes, the same grid ends,
modulo as written) and the same product terms (a rotary's table times a linear axis' ramp: the pair
and the ramp as vecpin wrote them, the table's knots free) the values that minimise the truth's
compensated error, fitted here by linear least squares (scipy, a sparse design matrix) on 10000
other random commands x the tools: the truth linearised in the commands (central differences of the
generator's kinematics), every table piecewise linear on ``KNOTS`` knots over its grid, a
tool-length (gauge) change free, and the frame's freedoms (part: translation and rotation about the
spindle; shape: the rigid motion) free. One fit per judged frame. It is judged by the same judge,
through the exact (not linearised) truth. The page is written by benchmarks/gentables_page.py.

What the campaign allows (*achievable*, benchmarks/gentables_oracle.py): the same best set for the
machine an oracle estimates from the campaign's own noisy readings, knowing the generator's prior
(its Gaussian-process kernels and sizes), the noise model, the tracker pose, the tools and the
nests (their heights exactly) (the
posterior mean: on average no estimate from these readings does better). achievable / best is what
the campaign's size and noise cost; vecpin / achievable what vecpin's method costs beyond that.

Run: python benchmarks/bench_generator_tables.py [-n 30] [--seed S] [--kinds table head_table ...]
     [--out docs/results/generator_tables.md] [--heldout]
Fresh seeds every run unless --seed; --heldout: the held-out seeds of ``benchmarks/heldout.py`` (committed code
only, no draw's details shown, the summary added to docs/results/heldout.md; run it once per stop, never tune).
"""
from __future__ import annotations

import argparse
import json
import os
import secrets
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):   # one thread: the machine is shared
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
import scipy.linalg  # noqa: E402
import scipy.sparse  # noqa: E402

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(ROOT / "tests"))

from generator import draw_campaign  # noqa: E402
from generator.kinematics import chain  # noqa: E402
from controller_appliers import linuxcnc_corrections, siemens_corrections  # noqa: E402
from part_frame_judge import part_errors, read_tables, shape_errors  # noqa: E402
from bench_unseen import noise_options, vecpin_cmd  # noqa: E402  (the stated noise; the command as a user runs it)
from heldout import Run, heldout_seeds  # noqa: E402
from gentables_oracle import estimated_campaign  # noqa: E402
from gentables_page import FORMATS, GAUGE_SIGMA_MM, KNOTS, N_FIT, N_JUDGE, TARGET, page  # noqa: E402,F401

RESULT = ROOT / "docs" / "results" / "generator_tables.md"
KINDS = ("table", "head_table", "head", "gantry")
PRIOR_OPTIONS = ("--basis", "smooth")   # the *prior* arm: the smoothness prior's fit (vecpin.fitting.smoothprior)
EIG_CUT = 1e-8          # ridge on the scaled normal equations, as a share of their largest eigenvalue's bound


def nest_height_options(camp, sigma_mm: float | None = GAUGE_SIGMA_MM) -> list[str]:
    """``--nest-height ID=MM`` per table nest, as the plan asks: the generator's true height of each
    nest's centre above its table face (z in its ``workpiece`` frame), read by a height gauge with a
    normal error of ``sigma_mm`` (drawn from the seed, so a rerun reads the same; None: no heights
    given). The reading's standard deviation is left to vecpin's default (a user who keeps the plan's
    nest_heights.csv as written), except for exact heights (0): ``ID=MM:0``, exact, stated."""
    if sigma_mm is None:
        return []
    rng = np.random.default_rng([camp.seed, 4051])
    z_mm = np.asarray(camp.nests_m)[:, 2] * 1e3 + rng.normal(0.0, 1.0, len(camp.nests_m)) * sigma_mm
    exact = ":0" if sigma_mm == 0 else ""
    return [f"--nest-height={k + 1}={h:.4f}{exact}" for k, h in enumerate(z_mm)]


def profile(axes: list[str], controller: str) -> dict:
    """The controller profile a user writes: Siemens NC names ``<axis>1`` and ``AX<k>``, reference
    points at 0; LinuxCNC joint numbers in URDF order."""
    if controller.startswith("siemens"):
        facts = {a: {"nc_name": f"{a}1", "general_name": f"AX{k + 1}", "reference_position": 0.0}
                 for k, a in enumerate(axes)}
    else:
        facts = {a: {"number": k} for k, a in enumerate(axes)}
    return {"format": "vecpin-controller-profile", "version": 1, "axes": facts}


class Truth:
    """The generator's true machine (its numpy kinematics): tips relative to its table, SI."""

    def __init__(self, camp):
        self.camp, self.layout = camp, camp.layout
        self.axes = [j.name for j in self.layout.axes]
        self.unit = np.array([1e-3 if j.kind == "prismatic" else np.pi / 180 for j in self.layout.axes])
        self.lower = np.array([j.lower for j in self.layout.axes])
        self.upper = np.array([j.upper for j in self.layout.axes])

    def _q(self, q: np.ndarray) -> dict:
        return {a: q[:, k] for k, a in enumerate(self.axes)}

    def tip(self, q: np.ndarray, tool: np.ndarray, errors: bool = True) -> np.ndarray:
        """(N, 3) tool tip in the workpiece frame [m] at commands q (N, n) [m, rad], tool (N,) [m]."""
        qd = self._q(q)
        err = self.camp.errors(with_effect=False) if errors else None
        t = chain(self.layout, self.layout.tool_chain, qd, errors=err)
        local = np.asarray(self.layout.tool_axis)[None, :] * tool[:, None]
        p = np.einsum("nij,nj->ni", t[:, :3, :3], local) + t[:, :3, 3]
        if self.layout.table_chain:
            w = chain(self.layout, self.layout.table_chain, qd, errors=err)
            p = np.einsum("nji,nj->ni", w[:, :3, :3], p - w[:, :3, 3])
        return p

    def spindle(self) -> np.ndarray:
        """The nominal tool direction in the workpiece frame with every axis at home (0, clipped)."""
        q = np.clip(np.zeros((1, len(self.axes))), self.lower, self.upper)
        return self.tip(q, np.ones(1), False)[0] - self.tip(q, np.zeros(1), False)[0]

    def commands(self, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
        """n random commands in the travel [m, rad], each with every tool of the campaign."""
        rng = np.random.default_rng(seed)
        q = self.lower + rng.random((n, len(self.axes))) * (self.upper - self.lower)
        tools = np.asarray(self.camp.tools_m)
        return np.repeat(q, len(tools), axis=0), np.tile(tools, n)


def judge(truth: Truth, corr_user: np.ndarray, gauge_mm: float, q: np.ndarray, tool: np.ndarray) -> dict:
    """Mean tip error [mm]: part and shape, of the truth commanded q + corrections (user units)."""
    tip = truth.tip(q + corr_user * truth.unit, tool)
    nom = truth.tip(q, tool + gauge_mm * 1e-3, errors=False)
    return {"part": float(np.linalg.norm(part_errors(nom, tip, truth.spindle()), axis=1).mean() * 1e3),
            "shape": float(np.linalg.norm(shape_errors(nom, tip), axis=1).mean() * 1e3)}


def _table_value(entry: tuple, axes: list[str], q_user: np.ndarray) -> np.ndarray:
    """A table's value at the commands (linear between its points, ends held, modulo wraps)."""
    inp, _, start, step, values, modulo = entry
    x = q_user[:, axes.index(inp)]
    if modulo:
        x = start + np.mod(x - start, step * (len(values) - 1))
    return np.interp(x, start + step * np.arange(len(values)), values)


def generic_corrections(tables: dict, axes: list[str], q_user: np.ndarray) -> np.ndarray:
    """Corrections [mm, deg] of a generic tables.json by its stated conventions: tables summed per
    output axis; a product term adds its table's value times its factor table's value."""
    out = np.zeros_like(q_user)
    for entry in tables["tables"]:
        out[:, axes.index(entry[1])] += _table_value(entry, axes, q_user)
    for table, factor in tables.get("products", []):
        out[:, axes.index(table[1])] += _table_value(table, axes, q_user) * _table_value(factor, axes, q_user)
    return out


def corrections(fmt: str, folder: Path, axes: list[str], q_user: np.ndarray) -> tuple[np.ndarray, float]:
    """(corrections [mm, deg], gauge change [mm]) of the files vecpin wrote for ``fmt``."""
    gauge = read_tables(folder / "tables.json")["gauge_mm"]
    if fmt == "generic":
        return generic_corrections(read_tables(folder / "tables.json"), axes, q_user), gauge
    if fmt.startswith("siemens"):
        return siemens_corrections(folder, axes, {a: 0.0 for a in axes}, q_user), gauge
    return linuxcnc_corrections(folder, axes, q_user), gauge


def hat(x: np.ndarray, lo: float, hi: float, k: int, modulo: bool = False) -> scipy.sparse.csr_matrix:
    """(N, k) weights of piecewise-linear interpolation on k knots over [lo, hi], ends held; ``modulo``:
    x taken modulo hi - lo, the last knot the first one (its column stays empty)."""
    if modulo:
        x = lo + np.mod(x - lo, hi - lo)
    u = np.clip((x - lo) / (hi - lo), 0.0, 1.0) * (k - 1)
    i = np.minimum(u.astype(int), k - 2)
    cols = np.c_[i, i + 1] % (k - 1) if modulo else np.c_[i, i + 1]
    rows = np.repeat(np.arange(len(x)), 2)
    return scipy.sparse.csr_matrix((np.c_[1.0 - (u - i), u - i].ravel(), (rows, cols.ravel())), shape=(len(x), k))


def jacobian(truth: Truth, q: np.ndarray, tool: np.ndarray) -> np.ndarray:
    """(N, 3, n) d tip / d command [m per user unit], central differences of the truth."""
    J = np.empty((len(q), 3, len(truth.axes)))
    for k in range(len(truth.axes)):
        h = np.zeros(len(truth.axes))
        h[k] = 1e-3 * truth.unit[k]             # 1 um or 1 mdeg
        J[:, :, k] = (truth.tip(q + h, tool) - truth.tip(q - h, tool)) / 2e-3
    return J


class BestSets:
    """The best values for a set of tables for the truth (module text), on fixed fitting commands:
    the truth's linearisation is computed once and shared by every table set and frame."""

    def __init__(self, truth: Truth, seed: int, n_fit: int = N_FIT):
        self.truth = truth
        q, tool = truth.commands(n_fit, seed)
        self.q_user = q / truth.unit
        self.J = jacobian(truth, q, tool)
        nom = truth.tip(q, tool, errors=False)
        self.r0 = (truth.tip(q, tool) - nom).ravel()                         # m
        c = nom - nom.mean(axis=0)
        s = truth.spindle() / np.linalg.norm(truth.spindle())
        gauge = -(truth.tip(q, tool + 1e-3, errors=False) - nom).reshape(-1, 1)   # per mm of gauge change
        shift = -np.tile(np.eye(3), (len(q), 1))
        self.frame = {"part": np.hstack([gauge, shift, -np.cross(s, c).reshape(-1, 1)]),
                      "shape": np.hstack([gauge, shift] + [-np.cross(w, c).reshape(-1, 1) for w in np.eye(3)])}
        self.cache: dict = {}

    def basis(self, spec: tuple) -> scipy.sparse.csr_matrix:
        """(N, KNOTS) a table's knot weights at the fitting commands; a product term's times its
        factor's value there (the factor as vecpin wrote it: the pair and the ramp fixed, the knots free)."""
        inp, _, lo, hi, modulo, factor = spec
        B = hat(self.q_user[:, self.truth.axes.index(inp)], lo, hi, KNOTS, modulo)
        if factor is None:
            return B
        f_axis, start, step, values = factor
        f = np.interp(self.q_user[:, self.truth.axes.index(f_axis)], start + step * np.arange(len(values)), values)
        return scipy.sparse.csr_matrix(B.multiply(f[:, None]))

    def solve(self, specs: list[tuple], frame: str) -> tuple[dict, float]:
        """(tables dict for :func:`generic_corrections`, gauge change [mm]) of the best set: the normal
        equations of the linearised problem (each table's column is its knots' weights times the tip's
        change per unit of its output axis; a sparse design matrix), solved by numpy."""
        specs = [tuple(sp) + (False, None)[len(sp) - 4:] for sp in specs]       # (input, output, lo, hi): a plain table
        key = (tuple(specs), frame)
        if key in self.cache:
            return self.cache[key], self.cache[key]["gauge_mm"]
        axes, F = self.truth.axes, self.frame[frame]
        n = len(self.q_user)
        Bs = [self.basis(spec) for spec in specs]
        Js = [self.J[:, :, axes.index(spec[1])] for spec in specs]                 # (N, 3) each
        Fr, r = F.reshape(n, 3, -1), self.r0.reshape(n, 3)
        A = scipy.sparse.vstack([scipy.sparse.hstack([B.multiply(J[:, d:d + 1]) for B, J in zip(Bs, Js)]
                                                     + [scipy.sparse.csr_matrix(Fr[:, d, :])]) for d in range(3)])
        A = A.tocsr()                                                  # rows: tip x of every command, then y, z
        N, g = (A.T @ A).toarray(), A.T @ r.T.ravel()
        d = np.sqrt(np.maximum(np.diag(N), 1e-300))
        Ns = N / np.outer(d, d)                                        # unit diagonal; a ridge of EIG_CUT x a bound
        ridge = EIG_CUT * np.abs(Ns).sum(axis=1).max()                 # of its largest eigenvalue holds the null space
        x = -scipy.linalg.cho_solve(scipy.linalg.cho_factor(Ns + ridge * np.eye(len(Ns))), g / d) / d
        tables: dict = {"tables": [], "products": [], "gauge_mm": float(x[len(specs) * KNOTS])}
        for t, (inp, outp, lo, hi, modulo, factor) in enumerate(specs):
            values = x[t * KNOTS:(t + 1) * KNOTS].copy()
            if modulo:
                values[-1] = values[0]
            entry = (inp, outp, lo, (hi - lo) / (KNOTS - 1), values, modulo)
            if factor is None:
                tables["tables"].append(entry)
            else:
                tables["products"].append((entry, (factor[0], outp, factor[1], factor[2], np.array(factor[3]), False)))
        self.cache[key] = tables
        return tables, tables["gauge_mm"]


def table_specs(folder: Path) -> list[tuple]:
    """[(input, output, start, end, modulo, factor)] of the tables vecpin wrote (its tables.json, user
    units); factor: None, or a product term's factor table (input, start, step, values) as written."""
    d = read_tables(folder / "tables.json")
    out = [(i, o, s, s + st * (len(v) - 1), m, None) for i, o, s, st, v, m in d["tables"]]
    for (i, o, s, st, v, m), (fi, _, fs, fst, fv, _) in d["products"]:
        out.append((i, o, s, s + st * (len(v) - 1), m, (fi, fs, fst, tuple(float(a) for a in fv))))
    return out


def model_label(path: Path, axes: list[str]) -> str:
    """The chosen model in short: kind, then per axis its basis and order (model.json)."""
    m = json.loads(path.read_text())["model"]
    bases = m.get("axis_bases") or []
    short = {"chebyshev": "Ch", "fourier": "F", "pspline": "PS"}
    prior = f" + {m['smooth_prior']['kernel']} prior" if m.get("smooth_prior") else ""
    return m["kind"] + " " + " ".join(f"{a}:{short.get(b['kind'], b['kind'])}{b.get('order', '')}"
                                      for a, b in zip(axes, bases)) + prior


def run_vecpin(camp, folder: Path, formats=FORMATS, heights: float | None = GAUGE_SIGMA_MM,
               extra: tuple[str, ...] = ()) -> dict:
    """Write the campaign, fit (default choice; the nests' heights as the plan asks, read with a gauge
    error of ``heights`` mm, None: not given; ``extra``: more fit options) and write tables for every
    format; seconds and the model's label."""
    paths = camp.write(folder)
    truth = camp.truth_record()
    model = folder / "model.json"
    if all((folder / f / "tables.json").exists() for f in formats):      # kept from an earlier run (--work)
        return {"fit_s": float("nan"), "label": model_label(model, truth["axes"])}
    t0 = time.perf_counter()
    fit = None if model.exists() else vecpin_cmd("fit", str(paths["urdf"]), str(paths["csv"]), "--out", str(model),
                                                 "--quiet", *noise_options(truth, stated=True),
                                                 *nest_height_options(camp, heights), *extra)
    if fit is not None and fit.returncode != 0:
        raise RuntimeError("fit: " + (fit.stderr.strip().splitlines() or ["?"])[-1])
    out = {"fit_s": time.perf_counter() - t0, "label": model_label(model, truth["axes"])}
    for fmt in formats:
        opts = ["--controller", fmt] if fmt != "generic" else []
        if fmt != "generic":
            prof = folder / f"profile_{fmt}.json"
            prof.write_text(json.dumps(profile(truth["axes"], fmt)))
            opts += ["--profile", str(prof)]
        res = vecpin_cmd("tables", str(model), "--out", str(folder / fmt), "--quiet", *opts)
        if res.returncode != 0:
            raise RuntimeError(f"tables {fmt}: " + (res.stderr.strip().splitlines() or ["?"])[-1])
    return out


def one_draw(seed: int, kind: str, work: Path, n_commands: int | None = None) -> dict:
    """One generator machine: vecpin's tables and the best sets judged (part, shape) per format;
    ``n_commands``: the campaign's commands (default: the generator's draw, 120..200)."""
    camp = draw_campaign(seed, kind=kind, family=None, n_commands=n_commands)
    folder = work / str(seed)
    t0 = time.perf_counter()
    rec = {"seed": seed, "kind": kind, "axes": [j.name for j in camp.layout.axes]}
    try:
        rec.update(run_vecpin(camp, folder))
    except RuntimeError as exc:
        rec["error"] = str(exc)
        return rec
    truth = Truth(camp)
    q, tool = truth.commands(N_JUDGE, seed + 7919)
    q_user = q / truth.unit
    rec["uncompensated"] = judge(truth, np.zeros_like(q), 0.0, q, tool)
    bests = BestSets(truth, seed + 104729)
    oracle = BestSets(Truth(estimated_campaign(camp)), seed + 104729)
    for fmt in FORMATS:
        corr, gauge = corrections(fmt, folder / fmt, truth.axes, q_user)
        specs = table_specs(folder / fmt)
        got = judge(truth, corr, gauge, q, tool)
        row = {"tables": len(specs), "products": sum(sp[5] is not None for sp in specs), "vecpin": got, "best": {},
               "achievable": {}}
        for frame in ("part", "shape"):
            for name, sets in (("best", bests), ("achievable", oracle)):
                best, bg = sets.solve(specs, frame)
                row[name][frame] = judge(truth, generic_corrections(best, truth.axes, q_user), bg, q, tool)[frame]
        rec[fmt] = row
    rec["commands_asked"] = n_commands
    rec["commands"] = int(len(next(iter(camp.q.values()))))
    rec["no-heights"] = side_run(camp, folder / "no-heights", truth, bests, q, tool, None, oracle=oracle)
    rec["prior"] = side_run(camp, folder / "prior", truth, bests, q, tool, None, PRIOR_OPTIONS, oracle)
    rec["exact-heights"] = side_run(camp, folder / "exact-heights", truth, bests, q, tool, 0.0)
    rec["noise-free"] = noise_free(seed, kind, folder / "noise-free", truth, bests, q, tool, n_commands)
    rec["seconds"] = time.perf_counter() - t0
    return rec


def judged_generic(folder: Path, truth: Truth, bests: BestSets, q, tool, oracle: BestSets | None = None) -> dict:
    """vecpin's generic tables in ``folder`` and the best set for the same tables, judged (part, shape);
    with ``oracle`` also the set the oracle's estimate gives for them (*achievable*)."""
    corr, gauge = corrections("generic", folder / "generic", truth.axes, q / truth.unit)
    specs = table_specs(folder / "generic")
    rec = {"vecpin": judge(truth, corr, gauge, q, tool), "best": {}, "tables": len(specs),
           "products": sum(sp[5] is not None for sp in specs)}
    for frame in ("part", "shape"):
        for name, sets in (("best", bests), ("achievable", oracle)):
            if sets is not None:
                best, bg = sets.solve(specs, frame)
                rec.setdefault(name, {})[frame] = judge(truth, generic_corrections(best, truth.axes, q / truth.unit),
                                                        bg, q, tool)[frame]
    return rec


def side_run(camp, folder: Path, truth: Truth, bests: BestSets, q, tool, heights: float | None,
             extra: tuple[str, ...] = (), oracle: BestSets | None = None) -> dict:
    """The same noisy campaign fitted with the heights read with gauge error ``heights`` mm (0: exact;
    None: without them, as before the plan asked for them; ``extra``: more fit options), tabled
    (generic) and judged the same way (``oracle``: also against the oracle's set for its tables)."""
    try:
        rec = run_vecpin(camp, folder, ("generic",), heights=heights, extra=extra)
    except RuntimeError as exc:
        return {"error": str(exc)}
    return rec | judged_generic(folder, truth, bests, q, tool, oracle)


def noise_free(seed: int, kind: str, folder: Path, truth: Truth, bests: BestSets, q, tool,
               n_commands: int | None = None) -> dict:
    """The same campaign read without noise (the same commands and rows, the truth's points, no
    tracker or axis noise, the nests' heights exact), fitted and tabled (generic) the same way: what
    identification from the noisy readings costs."""
    camp = draw_campaign(seed, kind=kind, family=None, n_commands=n_commands)
    camp.measured = camp.to_tracker(camp.base_points(repeat=False))
    try:
        rec = run_vecpin(camp, folder, ("generic",), heights=0.0)
    except RuntimeError as exc:
        return {"error": str(exc)}
    return rec | judged_generic(folder, truth, bests, q, tool)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", type=int, default=30, help="draws (default 30)")
    ap.add_argument("--seed", type=int, default=None, help="first seed (default: fresh)")
    ap.add_argument("--kinds", nargs="+", default=list(KINDS), choices=KINDS)
    ap.add_argument("--out", default=str(RESULT))
    ap.add_argument("--commands", type=int, default=None,
                    help="commands per campaign (default: the generator's draw, 120..200)")
    ap.add_argument("--json", default=None, help="also write every record here")
    ap.add_argument("--work", default=None,
                    help="keep vecpin's files here and reuse them (default: a temporary folder)")
    ap.add_argument("--rejudge", action="store_true",
                    help="with --work: only the draws whose fits are there (no new fit; tables written where missing)")
    ap.add_argument("--heldout", action="store_true",
                    help="the held-out seeds: committed code only, the summary only, added to docs/results/heldout.md")
    ap.add_argument("--from-json", nargs="+", default=None,
                    help="write the page from records saved by --json (runs split over processes)")
    args = ap.parse_args(argv)
    if args.from_json:
        records = [r for f in args.from_json for r in json.loads(Path(f).read_text())]
        seeds = sorted(r["seed"] for r in records)
        how = f"{len(records)} draws, seeds {seeds[0]}..{seeds[-1]} in {len(args.from_json)} runs, classes in turn"
        Path(args.out).write_text(page(records, how))
        print(f"wrote {args.out}")
        return
    first = args.seed if args.seed is not None else secrets.randbelow(10**8)
    held = Run("generator_tables", args.n) if args.heldout else None   # refused on uncommitted code
    seeds = heldout_seeds("generator_tables", args.n) if held else [first + i for i in range(args.n)]
    records = []
    with tempfile.TemporaryDirectory(prefix="vecpin_gentables_") as tmp:
        tmp = args.work or tmp
        for i in range(args.n):
            seed, kind = seeds[i], args.kinds[i % len(args.kinds)]
            done = [Path(tmp) / str(seed) / "model.json", Path(tmp) / str(seed) / "noise-free" / "model.json"]
            if args.rejudge and not all(p.exists() for p in done):
                continue
            rec = one_draw(seed, kind, Path(tmp), args.commands)
            records.append(rec)
            if held is not None:   # no draw's details
                held.progress(len(records))
            else:
                print(json.dumps(rec), flush=True)
            if args.json:
                Path(args.json).write_text(json.dumps(records, indent=1))
    how = (f"{args.n} draws from seed {first}" if held is None else f"{args.n} held-out draws") + \
        f", classes {', '.join(args.kinds)} in turn"
    if held is not None:
        print(held.write(page(records, how).splitlines(), final=True))
        return
    Path(args.out).write_text(page(records, how))
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
