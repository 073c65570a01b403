"""Thermal terms judged outside vecpin: a simulated machine whose thermal behaviour is a
family vecpin's thermal model does not contain (tests/thermal_truth.py: the structure
lags the air by 1.5 h, between the lags vecpin scans; the errors grow 1 % per K faster
than linearly; per-axis offsets, expansions about their own centres, and a tool that
grows), measured in a campaign with time and temperature; vecpin fits its terms and
writes each controller's files (Siemens, Beckhoff, Heidenhain, Fanuc, LinuxCNC's HAL
component); an independent reader per controller, written from the manuals the READMEs
cite (LinuxCNC: the component's source), turns the files into the controller's
correction; the corrected commands run on the simulated machine at a steady temperature
10 K from the campaign's mean. Judged there, on two campaigns: the tip's displacement
from where the geometric tables leave it (the truth's tip averaged over the campaign's
structure temperatures: a least-squares geometry takes up the thermal error's mean over
its campaign) is what vecpin's terms themselves leave (each controller carries them, its
rounding aside), a fraction of the error without them, and lies in the 5..95 % band
vecpin predicts (vecpin.compensation.thermal.remaining_mm: the coefficients' spread over
time blocks held out, the lag's uncertainty, the curvature per axis the campaign
bounds, extrapolated). vecpin's point figure is held to 20 % only with the chance it states
(about one in four from a campaign over a few kelvin, 10 K away: the curvature is not
resolved there); how often it holds over fresh truths, and the tolerance it does hold to
four times in five, is benchmarks/bench_thermal_truth.py's page, not a test's two
campaigns. Also: what the data cannot separate is said, and the curvature fitted per axis
lies within three of its standard deviations of the truth's."""
import dataclasses
import json

import numpy as np
import pytest

import vecpin
from thermal_truth import READERS, Truth, commands, corrected, judged
from vecpin.compensation.thermal import fit_thermal, remaining_mm
from vecpin.errors import ControllerLimitError, InputError
from vecpin.export import linuxcnc, thermal, thermal_linuxcnc
from vecpin.export.profile import ControllerProfile
from vecpin.fileio import OutputSet
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model

TRUTH = Truth()


def campaign(m, seed, truth=TRUTH, n=160):
    """10 h of a hall that cycles 3 K over 7 h and warms 0.15 K/h; tracker noise 3 um per coordinate."""
    rng = np.random.default_rng(seed)
    q = commands(m, n, rng)
    t = np.linspace(0, 10 * 3600, n)
    air = 21 + 3 * np.sin(2 * np.pi * t / (7 * 3600)) + 0.15 * t / 3600
    tool = np.full(n, 0.12)
    xyz = truth.tip(m, q, tool, truth.structure(t, air)) + rng.normal(0, 3e-6, (n, 3))
    return Campaign(m.axis_names, q, tool, xyz, extra={"time": t, "temperature": air})


def fit(seed):
    m = vecpin.Machine.load("trunnion_xyzac")
    camp = campaign(m, seed)
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    terms, _ = fit_thermal(geo, camp)
    return m, terms, geo, camp


@pytest.fixture(scope="module")
def fitted():
    return fit(5)


@pytest.fixture(scope="module")
def second():
    return fit(2)


def write_files(controller, terms, m, folder):
    """The controller's thermal files for ``terms`` into ``folder`` (LinuxCNC: the HAL component, not chained)."""
    with OutputSet(folder) as out:
        if controller == "linuxcnc":
            joints = linuxcnc.joint_numbers(m, ControllerProfile())
            thermal_linuxcnc.write(terms, m, joints, max(joints.values()) + 1, out, chained=False)
        else:
            thermal.write(controller, terms, ControllerProfile(), out)


def terms_applied(m, terms, q, temperature):
    """The commands with vecpin's own terms' correction [m] at ``temperature`` (what the files should carry)."""
    qd = q.copy()
    for a in terms.axes:
        i = m.axis(a).index
        qd[:, i] += terms.axis_correction_mm(a, q[:, i] * 1e3, temperature) * 1e-3
    return qd


@pytest.mark.parametrize("controller", list(READERS))
@pytest.mark.parametrize("which, step", [("fitted", 10.0), ("second", -10.0)])
def test_terms_through_the_controller_leave_the_predicted_error(request, tmp_path, controller, which, step):
    m, terms, _, camp = request.getfixturevalue(which)
    write_files(controller, terms, m, tmp_path)
    held = TRUTH.structure(camp.time, camp.temperature)               # what the geometry took up: its mean
    tv = terms.t0_c + step                                     # steady: the structure at the air's temperature
    q = commands(m, 40, np.random.default_rng(9))
    tool = np.full(len(q), 0.12)
    without, with_terms = judged(m, TRUTH, q, tool, corrected(m, q, tmp_path, controller, tv), tv, held)
    _, direct = judged(m, TRUTH, q, tool, terms_applied(m, terms, q, tv), tv, held)
    assert with_terms == pytest.approx(direct, rel=0.02, abs=1e-6)   # the files carry the terms (Fanuc: 1 um units)
    left = remaining_mm(terms, m, q, tool, tv)
    assert left.low <= with_terms * 1e3 <= left.high                 # in the 5..95 % band
    assert left.low <= left.point <= left.high and 0.1 < left.chance < 0.5   # a point, honestly not a promise
    assert with_terms < 0.25 * without and left.high < without * 1e3
    assert without > 50e-6                                       # a real thermal error to remove


def test_lag_and_the_fold_of_the_growth(fitted):
    m, terms = fitted[:2]
    assert abs(terms.lag_h - 1.5) < 0.3 and 0 < terms.held_out["lag_std_h"] < 0.5   # refined between 1 and 2 h
    assert terms.growth_um_per_k is None and any("growth is Z's offset" in n for n in terms.notes)
    c = terms.curvature      # a curvature per axis, Z's offset (the growth) its own, the truth's 1 %/K each
    sd = np.sqrt(np.diag(c["cov_per_k"]))
    assert c["names"] == ["X", "Y", "Z", "tool_growth"] and c["growth_axis"] == "Z"
    assert np.all(np.abs(np.array(c["per_k"]) - 0.01) < 3 * sd)


def test_what_the_data_cannot_separate_is_said():
    """A campaign whose temperature only rises while X is visited in time order."""
    m = vecpin.Machine.load("trunnion_xyzac")
    rng = np.random.default_rng(2)
    n = 80
    q = commands(m, n, rng)
    q[:, m.axis("X").index] = np.linspace(-0.3, 0.3, n)
    t = np.linspace(0, 4 * 3600, n)
    air = 20 + 0.8 * t / 3600
    tool = np.full(n, 0.1)
    camp = Campaign(m.axis_names, q, tool, TRUTH.tip(m, q, tool, air) + rng.normal(0, 3e-6, (n, 3)),
                    extra={"time": t, "temperature": air})
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    terms, _ = fit_thermal(geo, camp, lags=(0.0,))
    text = " ".join(terms.notes)
    assert "the temperature follows the time" in text and "the temperature follows axis X" in text


def test_limits_refused_before_writing(fitted, tmp_path):
    m, terms = fitted[:2]
    big = dataclasses.replace(terms, growth_um_per_k=400.0)
    with OutputSet(tmp_path) as out, pytest.raises(ControllerLimitError, match="MD20392"):
        thermal.write("840D", big, ControllerProfile(), out)
    with OutputSet(tmp_path) as out, pytest.raises(ControllerLimitError, match="9999"):
        thermal.write_fanuc(big, ControllerProfile(), out, detection_unit_mm=0.00001)


def test_tables_workflow_writes_the_thermal_files(fitted, tmp_path):
    """``make_thermal`` (what ``vecpin tables`` runs with a thermal campaign): thermal.json read back
    equal, the LinuxCNC component, and the predicted error over the measured temperatures."""
    from vecpin.compensation.thermal import ThermalTerms
    from vecpin.workflows.thermal import make_thermal
    m, terms, geo, camp = fitted
    run = make_thermal(geo, camp, tmp_path, "linuxcnc")
    assert {f.name for f in run.files} == {"thermal.json", "vecpin_thermal.comp", "vecpin_thermal.hal"}
    back = ThermalTerms.load(tmp_path / "thermal.json")
    assert back.offset_um_per_k == pytest.approx(terms.offset_um_per_k) and back.lag_h == terms.lag_h
    (cold, *_, floor, _), (lo, w_lo, r_lo, *_), _, (hi, w_hi, r_hi, *_), \
        (warm, w_warm, r_warm, lo_warm, hi_warm, _, chance) = run.rows
    assert cold < lo < hi < warm and max(w_lo, w_hi) > 0.01 and r_lo < 0.5 * w_lo and r_hi < 0.5 * w_hi
    assert lo_warm < r_warm < hi_warm < 0.5 * w_warm and 0.003 < floor < 0.01   # floor: 3 um per coordinate, in 3-D
    text = "\n".join(run.lines())
    assert "without" in text and "left by the terms" in text and "extrapolated" in text
    assert f"{chance * 100:.0f} % chance within 20 %" in text and "holds to 20 % only with the chance given" in text
    frame = "the tool tip's displacement relative to the workpiece"          # what the judge above measures
    assert frame in text and frame in json.loads((tmp_path / "thermal.json").read_text())["description"]


def test_terms_in_their_own_family_are_recovered(tmp_path):
    """A machine whose thermal errors are exactly the terms' form (lag 1 h, one of the scanned
    lags; linear in T) and whose head turns the tool: the fit finds the lag and each
    coefficient within 4 standard deviations of the truth, the tool's growth apart from the
    axes, each term's curvature within 4 of none; the LinuxCNC files warn first that a joint
    correction cannot carry the growth."""
    from vecpin.export import thermal_linuxcnc
    m = vecpin.Machine.load("snk_120v")
    rng = np.random.default_rng(11)
    n = 160
    lo, hi = np.array([a.lower for a in m.axes]), np.array([a.upper for a in m.axes])
    q = lo + (hi - lo) * rng.uniform(0, 1, (n, len(lo)))
    t = np.linspace(0, 9 * 3600, n)
    air = 20 + 3 * np.sin(2 * np.pi * t / (6 * 3600)) + 0.1 * t / 3600
    lagged = air.copy()
    for k in range(1, n):
        lagged[k] = lagged[k - 1] + (1 - np.exp(-(t[k] - t[k - 1]) / 3600.0)) * (air[k] - lagged[k - 1])
    a_true = {"X": 7e-6, "Y": -5e-6, "Z": 4e-6}         # m/K at the mid-travel P0
    b_true = {"X": 11.5e-6, "Y": 6e-6, "Z": 15e-6}      # 1/K
    c_true = 12e-6                                       # m/K
    d = lagged - lagged.mean()
    e = np.zeros_like(q)
    for a in a_true:
        i = m.axis(a).index
        mid = 0.5 * (m.axis(a).lower + m.axis(a).upper)
        e[:, i] = a_true[a] * d + b_true[a] * d * (q[:, i] - mid)
    tool = np.full(n, 0.15)
    kin = m.kinematics(q + e, tool, jacobian=False, frame="base")
    xyz = kin.tip + c_true * d[:, None] * kin.tool_dir + rng.normal(0, 3e-6, (n, 3))
    camp = Campaign(m.axis_names, q, tool, xyz, extra={"time": t, "temperature": air})
    geo = make_model("6dof", m, 2).fit(camp, NoiseModel.default(m, "spherical"))
    terms, _ = fit_thermal(geo, camp)
    assert terms.lag_h == 1.0
    for a in a_true:
        assert abs(terms.offset_um_per_k[a] - a_true[a] * 1e6) < 4 * terms.offset_std[a]
        assert abs(terms.slope_um_per_m_per_k[a] - b_true[a] * 1e6) < 4 * terms.slope_std[a]
    assert abs(terms.growth_um_per_k - c_true * 1e6) < 4 * terms.growth_std
    c = terms.curvature                                  # straight in T: no curvature, the growth a term of its own
    assert c["names"] == ["X", "Y", "Z", "tool_growth"]
    assert np.all(np.abs(c["per_k"]) < 4 * np.sqrt(np.diag(c["cov_per_k"])))
    with OutputSet(tmp_path) as out:
        thermal_linuxcnc.write(terms, m, {a: k for k, a in enumerate(m.axis_names)}, 5, out, chained=False)
    assert (tmp_path / "vecpin_thermal.hal").read_text().startswith("# WARNING: the tool's growth")


def test_a_band_wider_than_the_error_without_is_said(fitted):
    """Only where the temperature is extrapolated: near T0 both figures are noise."""
    from vecpin.workflows.thermal import prediction_lines
    terms = fitted[1]
    lo, hi = terms.t_range_c
    rows = [(terms.t0_c - 10, 0.05, 0.03, 0.01, 0.07, 0.005, 0.3), (lo, 0.01, 0.001, 0.0, 0.002, 0.005, 0.6),
            (terms.t0_c, 0.0004, 0.0003, 0.0, 0.0006, 0.005, 0.7),
            (terms.t0_c + 10, 0.05, 0.01, 0.002, 0.03, 0.005, 0.6)]
    notes = [ln for ln in prediction_lines(terms, rows) if "band's top exceeds" in ln]
    assert len(notes) == 1 and f"at {terms.t0_c - 10:.2f} degC (extrapolated)" in notes[0]
    assert not [ln for ln in prediction_lines(terms, rows) if "above the error without them" in ln]
    rows[0] = (terms.t0_c - 10, 0.03, 0.032, 0.013, 0.11, 0.03, 0.23)   # the point above the error without: said
    worse = [ln for ln in prediction_lines(terms, rows) if "above the error without them" in ln]
    assert len(worse) == 1 and f"at {terms.t0_c - 10:.2f} degC (extrapolated)" in worse[0]
    rows = [r[:1] + (r[1], 3 * r[1]) + r[3:] for r in rows]   # worse everywhere, the measured ends too: unresolved
    notes = prediction_lines(terms, rows)
    assert [ln for ln in notes if "does not resolve the thermal terms" in ln]
    assert not [ln for ln in notes if "degC (extrapolated) the figure the terms leave" in ln]


def test_a_campaign_without_temperatures_is_refused_before_the_tables():
    """``vecpin tables --thermal`` checks the campaign before writing any table."""
    from types import SimpleNamespace

    from vecpin.workflows.thermal import check_campaign
    with pytest.raises(InputError, match=r"c\.csv: the thermal terms need a .temperature. column .*was written"):
        check_campaign(SimpleNamespace(temperature=None, source="c.csv"))
    check_campaign(SimpleNamespace(temperature=np.zeros(3), source="c.csv"))
