"""kernels/collision_convex.py (capsule-cylinder, cylinder-cylinder, cylinder-box, ellipsoids with spheres, capsules,
ellipsoids, cylinders, boxes and meshes, and convex meshes with spheres, capsules, cylinders, boxes and meshes: GJK and EPA) against MuJoCo's mj_collision and against the definition of the
contact it computes.

MuJoCo's reference runs with mjDSBL_MULTICCD set: MuJoCo 4 otherwise adds polygon contacts where the EPA's features
are faces or edges (a cylinder's cap on a box), which warpdyn does not reproduce (one contact a pair; the loader says
so). Each pair at N_RANDOM random poses, for two margins, in a two-geom MJCF (tests/collision_reference.py).

What is checked:
- the count equals MuJoCo's at every pose (0 or 1; but for a contact exactly on the margin's edge);
- the contact is the pair's: its normal n maximises the cores' separation sep(n) = min_b n.b - max_a n.a over all
  directions (dense directions refined by Nelder-Mead, `_best_separations`): to EPA_TOL where the geoms penetrate,
  to GJK_TOL where they are apart within the margin (GJK converges linearly between two curved surfaces and stops
  where rounding leaves no progress); dist = sep(n) - the capsule's radius, and pos lies midway between the witnesses;
- MuJoCo agrees where its own EPA converged (its dist equals its sep along its normal to 1e-7: about half the poses;
  MuJoCo stops at ccd_tolerance 1e-6 and 35 iterations): dist to 1e-6, normal and position to MJ_TOL; where it did
  not, warpdyn's normal separates at least as well as MuJoCo's (it is the better contact);
- float32 against float64; the tape's gradient of dist against central differences (the normal and the witnesses
  are held: kernels/collision_convex.py's docstring).
"""

import functools

import mujoco
import numpy as np
import pytest
import warp as wp

from warpdyn.kernels import collision_convex as cc
from warpdyn.kernels import collision_polygons as cpoly
from warpdyn.kernels import collision_primitives as cp
from collision_reference import posed_contacts
from gradcheck import contact_gradient_check

PAIRS = [("capsule", "cylinder"), ("cylinder", "cylinder"), ("cylinder", "box"), ("sphere", "mesh"), ("capsule", "mesh"), ("cylinder", "mesh"), ("box", "mesh"), ("mesh", "mesh"),
         ("sphere", "ellipsoid"), ("capsule", "ellipsoid"), ("ellipsoid", "ellipsoid"), ("ellipsoid", "cylinder"), ("ellipsoid", "box"), ("ellipsoid", "mesh")]  # fmt: skip
TYPES = {"sphere": cp.SPHERE, "capsule": cp.CAPSULE, "ellipsoid": cp.ELLIPSOID, "cylinder": cp.CYLINDER, "box": cp.BOX, "mesh": cp.MESH}
SIZE1 = {"sphere": (0.12, 0.0, 0.0), "capsule": (0.1, 0.3, 0.0), "ellipsoid": (0.25, 0.1, 0.15), "cylinder": (0.2, 0.15, 0.0), "box": (0.2, 0.3, 0.1)}
SIZE2 = {"ellipsoid": (0.12, 0.2, 0.3), "cylinder": (0.15, 0.25, 0.0), "box": (0.2, 0.3, 0.1)}


def _rock(seed: int, radii) -> np.ndarray:
    """A convex mesh's vertices (k, 3) [m]: points on an ellipsoid of these radii (every one a vertex of the hull)."""
    u = np.random.default_rng(seed).normal(size=(24, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True) * np.asarray(radii)


ROCKS = (_rock(3, (0.15, 0.1, 0.12)), _rock(4, (0.12, 0.12, 0.08)))
"""geom1's and geom2's meshes where they are meshes (MuJoCo takes their convex hull, and recentres them)."""
MARGINS = (0.0, 0.1)  # margin + gap of the pair, half on each geom
N_RANDOM = 120
EPA_TOL = 1e-7
GJK_TOL = 2e-5
"""[m] EPA (the cores overlap) stops at TOLERANCE (1e-10) of the pair's size (9 poses in 10 here: below 6e-11 m), else
where its polytope is full or rounding breaks its convexity (4e-8 m at most here); GJK (the cores apart: two geoms
apart, or a capsule's or sphere's segment or centre outside the other) where rounding leaves no progress: its last
support's gap bounded the distance's error by 1e-5 m at most here (two curved surfaces: GJK converges linearly)."""
ELLIPSOID_TOL = 1e-4
"""[m] An ellipsoid is curved in every direction: EPA's polytope (VERTICES) places the depth to about 1e-5 m of the
best separation here, its face's normal where sep(n) is within 7e-5 m of the best (MuJoCo's depth: within 9e-4 m of
the best at these poses, a median 8e-7)."""
MJ_TOL = 2e-3
"""MuJoCo's normal and position where its EPA converged: its ccd_tolerance 1e-6 on the depth leaves the normal at a
curved optimum free to about its square root, and the position moves along the surfaces with it."""


def _support(name, size, p, R, d, vertices=None):
    """The core's support point along the world directions d (k, 3) (a capsule's segment and a sphere's centre: their
    radius apart; a mesh's: of its vertices); the pose p (3,) and R (3, 3), or one per direction, (k, 3) and (k, 3, 3)."""
    local = np.einsum("ki,kij->kj", d, np.broadcast_to(R, (len(d), 3, 3)))
    if name == "box":
        q = np.where(local >= 0, 1.0, -1.0) * np.asarray(size)
    elif name == "cylinder":
        radial = np.maximum(np.hypot(local[:, 0], local[:, 1]), 1e-300)
        q = np.stack([size[0] * local[:, 0] / radial, size[0] * local[:, 1] / radial, np.where(local[:, 2] >= 0, size[1], -size[1])], 1)
    elif name == "ellipsoid":
        scaled = local * np.asarray(size)
        q = scaled * np.asarray(size) / np.linalg.norm(scaled, axis=1, keepdims=True)
    elif name == "mesh":
        q = vertices[np.argmax(local @ vertices.T, axis=1)]
    else:
        q = np.zeros_like(local)
        if name == "capsule":
            q[:, 2] = np.where(local[:, 2] >= 0, size[1], -size[1])
    return p + np.einsum("kij,kj->ki", np.broadcast_to(R, (len(d), 3, 3)), q)


def _separation(pair, shapes, xpos, xmat, n):
    """sep(n) of the cores (k,) for unit directions n (k, 3); shapes: (sizes (2, 3), meshes' vertices (2,)); one pose,
    xpos (2, 3) and xmat (2, 3, 3), or one per direction, (k, 2, 3) and (k, 2, 3, 3)."""
    sizes, meshes = shapes
    n = np.atleast_2d(n)
    a = _support(pair[0], sizes[0], xpos[..., 0, :], xmat[..., 0, :, :], n, meshes[0])
    b = _support(pair[1], sizes[1], xpos[..., 1, :], xmat[..., 1, :, :], -n, meshes[1])
    return np.sum(n * (b - a), axis=1)


def _nelder_mead_max(f, x0, xatol=1e-13, fatol=1e-15, maxiter=3000):
    """The maxima of f (B,) from the starts x0 (B, d), B problems at once: Nelder-Mead with scipy's coefficients,
    initial simplex, rounding and stopping test, each problem's simplex frozen once it stops (the values of
    scipy.optimize.minimize(method="Nelder-Mead") on -f, one problem after the other, to 3e-12 m at every pose here, in
    a fifth of its time). f(x, rows): the values (k,) of the points x (k, d), x[i] a point of problem rows[i]."""
    B, d = x0.shape
    sim = np.repeat(x0[:, None], d + 1, axis=1)
    for k in range(d):
        sim[:, k + 1, k] = np.where(x0[:, k] != 0, 1.05 * x0[:, k], 0.00025)
    everyone = np.arange(B)
    cost = -np.stack([f(sim[:, j], everyone) for j in range(d + 1)], 1)  # minimised, as scipy's
    running = everyone
    for _ in range(maxiter - 1):  # scipy's count: the first simplex is its iteration 1
        order = np.argsort(cost[running], axis=1)
        sim[running] = np.take_along_axis(sim[running], order[:, :, None], 1)
        cost[running] = np.take_along_axis(cost[running], order, 1)
        s, c = sim[running], cost[running]
        going = (np.abs(s[:, 1:] - s[:, :1]).max(axis=(1, 2)) > xatol) | (np.abs(c[:, 1:] - c[:, :1]).max(axis=1) > fatol)
        running, s, c = running[going], s[going], c[going]
        if running.size == 0:
            break
        centre, worst = s[:, :-1].mean(axis=1), s[:, -1]

        def point(t, mask):  # (1 + t) centre - t worst (scipy's rounding) and its cost, for the problems of the mask
            x = (1.0 + t) * centre[mask] - t * worst[mask]
            return x, -f(x, running[mask])

        new, new_cost = worst.copy(), c[:, -1].copy()
        xr, r = point(1.0, slice(None))  # reflection
        expand = r < c[:, 0]
        xe, e = point(2.0, expand)
        better = np.zeros_like(expand)
        better[expand] = e < r[expand]
        take = (~expand & (r < c[:, -2])) | (expand & ~better)
        new[take], new_cost[take] = xr[take], r[take]
        new[better] = xe[better[expand]]
        new_cost[better] = e[better[expand]]
        outside = ~expand & ~take & (r < c[:, -1])
        inside = ~expand & ~take & ~outside
        shrink = np.zeros_like(expand)
        for t, mask, limit in ((0.5, outside, r), (-0.5, inside, c[:, -1])):  # contractions: outside (<= r), inside (< worst)
            x, value = point(t, mask)
            ok = value <= limit[mask] if t > 0 else value < limit[mask]
            rows = np.flatnonzero(mask)
            new[rows[ok]], new_cost[rows[ok]] = x[ok], value[ok]
            shrink[rows[~ok]] = True
        keep = ~shrink
        sim[running[keep], -1], cost[running[keep], -1] = new[keep], new_cost[keep]
        if shrink.any():
            rows = running[shrink]
            for j in range(1, d + 1):
                sim[rows, j] = sim[rows, 0] + 0.5 * (sim[rows, j] - sim[rows, 0])
                cost[rows, j] = -f(sim[rows, j], rows)
    return -cost.min(axis=1)


def _best_separations(pair, shapes, xpos, xmat, starts=3):
    """max over unit n of sep(n) (n,) at the poses xpos (n, 2, 3), xmat (n, 2, 3, 3): 20000 directions, each pose's
    best `starts` refined by Nelder-Mead (`_nelder_mead_max`)."""
    k = np.arange(20000) + 0.5
    z = 1 - 2 * k / 20000
    phi = np.pi * (1 + 5**0.5) * k
    dirs = np.stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z], 1)
    values = np.stack([_separation(pair, shapes, p, R, dirs) for p, R in zip(xpos, xmat)])
    pose = np.repeat(np.arange(len(xpos)), starts)

    def sep(x, rows):
        return _separation(pair, shapes, xpos[pose[rows]], xmat[pose[rows]], x / np.linalg.norm(x, axis=1, keepdims=True))

    refined = _nelder_mead_max(sep, dirs[np.argsort(values, axis=1)[:, -starts:]].reshape(-1, 3))
    return np.maximum(values.max(axis=1), refined.reshape(-1, starts).max(axis=1))


def _radius(pair, shapes):
    """The cores' radii, summed (spheres' and capsules')."""
    return sum(size[0] for name, size in zip(pair, shapes[0]) if name in ("sphere", "capsule"))


def _geom(name, size, mesh, margin):
    if name == "mesh":
        return f'<geom type="mesh" mesh="{mesh}" margin="{margin / 2}"/>'
    numbers = " ".join(map(str, size))
    return f'<geom type="{name}" size="{numbers}" margin="{margin / 2}"/>'


_ROCK_ASSETS = "".join(f'<mesh name="rock{k}" vertex="{" ".join(map(str, rock.ravel()))}"/>' for k, rock in enumerate(ROCKS))


def _mujoco_pair(pair, margin) -> mujoco.MjModel:
    """MuJoCo's model of the pair: geom1 on a mocap body, geom2 on a free body (a mesh: ROCKS' first, second), half the
    margin on each, multiCCD off (one contact a pair, as warpdyn's)."""
    xml = f"""<mujoco><option gravity="0 0 0"/><asset>{_ROCK_ASSETS}</asset><worldbody>
      <body mocap="true">{_geom(pair[0], SIZE1.get(pair[0]), "rock0", margin)}</body>
      <body><freejoint/>{_geom(pair[1], SIZE2.get(pair[1]), "rock1", margin)}</body>
    </worldbody></mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    m.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_MULTICCD)
    return m


@functools.cache
def _reference(pair, margin):
    """(xpos (n, 2, 3), xmat (n, 2, 3, 3), shapes (the kernel's sizes (2, 3): a mesh's (MuJoCo's bounding radius, 0,
    0); the meshes' vertices in their geoms' frames, MuJoCo's, or None), MuJoCo's contacts per pose) at random poses."""
    size1, size2 = SIZE1.get(pair[0]), SIZE2.get(pair[1])
    m = _mujoco_pair(pair, margin)
    meshes = [None, None]
    sizes = np.zeros((2, 3))
    for g, name in enumerate(pair):
        if name == "mesh":
            k = int(m.geom_dataid[g])
            meshes[g] = np.array(m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]], dtype=np.float64)
            sizes[g, 0] = m.geom_rbound[g]
        else:
            sizes[g, : len((size1, size2)[g])] = (size1, size2)[g]
    rng = np.random.default_rng(7)
    reach = float(m.geom_rbound[0] + m.geom_rbound[1]) + margin
    poses = []
    for _ in range(N_RANDOM):
        q, u = rng.normal(size=4), rng.normal(size=3)
        poses.append((tuple(u / np.linalg.norm(u) * rng.uniform(0.0, 0.8 * reach)), q / np.linalg.norm(q)))
    xpos, xmat, contacts = posed_contacts(m, rng, poses)
    return xpos, xmat, (sizes, tuple(meshes)), contacts


def polygons_struct(K, polygons, meshes):
    """The kernels' Polygons of `polygons` (per geom: None, or its mesh's (normals (q, 3), vertex index lists (q,)) in
    MuJoCo's mesh_poly order), and each geom's (first, count) of them, their vertices indexed as `_collide` stacks
    `meshes`."""
    normals, ranges, vertex, per_geom, offset = [], [], [], [], 0
    for geom, mesh in zip(polygons, meshes):
        per_geom.append((len(normals), 0 if geom is None else len(geom[0])))
        if geom is not None:
            for normal, indices in zip(*geom):
                normals.append(normal)
                ranges.append((len(vertex), len(indices)))
                vertex.extend(offset + np.asarray(indices))
        offset += 0 if mesh is None else len(mesh)
    P = K.Polygons()
    P.normal = wp.array(np.array(normals, dtype=np.float64).reshape(-1, 3), dtype=K.vec3)
    P.vertices = wp.array(np.array(ranges, dtype=np.int32).reshape(-1, 2), dtype=wp.vec2i)
    P.vertex = wp.array(np.array(vertex, dtype=np.int32), dtype=int)
    return P, per_geom


def _collide(pair, xpos, xmat, shapes, margin, dtype, requires_grad=False, polygons=None):
    """The kernel's inputs (p1, R1, p2, R2) and outputs count (n,), pos (n, k), frame (n, k), dist (n, k): k = 1, or
    CONTACTS with multiCCD's contacts (polygons: each geom's mesh's hull polygons, `polygons_struct`)."""
    K = cc.kernels(wp.float64 if dtype == np.float64 else wp.float32)
    n = len(xpos)
    sizes, meshes = shapes
    inputs = [wp.array(np.ascontiguousarray(a, dtype=dtype), dtype=t, requires_grad=requires_grad) for a, t in ((xpos[:, 0], K.vec3), (xmat[:, 0], K.mat33), (xpos[:, 1], K.vec3), (xmat[:, 1], K.mat33))]
    size = [wp.array(np.broadcast_to(s, (n, 3)).astype(dtype), dtype=K.vec3) for s in sizes]
    vertices = [v for v in meshes if v is not None]
    flat = np.concatenate(vertices) if vertices else np.zeros((1, 3))
    ranges, start = [], 0
    for v in meshes:
        ranges.append((start, len(v)) if v is not None else (0, 0))
        start += len(v) if v is not None else 0
    vr = [wp.array(np.broadcast_to(r, (n, 2)).astype(np.int32), dtype=wp.vec2i) for r in ranges]
    count = wp.full(n, -2, dtype=int)
    multiccd = polygons is not None
    P, per_geom = polygons_struct(K, polygons if multiccd else (None, None), meshes)
    k = cpoly.CONTACTS if multiccd else 1
    pos, frame = (wp.zeros((n, k), dtype=t, requires_grad=requires_grad) for t in (K.vec3, K.mat33))
    dist = wp.array(np.full((n, k), np.nan, dtype=dtype), dtype=K.scalar, requires_grad=requires_grad)  # unwritten without a contact
    wp.launch(
        K.collide, n,
        inputs=[TYPES[pair[0]], TYPES[pair[1]], inputs[0], inputs[1], size[0], inputs[2], inputs[3], size[1], wp.full(n, margin, dtype=K.scalar),
                wp.array(flat.astype(dtype), dtype=K.vec3), vr[0], vr[1], int(multiccd), P,
                *(wp.array(np.broadcast_to(r, (n, 2)).astype(np.int32), dtype=wp.vec2i) for r in per_geom)],
        outputs=[count, pos, frame, dist],
    )  # fmt: skip
    return inputs, count, pos, frame, dist


@pytest.mark.parametrize("margin", MARGINS, ids=["no_margin", "margin"])
@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: "-".join(p))
def test_pair_is_the_contact_and_equals_mujoco(pair, margin):
    """The count, the optimality of the normal, and MuJoCo's contact where its EPA converged (module docstring)."""
    xpos, xmat, shapes, contacts = _reference(pair, margin)
    _, count, pos, frame, dist = _collide(pair, xpos, xmat, shapes, margin, np.float64)
    count, pos, normal, dist = count.numpy(), pos.numpy()[:, 0], frame.numpy()[:, 0, 0], dist.numpy()[:, 0]
    r = _radius(pair, shapes)
    converged = better = 0
    best = _best_separations(pair, shapes, xpos, xmat)
    for i, (mj_pos, mj_frame, mj_dist) in enumerate(contacts):
        if len(mj_dist) != count[i]:  # only on the margin's edge: the contact's dist, found with a wider margin, is the margin
            wider = _collide(pair, xpos[i : i + 1], xmat[i : i + 1], shapes, margin + 1e-3, np.float64)[4].numpy()[0, 0]
            assert abs(wider - margin) < 1e-9, (i, mj_dist, wider)
            continue
        if count[i] == 0:
            continue
        sep = _separation(pair, shapes, xpos[i], xmat[i], normal[i])[0]
        tol = EPA_TOL if dist[i] + r < 0 else GJK_TOL  # the cores overlap (EPA) or not (GJK)
        tol = max(tol, ELLIPSOID_TOL) if "ellipsoid" in pair else tol
        assert abs(dist[i] - (sep - r)) <= tol, i
        assert sep >= best[i] - tol, i
        mj_sep = _separation(pair, shapes, xpos[i], xmat[i], mj_frame[0, 0])[0]
        if abs(mj_dist[0] - (mj_sep - r)) <= 1e-7:
            converged += 1
            assert abs(dist[i] - mj_dist[0]) <= 1e-6, i
            assert np.abs(normal[i] - mj_frame[0, 0]).max() <= MJ_TOL, i
            assert np.abs(pos[i] - mj_pos[0]).max() <= MJ_TOL, i
        else:
            better += 1
            assert sep >= mj_sep - tol, i
    print("-".join(pair), f"margin {margin}: {count.sum()} contacts, MuJoCo converged on {converged}, warpdyn's at least as good on {better}")
    assert count.sum() > N_RANDOM // 2 and (converged > count.sum() // 4 or "ellipsoid" in pair)  # (MuJoCo's EPA seldom converges on these)


@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: "-".join(p))
def test_float32_equals_float64(pair):
    """float32 (GJK and EPA run in float64 in both; float32 rounds the poses, sizes and results): the same counts but
    within the margin's edge, dist to 2e-5 m, and the float32 normal separates the geoms (sep in float64) within 1e-4 m
    of the float64 normal. The normals themselves may differ by 1e-2 where sep is flat about its optimum (a capsule's
    segment across a cylinder's side: sep then moves by 6e-5 m for it)."""
    xpos, xmat, shapes, _ = _reference(pair, 0.1)
    out64 = [a.numpy() for a in _collide(pair, xpos, xmat, shapes, 0.1, np.float64)[1:]]
    out32 = [a.numpy() for a in _collide(pair, xpos, xmat, shapes, 0.1, np.float32)[1:]]
    same = (out64[0] == out32[0]) & (out64[0] == 1)
    edge = out64[0] != out32[0]
    assert np.all(np.abs(np.where(out64[0] == 1, out64[3][:, 0], out32[3][:, 0])[edge] - 0.1) < 1e-5)  # the one that has it
    assert np.all(np.abs(out64[3][same, 0] - out32[3][same, 0]) <= 2e-5)
    for i in np.nonzero(same)[0]:
        sep64, sep32 = (_separation(pair, shapes, xpos[i], xmat[i], out[2][i, 0, 0].astype(np.float64))[0] for out in (out64, out32))
        assert sep32 >= sep64 - 1e-4, i
    assert same.sum() > len(xpos) // 2


@pytest.mark.parametrize("pair", PAIRS, ids=lambda p: "-".join(p))
def test_tape_gradient_of_dist_equals_finite_differences(pair):
    """float64: wp.Tape's gradient of L = sum of dist with respect to both poses, along a random direction, equals the
    central difference at steps 1e-6 and 2e-6 where those agree to 1e-6 and keep the count: to 3e-4 (dist's derivative
    at the held normal and witnesses is exact at the optimum (Danskin), with the witnesses' lever arms as accurate as
    EPA places them on a curved surface: to about the square root of its tolerance, 1e-5 m: 2.2e-4 at most here). With
    an ellipsoid (its witness its exact support point along the normal): the median error 1e-5 and 9 in 10 below 1e-4,
    a few poses in a hundred up to 0.1 where EPA's normal between two curved surfaces is coarse (docs/simulation.md)."""
    xpos, xmat, shapes, _ = _reference(pair, 0.1)

    def run(xpos, xmat):
        return _collide(pair, xpos, xmat, shapes, 0.1, np.float64, requires_grad=True)

    K = cc.kernels(wp.float64)
    c = contact_gradient_check(run, xpos, xmat, 1, K.vec3, K.mat33, position_and_normal=False)
    if "ellipsoid" in pair:  # EPA's normal between curved surfaces is coarse at a few poses (the module's ELLIPSOID_TOL)
        smooth = (np.abs(c["fd1"] - c["fd2"]) < 1e-5) & c["steps_keep_count"] & (c["count"] > 0)
        error = np.abs(c["along"][smooth] - c["fd1"][smooth])
        assert smooth.sum() > len(xpos) // 3
        assert np.median(error) < 2e-5 and np.quantile(error, 0.9) < 1e-4, (np.median(error), np.quantile(error, 0.9), error.max())
        return
    smooth = (np.abs(c["fd1"] - c["fd2"]) < 1e-6) & c["steps_keep_count"] & (c["count"] > 0)
    assert smooth.sum() > len(xpos) // 3
    np.testing.assert_allclose(c["along"][smooth], c["fd1"][smooth], atol=3e-4)


def test_a_meshs_bounding_radius_and_vertices_are_mujocos():
    """warpdyn's geom pairs of an MJCF with the two meshes (a free rock over a static one) carry each mesh's vertices as
    MuJoCo holds them (mesh_vert: recentred, in the geom's frame) and MuJoCo's geom_rbound as its size (the bounding
    sphere of its filter)."""
    import warnings

    import warpdyn as wd

    xml = f"""<mujoco><asset>{_ROCK_ASSETS}</asset><worldbody><geom type="mesh" mesh="rock0" pos="0 0 0.3"/>
      <body pos="0 0 0.6"><freejoint/><geom type="mesh" mesh="rock1"/></body></worldbody></mujoco>"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(xml, dtype=np.float64)
    m = mujoco.MjModel.from_xml_string(xml)
    pairs = wd.contact.geom_pairs(model)
    assert pairs.names == (("geom0", "geom1"),) and (pairs.type1[0], pairs.type2[0]) == (cp.MESH, cp.MESH)
    np.testing.assert_allclose([pairs.size1[0, 0], pairs.size2[0, 0]], m.geom_rbound, rtol=1e-6)
    for geom, (first, count) in enumerate((pairs.vertices1[0], pairs.vertices2[0])):
        k = int(m.geom_dataid[geom])
        np.testing.assert_array_equal(pairs.vertices[first : first + count], m.mesh_vert[m.mesh_vertadr[k] : m.mesh_vertadr[k] + m.mesh_vertnum[k]])


COAXIAL_TOL = 1e-2
"""[m] A round body deep inside another about their common axis: every radial direction separates them equally, and
EPA refines its polytope around a whole circle of them, which its VERTICES cover to a few millimetres (8 mm measured
for a cylinder in a cylinder; MuJoCo's EPA is further off, 6 mm)."""


DEGENERATE = [
    (("cylinder", "box"), (0.03, -0.02, -0.2499), EPA_TOL),  # the cylinder's cap flat on the box's face
    (("cylinder", "cylinder"), (0.02, 0.01, 0.3995), EPA_TOL),  # two caps flat on each other, offset
    (("sphere", "mesh"), (0.0, 0.0, 0.0), EPA_TOL),  # the sphere's centre at the mesh's
    (("mesh", "mesh"), (0.0, 0.0, 0.0), EPA_TOL),  # two meshes about one point
    (("box", "mesh"), (0.0, 0.0, 0.17), EPA_TOL),  # the mesh on the box's face, unturned
    (("cylinder", "cylinder"), (0.0, 0.0, 0.0), COAXIAL_TOL),  # one inside the other, coaxial
    (("capsule", "cylinder"), (0.0, 0.0, 0.0), COAXIAL_TOL),  # the capsule along the cylinder's axis
]
"""Poses where features line up (faces parallel, axes common, centres coincident): geom2's position in geom1's frame,
unturned, and the tolerance of the contact's depth."""
@pytest.mark.parametrize("case", DEGENERATE, ids=lambda c: "-".join(c[0]) + f"@{c[1][2]:g}")
def test_degenerate_poses(case):
    """Where faces lie flat on each other or the geoms share an axis or a centre: the same count as MuJoCo's (one
    contact), a unit normal, a direction that separates the geoms best and a depth that is its own, each to the case's
    tolerance, and a depth at least as near the best as MuJoCo's (its EPA's; the contact's position is not unique on
    a face and is not compared)."""
    pair, position, tol = case
    _, _, shapes, _ = _reference(pair, 0.0)
    m = _mujoco_pair(pair, 0.0)
    xpos, xmat, contacts = posed_contacts(m, np.random.default_rng(11), [(position, np.array([1.0, 0.0, 0.0, 0.0]))])
    _, count, pos, frame, dist = _collide(pair, xpos, xmat, shapes, 0.0, np.float64)
    n, d = frame.numpy()[0, 0, 0], dist.numpy()[0, 0]
    assert count.numpy()[0] == len(contacts[0][2]) == 1
    assert abs(np.linalg.norm(n) - 1.0) < 1e-12
    r = _radius(pair, shapes)
    sep = _separation(pair, shapes, xpos[0], xmat[0], n)[0] - r
    best = _best_separations(pair, shapes, xpos[:1], xmat[:1])[0] - r
    assert abs(d - sep) <= tol and sep >= best - tol, (d, sep, best)
    assert abs(d - best) <= abs(contacts[0][2][0] - best) + 1e-9, (d, best, contacts[0][2])
