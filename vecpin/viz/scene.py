"""meshcat scenes of a machine, its measured and modelled tool tips, and their errors.

The scene (machine base frame, metres):

* ``/machine``: the URDF's visual geometry, posed at a selected measurement row;
* ``/vecpin/measured``, ``/nominal``, ``/identified``, ``/compensated``: tool tips;
  measured points are mapped into the machine frame through the fitted tracker pose;
* ``/vecpin/errors``: measured minus nominal, ``/vecpin/residuals``: measured minus
  identified, ``/vecpin/compensated``: the model-predicted error left by the
  compensation tables - all drawn from the nominal tip, exaggerated by a factor and
  coloured by size (blue small, red large);
* ``/vecpin/tracker``: the tracker's pose; ``/vecpin/selected``: the selected row.

Every group is a node of meshcat's scene tree, so each can be switched on and off in
the viewer. :class:`RecordingWindow` records the commands instead of sending them to a
server: :func:`static_html` turns them into one self-contained page (no server, port
or subprocess) that can be mailed.
"""
from __future__ import annotations

import warnings
from pathlib import Path

import matplotlib
import meshcat
import meshcat.geometry as g
import meshcat.transformations as tf
import numpy as np
import pinocchio as pin
import umsgpack

from vecpin.fileio import write_text
from vecpin.measurement.campaign import Campaign
from vecpin.kinematics.machine import Machine


def _server_helpers():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from meshcat.servers.zmqserver import VIEWER_ROOT, create_command
    return VIEWER_ROOT, create_command


class RecordingWindow:
    """A meshcat window that keeps the scene's commands (last one per path wins)."""

    web_url = None
    server_proc = None

    def __init__(self):
        self.commands: dict[tuple, bytes] = {}

    def send(self, command) -> None:
        data = command.lower()
        if data["type"] == "delete":
            for key in [k for k in self.commands if k[1].startswith(data["path"])]:
                del self.commands[key]
            return
        key = (data["type"], data["path"], data.get("property"))
        self.commands[key] = umsgpack.packb(data)

    def paths(self, kind: str | None = None) -> list[str]:
        return [k[1] for k in self.commands if kind is None or k[0] == kind]

    def static_html(self, title: str = "vecpin") -> str:
        root, create_command = _server_helpers()
        js = Path(root, "main.min.js").read_text()
        cmds = "".join(create_command(b) for b in self.commands.values())
        return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{title}</title>
<style>body {{margin: 0;}} #meshcat-pane {{width: 100vw; height: 100vh; overflow: hidden;}}
#vecpin-legend {{position: absolute; left: 10px; bottom: 10px; font: 12px sans-serif; background: rgba(255,255,255,0.85);
padding: 6px 8px; border-radius: 4px;}}</style></head>
<body><div id="meshcat-pane"></div>
<div id="vecpin-legend">{title}</div>
<script>{js}</script>
<script>var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
{cmds}</script>
</body></html>
"""


def error_colors(size: np.ndarray, vmax: float) -> np.ndarray:
    """(3, N) RGB in [0, 1] for error sizes (turbo colormap, 0 .. vmax)."""
    cmap = matplotlib.colormaps["turbo"]
    return np.asarray(cmap(np.clip(size / max(vmax, 1e-12), 0, 1)))[:, :3].T


def _segments(start: np.ndarray, vec: np.ndarray, colors: np.ndarray) -> g.LineSegments:
    pos = np.empty((3, 2 * len(start)))
    pos[:, 0::2], pos[:, 1::2] = start.T, (start + vec).T
    col = np.repeat(colors, 2, axis=1)
    return g.LineSegments(g.PointsGeometry(pos.astype(np.float32), col.astype(np.float32)),
                          g.LineBasicMaterial(vertexColors=True, linewidth=2))


def _points(p: np.ndarray, color: np.ndarray | tuple, size: float) -> g.Points:
    col = np.tile(np.asarray(color, float)[:, None], (1, len(p))) if np.ndim(color) == 1 else color
    return g.Points(g.PointsGeometry(p.T.astype(np.float32), col.astype(np.float32)),
                    g.PointsMaterial(size=size))  # meshcat points always use vertex colours


def build_scene(vis: meshcat.Visualizer, model, campaign: Campaign, row: int = 0, exaggerate: float | None = None,
                tables=None) -> dict:
    """Fill ``vis`` with the machine and the campaign's tips and errors. ``model``: a
    fitted error model; ``tables``: a TableSet for the compensated view (optional).
    Returns facts of the scene (exaggeration, largest error, counts)."""
    m: Machine = model.machine
    campaign = campaign.primary()  # the rows the fitted tracker pose describes
    row = min(row, len(campaign) - 1)
    vis.delete()
    _machine_geometry(vis, m, campaign.q[row])
    nominal = m.tool_tip(campaign.q, campaign.tool)
    identified = model.predict(campaign.q, campaign.tool, "machine", features=_features(model, campaign))
    measured = _to_machine(model, campaign.xyz)
    err = measured - nominal
    res = measured - identified
    size = np.linalg.norm(err, axis=1)
    span = float(np.linalg.norm(np.ptp(nominal, axis=0)))
    k = exaggerate if exaggerate is not None else 0.08 * span / max(size.max(), 1e-12)
    vmax = float(size.max())
    root = vis["vecpin"]
    pt = 0.012 * span / 6
    root["nominal"].set_object(_points(nominal, (0.55, 0.55, 0.55), pt))
    root["measured"].set_object(_points(nominal + k * err, error_colors(size, vmax), 1.6 * pt))
    root["identified"].set_object(_points(nominal + k * (identified - nominal), (0.15, 0.35, 0.9), pt))
    root["errors"].set_object(_segments(nominal, k * err, error_colors(size, vmax)))
    root["residuals"].set_object(_segments(identified + (k - 1) * (identified - nominal) * 0, k * res,
                                           error_colors(np.linalg.norm(res, axis=1), vmax)))
    facts = {"exaggeration": k, "max_error_mm": vmax * 1e3, "rows": len(campaign),
             "max_residual_mm": float(np.linalg.norm(res, axis=1).max() * 1e3)}
    if tables is not None:
        from vecpin.compensation.functions import compensated_errors, model_as_actual
        comp = compensated_errors(model_as_actual(model), m, tables, campaign.q, campaign.tool)
        csize = np.linalg.norm(comp, axis=1)
        root["compensated"].set_object(_segments(nominal, k * comp, error_colors(csize, vmax)))
        facts["max_compensated_mm"] = float(csize.max() * 1e3)
    sel = root["selected"]
    sel.set_object(g.Sphere(0.025 * span / 6), g.MeshLambertMaterial(color=0xFFD400))
    sel.set_transform(tf.translation_matrix(nominal[row] + k * err[row]))
    _tracker(root["tracker"], model, span)
    # the viewer orbits the origin: bring the workspace centre there
    centre = 0.5 * (nominal.min(axis=0) + nominal.max(axis=0))
    vis.set_transform(tf.translation_matrix(-centre))
    vis["/Cameras/default/rotated/<object>"].set_property("position", [0.55 * span, 0.4 * span, 0.75 * span])
    vis["/Background"].set_property("top_color", [0.95, 0.96, 0.98])
    vis["/Background"].set_property("bottom_color", [0.75, 0.78, 0.82])
    return facts


def _features(model, campaign):
    if not model.effects:
        return None
    from vecpin.measurement.features import Features
    return Features.from_campaign(campaign)


def _to_machine(model, xyz: np.ndarray) -> np.ndarray:
    """Tracker-frame points into the machine frame through the fitted pose and E_0."""
    from vecpin.kinematics.so3 import exp3
    s = model.setup_
    p = (xyz - s.t) @ s.R  # R^T (y - t)
    return (p - s.e0[:3]) @ exp3(s.e0[3:])


def _machine_geometry(vis, m: Machine, q: np.ndarray) -> None:
    from pinocchio.visualize import MeshcatVisualizer
    visual = pin.buildGeomFromUrdfString(m.model, m.urdf_xml, pin.GeometryType.VISUAL)
    viz = MeshcatVisualizer(m.model, pin.GeometryModel(), visual)
    viz.initViewer(viewer=vis)
    viz.loadViewerModel(rootNodeName="machine")
    viz.display(m.full_q(q))


def _tracker(node, model, span: float) -> None:
    from vecpin.kinematics.so3 import exp3
    s = model.setup_
    R = exp3(s.e0[3:]).T @ s.R.T  # tracker axes in the machine frame
    pos = _to_machine(model, np.zeros((1, 3)))[0]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, pos
    node.set_transform(T)
    node["head"].set_object(g.Sphere(0.04 * span / 6), g.MeshLambertMaterial(color=0xD0D0D0))
    node["stand"].set_object(g.Cylinder(0.6, 0.01 * span / 6), g.MeshLambertMaterial(color=0x404040))
    node["stand"].set_transform(tf.translation_matrix([0, 0, -0.3]) @ tf.rotation_matrix(np.pi / 2, [1, 0, 0]))
    node["axes"].set_object(g.triad(0.3))


def write_html(path: str | Path, model, campaign: Campaign, row: int = 0, exaggerate: float | None = None,
               tables=None) -> dict:
    """A self-contained scene page (no server needed)."""
    window = RecordingWindow()
    vis = meshcat.Visualizer(window=window)
    facts = build_scene(vis, model, campaign, row, exaggerate, tables)
    title = (f"vecpin: {model.machine.name}, {model.kind} model; errors x{facts['exaggeration']:.0f} "
             f"(largest {facts['max_error_mm']:.3f} mm; blue small, red large); row {row} in yellow")
    write_text(path, window.static_html(title))
    facts["commands"] = len(window.commands)
    return facts


def serve(model, campaign: Campaign, row: int = 0, exaggerate: float | None = None, tables=None,
          ready=None) -> None:
    """Start a meshcat server with the scene and keep it until Ctrl-C; ``ready(url, facts)``
    is called once the scene is up. The server process is killed on the way out."""
    import time
    vis = meshcat.Visualizer()
    try:
        facts = build_scene(vis, model, campaign, row, exaggerate, tables)
        if ready:
            ready(vis.url(), facts)
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        return
    finally:
        if vis.window.server_proc is not None:
            vis.window.server_proc.kill()
