"""The shipped Franka Emika Panda (warpdyn/assets/franka_panda.xml, from MuJoCo Menagerie's panda_nohand.xml without
meshes and actuators): MuJoCo compiles it alone, warpdyn loads it with the one warning its comment names, and
warpdyn's dynamics equal MuJoCo's on the same file in float64 (M, h, qacc at qpos0 and random states, one step).
The shipped PandaPickCube scene (franka_panda_cube.xml): a scripted grasp picks up its cube beside MuJoCo.
Measured: M 5e-15, h 3e-15, qacc 3e-15 (tests/mjcf_compare.py's relative errors), the step's velocity change 7e-16.
"""

import warnings

import mujoco
import numpy as np
import pytest

import mjcf_compare
import mjcf_models
import warpdyn as wd
from warpdyn.description.mjcf import JOINT_LIMITS

JOINTS = tuple(f"joint{i}" for i in range(1, 8))
TOL = 1e-10


def _load_recording():
    """(model in float64, the warnings its load gave)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = wd.model.Model.build_from_model_description(wd.assets.franka_panda_mjcf(), dtype=np.float64)
    return model, caught


def _mujoco() -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(wd.assets.franka_panda_mjcf()))


def test_mujoco_compiles_the_panda_alone():
    """No mesh, geom, actuator or file beside it; 7 hinges, Menagerie's keyframe "home" and 2 ms implicitfast."""
    m = _mujoco()
    assert (m.nq, m.nv, m.nu, m.nmesh, m.ngeom, m.nmat) == (7, 7, 0, 0, 0, 0)
    assert [m.joint(j).name for j in range(m.njnt)] == list(JOINTS)
    np.testing.assert_array_equal(m.key("home").qpos, [0, 0, 0, -1.57079, 0, 1.57079, -0.7853])
    assert m.opt.timestep == 0.002 and m.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    np.testing.assert_array_equal(m.dof_armature, 0.1)
    np.testing.assert_array_equal(m.dof_damping, 1.0)


def test_the_panda_loads_with_one_warning_for_its_joint_limits():
    """warpdyn models all of it but the joint limits (MuJoCo's limit constraints): one NotModelledWarning that names
    the 7 joints' limits and nothing else; a fixed base, 8 links, the flange frame, the keyframe."""
    model, caught = _load_recording()
    assert [w.category for w in caught] == [wd.model.NotModelledWarning], [str(w.message) for w in caught]
    listed = str(caught[0].message).split(" holds elements that warpdyn does not model: ")[1]
    assert listed == f"{JOINT_LIMITS}: {list(JOINTS)}"  # one kind of element: the 7 joints' limits
    assert not model.floating_base() and model.joint_names() == JOINTS and model.number_of_links() == 8
    assert wd.assets.FRANKA_PANDA_FLANGE in model.frame_names()
    assert len(wd.assets.FRANKA_PANDA_TORQUE_LIMITS) == model.dofs()
    home = wd.data.keyframe(model, "home")
    np.testing.assert_array_equal(home.joint_positions.numpy(), _mujoco().key("home").qpos)


def test_the_panda_equals_mujoco():
    """M, h (qfrc_bias), passive forces and qacc at qpos0 and 5 random states (joint positions within their
    ranges, velocities N(0, 1)), relative to 1e-10 (mjcf_compare.compare_model)."""
    model, _ = _load_recording()
    errors = mjcf_compare.compare_model(model, _mujoco(), random_states=5, seed=3)
    assert all(errors[name] < TOL for name in ("M", "h", "forces", "qacc")), errors
    assert errors["start"] == 0.0


def test_a_step_of_the_panda_equals_mujocos():
    """One 2 ms step under random joint torques at random states equals mj_step (implicitfast: the joints' damping
    implicit, as warpdyn's Euler step; constraints disabled): the velocity change to 1e-10 of its size, the new
    positions to 1e-12 rad."""
    model, _ = _load_recording()
    m = _mujoco()
    ref = mjcf_models.reference_model(m)
    rng = np.random.default_rng(7)
    for _ in range(3):
        qpos, qvel = mjcf_models.random_state(m, rng)
        tau = rng.normal(0.0, 20.0, m.nv)
        d = mjcf_models.make_data(ref, qpos, qvel)
        d.qfrc_applied[:] = tau
        mujoco.mj_step(ref, d)
        new = wd.model.step(model, wd.data.Data.build(model, joint_positions=qpos, joint_velocities=qvel), joint_force_references=tau)
        change = d.qvel - qvel
        assert np.abs(new.joint_velocities.numpy() - d.qvel).max() < TOL * np.abs(change).max()
        assert np.abs(new.joint_positions.numpy() - d.qpos).max() < 1e-12


def _grasp_controls(ctrl: np.ndarray, t: float) -> np.ndarray:
    """The scripted pick from the keyframe "pickup1"'s controls: the gripper closes over 0.3 s, then from 0.5 s joint 2
    lifts by 0.4 rad and joint 4 by 0.3 rad over 0.5 s, then holds."""
    c = ctrl.copy()
    c[7] = 0.04 * max(0.0, 1.0 - t / 0.3)
    ramp = min(1.0, max(0.0, (t - 0.5) / 0.5))
    c[1] -= 0.4 * ramp
    c[3] += 0.3 * ramp
    return c


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_the_panda_picks_up_the_cube(dtype):
    """The shipped PandaPickCube scene (wd.assets.franka_panda_cube_mjcf: MuJoCo compiles it alone, 16 coordinates, 8
    controls, the two fingertip pads' geom pairs with the cube) under a scripted grasp from Menagerie's keyframe
    "pickup1", 2 s of 1 ms steps beside MuJoCo: the arm's joints end where MuJoCo's do (1e-3 rad; 1e-4 measured), the
    cube within 1 cm of MuJoCo's height, and
    the cube, turned 39 degrees about the vertical, is squeezed, lifted 39 cm and held by the contacts' static friction
    (its height below the fingers changes by less than 0.1 mm over the last 0.5 s). How the cube turns in the grip is
    the contact laws' own: MuJoCo's cube turns 30 degrees further about the vertical as the pads close and ends 6 mm
    lower, its fingers 4.5 mm further closed. Soft law K = 5e5, D = 500: with the defaults' D = 2000, the 0.1 kg cube's squeezed
    contacts damp it beyond the explicit step's stable rate at 1 ms and the float32 grasp squeezed it out."""
    m = mujoco.MjModel.from_xml_path(str(wd.assets.franka_panda_cube_mjcf()))
    assert (m.nq, m.nu, m.nmesh, m.opt.timestep) == (16, 8, 0, 0.001)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(wd.assets.franka_panda_cube_mjcf(), dtype=dtype)
    model.geom_contacts = True
    model.contact_params = wd.model.SoftContactsParams(K=5e5, D=500.0, mu=1.0)  # mu: MuJoCo's cube-floor friction, 1
    assert wd.contact.geom_pairs(model).names == (("left_finger_pad", "box"), ("right_finger_pad", "box"))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, m.key("pickup1").id)
    ctrl = m.key("pickup1").ctrl.copy()
    data = wd.data.keyframe(model, "pickup1")
    cube, finger = model.link_names().index("box"), model.link_names().index("left_finger")
    gaps = []
    for k in range(2000):
        u = _grasp_controls(ctrl, k * 1e-3)
        data = wd.model.step(model, data, ctrl=u)
        d.ctrl[:] = u
        mujoco.mj_step(m, d)
        if k >= 1500:
            H = wd.model.forward_kinematics(model, data).numpy()
            gaps.append(H[finger, 2, 3] - H[cube, 2, 3])
    assert bool(data.healthy.numpy().all())
    q = data.joint_positions.numpy().reshape(-1)
    arm = [wd.joint.position_slice(model, joint_index=wd.joint.name_to_idx(model, joint_name=f"joint{i}")).start for i in range(1, 8)]
    np.testing.assert_allclose(q[arm], d.qpos[:7], atol=1e-3)
    assert H[cube, 2, 3] > 0.03 + 0.38  # lifted from the floor
    assert abs(H[cube, 2, 3] - d.xpos[m.body("box").id][2]) < 0.01  # MuJoCo's cube slides 6 mm further down the pads
    assert np.ptp(gaps) < 1e-4, np.ptp(gaps)
