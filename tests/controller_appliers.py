"""Controllers simulated from their documentation: each reads vecpin's files with its own
small parser and applies the values by the vendor's documented rule (sources in each
function). Nothing here uses vecpin's readers."""
import csv
import re
from pathlib import Path

import numpy as np


def siemens_eec(folder: Path, axis: str, x_mm: np.ndarray) -> np.ndarray:
    """K3 p.238: 'A positive compensation value causes the machine axis to move in the negative direction.'"""
    text = (folder / "AX_EEC.INI").read_text()
    vals = {int(n): float(v) for n, v in re.findall(rf"\$AA_ENC_COMP\[0,(\d+),{axis}\]=(\S+)", text)}
    step = float(re.search(rf"\$AA_ENC_COMP_STEP\[0,{axis}\]=(\S+)", text).group(1))
    lo = float(re.search(rf"\$AA_ENC_COMP_MIN\[0,{axis}\]=(\S+)", text).group(1))
    v = np.array([vals[n] for n in range(len(vals))])
    return -np.interp(x_mm, lo + step * np.arange(len(v)), v)


def siemens_cec(folder: Path, inp: str, out: str, x_mm: np.ndarray) -> np.ndarray:
    """K3 sag section (840D sl FM 03/2009 p.372): a positive value moves the compensation axis negative."""
    text = (folder / "NC_CEC.INI").read_text()
    t = next(k for k, i in re.findall(r"\$AN_CEC_INPUT_AXIS\[(\d+)\]=\((\w+)\)", text)
             if i == inp and re.search(rf"\$AN_CEC_OUTPUT_AXIS\[{k}\]=\({out}\)", text))
    vals = {int(n): float(v) for n, v in re.findall(rf"\$AN_CEC\[{t},(\d+)\]=(\S+)", text)}
    step = float(re.search(rf"\$AN_CEC_STEP\[{t}\]=(\S+)", text).group(1))
    lo = float(re.search(rf"\$AN_CEC_MIN\[{t}\]=(\S+)", text).group(1))
    v = np.array([vals[n] for n in range(len(vals))])
    return -np.interp(x_mm, lo + step * np.arange(len(v)), v)


def fanuc_pitch(folder: Path, number: int, x_mm: np.ndarray, ref_mm=0.0, unit=0.001) -> np.ndarray:
    """B-63980EN p.100: point n at (n - 3620) x 3624 from the reference; its value is the
    compensation over the section ending at n, x 3623 detection units; zero at the reference.

    Rotary-axis type, 3625 (travel per rotation of a rotary axis in pitch error
    compensation, A-77810E table (a)) not 0: B-63980EN p.100 example 2 - the most negative
    point 3621 is the reference point 3620, the most positive 3622 = 3620 + 3625 / 3624, the
    points 3620 + 1 .. 3622 hold the sections of one rotation from the reference and the
    reference point repeats the last point's value (the section ending at the reference is
    the last one of the turn before). The table covers one rotation and repeats every 3625;
    "if the sum of the compensation value from 61 to 68 is not zero, the pitch error per
    rotation accumulates, resulting in a positional shift": so does it here."""
    para = (folder / "CNC-PARA.TXT").read_text()
    p = {int(n): re.search(rf"A{number}P(-?[\d.]+)", body).group(1)
         for n, body in re.findall(r"N0(\d{4})Q1(\S+)", para) if 3620 <= int(n) <= 3625}
    ref, first, last, mag, interval = int(p[3620]), int(p[3621]), int(p[3622]), int(p[3623]), float(p[3624])
    turn = float(p.get(3625, "0"))
    data = {int(n): int(v) for n, v in re.findall(r"N1(\d{4})Q0P(-?\d+)", (folder / "PITCH.TXT").read_text())}
    if turn != 0.0:
        assert first == ref and last == ref + round(turn / interval), (first, ref, last, turn, interval)  # p.100
        assert data[ref] == data[last], (data[ref], data[last])      # "set the same compensation value as for 68"
        absolute = np.cumsum([0] + [data[k] for k in range(ref + 1, last + 1)]) * mag * unit
        u = np.asarray(x_mm, float) - ref_mm
        turns = np.floor(u / turn)
        return turns * absolute[-1] + np.interp(u - turns * turn, interval * np.arange(last - ref + 1), absolute)
    points = np.arange(first - 1, last + 1)
    absolute = np.array([sum(data[k] for k in range(ref + 1, n + 1)) - sum(data[k] for k in range(n + 1, ref + 1))
                         for n in points]) * mag * unit
    return np.interp(x_mm, ref_mm + (points - ref) * interval, absolute)


def linuxcnc_type0(folder: Path, axis: str, x_mm: np.ndarray) -> np.ndarray:
    """usrmotintf.cc: trim = nominal - actual (type 0); control.c: motor_pos_cmd = pos_cmd + trim."""
    rows = []
    for ln in (folder / f"comp_{axis}.txt").read_text().splitlines():
        try:
            rows.append([float(v) for v in ln.split()[:3]])
        except ValueError:
            break
    a = np.array(rows)
    return np.interp(x_mm, a[:, 0], a[:, 0] - a[:, 1])


def beckhoff_ssfk(folder: Path, axis: str, x_mm: np.ndarray) -> np.ndarray:
    """TF5200: compensation value = actual - programmed (0.1 um); the NC takes it off the setpoint."""
    kv = dict(ln.split(None, 1) for ln in (folder / f"achskw_{axis}.lis").read_text().splitlines()
              if ln.strip() and not ln.startswith("#"))
    n = int(kv["kw.ssfk.kw_nr_max"])
    sp = np.array([int(kv[f"kw.ssfk.table[{i}].setpoint"]) for i in range(n)]) * 1e-4
    pos = np.array([int(kv[f"kw.ssfk.table[{i}].pos"]) for i in range(n)]) * 1e-4
    return -np.interp(x_mm, sp, pos)


def siemens_refp(folder: Path, axis: str) -> float | None:
    """MD34100 $MA_REFP_SET_POS[0,AXIS] of MD_REFP.INI (None: not set there): the machine
    coordinate the control gives the reference point (K3/H1 referencing)."""
    path = folder / "MD_REFP.INI"
    if not path.exists():
        return None
    m = re.search(rf"^\$MA_REFP_SET_POS\[0,{axis}\]=(\S+)", path.read_text(), re.M)
    return None if m is None else float(m.group(1))


def fanuc_param(folder: Path, number: int, axis_number: int) -> float | None:
    """Parameter ``number`` of controlled axis ``axis_number`` in CNC-PARA.TXT (None: absent)."""
    for n, body in re.findall(r"N(\d{5})Q1(\S+)", (folder / "CNC-PARA.TXT").read_text()):
        if int(n) == number:
            m = re.search(rf"A{axis_number}P(-?[\d.]+)", body)
            return None if m is None else float(m.group(1))
    return None


def reference_shift(old_reference: float, new_reference: float | None) -> float:
    """What a changed reference point value does to every command of the axis: the
    control calls the reference point ``new``; commanding q moves the axis q - new from it,
    so it goes ``old - new`` further than before."""
    return 0.0 if new_reference is None else old_reference - new_reference


def siemens_corrections(folder: Path, axes: list[str], ref: dict, q_user: np.ndarray,
                        with_refp: bool = True) -> np.ndarray:
    """Per axis [mm or deg] at commands ``q_user`` (columns: ``axes``, NC names ``<axis>1``
    and ``AX<k>``): its EEC, the CEC tables whose output it is, and the shift of its
    reference point value MD34100 from ``ref`` (the old values), as a SINUMERIK applies them."""
    out = np.zeros_like(q_user)
    for k, a in enumerate(axes):
        out[:, k] += siemens_eec(folder, f"{a}1", q_user[:, k])
        if with_refp:
            out[:, k] += reference_shift(ref[a], siemens_refp(folder, f"{a}1"))
    tables = siemens_cec_tables(folder)
    column = {f"AX{j + 1}": j for j in range(len(axes))}
    values = {t: _cec_value(d, q_user[:, column[d["input"]]]) for t, d in tables.items()}
    for t, d in tables.items():
        out[:, column[d["output"]]] -= values[t]             # a positive value moves the axis negative
        if d["mult"]:   # K3 p.249: the product of table t and table number mult (index mult - 1), added as a value
            other = tables[d["mult"] - 1]
            assert other["output"] == d["output"], "table 2 of the same compensation axis (K3 p.249)"
            out[:, column[d["output"]]] -= values[t] * values[d["mult"] - 1]
    return out


def siemens_cec_tables(folder: Path) -> dict[int, dict]:
    """Every table of NC_CEC.INI by index: input and output axis names, values, STEP, MIN, modulo and
    MULT_BY_TABLE (K3 03/2013 p.248-249)."""
    text = (folder / "NC_CEC.INI").read_text()
    out = {}
    for t, inp in re.findall(r"^\$AN_CEC_INPUT_AXIS\[(\d+)\]=\((\w+)\)", text, re.M):
        field = lambda name: re.search(rf"^\$AN_CEC_{name}\[{t}\]=(\S+)", text, re.M).group(1)  # noqa: E731
        vals = {int(n): float(v) for n, v in re.findall(rf"^\$AN_CEC\[{t},(\d+)\]=(\S+)", text, re.M)}
        out[int(t)] = {"input": inp, "output": field("OUTPUT_AXIS").strip("()"),
                       "values": np.array([vals[n] for n in range(len(vals))]), "step": float(field("STEP")),
                       "min": float(field("MIN")), "modulo": int(field("IS_MODULO")) == 1,
                       "mult": int(field("MULT_BY_TABLE"))}
    return out


def _cec_value(d: dict, x: np.ndarray) -> np.ndarray:
    """A table's value at input positions x: linear between points, end values beyond MIN/MAX (K3 p.248),
    repeated cyclically from MIN with the modulo function (p.249)."""
    v = d["values"]
    if d["modulo"]:
        x = d["min"] + np.mod(x - d["min"], d["step"] * (len(v) - 1))
    return np.interp(x, d["min"] + d["step"] * np.arange(len(v)), v)


def fanuc_corrections(folder: Path, axes: list[str], ref: dict, q_user: np.ndarray,
                      with_1240: bool = True) -> np.ndarray:
    """Per axis [mm or deg] (controlled-axis numbers 1, 2, ... in the order of ``axes``):
    pitch data anchored at the new reference position 1240, the shift of 1240 from ``ref``,
    and the straightness values entered as STRAIGHTNESS.CSV lists them (absolute, linear
    between points). ``with_1240`` False: parameter 1240 not loaded (the reference stays ``ref``).

    Straightness takes its points from the moving axis' pitch compensation point numbers
    (B-63522EN p.222); on a moving axis of rotary-axis type (3625 not 0) those points cover
    one rotation and repeat (B-63980EN p.100), so the straightness values are looked up at
    the moving axis' position within the rotation, from its first row (INFERRED from the two
    pages: no sentence on straightness over a rotary-type axis was found)."""
    out = np.zeros_like(q_user)
    for k, a in enumerate(axes):
        new = fanuc_param(folder, 1240, k + 1) if with_1240 else None
        if fanuc_param(folder, 3620, k + 1) is not None:
            out[:, k] += fanuc_pitch(folder, k + 1, q_user[:, k], ref_mm=new if new is not None else ref[a])
        out[:, k] += reference_shift(ref[a], new)
    with open(folder / "STRAIGHTNESS.CSV", newline="") as fh:
        rows = [r for r in csv.DictReader(ln for ln in fh if not ln.startswith("#"))]
    for name in sorted({r["table"] for r in rows}):
        rs = [r for r in rows if r["table"] == name]
        i, o = axes.index(rs[0]["moving_axis"]), axes.index(rs[0]["compensation_axis"])
        pos, val = np.array([float(r["position"]) for r in rs]), np.array([float(r["correction"]) for r in rs])
        at = q_user[:, i]
        turn = fanuc_param(folder, 3625, i + 1) or 0.0
        if turn != 0.0:
            at = pos[0] + np.mod(at - pos[0], turn)
        out[:, o] += np.interp(at, pos, val)
    return out


def _tnc_table(path: Path) -> list[dict]:
    """Rows of a TNC table as a fixed-width reader takes them (pyLSV2 table_reader): line 1
    ``BEGIN ...``, line 2 the column names, each column from its name's first character to
    the next name's; rows until ``[END]``."""
    lines = path.read_text(encoding="latin-1").splitlines()
    assert lines[0].startswith("BEGIN "), path
    starts = [m.start() for m in re.finditer(r"\S+", lines[1])]
    names = lines[1].split()
    rows = []
    for ln in lines[2:]:
        if ln.startswith("[END]"):
            return rows
        if ln.strip():
            rows.append({n: ln[a:b].strip() for n, a, b in zip(names, starts, starts[1:] + [None])})
    raise AssertionError(f"{path}: no [END]")


def heidenhain_corrections(folder: Path, nc_names: list[str], q_user: np.ndarray, rotary=()) -> np.ndarray:
    """Per axis [mm or deg] (columns: ``nc_names``): the active line of CONFIG.CMA names a
    .COM per input axis column (MANUALplus 620 TM p.718); in each .COM, AXISPOS is the
    input position and each axis column that axis' error there (p.716; vecpin writes
    errors, actual - nominal: the correction is its negative), linear between entries. A
    ``rotary`` input whose entries lie in 0..360 is looked up at its position modulo 360
    ("with an axis of rotation, the system only recognizes corrections of entries from 0
    to 360", TNC 407 TM p.156)."""
    out = np.zeros_like(q_user)
    active = [r for r in _tnc_table(folder / "CONFIG.CMA") if r.get("ACTIVE") == "*"]
    for row in active:
        for col, name in row.items():
            if col in ("NR", "ACTIVE") or not name:
                continue
            rows = _tnc_table(folder / name)
            x = np.array([float(r["AXISPOS"]) for r in rows])
            at = q_user[:, nc_names.index(col)]
            if col in rotary and x.min() >= 0.0 and x.max() <= 360.0:
                at = np.mod(at, 360.0)
            for out_nc in set(rows[0]) - {"NR", "AXISPOS"}:
                v = np.array([float(r[out_nc]) for r in rows])
                out[:, nc_names.index(out_nc)] -= np.interp(at, x, v)
    return out


def linuxcnc_corrections(folder: Path, axes: list[str], q_user: np.ndarray) -> np.ndarray:
    """Per joint [mm or deg] (joints numbered in the order of ``axes``): the COMP_FILE trims
    (type 0, :func:`linuxcnc_type0`) plus the HAL component's cross tables, read from the C
    arrays of vecpin_vec.comp (``{out, in, n, start, step, values}``; linear, end values held)."""
    out = np.zeros_like(q_user)
    for k, a in enumerate(axes):
        if (folder / f"comp_{a}.txt").exists():
            out[:, k] += linuxcnc_type0(folder, a, q_user[:, k])
    comp = folder / "vecpin_vec.comp"
    if not comp.exists():
        return out
    text = comp.read_text()
    arrays = {name: np.array([float(v) for v in body.split(",")])
              for name, body in re.findall(r"static const double (\w+)\[\d+\] = \{([^}]*)\};", text)}
    for o, i, n, start, step, name in re.findall(
            r"\{(\d+), (\d+), (\d+), (\S+), (\S+), (vecpin_v\d+)\}", text):
        x = float(start) + float(step) * np.arange(int(n))
        out[:, int(o)] += np.interp(q_user[:, int(i)], x, arrays[name][:int(n)])
    # product terms (the component's header): entry k of vecpin_ptables (a table over a rotary joint, the output
    # joint's units) times entry k of vecpin_pfactors (a plain number over a linear joint), added to the output joint
    value = {}
    for o, i, n, start, step, name in re.findall(
            r"\{(\d+), (\d+), (\d+), (\S+), (\S+), (vecpin_p[tf]\d+)\}", text):
        x = float(start) + float(step) * np.arange(int(n))
        value[name] = (int(o), np.interp(q_user[:, int(i)], x, arrays[name][:int(n)]))
    for name, (o, v) in value.items():
        if name.startswith("vecpin_pt"):
            factor_out, factor = value["vecpin_pf" + name[len("vecpin_pt"):]]
            assert factor_out == o, f"{name}: its factor has another output joint"
            out[:, o] += v * factor
    return out
