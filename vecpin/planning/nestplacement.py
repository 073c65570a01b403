"""Table nests and tracker stations that see the table across its tilt range.

A floor tracker sees a table axis only through the reflectors in the table nests, and
the nests of a trunnion tilted far from the tracker hide behind the table, the trunnion
or the holder: the table's pose at a command is measured only when three nests (not on a
line) are seen there from one station. Where that happens for no command, the model's
table-axis terms are extrapolated from the rest of the travel, and the tables with them.

:func:`place_nests` chooses where the nests stand and, when one station cannot see the
table over its travel, a second tracker station (as the seed recommends for large
machines, Section 2.6). It poses the machine at quasi-random commands over the travel
(those the tool is seen at and the holder is free), tests the line of sight from each
candidate station to each candidate nest (:meth:`SightLine.check_nests`: the machine's
URDF geometry, the holder included), and picks greedily the nests that give the most
commands three nests seen from one station, then improves the set by swaps. Candidate
nests stand on the table, on circles of 60 % and 100 % of the default nests' reach
(:func:`~vecpin.planning.nests.nest_positions`), at the default heights; candidate
second stations around the workspace, 8 directions x 3 heights at the first station's
distance. A second station is proposed when it covers at least :data:`SECOND_STATION_GAIN`
more of the table's travel. Frames: nests in the workpiece frame, stations in the machine
base frame, metres.

:func:`station_blocks` makes the proposal a plan's rows: after station 0's rows, a block
per further station (template column ``station``) reading, at each of the plan's
first-holder commands where that station sees the tool and at least one nest, the tool
and every nest it sees; the NC programs stop for the tracker to move between the blocks,
the simulator reads each block from its station, and the fit finds every station's pose.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from vecpin.kinematics.machine import Machine
from vecpin.measurement.plantemplate import PlanTemplate
from vecpin.planning.nests import NEST_HEIGHTS, nest_positions, nest_reach
from vecpin.planning.sightline import SightLine, solids_from_urdf
from vecpin.units import MM_PER_M
from vecpin.models.recorded import scrambled_halton   # scipy's qmc.Halton, without scipy.stats

SAMPLES = 120               # commands the sight lines are tested at
ANGLES = 8                  # candidate nest directions on each circle
RADII = (0.6, 1.0)          # candidate circles, shares of the default nests' reach
BINS = 10                   # a table axis' travel judged in tenths
SECOND_STATION_GAIN = 0.10  # a second station is proposed when it covers this much more of the table travel
MIN_SEEN = 3                # nests a command needs, seen from one station, for the table's pose


@dataclass
class Placement:
    """Where the nests stand and from where the tracker reads them: ``nests`` {id: (3,)
    [m], workpiece frame}, ``stations`` [(3,) [m], base frame] (the plan's tracker first;
    a second when proposed), ``covered`` {table axis: (BINS,) share of the sampled
    commands in each tenth of its travel with three nests seen from one station} for
    this placement and ``default_covered`` for the default nests from the first station,
    at the sampled ``commands`` (N,n) [m, rad]."""

    nests: dict
    stations: list
    covered: dict
    default_covered: dict
    commands: np.ndarray
    notes: list = field(default_factory=list)

    @property
    def samples(self) -> int:
        return len(self.commands)

    @staticmethod
    def travel_seen(covered: dict) -> float:
        """The share of the table axes' travel (tenths, all table axes) where the table's
        pose is measured at some sampled command."""
        return float(np.mean([(v > 0).mean() for v in covered.values()])) if covered else 1.0

    @staticmethod
    def commands_seen(covered: dict) -> float:
        """The mean share of sampled commands with the table's pose measured."""
        return float(np.mean([v.mean() for v in covered.values()])) if covered else 1.0

    def lines(self, machine: Machine) -> list[str]:
        """What the placement gives, per table axis (mm, deg)."""
        out = [f"table nests placed for the line of sight: the table's pose (three nests seen from one station) at "
               f"{100 * self.commands_seen(self.covered):.0f} % of {self.samples} sampled commands, in "
               f"{100 * self.travel_seen(self.covered):.0f} % of the table axes' travel (default nests from the first "
               f"station: {100 * self.commands_seen(self.default_covered):.0f} %, "
               f"{100 * self.travel_seen(self.default_covered):.0f} %)"]
        for name, v in self.covered.items():
            a = machine.axis(name)
            edges = a.to_user(a.lower + np.linspace(0, 1, BINS + 1) * a.travel)
            blind = [f"{edges[k]:.0f}..{edges[k + 1]:.0f}" for k in np.flatnonzero(v == 0)]
            out.append(f"  {name}: share of commands seen per tenth of the travel "
                       f"{' '.join(f'{100 * x:.0f}' for x in v)} %" + (
                           f"; not seen at {', '.join(blind)} {a.unit} (the table-axis terms are extrapolated there)"
                           if blind else ""))
        for k, st in enumerate(self.stations[1:], start=2):
            out.append(f"  tracker station {k} at {', '.join(f'{v * MM_PER_M:.0f}' for v in st)} mm (machine base frame): "
                       f"the plan's last block of rows (station {k - 1} in plan.csv; the NC programs stop for the "
                       "tracker to move there) reads the tool and the nests it sees at the first holder's commands")
        return out + [f"  {n}" for n in self.notes]


def _commands(machine: Machine, sl: SightLine, tool: float, seed: int) -> np.ndarray:
    """Quasi-random commands [m, rad] over the travel where the holder of length ``tool``
    [m] is free and the first station sees the tool."""
    q = machine.lower + scrambled_halton(machine.n_axes, 2 * SAMPLES, seed=seed) * (machine.upper - machine.lower)
    ok = (sl.collisions(q, tool) == "") & ~sl.check(q, tool).blocked
    return q[ok][:SAMPLES]


def candidate_nests(machine: Machine) -> np.ndarray:
    """(K,3) [m] candidate nest positions in the workpiece frame (see the module text)."""
    reach = nest_reach(machine)
    out = []
    for r in RADII:
        for k in range(ANGLES):
            a = 2 * np.pi * (k + 0.5 * (r < 1)) / ANGLES
            for h in NEST_HEIGHTS:
                out.append([r * reach * np.cos(a), r * reach * np.sin(a), h])
    return np.round(out, 6) + 0.0  # whole micrometres (no -0 printed)


def candidate_stations(machine: Machine, first: np.ndarray, tool: float) -> np.ndarray:
    """(S,3) [m] second-station candidates: 8 directions about the tool tips' workspace
    centre at the first station's horizontal distance from it, at the first station's
    height and 0.5 m below and above it (base frame)."""
    u = scrambled_halton(machine.n_axes, 128, seed=0)
    tips = machine.tool_tip(machine.lower + u * (machine.upper - machine.lower), tool, frame="base")
    centre = (tips.min(axis=0) + tips.max(axis=0)) / 2
    dist = float(np.hypot(*(first - centre)[:2]))
    out = []
    for k in range(8):
        az = k * np.pi / 4
        for dz in (-0.5, 0.0, 0.5):
            out.append([centre[0] + dist * np.sin(az), centre[1] - dist * np.cos(az), first[2] + dz])
    return np.array(out)


class _Posed(SightLine):
    """A :class:`SightLine` at a fixed set of commands q0 whose solids are posed once:
    the sight lines to every candidate nest from every candidate station are tested at
    the same commands, repeated (q0 tiled)."""

    def __init__(self, machine: Machine, tracker: np.ndarray, q0: np.ndarray, poses: np.ndarray, **sight):
        super().__init__(machine, tracker, **sight)
        self.q0, self.poses = q0, poses

    def solid_poses(self, q: np.ndarray) -> np.ndarray:
        reps, rest = divmod(len(q), len(self.q0))
        if rest or not np.array_equal(q[:len(self.q0)], self.q0):
            return super().solid_poses(q)
        return np.tile(self.poses, (reps, 1, 1, 1))


def _seen(machine: Machine, station: np.ndarray, q: np.ndarray, poses: np.ndarray, nests: np.ndarray, tool: float,
          solids, **sight) -> np.ndarray:
    """(N,K) the nests (K,3) seen from ``station`` at commands q, False where the tool is not."""
    sl = _Posed(machine, station, q, poses, solids=solids, **sight)
    tool_ok = ~sl.check(q, tool).blocked
    N, K = len(q), len(nests)
    out = ~sl.check_nests(np.tile(q, (K, 1)), np.repeat(nests, N, axis=0), tool).blocked
    return out.reshape(K, N).T & tool_ok[:, None]


def nests_seen(machine: Machine, station: np.ndarray, q: np.ndarray, nests: dict, tool: float, **sight) -> np.ndarray:
    """(N,K) which of the ``nests`` {id: (3,) [m], workpiece frame} a tracker at
    ``station`` (3,) [m] (base frame) sees at commands q (N,n) [m, rad] with the holder of
    length ``tool`` [m], False where it does not see the tool (a second station's rows)."""
    solids, _ = solids_from_urdf(machine, sight.pop("geometry", "auto"))
    sl = SightLine(machine, station, solids=solids, **sight)
    return _seen(machine, station, q, sl.solid_poses(q), np.array(list(nests.values())), tool, solids, **sight)


def _covered(seen: list[np.ndarray], chosen: list[int]) -> np.ndarray:
    """(N,) commands with at least :data:`MIN_SEEN` of the chosen nests seen from one station."""
    return np.any([s[:, chosen].sum(axis=1) >= MIN_SEEN for s in seen], axis=0)


def _apart(angle: np.ndarray, n: int) -> bool:
    """Directions [rad] at least 180 deg / n apart (the nests span the table, so that its
    pose is measured with a long lever, not from a cluster)."""
    d = np.abs(angle[:, None] - angle[None, :]) % (2 * np.pi)
    d = np.minimum(d, 2 * np.pi - d) + 4 * np.pi * np.eye(len(angle))
    return bool(d.min() >= np.pi / n - 1e-9)


def _value(seen: list[np.ndarray], chosen: list[int], bins: list[np.ndarray]) -> tuple[int, float]:
    """How well the chosen nests see the table across its travel: (tenths of the table
    axes' travel with some command's pose measured, sum over the tenths of the square root
    of the share of commands measured there: an even spread over the travel counts more
    than many commands where the table is easy to see)."""
    cov = _covered(seen, chosen).astype(float)
    share = np.concatenate([np.bincount(b, weights=cov, minlength=BINS) / np.maximum(np.bincount(b, minlength=BINS), 1)
                            for b in bins])
    return int((share > 0).sum()), float(np.sqrt(share).sum())


def _choose(seen: list[np.ndarray], n: int, angle: np.ndarray, bins: list[np.ndarray]) -> list[int]:
    """n candidate nests in directions :func:`_apart`: greedy on the commands' seen nests
    (each command counts up to :data:`MIN_SEEN`, from its best station), then swaps that
    raise :func:`_value`."""
    chosen: list[int] = []

    def score(c):
        return np.max([np.minimum(s[:, c].sum(axis=1), MIN_SEEN) for s in seen], axis=0).sum() if c else 0

    for _ in range(n):
        free = [k for k in range(seen[0].shape[1]) if _apart(angle[chosen + [k]], n)]
        chosen.append(max(free, key=lambda k: (score(chosen + [k]), -k)))
    best = _value(seen, chosen, bins)
    for _ in range(2):
        for i in range(n):
            for k in range(seen[0].shape[1]):
                trial = chosen[:i] + [k] + chosen[i + 1:]
                if _apart(angle[trial], n) and (value := _value(seen, trial, bins)) > best:
                    best, chosen = value, trial
    return chosen


def _bins(machine: Machine, q: np.ndarray) -> list[np.ndarray]:
    """Each table axis' tenth of its travel of each command."""
    out = []
    for name in machine.table_axes:
        a = machine.axis(name)
        out.append(np.clip(((q[:, a.index] - a.lower) / a.travel * BINS).astype(int), 0, BINS - 1))
    return out


def _per_axis(machine: Machine, q: np.ndarray, covered: np.ndarray) -> dict:
    """{table axis: (BINS,) share of covered commands in each tenth of its travel}."""
    return {name: np.array([covered[b == k].mean() if (b == k).any() else 0.0 for k in range(BINS)])
            for name, b in zip(machine.table_axes, _bins(machine, q))}


def _second_station(machine, tracker, q, poses, cand, angle, seen1, chosen, n, tool, solids, sight):
    """(gain in :func:`_value`, station, nests, its seen matrix) of the best second station."""
    bins = _bins(machine, q)
    base = _value([seen1], chosen, bins)
    best = None
    for st in candidate_stations(machine, tracker, tool):
        if np.linalg.norm(st - tracker) < 0.5:
            continue
        s2 = _seen(machine, st, q, poses, cand, tool, solids, **sight)
        c = _choose([seen1, s2], n, angle, bins)
        v = _value([seen1, s2], c, bins)
        gain = (v[0] - base[0]) / (BINS * len(bins)) + (v[1] - base[1]) / max(base[1], 1e-9)
        if best is None or gain > best[0]:
            best = (gain, st, c, s2)
    return best


def place_nests(machine: Machine, tracker: np.ndarray, n: int, tool: float, second_station: bool = True,
                seed: int = 0, **sight) -> Placement:
    """The placement of ``n`` >= 3 nests, read from ``tracker`` (3,) [m] (and a second
    station when ``second_station`` and it sees the table over more of its travel), for a
    holder of length ``tool`` [m]; ``sight``: :class:`SightLine` options (tool radius,
    target clearance, geometry). The default nests are kept unless others see the table
    better across its travel. See the module text."""
    solids, _ = solids_from_urdf(machine, sight.pop("geometry", "auto"))
    first = SightLine(machine, tracker, solids=solids, **sight)
    q = _commands(machine, first, tool, seed)
    default = np.array(list(nest_positions(machine, n).values()))
    cand = np.vstack([candidate_nests(machine), default])
    angle = np.arctan2(cand[:, 1], cand[:, 0])
    poses = first.solid_poses(q)
    seen1 = _seen(machine, tracker, q, poses, cand, tool, solids, **sight)
    bins, keep = _bins(machine, q), list(range(len(cand) - n, len(cand)))
    chosen = _choose([seen1], n, angle, bins)
    notes, stations, seen = [], [np.asarray(tracker, float)], [seen1]
    if _value(seen, chosen, bins) <= _value(seen, keep, bins):
        chosen = keep
        notes.append("the default nests see the table as well as any other placement tried: kept")
    if second_station and not _covered(seen, chosen).all():
        gain, st, c, s2 = _second_station(machine, tracker, q, poses, cand, angle, seen1, chosen, n, tool, solids, sight)
        if gain >= SECOND_STATION_GAIN:
            stations.append(st)
            seen.append(s2)
            chosen = c
        else:
            notes.append(f"a second station would see the table {100 * gain:.0f} % better only: not proposed")
    nests = {str(k + 1): cand[j] for k, j in enumerate(chosen)}
    return Placement(nests, stations, _per_axis(machine, q, _covered(seen, chosen)),
                     _per_axis(machine, q, _covered([seen1], keep)), q, notes)


def station_blocks(machine: Machine, template: PlanTemplate, placement: Placement, **sight) -> PlanTemplate:
    """``template`` (station 0's rows) followed by one block of rows per further station
    of ``placement``: at each distinct command of the first holder (template order) where
    that station sees the tool and at least one nest, the tool row, then a row for each
    nest it sees there (``sight``: :class:`SightLine` options). Points numbered on;
    ``station`` 0, 1, ... (see the module text)."""
    if len(placement.stations) < 2:
        return template
    t0 = template.take(template.tool_rows)
    first = np.isclose(t0.tool, template.tool[0])
    _, pick = np.unique(np.round(t0.q[first], 9), axis=0, return_index=True)
    t0 = t0.take(np.flatnonzero(first)[np.sort(pick)])  # each command once, in the plan's order
    nests = placement.nests
    ids, pos = np.array(list(nests), dtype=object), np.array(list(nests.values()))
    blocks, point = [template], int(template.point.max())
    for k, station in enumerate(placement.stations[1:], start=1):
        seen = nests_seen(machine, station, t0.q, nests, float(t0.tool[0]), **dict(sight))
        keep = np.flatnonzero(seen.any(axis=1))
        count = 1 + seen[keep].sum(axis=1)
        src = np.repeat(keep, count)
        is_nest = np.ones(len(src), bool)
        is_nest[np.r_[0, np.cumsum(count)[:-1]]] = False
        which = np.nonzero(seen[keep])[1]
        b = t0.take(src)
        b.point = point + np.arange(1, len(src) + 1)
        b.instrument = np.where(is_nest, "nest", "tracker").astype(object)
        b.target = np.full(len(src), "", dtype=object)
        b.target[is_nest] = ids[which]
        b.nest = np.full((len(src), 3), np.nan)
        b.nest[is_nest] = pos[which]
        b.station = np.full(len(src), k)
        blocks.append(b)
        point += len(src)
    def cat(f):
        return np.concatenate([getattr(b, f) for b in blocks])
    return PlanTemplate(cat("point"), cat("q"), cat("tool"), None if template.approach is None else cat("approach"),
                        template.source, cat("instrument"), cat("target"), cat("nest"),
                        np.concatenate([b.stations for b in blocks]))


__all__ = ["Placement", "place_nests", "station_blocks", "nests_seen", "candidate_nests", "candidate_stations", "SECOND_STATION_GAIN"]
