"""meshcat scenes: content checked without ports or subprocesses; the page rendered
for real in headless Chromium when it is installed (.ci/run installs it)."""
import shutil
import subprocess
import tempfile


import meshcat
import numpy as np
import pytest

from vecpin.models import make_model
from vecpin.measurement.noise import NoiseModel
from vecpin.simulation.simulate import Design, simulate
from vecpin.compensation.plan import plan_tables
from vecpin.viz.scene import RecordingWindow, build_scene, error_colors, write_html


@pytest.fixture(scope="module")
def fitted(machines):
    m = machines["flow_xyzcb"]
    sim = simulate(m, seed=2, design=Design(n_commands=120))
    model = make_model("ap", m, 4).fit(sim.campaign, NoiseModel.default(m, "spherical"))
    return model, sim.campaign


def test_scene_content_without_a_server(fitted):
    model, c = fitted
    window = RecordingWindow()
    vis = meshcat.Visualizer(window=window)
    tables = plan_tables(model, n_commands=200).tables
    facts = build_scene(vis, model, c, row=7, tables=tables)
    objects = window.paths("set_object")
    for group in ("measured", "nominal", "identified", "errors", "residuals", "compensated", "selected"):
        assert f"/meshcat/vecpin/{group}" in objects
    assert any(p.startswith("/meshcat/machine/") for p in objects)
    assert sum(p.startswith("/meshcat/machine/") for p in objects) == 13  # every URDF visual
    assert "/meshcat/vecpin/tracker/axes" in objects
    assert facts["max_error_mm"] > 0.1 and facts["max_compensated_mm"] < facts["max_error_mm"]
    # the measured points are drawn in the machine frame: measured - nominal equals the registered error
    assert 20 < facts["exaggeration"] < 1e5


def _selected(window):
    import umsgpack
    sel = umsgpack.unpackb(window.commands[("set_transform", "/meshcat/vecpin/selected", None)])
    return np.array(sel["matrix"]).reshape(4, 4, order="F")[:3, 3]


def test_machine_is_posed_at_the_selected_row(fitted):
    model, c = fitted
    tips = []
    for row in (2, 11):
        window = RecordingWindow()
        build_scene(meshcat.Visualizer(window=window), model, c, row=row)
        tips.append(_selected(window))
    assert np.linalg.norm(tips[0] - tips[1]) > 0.05


def test_view_row_is_the_row_the_messages_print(fitted, tmp_path, capsys):
    """`vecpin view --row N` poses the machine at the CSV's line N (header = line 1, as a
    campaign file's messages count rows): with exaggeration 1 the selected point is that
    line's x, y, z (read with the csv module) in the machine frame. A number outside the
    file is refused naming the file and the rows it has."""
    import csv
    from vecpin.cli import main
    from vecpin.measurement.campaign import write_campaign
    from vecpin.viz.scene import to_machine_frame
    model, c = fitted
    model.save(tmp_path / "m.json")
    path = tmp_path / "c.csv"
    write_campaign(path, c, model.machine)
    lines = list(csv.reader(open(path)))
    header = lines[0]
    for row in (2, 9, len(lines)):
        xyz = np.array([float(lines[row - 1][header.index(a)]) for a in "xyz"]) / 1000.0
        window = RecordingWindow()
        facts = build_scene(meshcat.Visualizer(window=window), model, c, row=row, exaggerate=1.0)
        assert facts["row"] == row
        np.testing.assert_allclose(_selected(window), to_machine_frame(model, xyz[None])[0], atol=1e-9)
    assert main(["view", str(tmp_path / "m.json"), str(path), "--row", "9", "--no-tables",
                 "--html", str(tmp_path / "v.html")]) == 0
    assert f"posed at row 9 of {path}" in capsys.readouterr().out
    for bad in (1, len(lines) + 1):
        assert main(["view", str(tmp_path / "m.json"), str(path), "--row", str(bad), "--no-tables",
                     "--html", str(tmp_path / "v.html")]) == 2
        err = capsys.readouterr().err
        assert f"--row {bad}" in err and str(path) in err and f"rows 2 .. {len(lines)}" in err, err


def test_error_colours_run_blue_to_red():
    c = error_colors(np.array([0.0, 1.0]), 1.0)
    assert c[2, 0] > c[0, 0] and c[0, 1] > c[2, 1]  # small: blue; large: red


def test_html_page_is_self_contained(fitted, tmp_path):
    model, c = fitted
    facts = write_html(tmp_path / "scene.html", model, c, row=3)
    html = (tmp_path / "scene.html").read_text()
    assert "MeshCat.Viewer" in html and html.count("data:application/octet-binary;base64,") == facts["commands"]
    assert "http://" not in html.split("<script>")[0] and "src=\"http" not in html


@pytest.mark.skipif(shutil.which("chromium") is None, reason="chromium is not installed (.ci/run installs it)")
def test_page_renders_in_headless_chromium(fitted, tmp_path):
    from PIL import Image
    model, c = fitted
    page = tmp_path / "scene.html"
    write_html(page, model, c, row=3)
    shot = tmp_path / "shot.png"
    cmd = ["chromium", "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
           "--disable-background-networking", "--disable-component-update", "--disable-sync", "--no-first-run",
           f"--user-data-dir={tempfile.mkdtemp()}", "--window-size=1000,700", "--virtual-time-budget=5000",
           f"--screenshot={shot}", page.resolve().as_uri()]
    subprocess.run(cmd, capture_output=True, timeout=180)
    img = np.asarray(Image.open(shot).convert("RGB")).astype(float)
    assert img.std() > 10  # not blank
    r, g_, b = img[..., 0], img[..., 1], img[..., 2]
    orange = (r > 200) & (g_ > 100) & (g_ < 190) & (b < 80)        # the painted gantry
    blue_head = (b > 120) & (r < 90) & (g_ < 130)                   # the rotary head / small errors
    red_vec = (r > 180) & (g_ < 90) & (b < 90)                      # large error vectors
    assert orange.sum() > 500 and blue_head.sum() > 30 and red_vec.sum() > 10


def test_a_terminated_view_takes_its_meshcat_server_with_it(fitted, tmp_path):
    """`vecpin view` stopped by SIGTERM (a `kill`, a closed terminal's SIGHUP is handled
    alike) kills the meshcat server it started, as Ctrl-C does: no server left running."""
    import os
    import signal
    import sys
    import time
    from pathlib import Path
    from vecpin.measurement.campaign import write_campaign
    model, campaign = fitted
    model.save(tmp_path / "m.json")
    write_campaign(tmp_path / "c.csv", campaign, model.machine)
    proc = subprocess.Popen([sys.executable, "-m", "vecpin", "view", str(tmp_path / "m.json"), str(tmp_path / "c.csv")],
                            stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    try:
        lines = [proc.stdout.readline() for _ in range(4)]          # meshcat's own lines, then vecpin's
        assert any("meshcat scene at" in ln for ln in lines), lines  # the scene is up: the server runs
        children = Path(f"/proc/{proc.pid}/task/{proc.pid}/children").read_text().split()
        assert children, "the meshcat server is the view's child process"
        proc.send_signal(signal.SIGTERM)
        proc.wait(timeout=30)
    finally:
        proc.kill()
    deadline = time.time() + 10
    while time.time() < deadline and any(Path(f"/proc/{c}").exists() for c in children):
        time.sleep(0.1)
    left = [c for c in children if Path(f"/proc/{c}").exists()
            and "zombie" not in Path(f"/proc/{c}/status").read_text().lower()]
    for c in left:
        os.kill(int(c), signal.SIGKILL)
    assert not left, f"meshcat server(s) {left} still running after the view was terminated"
