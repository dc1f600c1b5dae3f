"""Ball and free joints, and scenes of several trees (issue 35): each joint has its own positions and velocities
(a ball joint 4 and 3, a free joint 7 and 6: MuJoCo's qpos and qvel of that joint), and a world of several
trees is a fixed base, the world, with each free body hanging from it by a free joint.

References: MuJoCo (M, qfrc_bias, the passive forces, qacc with constraints disabled, one Euler step) on
MJCF fixtures mapped by tests/mjcf_compare.py; physics (a torque-free body keeps its energy and angular
momentum); central finite differences for tape gradients (float64); the description's own poses for
qpos0 and keyframes.
"""

from __future__ import annotations

import pathlib
import warnings

import mujoco
import numpy as np
import pytest
import warp as wp

import mjcf_compare
import mjcf_models as mm
import warpdyn as wd

MENAGERIE = pathlib.Path(__file__).parent / "models" / "menagerie"

# Two free drones and a pendulum on a ball joint in one world, with MuJoCo's passive parameters on the free and
# ball joints (armature, damping, stiffness: each DoF alike).
SCENE = """
<mujoco model="scene">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" timestep="0.002"/>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="drone" pos="0.3 -0.2 1" quat="0.9961947 0 0.0871557 0">
      <freejoint name="drone_free"/>
      <inertial pos="0.005 -0.003 0.01" quat="0.9914449 0 0 0.1305262" mass="0.8" diaginertia="0.004 0.005 0.008"/>
      <geom type="box" size="0.1 0.1 0.02"/>
    </body>
    <body name="crate" pos="-1 0.5 0.4" euler="0.3 -0.2 0.5">
      <joint name="crate_free" type="free" armature="0.02" damping="0.3" stiffness="2"/>
      <inertial pos="0.01 0.02 -0.01" mass="2.5" diaginertia="0.03 0.04 0.05"/>
      <geom type="box" size="0.1 0.15 0.2"/>
    </body>
    <body name="mount" pos="1 1 2">
      <body name="bob" pos="0 0 -0.1" euler="0.2 0.1 0">
        <joint name="swivel" type="ball" pos="0 0 0.1" armature="0.01" damping="0.2" stiffness="0.5"/>
        <inertial pos="0.02 0 -0.3" mass="1.2" diaginertia="0.03 0.031 0.004"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.5" size="0.03"/>
        <body name="tip" pos="0 0 -0.5">
          <joint name="tip_hinge" axis="0 1 0" damping="0.1"/>
          <inertial pos="0 0 -0.1" mass="0.4" diaginertia="0.002 0.002 0.0003"/>
          <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02"/>
        </body>
      </body>
    </body>
  </worldbody>
  <keyframe><key name="tilted" qpos="0.3 -0.2 1.5 1 0 0 0  -1 0.5 0.4 0.9238795 0.3826834 0 0  0.9659258 0 0.2588190 0  0.4"
    qvel="0.1 0 0.2 0 0.3 0  0 0 0 0.5 0 0  0.2 -0.1 0.3  -0.4"/></keyframe>
</mujoco>
"""


def _load(xml_or_path, dtype=np.float64) -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        return wd.model.Model.build_from_model_description(str(xml_or_path) if isinstance(xml_or_path, pathlib.Path) else xml_or_path, dtype=dtype)


@pytest.fixture(scope="module")
def scene_file(tmp_path_factory) -> pathlib.Path:
    path = tmp_path_factory.mktemp("scene") / "scene.xml"
    path.write_text(SCENE)
    return path


def test_the_scene_has_its_trees_and_addresses():
    """The scene's world is the fixed base; the free bodies hang from it by free joints (7 positions, 6
    velocities), the ball joint has 4 and 3, the hinge 1 and 1, each at its own address in joint order
    (reference: the XML and MuJoCo's joint sizes)."""
    model = _load(SCENE)
    assert not model.floating_base() and model.base_link() == "world"
    assert (model.number_of_joints(), model.number_of_joint_coordinates(), model.dofs()) == (4, 7 + 7 + 4 + 1, 6 + 6 + 3 + 1)
    sizes = {name: (s.stop - s.start, v.stop - v.start) for k, name in enumerate(model.joint_names())
             for s, v in [(wd.joint.position_slice(model, joint_index=k), wd.joint.velocity_slice(model, joint_index=k))]}
    assert sizes == {"crate_free": (7, 6), "drone_free": (7, 6), "swivel": (4, 3), "tip_hinge": (1, 1)}
    crate = wd.joint.velocity_slice(model, joint_index=wd.joint.name_to_idx(model, joint_name="crate_free"))
    assert model.dof_names()[crate] == tuple(f"crate_free:{k}" for k in ("x", "y", "z", "rx", "ry", "rz"))


@pytest.mark.parametrize("dtype", [np.float64, np.float32], ids=["float64", "float32"])
@pytest.mark.parametrize("which", ["scene", "ball", "cassie", "cube"])
def test_mass_matrix_bias_passive_forces_and_accelerations_equal_mujoco(which, dtype, scene_file, tmp_path):
    """M, h (qfrc_bias), the passive forces (armature, damping and springs of ball and free joints included) and
    ABA's accelerations equal MuJoCo's (constraints disabled) at qpos0 and three random states, mapped by
    tests/mjcf_compare.py. Tolerance: issue 35's 1e-8 relative in float64 (measured ~1e-13); float32's
    rounding 1e-4."""
    path = {"scene": scene_file, "cassie": MENAGERIE / "cassie.xml", "cube": MENAGERIE / "mjx_single_cube.xml"}.get(which)
    if path is None:
        path = tmp_path / "ball.xml"
        path.write_text(mm.BALL)
    model = _load(path, dtype)
    errors = mjcf_compare.compare_model(model, mujoco.MjModel.from_xml_path(str(path)))
    tolerance = 1e-8 if dtype == np.float64 else 1e-4
    assert all(errors[name] <= tolerance for name in mjcf_compare.QUANTITIES), errors
    assert errors["start"] <= (0.0 if dtype == np.float64 else 1e-7), "Data.build starts where MuJoCo's qpos0 is"


@pytest.mark.parametrize("seed", [0, 1])
def test_an_euler_step_equals_mujocos(seed, scene_file):
    """One step of SemiImplicitEulerSO3 (MuJoCo's Euler: damping implicit, quaternions rotated exactly by
    dt omega in the child's axes, a free body's position advanced by dt v) equals mj_step's with constraints
    disabled (reference: MuJoCo; 1e-10: both compute the same arithmetic in float64)."""
    mj = mujoco.MjModel.from_xml_path(str(scene_file))
    model = _load(scene_file)
    assert model.integrator == wd.model.IntegratorType.SemiImplicitEulerSO3 and model.implicit_damping
    qpos, qvel = mm.random_state(mj, np.random.default_rng(seed))
    data = wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs)
    stepped = wd.model.step(model, data)
    expected = mm.euler_step(mj, qpos, qvel)
    reference = mjcf_compare.mujoco_to_warpdyn_state(model, mj, expected.qpos, expected.qvel).data_kwargs
    np.testing.assert_allclose(stepped.joint_positions.numpy(), reference["joint_positions"], rtol=0, atol=1e-10)
    np.testing.assert_allclose(stepped.joint_velocities.numpy(), reference["joint_velocities"], rtol=0, atol=1e-10)
    assert stepped.healthy.numpy().all()


@pytest.mark.parametrize("integrator", ["SemiImplicitEuler", "RungeKutta4"])
def test_a_tumbling_free_body_keeps_its_energy_and_momentum(integrator):
    """A free body spinning near its intermediate axis without gravity (a scene's free joint beside a fixed
    hinge; the unstable axis, so that it tumbles) keeps its kinetic energy and its angular momentum in the world: RK4 to 1e-9 relative over 0.5 s at
    1 ms (its error is O(dt^4)); semi-implicit Euler's energy to 2e-3 (first order: it rotates exactly but
    its velocity update is explicit), its momentum likewise. Reference: physics (Euler's equations conserve
    both)."""
    xml = """<mujoco><option gravity="0 0 0" timestep="0.001"/><default><geom contype="0" conaffinity="0"/></default>
      <worldbody><body name="post"><joint name="spin" axis="0 0 1"/><inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>
      <body name="book" pos="0 0 1"><freejoint name="book_free"/><inertial pos="0 0 0" mass="1" diaginertia="0.01 0.02 0.03"/></body>
      </worldbody></mujoco>"""
    model = _load(xml)
    model.integrator = wd.model.IntegratorType[integrator]
    book = wd.joint.name_to_idx(model, joint_name="book_free")
    v = np.zeros(model.dofs())
    v[wd.joint.velocity_slice(model, joint_index=book)] = [0.1, 0.0, 0.0, 0.05, 4.0, 0.05]  # near the intermediate axis
    data = wd.data.Data.build(model, joint_velocities=v)

    def invariants(d):
        q = d.joint_positions.numpy()[wd.joint.position_slice(model, joint_index=book)]
        w = d.joint_velocities.numpy()[wd.joint.velocity_slice(model, joint_index=book)][3:]
        R = wd.math.Quaternion.to_dcm(q[3:])
        I = np.diag([0.01, 0.02, 0.03])
        return 0.5 * w @ I @ w, R @ (I @ w)

    E0, L0 = invariants(data)
    for _ in range(500):
        data = wd.model.step(model, data)
    E, L = invariants(data)
    tolerance = 1e-9 if integrator == "RungeKutta4" else 2e-3
    assert abs(E - E0) <= tolerance * E0 and np.abs(L - L0).max() <= tolerance * np.linalg.norm(L0), (E - E0, L - L0)


def test_gradients_through_steps_equal_central_differences():
    """d(loss)/d(initial joint positions and velocities) through 5 RK4 steps of the scene (ball, free and
    hinge joints; quaternion entries perturbed as they are stored, the step normalising them) equals central
    differences (float64, h = 1e-6, rtol 1e-5 of the largest entry: the loss's rounding over 2e-6)."""
    model = _load(SCENE)
    model.integrator = wd.model.IntegratorType.RungeKutta4
    mj = mujoco.MjModel.from_xml_string(SCENE)
    qpos, qvel = mm.random_state(mj, np.random.default_rng(7))
    state = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
    q0, v0 = state["joint_positions"], state["joint_velocities"]
    weights_q = np.random.default_rng(8).uniform(-1, 1, model.number_of_joint_coordinates())
    weights_v = np.random.default_rng(9).uniform(-1, 1, model.dofs())

    def loss_of(q, v, tape=None):
        data = wd.data.Data.build(model, joint_positions=q, joint_velocities=v, requires_grad=tape is not None, validate=False)
        d = data
        for _ in range(5):
            d = wd.model.step(model, d)
        value = float(weights_q @ d.joint_positions.numpy() + weights_v @ d.joint_velocities.numpy())
        return value, data, d

    data = wd.data.Data.build(model, joint_positions=q0, joint_velocities=v0, requires_grad=True)
    tape = wp.Tape()
    with tape:
        d = data
        for _ in range(5):
            d = wd.model.step(model, d)
    tape.backward(grads={d.joint_positions_state: wp.array(weights_q[None], dtype=wp.float64), d.joint_velocities_state: wp.array(weights_v[None], dtype=wp.float64)})
    got_q, got_v = data.joint_positions_state.grad.numpy()[0], data.joint_velocities_state.grad.numpy()[0]
    h = 1e-6
    fd_q = np.array([(loss_of(q0 + h * e, v0)[0] - loss_of(q0 - h * e, v0)[0]) / (2 * h) for e in np.eye(len(q0))])
    fd_v = np.array([(loss_of(q0, v0 + h * e)[0] - loss_of(q0, v0 - h * e)[0]) / (2 * h) for e in np.eye(len(v0))])
    np.testing.assert_allclose(got_q, fd_q, rtol=0, atol=1e-5 * np.abs(fd_q).max())
    np.testing.assert_allclose(got_v, fd_v, rtol=0, atol=1e-5 * np.abs(fd_v).max())


def test_keyframes_and_initial_positions(scene_file):
    """Data.build starts at MuJoCo's qpos0 (the free bodies where the XML puts them, the ball at identity) and
    wd.data.keyframe at a named key; the link poses equal MuJoCo's at both (reference: MuJoCo's xpos, xquat;
    1e-12); an unknown key is a ValueError listing the keyframes."""
    mj = mujoco.MjModel.from_xml_path(str(scene_file))
    model = _load(scene_file)
    assert model.keyframe_names() == ("tilted",)
    for data, qpos in ((wd.data.Data.build(model), mj.qpos0), (wd.data.keyframe(model, "tilted"), mj.key("tilted").qpos)):
        xpos, xquat = mm.body_poses(mj, qpos)
        H = wd.model.forward_kinematics(model, data).numpy()
        for i, name in enumerate(model.link_names()[1:], start=1):
            b = mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, name)
            np.testing.assert_allclose(H[i][:3, 3], xpos[b], atol=1e-12, err_msg=name)
            np.testing.assert_allclose(H[i][:3, :3], wd.math.Quaternion.to_dcm(xquat[b]), atol=1e-12, err_msg=name)
    velocities = wd.data.keyframe(model, "tilted").joint_velocities.numpy()
    np.testing.assert_allclose(velocities, mjcf_compare.mujoco_to_warpdyn_state(model, mj, mj.key("tilted").qpos, mj.key("tilted").qvel).data_kwargs["joint_velocities"])
    with pytest.raises(ValueError, match=r"no keyframe 'standing'; its keyframes: \['tilted'\]"):
        wd.data.keyframe(model, "standing")


def test_joint_quaternions_are_checked_and_normalised():
    """Data.build refuses a ball or free joint's quaternion that is not of unit norm, naming the joint; replace
    normalises it (as JaxSim's replace does the base's); a zero one is refused."""
    model = _load(SCENE)
    q = np.array(model.tree.qpos0)
    swivel = wd.joint.position_slice(model, joint_index=wd.joint.name_to_idx(model, joint_name="swivel"))
    q[swivel] = [1.0, 0.1, 0.0, 0.0]
    with pytest.raises(ValueError, match=r"joint 'swivel' \(its quaternion at 0:4\) must be a unit quaternion"):
        wd.data.Data.build(model, joint_positions=q)
    data = wd.data.Data.build(model).replace(model, joint_positions=q)
    np.testing.assert_allclose(data.joint_positions.numpy()[swivel], np.array([1.0, 0.1, 0.0, 0.0]) / np.sqrt(1.01), atol=1e-15)
    q[swivel] = 0.0
    with pytest.raises(ValueError, match=r"joint 'swivel' must be finite, non-zero"):
        data.replace(model, joint_positions=q)


def test_a_locked_ball_joint_is_lumped_at_its_quaternion():
    """reduce locks a ball joint at a given quaternion (normalised) and lumps its link: the reduced model's
    link poses equal the full model's at that quaternion (reference: the full model; 1e-12)."""
    model = _load(mm.BALL)
    Q = np.array([0.9, 0.1, -0.3, 0.2])
    reduced = wd.model.reduce(model, ["ball_hinge"], locked_joint_positions={"ball": Q})
    full = wd.data.Data.build(model, joint_positions=np.concatenate([Q / np.linalg.norm(Q), [0.3]]))
    small = wd.data.Data.build(reduced, joint_positions=[0.3])
    H_full, H = wd.model.forward_kinematics(model, full).numpy(), wd.model.forward_kinematics(reduced, small).numpy()
    np.testing.assert_allclose(H[1], H_full[model.link_names().index("ball_child")], atol=1e-12)
    with pytest.raises(ValueError, match=r"locked_joint_positions\['ball'\] must be a unit quaternion \(w, x, y, z\) \(4 numbers\)"):
        wd.model.reduce(model, ["ball_hinge"], locked_joint_positions={"ball": 0.3})


def test_urdf_floating_and_sdf_ball_joints():
    """A URDF floating joint between two links is a free joint (7 positions, 6 velocities); an SDFormat ball joint
    is a ball joint about the joint frame's origin, whose mass matrix equals the MJCF description of the same
    pendulum's (reference: MuJoCo-read MJCF through warpdyn; 1e-12)."""
    urdf = """<robot name="r"><link name="base"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="loose"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="float" type="floating"><parent link="base"/><child link="loose"/></joint></robot>"""
    model = _load(urdf)
    assert (model.number_of_joint_coordinates(), model.dofs()) == (7, 6)
    inertial = "<inertial><pose>0.02 0 -0.3 0 0 0</pose><mass>1.2</mass><inertia><ixx>0.03</ixx><iyy>0.031</iyy><izz>0.004</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial>"
    sdf = f"""<sdf version="1.9"><model name="p"><link name="top"><pose>0 0 2 0 0 0</pose>{inertial}</link>
      <joint name="weld" type="fixed"><parent>world</parent><child>top</child></joint>
      <link name="bob"><pose relative_to="top">0 0 -0.1 0 0 0</pose>{inertial}</link>
      <joint name="swivel" type="ball"><pose relative_to="bob">0 0 0.1 0 0 0</pose><parent>top</parent><child>bob</child></joint></model></sdf>"""
    mjcf = """<mujoco><worldbody><body name="top" pos="0 0 2"><inertial pos="0.02 0 -0.3" mass="1.2" diaginertia="0.03 0.031 0.004"/>
      <body name="bob" pos="0 0 -0.1"><joint name="swivel" type="ball" pos="0 0 0.1"/>
      <inertial pos="0.02 0 -0.3" mass="1.2" diaginertia="0.03 0.031 0.004"/></body></body></worldbody></mujoco>"""
    a, b = _load(sdf), _load(mjcf)
    Q = np.array([0.8, 0.2, -0.4, 0.1]) / np.linalg.norm([0.8, 0.2, -0.4, 0.1])
    M = [wd.model.free_floating_mass_matrix(m, wd.data.Data.build(m, joint_positions=Q)).numpy()[6:, 6:] for m in (a, b)]
    np.testing.assert_allclose(M[0], M[1], atol=1e-12)


def _floating_with_free_joint_parameters() -> str:
    """A floating base (a free body alone) whose free joint carries armature, damping and stiffness, with a
    hinged arm (MuJoCo's free joint and its <joint type="free"> defaults)."""
    return """<mujoco model="floating"><option timestep="0.002"/><default><geom contype="0" conaffinity="0"/></default>
      <worldbody><body name="hull" pos="0.2 -0.1 1.5" euler="0.3 0.1 -0.2">
        <joint name="root" type="free" armature="0.05" damping="0.8" stiffness="3"/>
        <inertial pos="0.02 0.01 -0.03" quat="0.9 0.1 0.2 0.3" mass="3" diaginertia="0.05 0.06 0.08"/>
        <body name="arm" pos="0.2 0 0"><joint name="elbow" axis="0 1 0" armature="0.01" damping="0.1"/>
          <inertial pos="0.15 0 0" mass="0.5" diaginertia="0.001 0.004 0.004"/></body>
      </body></worldbody></mujoco>"""


def test_a_floating_bases_free_joint_armature_damping_and_stiffness(tmp_path):
    """A floating base's free-joint armature, damping and spring (MJCF, RB-Y1's kind): M, h, the passive forces
    and qacc equal MuJoCo's (1e-8, measured ~1e-14), one Euler step too (the damping implicit, as MuJoCo's
    eulerdamp; 1e-10), and C nu = h - g holds with them in every representation (the armature's velocity
    product, which its Body coordinates have and Mixed not; 1e-12). Reference: MuJoCo with constraints disabled,
    the identity."""
    xml = _floating_with_free_joint_parameters()
    path = tmp_path / "floating.xml"
    path.write_text(xml)
    mj = mujoco.MjModel.from_xml_path(str(path))
    model = _load(path)
    assert model.floating_base() and (float(model.base_armature.numpy()[0]), float(model.base_damping.numpy()[0]), float(model.base_stiffness.numpy()[0])) == (0.05, 0.8, 3.0)
    errors = mjcf_compare.compare_model(model, mj)
    assert all(errors[name] <= 1e-8 for name in mjcf_compare.QUANTITIES), errors
    qpos, qvel = mm.random_state(mj, np.random.default_rng(3))
    state = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel)
    stepped = wd.model.step(model, wd.data.Data.build(model, **state.data_kwargs))
    expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, *mm.euler_step(mj, qpos, qvel)[:2]).data_kwargs
    np.testing.assert_allclose(stepped.base_position.numpy(), expected["base_position"], atol=1e-10)
    np.testing.assert_allclose(stepped.base_velocity.numpy(), np.concatenate([expected["base_linear_velocity"], expected["base_angular_velocity"]]), atol=1e-10)
    np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], atol=1e-10)
    for representation in (wd.VelRepr.Body, wd.VelRepr.Mixed, wd.VelRepr.Inertial):
        data = wd.data.Data.build(model, **state.data_kwargs)
        with data.switch_velocity_representation(representation):
            C = wd.model.free_floating_coriolis_matrix(model, data).numpy()
            h = wd.model.free_floating_bias_forces(model, data).numpy()
            g = wd.model.free_floating_gravity_forces(model, data).numpy()
            nu = data.generalized_velocity.numpy()
        np.testing.assert_allclose(C @ nu, h - g, atol=1e-12 * max(1.0, np.abs(h).max()), err_msg=str(representation))



def test_gradients_of_the_free_joint_parameters(tmp_path):
    """d(loss)/d(base_armature, base_damping, base_stiffness) through 5 Euler steps of the floating base with
    its free joint's parameters equals central differences (float64, relative step 1e-6, rtol 1e-5)."""
    model = _load(_floating_with_free_joint_parameters())
    mj = mujoco.MjModel.from_xml_string(_floating_with_free_joint_parameters())
    qpos, qvel = mm.random_state(mj, np.random.default_rng(5))
    state = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
    names = ("base_armature", "base_damping", "base_stiffness")
    params = wd.model.parameters_requiring_grad(model, names=names)
    weights = np.random.default_rng(6).uniform(-1, 1, 6)

    def rollout():
        d = wd.data.Data.build(model, **state)
        for _ in range(5):
            d = wd.model.step(model, d)
        return d

    tape = wp.Tape()
    with tape:
        final = rollout()
    tape.backward(grads={final.base_velocity_state: wp.array(weights[None], dtype=wp.float64)})
    for name in names:
        value = float(params[name].numpy()[0])
        h = 1e-6 * value

        def loss_at(v):
            params[name].assign(np.array([v]))
            return float(weights @ rollout().base_velocity_state.numpy()[0])

        fd = (loss_at(value + h) - loss_at(value - h)) / (2 * h)
        params[name].assign(np.array([value]))
        np.testing.assert_allclose(params[name].grad.numpy()[0], fd, rtol=1e-5, err_msg=name)
