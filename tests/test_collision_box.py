"""kernels/collision_box.py against MuJoCo's mj_collision (mjc_BoxBox), as tests/test_collision_primitives.py tests
the other pairs: two boxes in an MJCF (geom1 on a mocap body, geom2 on a free body), posed through mocap_pos,
mocap_quat and qpos, their world poses (geom_xpos, geom_xmat) given to the `collide` kernel, for two margins (0, and
margin 0.06 + gap 0.04). Two pairs of sizes, different boxes and identical square plates, each with N_RANDOM random
poses and constructed ones: stacked face on face, turned about the vertical (the plates' 8-contact octagon), offset,
tilted; a corner, an edge down on a face; crossing edges; deep penetration; touching, within the margin and beyond
it; the plates coincident, also turned onto themselves.

The contacts must be MuJoCo's: the same count (but for contacts exactly on the margin's edge), and, paired by
position, the same positions, contact frames and distances: to 1e-10 in float64 (the arithmetic is MuJoCo's; what is
left is rounding), and in float32 to FLOAT32_TOL plus FLOAT32_GROWTH times the conditioning measured per pose. Where
MuJoCo decides by the last bit of its own rounding (two faces equally deep: coincident boxes, `_tie_decided`), the
normal is compared up to its sign; the constructed poses are otherwise generic (no corner exactly on a face's side,
no axis equally opposed to two faces), as such ties flip with a different order of the same products (FMA).
"""

import functools

import mujoco
import numpy as np
import pytest
import scipy.optimize
import scipy.spatial.transform
import warp as wp

from warpdyn.kernels import collision_box as cb
from collision_reference import posed_contacts
from gradcheck import contact_gradient_check

Rotation = scipy.spatial.transform.Rotation

FLOAT64_TOL = 1e-10
FLOAT32_TOL = 2e-5
FLOAT32_MOVE = 1e-6
FLOAT32_DRAWS = 16
FLOAT32_GROWTH = 10.0
"""float32: a contact takes tens of operations on lengths of order 1 m, each rounded to 6e-8 relative: 2e-5 m (or
unit) leaves a margin over that. Where a contact is ill-conditioned (a clipped vertex where an incident edge nearly
runs along the reference face's side, the height of a vertex of a nearly parallel face) rounding is amplified; float64
arithmetic on inputs moved at random by FLOAT32_MOVE (float32's rounding over tens of operations) measures how much
(FLOAT32_DRAWS draws, the largest change), and float32 is allowed FLOAT32_GROWTH times that. Poses where such moves
change the count (a branch of MuJoCo's on its edge: a face's corner on the other's side, faces parallel to rounding)
are compared in float64 only."""

SIZES = {"different": ((0.2, 0.3, 0.1), (0.25, 0.15, 0.2)), "identical": ((0.3, 0.3, 0.05), (0.3, 0.3, 0.05))}
MARGINS = ((0.0, 0.0), (0.06, 0.04))  # (margin, gap) of the pair, half on each geom
N_RANDOM = {"different": 200, "identical": 60}


def _pose(rotation, position):
    """(geom2's position in geom1's frame, its quaternion w, x, y, z relative to geom1's) from a scipy Rotation."""
    x, y, z, w = rotation.as_quat()
    return tuple(float(c) for c in position), np.array([w, x, y, z])


def _about_z(angle):
    return Rotation.from_rotvec([0.0, 0.0, angle])


def _special(size1, size2, margin):
    """The constructed poses of geom2 relative to geom1 (`_pose`)."""
    s1, s2 = np.asarray(size1), np.asarray(size2)
    gaps = (0.0, -0.01, -0.04, 0.5 * margin, margin + 0.01)
    cases = []
    for angle in (0.0, 0.3, np.pi / 4, 1.2):  # stacked face on face, turned, offset
        for offset in ((0.04, -0.07), (0.27, 0.19)):
            cases += [_pose(_about_z(angle), (*offset, s1[2] + s2[2] + dz)) for dz in gaps]
    cases += [_pose(Rotation.from_rotvec([np.pi, 0.0, 0.0]), (0.02, 0.0, -s1[2] - s2[2] + 0.01))]  # below, upside down
    for tilt in (0.05, 0.2):  # tilted: an edge of the lower face deepest
        cases += [_pose(Rotation.from_rotvec([tilt, 0.0, 0.0]) * _about_z(0.4), (0.0, 0.05, s1[2] + s2[2] + dz)) for dz in gaps]
    corner = s2 / np.linalg.norm(s2)  # a corner down: geom2's corner direction to -z, turned about z
    down, _ = Rotation.align_vectors([[0.0, 0.0, -1.0]], [corner])
    cases += [_pose(_about_z(0.7) * down, (0.03, -0.05, s1[2] + np.linalg.norm(s2) + dz)) for dz in gaps]
    edge_down = Rotation.from_rotvec([np.arctan2(s2[1], s2[2]), 0.0, 0.0])  # an edge along x down, turned about z
    cases += [_pose(_about_z(0.5) * edge_down, (0.0, 0.04, s1[2] + np.hypot(s2[1], s2[2]) + dz)) for dz in gaps]
    bisector = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)  # crossing edges: geom1's edge along y at x, z = s1x, s1z
    for phi in (np.pi / 2, np.pi / 3):
        along = np.cos(phi) * np.array([0.0, 1.0, 0.0]) + np.sin(phi) * np.array([-1.0, 0.0, 1.0]) / np.sqrt(2.0)
        local = np.array([[1.0, 0.0, 0.0], [0.0, -1.0 / np.sqrt(2.0), -1.0 / np.sqrt(2.0)]])  # geom2's edge along x, its bisector
        turn, _ = Rotation.align_vectors(np.array([along, -bisector]), local)
        for dz in gaps:
            center = np.array([s1[0], 0.05, s1[2]]) + bisector * dz + turn.apply([0.0, s2[1], s2[2]])
            cases.append(_pose(turn, center))
    for rotvec in ((0.3, -0.2, 0.5), (1.0, 0.6, 0.2)):  # deep: centers close, concentric
        cases += [_pose(Rotation.from_rotvec(rotvec), offset) for offset in ((0.0, 0.0, 0.0), (0.02, -0.03, 0.01))]
    cases += [_pose(Rotation.identity(), offset) for offset in ((0.02, -0.03, 0.01), (1e-3, 0.0, 2e-3))]
    if np.array_equal(s1, s2):  # coincident, also turned onto itself
        cases += [_pose(Rotation.from_rotvec(r), (0.0, 0.0, 0.0)) for r in ((0.0, 0.0, 0.0), (0.0, 0.0, np.pi / 2), (np.pi, 0.0, 0.0))]
    return cases


@functools.cache
def _reference(sizes, margin, gap, seed=0):
    """The poses (world positions (n, 2, 3), rotations (n, 2, 3, 3)), the sizes (2, 3), the pair's margin + gap, and
    MuJoCo's contacts per pose: [(pos (k, 3), frame (k, 3, 3), dist (k,))]."""
    size1, size2 = SIZES[sizes]
    xml = f"""<mujoco><option gravity="0 0 0"/><worldbody>
      <body mocap="true"><geom type="box" size="{' '.join(map(str, size1))}" margin="{margin / 2}" gap="{gap / 2}"/></body>
      <body><freejoint/><geom type="box" size="{' '.join(map(str, size2))}" margin="{margin / 2}" gap="{gap / 2}"/></body>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    rng = np.random.default_rng(seed)
    poses = _special(size1, size2, margin + gap)
    reach = np.linalg.norm(size1) + np.linalg.norm(size2) + margin + gap
    for _ in range(N_RANDOM[sizes]):
        q = rng.normal(size=4)
        u = rng.normal(size=3)
        poses.append((tuple(u / np.linalg.norm(u) * rng.uniform(0.0, reach + 0.05)), q / np.linalg.norm(q)))
    xpos, xmat, contacts = posed_contacts(m, rng, poses)
    return xpos, xmat, np.array([size1, size2]), margin + gap, contacts


def _arrays(K, xpos, xmat, sizes, margin, dtype, requires_grad=False):
    """The `collide` kernel's inputs: geom1's and geom2's positions, rotations and sizes, the margins."""
    n = len(xpos)

    def arr(a, t, grad=False):
        return wp.array(np.ascontiguousarray(a, dtype=dtype), dtype=t, requires_grad=grad)

    size = np.broadcast_to(sizes, (n, 2, 3))
    return [
        arr(xpos[:, 0], K.vec3, requires_grad), arr(xmat[:, 0], K.mat33, requires_grad), arr(size[:, 0], K.vec3),
        arr(xpos[:, 1], K.vec3, requires_grad), arr(xmat[:, 1], K.mat33, requires_grad), arr(size[:, 1], K.vec3),
        arr(np.full(n, margin), K.scalar),
    ]  # fmt: skip


def _outputs(K, n, dtype, requires_grad=False):
    """count (n,) and NaN-filled positions (n, MAX, 3), frames (n, MAX, 3, 3), dists (n, MAX)."""
    shape = (n, cb.MAX_CONTACTS)
    return [wp.full(n, -2, dtype=int)] + [
        wp.array(np.full(shape + tail, np.nan, dtype), dtype=t, requires_grad=requires_grad) for tail, t in (((3,), K.vec3), ((3, 3), K.mat33), ((), K.scalar))
    ]  # fmt: skip


def _collide(xpos, xmat, sizes, margin, dtype):
    """The kernel's contacts per pose: count (n,), positions (n, MAX, 3), frames (n, MAX, 3, 3), dists (n, MAX)."""
    K = cb.kernels(wp.float64 if dtype == np.float64 else wp.float32)
    outputs = _outputs(K, len(xpos), dtype)
    wp.launch(K.collide, len(xpos), inputs=_arrays(K, xpos, xmat, sizes, margin, dtype), outputs=outputs)
    return tuple(a.numpy() for a in outputs)


def _contacts(out, i):
    count, pos, frame, dist = out
    return pos[i, : count[i]], frame[i, : count[i]], dist[i, : count[i]]


def _compare(ref, mine, margin, band):
    """Max |error| of position, frame and dist over MuJoCo's contacts `ref` and the kernel's `mine` (each (pos,
    frame, dist)) paired by position (an optimal assignment; two contacts on the margin's edge over 1 mm apart are no
    pair), and the number left unpaired; None where one of those is not on the margin's edge (|dist - margin| <=
    band: exactly touching, which the last bit's rounding decides: faces touching, their corners in or out)."""
    cost = np.linalg.norm(ref[0][:, None] - mine[0][None], axis=-1)
    rows, cols = scipy.optimize.linear_sum_assignment(cost)
    on_edge = (np.abs(ref[2][rows] - margin) <= band) & (np.abs(mine[2][cols] - margin) <= band)
    paired = (cost[rows, cols] <= 1e-3) | ~on_edge
    rows, cols = rows[paired], cols[paired]
    unpaired = np.concatenate([np.delete(ref[2], rows), np.delete(mine[2], cols)])
    if np.any(np.abs(unpaired - margin) > band):
        return None
    return np.array([np.abs(a[rows] - b[cols]).max(initial=0.0) for a, b in zip(ref, mine)]), len(unpaired)


def _tie_decided(xpos, xmat, sizes):
    """Per pose, whether MuJoCo's normal is decided by rounding: the centers coincide (no side to push out to) and
    each box's deepest face is as deep as the other's to 1e-12, so that MuJoCo's strict `sep > sep_best` picks one
    by the last bit of its rotation products, their normals opposite. For identical boxes the contacts are the
    same either way but for the normal's sign."""
    rot = np.abs(np.einsum("nki,nkj->nij", xmat[:, 0], xmat[:, 1]))
    sep1 = -sizes[0] - rot @ sizes[1]
    sep2 = -sizes[1] - rot.transpose(0, 2, 1) @ sizes[0]
    coincident = np.linalg.norm(xpos[:, 1] - xpos[:, 0], axis=-1) <= 1e-12
    return coincident & (np.abs(sep1.max(1) - sep2.max(1)) <= 1e-12)


def _edge_contact(xmat, contacts):
    """Per pose, whether its contacts are an edge pair's: one contact whose normal is none of the boxes' face axes
    (a face manifold's normal is one, to the bit)."""
    one = np.array([len(c[2]) == 1 for c in contacts])
    normals = np.array([c[1][0, 0] if len(c[2]) == 1 else np.zeros(3) for c in contacts])
    return one & (np.abs(np.einsum("nbij,ni->nbj", xmat, normals)).max(axis=(1, 2)) < 1.0 - 1e-12)


def _moved(rng, xpos, xmat, sizes, margin):
    """The inputs moved at random by FLOAT32_MOVE: positions, sizes and margin by that (relative, absolute below
    1), each rotation by a rotation of that angle (so that it stays one)."""
    def move(a):
        return a + FLOAT32_MOVE * np.maximum(np.abs(a), 1.0) * rng.standard_normal(np.shape(a))

    turn = Rotation.from_rotvec(FLOAT32_MOVE * rng.standard_normal((xmat.shape[0] * 2, 3))).as_matrix()
    return move(xpos), xmat @ turn.reshape(xmat.shape), move(sizes), move(margin)


@pytest.mark.parametrize("margin, gap", MARGINS, ids=["no_margin", "margin"])
@pytest.mark.parametrize("sizes", SIZES)
def test_box_box_equals_mujoco(sizes, margin, gap, dtype):
    """Each pose's contacts equal MuJoCo's: their count (but for contacts exactly on the margin's edge), then the
    position, frame and dist of the contacts paired by position, within FLOAT64_TOL, or in float32 within the
    tolerance FLOAT32_TOL's docstring derives, on all but the poses it leaves to float64. The poses cover no contact,
    one (an edge pair's, crossing edges), and face manifolds up to 8."""
    xpos, xmat, half_sizes, total, contacts = _reference(sizes, margin, gap)
    counts = np.array([len(c[2]) for c in contacts])
    assert {0, 1, 4}.issubset(counts) and counts.max() == (8 if sizes == "identical" else 7)
    assert _edge_contact(xmat, contacts).sum() >= 10
    out = _collide(xpos, xmat, half_sizes, total, dtype)
    if dtype == np.float32:
        rng = np.random.default_rng(1)
        moved = [_collide(*_moved(rng, xpos, xmat, half_sizes, total), np.float64) for _ in range(FLOAT32_DRAWS)]
    tied = _tie_decided(xpos, xmat, half_sizes)
    assert tied.sum() == (3 if sizes == "identical" else 0)
    worst, plain, edge, skipped = np.zeros(3), np.zeros(3), 0, 0
    for i, ref in enumerate(contacts):
        mine = _contacts(out, i)
        if tied[i] and dtype == np.float32:  # rounding's choice, unlike float64's inputs moved by float32-sized steps
            skipped += 1
            continue
        if tied[i]:  # the normals compared up to their sign: |n . n_MuJoCo| = 1
            ref, mine = (ref[0], np.ones((len(ref[2]), 1)), ref[2]), (mine[0], np.abs(mine[1][:, :1, :] @ ref[1][:1, 0, :, None])[..., 0], mine[2])
        tol, band = np.full(3, FLOAT64_TOL), 1e-12
        if dtype == np.float32:
            shifts = [_compare(ref, _contacts(out_moved, i), total, FLOAT32_TOL) for out_moved in moved]
            if any(shift is None for shift in shifts):
                skipped += 1
                continue
            shift = np.max([shift[0] for shift in shifts], axis=0)
            tol, band = FLOAT32_TOL + FLOAT32_GROWTH * shift, FLOAT32_TOL
        compared = _compare(ref, mine, total, band)
        assert compared is not None, (i, ref, mine)
        assert np.all(compared[0] <= tol), (i, compared[0], tol, ref, mine)
        worst, edge = np.maximum(worst, compared[0]), edge + compared[1]
        if dtype == np.float64 or np.all(shift <= 10 * FLOAT32_MOVE):
            plain = np.maximum(plain, compared[0])  # well conditioned: moved 10 times the inputs at most
    print(sizes, np.dtype(dtype).name, f"margin + gap {total}: max |pos|, |frame|, |dist| errors {worst}, {plain} where well conditioned; {edge} contacts on the edge, {skipped} poses skipped")
    assert skipped - tied.sum() * (dtype == np.float32) <= len(contacts) // 10


def test_tape_gradient_equals_finite_differences():
    """float64: wp.Tape's gradient of L = sum over contacts of dist + w1.pos + w2.normal (w1, w2 random) with respect
    to both poses, along a random direction (positions moved, rotations turned), equals the central difference at
    steps 1e-6 and 2e-6 on the poses where those two agree to 1e-6, the one-sided differences at 1e-6 to 1e-4 (a
    kink, a corner exactly on the other face's side, averages two slopes the same at both steps) and the count is
    kept (no branch of MuJoCo's crossed: the same axis, reference face and clipped polygon): to 1e-7 (the
    differences' truncation, 1.4e-9 seen on gradients up to 30). Those poses (159 of 277) include face manifolds of
    several contacts and single edge contacts."""
    xpos, xmat, sizes, total, contacts = _reference("different", 0.06, 0.04)
    K = cb.kernels(wp.float64)
    n = len(xpos)

    def run(xpos, xmat):
        inputs = _arrays(K, xpos, xmat, sizes, total, np.float64, requires_grad=True)
        count, pos, frame, dist = _outputs(K, n, np.float64, requires_grad=True)
        wp.launch(K.collide, n, inputs=inputs, outputs=[count, pos, frame, dist])
        return [inputs[k] for k in (0, 1, 3, 4)], count, pos, frame, dist

    c = contact_gradient_check(run, xpos, xmat, cb.MAX_CONTACTS, K.vec3, K.mat33)
    count = c["count"]
    smooth = (np.abs(c["fd1"] - c["fd2"]) < 1e-6) & (c["kink"] < 1e-4) & c["steps_keep_count"] & (count > 0)
    assert smooth.sum() > n // 4 and np.sum(smooth & _edge_contact(xmat, contacts)) >= 10 and np.sum(smooth & (count >= 4)) >= 10
    np.testing.assert_allclose(c["along"][smooth], c["fd1"][smooth], atol=1e-7)
