"""The report for several models at once (Paper I Fig. 9-11), histogram bins, the vector
grid's fixed axes and arrow key, the scene's groups (one shown at a time, each with its
own exaggeration, all on one colour scale), one colour scale per quantity across a report's figures and, in headless Chromium, the scene's legend and
colour bar and the report's colour bars."""
import re
import shutil
import subprocess
import tempfile

import matplotlib
import meshcat
import numpy as np
import pytest
import umsgpack

from vecpin.cli import main
from vecpin.measurement.campaign import write_campaign
from vecpin.measurement.noise import NoiseModel
from vecpin.models import make_model
from vecpin.simulation.simulate import Design, simulate
from vecpin.viz import figures
from vecpin.workflows.reporting import report as write_report
from vecpin.viz.scene import GROUPS, RecordingWindow, build_scene, write_html

pytestmark = pytest.mark.slow   # a long matrix: the edit loop (-m 'not slow') leaves it to CI

CHROMIUM = shutil.which("chromium")


@pytest.fixture(scope="module")
def fitted(flow):
    sim = simulate(flow, seed=4, design=Design(n_commands=100, n_validation=20))
    noise = NoiseModel.default(flow, "spherical")
    return sim, [make_model(k, flow, 2).fit(sim.campaign, noise) for k in ("6dof", "ap")]


def shoot(page, out, size="1000,700"):
    from PIL import Image
    cmd = ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
           "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
           f"--user-data-dir={tempfile.mkdtemp()}", f"--window-size={size}", "--virtual-time-budget=5000",
           f"--screenshot={out}", page.resolve().as_uri()]
    subprocess.run(cmd, capture_output=True, timeout=240)
    return np.asarray(Image.open(out).convert("RGB")).astype(float)


def turbo_strips(img, vertical: bool, min_len: int = 120) -> int:
    """Number of pixel lines (columns if ``vertical``) holding a run of >= ``min_len``
    pixels whose colours follow matplotlib's turbo map from one end to the other."""
    from scipy.spatial import cKDTree
    lut = matplotlib.colormaps["turbo"](np.linspace(0, 1, 256))[:, :3] * 255
    a = img.transpose(1, 0, 2) if vertical else img
    idx = np.full(a.shape[:2], -1)
    coloured = np.ptp(a, axis=2) > 40  # grey, white and black are not on the map
    d, k = cKDTree(lut).query(a[coloured])
    idx[coloured] = np.where(d < 30, k, -1)
    found = 0
    for line in idx:
        good = line >= 0
        if good.sum() < min_len:
            continue
        edges = np.flatnonzero(np.diff(np.r_[0, good.astype(int), 0]))
        for s, e in zip(edges[::2], edges[1::2]):
            run = line[s:e]
            if e - s >= min_len and abs(int(run[-1]) - int(run[0])) > 180 and \
                    np.mean(np.diff(run) * np.sign(run[-1] - run[0]) >= -3) > 0.95:
                found += 1
                break
    return found


def test_histogram_layout_gives_a_small_residual_sensible_bins():
    rng = np.random.default_rng(0)
    errs = {"nominal": rng.uniform(0.1, 1.0, 300), "AP": rng.uniform(0.01, 0.06, 300),
            "6-DoF": rng.uniform(0.01, 0.05, 300)}
    shared = np.linspace(0, errs["nominal"].max(), 41)
    assert np.count_nonzero(np.histogram(errs["AP"], shared)[0]) <= 3  # one scale for all: two or three bars
    layout = figures.histogram_layout(errs)
    assert [sorted(lab) for lab, _ in layout] == [["nominal"], ["6-DoF", "AP"]]
    edges = layout[1][1]
    assert np.count_nonzero(np.histogram(errs["AP"], edges)[0]) >= 20


def test_vector_grid_states_what_it_holds_fixed(flow, monkeypatch):
    seen = {}
    monkeypatch.setattr(figures, "_save", lambda fig, path: seen.setdefault("fig", fig))
    figures.error_vector_plot(flow, lambda q, t: np.c_[q[:, 0] * 1e-4, q[:, 1] * 1e-4, q[:, 2] * 0], "x.png",
                              ("X", "Y"), fixed={"Z": 300.0, "C": 90.0}, tool=0.2)
    ax = seen["fig"].axes[0]
    title = ax.get_title(loc="left")
    assert "held fixed: Z = 300.0 mm, C = 90.0 deg, B = 0.0 deg, tool 200.0 mm" in title
    keys = [c for c in ax.get_children() if type(c).__name__ == "QuiverKey"]
    assert len(keys) == 1 and keys[0].U == 0.5 and "0.5 mm" in keys[0].text.get_text()


def test_report_covers_several_models(flow, fitted, tmp_path, monkeypatch):
    """... and its colour-mapped figures share one scale of the tip error (issue 41): the
    grid plots before and after the tables take the same colormap and limits, and the 3D
    scene's colour bar of every group ends where they do."""
    sim, models = fitted
    grids, scales = [], {}
    real = figures.compensation_grid
    monkeypatch.setattr(figures, "compensation_grid", lambda m, sols, path: grids.append(list(sols)) or real(m, sols, path))
    save = figures._save

    def seen(fig, path):
        scales[path.name] = [(c.get_cmap().name, c.get_clim()) for ax in fig.axes for c in ax.collections
                             if c.get_array() is not None]
        return save(fig, path)
    monkeypatch.setattr(figures, "_save", seen)
    page = write_report(models, sim.campaign, tmp_path / "r", validation=sim.validation)
    before, after = set(scales["vectors.png"]), set(scales["vectors_comp.png"])   # the arrows and their colour bar
    assert len(before) == 1 and before == after
    (cmap, (bottom, top)), = before
    assert cmap == "turbo" and bottom == 0.0
    bars = re.findall(r'<span>([\d.]+) mm</span></div></div>', (tmp_path / "r" / "scene.html").read_text())
    assert len(bars) == 3 and all(float(b) == pytest.approx(top, abs=5e-4) for b in bars)
    assert f"tip error 0 .. {top:.3f} mm (turbo colormap)" in page.read_text()
    html = page.read_text()
    for needle in ("6-DoF order 2", "AP order 2", "identification: model 6-DoF order 2", "validation: model AP order 2",
                   "figures/histogram_compensated.png", "Paper I Fig. 10", "scene.html"):
        assert needle in html
    assert grids == [["6-DoF order 2 tables", "AP order 2 tables"]]  # Fig. 10: both models overlaid
    for f in ("histogram.png", "histogram_validation.png", "histogram_compensated.png", "tables.png", "vectors.png"):
        assert (tmp_path / "r" / "figures" / f).stat().st_size > 15000
    assert not list((tmp_path / "r").glob(".vecpin-staging-*"))


def test_report_command_takes_several_models(flow, fitted, tmp_path, capsys):
    sim, models = fitted
    for k, mod in enumerate(models):
        mod.save(tmp_path / f"m{k}.json")
    write_campaign(tmp_path / "c.csv", sim.campaign, flow)
    assert main(["report", str(tmp_path / "m0.json"), str(tmp_path / "m1.json"), str(tmp_path / "c.csv"),
                 "--out", str(tmp_path / "r"), "--quiet"]) == 0
    assert "for 2 models" in capsys.readouterr().out
    assert "AP order 2" in (tmp_path / "r" / "index.html").read_text()


def test_scene_shows_one_group_each_on_its_own_scale(flow, fitted):
    sim, models = fitted
    from vecpin.compensation.plan import plan_tables
    tables = plan_tables(models[0], n_commands=200).tables
    window = RecordingWindow()
    facts = build_scene(meshcat.Visualizer(window=window), models[0], sim.campaign, 2, None, tables, "residuals")
    groups = {g["name"]: g for g in facts["groups"]}
    assert [g["name"] for g in facts["groups"] if g["visible"]] == ["residuals"]
    nominal = flow.tool_tip(sim.campaign.q, sim.campaign.tool)
    span = np.linalg.norm(np.ptp(nominal, axis=0))
    for g in groups.values():  # the largest vector of every group: 8 % of the workspace
        assert g["exaggeration"] * g["max_mm"] * 1e-3 == pytest.approx(0.08 * span)
    for name, (_, nodes) in GROUPS.items():
        for node in nodes:
            cmd = umsgpack.unpackb(window.commands[("set_property", f"/meshcat/vecpin/{node}", "visible")])
            assert cmd["value"] == (name == "residuals")
    facts = build_scene(meshcat.Visualizer(window=RecordingWindow()), models[0], sim.campaign, 2,
                        {"errors": 100.0}, tables)
    assert facts["groups"][0]["exaggeration"] == 100.0 and facts["groups"][1]["exaggeration"] != 100.0


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it)")
def test_scene_screenshot_has_the_legend_colour_bar_and_switches_groups(flow, fitted, tmp_path):
    sim, models = fitted
    facts = write_html(tmp_path / "e.html", models[1], sim.campaign, 3, None, None, "errors")
    html = (tmp_path / "e.html").read_text()
    assert 'id="vecpin-legend"' in html and html.count('name="vecpin-group"') == 2
    vmax = facts["groups"][0]["max_mm"]
    assert re.search(rf">{vmax:.3f} mm<", html)
    img = shoot(tmp_path / "e.html", tmp_path / "e.png")
    legend = img[10:250, 10:430]
    assert (legend.min(axis=2) > 235).mean() > 0.6          # the white legend box
    assert (legend.max(axis=2) < 80).sum() > 300            # its text
    assert turbo_strips(legend, vertical=False) >= 8        # the colour bar: rows of the turbo gradient
    # the residual group shown at load, and the same page switched to it by the legend's script
    write_html(tmp_path / "r.html", models[1], sim.campaign, 3, None, None, "residuals")
    # the recorded commands are applied asynchronously at load: switch as a user would, a moment later
    i = html.rindex("</body>")
    (tmp_path / "s.html").write_text(html[:i] + '<script>setTimeout(() => vecpinShow("residuals"), 1500);</script>'
                                     + html[i:])
    r = shoot(tmp_path / "r.html", tmp_path / "r.png")[260:]
    s = shoot(tmp_path / "s.html", tmp_path / "s.png")[260:]
    e = img[260:]
    assert np.abs(r - s).mean() < 0.5 * np.abs(r - e).mean()
    assert np.abs(r - e).mean() > 0.2  # the groups differ on screen


@pytest.mark.skipif(CHROMIUM is None, reason="chromium is not installed (.ci/run installs it)")
def test_report_screenshot_shows_its_colour_bars(flow, fitted, tmp_path):
    sim, models = fitted
    page = write_report(models, sim.campaign, tmp_path / "r", validation=sim.validation)
    img = shoot(page, tmp_path / "r.png", size="1200,9000")
    assert img.std() > 10
    assert turbo_strips(img, vertical=True) >= 10  # the vector plots' colour bars


def test_a_negligible_compensated_error_is_drawn_at_the_errors_scale(flow, fitted, monkeypatch):
    """Tables that leave (numerically) nothing: the compensated group is not magnified to 8 % of
    the workspace (issue 41: an AP model's was drawn x489861) but shares the errors' exaggeration;
    every group shares one colour scale."""
    sim, models = fitted
    from vecpin.compensation.plan import plan_tables
    tables = plan_tables(models[0], n_commands=200).tables
    tables.tables = {}                                             # no table: the error left is the error
    facts = build_scene(meshcat.Visualizer(window=RecordingWindow()), models[0], sim.campaign, 2, None, tables)
    g = {x["name"]: x for x in facts["groups"]}
    top = max(x["max_mm"] for x in g.values())                    # one colour scale: the largest of any group
    assert {x["scale_mm"] for x in g.values()} == {top} and facts["scale"]["limits"] == [0.0, top]
    assert g["compensated"]["exaggeration"] != g["errors"]["exaggeration"]   # not negligible: its own length
    monkeypatch.setattr("vecpin.viz.scene.NEGLIGIBLE", 10.0)      # every compensated error counts as negligible
    facts = build_scene(meshcat.Visualizer(window=RecordingWindow()), models[0], sim.campaign, 2, None, tables)
    g = {x["name"]: x for x in facts["groups"]}
    assert g["compensated"]["exaggeration"] == g["errors"]["exaggeration"]
    assert g["compensated"]["scale_mm"] == g["errors"]["scale_mm"] == top
