"""Tracker exports into campaigns: foreign formats read back to the simulated values, units
told from the spread of the points (an all-inch file cannot pass as mm), joins by name
and by order, and every problem named by file, row and column."""
import csv
from datetime import datetime, timedelta

import numpy as np
import pytest

from vecpin.cli import main
from vecpin.errors import CampaignFileError, InputError
from vecpin.measurement.campaign import read_campaign, write_campaign
from vecpin.measurement.importer import import_export, parse_column_map
from vecpin.measurement.importwrite import write_imported
from vecpin.measurement.plantemplate import point_name
from vecpin.planning.plan import PlanSettings, make_plan
from vecpin.simulation.simulate import Design, simulate

T0 = datetime(2024, 3, 5, 23, 55, 0)  # the campaign runs past midnight


@pytest.fixture(scope="module")
def day(flow, tmp_path_factory):
    d = tmp_path_factory.mktemp("imp")
    plan = make_plan(flow, PlanSettings(n_commands=20, order=1, candidates=200, sight=False, validation_points=20))
    (d / "plan.csv").write_text(plan.template.to_csv(flow))
    sim = simulate(flow, 4, plan=(plan.template.q, plan.template.tool))
    return d, plan.template, sim.campaign


DEFAULT_HEADER = [("Name", "name"), ("Air Temp (F)", "temp"), ("Timestamp", "time"), ("Meas X", "x"), ("Meas Y", "y"),
                  ("Meas Z", "z"), ("Nom X", "nom"), ("Sigma", "sigma")]


def export(path, campaign, template, *, sep=";", dec=",", unit_mm=25.4, header=None, names=True, order=None,
           bom=True, comment=True, rows=None, time_fmt="%d.%m.%Y %H:%M:%S", temp="F"):
    """Write a tracker-software-like export of a campaign: ``header`` is a list of
    (column name, what it holds: name/temp/time/x/y/z/nom/sigma)."""
    header = list(header or DEFAULT_HEADER)
    if temp == "C":
        header = [("Air Temp (C)" if k == "temp" and h == "Air Temp (F)" else h, k) for h, k in header]
    if not names:
        header = [h for h in header if h[1] != "name"]
    xyz = campaign.xyz * 1000.0 / unit_mm
    T = campaign.temperature * 9 / 5 + 32 if temp == "F" else campaign.temperature
    lines = (["# TrackerSoft export, job 42"] if comment else []) + [sep.join(h for h, _ in header)]
    idx = list(range(len(campaign)) if rows is None else rows)
    for i in (idx if order is None else order):
        t = (T0 + timedelta(seconds=float(campaign.time[i]))).strftime(time_fmt) if time_fmt else f"{campaign.time[i]:.3f}"
        vals = {"name": point_name(template.point[i]), "temp": f"{T[i]:.3f}", "time": t, "x": f"{xyz[i, 0]:.6f}",
                "y": f"{xyz[i, 1]:.6f}", "z": f"{xyz[i, 2]:.6f}", "nom": "0.0", "sigma": "0.0004"}
        cells = [vals[k] for _, k in header]
        if dec == ",":
            cells = [c.replace(".", ",") if c[:1] in "-0123456789" and ":" not in c else c for c in cells]
        lines.append(sep.join(cells))
    path.write_text(("\ufeff" if bom else "") + "\r\n".join(lines) + "\r\n", encoding="utf-8")
    return path


def hdr(*names):
    """A header with these column names for name, temp, time, x, y, z (in that order)."""
    return list(zip(names, ["name", "temp", "time", "x", "y", "z"]))


def test_foreign_export_reads_back_to_the_measured_values(flow, day):
    d, t, c = day
    p = export(d / "e1.csv", c, t)
    res = import_export(p, flow, d / "plan.csv")
    got = res.campaign
    assert (res.delimiter, res.decimal, res.units) == (";", ",", "in")
    assert "spread" in res.units_reason and res.encoding == "UTF-8 with BOM"
    assert res.columns == {"x": "Meas X", "y": "Meas Y", "z": "Meas Z", "point": "Name", "time": "Timestamp",
                           "temperature": "Air Temp (F)"}
    np.testing.assert_allclose(got.xyz, c.xyz, atol=1e-6 * 25.4e-3)      # 6 decimals of an inch
    np.testing.assert_allclose(got.q, c.q)
    np.testing.assert_allclose(got.tool, c.tool)
    np.testing.assert_allclose(got.time, c.time - c.time[0], atol=1.0)     # whole seconds
    np.testing.assert_allclose(got.temperature, c.temperature, atol=1e-3)  # °F -> °C
    np.testing.assert_array_equal(got.extra["point"], t.point)
    out = write_imported(res, flow, d / "c1.csv")
    back = read_campaign(out, flow)
    np.testing.assert_allclose(back.xyz, got.xyz, atol=1e-9)


def test_all_inch_file_cannot_pass_as_mm(flow, day):
    d, t, c = day
    p = export(d / "e2.csv", c, t)
    with pytest.raises(CampaignFileError, match="which means in: give `units` in") as e:
        import_export(p, flow, d / "plan.csv", units="mm")
    assert e.value.column == "Meas X" and str(p) in str(e.value)
    # a millimetre file said to be in inches is caught the same way
    pmm = export(d / "e3.csv", c, t, unit_mm=1.0)
    assert import_export(pmm, flow, d / "plan.csv").units == "mm"
    with pytest.raises(CampaignFileError, match="means mm"):
        import_export(pmm, flow, d / "plan.csv", units="in")
    pm = export(d / "e4.csv", c, t, unit_mm=1000.0, dec=".", sep=",")
    assert import_export(pm, flow, d / "plan.csv").units == "m"


def test_header_units_are_read_and_checked(flow, day):
    d, t, c = day
    p = export(d / "e5.csv", c, t, header=hdr("Name", "Air Temp (F)", "Timestamp", "X [in]", "Y [in]", "Z [in]"),
               sep="\t", dec=".")
    res = import_export(p, flow, d / "plan.csv")
    assert res.units == "in" and res.units_reason.startswith("from the column headers") and res.delimiter == "\t"
    bad = export(d / "e6.csv", c, t, header=hdr("Name", "Air Temp (F)", "Timestamp", "X [mm]", "Y [mm]", "Z [mm]"))
    with pytest.raises(CampaignFileError, match=r"said to be in mm \(from the column headers\)"):
        import_export(bad, flow, d / "plan.csv")


def test_join_by_order_and_its_checks(flow, day):
    d, t, c = day
    p = export(d / "e7.csv", c, t, names=False)
    res = import_export(p, flow, d / "plan.csv")
    assert res.joined_by.startswith("by order")
    np.testing.assert_allclose(res.campaign.xyz, c.xyz, atol=1e-7)
    short = export(d / "e8.csv", c, t, names=False, rows=range(len(c) - 1))
    with pytest.raises(CampaignFileError, match="counts must agree"):
        import_export(short, flow, d / "plan.csv")
    rng = np.random.default_rng(0)
    shuffled = export(d / "e9.csv", c, t, names=False, time_fmt=None, order=rng.permutation(len(c)))
    with pytest.raises(CampaignFileError, match="rows out of order, the wrong plan"):
        import_export(shuffled, flow, d / "plan.csv")


def test_join_by_name_reports_missing_and_rejects_unknown(flow, day):
    d, t, c = day
    p = export(d / "e10.csv", c, t, rows=[i for i in range(len(c)) if i not in (3, 4)])
    res = import_export(p, flow, d / "plan.csv")
    assert res.unmeasured == [4, 5] and len(res.campaign) == len(c) - 2
    text = p.read_text(encoding="utf-8").replace("P0007;", "Base;")
    (d / "e11.csv").write_text(text, encoding="utf-8")
    with pytest.raises(CampaignFileError, match="'Base' is no plan point name") as e:
        import_export(d / "e11.csv", flow, d / "plan.csv")
    assert e.value.column == "Name" and e.value.row == 7  # comment, header, P0001-P0003, P0006, P0007
    text = p.read_text(encoding="utf-8").replace("P0007;", "P0999;")
    (d / "e12.csv").write_text(text, encoding="utf-8")
    with pytest.raises(CampaignFileError, match="not in the plan"):
        import_export(d / "e12.csv", flow, d / "plan.csv")
    res = import_export(d / "e12.csv", flow, d / "plan.csv", ignore_unmatched=True)
    assert res.unmatched == ["P0999"]
    text = p.read_text(encoding="utf-8").replace("P0008;", "P0007;")
    (d / "e13.csv").write_text(text, encoding="utf-8")
    with pytest.raises(CampaignFileError, match="measured twice"):
        import_export(d / "e13.csv", flow, d / "plan.csv")


def test_names_join_whole_a_reference_point_never_joins_a_plan_point(flow, day):
    """A tracker reference point named TR_REF1 (here measured where point 1 is not) is no
    plan point: refused by name, skipped with --ignore-unmatched, and point 1 is joined to
    the row named P0001 or, without one, reported unmeasured; Pt7, Point 7 and 7 name
    point 7 (whole names)."""
    d, t, c = day
    p = export(d / "e40.csv", c, t)
    lines = p.read_text(encoding="utf-8").splitlines()
    ref = lines[2].split(";")                       # the P0001 row, as the reference point
    ref[0] = "TR_REF1"
    ref[3] = f"{float(ref[3].replace(',', '.')) + 100 / 25.4:.6f}".replace(".", ",")  # 100 mm from P0001
    with_ref = lines[:2] + [";".join(ref)] + lines[2:]
    (d / "e41.csv").write_text("\r\n".join(with_ref) + "\r\n", encoding="utf-8")
    with pytest.raises(CampaignFileError, match="'TR_REF1' is no plan point name") as e:
        import_export(d / "e41.csv", flow, d / "plan.csv")
    assert e.value.row == 3 and e.value.column == "Name"
    res = import_export(d / "e41.csv", flow, d / "plan.csv", ignore_unmatched=True)
    assert res.unmatched == ["TR_REF1"] and res.unmeasured == []
    np.testing.assert_allclose(res.campaign.xyz, c.xyz, atol=1e-7)   # point 1 from its own row
    (d / "e42.csv").write_text("\r\n".join(lines[:2] + [";".join(ref)] + lines[3:]) + "\r\n", encoding="utf-8")
    res = import_export(d / "e42.csv", flow, d / "plan.csv", ignore_unmatched=True)
    assert res.unmatched == ["TR_REF1"] and res.unmeasured == [1] and len(res.campaign) == len(c) - 1
    renamed = "\r\n".join(lines).replace("P0007;", "Pt7;").replace("P0008;", "Point 8;").replace("P0009;", "9;")
    (d / "e43.csv").write_text(renamed + "\r\n", encoding="utf-8")
    res = import_export(d / "e43.csv", flow, d / "plan.csv")
    assert res.unmeasured == [] and res.unmatched == []
    np.testing.assert_allclose(res.campaign.xyz, c.xyz, atol=1e-7)
    (d / "e44.csv").write_text("\r\n".join(lines).replace("P0007;", "P0007_2;") + "\r\n", encoding="utf-8")
    with pytest.raises(CampaignFileError, match="'P0007_2' is no plan point name"):
        import_export(d / "e44.csv", flow, d / "plan.csv")


def test_numbers_and_columns_problems_name_row_and_column(flow, day):
    d, t, c = day
    p = export(d / "e14.csv", c, t)
    lines = p.read_text(encoding="utf-8").splitlines()
    cells = lines[5].split(";")
    cells[3] = "12,5x"
    lines[5] = ";".join(cells)
    (d / "e15.csv").write_text("\r\n".join(lines), encoding="utf-8")
    with pytest.raises(CampaignFileError, match="'12,5x' is not a number") as e:
        import_export(d / "e15.csv", flow, d / "plan.csv")
    assert e.value.row == 6 and e.value.column == "Meas X"
    cells[3] = "1.234,5"
    lines[5] = ";".join(cells)
    (d / "e16.csv").write_text("\r\n".join(lines), encoding="utf-8")
    with pytest.raises(CampaignFileError, match="thousands separators") as e:
        import_export(d / "e16.csv", flow, d / "plan.csv")
    assert e.value.row == 6
    lines[5] = lines[5] + ";extra;cells"
    (d / "e17.csv").write_text("\r\n".join(lines), encoding="utf-8")
    with pytest.raises(CampaignFileError, match="cells where the header") as e:
        import_export(d / "e17.csv", flow, d / "plan.csv")
    assert e.value.row == 6
    with pytest.raises(CampaignFileError, match="`columns` names x='Mess X' but no header line has that column") as e:
        import_export(p, flow, d / "plan.csv", columns="x=Mess X,y=Meas Y,z=Meas Z")
    amb = export(d / "e18.csv", c, t, header=hdr("Name", "Air Temp (F)", "Timestamp", "Meas X", "Meas Y", "Meas Z")
                 + [("Actual X", "x")])
    with pytest.raises(CampaignFileError, match="several columns could be the measured x: Meas X, Actual X"):
        import_export(amb, flow, d / "plan.csv")
    res = import_export(amb, flow, d / "plan.csv", columns="x=Meas X")
    assert res.columns["x"] == "Meas X"
    with pytest.raises(InputError, match="not a field"):
        parse_column_map("q=Meas X", flow)


def test_time_and_temperature_forms(flow, day):
    d, t, c = day
    iso = export(d / "e19.csv", c, t, time_fmt="%Y-%m-%dT%H:%M:%S", temp="C")
    res = import_export(iso, flow, d / "plan.csv")
    np.testing.assert_allclose(res.campaign.time, c.time - c.time[0], atol=1.0)
    np.testing.assert_allclose(res.campaign.temperature, c.temperature, atol=1e-3)
    secs = export(d / "e20.csv", c, t, time_fmt=None, temp="C")
    np.testing.assert_allclose(import_export(secs, flow, d / "plan.csv").campaign.time, c.time - c.time[0], atol=1e-3)
    # 05.03 vs 03.05: read as day/month and month/day these times differ: ambiguous
    amb = export(d / "e21.csv", c, t, time_fmt="%m/%d/%Y %H:%M:%S", temp="C")
    with pytest.raises(CampaignFileError, match="give `time_format`"):
        import_export(amb, flow, d / "plan.csv")
    res = import_export(amb, flow, d / "plan.csv", time_format="%m/%d/%Y %H:%M:%S")
    np.testing.assert_allclose(res.campaign.time, c.time - c.time[0], atol=1.0)
    f_no_unit = export(d / "e22.csv", c, t, header=hdr("Name", "Air Temp", "Timestamp", "Meas X", "Meas Y", "Meas Z"),
                       temp="F")
    with pytest.raises(CampaignFileError, match="look like °F"):
        import_export(f_no_unit, flow, d / "plan.csv")
    res = import_export(f_no_unit, flow, d / "plan.csv", temperature_unit="F")
    np.testing.assert_allclose(res.campaign.temperature, c.temperature, atol=1e-3)


def test_without_a_plan_the_export_carries_the_axes(flow, day, tmp_path):
    d, t, c = day
    write_campaign(tmp_path / "c.csv", c, flow)
    text = (tmp_path / "c.csv").read_text().replace(",", ";").replace(".", ",")
    (tmp_path / "e.csv").write_text(text)
    res = import_export(tmp_path / "e.csv", flow, units="mm")
    np.testing.assert_allclose(res.campaign.q, c.q, atol=1e-9)
    assert res.units_reason.startswith("given with `units`")
    assert import_export(tmp_path / "e.csv", flow).units == "mm"  # the axis columns give the planned spread
    (tmp_path / "n.csv").write_text("Name;Meas X;Meas Y;Meas Z\nP1;1;2;3\nP2;1;2;3\nP3;1;2;3\nP4;1;2;3\n")
    with pytest.raises(CampaignFileError, match="give `plan`") as e:
        import_export(tmp_path / "n.csv", flow, units="mm")
    assert e.value.column == "X"


def _same_campaign(a, b):
    """Every field of two campaigns equal, to the 6 decimals of a file (SI)."""
    assert a.axis_names == b.axis_names and list(a.extra) == list(b.extra)
    for name in ("q", "tool", "xyz", "radius"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), atol=1e-9, equal_nan=True, err_msg=name)
    for name in ("instrument", "station", "pivot", "point", "target"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for k in a.extra:
        np.testing.assert_allclose(a.extra[k], b.extra[k], atol=1e-6, err_msg=k)


def test_simulated_and_imported_campaign_files_have_one_writer(machines, tmp_path):
    """The writer of vecpin simulate's files (write_campaign) and of vecpin import's
    (write_imported) write the same bytes for one campaign with every kind of row: tool
    targets, table nests, two tracker stations, ball bar rows, and a plan's point numbers
    and approach signs. Read with the csv module: a per-row column only when a row uses
    it, counts as whole numbers, ball bar radii in mm; the file reads back to the campaign."""
    m = machines["trunnion_xyzac"]
    c = simulate(m, 5, design=Design(n_commands=6, n_validation=2, stations=2, ballbar_points=4,
                                     targets_mm=((0.0, 0.0, 50.0),))).campaign
    n = len(c)
    c.extra["point"] = np.arange(1.0, n + 1)
    c.extra["approach_A"] = np.where(np.arange(n) % 2, 1.0, -1.0)
    write_campaign(tmp_path / "simulated.csv", c, m)
    write_imported(c, m, tmp_path / "imported.csv")
    text = (tmp_path / "simulated.csv").read_bytes()
    assert text == (tmp_path / "imported.csv").read_bytes()
    rows = list(csv.DictReader(open(tmp_path / "simulated.csv")))
    assert list(rows[0])[-7:] == ["point", "approach_A", "instrument", "target", "station", "r", "pivot"]
    assert [r["point"] for r in rows] == [str(k) for k in range(1, n + 1)]
    assert {r["approach_A"] for r in rows} == {"1", "-1"}
    bb = [r for r in rows if r["instrument"] == "ballbar"]
    assert len(bb) == 4 and all(r["station"] == "" and r["x"] == "" for r in bb)
    np.testing.assert_allclose([float(r["r"]) for r in bb], c.radius[c.ballbar_rows] * 1000, atol=1e-6)  # mm
    assert {r["station"] for r in rows if r["instrument"] != "ballbar"} == {"0", "1"}
    assert {r["target"] for r in rows if r["instrument"] == "nest"} == {"1", "2", "3"}
    _same_campaign(read_campaign(tmp_path / "simulated.csv", m), c)
    # the columns nobody uses are not written: tool tips and nests from one station
    tips = c.subset(np.flatnonzero((c.instrument == "nest") & (c.station == 0)))
    write_campaign(tmp_path / "nests.csv", tips, m)
    assert (tmp_path / "nests.csv").read_text().splitlines()[0].endswith("temperature,point,approach_A,instrument,target")
    spar = machines["spar_mill_23"]
    two = simulate(spar, 5, design=Design(n_commands=8, n_validation=2)).campaign
    write_imported(two, spar, tmp_path / "spar.csv")
    assert {r["tool_point"] for r in csv.DictReader(open(tmp_path / "spar.csv"))} == set(spar.tool_links)
    _same_campaign(read_campaign(tmp_path / "spar.csv", spar), two)


def test_read_campaign_hints_at_semicolons_and_tabs(flow, day, tmp_path):
    d, t, c = day
    write_campaign(tmp_path / "c.csv", c, flow)
    for sep, word in ((";", "semicolon"), ("\t", "tab")):
        (tmp_path / "s.csv").write_text((tmp_path / "c.csv").read_text().replace(",", sep))
        with pytest.raises(CampaignFileError, match=f"{word}-separated") as e:
            read_campaign(tmp_path / "s.csv", flow)
        assert e.value.row == 1 and "vecpin import" in str(e.value) and "missing axis" not in str(e.value)


def test_import_cli(flow, day, tmp_path, capsys):
    d, t, c = day
    p = export(d / "e30.csv", c, t)
    out = tmp_path / "campaign.csv"
    assert main(["import", str(p), "--machine", "flow_xyzcb", "--plan", str(d / "plan.csv"), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "semicolon-separated, decimal ','" in text and "coordinates in inches" in text
    np.testing.assert_allclose(read_campaign(out, flow).xyz, c.xyz, atol=1e-6)
    assert main(["import", str(p), "--machine", "flow_xyzcb", "--plan", str(d / "plan.csv"), "--units", "mm",
                 "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "give --units in" in err and "Traceback" not in err


def test_german_export_with_date_and_time_columns_keeps_names_time_and_temperature(flow, day):
    """`Punktname;X;Y;Z;Datum;Uhrzeit;Lufttemperatur`: joined by the point names, the date and
    the time of day read as one stamp, the air temperature kept (none dropped silently)."""
    d, t, c = day
    lines = ["Punktname;X;Y;Z;Datum;Uhrzeit;Lufttemperatur"]
    for i in range(len(c)):
        stamp = T0 + timedelta(seconds=float(c.time[i]))
        x, y, z = (f"{v:.6f}".replace(".", ",") for v in c.xyz[i] * 1000.0)
        lines.append(";".join([point_name(t.point[i]), x, y, z, stamp.strftime("%d.%m.%Y"),
                               stamp.strftime("%H:%M:%S"), f"{c.temperature[i]:.3f}".replace(".", ",")]))
    p = d / "de.csv"
    p.write_text("\r\n".join(lines) + "\r\n", encoding="utf-8")
    res = import_export(p, flow, d / "plan.csv")
    assert res.columns["point"] == "Punktname" and res.columns["temperature"] == "Lufttemperatur"
    assert (res.columns["date"], res.columns["time"]) == ("Datum", "Uhrzeit")
    got = res.campaign
    np.testing.assert_array_equal(got.extra["point"], t.point)
    np.testing.assert_allclose(got.time, c.time - c.time[0], atol=1.0)   # across midnight: the date counts
    np.testing.assert_allclose(got.temperature, c.temperature, atol=1e-3)
    np.testing.assert_allclose(got.xyz, c.xyz, atol=1e-9)
