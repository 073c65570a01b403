"""meshcat scenes of a machine, its measured and modelled tool tips, and their errors.

The scene (machine base frame, metres):

* ``/machine``: the URDF's visual geometry, posed at a selected measurement row;
* ``/vecpin/measured``, ``/nominal``, ``/identified``, ``/compensated``: tool tips;
  measured points are mapped into the machine frame through the fitted tracker pose;
* ``/vecpin/errors``: measured minus nominal, ``/vecpin/residuals``: measured minus
  identified, ``/vecpin/compensated``: the model-predicted error left by the
  compensation tables - all drawn from the nominal tip, each group exaggerated by its
  own factor and coloured by size on one scale, the run's tip error (blue 0, red the
  largest vector of any group, or the report's scale: :mod:`vecpin.viz.scales`);
  one group is visible at a time (meshcat's ``visible`` property);
* ``/vecpin/tracker``: the tracker's pose; ``/vecpin/selected``: the selected row.

Every group is a node of meshcat's scene tree, so each can be switched on and off in
the viewer. :class:`RecordingWindow` records the commands instead of sending them to a
server: :func:`static_html` turns them into one self-contained page (no server, port
or subprocess) that can be mailed; its overlay lists the groups (one shown at a time)
with their exaggeration and a colour bar in mm.
"""
from __future__ import annotations

import html
import json
import re
import warnings
from pathlib import Path

import meshcat
import meshcat.geometry as g
import meshcat.transformations as tf
import numpy as np
import pinocchio as pin
import umsgpack

from vecpin.fileio import write_text
from vecpin.measurement.campaign import Campaign
from vecpin.kinematics.machine import Machine
from vecpin.units import MM_PER_M, M_PER_MM
from vecpin.viz.scales import TIP_ERROR, ColourScale, tip_error_scale


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

    def static_html(self, title: str = "vecpin", legend: str | None = None) -> str:
        """One self-contained page with the recorded scene; ``legend``: HTML of an overlay
        (default: the title in a box)."""
        root, create_command = _server_helpers()
        js = Path(root, "main.min.js").read_text()
        cmds = "".join(create_command(b) for b in _renumbered(list(self.commands.values())))
        overlay = legend if legend is not None else f'<div id="vecpin-legend">{html.escape(title)}</div>'
        return f"""<!DOCTYPE html>
<html><head><meta charset="utf-8"><title>{html.escape(title)}</title>
<style>body {{margin: 0;}} #meshcat-pane {{width: 100vw; height: 100vh; overflow: hidden;}}
#vecpin-legend {{position: absolute; left: 10px; top: 10px; font: 12px sans-serif; background: rgba(255,255,255,0.92);
padding: 8px 10px; border-radius: 4px; max-width: 380px; border: 1px solid #888;}}
#vecpin-legend .bar {{width: 260px; height: 14px; border: 1px solid #444; margin-top: 4px;}}
#vecpin-legend .ticks {{width: 262px; display: flex; justify-content: space-between; font-size: 11px;}}
#vecpin-legend label {{display: block; margin: 2px 0;}}</style></head>
<body><div id="meshcat-pane"></div>
{overlay}
<script>{js}</script>
<script>var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
{cmds}</script>
</body></html>
"""


_UUID = re.compile(rb"[0-9a-f]{8}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{4}-[0-9a-f]{12}")


def _renumbered(commands: list[bytes]) -> list[bytes]:
    """The commands with meshcat's time-based object uuids replaced, in order of first
    appearance, by fixed ones of the same length (msgpack stays valid): the same scene
    gives the same page."""
    seen: dict[bytes, bytes] = {}

    def fixed(m: re.Match) -> bytes:
        return seen.setdefault(m.group(0), f"00000000-0000-4000-8000-{len(seen):012x}".encode())
    return [_UUID.sub(fixed, c) for c in commands]


def error_colors(size: np.ndarray, vmax: float) -> np.ndarray:
    """(3, N) RGB in [0, 1] for error sizes (the tip error's colormap, 0 .. vmax)."""
    return ColourScale(TIP_ERROR, "mm", vmax).rgb(size)


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


GROUPS = {  # group -> (legend text, scene nodes it shows)
    "errors": ("measured − nominal (uncompensated errors), with measured and identified tips",
               ("errors", "measured", "identified")),
    "residuals": ("measured − identified (model residuals)", ("residuals",)),
    "compensated": ("error left by the compensation tables (model-predicted)", ("compensated",)),
}


NEGLIGIBLE = 0.01   # a compensated error below this share of the largest error is drawn at the errors' scale


def _exaggeration(exaggerate, group: str, span: float, largest: float) -> float:
    if isinstance(exaggerate, dict) and group in exaggerate:
        return float(exaggerate[group])
    if isinstance(exaggerate, (int, float)):
        return float(exaggerate)
    return 0.08 * span / max(largest, 1e-12)  # the largest vector: 8 % of the workspace


def scene_vectors(model, campaign: Campaign, tables=None) -> tuple[np.ndarray, np.ndarray, dict]:
    """(nominal tips, identified tips (N, 3) [m], {group: vectors (N, 3) [m]}) the scene
    draws for the campaign's station-0 rows, machine base frame."""
    m: Machine = model.machine
    from vecpin.measurement.registration import check_same_pose, station0
    campaign = station0(campaign)  # the rows the fitted tracker pose describes
    check_same_pose(m.tool_tip(campaign.q, campaign.tool, frame="base"), model.predict_nominal(campaign.q, campaign.tool),
                    campaign.xyz, campaign.source, "the model", campaign.lines)
    nominal = m.tool_tip(campaign.q, campaign.tool, frame="base")
    identified = model.predict_tip(campaign.q, campaign.tool, "machine", features=_features(model, campaign))
    measured = to_machine_frame(model, campaign.xyz)
    vectors = {"errors": measured - nominal, "residuals": measured - identified}
    if tables is not None:
        from vecpin.compensation.frame import model_as_actual
        from vecpin.compensation.report import compensated_errors
        vectors["compensated"] = compensated_errors(model_as_actual(model), m, tables, campaign.q, campaign.tool)
    return nominal, identified, vectors


def build_scene(vis: meshcat.Visualizer, model, campaign: Campaign, row: int | None = None, exaggerate=None,
                tables=None, show: str = "errors", scale: ColourScale | None = None) -> dict:
    """Fill ``vis`` with the machine and the campaign's tips and errors, the machine posed
    at ``row`` (the campaign file's row as messages count it, header = 1; None: its first
    tracker row of station 0). ``model``: a fitted error model; ``tables``: a TableSet
    for the compensated view (optional).

    Each vector group (:data:`GROUPS`) has its own exaggeration (``exaggerate``: one
    factor for all, {group: factor}, or None: the group's largest vector drawn at 8 %
    of the workspace); every group is coloured on one scale, the run's tip error
    (``scale``: the report's, shared with its grid plots; None: 0 .. the largest vector of
    any group), so a colour is one size in every group; only the group ``show`` is visible
    at first. Returns facts of the scene, with ``scale`` and ``groups``: [{name, label,
    exaggeration, max_mm, scale_mm (the colour scale's top), visible}]. A compensated error
    below :data:`NEGLIGIBLE` of the largest error is drawn at the errors' exaggeration:
    numerical noise is not magnified into a machine."""
    m: Machine = model.machine
    from vecpin.measurement.registration import station0
    at = _scene_row(campaign, row)  # index of the posed row among those drawn
    nominal, identified, vectors = scene_vectors(model, campaign, tables)
    campaign = station0(campaign)
    err = vectors["errors"]
    if show not in vectors:
        from vecpin.errors import InputError
        raise InputError(f"`show` {show}: one of {', '.join(vectors)}")
    scale = scale or tip_error_scale(*(np.linalg.norm(v, axis=1) * MM_PER_M for v in vectors.values()))
    vis.delete()
    notes = _machine_geometry(vis, m, campaign.q[at], mesh_dirs(model))
    span = float(np.linalg.norm(np.ptp(nominal, axis=0)))
    root = vis["vecpin"]
    pt = 0.012 * span / 6
    groups = []
    for name, vec in vectors.items():
        size = np.linalg.norm(vec, axis=1)
        vmax = float(size.max())
        k = _exaggeration(exaggerate, name, span, vmax)
        if name == "compensated" and groups and vmax < NEGLIGIBLE * groups[0]["max_mm"] * M_PER_MM and not (
                isinstance(exaggerate, (int, float)) or (isinstance(exaggerate, dict) and name in exaggerate)):
            k = groups[0]["exaggeration"]   # nothing left: the errors' exaggeration
        col = scale.rgb(size * MM_PER_M)
        root[name].set_object(_segments(nominal, k * vec, col))
        if name == "errors":
            root["measured"].set_object(_points(nominal + k * err, col, 1.6 * pt))
            root["identified"].set_object(_points(nominal + k * (identified - nominal), (0.15, 0.35, 0.9), pt))
        for node in GROUPS[name][1]:
            root[node].set_property("visible", name == show)
        groups.append({"name": name, "label": GROUPS[name][0], "exaggeration": k, "max_mm": vmax * MM_PER_M,
                       "scale_mm": scale.top, "visible": name == show})
    root["nominal"].set_object(_points(nominal, (0.55, 0.55, 0.55), pt))
    g0 = groups[0]
    facts = {"exaggeration": g0["exaggeration"], "max_error_mm": g0["max_mm"], "rows": len(campaign),
             "max_residual_mm": groups[1]["max_mm"], "groups": groups, "row": int(campaign.lines[at]),
             "notes": notes, "scale": scale.as_dict()}
    if tables is not None:
        facts["max_compensated_mm"] = groups[2]["max_mm"]
    sel = root["selected"]
    sel.set_object(g.Sphere(0.025 * span / 6), g.MeshLambertMaterial(color=0xFFD400))
    sel.set_transform(tf.translation_matrix(nominal[at] + g0["exaggeration"] * err[at]))
    _tracker(root["tracker"], model, span)
    # the viewer orbits the origin: bring the workspace centre there
    centre = 0.5 * (nominal.min(axis=0) + nominal.max(axis=0))
    vis.set_transform(tf.translation_matrix(-centre))
    vis["/Cameras/default/rotated/<object>"].set_property("position", _camera(model, centre, span))
    vis["/Background"].set_property("top_color", [0.95, 0.96, 0.98])
    vis["/Background"].set_property("bottom_color", [0.75, 0.78, 0.82])
    return facts


def _gradient_css(n: int = 11) -> str:
    cols = error_colors(np.linspace(0, 1, n), 1.0).T
    stops = ", ".join(f"rgb({int(r * 255)},{int(g_ * 255)},{int(b * 255)}) {100 * k / (n - 1):.0f}%"
                      for k, (r, g_, b) in enumerate(cols))
    return f"linear-gradient(to right, {stops})"


def legend_html(title: str, groups: list[dict]) -> str:
    """The overlay of a static scene: the groups as radio buttons (one shown at a time),
    each with its exaggeration and a colour bar in mm; always-shown items listed."""
    grad = _gradient_css()
    rows, bars = [], []
    for gr in groups:
        checked = " checked" if gr["visible"] else ""
        rows.append(f'<label><input type="radio" name="vecpin-group" value="{gr["name"]}"{checked} '
                    f'onchange="vecpinShow(this.value)"> {html.escape(gr["label"])}, '
                    f'×{gr["exaggeration"]:.0f}</label>')
        vmax = gr.get("scale_mm", gr["max_mm"])   # the colour scale's top (a negligible group: the errors')
        bars.append(f'<div class="vecpin-bar" id="vecpin-bar-{gr["name"]}" style="display:'
                    f'{"block" if gr["visible"] else "none"}"><div>colour: length of the {gr["name"]} vectors [mm]'
                    f'</div><div class="bar" style="background: {grad};"></div><div class="ticks"><span>0</span>'
                    f'<span>{vmax / 2:.3f}</span><span>{vmax:.3f} mm</span></div></div>')
    nodes = {gr["name"]: [f"meshcat/vecpin/{n}".split("/") for n in GROUPS[gr["name"]][1]] for gr in groups}
    script = f"""<script>var vecpinNodes = {json.dumps(nodes)};
function vecpinShow(name) {{
  for (const g in vecpinNodes) {{
    for (const p of vecpinNodes[g]) {{ viewer.set_property(p, "visible", g === name); }}
    document.getElementById("vecpin-bar-" + g).style.display = (g === name) ? "block" : "none";
  }}
  viewer.set_dirty();  // the viewer draws only when told that something changed
}}</script>"""
    return (f'<div id="vecpin-legend"><div><b>{html.escape(title)}</b></div><div>show one group:</div>'
            + "".join(rows) + "".join(bars) +
            '<div style="margin-top:4px;color:#444">always shown: nominal tips (grey), the selected row (yellow), '
            "the tracker (grey sphere with axes)</div></div>" + script)


def _features(model, campaign):
    if not model.effects:
        return None
    from vecpin.measurement.features import Features
    return Features.from_campaign(campaign)


def to_machine_frame(model, xyz: np.ndarray) -> np.ndarray:
    """Tracker-frame points (N,3) [m] into the machine frame through the fitted pose and E_0."""
    from vecpin.kinematics.so3 import exp3
    s = model.setup_
    p = (xyz - s.t) @ s.R  # R^T (y - t)
    return (p - s.e0[:3]) @ exp3(s.e0[3:])


MESH_PARENTS = 3  # parent folders of a URDF's folder searched for the package of a package:// mesh


def mesh_dirs(model) -> list[Path]:
    """Folders a relative mesh of the model's URDF is looked for in: the URDF's own folder
    (a machine loaded from a file), the folder recorded in the model file, the model
    file's folder."""
    m = model.machine
    dirs = [m.urdf_path.parent] if m.urdf_path is not None else []
    return dirs + [Path(d) for d in getattr(model, "mesh_dirs_", [])]


def resolve_meshes(urdf_xml: str, dirs: list[Path]) -> tuple[str, list[str]]:
    """The URDF with every visual mesh file name made absolute where the file is found
    (relative to ``dirs``; ``package://PKG/...`` under a folder or its PKG subfolder, or
    under a parent folder up to :data:`MESH_PARENTS` levels up that is PKG or holds it), and
    every visual whose mesh is found nowhere left out. Returns (URDF text, missing files)."""
    import xml.etree.ElementTree as ET
    if "<mesh" not in urdf_xml:
        return urdf_xml, []
    root = ET.fromstring(urdf_xml)
    missing: list[str] = []
    for link in root.iter("link"):
        for vis_el in list(link.findall("visual")):
            mesh = vis_el.find("geometry/mesh")
            if mesh is None:
                continue
            name = mesh.get("filename", "")
            found = _find_mesh(name, dirs)
            if found is None:
                missing.append(name)
                link.remove(vis_el)
            else:
                mesh.set("filename", str(found))
    return ET.tostring(root, encoding="unicode"), missing


def _find_mesh(name: str, dirs: list[Path]) -> Path | None:
    if name.startswith("file://"):
        name = name[len("file://"):]
    tries: list[Path] = []
    if name.startswith("package://"):
        pkg, _, rest = name[len("package://"):].partition("/")
        for d in dirs:  # the package folder beside the URDF, or the URDF inside it (ROS: PKG/urdf/x.urdf)
            tries += [d / rest, d / pkg / rest]
            for a in [d, *list(d.parents)[:MESH_PARENTS]]:
                tries += [a / rest] if a.name == pkg else []
                tries += [a.parent / pkg / rest]
    elif Path(name).is_absolute():
        tries.append(Path(name))
    else:
        tries += [d / name for d in dirs]
    return next((t.resolve() for t in tries if t.is_file()), None)


def _machine_geometry(vis, m: Machine, q: np.ndarray, dirs: list[Path] | None = None) -> list[str]:
    """Draw the machine's visual geometry posed at ``q``; returns notes (meshes left out)."""
    from pinocchio.visualize import MeshcatVisualizer
    xml, missing = resolve_meshes(m.urdf_xml, dirs or [])
    visual = pin.buildGeomFromUrdfString(m.model, xml, pin.GeometryType.VISUAL)
    viz = MeshcatVisualizer(m.model, pin.GeometryModel(), visual)
    viz.initViewer(viewer=vis)
    viz.loadViewerModel(rootNodeName="machine")
    viz.display(m.full_q(q))
    if not missing:
        return []
    where = ", ".join(str(d) for d in dirs) if dirs else "no folder known"
    return [f"drawn without {len(missing)} mesh file(s) not found ({', '.join(sorted(set(missing))[:3])}; looked in "
            f"{where}): put the meshes beside the URDF or the model file"]


def _camera(model, centre: np.ndarray, span: float) -> list[float]:
    """Camera position for meshcat (its Y-up 'rotated' frame, relative to the workspace
    centre): from the tracker's side of the machine, where the tracker sees the tool
    tips (so no column or gantry beam stands between), 30 degrees above the floor, one
    workspace diagonal (at least 1.5 m) away."""
    tracker = to_machine_frame(model, np.zeros((1, 3)))[0]
    d = tracker - centre
    d[2] = 0.0
    n = float(np.linalg.norm(d))
    d = d / n if n > 1e-6 else np.array([0.59, -0.81, 0.0])
    rel = max(span, 1.5) * (np.cos(np.pi / 6) * d + np.array([0.0, 0.0, np.sin(np.pi / 6)]))
    return [float(rel[0]), float(rel[2]), float(-rel[1])]  # world (x, y, z) -> meshcat rotated (x, z, -y)


def _tracker(node, model, span: float) -> None:
    from vecpin.kinematics.so3 import exp3
    s = model.setup_
    R = exp3(s.e0[3:]).T @ s.R.T  # tracker axes in the machine frame
    pos = to_machine_frame(model, np.zeros((1, 3)))[0]
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R, pos
    node.set_transform(T)
    node["head"].set_object(g.Sphere(0.04 * span / 6), g.MeshLambertMaterial(color=0xD0D0D0))
    node["stand"].set_object(g.Cylinder(0.6, 0.01 * span / 6), g.MeshLambertMaterial(color=0x404040))
    node["stand"].set_transform(tf.translation_matrix([0, 0, -0.3]) @ tf.rotation_matrix(np.pi / 2, [1, 0, 0]))
    node["axes"].set_object(g.triad(0.3))


def _scene_row(campaign: Campaign, row: int | None) -> int:
    """The index among the campaign's station-0 tracker rows (the rows the scene draws)
    of its row ``row``, counted as every message counts rows: the line of the campaign
    file (the header is row 1, the first measurement row 2; a campaign made in memory
    counts alike). None: the first row the scene draws. A row outside the file, or one
    the scene does not draw, is refused naming the file and the rows there are."""
    from vecpin.errors import InputError
    from vecpin.measurement.registration import station0
    sub = station0(campaign)
    if row is None:
        return 0
    first, last = int(campaign.lines.min()), int(campaign.lines.max())
    if not first <= row <= last:
        raise InputError(f"`row` {row}: {campaign.source} has rows {first} .. {last} (rows as its messages count them: "
                         "the header is row 1)")
    hit = np.flatnonzero(sub.lines == row)
    if hit.size == 0:
        what = "is not a measurement row (a blank line?)" if row not in campaign.lines else \
            "is not a tracker row of station 0"
        raise InputError(f"`row` {row}: row {row} of {campaign.source} {what}; the scene draws the tracker rows of "
                         f"station 0, e.g. `row` {int(sub.lines[0])}")
    return int(hit[0])


def write_html(path: str | Path, model, campaign: Campaign, row: int | None = None, exaggerate=None,
               tables=None, show: str = "errors", scale: ColourScale | None = None) -> dict:
    """A self-contained scene page (no server needed) with the legend and colour bars
    (``scale``: the run's tip-error scale, see :func:`build_scene`)."""
    window = RecordingWindow()
    vis = meshcat.Visualizer(window=window)
    facts = build_scene(vis, model, campaign, row, exaggerate, tables, show, scale)
    title = f"vecpin: {model.machine.name}, {model.kind} model, row {facts['row']} posed"
    write_text(path, window.static_html(title, legend_html(title, facts["groups"])))
    facts["commands"] = len(window.commands)
    return facts


def legend_lines(facts: dict) -> list[str]:
    """The legend as text (for the live server, whose page has no overlay)."""
    out = []
    for gr in facts["groups"]:
        top = gr.get("scale_mm", gr["max_mm"])
        same = " (one scale for every group)"
        out.append(f"  /vecpin/{gr['name']:<12s} {gr['label']}: x{gr['exaggeration']:.0f}, colour 0 .. "
                   f"{top:.3f} mm (blue .. red){same}{'  [shown]' if gr['visible'] else ''}")
    out += [f"  note: {n}" for n in facts.get("notes", [])]
    return out


def serve(model, campaign: Campaign, row: int | None = None, exaggerate=None, tables=None,
          ready=None, show: str = "errors") -> None:
    """Start a meshcat server with the scene and keep it until Ctrl-C (or a SIGTERM or
    SIGHUP: a closed terminal, ``kill``); ``ready(url, facts)`` is called once the scene
    is up. The server process is killed on the way out, whichever way that is."""
    import signal
    import time

    def stop(signum, frame):
        raise KeyboardInterrupt
    caught = [s for s in (signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s is not None]
    before = {s: signal.signal(s, stop) for s in caught}
    vis = meshcat.Visualizer()
    try:
        facts = build_scene(vis, model, campaign, row, exaggerate, tables, show)
        if ready:
            ready(vis.url(), facts)
        while True:
            time.sleep(3600)
    except KeyboardInterrupt:
        return
    finally:
        if vis.window.server_proc is not None:
            vis.window.server_proc.kill()
            vis.window.server_proc.wait()
        for s, handler in before.items():
            signal.signal(s, handler)
