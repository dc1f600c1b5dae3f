"""kernels/collision_primitives.py against MuJoCo's mj_collision: for each pair of primitive geoms and two margins
(0, and margin 0.06 + gap 0.04), ~165 poses (150 random ones, and constructed ones: touching, deeply penetrating,
within the margin, beyond it, and the degenerate ones: a box face, a capsule or a cylinder flat on a plane, parallel
and collinear capsules, concentric spheres, a sphere's center inside a box or a cylinder, a capsule along a box's
face or edge) in a two-geom MJCF (geom1 on a mocap body, geom2 on a free body, so that MuJoCo collides them), posed
through mocap_pos, mocap_quat and qpos; MuJoCo's world poses (geom_xpos, geom_xmat) go to the `collide` kernel.

The contacts must be MuJoCo's: the same count (but for contacts exactly on the margin's edge, whose last bit decides
them), and, paired by position, the same positions, contact frames (the normal from geom1 to geom2 and the two
tangents) and distances: to 1e-10 in float64 (the formulas are MuJoCo's, closed-form; what is left is rounding,
~1e-15 on these O(1) scales, amplified where a normal is drawn between nearly coincident points), and in float32 to
the tolerance below.
"""

import functools

import mujoco
import numpy as np
import pytest
import scipy.optimize
import scipy.spatial.transform
import warp as wp

from warpdyn.kernels import collision_primitives as cp
from collision_reference import posed_contacts
from gradcheck import contact_gradient_check

FLOAT64_TOL = 1e-10
FLOAT32_TOL = 2e-5
FLOAT32_MOVE = 1e-6
FLOAT32_DRAWS = 16
FLOAT32_GROWTH = 10.0
FLOAT32_POINTS = 1e-6
"""float32: a contact takes tens of operations on lengths of order 1 m, each rounded to 6e-8 relative: 2e-5 m (or
unit) leaves a margin over that. Where the contact is ill-conditioned (a normal from two nearly coincident points,
the tangent of a capsule standing on a plane) rounding is amplified; how much, float64 arithmetic on inputs moved at
random by FLOAT32_MOVE (`_moved`: float32's rounding over tens of operations) measures (FLOAT32_DRAWS draws, the
largest change), and float32 is allowed FLOAT32_GROWTH times that. A normal drawn between two points s apart
(MuJoCo's mjraw_SphereSphere) that float32 computes separately, each to ~1e-7 m, is allowed FLOAT32_POINTS / s more:
exact arithmetic on moved inputs keeps that direction (the common perpendicular of two capsules' axes) where
float32's rounding of each point does not. Poses where such moves change the count (a branch of MuJoCo's on its
edge), and those whose contacts MuJoCo decides by the sign of rounding noise (`_noise_decided`), are compared in
float64 only."""

TYPES = {"plane": cp.PLANE, "sphere": cp.SPHERE, "capsule": cp.CAPSULE, "ellipsoid": cp.ELLIPSOID, "cylinder": cp.CYLINDER, "box": cp.BOX}
SIZES = {"plane": (0.0, 0.0, 1.0), "sphere": (0.3,), "capsule": (0.1, 0.3), "ellipsoid": (0.3, 0.2, 0.1), "cylinder": (0.2, 0.15), "box": (0.2, 0.3, 0.1)}
SIZES2 = {"sphere": (0.2,), "capsule": (0.15, 0.4), "box": (0.25, 0.15, 0.2)}  # geom2's sizes where the types are the same
MARGINS = ((0.0, 0.0), (0.06, 0.04))  # (margin, gap) of the pair, half on each geom
N_RANDOM = 150


def _quat(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def _mul(q1, q2):
    out = np.empty(4)
    mujoco.mju_mulQuat(out, np.asarray(q1, float), np.asarray(q2, float))
    return out


def _rot(q):
    out = np.empty(9)
    mujoco.mju_quat2Mat(out, np.asarray(q, float))
    return out.reshape(3, 3)


def _inverse(p, q):
    """The pose (position, quaternion) of frame A in frame B from B's (p, q) in A."""
    q_inv = np.array([q[0], -q[1], -q[2], -q[3]])
    return tuple(-(_rot(q).T @ np.asarray(p, float))), q_inv


def _rbound(name, size):
    return {"plane": 0.0, "sphere": size[0], "capsule": size[0] + size[1], "ellipsoid": max(size), "cylinder": np.hypot(size[0], size[1]), "box": np.linalg.norm(size)}[name]


IDENTITY = np.array([1.0, 0.0, 0.0, 0.0])
X90 = _quat([1, 0, 0], np.pi / 2)


def _special(name1, name2, size1, size2, margin):
    """(geom2's position in geom1's frame, its quaternion relative to geom1's) of the pair's constructed poses."""
    r1, r2 = size1[0], size2[0]
    cases = []
    if name1 == "plane":
        top = {"sphere": r2, "capsule": r2 + size2[1], "ellipsoid": size2[2], "cylinder": size2[1], "box": size2[2]}[name2]
        flat = {"capsule": (X90, r2), "cylinder": (X90, r2), "box": (_quat([0, 0, 1], 0.7), size2[2]), "ellipsoid": (_quat([0, 0, 1], 0.3), size2[2])}
        for q, h in [(IDENTITY, top), flat.get(name2, (IDENTITY, top)), (_quat([1, 0, 0], np.pi), top)]:
            for dh in (0.0, -0.01, -0.1, 0.5 * margin, margin + 0.01):
                cases.append(((0.3, -0.2, h + dh), q))
        if name2 == "box":  # on an edge, on a corner
            cases += [((0.0, 0.0, np.hypot(size2[1], size2[2]) - 0.01), _quat([1, 0, 0], np.arctan2(size2[1], size2[2])))]
            cases += [((0.0, 0.0, 0.05), _quat([1, 1, 0], 0.9))]
        if name2 == "cylinder":  # tilted a little, the rim's lowest point first
            cases += [((0.0, 0.0, size2[1] - 0.02), _quat([1, 0, 0], 0.05))]
        return cases
    if name1 == name2 == "sphere":
        cases += [((0.0, 0.0, 0.0), _quat([1, 0, 0], 0.4)), ((0.0, 0.0, 0.0), IDENTITY), ((0.0, 0.0, 0.0), _quat([0, 0, 1], 1.0))]
        cases += [((r1 + r2 + d, 0.0, 0.0), IDENTITY) for d in (0.0, -0.2, 0.5 * margin, margin + 0.01)]
        return cases
    if name1 == "sphere" and name2 == "capsule":  # the center on the capsule's axis (inside, at an end), beside it
        cases += [((0.0, 0.0, z), _quat([1, 0, 0], 0.3)) for z in (0.0, 0.1)]
        cases += [((0.0, 0.0, size2[1] + r1 + r2 + d), IDENTITY) for d in (-0.05, 0.0, 0.5 * margin)]
        cases += [((r1 + r2 + d, 0.0, 0.1), IDENTITY) for d in (0.0, -0.1, 0.5 * margin)]
        return [((-x, -y, -z), q) for (x, y, z), q in cases]  # the capsule relative to the sphere
    if name1 == "sphere" and name2 == "cylinder":  # the center inside near the side, near a cap, on the axis, at the rim
        cases += [((0.15, 0.0, 0.0), IDENTITY), ((0.05, 0.0, 0.12), IDENTITY), ((0.0, 0.0, 0.1), IDENTITY)]
        cases += [((0.0, 0.0, size2[1] + r1 + d), IDENTITY) for d in (0.0, -0.05, 0.5 * margin)]
        cases += [((r2 + 0.1, 0.0, size2[1] + 0.1), IDENTITY), ((r2 + r1 - 0.02, 0.0, 0.0), IDENTITY)]
        return [((-x, -y, -z), q) for (x, y, z), q in cases]
    if name1 == "sphere" and name2 == "box":  # the center inside the box, near each face; on a face; at an edge
        for axis in range(3):
            for sign in (-1, 1):
                c = np.zeros(3)
                c[axis] = sign * 0.8 * size2[axis]
                cases.append((tuple(c), IDENTITY))
        cases += [((size2[0], 0.05, 0.0), IDENTITY), ((0.0, 0.0, 0.0), IDENTITY)]
        cases += [((size2[0] + r1 * 0.5 + d, size2[1] + r1 * 0.5, 0.0), IDENTITY) for d in (0.0, 0.5 * margin)]
        return [((-x, -y, -z), q) for (x, y, z), q in cases]
    if name1 == name2 == "capsule":  # parallel (segment 1 inside 2, overlapping, apart), antiparallel, collinear, crossing
        for q in (IDENTITY, _quat([1, 0, 0], np.pi), _quat([0, 1, 0], 5e-5), _quat([0, 1, 0], np.pi - 5e-5)):
            for x, z in ((r1 + r2 - 0.02, 0.05), (r1 + r2 - 0.01, 0.5), (r1 + r2 + 0.5 * margin, -0.4), (0.1, 0.8), (0.0, 0.75), (0.2, -0.9)):
                cases.append(((x, 0.0, z), q))
        cases += [((0.0, 0.0, size1[1] + size2[1] + r1 + r2 - 0.01), IDENTITY), ((0.0, 0.0, 0.0), IDENTITY)]
        cases += [((0.0, r1 + r2 - 0.05, 0.0), X90), ((0.0, 0.0, 0.0), X90)]
        return cases
    if name1 == "capsule" and name2 == "box":  # the capsule in the box's frame: along a face, an edge, across an edge, standing, inside
        sx, sy, sz = size2
        along_x, along_y = _quat([0, 1, 0], np.pi / 2), _quat([1, 0, 0], np.pi / 2)
        for d in (-0.02, 0.0, 0.5 * margin):
            cases += [((0.05, 0.02, sz + r1 + d), along_x), ((sx, 0.1, sz + r1 + d), along_x), ((0.0, sy + r1 + d, sz + r1 + d), along_x)]
        cases += [((0.05, 0.0, sz + r1 - 0.01), _quat([0, 1, 0], np.pi / 2 + 0.2)), ((0.0, sy + 0.07, sz + 0.07), along_x)]
        cases += [((sx + 0.05, 0.0, sz + 0.05), _mul(_quat([0, 0, 1], 0.5), along_y)), ((0.0, 0.0, sz + size1[1] + r1 - 0.02), IDENTITY)]
        cases += [((0.0, 0.0, sz), IDENTITY), ((sx + 0.2, sy + 0.2, sz + 0.2), _quat([1, -1, 0], 0.96)), ((0.0, 0.0, 0.0), along_x)]
        return [_inverse(p, q) for p, q in cases]  # the box relative to the capsule
    raise KeyError((name1, name2))



@functools.cache
def _reference(name1, name2, margin, gap, seed=0):
    """The poses (world positions (n, 2, 3), rotations (n, 2, 3, 3)), the sizes (2, 3), the pair's margin + gap,
    and MuJoCo's contacts per pose: [(pos (k, 3), frame (k, 3, 3), dist (k,))]."""
    size1 = SIZES[name1]
    size2 = SIZES2.get(name2, SIZES[name2]) if name1 == name2 else SIZES[name2]
    size1, size2 = (s + (0.0,) * (3 - len(s)) for s in (size1, size2))
    xml = f"""<mujoco><option gravity="0 0 0"/><worldbody>
      <body mocap="true"><geom type="{name1}" size="{' '.join(map(str, SIZES[name1]))}" margin="{margin / 2}" gap="{gap / 2}"/></body>
      <body><freejoint/><geom type="{name2}" size="{' '.join(map(str, size2))}" margin="{margin / 2}" gap="{gap / 2}"/></body>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    rng = np.random.default_rng(seed)
    poses = _special(name1, name2, size1, size2, margin + gap)
    reach = _rbound(name1, size1) + _rbound(name2, size2) + margin + gap
    for _ in range(N_RANDOM):
        q = rng.normal(size=4)
        if name1 == "plane":
            p = (rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(-reach, reach + 0.05))
        else:
            u = rng.normal(size=3)
            p = tuple(u / np.linalg.norm(u) * rng.uniform(0.0, reach + 0.05))
        poses.append((p, q / np.linalg.norm(q)))
    xpos, xmat, contacts = posed_contacts(m, rng, poses)
    return xpos, xmat, np.array([size1, size2]), margin + gap, contacts


def _collide(name1, name2, xpos, xmat, sizes, margin, dtype):
    """The kernel's contacts per pose: count (n,), positions (n, MAX, 3), frames (n, MAX, 3, 3), dists (n, MAX)."""
    K = cp.kernels(wp.float64 if dtype == np.float64 else wp.float32)
    n = len(xpos)

    def arr(a, t):
        return wp.array(np.ascontiguousarray(a, dtype=dtype), dtype=t)

    count = wp.full(n, -2, dtype=int)
    pos = wp.array(np.full((n, cp.MAX_CONTACTS, 3), np.nan, dtype), dtype=K.vec3)
    frame = wp.array(np.full((n, cp.MAX_CONTACTS, 3, 3), np.nan, dtype), dtype=K.mat33)
    dist = wp.array(np.full((n, cp.MAX_CONTACTS), np.nan, dtype), dtype=K.scalar)
    size = np.broadcast_to(sizes, (n, 2, 3))
    wp.launch(
        K.collide,
        n,
        inputs=[TYPES[name1], TYPES[name2], arr(xpos[:, 0], K.vec3), arr(xmat[:, 0], K.mat33), arr(size[:, 0], K.vec3), arr(xpos[:, 1], K.vec3), arr(xmat[:, 1], K.mat33), arr(size[:, 1], K.vec3), arr(np.full(n, margin), K.scalar)],
        outputs=[count, pos, frame, dist],
    )
    return count.numpy(), pos.numpy(), frame.numpy(), dist.numpy()


def _compare(ref, mine, margin, band):
    """Max |error| of position, frame and dist over MuJoCo's contacts `ref` and the kernel's `mine` (each (pos,
    frame, dist)) paired by position (an optimal assignment: duplicates pair up), and the number of contacts left
    unpaired; None where one of those is not on the margin's edge (|dist - margin| <= band: exactly touching, which
    the last bit's rounding decides)."""
    cost = np.linalg.norm(ref[0][:, None] - mine[0][None], axis=-1)
    rows, cols = scipy.optimize.linear_sum_assignment(cost)
    unpaired = np.concatenate([np.delete(ref[2], rows), np.delete(mine[2], cols)])
    if np.any(np.abs(unpaired - margin) > band):
        return None
    return np.array([np.abs(a[rows] - b[cols]).max(initial=0.0) for a, b in zip(ref, mine)]), len(unpaired)


def _separation(pair, sizes, dist):
    """The least distance (m) between the two points a contact's normal is drawn between: dist plus the radii of
    the spheres and capsules of the pair (their segments' points, a box's point nearest a sphere); inf where the
    normal is a plane's."""
    if pair[0] == "plane" or len(dist) == 0:
        return np.inf
    radii = sum(size[0] for name, size in zip(pair, sizes) if name in ("sphere", "capsule"))
    return max(np.min(dist) + radii, 1e-12)


def _moved(rng, xpos, xmat, sizes, margin):
    """The inputs moved at random by FLOAT32_MOVE: positions, sizes and margin by that (relative, absolute below
    1), each rotation by a rotation of that angle (so that it stays one)."""
    def move(a):
        return a + FLOAT32_MOVE * np.maximum(np.abs(a), 1.0) * rng.standard_normal(np.shape(a))

    turn = scipy.spatial.transform.Rotation.from_rotvec(FLOAT32_MOVE * rng.standard_normal((xmat.shape[0] * 2, 3))).as_matrix()
    return move(xpos), xmat @ turn.reshape(xmat.shape), move(sizes), move(margin)


def _noise_decided(pair, xmat):
    """Per pose, whether MuJoCo decides its contacts by the sign of rounding noise: a capsule parallel to a face of
    a box (a component of its axis in the box's frame below 1e-12; mjraw_CapsuleBox's axisdir bits, which float32,
    computing exact zeros there, sets otherwise)."""
    if pair != ("capsule", "box"):
        return np.zeros(len(xmat), bool)
    axis = np.einsum("nji,nj->ni", xmat[:, 1], xmat[:, 0, :, 2])
    return np.any(np.abs(axis) < 1e-12, axis=1)


def _contacts(out, i):
    count, pos, frame, dist = out
    return pos[i, : count[i]], frame[i, : count[i]], dist[i, : count[i]]


PAIRS = [
    ("plane", "sphere"),
    ("plane", "capsule"),
    ("plane", "box"),
    ("plane", "cylinder"),
    ("plane", "ellipsoid"),
    ("sphere", "sphere"),
    ("sphere", "capsule"),
    ("sphere", "cylinder"),
    ("sphere", "box"),
    ("capsule", "capsule"),
    ("capsule", "box"),
]


@pytest.mark.parametrize("margin, gap", MARGINS, ids=["no_margin", "margin"])
@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: "-".join(p))
def test_pair_equals_mujoco(pair, margin, gap, dtype):
    """Each pose's contacts equal MuJoCo's: their count (but for contacts exactly on the margin's edge), then the
    position, frame and dist of the contacts paired by position, within FLOAT64_TOL, or in float32 within
    the tolerance FLOAT32_TOL's docstring derives, on all but the poses it leaves to float64."""
    xpos, xmat, sizes, total, contacts = _reference(*pair, margin, gap)
    assert sum(len(c[2]) for c in contacts) > len(contacts) // 3  # the poses touch often enough to test something
    out = _collide(*pair, xpos, xmat, sizes, total, dtype)
    if dtype == np.float32:
        rng = np.random.default_rng(1)
        moved = [_collide(*pair, *_moved(rng, xpos, xmat, sizes, total), np.float64) for _ in range(FLOAT32_DRAWS)]
    worst, plain, edge, skipped = np.zeros(3), np.zeros(3), 0, 0
    noisy = _noise_decided(pair, xmat)
    for i, ref in enumerate(contacts):
        tol, band = np.full(3, FLOAT64_TOL), 1e-12
        if dtype == np.float32:
            shifts = [_compare(ref, _contacts(out_moved, i), total, FLOAT32_TOL) for out_moved in moved]
            if noisy[i] or any(shift is None for shift in shifts):
                skipped += 1
                continue
            shift = np.max([shift[0] for shift in shifts], axis=0)
            tol, band = FLOAT32_TOL + FLOAT32_GROWTH * shift + FLOAT32_POINTS / _separation(pair, sizes, ref[2]), FLOAT32_TOL
        compared = _compare(ref, _contacts(out, i), total, band)
        assert compared is not None, (i, ref, _contacts(out, i))
        assert np.all(compared[0] <= tol), (i, compared[0], tol, ref, _contacts(out, i))
        worst, edge = np.maximum(worst, compared[0]), edge + compared[1]
        if dtype == np.float64 or (np.all(shift <= 10 * FLOAT32_MOVE) and _separation(pair, sizes, ref[2]) >= 0.01):
            plain = np.maximum(plain, compared[0])  # well conditioned: moved 10 times the inputs at most
    print("-".join(pair), np.dtype(dtype).name, f"margin + gap {total}: max |pos|, |frame|, |dist| errors {worst}, {plain} where well conditioned; {edge} contacts on the edge, {skipped} poses skipped")
    assert skipped - noisy.sum() <= len(contacts) // 20


def test_pairs_without_a_function_have_no_count():
    """`collide` gives count -1 for a pair of types it has no function for (box-box, capsule-cylinder), whatever the
    poses: the caller cannot read them as no contact."""
    poses = np.zeros((1, 2, 3)), np.broadcast_to(np.eye(3), (1, 2, 3, 3)), np.array([[0.1, 0.2, 0.3], [0.1, 0.2, 0.3]])
    for pair in (("box", "box"), ("capsule", "cylinder")):
        assert _collide(*pair, *poses, 0.0, np.float64)[0].tolist() == [-1]


@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: "-".join(p))
def test_tape_gradient_equals_finite_differences(pair):
    """float64: wp.Tape's gradient of L = sum over contacts of dist + w1.pos + w2.normal (w1, w2 random) with
    respect to both poses, along a random direction (positions moved, rotations turned), equals the central
    difference at steps 1e-6 and 2e-6 on the random poses where those two agree to 1e-6 (no branch of MuJoCo's
    crossed, no kink) and keep the count: to 1e-6 (the differences' truncation, h^2 times third derivatives that grow
    where a normal is drawn between close points: up to 2e-7 here, 1e-9 for the plane pairs)."""
    xpos, xmat, sizes, total, contacts = _reference(*pair, 0.06, 0.04)
    xpos, xmat = xpos[-N_RANDOM:], xmat[-N_RANDOM:]
    K = cp.kernels(wp.float64)
    n = len(xpos)

    def run(xpos, xmat):
        inputs = [wp.array(np.ascontiguousarray(a), dtype=t, requires_grad=True) for a, t in ((xpos[:, 0], K.vec3), (xmat[:, 0], K.mat33), (xpos[:, 1], K.vec3), (xmat[:, 1], K.mat33))]
        size = [wp.array(np.broadcast_to(s, (n, 3)).copy(), dtype=K.vec3) for s in sizes]
        count = wp.zeros(n, dtype=int)
        pos, frame, dist = (wp.zeros((n, cp.MAX_CONTACTS), dtype=t, requires_grad=True) for t in (K.vec3, K.mat33, wp.float64))
        wp.launch(K.collide, n, inputs=[TYPES[pair[0]], TYPES[pair[1]], inputs[0], inputs[1], size[0], inputs[2], inputs[3], size[1], wp.full(n, total, dtype=wp.float64)], outputs=[count, pos, frame, dist])
        return inputs, count, pos, frame, dist

    c = contact_gradient_check(run, xpos, xmat, cp.MAX_CONTACTS, K.vec3, K.mat33)
    smooth = (np.abs(c["fd1"] - c["fd2"]) < 1e-6) & c["steps_keep_count"] & (c["count"] > 0)
    assert smooth.sum() > n // 3
    np.testing.assert_allclose(c["along"][smooth], c["fd1"][smooth], atol=1e-6)
