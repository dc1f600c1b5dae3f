"""Data: building, defaults, random data, replace, velocity representations, derived base quantities.

References: the documented contract of warpdyn.data (defaults, shapes, bounds), the inputs themselves
(copies must be exact), the description's welded base pose parsed independently from the URDF text, and
host-side NumPy formulas for quaternion -> rotation. Tolerances are exact for copies and a few ulps
(float64 1e-14, float32 1e-6) for a normalisation or a quaternion-to-matrix conversion, as each test says.

Layouts: tests that move per-environment arrays run in both physical layouts of warpdyn.arrays (the
device's default, env-major on the CPU, and env-fastest, the GPU's), so a CPU run covers both.
"""

from __future__ import annotations

import functools
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from warpdyn import VelRepr

REPRS = (VelRepr.Body, VelRepr.Mixed, VelRepr.Inertial)


@functools.cache
def _model(name: str, dtype=np.float64) -> wd.model.Model:
    if name == "tree":  # floating base; revolute, prismatic and continuous (unlimited) joints
        return wd.model.Model.build_from_model_description(robots.random_tree_urdf(0), dtype=dtype)
    if name == "fixed":
        return wd.model.Model.build_from_model_description(robots.random_tree_urdf(5, fixed_base=True), dtype=dtype)
    if name == "icub_legs":
        urdf = robots.icub_urdf()
        full = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        return wd.model.Model.build_from_model_description(
            urdf, considered_joints=robots.icub_leg_joints(full.joint_names()), dtype=dtype
        )
    if name == "ergocub_seed":
        urdf = robots.ergocub_urdf()
        full = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        return wd.model.Model.build_from_model_description(
            urdf, considered_joints=robots.seed_joints(full.joint_names()), dtype=dtype
        )
    raise KeyError(name)


def _unit_quaternions(rng, N) -> np.ndarray:
    q = rng.normal(size=(N, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def _state_fields(data) -> dict:
    return {f: getattr(data, f"{f}_state").numpy() for f in
            ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")}


# ------------------------------------------------------------------------------------------ defaults


def test_build_defaults(dtype, layout):
    """Data.build(model) is the zero configuration at rest: base at the origin, identity quaternion
    (w, x, y, z) = (1, 0, 0, 0), Mixed representation, one environment with JaxSim's shapes.

    Reference: the documented defaults; values are exact (no arithmetic but the Mixed -> Mixed base
    velocity conversion of zero, exactly zero).
    """
    model = _model("tree", dtype)
    n = model.dofs()
    data = wd.data.Data.build(model)
    assert data.num_envs is None and data.batch_size == 1
    assert data.velocity_representation == VelRepr.Mixed
    assert data.scalar == model.scalar
    assert not data.requires_grad
    expected = {
        "base_position": np.zeros(3), "base_quaternion": np.array([1.0, 0.0, 0.0, 0.0]),
        "joint_positions": np.zeros(n), "joint_velocities": np.zeros(n), "base_velocity": np.zeros(6),
        "generalized_velocity": np.zeros(6 + n), "base_orientation": np.array([1.0, 0.0, 0.0, 0.0]),
        "base_transform": np.eye(4),
    }
    for name, value in expected.items():
        array = getattr(data, name)
        assert tuple(array.shape) == value.shape, name
        np.testing.assert_array_equal(array.numpy(), value, err_msg=name)
    batched = wd.data.Data.build(model, num_envs=3, velocity_representation=VelRepr.Body)
    assert batched.num_envs == 3 and batched.batch_size == 3 and batched.velocity_representation == VelRepr.Body
    for name, value in expected.items():
        array = getattr(batched, name)
        assert tuple(array.shape) == (3, *value.shape), name
        np.testing.assert_array_equal(array.numpy(), np.broadcast_to(value, (3, *value.shape)), err_msg=name)


def test_data_dtype_and_device(dtype):
    """data.dtype is the NumPy dtype of the model's scalar; data.device the model's device.

    Reference: the dtype the model was built with (float32 or float64) and model.device.
    """
    model = _model("tree", dtype)
    data = wd.data.Data.zero(model, num_envs=2)
    assert data.scalar == model.scalar
    assert data.dtype == np.dtype(dtype)
    assert str(data.device) == str(model.device)


def test_zero_equals_build_defaults(dtype):
    """Data.zero is Data.build with defaults, for one and for N environments, in any representation.

    Reference: Data.build(model); exact equality of every state array.
    """
    model = _model("tree", dtype)
    for num_envs in (None, 4):
        for repr_ in REPRS:
            zero = wd.data.Data.zero(model, velocity_representation=repr_, num_envs=num_envs)
            ref = wd.data.Data.build(model, velocity_representation=repr_, num_envs=num_envs)
            assert zero.num_envs == num_envs and zero.velocity_representation == repr_
            for name, value in _state_fields(ref).items():
                np.testing.assert_array_equal(_state_fields(zero)[name], value, err_msg=name)


def _welded_pose_from_urdf(urdf: str) -> np.ndarray:
    """world_H_base of the URDF's fixed 'world' joint, parsed here (xyz, rpy: R = Rz(yaw) Ry(pitch) Rx(roll))."""
    root = ET.fromstring(urdf)
    joint = next(j for j in root.findall("joint") if j.find("parent").get("link") == "world")
    origin = joint.find("origin")
    xyz = np.array([float(v) for v in origin.get("xyz").split()])
    r, p, y = (float(v) for v in origin.get("rpy").split())
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = Rz @ Ry @ Rx, xyz
    return H


@pytest.mark.parametrize("seed", [5, 9])
def test_fixed_base_default_pose_is_the_welded_pose(seed, dtype):
    """A fixed-base model's data defaults to where the URDF welds the base (not to the origin).

    Reference: the origin of the URDF's fixed joint to 'world', parsed from the text with the URDF rpy
    convention. Holds for Data.build, Data.zero, random_model_data (which draws no base pose and no base
    velocity for a fixed base) and the FK of link 0. Tolerance: float64 1e-14, float32 1e-6 (a rotation
    matrix through a quaternion).
    """
    urdf = robots.random_tree_urdf(seed, fixed_base=True)
    model = wd.model.Model.build_from_model_description(urdf, dtype=dtype)
    assert not model.floating_base()
    H = _welded_pose_from_urdf(urdf)
    assert np.linalg.norm(H[:3, 3]) > 0.1 and not np.allclose(H[:3, :3], np.eye(3), atol=0.1)  # a real test
    tol = 1e-14 if np.dtype(dtype) == np.float64 else 1e-6
    for data in (wd.data.Data.build(model), wd.data.Data.zero(model), wd.data.random_model_data(model, key=seed),
                 wd.data.Data.build(model, num_envs=2)):
        got = data.base_transform.numpy().reshape(-1, 4, 4)
        np.testing.assert_allclose(got, np.broadcast_to(H, got.shape), rtol=0, atol=tol)
        np.testing.assert_allclose(data.base_position.numpy().reshape(-1, 3), np.broadcast_to(H[:3, 3], (len(got), 3)),
                                   rtol=0, atol=tol)
        np.testing.assert_array_equal(data.base_velocity.numpy(), 0.0)
        W_H_L = wd.model.forward_kinematics(model, data).numpy().reshape(len(got), -1, 4, 4)
        np.testing.assert_allclose(W_H_L[:, 0], np.broadcast_to(H, got.shape), rtol=0, atol=tol)


def test_properties_are_views_of_the_state(layout):
    """joint_positions, joint_velocities, base_position and base_quaternion are views of the state arrays
    (documented: no copy): same memory, and for a single environment the environment axis dropped.

    Reference: the state arrays' pointers and shapes.
    """
    model = _model("tree")
    for num_envs in (None, 3):
        data = wd.data.random_model_data(model, key=11, num_envs=num_envs)
        for name in ("joint_positions", "joint_velocities", "base_position", "base_quaternion"):
            view, state = getattr(data, name), getattr(data, f"{name}_state")
            assert view.ptr == state.ptr, name
            assert tuple(view.shape) == (tuple(state.shape) if num_envs else tuple(state.shape[1:])), name
            np.testing.assert_array_equal(view.numpy().reshape(state.shape), state.numpy())


# ------------------------------------------------------------------------------ shared vs per env


def test_shared_and_per_environment_arguments(dtype, layout):
    """Each argument may be shared (JaxSim's shape) or per environment (leading N), NumPy or Warp.

    Reference: the inputs, broadcast on the host: a shared value lands in every environment, a
    per-environment one row by row. Exact, except base velocities given in Body (converted to the stored
    Mixed state and back: tolerance float64 1e-14, float32 1e-6).
    """
    model = _model("tree", dtype)
    n, N = model.dofs(), 3
    rng = np.random.default_rng(21)
    s_shared, s_rows = rng.uniform(-1, 1, n), rng.uniform(-1, 1, (N, n))
    p_rows, q_shared = rng.uniform(-1, 1, (N, 3)), _unit_quaternions(rng, 1)[0]
    lin_shared, ang_rows = rng.uniform(-1, 1, 3), rng.uniform(-1, 1, (N, 3))
    sdot_rows = rng.uniform(-1, 1, (N, n))
    scalar = model.scalar
    cases = {}
    for s_kind, s in (("shared", s_shared), ("per-environment", s_rows)):
        cases[f"numpy, {s_kind} joint positions"] = (s, dict(
            joint_positions=s, joint_velocities=sdot_rows, base_position=p_rows, base_quaternion=q_shared,
            base_linear_velocity=lin_shared, base_angular_velocity=ang_rows))
        cases[f"warp, {s_kind} joint positions"] = (s, dict(
            joint_positions=wp.array(s, dtype=scalar), joint_velocities=wp.array(sdot_rows, dtype=scalar),
            base_position=wp.array(p_rows, dtype=scalar), base_quaternion=wp.array(q_shared, dtype=scalar),
            base_linear_velocity=wp.array(lin_shared, dtype=scalar),
            base_angular_velocity=wp.array(ang_rows, dtype=scalar)))
    cast = lambda x: np.asarray(x, dtype=dtype)  # noqa: E731
    tol = 1e-14 if np.dtype(dtype) == np.float64 else 1e-6
    for kind, (s, kwargs) in cases.items():
        data = wd.data.Data.build(model, **kwargs, velocity_representation=VelRepr.Body, num_envs=N)
        np.testing.assert_array_equal(data.joint_positions.numpy(), np.broadcast_to(cast(s), (N, n)), err_msg=kind)
        np.testing.assert_array_equal(data.joint_velocities.numpy(), cast(sdot_rows), err_msg=kind)
        np.testing.assert_array_equal(data.base_position.numpy(), cast(p_rows), err_msg=kind)
        np.testing.assert_array_equal(data.base_quaternion.numpy(), np.tile(cast(q_shared), (N, 1)), err_msg=kind)
        expected_v = np.concatenate([np.tile(lin_shared, (N, 1)), ang_rows], axis=1)
        np.testing.assert_allclose(data.base_velocity.numpy(), expected_v, rtol=0, atol=tol, err_msg=kind)


def test_numpy_integer_num_envs():
    """num_envs may be a NumPy integer (as from array arithmetic); the data then has that many environments.

    Reference: the integer given; num_envs is stored as a Python int.
    """
    model = _model("tree")
    data = wd.data.Data.build(model, num_envs=np.int64(2))
    assert data.num_envs == 2 and type(data.num_envs) is int and tuple(data.joint_positions.shape) == (2, model.dofs())


def test_single_environment_accepts_only_the_unbatched_shape():
    """num_envs=None takes JaxSim's shapes; a per-environment array is for batched data only.

    Reference: the documented shapes: (n,) accepted, (1, n) rejected with a message naming the argument.
    """
    model = _model("tree")
    n = model.dofs()
    s = np.linspace(-1, 1, n)
    np.testing.assert_array_equal(wd.data.Data.build(model, joint_positions=s).joint_positions.numpy(), s)
    with pytest.raises(ValueError, match="joint_positions"):
        wd.data.Data.build(model, joint_positions=s[None])


# ------------------------------------------------------------------------------- random_model_data


@pytest.mark.parametrize("name", ["tree", "icub_legs", "ergocub_seed"])
def test_random_model_data_within_default_bounds_and_joint_limits(name, dtype):
    """random_model_data draws within JaxSim's default bounds and within the joint limits.

    Reference: the documented bounds: base position in [(-1, -1, 0.5), 1], unit quaternions, base
    velocities (Mixed by default) and joint velocities in [-1, 1], joint positions within the model's
    limits, [-pi, pi] for unlimited joints. With N = 256 draws the samples must also spread over most of
    each range (a draw stuck at zero would pass a bounds check). Tolerance: the dtype's rounding (float32
    casts of bounds, 1e-6; quaternion norm to 1e-6 as Data.build validates).
    """
    model = _model(name, dtype)
    N = 256
    data = wd.data.random_model_data(model, key=31, num_envs=N)
    eps = 1e-12 if np.dtype(dtype) == np.float64 else 1e-6
    p = data.base_position.numpy()
    low, high = np.array([-1.0, -1.0, 0.5]), np.ones(3)
    assert np.all(p >= low - eps) and np.all(p <= high + eps)
    assert np.all(p.max(0) - p.min(0) > 0.8 * (high - low))
    q = data.base_quaternion.numpy()
    np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, rtol=0, atol=1e-6)
    assert np.unique(np.round(q, 3), axis=0).shape[0] > N // 2
    v = data.base_velocity.numpy()
    assert np.all(np.abs(v) <= 1.0 + eps) and np.all(v.max(0) - v.min(0) > 1.6)
    sdot = data.joint_velocities.numpy()
    assert np.all(np.abs(sdot) <= 1.0 + eps) and np.all(sdot.max(0) - sdot.min(0) > 1.6)
    lower, upper = wd.joint.position_limits(model)
    lower = np.where(np.isfinite(lower), lower, -np.pi)
    upper = np.where(np.isfinite(upper), upper, np.pi)
    s = data.joint_positions.numpy()
    assert np.all(s >= lower - eps) and np.all(s <= upper + eps), "joint positions outside the limits"
    assert np.all(s.max(0) - s.min(0) > 0.8 * (upper - lower))


def test_random_model_data_with_custom_bounds_and_representation(dtype):
    """Custom bounds are honoured; base velocities are drawn in the requested representation.

    Reference: the bounds given; the base velocity read back in Body (the representation it was drawn
    in) lies within them, while its Mixed state (a rotation of it) does not in general. Tolerance: float64
    1e-12, float32 1e-6 (round trip of the Body velocity through the stored Mixed state).
    """
    model = _model("tree", dtype)
    N = 128
    data = wd.data.random_model_data(
        model, key=32, num_envs=N, velocity_representation=VelRepr.Body,
        base_pos_bounds=((0.0, 0.1, 0.2), (0.05, 0.15, 0.25)), joint_pos_bounds=(-0.1, 0.2),
        base_vel_lin_bounds=(2.0, 3.0), base_vel_ang_bounds=(-0.01, 0.01), joint_vel_bounds=(5.0, 6.0),
    )
    eps = 1e-12 if np.dtype(dtype) == np.float64 else 1e-6
    assert data.velocity_representation == VelRepr.Body
    p = data.base_position.numpy()
    assert np.all(p >= np.array([0.0, 0.1, 0.2]) - eps) and np.all(p <= np.array([0.05, 0.15, 0.25]) + eps)
    s, sdot = data.joint_positions.numpy(), data.joint_velocities.numpy()
    assert np.all(s >= -0.1 - eps) and np.all(s <= 0.2 + eps)
    assert np.all(sdot >= 5.0 - eps) and np.all(sdot <= 6.0 + eps)
    v = data.base_velocity.numpy()
    assert np.all(v[:, :3] >= 2.0 - eps) and np.all(v[:, :3] <= 3.0 + eps)
    assert np.all(np.abs(v[:, 3:]) <= 0.01 + eps)
    mixed = data.base_velocity_state.numpy()
    assert not np.all((mixed[:, :3] >= 2.0) & (mixed[:, :3] <= 3.0))  # it really was drawn in Body


def test_random_model_data_is_reproducible_by_seed(dtype):
    """The same seed gives the same data; another seed other data.

    Reference: exact equality of every state array for equal seeds; for different seeds every array
    differs (fresh draws everywhere).
    """
    model = _model("tree", dtype)
    a = _state_fields(wd.data.random_model_data(model, key=41, num_envs=5))
    b = _state_fields(wd.data.random_model_data(model, key=41, num_envs=5))
    c = _state_fields(wd.data.random_model_data(model, key=42, num_envs=5))
    for name in a:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
        assert not np.array_equal(a[name], c[name]), name
    single = wd.data.random_model_data(model, key=41)
    assert single.num_envs is None and tuple(single.joint_positions.shape) == (model.dofs(),)
    np.testing.assert_array_equal(single.joint_positions.numpy(), wd.data.random_model_data(model, key=41).joint_positions.numpy())


def test_random_model_data_requires_grad():
    """requires_grad=True gives state arrays with gradients allocated (and zero)."""
    data = wd.data.random_model_data(_model("tree"), key=43, requires_grad=True)
    assert data.requires_grad
    for name in _state_fields(data):
        grad = getattr(data, f"{name}_state").grad
        assert grad is not None, name
        np.testing.assert_array_equal(grad.numpy(), 0.0)


# ---------------------------------------------------------------------------------------- replace


def test_replace_each_field(layout):
    """replace(field=value) changes that field only and leaves the original data untouched; as JaxSim's, a
    replace without a base velocity keeps the Inertial one, so a moved base has another Mixed velocity.

    Reference: the new value, and the old data's state for every other field (exact copies), but the Mixed
    base velocity (the stored state) after base_position: the kept Inertial velocity (v_I, w) seen at the new
    origin, (v_I + w x p_new, w), to 1e-14.
    """
    model = _model("tree")
    n, N = model.dofs(), 3
    rng = np.random.default_rng(51)
    data = wd.data.random_model_data(model, key=51, num_envs=N)
    old = _state_fields(data)
    new_values = {
        "joint_positions": ("joint_positions", rng.uniform(-1, 1, (N, n))),
        "joint_velocities": ("joint_velocities", rng.uniform(-1, 1, (N, n))),
        "base_position": ("base_position", rng.uniform(-1, 1, (N, 3))),
        "base_quaternion": ("base_quaternion", _unit_quaternions(rng, N)),
    }
    for argument, (field, value) in new_values.items():
        new = data.replace(model, **{argument: value})
        assert new is not data and new.num_envs == N and new.velocity_representation == data.velocity_representation
        fields = _state_fields(new)
        np.testing.assert_array_equal(fields[field], value, err_msg=argument)
        for other, array in old.items():
            if other == "base_velocity" and field == "base_position":
                w = array[:, 3:]
                v_inertial = array[:, :3] - np.cross(w, old["base_position"])
                expected = np.concatenate([v_inertial + np.cross(w, value), w], axis=1)
                np.testing.assert_allclose(fields[other], expected, rtol=0, atol=1e-14, err_msg="kept Inertial velocity")
            elif other != field:
                np.testing.assert_array_equal(fields[other], array, err_msg=f"{argument} changed {other}")
        for name, array in old.items():
            np.testing.assert_array_equal(_state_fields(data)[name], array, err_msg=f"original {name}")
    single = wd.data.random_model_data(model, key=52)
    s = rng.uniform(-1, 1, n)
    new = single.replace(model, joint_positions=s)
    assert new.num_envs is None and tuple(new.joint_positions.shape) == (n,)
    np.testing.assert_array_equal(new.joint_positions.numpy(), s)
    np.testing.assert_array_equal(new.joint_velocities.numpy(), single.joint_velocities.numpy())


@pytest.mark.parametrize("envs", [[1, 3], np.array([False, True, False, True])], ids=["indices", "mask"])
def test_replace_a_subset_of_environments(envs, layout):
    """replace(..., envs=) changes only those environments; the others keep their whole state.

    Reference: the new values in environments 1 and 3, the old state (exact) in 0 and 2, for every field.
    """
    model = _model("tree")
    n, N = model.dofs(), 4
    rng = np.random.default_rng(53)
    data = wd.data.random_model_data(model, key=53, num_envs=N)
    old = _state_fields(data)
    s, sdot = rng.uniform(-1, 1, (N, n)), rng.uniform(-1, 1, (N, n))
    p, q = rng.uniform(-1, 1, (N, 3)), _unit_quaternions(rng, N)
    lin, ang = rng.uniform(-1, 1, (N, 3)), rng.uniform(-1, 1, (N, 3))
    new = data.replace(model, joint_positions=s, joint_velocities=sdot, base_position=p, base_quaternion=q,
                       base_linear_velocity=lin, base_angular_velocity=ang, envs=envs)
    fields = _state_fields(new)
    changed, kept = [1, 3], [0, 2]
    expected = {"joint_positions": s, "joint_velocities": sdot, "base_position": p, "base_quaternion": q,
                "base_velocity": np.concatenate([lin, ang], axis=1)}  # the data is Mixed: the state itself
    for name, value in expected.items():
        np.testing.assert_allclose(fields[name][changed], value[changed], rtol=0, atol=1e-15, err_msg=name)
        np.testing.assert_array_equal(fields[name][kept], old[name][kept], err_msg=f"{name} in kept envs")
    # A shared value given with envs= also reaches only those environments.
    shared = data.replace(model, joint_positions=np.full(n, 0.25), envs=[2])
    got = shared.joint_positions.numpy()
    np.testing.assert_array_equal(got[2], 0.25)
    np.testing.assert_array_equal(got[[0, 1, 3]], old["joint_positions"][[0, 1, 3]])


@pytest.mark.parametrize("repr_", REPRS, ids=lambda r: r.name)
def test_replace_half_of_the_base_velocity_keeps_the_other_half(repr_, layout):
    """Replacing the linear (or angular) base velocity keeps the other half, in the data's representation.

    Reference: the old data's base_velocity read in its own representation (Body, Mixed, Inertial): the
    kept half must read back unchanged and the given half as given. Tolerance: float64 1e-14 (a round trip
    through the stored Mixed state: a rotation or a cross product and back).
    """
    model = _model("tree")
    N = 3
    rng = np.random.default_rng(54 + int(repr_))
    data = wd.data.random_model_data(model, key=54, num_envs=N, velocity_representation=repr_)
    before = data.base_velocity.numpy()
    lin, ang = rng.uniform(-2, 2, (N, 3)), rng.uniform(-2, 2, (N, 3))
    new = data.replace(model, base_angular_velocity=ang)
    np.testing.assert_allclose(new.base_velocity.numpy(), np.concatenate([before[:, :3], ang], 1), rtol=0, atol=1e-14)
    new = data.replace(model, base_linear_velocity=lin)
    np.testing.assert_allclose(new.base_velocity.numpy(), np.concatenate([lin, before[:, 3:]], 1), rtol=0, atol=1e-14)
    assert new.velocity_representation == repr_


# ---------------------------------------------------------------------- velocity representations


def test_switch_velocity_representation_restores_it():
    """Inside the block the data reads velocities in the new representation; after it, the original one,
    also when the block raises (the exception propagates) and when blocks nest.

    Reference: the data's representation attribute, and base_velocity before and after (exact: the same
    state read in the same representation).
    """
    model = _model("tree")
    data = wd.data.random_model_data(model, key=61, velocity_representation=VelRepr.Inertial)
    before = data.base_velocity.numpy()
    with data.switch_velocity_representation(VelRepr.Body) as switched:
        assert switched is data and data.velocity_representation == VelRepr.Body
        body = data.base_velocity.numpy()
        with data.switch_velocity_representation(VelRepr.Mixed):
            assert data.velocity_representation == VelRepr.Mixed
            np.testing.assert_allclose(data.base_velocity.numpy(), data.base_velocity_state.numpy()[0], rtol=0, atol=1e-15)
        assert data.velocity_representation == VelRepr.Body
    assert not np.allclose(body, before)  # the switch did change what is read
    assert data.velocity_representation == VelRepr.Inertial
    np.testing.assert_array_equal(data.base_velocity.numpy(), before)

    class Boom(RuntimeError):
        pass

    with pytest.raises(Boom):
        with data.switch_velocity_representation(VelRepr.Mixed):
            assert data.velocity_representation == VelRepr.Mixed
            raise Boom()
    assert data.velocity_representation == VelRepr.Inertial
    np.testing.assert_array_equal(data.base_velocity.numpy(), before)
    with pytest.raises(ValueError):
        with data.switch_velocity_representation(42):
            pass
    assert data.velocity_representation == VelRepr.Inertial


# -------------------------------------------------------------------------- derived base quantities


def test_base_orientation_is_the_normalised_quaternion(dtype, layout):
    """base_orientation is base_quaternion divided by its norm; base_quaternion is the raw state.

    Reference: NumPy's q / |q| of quaternions scaled by 0.5 to 3 (built with validate=False). Tolerance:
    float64 1e-15, float32 3e-7 (one normalisation).
    """
    model = _model("tree", dtype)
    rng = np.random.default_rng(71)
    N = 5
    q = _unit_quaternions(rng, N) * rng.uniform(0.5, 3.0, (N, 1))
    data = wd.data.Data.build(model, base_quaternion=q, num_envs=N, validate=False)
    tol = 1e-15 if np.dtype(dtype) == np.float64 else 3e-7
    np.testing.assert_array_equal(data.base_quaternion.numpy(), q.astype(dtype))
    np.testing.assert_allclose(data.base_orientation.numpy(), q / np.linalg.norm(q, axis=1, keepdims=True),
                               rtol=0, atol=tol)
    single = wd.data.Data.build(model, base_quaternion=q[0], validate=False)
    assert tuple(single.base_orientation.shape) == (4,)
    np.testing.assert_allclose(single.base_orientation.numpy(), q[0] / np.linalg.norm(q[0]), rtol=0, atol=tol)


def test_base_transform_matches_quaternion_and_position(dtype, layout):
    """base_transform is [[R(q), p], [0, 1]], with R of the (w, x, y, z) quaternion.

    Reference: NumPy's rotation matrix of the quaternion (tests/robots.rotation_wxyz) and the position.
    Tolerance: float64 1e-15, float32 1e-6 (quadratic products of quaternion components).
    """
    model = _model("tree", dtype)
    rng = np.random.default_rng(72)
    N = 6
    p, q = rng.uniform(-2, 2, (N, 3)), _unit_quaternions(rng, N)
    data = wd.data.Data.build(model, base_position=p, base_quaternion=q, num_envs=N)
    H = np.tile(np.eye(4), (N, 1, 1))
    H[:, :3, :3] = [robots.rotation_wxyz(x) for x in q]
    H[:, :3, 3] = p
    tol = 1e-15 if np.dtype(dtype) == np.float64 else 1e-6
    np.testing.assert_allclose(data.base_transform.numpy(), H, rtol=0, atol=tol)
    W_H_B, s = data.generalized_position
    np.testing.assert_array_equal(W_H_B.numpy(), data.base_transform.numpy())
    np.testing.assert_array_equal(s.numpy(), data.joint_positions.numpy())
    single = wd.data.Data.build(model, base_position=p[0], base_quaternion=q[0])
    assert tuple(single.base_transform.shape) == (4, 4)
    np.testing.assert_allclose(single.base_transform.numpy(), H[0], rtol=0, atol=tol)
