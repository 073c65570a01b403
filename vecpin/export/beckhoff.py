"""Beckhoff TwinCAT 3 CNC (TF5200) / ISG kernel: axis compensation lists, volumetric files.

Axis compensation lists ``achskw_<AXIS>.lis`` (ASCII, ``key value`` per line, ``#``
comment lines, trailing ``/* ... */`` comments; TF5200 examples infosys 15273973131,
308695435), one per axis, registered in the start-up list (``zahl_kw``,
``achs_kw_log_ax_nr[i]``, ``achs_kw[i]``; P-STUP-00016/17):

* header ``kopf.achs_nr`` (logical axis number, P-COMP-00001) and ``kopf.log_achs_name``;
* leadscrew error compensation ``kw.ssfk.*`` (pitch table of this axis):
  ``interval 0`` (non-equidistant, with ``table[i].setpoint``), ``kw_startpos``,
  ``kw_nr_max`` (< ``max_points``, default 1500, P-COMP-00059), ``unit 1`` (0.1 um,
  rotary 0.0001 deg), ``bilateral 1`` with ``table[i].pos`` = ``.neg``, ``modulo``;
  activated by ``lr_param.ssfk 1`` in the axis list (P-AXIS-00175), only when homed;
* cross compensation ``kw.crosscomp.*`` in the list of the **slave** (compensated)
  axis: ``master_ax_nr`` (input axis), ``last_index``, ``unit 1``,
  ``table[i].setpoint`` / ``.correction`` (max_points default 1001, P-COMP-00060):
  one master per slave list, so at most one cross table per compensated axis;
  activated by ``lr_param.crosscomp 1`` (P-AXIS-00047).

Sign: SSFK "computed compensation value = s_actual - s_setpoint" (programmed 19866.7
um, measured 19856.5 um -> ``pos -102``; TF5200 308695435 / ISG 113439115), so a file
value is the **error** (CERTAIN for the value's definition); cross-compensation values
are documented only as "relative compensation value": vecpin writes them with the same
convention (UNKNOWN: run the sign test).

Volumetric compensation (TF5280, option): ``vol_comp_0.lis`` (logical axis numbers
``x y z a b c``, ``chain``, ``file[j]``, ``file_format[j] ISG_CSV``,
``interpolation GRID``) and one ISG CSV per axis with the model's ISO 230-1 component
errors in mm and rad (:mod:`vecpin.export.iso230`), for a 6-DoF model.
"""
from __future__ import annotations

import re
from pathlib import Path

import numpy as np

from vecpin.compensation.limits import ControllerLimits
from vecpin.compensation.tables import CompensationTable, TableSet
from vecpin.errors import ControllerFileError, InputError
from vecpin.export import iso230
from vecpin.export.boundary import gauge_readme
from vecpin.export.common import ControllerFormat, ExportJob, equidistant, read_lines, to_float, to_int
from vecpin.export.profile import ControllerProfile
from vecpin.kinematics.machine import Machine

STARTUP, VOL_LIST, README = "startup_entries.lis", "vol_comp_0.lis", "README_BECKHOFF.md"
FILE_UNIT = 1e-4   # unit 1: 0.1 um = 1e-4 mm; rotary 0.0001 deg

LIMITS = ControllerLimits(
    "beckhoff", max_cross_points=1000, max_pitch_points=1499, one_cross_table_per_output=True,
    source="TF5200: crosscomp max_points default 1001 (old docs 1000 values), ssfk kw_nr_max < max_points default "
           "1500, one master per slave list")


def list_name(axis: str) -> str:
    return f"achskw_{axis}.lis"


def vc_name(axis: str) -> str:
    return f"vc_{axis}.csv"


def check(machine: Machine, profile: ControllerProfile, limits: ControllerLimits, modulo_axes=()) -> None:
    for a in machine.axes:
        profile.need(a.name, "number", limits.name, "logical axis number (kopf.achs_nr, master_ax_nr)")


def _key(k: str, v, comment: str = "") -> str:
    line = f"{k:<35s} {v}"
    return f"{line:<42s}/* {comment} */" if comment else line


def _units(values_user: np.ndarray) -> np.ndarray:
    return np.rint(np.asarray(values_user, float) / FILE_UNIT).astype(np.int64)


def write(job: ExportJob) -> list[str]:
    """One ``achskw_<AXIS>.lis`` per axis with tables, the start-up list entries, the
    volumetric files (6-DoF model) and ``README_BECKHOFF.md``."""
    m, prof = job.machine, job.profile
    job.limits.check_tables(job.tables)
    names = []
    for a in m.axes:
        pitch = [t for t in job.tables.tables if t.is_pitch and t.input_axis == a.name]
        cross = [t for t in job.tables.tables if not t.is_pitch and t.output_axis == a.name]
        if not pitch and not cross:
            continue
        number = prof.need(a.name, "number", "beckhoff", "logical axis number")
        lines = [f"# vecpin axis compensation list of {a.name}, machine {m.name}: values are errors (actual - "
                 "programmed) in 0.1 um or 0.0001 deg",
                 _key("kopf.achs_nr", number), _key("kopf.log_achs_name", prof.axis(a.name).nc_name or a.name)]
        for t in pitch:
            sp, val = _units(a.to_user(t.positions)), _units(-a.to_user(t.values))
            lines += [_key("kw.ssfk.interval", 0), _key("kw.ssfk.kw_startpos", int(sp[0])),
                      _key("kw.ssfk.kw_nr_max", len(sp)), _key("kw.ssfk.unit", 1, "0: increments 1: 0.1 um"),
                      _key("kw.ssfk.bilateral", 1)]
            if t.modulo:
                lines.append(_key("kw.ssfk.modulo", 1))
            lines += [_key(f"kw.ssfk.table[{i}].setpoint", int(v)) for i, v in enumerate(sp)]
            lines += [_key(f"kw.ssfk.table[{i}].pos", int(v)) for i, v in enumerate(val)]
            lines += [_key(f"kw.ssfk.table[{i}].neg", int(v)) for i, v in enumerate(val)]
        for t in cross:
            ai = m.axis(t.input_axis)
            if t.modulo:
                raise InputError(f"beckhoff: cross table {t.name} is modulo; vecpin knows no modulo key of "
                                 "kw.crosscomp: make the tables without `modulo_axes`")
            master = prof.need(ai.name, "number", "beckhoff", "logical axis number")
            sp, val = _units(ai.to_user(t.positions)), _units(-a.to_user(t.values))
            lines += [_key("kw.crosscomp.last_index", len(sp) - 1, "last valid index"),
                      _key("kw.crosscomp.master_ax_nr", master, f"logical axis number of the master {ai.name}"),
                      _key("kw.crosscomp.unit", 1, "0: increments 1: 0.1 um")]
            for i, (x, v) in enumerate(zip(sp, val)):
                lines += [_key(f"kw.crosscomp.table[{i}].setpoint", int(x)), _key(f"kw.crosscomp.table[{i}].correction",
                                                                                  int(v))]
        name = list_name(a.name)
        job.out.write_text(name, "\n".join(lines) + "\n")
        names.append(name)
    comps = []
    why_not = _no_volumetric(m)
    if job.model is not None and job.model.kind == "6dof" and why_not:
        job.notes.append(f"beckhoff: no volumetric files (TF5280): {why_not}; the axis compensation lists carry the "
                         "tables")
    elif job.model is not None and job.model.kind == "6dof":
        comps = iso230.component_errors(job.model, min(job.points, 1001))
        title = f"machine {m.name}, 6-DoF model order {job.model.order}"
        for c in comps:
            job.out.write_text(vc_name(c.axis), iso230.write_isg(c, m, title))
        job.out.write_text(VOL_LIST, _vol_list(job, comps))
        names += [vc_name(c.axis) for c in comps] + [VOL_LIST]
    elif job.model is not None:
        job.notes.append("beckhoff: no volumetric files: an AP model has no ISO 230-1 component errors "
                         "(use a 6-DoF model for TF5280)")
    st = [f"# vecpin: entries for the start-up list (hochlauf.lis) of {m.name}"]
    st.append(_key("zahl_kw", len([n for n in names if n.startswith("achskw_")])))
    for i, n in enumerate(nm for nm in names if nm.startswith("achskw_")):
        axis = n[len("achskw_"):-len(".lis")]
        st += [_key(f"achs_kw_log_ax_nr[{i}]", prof.axis(axis).number), _key(f"achs_kw[{i}]", n)]
    if comps:
        st += [_key("vol_comp[0].file_name", VOL_LIST),
               _key("vol_comp[0].max_records", sum(len(c.positions) for c in comps))]
    job.out.write_text(STARTUP, "\n".join(st) + "\n")
    job.out.write_text(README, _readme(job, comps))
    return names + [STARTUP, README]


def _no_volumetric(m: Machine) -> str | None:
    """Why vecpin writes no TF5280 configuration for this machine (None: it does)."""
    bad = [a.name for a in m.axes if a.name.lower() not in ("x", "y", "z", "a", "b", "c")]
    if bad:
        return f"TF5280 names axes x y z a b c, and {', '.join(bad)} is none of them"
    if m.has_workpiece:
        return ("the machine has table axes (a workpiece branch), and vecpin writes TF5280's kinematic chain for "
                "head axes only")
    return None


def _vol_list(job: ExportJob, comps) -> str:
    m, prof = job.machine, job.profile
    lines = [f"# vecpin volumetric compensation (TF5280) of {m.name}: ISO 230-1 component errors of the 6-DoF model"]
    for a in m.axes:
        if a.name.lower() not in ("x", "y", "z", "a", "b", "c"):
            raise InputError(f"beckhoff: TF5280 names axes x y z a b c; {a.name} is none of them")
        lines.append(_key(a.name.lower(), prof.axis(a.name).number))
    lines.append(_key("chain", "".join(a.name for a in m.axes)))
    for j, c in enumerate(comps):
        lines += [_key(f"file[{j}]", vc_name(c.axis)), _key(f"file_format[{j}]", "ISG_CSV")]
    lines.append(_key("interpolation", "GRID"))
    return "\n".join(lines) + "\n"


def _readme(job: ExportJob, comps) -> str:
    m = job.machine
    s = [f"# Compensation for {m.name} (Beckhoff TwinCAT CNC / ISG)", "",
         "`achskw_<AXIS>.lis`: axis compensation lists, one per axis: leadscrew tables (`kw.ssfk`, this axis' pitch",
         "table) and at most one cross table whose slave is this axis (`kw.crosscomp`, master = input axis).",
         f"Register them with the entries of `{STARTUP}` in the start-up list and set in each axis list:", ""]
    for a in m.axes:
        p = [t for t in job.tables.tables if t.is_pitch and t.input_axis == a.name]
        c = [t for t in job.tables.tables if not t.is_pitch and t.output_axis == a.name]
        if p or c:
            s.append(f"- {a.name}: " + ", ".join((["`lr_param.ssfk 1`"] if p else []) +
                                                 ([f"`lr_param.crosscomp 1` ({c[0].name})"] if c else [])))
    s += ["", "Values are errors (actual minus programmed) in 0.1 um (rotary 0.0001 deg), positions in the same",
          "units; the SSFK sign follows the TF5200 example (measured - programmed); the cross-compensation sign is",
          "not documented and is written the same way: run the sign test on one cross table.", ""]
    if comps:
        s += [f"Volumetric compensation (TF5280 option): `{VOL_LIST}` and `vc_<AXIS>.csv` (ISG CSV, ISO 230-1",
              "component errors of the 6-DoF model in mm and rad, reference point: origin of each axis' moving frame).",
              "Use either the axis lists or the volumetric compensation for the same errors, not both. `chain` lists",
              "the axes in vecpin's chain order (base to spindle); check that it is the order TF5280 expects.", ""]
    s += ["## Gauge line", "", *gauge_readme("beckhoff", job.tables.gauge_offset_change, job.gauge_effect), ""]
    return "\n".join(s)


# ---------------------------------------------------------------------- reader
_COMMENT = re.compile(r"/\*.*?\*/")


def read_list(path: Path) -> dict[str, tuple[str, int]]:
    """``{key: (value, line)}`` of a ``.lis`` file; a malformed line is a ControllerFileError."""
    out: dict[str, tuple[str, int]] = {}
    for no, raw in enumerate(read_lines(path, "latin-1"), 1):
        text = _COMMENT.sub("", raw).strip()
        if not text or text.startswith("#"):
            continue
        if "/*" in text:
            raise ControllerFileError(path, "a /* comment is not closed on its line", no)
        parts = text.split(None, 1)
        if len(parts) != 2:
            raise ControllerFileError(path, f"'{text}' is not 'key value'", no)
        if parts[0] in out:
            raise ControllerFileError(path, f"{parts[0]} is given twice (first on line {out[parts[0]][1]})", no)
        out[parts[0]] = (parts[1].strip(), no)
    return out


def _indexed(path, d: dict, prefix: str, field: str, count: int) -> np.ndarray:
    vals = []
    for i in range(count):
        k = f"{prefix}.table[{i}].{field}"
        if k not in d:
            raise ControllerFileError(path, f"no {k}", None)
        vals.append(to_float(d[k][0], path, d[k][1], k))
    return np.array(vals)


def read_axis_list(path: Path, machine: Machine, profile: ControllerProfile) -> list[CompensationTable]:
    """The tables of one axis compensation list (corrections, SI)."""
    d = read_list(path)
    known = re.compile(r"^(kopf\.(achs_nr|log_achs_name|log_achs_nr)|kw\.ssfk\.[\w\[\].]+|kw\.crosscomp\.[\w\[\].]+)$")
    for k, (_, no) in d.items():
        if not known.match(k):
            raise ControllerFileError(path, f"key {k} is not one vecpin reads (kopf.*, kw.ssfk.*, kw.crosscomp.*)", no)
    if "kopf.achs_nr" not in d:
        raise ControllerFileError(path, "no kopf.achs_nr", 1)
    number = to_int(d["kopf.achs_nr"][0], path, d["kopf.achs_nr"][1], "kopf.achs_nr")
    axis = profile.axis_by_number(number)
    if axis is None:
        raise ControllerFileError(path, f"logical axis {number} is not in the controller profile", d["kopf.achs_nr"][1])
    a = machine.axis(axis)
    tables = []

    def need(k):
        if k not in d:
            raise ControllerFileError(path, f"no {k}", None)
        return d[k]

    for prefix in ("kw.ssfk", "kw.crosscomp"):
        if not any(k.startswith(prefix + ".") for k in d):
            continue
        unit = need(f"{prefix}.unit")
        if to_int(unit[0], path, unit[1], "unit") != 1:
            raise ControllerFileError(path, f"{prefix}.unit {unit[0]}: vecpin reads unit 1 (0.1 um); unit 0 counts "
                                      "encoder increments", unit[1])
        if prefix == "kw.ssfk":
            n_k = need("kw.ssfk.kw_nr_max")
            n = to_int(n_k[0], path, n_k[1], "kw_nr_max")
            interval = to_float(need("kw.ssfk.interval")[0], path, need("kw.ssfk.interval")[1], "interval")
            if interval == 0:
                sp = _indexed(path, d, prefix, "setpoint", n)
            else:
                s0 = need("kw.ssfk.kw_startpos")
                sp = to_float(s0[0], path, s0[1], "kw_startpos") + interval * np.arange(n)
            pos = _indexed(path, d, prefix, "pos", n)
            bil = d.get("kw.ssfk.bilateral", ("0", 0))
            if to_int(bil[0], path, bil[1], "bilateral") == 1:
                neg = _indexed(path, d, prefix, "neg", n)
                if np.any(pos != neg):
                    raise ControllerFileError(path, "table[].pos and .neg differ: vecpin tables do not depend on the "
                                              "direction", bil[1])
            mod = d.get("kw.ssfk.modulo", ("0", 0))
            modulo = to_int(mod[0], path, mod[1], "modulo") == 1
            start, step = equidistant(path, sp * FILE_UNIT, n_k[1], "setpoints", tol=0.6 * FILE_UNIT)
            tables.append(CompensationTable(a.name, a.name, float(a.to_si(start)), float(a.to_si(step)),
                                            a.to_si(-pos * FILE_UNIT), modulo))
        else:
            li = need("kw.crosscomp.last_index")
            n = to_int(li[0], path, li[1], "last_index") + 1
            mk = need("kw.crosscomp.master_ax_nr")
            master = profile.axis_by_number(to_int(mk[0], path, mk[1], "master_ax_nr"))
            if master is None:
                raise ControllerFileError(path, f"master axis {mk[0]} is not in the controller profile", mk[1])
            ai = machine.axis(master)
            sp = _indexed(path, d, prefix, "setpoint", n)
            corr = _indexed(path, d, prefix, "correction", n)
            start, step = equidistant(path, sp * FILE_UNIT, li[1], "setpoints", tol=0.6 * FILE_UNIT)
            tables.append(CompensationTable(ai.name, a.name, float(ai.to_si(start)), float(ai.to_si(step)),
                                            a.to_si(-corr * FILE_UNIT)))
    return tables


def read(folder: Path, machine: Machine, profile: ControllerProfile) -> TableSet:
    """Every ``achskw_<AXIS>.lis`` in ``folder`` (the volumetric files: :func:`vecpin.export.iso230.read_isg`)."""
    folder = Path(folder)
    tables = []
    for a in machine.axes:
        if (folder / list_name(a.name)).exists():
            tables += read_axis_list(folder / list_name(a.name), machine, profile)
    if not tables:
        raise ControllerFileError(folder, "no achskw_<AXIS>.lis file")
    return TableSet(machine.axis_names, tables, 0.0)


FORMAT = ControllerFormat(
    "beckhoff", "Beckhoff TwinCAT 3 CNC / ISG kernel", LIMITS, write, read, check,
    files="`achskw_<AXIS>.lis` (kw.ssfk pitch, kw.crosscomp cross), `startup_entries.lis`, with a 6-DoF model "
          "`vol_comp_0.lis` + `vc_<AXIS>.csv` (TF5280 ISG CSV), `README_BECKHOFF.md`",
    sign="file value = error (actual - programmed) in 0.1 um / 0.0001 deg: CERTAIN for kw.ssfk (TF5200 example), "
         "assumed for kw.crosscomp; volumetric CSV: ISO 230-1 errors (mm, rad)",
    source="infosys.beckhoff.com TF5200 axis compensation (113382283, 15273973131, 308695435), ISG 113439115, "
           "TF5280 volumetric (296429067, 296426379, 296423819)",
    to_check="sign of kw.crosscomp (sign test), max_points of your CNC version, TF5280 chain order and reference "
             "point of the component errors",
    dialect="din")
