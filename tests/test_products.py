"""Product terms (issue 39 b): a table of a turning table's axis times a fixed ramp of a linear axis.

* A tilt fixed to a turning table (closed form: the tip relative to the table turned by a
  constant small rotation) is largely beyond one-axis tables; with product terms the same
  least-squares problem removes most of it.
* The SINUMERIK files carry them (``$AN_CEC_MULT_BY_TABLE``, K3 03/2013 p.249): applied by the
  controller simulated from the manual (tests/controller_appliers.py: each table adds its own
  value, the product of the two tables' values is added as another), they land on the planned
  set within 0.0002 mm at the tool tip, and vecpin's reader reads back the same set.
* The generic files carry them, applied by the part-frame judge's own reader.
* vecpin's LinuxCNC HAL component carries them (its own definition, in the component's header): read from
  the C arrays by the independent applier, they land on the planned set within 0.0002 mm; the real
  controller applies them in tests/test_linuxcnc_real.py."""
import copy

import numpy as np
import pytest
from controller_appliers import linuxcnc_corrections, siemens_corrections
from controller_cases import profile as user_profile
from controller_cases import reference_positions
from part_frame_judge import apply as judge_apply
from part_frame_judge import read_tables

import vecpin
from vecpin.compensation.functions import all_table_names, pseudo_commands, table_bases
from vecpin.compensation.products import ProductEvidence, choose_products, product_candidates
from vecpin.compensation.tableproblem import TableProblem
from vecpin.compensation.tables import CompensationTable, ProductTable, TableSet
from vecpin.export import linuxcnc, siemens
from vecpin.export.profile import ControllerProfile
from vecpin.export.common import ExportJob
from vecpin.errors import InputError
from vecpin.export.generic import write_tables
from vecpin.fileio import OutputSet

TILT = np.array([1.5e-4, -1.0e-4, 0.0])   # rad, fixed to the table (about its x and y)
TOOLS = (0.2, 0.3)                        # m


@pytest.fixture(scope="module")
def machine():
    return vecpin.Machine.load("head_table_bc")


def tilted_table(m):
    """An actual machine whose table is tilted by TILT in its own frame: the tip relative to the table
    is the nominal one turned by TILT about the table's origin (closed form, small angle exact to
    second order); the nominal Jacobian steers the solve."""
    def actual(q, tool, jacobian=False, point=0):
        k = m.kinematics(q, tool, jacobian, frame="workpiece", point=point)
        return k.tip + np.cross(TILT, k.tip), (k.jacobian if jacobian else None)
    return actual


@pytest.fixture(scope="module")
def problem(machine):
    q = pseudo_commands(machine, 300, 1)
    q[:, machine.axis("B").index] = 0.0     # the head vertical: the tip is the linear axes' position plus the tool
    return TableProblem(tilted_table(machine), machine, q, TOOLS, bases=table_bases(machine, 4, "fourier"),
                        products=product_candidates(machine))


def test_a_tilt_fixed_to_a_turning_table_needs_product_terms(machine, problem):
    """head_table_bc (C turns the table), its head vertical: every candidate is (linear output, C, linear
    factor); the full one-axis set leaves most of a 180 µrad tilt fixed to the table, the chosen product terms
    most of the rest (with the head tilted, the tool's own lever turns with B as well: a product of three)."""
    assert {r for _, r, _ in product_candidates(machine)} == {"C"} and len(problem.products) == 9
    assert product_candidates(vecpin.Machine.load("cincinnati_20v")) == []       # no turning table: none
    before = np.sqrt(problem.e0e0 / len(problem.q))   # no table
    full = problem.cost(all_table_names(machine))
    chosen = choose_products(problem, all_table_names(machine), None)
    with_products = problem.cost(all_table_names(machine) + chosen)
    assert full > 0.5 * before                        # one-axis tables: a tilt on a turning table stays
    assert with_products < 0.2 * full, (before, full, with_products, chosen)
    assert {"zc*x", "zc*y"} <= set(chosen)            # Δz = a(C) x + b(C) y
    assert len(choose_products(problem, all_table_names(machine), 1)) == 1     # the room the controller leaves


def _tilt_noise(m, problem, sd: float) -> np.ndarray:
    """(3R, 2) a model's prediction noise that is itself a tilt fixed to the table, ``sd`` [rad] about x and y:
    the displacement w x r of the tips relative to the table (closed form), registered as the problem's errors."""
    r = m.kinematics(problem.q, problem.L, jacobian=False, frame="workpiece").tip
    F = np.stack([np.cross(w, r).ravel() * sd for w in np.eye(3)[:2]], axis=1)
    return problem._registered(np.ascontiguousarray(F))


def test_product_terms_only_where_the_campaign_determines_them(machine, problem):
    """A 180 µrad tilt fixed to the table, modelled with an uncertainty that is itself such a tilt: known to
    20 µrad (1 sigma) the product terms that carry it are chosen; known to 2 mrad (the model's tilt is mostly
    its noise) none, as tables following the noise would leave the machine worse. The rule's expected error
    is unbiased: told 300 noisy models (150 antithetic pairs), it agrees on average (within 3 standard errors)
    with the closed form of tables fitted to such models and judged on the truth (numpy's projection)."""
    names = all_table_names(machine)
    assert {"zc*x", "zc*y"} <= set(choose_products(problem, names, None, _tilt_noise(machine, problem, 2e-5)))
    assert choose_products(problem, names, None, _tilt_noise(machine, problem, 2e-3)) == []
    F = _tilt_noise(machine, problem, 1e-4)
    truth = []   # tables fitted to a model e0 + F z judged on e0: E|e0 - H (e0 + F z)|^2 = |(I - H) e0|^2 + |H F|^2
    for names_ in (names, names + ["zc*x", "zc*y"]):
        Q = np.linalg.qr(problem.A[:, problem.columns(names_)])[0]     # H = Q Q' (numpy, no ridge)
        truth.append(np.sum((problem.e0 - Q @ (Q.T @ problem.e0)) ** 2) + np.sum((Q @ (Q.T @ F)) ** 2))
    predicted = []
    for z in np.random.default_rng(3).standard_normal((150, F.shape[1])):   # the rule, told a noisy model
        pair = []
        for e in (problem.e0 + F @ z, problem.e0 - F @ z):    # antithetic: the error's term linear in z cancels
            noisy = copy.copy(problem)
            noisy.e0, noisy.g, noisy.e0e0 = e, problem.A.T @ e, float(e @ e)
            evidence = ProductEvidence(noisy, names, F)
            pair.append(evidence.value(["zc*x", "zc*y"]) - evidence.value([]))
        predicted.append(np.mean(pair))
    gain, se = truth[1] - truth[0], np.std(predicted) / np.sqrt(len(predicted))
    assert gain < 0 and abs(np.mean(predicted) - gain) < 3 * se < 0.4 * abs(gain), (np.mean(predicted), gain, se)


def _tilt_left(m, problem, names) -> float:
    """The tilt [rad] (about the table's x and y) of the compensated volume the linearised tables ``names``
    leave: the small rotation best fitted to their errors about the tips' centroid (closed form of a rotation's
    displacement, w x r), by numpy's least squares."""
    e = (problem.A @ problem.solve_linear(names) + problem.e0).reshape(-1, 3)
    r = m.kinematics(problem.q, problem.L, jacobian=False, frame="workpiece").tip
    r = r - r.mean(axis=0)
    lever = -np.cross(r[:, :, None], np.eye(3)[None], axis=1)        # d(w x r)/dw, per tip
    w = np.linalg.lstsq(lever.reshape(-1, 3), (e - e.mean(axis=0)).ravel(), rcond=None)[0]
    return float(np.hypot(w[0], w[1]))


def test_written_product_terms_keep_the_face(machine):
    """With product terms written in the table's face frame the tables hold the volume's turn at zero
    (``hold_turn``): with the head tilting too (B moves), least squares alone trades part of a tilt fixed to the
    table for a smaller error elsewhere (the tool's lever turns with B: beyond a product of two), which a part
    clamped on the face sees; held, the same kind of terms leave none of it (< 1 µrad of 180)."""
    q = pseudo_commands(machine, 200, 1)
    left, problems = {}, {}
    for hold in (False, True):
        bases = table_bases(machine, 4, "fourier")
        p = problems[hold] = TableProblem(tilted_table(machine), machine, q, TOOLS, hold_turn=hold,
                                          products=product_candidates(machine), bases=bases)
        names = all_table_names(machine)
        left[hold] = _tilt_left(machine, p, names + choose_products(p, names, None))
    assert left[False] > 5e-6 and left[True] < 1e-6, left
    problems[True].release_turn()     # the hold let go (no term used): the problem without it
    assert np.allclose(problems[True].solve_linear(names), problems[False].solve_linear(names), rtol=1e-6, atol=1e-12)


def _product_set(m) -> TableSet:
    """Tables with two product terms (one whose factor axis is its output: the pitch table cancels its ramp)."""
    rng = np.random.default_rng(5)
    tables = []
    for o in ("X", "Y", "Z"):
        for i in ("X", "Y", "Z", "C"):
            a = m.axis(i)
            tables.append(CompensationTable(i, o, a.lower, a.travel / 40, 1e-5 * np.cumsum(rng.standard_normal(41))))
    for r in ("B", "C"):
        a = m.axis(r)
        tables.append(CompensationTable(r, r, a.lower, a.travel / 40, 1e-5 * rng.standard_normal(41)))
    c = m.axis("C")
    prods = []
    for o, f in (("Z", "X"), ("X", "X")):
        ramp = np.linspace(-1.0, 1.0, 41)
        angle = np.linspace(c.lower, c.upper, 41)
        prods.append(ProductTable(CompensationTable("C", o, c.lower, c.travel / 40, 8e-5 * np.cos(angle)),
                                  CompensationTable(f, o, m.axis(f).lower, m.axis(f).travel / 40, ramp)))
    return TableSet(m.axis_names, tables, products=prods)


def test_siemens_files_with_table_multiplication_land_on_the_planned_set(machine, tmp_path):
    """K3 p.249: table 1 times table 2 of the same compensation axis, added as another value; each still adds its
    own. The files as the simulated SINUMERIK applies them and as vecpin reads them back give the planned
    commands, and the tool tip within 0.0002 mm."""
    m = machine
    planned = _product_set(m)
    prof = user_profile(m, "siemens-840d")
    with OutputSet(tmp_path) as out:
        siemens.write(ExportJob(planned, m, prof, siemens.LIMITS_840D, out))
    text = (tmp_path / "NC_CEC.INI").read_text()
    # 9 cross tables, then per product its table and its ramp: table 9 times table number 11 (index 10), 11 times 13
    assert text.count("$AN_CEC_MULT_BY_TABLE[") == 9 + 4
    assert "$AN_CEC_MULT_BY_TABLE[9]=11" in text and "$AN_CEC_MULT_BY_TABLE[11]=13" in text
    q = pseudo_commands(m, 400, 7)
    q_user = m.to_user(q)
    applied = m.to_si(q_user + siemens_corrections(tmp_path, list(m.axis_names), reference_positions(m), q_user))
    wanted = planned.apply(q)
    tips = [m.tool_tip(c, np.full(len(q), 0.25), frame="workpiece") for c in (applied, wanted)]
    assert np.abs(tips[0] - tips[1]).max() * 1e3 < 2e-4
    back = siemens.read(tmp_path, m, prof)
    assert len(back.products) == 2 and sorted(back.names()) == sorted(planned.names())
    assert np.abs(back.apply(q) - wanted).max() * 1e3 < 2e-4      # mm, deg
    without = TableSet(m.axis_names, planned.tables)
    assert np.abs(without.apply(q) - wanted).max() * 1e3 > 0.05   # the products matter here


def test_a_multiplied_table_of_another_axis_is_refused(machine, tmp_path):
    m = machine
    prof = user_profile(m, "siemens-840d")
    with OutputSet(tmp_path) as out:
        siemens.write(ExportJob(_product_set(m), m, prof, siemens.LIMITS_840D, out))
    path = tmp_path / "NC_CEC.INI"
    path.write_text(path.read_text().replace("$AN_CEC_MULT_BY_TABLE[9]=11", "$AN_CEC_MULT_BY_TABLE[9]=1"))
    with pytest.raises(vecpin.errors.ControllerFileError, match="same compensation axis"):
        siemens.read(tmp_path, m, prof)


def test_generic_files_carry_product_terms(machine, tmp_path):
    """tables.json with its products convention: vecpin reads back the set, the judge's own reader applies it."""
    m = machine
    planned = _product_set(m)
    write_tables(planned, m, tmp_path)
    q = pseudo_commands(m, 200, 3)
    back = TableSet.load_json(tmp_path / "tables.json", m)
    np.testing.assert_allclose(back.apply(q), planned.apply(q), atol=1e-12)
    np.testing.assert_allclose(judge_apply(read_tables(tmp_path / "tables.json"), m, q), planned.apply(q),
                               atol=1e-12)
    assert "zc*x:factor" in (tmp_path / "tables.csv").read_text()


def test_product_terms_count_against_the_controllers_tables():
    """Two CEC tables per term within the controller's table count; none where the controller cannot multiply."""
    from vecpin.compensation.limits import NO_LIMITS
    from vecpin.compensation.products import room_for_products
    from vecpin.export import fanuc
    assert room_for_products(siemens.LIMITS_840D, 20) == 22 and room_for_products(siemens.LIMITS_840D, 64) == 0
    assert room_for_products(siemens.LIMITS_840D.overridden({"max_cross_tables": 25}), 20) == 2
    assert room_for_products(NO_LIMITS, 20) is None
    assert room_for_products(fanuc.LIMITS, 6) == 0
    assert room_for_products(linuxcnc.LIMITS, 30) is None       # vecpin's own HAL component: no table limit


def test_linuxcnc_component_with_product_terms_lands_on_the_planned_set(machine, tmp_path):
    """The component's product arrays (table over the rotary joint times factor over the linear joint, added to
    the output joint), applied by the test's own reader of the C source with the COMP_FILEs, give the planned
    commands and the tool tip within 0.0002 mm; vecpin's reader reads back the same set."""
    m = machine
    planned = _product_set(m)
    prof = ControllerProfile()
    with OutputSet(tmp_path) as out:
        names = linuxcnc.write(ExportJob(planned, m, prof, linuxcnc.LIMITS, out))
    assert "vecpin_vec.comp" in names
    q = pseudo_commands(m, 400, 7)
    q_user = m.to_user(q)
    applied = m.to_si(q_user + linuxcnc_corrections(tmp_path, list(m.axis_names), q_user))
    wanted = planned.apply(q)
    tips = [m.tool_tip(c, np.full(len(q), 0.25), frame="workpiece") for c in (applied, wanted)]
    assert np.abs(tips[0] - tips[1]).max() * 1e3 < 2e-4
    back = linuxcnc.read(tmp_path, m, prof)
    assert sorted(p.name for p in back.products) == ["xc*x", "zc*x"]
    assert np.abs(back.apply(q) - wanted).max() * 1e3 < 2e-4      # mm, deg
    without = TableSet(m.axis_names, planned.tables)
    assert np.abs(without.apply(q) - wanted).max() * 1e3 > 0.05   # the products matter here


def test_products_by_default_where_the_face_is_read_and_the_controller_carries_them(machine):
    """The default (``products`` None): on where the campaign read the table's face and the controller carries
    products exactly as planned (generic files, vecpin's LinuxCNC component); on SINUMERIK computed and printed
    but written only when asked (the unit of its product is inferred); off where the face was not read, the
    table does not turn, the controller cannot multiply, or its table limit forces a subset (said so)."""
    from vecpin.compensation.limits import NO_LIMITS
    from vecpin.compensation.products import products_wanted
    from vecpin.export import fanuc
    m = machine
    for limits in (NO_LIMITS, linuxcnc.LIMITS):
        assert products_wanted(None, limits, True, m, False) == (True, "", "")
        offer, held, line = products_wanted(None, limits, False, m, False)
        assert not offer and "did not read the table's face" in line and "`products`" in line
        assert products_wanted(True, limits, False, m, False) == (True, "", "")
        assert products_wanted(False, limits, True, m, False)[:2] == (False, "")
    offer, held, _ = products_wanted(None, siemens.LIMITS_840D, True, m, False)
    assert offer and "inferred" in held and "confirm it on the machine" in held and "`products`" in held
    assert products_wanted(True, siemens.LIMITS_828D, True, m, False) == (True, "", "")
    offer, _, line = products_wanted(None, fanuc.LIMITS, True, m, False)
    assert not offer and "does not multiply tables" in line
    offer, _, line = products_wanted(True, siemens.LIMITS_828D, True, m, True)
    assert not offer and "subset" in line
    head = vecpin.Machine.load("cincinnati_20v")
    assert products_wanted(None, NO_LIMITS, True, head, False) == (False, "", "")
    with pytest.raises(InputError, match="has no rotary axis that turns the table"):
        products_wanted(True, NO_LIMITS, True, head, False)


def test_command_line_products_default_on_and_off():
    from vecpin.cli.main import build_parser
    parse = build_parser().parse_args
    assert parse(["tables", "m.json", "--out", "d"]).products is None
    assert parse(["tables", "m.json", "--out", "d", "--products"]).products is True
    assert parse(["tables", "m.json", "--out", "d", "--no-products"]).products is False
