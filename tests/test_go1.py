"""The Unitree Go1 of the pip package example-robot-data (`wd.assets.example_robot_data_urdf("go1")`): found,
loaded with the warnings it deserves, its dynamics against MuJoCo, its foot-only collidable points (the recipe
of warpdyn.assets' docstring), and standing on flat ground on position servos.

Reference: C MuJoCo on the same URDF (fixed links fused, a free joint; constraints, joint damping and springs
off: tests/test_dynamics.py's set-up). MuJoCo refuses the URDF's placeholder `base` inertia (every entry
1e-6: rank 1, "inertia must have positive eigenvalues"), so both MuJoCo and the warpdyn model compared with it
read the URDF with that link's products of inertia set to 0; a separate test checks that this is the only
difference from the model of the original file (the base link's inertia, by exactly those products).
"""

from __future__ import annotations

import importlib.metadata
import warnings
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
from warpdyn import VelRepr, assets

GO1 = assets.example_robot_data_urdf("go1")
URDF = GO1.read_text()
LEGS = ("FR", "FL", "RR", "RL")
# float64: sums of O(100) products agree to ~1e-13; 1e-9 as tests/test_dynamics.py. float32: eps 1.2e-7
# amplified by the same sums and by M^-1 (the Go1's M spans 1e-4 to 13: ABA gets 50x the tolerance).
TOL = {np.float64: 1e-9, np.float32: 2e-3}


def _without_base_products(text: str) -> str:
    """The URDF with the placeholder base's products of inertia set to 0 (MuJoCo compiles it then)."""
    root = ET.fromstring(text)
    inertia = root.find("link[@name='base']/inertial/inertia")
    for key in ("ixy", "ixz", "iyz"):
        inertia.set(key, "0")
    return ET.tostring(root, encoding="unicode")


def _load(text, dtype=np.float64, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.UnphysicalInertiaWarning)
        return wd.model.Model.build_from_model_description(text, dtype=dtype, **kwargs)


def feet_only(model, sphere_points=20):
    """The recipe of warpdyn.assets' docstring: the foot spheres' points below their centres."""
    model = wd.contact.with_collidable_points(model, options=wd.contact.CollidablePointsOptions(shapes=("sphere",), sphere_points=sphere_points))
    point = model.kin_dyn_parameters.contact_parameters.point
    return wd.contact.with_collidable_points(model, enabled=point[:, 2] < assets.GO1_FOOT_CENTRE[2])


# ------------------------------------------------------------------------------------ finding it


def test_example_robot_data_urdf_finds_and_refuses(monkeypatch):
    """The Go1 is the installed distribution's file; unknown and ambiguous names and a missing package raise
    errors that say what to do. Reference: the distribution's own record of its files (importlib.metadata)."""
    dist = importlib.metadata.distribution("example-robot-data")
    recorded = [dist.locate_file(f) for f in dist.files if f.as_posix().endswith("robots/go1_description/urdf/go1.urdf")]
    assert [GO1] == [type(GO1)(p) for p in recorded] and GO1.is_file()
    assert assets.example_robot_data_urdf("go1.urdf") == GO1
    assert assets.example_robot_data_urdf("go1_description/urdf/go1") == GO1
    with pytest.raises(FileNotFoundError, match=r"no URDF called 'go3'.*\bgo1\b.*pip install example-robot-data"):
        assets.example_robot_data_urdf("go3")
    with pytest.raises(ValueError, match="anymal_b_simple_description/robots/anymal, anymal_c_simple_description/urdf/anymal"):
        assets.example_robot_data_urdf("anymal")

    def missing(name):
        raise importlib.metadata.PackageNotFoundError(name)

    monkeypatch.setattr(importlib.metadata, "distribution", missing)
    with pytest.raises(ImportError, match="example-robot-data.*pip install example-robot-data"):
        assets.example_robot_data_urdf("go1")


# ------------------------------------------------------------------------------------ loading


def test_go1_loads_as_the_urdf_says():
    """One warning (the placeholder base's rank-1 inertia), 13 links, the 12 joints of GO1_JOINTS with the
    URDF's limits, friction and damping, the feet lumped into the calves at GO1_FOOT_CENTRE, the standing pose
    within the limits, the total mass of the URDF and of MuJoCo. Reference: the URDF read with ElementTree
    (exact values; masses summed in another order: 1e-12)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = wd.model.Model.build_from_model_description(GO1, dtype=np.float64)
    assert [(w.category, "link 'base'" in str(w.message)) for w in caught] == [(wd.model.UnphysicalInertiaWarning, True)]
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the same file with a physical placeholder: no warning at all
        wd.model.Model.build_from_model_description(_without_base_products(URDF), dtype=np.float64)

    root = ET.fromstring(URDF)
    movable = [j for j in root.findall("joint") if j.get("type") != "fixed"]
    assert tuple(j.get("name") for j in movable) == assets.GO1_JOINTS
    assert model.floating_base() and model.base_link() == "base" and model.dofs() == 12
    by_name = sorted(LEGS)  # breadth-first, siblings by name (JaxSim's order)
    assert model.link_names() == ("base", *(f"{leg}_{part}" for part in ("hip", "thigh", "calf") for leg in by_name))
    assert model.joint_names() == tuple(f"{leg}_{part}_joint" for part in ("hip", "thigh", "calf") for leg in by_name)
    order = [model.joint_names().index(j.get("name")) for j in movable]
    limit = np.array([[float(j.find("limit").get(k)) for k in ("lower", "upper", "effort", "velocity")] for j in movable])
    np.testing.assert_array_equal(model.tree.position_limits[order], limit[:, :2])
    np.testing.assert_array_equal(model.tree.effort_limits[order], limit[:, 2])
    np.testing.assert_array_equal(model.tree.velocity_limits[order], limit[:, 3])
    np.testing.assert_array_equal(model.tree.damping, 0.01)
    np.testing.assert_array_equal(model.tree.friction, 0.2)

    frames = model.kin_dyn_parameters.frame_parameters
    for foot, calf in zip(assets.GO1_FOOT_FRAMES, assets.GO1_FEET, strict=True):
        i = frames.name.index(foot)
        assert model.link_names()[frames.body[i]] == calf
        np.testing.assert_array_equal(frames.transform[i][:3, 3], assets.GO1_FOOT_CENTRE)
    spheres = [(model.link_names()[k], s.radius) for k, shapes in enumerate(model.tree.collisions) for s in shapes if s.kind == "sphere"]
    assert spheres == [(calf, assets.GO1_FOOT_RADIUS) for calf in sorted(assets.GO1_FEET, key=model.link_names().index)]

    assert set(assets.GO1_STANDING_POSE) == set(assets.GO1_JOINTS)
    low, high = model.tree.position_limits.T
    pose = np.array([assets.GO1_STANDING_POSE[j] for j in model.joint_names()])
    assert np.all((low < pose) & (pose < high))

    urdf_mass = sum(float(m.get("value")) for m in root.iter("mass"))
    mj = robots.mujoco_model(_without_base_products(URDF), None, floating=True)
    assert wd.model.total_mass(model) == pytest.approx(urdf_mass, rel=1e-12)
    assert float(mj.body_mass.sum()) == pytest.approx(urdf_mass, rel=1e-12)


def test_only_the_base_placeholder_differs_from_what_mujoco_reads():
    """The model of the original file and that of the file MuJoCo compiles (the base's products of inertia
    zeroed) differ in the base link's inertia alone, by exactly those 1e-6 kg m^2 products (the base is lumped
    with the trunk: the products add to the trunk's). Reference: the URDF's numbers; exact up to the lumping's
    float64 rounding (1e-15)."""
    original, patched = _load(GO1), _load(_without_base_products(URDF))
    for name in ("link_mass", "link_com", "parent_H_joint", "joint_axis", "link_H_frame", "position_limits"):
        np.testing.assert_array_equal(getattr(original.tree, name), getattr(patched.tree, name), err_msg=name)
    products = 1e-6 * (np.ones((3, 3)) - np.eye(3))
    np.testing.assert_allclose(original.tree.link_inertia[0] - patched.tree.link_inertia[0], products, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(original.tree.link_inertia[1:], patched.tree.link_inertia[1:])


# ------------------------------------------------------------------------------------ against MuJoCo


def mujoco_errors(dtype, seed: int) -> dict:
    """{quantity: (max |warpdyn - MuJoCo|, scale)} at a random state (seed): M, h, g, ABA and CRB forward
    dynamics, RNEA, every link's pose, the four foot frames' poses (MuJoCo without fusing: they are bodies)."""
    text = _without_base_products(URDF)
    model = _load(text, dtype)
    mj = robots.mujoco_model(text, None, floating=True)
    off = mujoco.mjtDisableBit
    mj.opt.disableflags |= off.mjDSBL_CONSTRAINT | off.mjDSBL_DAMPER | off.mjDSBL_SPRING
    mj_unfused = robots.mujoco_model(text, None, floating=True, fuse_static=False)
    data = wd.data.random_model_data(model, key=seed, velocity_representation=VelRepr.Mixed)
    state = [robots.host(a) for a in (data.base_position, data.base_quaternion, data.joint_positions, data.base_velocity, data.joint_velocities)]
    st = robots.MujocoState(mj, model.joint_names(), True)
    st.set(*state)
    d, n = st.d, model.dofs()
    idx = np.r_[0:6, st.dof_adr]
    P = np.eye(6 + n)
    P[3:6, 3:6] = robots.rotation_wxyz(state[1]).T  # MuJoCo's nu = P nu_mixed
    out = {}

    def record(what, actual, expected):
        actual, expected = np.asarray(actual, dtype=np.float64), np.asarray(expected, dtype=np.float64)
        assert actual.shape == expected.shape, what
        out[what] = (float(np.abs(actual - expected).max()), max(1.0, float(np.abs(expected).max())))

    M_mj = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, d, M_mj)
    record("M (CRBA)", wd.model.free_floating_mass_matrix(model, data).numpy(), P.T @ M_mj[np.ix_(idx, idx)] @ P)
    record("h", wd.model.free_floating_bias_forces(model, data).numpy(), P.T @ d.qfrc_bias[idx])
    rng = np.random.default_rng(seed)
    tau = rng.uniform(-10.0, 10.0, n)
    d.qfrc_applied[:] = 0.0
    d.qfrc_applied[st.dof_adr] = tau
    mujoco.mj_forward(mj, d)
    expected = np.linalg.solve(P, d.qacc[idx])
    for name, prefer_aba in (("ABA", True), ("CRB forward dynamics", False)):
        base, joints = wd.model.forward_dynamics(model, data, joint_forces=tau, prefer_aba=prefer_aba)
        record(name, np.r_[base.numpy(), joints.numpy()], expected)
    nu_dot = rng.uniform(-2.0, 2.0, 6 + n)
    f_B, tau_id = wd.model.inverse_dynamics(model, data, base_acceleration=nu_dot[:6], joint_accelerations=nu_dot[6:])
    d.qacc[:] = 0.0
    d.qacc[idx] = P @ nu_dot
    mujoco.mj_inverse(mj, d)
    record("RNEA", np.r_[f_B.numpy(), tau_id.numpy()], P.T @ d.qfrc_inverse[idx])
    rest = wd.data.Data.build(model, base_position=state[0], base_quaternion=state[1], joint_positions=state[2])
    st.set(state[0], state[1], state[2], np.zeros(6), np.zeros(n))
    record("g", wd.model.free_floating_gravity_forces(model, rest).numpy(), P.T @ d.qfrc_bias[idx])

    st.set(*state)
    H = wd.model.forward_kinematics(model, data).numpy()
    record("link poses", H, [robots.H_of(*st.body_pose(name)[::-1]) for name in model.link_names()])
    su = robots.MujocoState(mj_unfused, model.joint_names(), True)
    su.set(*state)
    feet = [wd.frame.transform(model, data, frame_index=wd.frame.name_to_idx(model, frame_name=f)).numpy() for f in assets.GO1_FOOT_FRAMES]
    record("foot frames", feet, [robots.H_of(*su.body_pose(f)[::-1]) for f in assets.GO1_FOOT_FRAMES])
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_go1_dynamics_and_kinematics_match_mujoco(seed, dtype):
    """M, h, g, ABA, CRB forward dynamics, RNEA, link poses and foot frames vs MuJoCo at random states (base
    anywhere, any orientation, joints in [-pi, pi] rad as random_model_data draws them, velocities in [-1, 1]).
    Tolerance: TOL relative to max(1, |reference|), 50x for the two forward dynamics (M^-1)."""
    for what, (err, scale) in mujoco_errors(dtype, seed).items():
        tol = TOL[dtype] * (50 if what in ("ABA", "CRB forward dynamics") else 1)
        assert err <= tol * scale, f"{what}: max error {err:.3e} > {tol:.0e} * {scale:.3g}"


# ------------------------------------------------------------------------------------ contact and standing


def test_feet_only_points_are_on_the_four_feet(dtype):
    """The docstring's recipe: 80 points in all (20 per foot sphere, nothing else), 36 enabled, 9 per foot,
    each on its foot's sphere (distance to the foot frame's origin = radius) and below its centre, also in the
    world at the standing pose; the servos added after keep them. Reference: the sphere's geometry (radius
    0.02 m; float32: the positions carry ~1e-7 m of rounding)."""
    model = feet_only(_load(GO1, dtype))
    params = model.kin_dyn_parameters.contact_parameters
    body, point, enabled = np.asarray(params.body), params.point, np.asarray(params.enabled)
    feet = [model.link_names().index(f) for f in assets.GO1_FEET]
    assert len(body) == 80 and set(body.tolist()) == set(feet) and enabled.sum() == 36
    assert [int(np.sum(enabled & (body == f))) for f in feet] == [9, 9, 9, 9]
    np.testing.assert_allclose(np.linalg.norm(point - assets.GO1_FOOT_CENTRE, axis=1), assets.GO1_FOOT_RADIUS, rtol=1e-12)

    servo = wd.model.add_actuators(model, "position", kp=100.0)
    assert servo.kin_dyn_parameters.contact_parameters.enabled == params.enabled
    pose = np.array([assets.GO1_STANDING_POSE[j] for j in model.joint_names()])
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, 0.5], joint_positions=pose)
    W_p_C = wd.contact.collidable_point_positions(model, data).numpy()
    assert W_p_C.shape == (36, 3)
    tol = 1e-12 if dtype == np.float64 else 1e-6
    for k, (foot, f) in enumerate(zip(assets.GO1_FOOT_FRAMES, feet, strict=True)):
        centre = wd.frame.transform(model, data, frame_index=wd.frame.name_to_idx(model, frame_name=foot)).numpy()[:3, 3]
        mine = W_p_C[9 * k : 9 * k + 9]  # enabled points in link order, FR, FL, RR, RL
        assert np.all(body[enabled][9 * k : 9 * k + 9] == f)
        np.testing.assert_allclose(np.linalg.norm(mine - centre, axis=1), assets.GO1_FOOT_RADIUS, atol=tol)
        assert mine[:, 2].min() < centre[2] - 0.9 * assets.GO1_FOOT_RADIUS  # a point near the sphere's bottom


def _standing(dtype, kp):
    """The feet-only Go1 on position servos (kp [N m/rad], clipped at the URDF's effort limits) and implicit
    joint damping 2 N m s/rad, as LeggedEnv builds it; soft contacts K = 1e5, LeggedEnv's D; SIE at 2 ms; the
    lowest foot point on the ground, at rest, in GO1_STANDING_POSE."""
    model = feet_only(_load(GO1, dtype))
    effort = model.tree.effort_limits
    model = wd.model.add_actuators(model, "position", kp=kp, force_range=np.stack([-effort, effort], axis=1))
    model.set_joint_parameters(damping=np.full(model.dofs(), 2.0))
    model.implicit_damping = True
    model.integrator = wd.model.IntegratorType.SemiImplicitEuler
    model.time_step = 0.002
    model.contact_params = wd.model.SoftContactsParams(K=1e5, D=2000.0 * 0.1 ** (2.0 / 3.0), mu=0.5)
    pose = np.array([assets.GO1_STANDING_POSE[j] for j in model.joint_names()])
    touch = wd.data.Data.build(model, joint_positions=pose)
    z0 = -float(wd.contact.collidable_point_positions(model, touch).numpy()[:, 2].min())
    return model, wd.data.Data.build(model, base_position=[0.0, 0.0, z0], joint_positions=pose), pose


def test_go1_stands_on_its_servos(dtype):
    """1 s on flat ground holding GO1_STANDING_POSE (ctrl = the pose): the base settles by at most 2 cm from
    its touching height (soft contacts and servo sag; 1 cm measured), stays within 2 cm horizontally and
    0.05 rad of upright, the joints within 0.1 rad of the pose, the state finite and at rest at the end; without
    servo gains the same robot collapses (its base falls by more than 10 cm: the check can fail). Reference:
    statics (the servo's torque at the measured sag carries the weight). A 2 ms step with the servos' damping
    explicit (add_actuators kv=2, no implicit damping) instead creeps forward at 0.1 m/s: implicit damping
    it is, as LeggedEnv."""
    model, data, pose = _standing(dtype, kp=100.0)
    z0 = float(data.base_position.numpy()[2])
    heights = []
    for _ in range(500):
        data = wd.model.step(model, data, ctrl=pose)
        heights.append(float(data.base_position.numpy()[2]))
    p, q = robots.host(data.base_position), robots.host(data.base_quaternion)
    v, s, sd = robots.host(data.base_velocity), robots.host(data.joint_positions), robots.host(data.joint_velocities)
    assert np.all(np.isfinite(np.r_[p, q, v, s, sd]))
    assert np.abs(np.array(heights) - z0).max() < 0.02, f"base height left [{min(heights):.4f}, {max(heights):.4f}] m around {z0:.4f}"
    assert np.linalg.norm(p[:2]) < 0.02, f"base moved {p[:2]} m horizontally"
    up = robots.rotation_wxyz(q)[:, 2]
    assert np.arccos(np.clip(up[2], -1.0, 1.0)) < 0.05
    assert np.abs(s - pose).max() < 0.1
    assert np.abs(v).max() < 0.05 and np.abs(sd).max() < 0.1

    limp, data, pose = _standing(dtype, kp=0.0)
    for _ in range(250):
        data = wd.model.step(limp, data, ctrl=pose)
    assert float(data.base_position.numpy()[2]) < z0 - 0.1
