"""From a fitted model to controller files (the ``tables`` command)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from vecpin.compensation.plan import TablePlan, plan_tables
from vecpin.errors import InputError
from vecpin.export.controllers import write_fanuc, write_generic, write_siemens
from vecpin.measurement.campaign import Campaign
from vecpin.models import ErrorModel


def parse_axis_map(items: list[str], machine) -> dict[str, str]:
    """``JOINT=NCNAME`` items -> {joint: NC axis name}; every joint must exist and no two
    joints may share an NC name."""
    out: dict[str, str] = {}
    for it in items:
        if "=" not in it:
            raise InputError(f"--axis-map takes JOINT=NCNAME, not '{it}'")
        a, b = (x.strip() for x in it.split("=", 1))
        machine.axis(a)
        if not b:
            raise InputError(f"--axis-map {it}: the NC axis name is empty")
        out[a] = b
    names = list(out.values())
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        n = sorted(dup)[0]
        joints = [a for a, b in out.items() if b == n]
        raise InputError(f"--axis-map: joints {', '.join(joints)} are all mapped to NC axis {n}; each joint needs "
                         "its own NC axis")
    return out


@dataclass
class TableRun:
    plan: TablePlan
    files: list[Path]
    commands_source: str | None

    def lines(self, model_name: str, controller: str, points: int) -> list[str]:
        plan = self.plan
        m_name = plan.problem.machine.name
        out = [f"compensation tables for {m_name} ({controller}), model {model_name}"]
        grid = (f"resampled to the controller's grid, at most {plan.controller.max_points} points"
                if controller == "fanuc-30i" else f"{points} points each")
        out.append(f"  tables: {' '.join(plan.tables.names())}  ({len(plan.tables.tables)} tables, {grid})")
        out.append(f"  gauge line (T_offset) change: {plan.tables.gauge_offset_change * 1e3:+.4f} mm")
        if plan.selection is not None:
            s = plan.selection
            out.append(f"  selection ({s.method}): {' '.join(s.tables)} in {s.seconds:.2f} s, "
                       f"{s.evaluations} combinations scored")
        where = f"the commands of {self.commands_source}" if self.commands_source else "1000 quasi-random commands"
        tools = ", ".join(f"{t * 1e3:g}" for t in plan.problem.tools)
        out.append(f"  predicted volumetric error (model, {where} x tools {tools} mm):")
        out.append(plan.report.table())
        out += [f"  wrote {f}" for f in self.files]
        return out


def make_tables(model: ErrorModel, out_dir: str | Path, controller: str = "generic", *, max_tables: int | None = None,
                no_circular: bool = False, forbid_output=(), method: str = "exact", points: int = 1024,
                tools_mm=None, modulo_axes=(), commands: Campaign | None = None, axis_map: dict | None = None,
                progress: Callable[[str], None] | None = None) -> TableRun:
    """Tables of ``model`` for ``controller``, written into ``out_dir`` with the generic files."""
    m = model.machine
    for a in forbid_output:
        m.axis(a)
    q = None
    if commands is not None:
        q = commands.q
        if tools_mm is None:
            tools_mm = [float(t * 1e3) for t in commands.tool_lengths()]
    plan = plan_tables(model, controller, max_tables=max_tables, no_circular=no_circular or None,
                       forbid_output=list(forbid_output), points=points, method=method, tools_mm=tools_mm,
                       modulo_axes=list(modulo_axes), commands=None if q is None else np.asarray(q), progress=progress)
    if controller == "siemens-840d":
        files = write_siemens(plan.tables, m, out_dir, axis_map or {}, plan.controller)
    elif controller == "fanuc-30i":
        files = write_fanuc(plan.tables, m, out_dir, plan.controller)
    else:
        files = []
    files += write_generic(plan.tables, m, out_dir)
    return TableRun(plan, files, None if commands is None else commands.source)
