"""kernels/collision_polygons.py (MuJoCo's multiCCD: several contacts where two geoms of GJK and EPA's pairs meet face
to face or edge to face) against MuJoCo 4's mj_collision with multiCCD on (its default) and ccd_tolerance 1e-12.

Poses: geom2 resting on geom1's face (a box's top, a mesh's polygon, a cylinder's cap or side) or lying along it (a
capsule, a cylinder's side, a box's edge, a mesh cube on its edge: "-on-edge"), at a random offset, turn about the face's normal and depth, tilted by up to
TILT. What is checked:
- the count equals MuJoCo's at every pose;
- flat (no tilt) and where the features' clipped polygon has at most four vertices, the contacts are MuJoCo's: the
  same positions (as sets) and dists, to 1e-12 m;
- tilted, MuJoCo 4.0 places them differently from MuJoCo 3's multicontact, which warpdyn follows (witnessOnFace: the
  clipped vertex and its drop onto the face): within TILTED_TOL;
- more than four vertices (a cylinder's cap on a face: its rim's 16 points; two turned squares: an octagon): four of
  them, as MuJoCo keeps four, at the clipped polygon's vertices (each on both features) and spread as MuJoCo's
  (the quadrilateral's area at least AREA_SHARE of MuJoCo's);
- float32 against float64, and the tape's gradients of the contacts against central differences.
"""

import mujoco
import numpy as np
import pytest
import warp as wp

from warpdyn.kernels import collision_convex as cc
from warpdyn.kernels import collision_polygons as cpoly
from warpdyn.kernels import collision_primitives as cp
from collision_reference import posed_contacts
from gradcheck import contact_gradient_check
from test_collision_convex import _collide

CUBE = np.array([(x, y, z) for z in (-0.1, 0.1) for y in (-0.1, 0.1) for x in (-0.1, 0.1)])
HEXAGON = np.array([(0.1 * np.cos(a), 0.1 * np.sin(a), z) for z in (-0.05, 0.05) for a in np.arange(6) * np.pi / 3])
TILT = 3e-3
"""[rad] The largest tilt of the poses: a resting geom's (its face's contacts sink unevenly by under a millimetre)."""
TILTED_TOL = 5e-6
"""[m] MuJoCo 4.0's tilted contacts against MuJoCo 3's placement, which warpdyn follows (3.9e-6 at most here)."""
FLAT_TOL = 1e-9
"""[m] Flat: machine precision (1e-15), but along a cylinder's side (MuJoCo's from its EPA's witness: 6e-10)."""
NORMAL_TOL = 1e-9
AREA_SHARE = 0.85
TIED_AREA = 1e-4
"""Relative: QUAD_TIE (1e-5) and float32's rounding of the areas."""
F32_TOL = 2e-5
"""[m] float32's rounding of the poses and of the clipping (about 1e-7 of the poses' metres)."""
ROUND_EDGES = ("cylinder-side-box", "capsule-cylinder", "capsule-cube")
ROUND_RTOL = 2e-3
"""A round side's dist gradient, relative (measured: 1.1e-3 at most at 3 mrad)."""
GRAD_TOL = 1e-6
"""Central differences at 1e-6 of a smooth function: their truncation and rounding (about 1e-8 here)."""

LYING = ' quat="0.7071067811865476 0 0.7071067811865476 0"'  # geom1 turned to lie along x (a cylinder's or capsule's side up)
EDGE_UP = ' quat="0.9238795325112867 0.3826834323650898 0 0"'  # a box or mesh cube turned 45 degrees about x: an edge up, one down
# name: (geom1 XML, geom2 XML, geom2's resting height above geom1's centre, the offsets' range [m])
CASES = {
    "box-cube": ('<geom type="box" size="0.3 0.3 0.1"/>', '<geom type="mesh" mesh="cube"/>', 0.2, 0.1),
    "box-hexagon": ('<geom type="box" size="0.3 0.3 0.1"/>', '<geom type="mesh" mesh="hexagon"/>', 0.15, 0.1),
    "box-edge-cube": (f'<geom type="box" size="0.3 0.05 0.05"{EDGE_UP}/>', '<geom type="mesh" mesh="cube"/>', 0.1 + 0.05 * 2**0.5, 0.05),
    "cube-cube": ('<geom type="mesh" mesh="cube"/>', '<geom type="mesh" mesh="cube"/>', 0.2, 0.1),
    "box-cube-on-edge": ('<geom type="box" size="0.3 0.3 0.1"/>', f'<geom type="mesh" mesh="cube"{EDGE_UP}/>', 0.1 + 0.1 * 2**0.5, 0.1),
    "cube-cube-on-edge": ('<geom type="mesh" mesh="cube"/>', f'<geom type="mesh" mesh="cube"{EDGE_UP}/>', 0.1 + 0.1 * 2**0.5, 0.1),
    "cylinder-box": ('<geom type="cylinder" size="0.2 0.15"/>', '<geom type="box" size="0.3 0.3 0.1"/>', 0.25, 0.1),
    "cylinder-cylinder": ('<geom type="cylinder" size="0.2 0.15"/>', '<geom type="cylinder" size="0.15 0.1"/>', 0.25, 0.1),
    "cylinder-side-box": (f'<geom type="cylinder" size="0.05 0.3"{LYING}/>', '<geom type="box" size="0.2 0.2 0.1"/>', 0.15, 0.1),
    "cylinder-cube": ('<geom type="cylinder" size="0.05 0.2"/>', '<geom type="mesh" mesh="cube"/>', 0.3, 0.03),
    "capsule-cylinder": (f'<geom type="capsule" size="0.05 0.3"{LYING}/>', '<geom type="cylinder" size="0.1 0.2"/>', 0.25, 0.05),
    "capsule-cube": (f'<geom type="capsule" size="0.03 0.3"{LYING}/>', '<geom type="mesh" mesh="cube"/>', 0.13, 0.05),
}
CAP_EDGES = {
    "cylinder-box-on-edge": ('<geom type="cylinder" size="0.2 0.15"/>', f'<geom type="box" size="0.1 0.1 0.1"{EDGE_UP}/>', 0.15 + 0.1 * 2**0.5, 0.05),
    "cylinder-cube-on-edge": ('<geom type="cylinder" size="0.2 0.15"/>', f'<geom type="mesh" mesh="cube"{EDGE_UP}/>', 0.15 + 0.1 * 2**0.5, 0.05),
}
"""A box's or a mesh cube's edge on a cylinder's cap: test_an_edge_on_a_cylinders_cap."""
ASSETS = "".join(f'<mesh name="{name}" vertex="{" ".join(map(str, v.ravel()))}"/>' for name, v in (("cube", CUBE), ("hexagon", HEXAGON)))
N_POSES = 24


def _model(case) -> mujoco.MjModel:
    g1, g2, _, _ = (CASES | CAP_EDGES)[case]
    xml = f"""<mujoco><option gravity="0 0 0" ccd_tolerance="1e-12" ccd_iterations="200"/><asset>{ASSETS}</asset><worldbody>
      <body mocap="true">{g1}</body><body><freejoint/>{g2}</body></worldbody></mujoco>"""
    return mujoco.MjModel.from_xml_string(xml)


def _shapes(m):
    """The kernel's (types (2,), sizes (2, 3), meshes' vertices (2,), meshes' polygons (2,)) of MuJoCo's two geoms."""
    types, sizes, meshes, polygons = [], np.zeros((2, 3)), [None, None], [None, None]
    for g in range(2):
        types.append(int(m.geom_type[g]))
        sizes[g] = m.geom_size[g]
        k = int(m.geom_dataid[g])
        if types[g] == cp.MESH:
            sizes[g] = (m.geom_rbound[g], 0.0, 0.0)
            meshes[g] = np.array(m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]], dtype=np.float64)
            first, count = int(m.mesh_polyadr[k]), int(m.mesh_polynum[k])
            normals = np.array(m.mesh_polynormal[first : first + count], dtype=np.float64)
            indices = [m.mesh_polyvert[m.mesh_polyvertadr[q] : m.mesh_polyvertadr[q] + m.mesh_polyvertnum[q]] for q in range(first, first + count)]
            polygons[g] = (normals, indices)
    return types, sizes, meshes, polygons


def _poses(case, tilt, seed=0):
    """geom2's poses relative to geom1's body (module docstring): resting, offset up to the case's reach, turned, sunk
    0.05 to 1 mm."""
    rng = np.random.default_rng(seed)
    _, _, height, reach = (CASES | CAP_EDGES)[case]
    poses = []
    for _ in range(N_POSES):
        yaw, axis = rng.uniform(0, 2 * np.pi), np.append(rng.normal(size=2), 0.0)
        t = rng.uniform(0, tilt)
        q = np.zeros(4)
        mujoco.mju_mulQuat(q, np.array([np.cos(yaw / 2), 0, 0, np.sin(yaw / 2)]), np.append(np.cos(t / 2), np.sin(t / 2) * axis / np.linalg.norm(axis)))
        poses.append(((*rng.uniform(-reach, reach, 2), height - rng.uniform(5e-5, 1e-3)), q))
    return poses


def _run(case, tilt, dtype=np.float64, seed=0, requires_grad=False, xpos=None, xmat=None):
    m = _model(case)
    types, sizes, meshes, polygons = _shapes(m)
    contacts = None
    if xpos is None:
        xpos, xmat, contacts = posed_contacts(m, np.random.default_rng(seed), _poses(case, tilt, seed))
    names = [{v: k for k, v in {"box": cp.BOX, "cylinder": cp.CYLINDER, "capsule": cp.CAPSULE, "mesh": cp.MESH}.items()}[t] for t in types]
    out = _collide(tuple(names), xpos, xmat, (sizes, tuple(meshes)), 0.0, dtype, requires_grad=requires_grad, polygons=tuple(polygons))
    return xpos, xmat, contacts, out


def _area(points):
    """The area of the quadrilateral of four points, ordered about their centroid in their plane [m^2]."""
    c = points.mean(0)
    normal = np.linalg.svd(points - c)[2][2]
    u = np.linalg.svd(points - c)[2][0]
    v = np.cross(normal, u)
    xy = np.stack([(points - c) @ u, (points - c) @ v], 1)
    xy = xy[np.argsort(np.arctan2(xy[:, 1], xy[:, 0]))]
    return 0.5 * abs(np.sum(xy[:, 0] * np.roll(xy[:, 1], -1) - np.roll(xy[:, 0], -1) * xy[:, 1]))


@pytest.mark.parametrize("tilt", [0.0, TILT], ids=["flat", "tilted"])
@pytest.mark.parametrize("case", list(CASES))
def test_contacts_equal_mujocos(case, tilt):
    """The module docstring's checks against MuJoCo."""
    _, _, contacts, (_, count, pos, frame, dist) = _run(case, tilt)
    count, pos, normal, dist = count.numpy(), pos.numpy(), frame.numpy()[..., 0, :], dist.numpy()
    near = FLAT_TOL if tilt == 0 else TILTED_TOL
    matched, worst_gap, worst_dist = 0, 0.0, 0.0
    for i, (mj_pos, mj_frame, mj_dist) in enumerate(contacts):
        assert count[i] == len(mj_dist), (i, count[i], len(mj_dist))
        ours = pos[i, : count[i]]
        gap = np.array([np.linalg.norm(ours - p, axis=1).min() for p in mj_pos])
        np.testing.assert_allclose(normal[i, : count[i]], np.broadcast_to(mj_frame[0, 0], (count[i], 3)), atol=NORMAL_TOL)
        if gap.max() <= near:
            matched += 1
            order = [int(np.linalg.norm(ours - p, axis=1).argmin()) for p in mj_pos]
            worst_gap, worst_dist = max(worst_gap, gap.max()), max(worst_dist, np.abs(dist[i, order] - mj_dist).max())
            assert np.abs(dist[i, order] - mj_dist).max() <= near, i
        else:  # a polygon of more than four vertices: MuJoCo keeps another quadrilateral of it
            assert count[i] == 4, (i, gap, ours, mj_pos)
            assert _area(ours) >= AREA_SHARE * _area(mj_pos), (i, _area(ours), _area(mj_pos))
    print(case, f"tilt {tilt}: {count.sum()} contacts, {matched} of {len(contacts)} poses MuJoCo's (to {worst_gap:.1e} m, dists {worst_dist:.1e} m)")


@pytest.mark.parametrize("case", list(CAP_EDGES))
def test_an_edge_on_a_cylinders_cap(case):
    """An edge on a cylinder's cap keeps its two ends (those at or below the cap) wherever it lies within EDGE_TOL of
    the cap, as an edge on a box's or a mesh's face does and a capsule on a cap does in MuJoCo: flat, the contacts
    are MuJoCo's; tilted, MuJoCo 4.0 gives one contact (its EPA's: only an exactly flat edge gets two there, one
    already at a tilt of 1e-9 rad), which is warpdyn's deepest, and warpdyn keeps the other end too where it is below
    the cap."""
    _, _, contacts, (_, count, pos, _, dist) = _run(case, 0.0)
    count, pos, dist = count.numpy(), pos.numpy(), dist.numpy()
    for i, (mj_pos, _, mj_dist) in enumerate(contacts):
        assert count[i] == len(mj_dist) == 2, (i, count[i], len(mj_dist))
        order = [int(np.linalg.norm(pos[i, :2] - p, axis=1).argmin()) for p in mj_pos]
        np.testing.assert_allclose(pos[i, order], mj_pos, atol=FLAT_TOL)
        np.testing.assert_allclose(dist[i, order], mj_dist, atol=FLAT_TOL)
    xpos, xmat, contacts, (_, count, pos, _, dist) = _run(case, TILT)
    count, pos, dist = count.numpy(), pos.numpy(), dist.numpy()
    corners = CUBE.astype(np.float32).astype(np.float64) if "cube" in case else CUBE  # MuJoCo's mesh_vert: float32
    for i, (mj_pos, _, mj_dist) in enumerate(contacts):
        assert len(mj_dist) == 1, (i, len(mj_dist))
        deepest = int(dist[i, : count[i]].argmin())
        np.testing.assert_allclose(pos[i, deepest], mj_pos[0], atol=FLAT_TOL)
        np.testing.assert_allclose(dist[i, deepest], mj_dist[0], atol=FLAT_TOL)
        heights = (xpos[i, 1] + (corners @ xmat[i, 1].T) - xpos[i, 0]) @ xmat[i, 0][:, 2] - 0.15  # the corners' above the cap
        below = np.sort(heights)[:2]  # the edge's two ends
        below = below[below <= 0.0]
        np.testing.assert_allclose(np.sort(dist[i, : count[i]]), below, atol=FLAT_TOL)
    assert (count == 2).sum() >= len(count) // 2, count


@pytest.mark.parametrize("case", list(CASES))
def test_float32_equals_float64(case):
    """float32 (the clipping in float32; GJK and EPA in float64 in both): the same counts, positions and dists to
    F32_TOL; or, where the clipped polygon has more than four vertices and two quadrilaterals are tied but for
    rounding (kernels/collision_polygons.py's QUAD_TIE; a CUDA build's fused multiply-adds round otherwise than the
    CPU's), another quadrilateral of the same area to TIED_AREA."""
    xpos, xmat, _, out64 = _run(case, TILT)
    out32 = _run(case, TILT, dtype=np.float32, xpos=xpos, xmat=xmat)[3]
    (count64, pos64, _, dist64), (count32, pos32, _, dist32) = ([a.numpy() for a in out[1:]] for out in (out64, out32))
    np.testing.assert_array_equal(count32, count64)
    for i in range(len(xpos)):
        k = count64[i]
        gap = np.array([np.linalg.norm(pos64[i, :k] - p, axis=1).min() for p in pos32[i, :k]])
        if gap.max() > F32_TOL:
            assert k == 4 and abs(_area(pos32[i, :4]) - _area(pos64[i, :4])) <= TIED_AREA * _area(pos64[i, :4]), (i, gap)
            continue
        order = [int(np.linalg.norm(pos64[i, :k] - p, axis=1).argmin()) for p in pos32[i, :k]]
        assert np.abs(dist32[i, :k] - dist64[i, order]).max() <= F32_TOL, i


@pytest.mark.parametrize("case", list(CASES))
def test_tape_gradient_equals_finite_differences(case):
    """float64: wp.Tape's gradient of L = sum over the contacts of dist + w1.pos + w2.normal (w1, w2 random) with
    respect to both poses, along a random direction, equals the central difference where the steps keep the counts
    (and the clipped polygon's choice: fd at 1e-6 and 2e-6 agree) to GRAD_TOL: the features held, each point made
    again from them at the poses is exact (kernels/collision_polygons.py). A capsule's or cylinder's side (ROUND_EDGES)
    lies under GJK and EPA's normal, as MuJoCo's: held, its dist's derivative misses the line's turn with the normal,
    off by about the faces' tilt relative (ROUND_RTOL; L = the dists alone, the normal's EPA rounding making the
    differences of the positions noisy)."""
    xpos, xmat, _, _ = _run(case, TILT)

    def run(xpos, xmat):
        return _run(case, TILT, requires_grad=True, xpos=xpos, xmat=xmat)[3]

    K = cc.kernels(wp.float64)
    round_edge = case in ROUND_EDGES
    c = contact_gradient_check(run, xpos, xmat, cpoly.CONTACTS, K.vec3, K.mat33, position_and_normal=not round_edge)
    smooth = c["steps_keep_count"] & (c["count"] > 1) & (np.abs(c["fd1"] - c["fd2"]) < 1e-6)
    assert smooth.sum() >= (len(xpos) // 2 if round_edge else 3 * len(xpos) // 4), smooth.sum()
    np.testing.assert_allclose(c["along"][smooth], c["fd1"][smooth], atol=GRAD_TOL, rtol=ROUND_RTOL if round_edge else 0.0)


def test_the_loader_names_mesh_faces_too_large_for_the_clipping():
    """A mesh whose hull has a face of more than MAX_FACE vertices (a 40-sided prism's caps) is named in the loader's
    NotModelledWarning (such a face keeps GJK and EPA's one contact); a hexagonal prism's is not."""
    import warpdyn as wd
    from warpdyn.description.mjcf import MULTICCD

    def prism(sides):
        ring = [(0.1 * np.cos(a), 0.1 * np.sin(a), z) for z in (-0.05, 0.05) for a in np.arange(sides) * 2 * np.pi / sides]
        return f"""<mujoco><asset><mesh name="prism" vertex="{" ".join(map(str, np.ravel(ring)))}"/></asset><worldbody>
          <geom name="table" type="box" size="0.3 0.3 0.1"/><body pos="0 0 0.2"><freejoint/><geom name="puck" type="mesh" mesh="prism"/></body>
          </worldbody></mujoco>"""

    with pytest.warns(wd.model.NotModelledWarning) as caught:
        wd.model.Model.build_from_model_description(prism(40), dtype=np.float64)
    assert f"{MULTICCD}: ['1 mesh geoms (e.g. puck)']" in " ".join(str(w.message) for w in caught)
    with pytest.warns(wd.model.NotModelledWarning) as caught:
        wd.model.Model.build_from_model_description(prism(6), dtype=np.float64)
    assert MULTICCD not in " ".join(str(w.message) for w in caught)
