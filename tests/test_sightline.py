"""Line of sight past the machine's URDF geometry: cases whose answer is known by hand,
the segment tests against coal's (hpp-fcl's) own distance queries, a mesh against the
box it describes, and the bundled gantry."""
import numpy as np
import pytest

from vecpin import Machine
from vecpin.planning.sightline import (SightLine, _segment_box, _segment_cylinder, _segment_sphere,
                                       _segment_triangles, solids_from_urdf)

# a gantry X (along x) - Y - Z with the spindle pointing down (-z). Fixed obstacles on the base:
# a wall 0.95 < x < 1.05, -0.5 < y < 0.5, 0 < z < 1; a sphere r 0.2 at (1, 2, 0.5); a cylinder r 0.1
# along x (rpy about y by 90 deg) centred (1, -2, 0.5), length 0.4. Moving: a box 0.2 on the X carriage at z = 2.
URDF = """<robot name="los_test">
  <link name="base">
    <visual><origin xyz="1.0 0 0.5"/><geometry><box size="0.1 1.0 1.0"/></geometry></visual>
    <visual><origin xyz="1.0 2.0 0.5"/><geometry><sphere radius="0.2"/></geometry></visual>
    <visual><origin xyz="1.0 -2.0 0.5" rpy="0 1.5707963267948966 0"/><geometry><cylinder radius="0.1" length="0.4"/></geometry></visual>
  </link>
  <joint name="X" type="prismatic"><parent link="base"/><child link="xc"/><axis xyz="1 0 0"/>
    <limit lower="-1" upper="4" effort="1" velocity="1"/></joint>
  <link name="xc"><visual><origin xyz="0 0 2"/><geometry><box size="0.2 0.2 0.2"/></geometry></visual></link>
  <joint name="Y" type="prismatic"><parent link="xc"/><child link="yc"/><axis xyz="0 1 0"/>
    <limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <link name="yc"/>
  <joint name="Z" type="prismatic"><parent link="yc"/><child link="spindle"/><axis xyz="0 0 1"/>
    <limit lower="0" upper="3" effort="1" velocity="1"/></joint>
  <link name="spindle"/>
</robot>"""


@pytest.fixture(scope="module")
def rig():
    m = Machine.from_urdf_string(URDF, "los_test")
    return m, SightLine(m, np.array([-1.0, 0.0, 0.5]), tool_radius=0.0, target_clearance=0.0)


def _tip_q(points, tool=0.0):
    """Commands putting the tool tip (tool along -z) at the points."""
    p = np.atleast_2d(points).astype(float)
    return np.c_[p[:, 0], p[:, 1], p[:, 2] + tool]


def test_known_cases(rig):
    m, sl = rig
    targets = np.array([
        [2.0, 0.0, 0.5],    # straight through the wall
        [0.5, 0.0, 0.5],    # in front of the wall
        [2.0, 1.6, 0.5],    # at x = 1 the line is at y = 1.07: beside the wall
        [2.0, 1.4, 0.5],    # at x = 0.95..1.05 the line is at y = 0.91..0.96: beside the wall
        [2.0, 0.7, 0.5],    # at x = 0.95 the line is at y = 0.455 < 0.5: clips the wall's edge
        [2.0, 0.0, 1.6],    # at x = 0.95 the line is at z = 1.0 + 0.2 ... above the wall? no: z = 0.5 + 1.95*1.1/3
        [3.0, 4.0, 0.5],    # the line from (-1,0,.5) to (3,4,.5) passes (1,2,.5): the sphere's centre
        [3.0, -4.0, 0.5],   # through the cylinder's axis point (1,-2,.5)
        [3.0, -4.0, 0.75],  # at x = 1 the line is at z = 0.625: outside r = 0.1 of the cylinder axis
    ])
    # z at the wall for the 6th target: z(x) = 0.5 + (x + 1)/3 * 1.1 -> 1.215 at x = 0.95: above the wall top (1.0)
    expected = [True, False, False, False, True, False, True, True, False]
    res = sl.check(_tip_q(targets), 0.0)
    assert list(res.blocked) == expected
    assert res.by[0] == "base_0" and res.by[6] == "base_1" and res.by[7] == "base_2"
    np.testing.assert_allclose(res.distance[0], 3.0)


def test_posed_geometry_agrees_with_coal(rig):
    """Random commands: the answer of the posed URDF (fixed wall, sphere, cylinder and the
    box riding on the X carriage at (X, 0, 2)) against coal's distances of the same shapes
    placed by hand."""
    import coal
    m, sl = rig
    rng = np.random.default_rng(11)
    q = np.c_[rng.uniform(-1, 4, 300), rng.uniform(-3, 3, 300), rng.uniform(0, 3, 300)]
    res = sl.check(q, 0.0)
    R_cyl = np.array([[0, 0, 1.0], [0, 1.0, 0], [-1.0, 0, 0]])  # rpy (0, pi/2, 0): local z along base x
    shapes = [(coal.Box(0.1, 1.0, 1.0), np.eye(3), lambda x: np.array([1.0, 0, 0.5])),
              (coal.Sphere(0.2), np.eye(3), lambda x: np.array([1.0, 2.0, 0.5])),
              (coal.Cylinder(0.1, 0.4), R_cyl, lambda x: np.array([1.0, -2.0, 0.5])),
              (coal.Box(0.2, 0.2, 0.2), np.eye(3), lambda x: np.array([x, 0.0, 2.0]))]
    expected, clear = np.zeros(len(q), bool), np.ones(len(q), bool)
    for i, qi in enumerate(q):
        tip = qi.copy()  # tool 0: the tip is the spindle origin (X, Y, Z)
        for shape, R, centre in shapes:
            p0, p1 = (sl.tracker - centre(qi[0])) @ R, (tip - centre(qi[0])) @ R  # the segment in the shape's frame
            d = _coal_distance(shape, p0, p1)
            clear[i] &= abs(d) > 1e-6
            expected[i] |= d <= 0
    assert clear.sum() > 290 and 0.05 < expected.mean() < 0.95
    np.testing.assert_array_equal(res.blocked[clear], expected[clear])


def test_carriage_box_blocks_when_between(rig):
    m, _ = rig
    # a tracker above the carriage box at (X, 0, 2) looks down on a tip under it
    above = SightLine(m, np.array([0.5, 0.0, 5.0]), tool_radius=0.0, target_clearance=0.0)
    res = above.check(np.array([[0.5, 0.0, 1.0], [0.5, 0.6, 1.0], [3.0, 0.0, 1.0]]), 0.0)
    assert list(res.blocked) == [True, False, False] and res.by[0] == "xc_0"


def test_target_clearance_and_tool_holder(rig):
    m, _ = rig
    # tracker straight above the tip: the holder (a cylinder from the gauge line down to the tip) is in the way
    tip = np.array([2.0, 1.0, 1.5])  # off the carriage box at (2, 0, 2)
    tool = 0.3
    q = _tip_q(tip, tool)
    from_above = SightLine(m, tip + np.array([0, 0, 3.0]), tool_radius=0.01, target_clearance=0.019)
    from_side = SightLine(m, tip + np.array([0, 3.0, 0.0]), tool_radius=0.01, target_clearance=0.019)
    assert from_above.check(q, tool).by[0] == "tool holder"
    assert not from_side.check(q, tool).blocked[0]
    no_holder = SightLine(m, tip + np.array([0, 0, 3.0]), tool_radius=0.0, target_clearance=0.019)
    assert not no_holder.check(q, tool).blocked[0]


def test_tracker_inside_fixed_geometry_is_reported(rig):
    m, _ = rig
    assert SightLine(m, np.array([1.0, 0.0, 0.5])).inside_fixed() == ["base_0"]
    assert SightLine(m, np.array([1.0, 2.05, 0.5])).inside_fixed() == ["base_1"]
    assert SightLine(m, np.array([-1.0, 0.0, 0.5])).inside_fixed() == []


def _coal_distance(shape, p0, p1):
    import coal
    d = p1 - p0
    L = np.linalg.norm(d)
    z = d / L
    x = np.cross(z, [1.0, 0, 0]) if abs(z[0]) < 0.9 else np.cross(z, [0, 1.0, 0])
    x /= np.linalg.norm(x)
    R = np.c_[x, np.cross(z, x), z]
    cap = coal.Capsule(1e-9, L)
    return coal.distance(cap, coal.Transform3s(R, (p0 + p1) / 2), shape, coal.Transform3s(),
                         coal.DistanceRequest(), coal.DistanceResult())


def test_segment_primitives_agree_with_coal():
    """Independent truth: coal's signed distance between a thin capsule along the
    segment and the shape (negative or zero: they meet)."""
    import coal
    rng = np.random.default_rng(7)
    p0 = rng.uniform(-1.5, 1.5, (400, 3))
    p1 = rng.uniform(-1.5, 1.5, (400, 3))
    half = np.array([0.3, 0.5, 0.2])
    cases = [(coal.Box(*(2 * half)), _segment_box(p0, p1, half)),
             (coal.Cylinder(0.4, 1.0), _segment_cylinder(p0, p1, np.full(400, 0.4), np.full(400, 0.5))),
             (coal.Sphere(0.6), _segment_sphere(p0, p1, 0.6))]
    for shape, mine in cases:
        dist = np.array([_coal_distance(shape, a, b) for a, b in zip(p0, p1)])
        clear = np.abs(dist) > 1e-6
        assert clear.sum() > 380
        np.testing.assert_array_equal(mine[clear], dist[clear] <= 0)
        assert 0.1 < mine.mean() < 0.9  # both answers occur


def test_mesh_behaves_as_the_box_it_describes(tmp_path):
    """An STL cube loaded through the URDF (Pinocchio/assimp, with a scale) blocks exactly
    the segments the equivalent box blocks."""
    V = np.array([[x, y, z] for x in (-.5, .5) for y in (-.5, .5) for z in (-.5, .5)])
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    stl = ["solid c"]
    for f in faces:
        stl += [" facet normal 0 0 0", "  outer loop"] + [f"   vertex {V[i][0]} {V[i][1]} {V[i][2]}" for i in f] + \
               ["  endloop", " endfacet"]
    (tmp_path / "cube.stl").write_text("\n".join(stl + ["endsolid c"]) + "\n")
    urdf = URDF.replace('<visual><origin xyz="1.0 0 0.5"/><geometry><box size="0.1 1.0 1.0"/></geometry></visual>',
                        '<visual><origin xyz="1.0 0 0.5"/><geometry><mesh filename="cube.stl" scale="0.1 1.0 1.0"/>'
                        '</geometry></visual>')
    (tmp_path / "m.urdf").write_text(urdf)
    m = Machine.load(tmp_path / "m.urdf")
    solids, used = solids_from_urdf(m)
    assert used == "visual" and solids[0].kind == "mesh" and len(solids[0].triangles) == 12
    box_m = Machine.from_urdf_string(URDF, "box")
    rng = np.random.default_rng(3)
    targets = np.c_[rng.uniform(1.1, 3.5, 300), rng.uniform(-1.5, 1.5, 300), rng.uniform(-0.5, 1.5, 300)]
    tr = np.array([-1.0, 0.1, 0.45])
    a = SightLine(m, tr, tool_radius=0, target_clearance=0).check(_tip_q(targets), 0.0)
    b = SightLine(box_m, tr, tool_radius=0, target_clearance=0).check(_tip_q(targets), 0.0)
    np.testing.assert_array_equal(a.blocked, b.blocked)
    assert 0.1 < a.blocked.mean() < 0.9
    assert SightLine(m, np.array([1.0, 0.2, 0.3])).inside_fixed() == [solids[0].name]  # ray parity inside the mesh
    assert _segment_triangles(np.zeros((1, 3)), np.ones((1, 3)) * 5, V[[0]], np.zeros((0, 3), int)).tolist() == [0]


def test_bundled_gantry_front_leg_hides_the_middle(machines):
    """flow_xyzcb with the tracker 2.2 m in front at the middle of X: the front gantry leg
    (x_carriage_1, a box 0.45 x 0.35 m at y -0.55 that moves with X) hides tips only
    where the sight line passes the leg."""
    m = machines["flow_xyzcb"]
    tr = np.array([3.05, -2.2, -0.3])
    sl = SightLine(m, tr)
    rng = np.random.default_rng(0)
    q = m.lower + rng.random((1500, 5)) * (m.upper - m.lower)
    res = sl.check(q, 0.21488)
    leg = res.by == "x_carriage_1"
    assert leg.sum() > 50
    # where the sight line crosses the leg's plane y = -0.55 it must be within the leg's half width
    # (0.225 m) of the carriage position X, allowing for the leg's thickness (0.35 m along y)
    tip = m.tool_tip(q[leg], 0.21488)
    s = (-0.55 - tr[1]) / (tip[:, 1] - tr[1])
    x_cross = tr[0] + s * (tip[:, 0] - tr[0])
    slope = np.abs((tip[:, 0] - tr[0]) / (tip[:, 1] - tr[1]))
    assert np.all(np.abs(x_cross - q[leg, 0]) <= 0.225 + 0.175 * slope + 1e-9)


def test_holder_in_the_geometry_is_a_collision_not_a_sight_loss():
    """The holder's axis from the gauge line to the target meets the wall: a collision,
    whatever the tracker sees; the spindle's own solid (the holder sits in it) never counts."""
    spindle = '<link name="spindle"><visual><origin xyz="0 0 0.1"/><geometry><cylinder radius="0.05" length="0.2"/>' \
              '</geometry></visual></link>'
    m = Machine.from_urdf_string(URDF.replace('<link name="spindle"/>', spindle), "los_test")
    sl = SightLine(m, np.array([-1.0, 3.0, 0.5]), tool_radius=0.0, target_clearance=0.0)
    # spindle at (x, y, z), a 0.5 m holder down to (x, y, z - 0.5)
    q = np.array([[1.0, 0.0, 1.2],    # the holder's lower 0.3 m in the wall: collision
                  [1.0, 0.0, 1.6],    # the tip 0.1 m above the wall: free
                  [0.5, 0.0, 1.2],    # beside the wall: free
                  [1.0, 0.45, 0.7],   # the whole holder inside the wall
                  [3.0, 0.0, 1.0]])   # in the open, only the spindle's own cylinder about the holder
    assert list(sl.collisions(q, 0.5)) == ["base_0", "", "", "base_0", ""]
