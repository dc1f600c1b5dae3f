"""Collidable points (wd.contact): geometry from the collision shapes, and their kinematics (the enabled
mask, in_contact, velocities and Jacobians). Their derivatives against finite differences are in
tests/test_contact_derivatives.py; the seed's ergoCub with its points and random states for it, which
both files use, in tests/robots.py.

References:
- C MuJoCo (float64) on the same description, compiled with `fusestatic` off so that every URDF link
  (lumped ones included) is a body whose collision geoms keep their world poses (geom_xpos, geom_xmat);
  the shapes' surfaces and corners are computed from those poses and MuJoCo's geom sizes, never from
  warpdyn's shapes. Joints are mapped by name (robots.MujocoState).
- The URDF text itself (the box sizes and origins of ergoCub's feet, read with ElementTree).
- Identities: J·ν equals the point velocities.
Tolerances are absolute, scaled by the size of what is compared (at least 1 m): float64 1e-10 (a few
composed transforms, rounding ~1e-15 observed), float32 1e-5 (float32 epsilon 1.2e-7 accumulated over up
to ~10 composed transforms and lever arms of a few metres: observed ≤ 4e-7 against float64 and MuJoCo).
"""

from __future__ import annotations

import dataclasses
import itertools
import pathlib
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import NO_MESH, ergocub_full_model, ergocub_seed_model, ergocub_seed_with_points, random_state_kwargs
from warpdyn import VelRepr
from warpdyn.description.collidable import capsule_points, cylinder_points, ellipsoid_points, farthest_point_subsample, sphere_points

REPRS = (VelRepr.Body, VelRepr.Mixed, VelRepr.Inertial)
TOL = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 1e-5}


def _tol(dtype, *refs) -> float:
    scale = max([1.0] + [float(np.max(np.abs(r))) for r in refs if np.size(r)])
    return TOL[np.dtype(dtype)] * scale


# ------------------------------------------------------------------------------------------ robots


def _shapes_urdf(seed: int, fixed_base: bool = False) -> str:
    """robots.random_tree_urdf(seed) with 1 or 2 random collision shapes (box, sphere, cylinder) on every link."""
    root = ET.fromstring(robots.random_tree_urdf(seed, fixed_base=fixed_base))
    rng = np.random.default_rng(seed + 100)
    for link in root.findall("link"):
        if link.get("name") == "world":
            continue
        for _ in range(int(rng.integers(1, 3))):
            kind = rng.choice(["box", "sphere", "cylinder"])
            xyz, rpy = rng.uniform(-0.3, 0.3, 3), rng.uniform(-np.pi, np.pi, 3)
            collision = ET.SubElement(link, "collision")
            ET.SubElement(collision, "origin", xyz=" ".join(f"{v:.17g}" for v in xyz), rpy=" ".join(f"{v:.17g}" for v in rpy))
            geometry = ET.SubElement(collision, "geometry")
            if kind == "box":
                ET.SubElement(geometry, "box", size=" ".join(f"{v:.17g}" for v in rng.uniform(0.02, 0.4, 3)))
            elif kind == "sphere":
                ET.SubElement(geometry, "sphere", radius=f"{rng.uniform(0.02, 0.2):.17g}")
            else:
                ET.SubElement(geometry, "cylinder", radius=f"{rng.uniform(0.02, 0.2):.17g}", length=f"{rng.uniform(0.05, 0.5):.17g}")
    return ET.tostring(root, encoding="unicode")


def _mujoco_keep_primitives(urdf_text: str, considered, floating: bool):
    """MuJoCo's model of a URDF with every link a body: visuals and mesh collisions removed, primitive
    collisions kept as geoms, joints not considered made fixed."""
    return robots.mujoco_model(
        urdf_text, considered, floating=floating, fuse_static=False,
        keep_collision=lambda collision: collision.find("geometry/mesh") is None,
    )


def _mujoco_at(mj, model, state):
    """MuJoCo data at a single-environment warpdyn state given with Mixed base velocity."""
    mjs = robots.MujocoState(mj, model.joint_names(), model.floating_base())
    mixed = np.concatenate([state["base_linear_velocity"], state["base_angular_velocity"]])
    mjs.set(state["base_position"], state["base_quaternion"], state["joint_positions"], mixed, state["joint_velocities"])
    return mjs


def _assert_same_points(actual, expected, tol, what=""):
    """The two point sets (K, 3) are equal up to order: a bijection with distances <= tol."""
    assert actual.shape == expected.shape, what
    distance = np.linalg.norm(actual[:, None, :] - expected[None, :, :], axis=2)
    nearest = np.argmin(distance, axis=0)
    assert np.all(distance[nearest, np.arange(len(expected))] <= tol), f"{what}: {distance.min(axis=0).max()}"
    assert len(np.unique(nearest)) == len(expected), f"{what}: not a bijection"


def _kept_link(model, body_name: str) -> int:
    """The index of the link that the description's link `body_name` is lumped into (or is)."""
    if body_name in model.link_names():
        return model.link_names().index(body_name)
    return int(model.tree.frame_parent[model.frame_names().index(body_name)])


def _geom_world(mj, d, g):
    return d.geom_xpos[g].copy(), d.geom_xmat[g].reshape(3, 3).copy(), mj.geom_size[g].copy(), int(mj.geom_type[g])


def _on_geom(points, xpos, xmat, size, kind, tol):
    """Which of `points` (K, 3) lie on the surface of a MuJoCo geom (box: only its corners count)."""
    local = (points - xpos) @ xmat
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return np.all(np.abs(np.abs(local) - size) <= tol, axis=1)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return np.abs(np.linalg.norm(local, axis=1) - size[0]) <= tol
    rho, z = np.linalg.norm(local[:, :2], axis=1), local[:, 2]
    r, half = size[0], size[1]
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        side = (np.abs(rho - r) <= tol) & (np.abs(z) <= half + tol)
        cap = (np.abs(np.abs(z) - half) <= tol) & (rho <= r + tol)
        return side | cap
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        axis_point = np.stack([np.zeros_like(z), np.zeros_like(z), np.clip(z, -half, half)], axis=1)
        return np.abs(np.linalg.norm(local - axis_point, axis=1) - r) <= tol
    raise AssertionError(f"unexpected geom type {kind}")


def _expected_count(kind, options) -> int:
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return 8
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return options.sphere_points
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return (2 + options.side_rings) * options.circle_points + 2
    return 2 * (options.capsule_cap_rings * options.circle_points + 1) + options.side_rings * options.circle_points


def _check_points_against_mujoco(model, mj, d, W_p_C, options, tol):
    """Every point lies on a geom of a description link lumped into its own link; every box corner is a
    point; each link has the number of points its geoms should give."""
    body = np.asarray(model.kin_dyn_parameters.contact_parameters.body)
    expected = np.zeros(model.number_of_links(), dtype=int)
    covered = np.zeros(len(body), dtype=bool)
    for g in range(mj.ngeom):
        name = mj.body(int(mj.geom_bodyid[g])).name
        if int(mj.geom_bodyid[g]) == 0 or (mj.geom_contype[g] == 0 and mj.geom_conaffinity[g] == 0):
            continue
        L = _kept_link(model, name)
        xpos, xmat, size, kind = _geom_world(mj, d, g)
        expected[L] += _expected_count(kind, options)
        mine = np.flatnonzero(body == L)
        on = _on_geom(W_p_C[mine], xpos, xmat, size, kind, tol)
        covered[mine[on]] = True
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            corners = xpos + np.array(list(itertools.product((-1, 1), repeat=3))) * size @ xmat.T
            for corner in corners:
                assert np.min(np.linalg.norm(W_p_C[mine] - corner, axis=1)) <= tol, f"box corner of geom {g} on '{name}'"
        else:
            assert np.count_nonzero(on) >= _expected_count(kind, options), f"points on geom {g} ({kind}) of '{name}'"
    assert covered.all(), f"points on no geom of their link: {np.flatnonzero(~covered)}"
    np.testing.assert_array_equal(np.bincount(body, minlength=model.number_of_links()), expected)


# ----------------------------------------------------------------------------------- seed ergoCub


def test_seed_ergocub_has_the_seeds_32_points_on_the_ankles(dtype):
    """The seed's reduced ergoCub: 4 foot boxes (2 per foot, on l/r_foot_front/rear, lumped into
    l/r_ankle_2) give 32 points, all enabled, and no warning (meshes are off by default, as in JaxSim);
    with meshes requested, its unresolved package:// meshes give one warning that names them and the
    same 32 points. Reference: the seed notebook's n_cp = 32 (JaxSim) and the URDF text."""
    model = ergocub_seed_model(dtype)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        params = wd.model.reduce(model, model.joint_names()).kin_dyn_parameters  # a fresh model: built here
    assert not [w for w in caught if issubclass(w.category, wd.contact.UnresolvedMeshWarning)]
    with_meshes = wd.contact.CollidablePointsOptions(shapes=("box", "sphere", "mesh"))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        meshed = wd.contact.with_collidable_points(model, options=with_meshes).kin_dyn_parameters
    mesh_warnings = [w for w in caught if issubclass(w.category, wd.contact.UnresolvedMeshWarning)]
    assert len(mesh_warnings) == 1
    message = str(mesh_warnings[0].message)
    assert message.startswith("62 collision mesh(es)")
    assert "on link 'l_ankle_2': ['package://ergoCub/meshes/simmechanics/sim_ecub_1-1_l_ankle_2.stl']" in message
    assert len(meshed.contact_parameters.body) == 32
    cp = params.contact_parameters
    assert len(cp.body) == 32 and cp.point.shape == (32, 3) and all(cp.enabled)
    names = [model.link_names()[b] for b in cp.body]
    assert names.count("l_ankle_2") == 16 and names.count("r_ankle_2") == 16
    assert len(cp.indices_of_enabled_collidable_points) == 32
    # Without meshes (JaxSim's default), the same points and no warning.
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        no_mesh = ergocub_seed_with_points(dtype).kin_dyn_parameters.contact_parameters
    np.testing.assert_array_equal(no_mesh.point, cp.point)
    assert no_mesh.body == cp.body


def test_seed_points_are_the_foot_box_corners_moved_to_the_ankle(dtype):
    """The points are the 8 corners of each foot box, on the lumped links l/r_foot_front/rear, expressed
    in l/r_ankle_2. References: (1) the URDF's box sizes and origins (ElementTree) composed with the
    lumped frames' poses wd.frame.transform; (2) MuJoCo's world poses of the same boxes (fusestatic off).
    Corners are compared as sets (sorted lexicographically), so the test does not depend on the order."""
    model = ergocub_seed_with_points(dtype)
    root = ET.fromstring(robots.ergocub_urdf())
    rng = np.random.default_rng(7)
    state = random_state_kwargs(model, rng)
    data = wd.data.Data.build(model, **state)
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy()
    assert W_p_C.shape == (32, 3)
    expected = []
    for foot in ("l_foot_front", "l_foot_rear", "r_foot_front", "r_foot_rear"):
        collision = root.find(f"link[@name='{foot}']/collision")
        size = np.array(collision.find("geometry/box").get("size").split(), dtype=float)
        xyz = np.array(collision.find("origin").get("xyz").split(), dtype=float)
        assert collision.find("origin").get("rpy").split() == ["0", "-0", "0"]
        W_H_F = wd.frame.transform(model, data, frame_index=wd.frame.name_to_idx(model, frame_name=foot)).numpy()
        for signs in itertools.product((-0.5, 0.5), repeat=3):
            expected.append(W_H_F[:3, :3] @ (xyz + np.array(signs) * size) + W_H_F[:3, 3])
    expected = np.array(expected)
    _assert_same_points(W_p_C.astype(np.float64), expected, _tol(dtype, expected), "foot boxes")
    mj = _mujoco_keep_primitives(robots.ergocub_urdf(), robots.seed_joints(ergocub_full_model(np.float64).joint_names()), True)
    mjs = _mujoco_at(mj, model, state)
    _check_points_against_mujoco(model, mj, mjs.d, W_p_C.astype(np.float64), NO_MESH, _tol(dtype, W_p_C))


def test_seed_contact_transforms_are_point_position_and_link_orientation(dtype):
    """W_H_C = (link orientation, point position). References: MuJoCo's body orientation of the point's
    link (xmat), and the points' positions (checked against MuJoCo above); batched equals single."""
    model = ergocub_seed_with_points(dtype)
    rng = np.random.default_rng(8)
    state = random_state_kwargs(model, rng, num_envs=3)
    data = wd.data.Data.build(model, **state, num_envs=3)
    W_H_C = wd.contact.transforms(model, data).numpy()
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy()
    assert W_H_C.shape == (3, 32, 4, 4) and W_p_C.shape == (3, 32, 3)
    body = model.kin_dyn_parameters.contact_parameters.body
    mj = _mujoco_keep_primitives(robots.ergocub_urdf(), robots.seed_joints(ergocub_full_model(np.float64).joint_names()), True)
    for e in range(3):
        single = {k: v[e] for k, v in state.items()}
        mjs = _mujoco_at(mj, model, single)
        R = np.array([mjs.body_pose(model.link_names()[b])[1] for b in body])
        tol = _tol(dtype, W_p_C[e])
        np.testing.assert_allclose(W_H_C[e, :, :3, :3], R, rtol=0, atol=tol)
        np.testing.assert_allclose(W_H_C[e, :, :3, 3], W_p_C[e], rtol=0, atol=tol)
        np.testing.assert_array_equal(W_H_C[e, :, 3], np.tile([0, 0, 0, 1], (32, 1)))
        d1 = wd.data.Data.build(model, **single)
        np.testing.assert_allclose(wd.contact.transforms(model, d1).numpy(), W_H_C[e], rtol=0, atol=tol)


def test_seed_centroidal_cell_17(dtype):
    """The seed's cell 17 ported line by line: G_Xf_C = Adjoint.from_transform(G_H_W @ W_H_C, inverse=True)
    is (32, 6, 6), batched without vmap. Reference: the blocks [[R^T, -R^T (p - c)^], [0, R^T]] written out
    with NumPy from W_H_C and the CoM c (computed here with NumPy from the link poses and the lumped
    masses; wd.com is another module)."""
    model = ergocub_seed_with_points(dtype)
    data = wd.data.random_model_data(model, key=3)
    n_cp = len(model.kin_dyn_parameters.contact_parameters.body)
    assert n_cp == 32
    W_H_C = wd.contact.transforms(model=model, data=data)
    W_H_L = wd.model.forward_kinematics(model, data).numpy().astype(np.float64)
    m = model.tree.link_mass
    W_p_CoM = np.einsum("l,lij,lj->i", m, W_H_L[:, :3, :3], model.tree.link_com) / m.sum()
    W_p_CoM += np.einsum("l,li->i", m, W_H_L[:, :3, 3]) / m.sum()
    G_H_W = wd.math.Transform.inverse(wd.math.Transform.from_rotation_and_translation(translation=W_p_CoM))
    G_Xf_C = wd.math.Adjoint.from_transform(transform=G_H_W @ W_H_C.numpy(), inverse=True)  # JAX's arrays mix with NumPy; Warp's off the CPU do not
    assert G_Xf_C.shape == (32, 6, 6)
    H = W_H_C.numpy().astype(np.float64)
    R, p = H[:, :3, :3], H[:, :3, 3] - W_p_CoM
    Rt = np.swapaxes(R, 1, 2)
    ref = np.zeros((32, 6, 6))
    ref[:, :3, :3], ref[:, 3:, 3:] = Rt, Rt
    ref[:, :3, 3:] = -Rt @ np.array([robots.skew(v) for v in p])
    np.testing.assert_allclose(G_Xf_C, ref, rtol=0, atol=_tol(dtype, ref))
    C_fl = np.random.default_rng(0).uniform(-10.0, 10.0, size=(n_cp, 3))
    G_hdot = 0
    G_hdot += wd.model.total_mass(model) * np.hstack([0, 0, model.gravity, 0, 0, 0])
    # The seed writes einsum("c66,c6->6", ...): JAX reads the repeated "6" as a diagonal; NumPy needs
    # letters. The port contracts the matrix with the force, which is what the cell means.
    G_hdot += np.einsum("cij,cj->i", G_Xf_C, np.hstack([C_fl, np.zeros_like(C_fl)]))
    assert G_hdot.shape == (6,)


# ------------------------------------------------------------------------- random trees and MJCF


@pytest.mark.parametrize("seed, fixed_base", ((0, False), (3, False), (4, True)))
def test_random_tree_points_lie_on_mujoco_geoms(seed, fixed_base, dtype):
    """Boxes, spheres and cylinders on every link of random trees, lumped links included (their points
    move to the kept link). Reference: MuJoCo's geoms (fusestatic off: every URDF link a body) at the
    same state: each point lies on a geom of a link lumped into (or equal to) its own link, every box
    corner is a point, and the number of points per link is what the shapes give."""
    text = _shapes_urdf(seed, fixed_base=fixed_base)
    model = wd.model.Model.build_from_model_description(text, dtype=dtype)
    assert model.number_of_frames() > 0, "the tree should have lumped links"
    options = model.kin_dyn_parameters.options
    mj = _mujoco_keep_primitives(text, None, model.floating_base())
    rng = np.random.default_rng(seed)
    state = random_state_kwargs(model, rng)
    data = wd.data.Data.build(model, **state)
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy().astype(np.float64)
    mjs = _mujoco_at(mj, model, state)
    _check_points_against_mujoco(model, mj, mjs.d, W_p_C, options, _tol(dtype, W_p_C))


MJCF = """
<mujoco model="shapes">
  <worldbody>
    <body name="base" pos="0.1 0.2 0.8" quat="0.9 0.1 -0.2 0.3">
      <freejoint/>
      <inertial pos="0 0 0" mass="2" diaginertia="0.1 0.1 0.1"/>
      <geom type="box" size="0.1 0.2 0.05" pos="0.01 0.02 0.03" euler="10 20 30"/>
      <geom type="sphere" size="0.07" pos="0 0.1 -0.2"/>
      <geom type="sphere" size="0.5" contype="0" conaffinity="0"/>
      <body name="arm" pos="0.3 0 0" euler="0 30 0">
        <joint name="hinge" type="hinge" axis="0 1 0" pos="0 0 0.05"/>
        <inertial pos="0 0 -0.1" mass="1" diaginertia="0.01 0.01 0.01"/>
        <geom type="capsule" size="0.04 0.15" pos="0 0 -0.15" euler="5 0 0"/>
        <body name="hand" pos="0 0 -0.35" euler="0 0 45">
          <inertial pos="0 0 0" mass="0.3" diaginertia="0.001 0.001 0.001"/>
          <geom type="cylinder" size="0.05 0.02" pos="0.01 0 0"/>
          <geom type="capsule" fromto="0 0 0 0.1 0.1 0" size="0.02"/>
        </body>
      </body>
      <body name="slider" pos="-0.2 0 0">
        <joint name="slide" type="slide" axis="1 0 0"/>
        <inertial pos="0 0 0" mass="0.5" diaginertia="0.01 0.01 0.01"/>
        <geom type="cylinder" size="0.03 0.1" euler="90 0 0"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mjcf_shapes_lie_on_mujoco_geoms(dtype):
    """An MJCF with a box, spheres (one visual-only: no points), capsules (one given by fromto) and
    cylinders, on a floating base, a hinge, a welded body (lumped into the hinge's link) and a slider.
    Reference: MuJoCo's own geom poses and sizes on the same MJCF at the same state. Also checks the
    non-default options (more sphere points, side rings, cap rings)."""
    options = wd.contact.CollidablePointsOptions(sphere_points=20, circle_points=7, side_rings=2, capsule_cap_rings=3)
    model = wd.contact.with_collidable_points(
        wd.model.Model.build_from_model_description(MJCF, dtype=dtype), options=options
    )
    assert model.frame_names() == ("hand",)
    mj = mujoco.MjModel.from_xml_string(MJCF)
    rng = np.random.default_rng(5)
    state = random_state_kwargs(model, rng)
    data = wd.data.Data.build(model, **state)
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy().astype(np.float64)
    mjs = _mujoco_at(mj, model, state)
    _check_points_against_mujoco(model, mj, mjs.d, W_p_C, options, _tol(dtype, W_p_C))
    counts = np.bincount(model.kin_dyn_parameters.contact_parameters.body, minlength=3)
    assert counts.tolist() == [8 + 20, 2 * (3 * 7 + 1) + 2 * 7 + 4 * 7 + 2 + 2 * (3 * 7 + 1) + 2 * 7, 4 * 7 + 2]


def test_shape_points_lie_on_the_surfaces():
    """Sphere, ellipsoid, cylinder and capsule points in their own frame: on the surface, the expected counts, rims
    and caps present, spread out (no duplicates). Reference: the implicit surface equations."""
    r, L = 0.3, 0.8
    S = sphere_points(r, 50)
    assert S.shape == (50, 3)
    np.testing.assert_allclose(np.linalg.norm(S, axis=1), r, atol=1e-15)
    assert abs(S[:, 1].max() - r) < 1e-15 and abs(S[:, 1].min() + r) < 1e-15
    C = cylinder_points(r, L, 16, side_rings=1)
    rho = np.linalg.norm(C[:, :2], axis=1)
    assert C.shape == (3 * 16 + 2, 3)
    np.testing.assert_allclose(rho[:48], r, atol=1e-15)
    np.testing.assert_allclose(np.sort(np.unique(np.round(C[:48, 2], 12))), [-L / 2, 0.0, L / 2], atol=1e-12)
    np.testing.assert_allclose(C[48:], [[0, 0, -L / 2], [0, 0, L / 2]])
    K = capsule_points(r, L, 12, cap_rings=2, side_rings=0)
    assert K.shape == (2 * (2 * 12 + 1), 3)
    closest = np.stack([np.zeros(len(K)), np.zeros(len(K)), np.clip(K[:, 2], -L / 2, L / 2)], axis=1)
    np.testing.assert_allclose(np.linalg.norm(K - closest, axis=1), r, atol=1e-15)
    assert np.isclose(K[:, 2].min(), -L / 2 - r) and np.isclose(K[:, 2].max(), L / 2 + r)
    E = ellipsoid_points([0.3, 0.2, 0.1], 50)
    np.testing.assert_allclose(np.sum((E / [0.3, 0.2, 0.1]) ** 2, axis=1), 1.0, atol=1e-14)
    assert E.shape == (50, 3) and np.isclose(E[:, 1].max(), 0.2) and np.isclose(E[:, 1].min(), -0.2)
    for points in (S, C, K, E):
        assert len(np.unique(np.round(points, 12), axis=0)) == len(points)


# ---------------------------------------------------------------------------------------- meshes


def _write_mesh(directory: pathlib.Path, name: str) -> np.ndarray:
    """An OBJ tetrahedron-like mesh with 5 distinct vertices; returns the vertices."""
    vertices = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 2.0, 0.0], [0.0, 0.0, 3.0], [0.5, 0.5, 0.5]])
    faces = [(1, 2, 3), (1, 2, 4), (1, 3, 4), (2, 3, 4), (1, 2, 5)]
    lines = [f"v {x} {y} {z}" for x, y, z in vertices] + [f"f {a} {b} {c}" for a, b, c in faces]
    (directory / name).write_text("\n".join(lines) + "\n")
    return vertices


def _mesh_urdf(uris) -> str:
    collisions = "".join(
        f'<collision><origin xyz="0.1 0.2 0.3" rpy="0.3 0.2 0.1"/><geometry><mesh filename="{uri}" scale="0.1 0.2 0.3"/>'
        "</geometry></collision>"
        for uri in uris
    )
    return (
        '<robot name="meshes"><link name="base"><inertial><mass value="1"/>'
        '<inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>'
        f"{collisions}</link></robot>"
    )


def test_meshes_resolve_or_warn_once(tmp_path, dtype):
    """URDF meshes: an absolute path, file://, package:// (through package_dirs) and a relative path
    (through mesh_dirs) resolve and give their scaled vertices in the link frame; two missing meshes
    give one UnresolvedMeshWarning naming both; mesh_max_points subsamples. Reference: the vertices
    written to the OBJ files, transformed with NumPy (origin rpy as URDF's fixed-axis X-Y-Z)."""
    package = tmp_path / "share" / "mypkg" / "meshes"
    package.mkdir(parents=True)
    vertices = _write_mesh(package, "part.obj")
    uris = [
        str(package / "part.obj"),
        f"file://{package / 'part.obj'}",
        "package://mypkg/meshes/part.obj",
        "meshes/part.obj",
        "package://missing/meshes/nothing.stl",
        "nowhere/nothing.obj",
    ]
    model = wd.model.Model.build_from_model_description(_mesh_urdf(uris), dtype=dtype)
    options = wd.contact.CollidablePointsOptions(shapes=("box", "sphere", "mesh"), package_dirs=(str(tmp_path / "share"),), mesh_dirs=(str(tmp_path / "share" / "mypkg"),))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = wd.contact.with_collidable_points(model, options=options)
    assert len(caught) == 1 and issubclass(caught[0].category, wd.contact.UnresolvedMeshWarning)
    assert "package://missing/meshes/nothing.stl" in str(caught[0].message)
    assert "nowhere/nothing.obj" in str(caught[0].message)
    cp = model.kin_dyn_parameters.contact_parameters
    assert len(cp.body) == 4 * 5
    a, b, c = 0.3, 0.2, 0.1  # URDF rpy: R = Rz(yaw) Ry(pitch) Rx(roll)
    Rx = np.array([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])
    Ry = np.array([[np.cos(b), 0, np.sin(b)], [0, 1, 0], [-np.sin(b), 0, np.cos(b)]])
    Rz = np.array([[np.cos(c), -np.sin(c), 0], [np.sin(c), np.cos(c), 0], [0, 0, 1]])
    expected = (vertices * [0.1, 0.2, 0.3]) @ (Rz @ Ry @ Rx).T + [0.1, 0.2, 0.3]
    for k in range(4):
        _assert_same_points(cp.point[5 * k : 5 * k + 5], expected, 1e-12, f"mesh {uris[k]}")
    data = wd.data.Data.build(model)
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy()
    np.testing.assert_allclose(W_p_C, cp.point, atol=_tol(dtype, cp.point))
    subsample = dataclasses.replace(options, shapes=("mesh",), mesh_max_points=3)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        sub = wd.contact.with_collidable_points(model, options=subsample)
    assert len(caught) == 1
    sub_points = sub.kin_dyn_parameters.contact_parameters.point
    assert sub_points.shape == (4 * 3, 3)
    for k in range(4):  # each subsample: 3 distinct vertices of the mesh
        distance = np.linalg.norm(sub_points[3 * k : 3 * k + 3, None] - expected[None], axis=2)
        assert np.all(distance.min(axis=1) <= 1e-12) and len(set(distance.argmin(axis=1))) == 3
    # The subsample itself: greedy farthest points from the lowest one, kept in their order.
    line = np.array([[0.0, 0.0, z] for z in (3.0, -1.0, 0.5, 10.0, 9.0, 4.0)])
    np.testing.assert_array_equal(farthest_point_subsample(line, 3)[:, 2], [-1.0, 10.0, 4.0])
    np.testing.assert_array_equal(farthest_point_subsample(line, 4)[:, 2], [-1.0, 0.5, 10.0, 4.0])


# -------------------------------------------------------------------------- enabled points, API


def test_enabled_mask_selects_points_and_leaves_the_model_unchanged(dtype):
    """enabled_links / enabled masks: len(body) counts all points, the functions return the enabled
    ones (as JaxSim); the original model keeps all points. Reference: the all-points results indexed
    with the mask."""
    model = ergocub_seed_with_points(dtype)
    data = wd.data.random_model_data(model, key=4)
    left = wd.contact.with_collidable_points(model, enabled_links=("l_ankle_2",))
    cp = left.kin_dyn_parameters.contact_parameters
    assert len(cp.body) == 32 and sum(cp.enabled) == 16
    idx = cp.indices_of_enabled_collidable_points
    assert all(left.link_names()[cp.body[i]] == "l_ankle_2" for i in idx)
    full_p = wd.contact.collidable_point_positions(model, data).numpy()
    np.testing.assert_array_equal(wd.contact.collidable_point_positions(left, data).numpy(), full_p[idx])
    np.testing.assert_array_equal(wd.contact.transforms(left, data).numpy(), wd.contact.transforms(model, data).numpy()[idx])
    np.testing.assert_array_equal(wd.contact.jacobian(left, data).numpy(), wd.contact.jacobian(model, data).numpy()[idx])
    np.testing.assert_array_equal(
        wd.contact.collidable_point_velocities(left, data).numpy(), wd.contact.collidable_point_velocities(model, data).numpy()[idx]
    )
    assert sum(model.kin_dyn_parameters.contact_parameters.enabled) == 32
    mask = np.zeros(32, dtype=bool)
    mask[[0, 5, 31]] = True
    some = wd.contact.with_collidable_points(model, enabled=mask)
    np.testing.assert_array_equal(wd.contact.collidable_point_positions(some, data).numpy(), full_p[[0, 5, 31]])
    none = wd.contact.with_collidable_points(model, enabled=np.zeros(32, dtype=bool))
    assert wd.contact.collidable_point_positions(none, data).shape == (0, 3)
    assert wd.contact.jacobian(none, data).shape == (0, 6, 6 + model.dofs())
    assert wd.contact.transforms(none, data).shape == (0, 4, 4)
    assert wd.contact.collidable_point_velocities(none, data).shape == (0, 3)
    assert not wd.contact.in_contact(none, data).numpy().any()
    pointless = wd.contact.with_collidable_points(none, enabled_links=())  # a model without points: nothing to disable
    assert len(pointless.kin_dyn_parameters.contact_parameters.enabled) == 32 and not any(pointless.kin_dyn_parameters.contact_parameters.enabled)
    bare = wd.model.Model.build_from_model_description(robots.random_tree_urdf(3), dtype=dtype)
    bare = wd.contact.with_collidable_points(wd.contact.with_collidable_points(bare, enabled_links=()), enabled_links=())
    assert len(bare.kin_dyn_parameters.contact_parameters.body) == 0
    with pytest.raises(ValueError, match="expected \\(32,\\)"):
        wd.contact.with_collidable_points(model, enabled=np.ones(31, dtype=bool))
    with pytest.raises(TypeError, match="boolean"):
        wd.contact.with_collidable_points(model, enabled=np.ones(32))
    with pytest.raises(ValueError, match="no link named"):
        wd.contact.with_collidable_points(model, enabled_links=("l_foot",))
    with pytest.raises(ValueError, match="not both"):
        wd.contact.with_collidable_points(model, enabled=mask, enabled_links=("l_ankle_2",))
    with pytest.raises(ValueError, match="unknown kinds"):
        wd.contact.CollidablePointsOptions(shapes=("cone",))
    with pytest.raises(ValueError, match="sphere_points"):
        wd.contact.CollidablePointsOptions(sphere_points=1)


def test_in_contact_against_flat_ground(dtype):
    """in_contact: a link is in contact when any of its enabled points has z <= 0. Reference: NumPy on
    the point positions (checked against MuJoCo above), for batched random states placed near the
    ground, all links and a subset by name; a link without points is never in contact."""
    model = ergocub_seed_with_points(dtype)
    rng = np.random.default_rng(9)
    N = 16
    data = wd.data.Data.build(model, **random_state_kwargs(model, rng, N, z_range=(-0.2, 1.2)), num_envs=N)
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy()
    body = np.asarray(model.kin_dyn_parameters.contact_parameters.body)
    contact = wd.contact.in_contact(model, data).numpy()
    assert contact.shape == (N, model.number_of_links()) and contact.dtype == bool
    ref = np.array([[np.any(W_p_C[e, body == L, 2] <= 0.0) for L in range(model.number_of_links())] for e in range(N)])
    np.testing.assert_array_equal(contact, ref)
    assert ref[:, model.link_names().index("l_ankle_2")].any() and not ref.all()
    names = ("r_ankle_2", "root_link", "l_ankle_2")
    sub = wd.contact.in_contact(model, data, link_names=names).numpy()
    np.testing.assert_array_equal(sub, ref[:, [model.link_names().index(n) for n in names]])
    assert not sub[:, 1].any()
    # Single environment: the robot upright, lowered until its left foot is 1 mm below the ground.
    upright = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()
    lowest_left = upright[body == model.link_names().index("l_ankle_2"), 2].max()
    single = wd.data.Data.build(model, base_position=[0.0, 0.0, -lowest_left - 1e-3])
    assert wd.contact.in_contact(model, single, link_names="l_ankle_2").numpy().tolist() == [True]
    assert wd.contact.in_contact(model, single).shape == (model.number_of_links(),)


# --------------------------------------------------------------------------- velocities, Jacobians


@pytest.mark.parametrize("in_repr", REPRS)
def test_point_velocities_equal_jacobian_times_nu(in_repr, dtype):
    """collidable_point_velocities equals the linear rows of the Mixed-output contact Jacobian times ν
    (the data's representation), whatever that representation; the Inertial and Body outputs are the
    Mixed one mapped by the contact frame's transforms (NumPy, from wd.contact.transforms); the linear
    Mixed rows equal MuJoCo's point Jacobian (mj_jac, converted to warpdyn's Mixed input).
    Tolerance: as the module's (two code paths summing the same ~18 terms)."""
    model = ergocub_seed_with_points(dtype)
    rng = np.random.default_rng(10 + int(in_repr))
    state = random_state_kwargs(model, rng)
    data = wd.data.Data.build(model, **state, velocity_representation=in_repr)
    nu = data.generalized_velocity.numpy()
    v = wd.contact.collidable_point_velocities(model, data).numpy()
    J = {Y: wd.contact.jacobian(model, data, output_vel_repr=Y).numpy() for Y in REPRS}
    assert v.shape == (32, 3) and J[VelRepr.Mixed].shape == (32, 6, 6 + model.dofs())
    np.testing.assert_array_equal(wd.contact.jacobian(model, data).numpy(), J[in_repr])
    tol = _tol(dtype, v, J[VelRepr.Mixed])
    np.testing.assert_allclose(J[VelRepr.Mixed][:, :3] @ nu, v, rtol=0, atol=tol)
    H = wd.contact.transforms(model, data).numpy().astype(np.float64)
    for c in range(32):
        R, p = H[c, :3, :3], H[c, :3, 3]
        np.testing.assert_allclose(J[VelRepr.Inertial][c], robots.from_mixed("Inertial", R, p) @ J[VelRepr.Mixed][c], rtol=0, atol=tol)
        np.testing.assert_allclose(J[VelRepr.Body][c], robots.from_mixed("Body", R, p) @ J[VelRepr.Mixed][c], rtol=0, atol=tol)
    # MuJoCo: Mixed input, so convert this data's Jacobian to Mixed input first.
    T = np.eye(6 + model.dofs())
    W_H_B = data.base_transform.numpy().astype(np.float64)
    T[:6, :6] = robots.from_mixed(in_repr.name, W_H_B[:3, :3], W_H_B[:3, 3])
    mj = _mujoco_keep_primitives(robots.ergocub_urdf(), robots.seed_joints(ergocub_full_model(np.float64).joint_names()), True)
    mjs = _mujoco_at(mj, model, state)
    for c in (0, 9, 17, 31):
        jacp, jacr = np.zeros((3, mj.nv)), np.zeros((3, mj.nv))
        body = mj.body(model.link_names()[model.kin_dyn_parameters.contact_parameters.body[c]]).id
        mujoco.mj_jac(mj, mjs.d, jacp, jacr, H[c, :3, 3], body)
        ref = np.zeros((3, 6 + model.dofs()))
        ref[:, :3] = jacp[:, :3]
        ref[:, 3:6] = jacp[:, 3:6] @ robots.rotation_wxyz(mjs.d.qpos[3:7]).T
        ref[:, 6:] = jacp[:, mjs.dof_adr]
        np.testing.assert_allclose(J[VelRepr.Mixed][c, :3] @ T, ref, rtol=0, atol=tol, err_msg=f"point {c}")

