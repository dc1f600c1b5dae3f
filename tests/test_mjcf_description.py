"""The description layer of the MJCF features (warpdyn.description: load, build_tree) against MuJoCo.

References: MuJoCo's compiled MjModel fields (dof_armature, dof_damping, jnt_stiffness, qpos_spring,
jnt_actfrcrange, body_gravcomp, actuator_*, opt) for the parameters, which are copied, so they must be
equal with 0 tolerance; MuJoCo's mj_kinematics (xpos, xquat, xanchor, xaxis) and mj_passive
(qfrc_gravcomp) for the kinematics and the lumped gravity compensation, recomputed on the host from the
tree in float64 (1e-12: a few roundings of products of O(1) numbers). Fixtures: tests/mjcf_fixtures.py
(semantics in docs/mujoco_semantics.md) and the small ones below. Host only: no device is touched.

What is not modelled (the warning) and URDF descriptions: tests/test_mjcf_warnings.py.
"""

from __future__ import annotations

import warnings

import mjcf_models as mm
import mujoco
import numpy as np
import pytest

from warpdyn.description import NotModelledWarning, load
from warpdyn.description.model import joint_motion, quaternion_wxyz_to_matrix
from warpdyn.description.tree import JOINT_PRISMATIC, JOINT_REVOLUTE, build_tree

#: Gravity compensation through lumping: welded children with their own gravcomp (a1_motor, a1_cover,
#: a2_buoy > 1: buoyancy, a2_tool none), a multi-joint body (a1), an actuatorgravcomp joint (ga3), a slide.
GRAVCOMP_LUMPED = """
<mujoco model="gravcomp_lumped">
  <compiler angle="radian"/>
  <default>
    <geom contype="0" conaffinity="0"/>
  </default>
  <worldbody>
    <body name="a1" pos="0 0 1" quat="0.9659258 0 0 0.2588190" gravcomp="1">
      <joint name="ga1" axis="0 1 0"/>
      <joint name="ga2" axis="1 0 0.3" pos="0 0 0.05" ref="0.2"/>
      <inertial pos="0.15 0 0.01" mass="1.0" diaginertia="0.001 0.0085 0.0085"/>
      <body name="a1_motor" pos="0.1 0.02 0" quat="0.9238795 0.3826834 0 0" gravcomp="0.7">
        <inertial pos="0.01 0 0.02" mass="0.4" diaginertia="0.0002 0.0003 0.0003"/>
        <body name="a1_cover" pos="0 0.01 0.03" gravcomp="0.3">
          <inertial pos="0 0.02 0" mass="0.1" diaginertia="0.0001 0.0001 0.0001"/>
        </body>
      </body>
      <body name="a2" pos="0.3 0 0" gravcomp="0.5">
        <joint name="ga3" axis="0 0 1" actuatorgravcomp="true"/>
        <inertial pos="0.12 0 -0.02" mass="0.8" diaginertia="0.0008 0.004 0.004"/>
        <body name="a2_tool" pos="0.25 0 0">
          <inertial pos="0.02 0 0" mass="0.3" diaginertia="0.0002 0.0003 0.0003"/>
        </body>
        <body name="a2_buoy" pos="0.1 -0.05 0.02" quat="0.7071068 0 0.7071068 0" gravcomp="2">
          <inertial pos="0.03 0.01 0" mass="0.2" diaginertia="0.0001 0.0001 0.0001"/>
        </body>
        <body name="a3" pos="0.25 0 0" gravcomp="1.2">
          <joint name="ga4" type="slide" axis="1 0 0"/>
          <inertial pos="0.05 0.01 0" mass="0.5" diaginertia="0.0003 0.0005 0.0005"/>
        </body>
      </body>
    </body>
  </worldbody>
  <actuator>
    <motor name="gl_mot" joint="ga3" gear="2"/>
  </actuator>
</mujoco>
"""

#: The same arm under a free, gravity-compensated base with a welded, compensated payload.
GRAVCOMP_LUMPED_FLOATING = GRAVCOMP_LUMPED.replace(
    '<body name="a1" pos="0 0 1"',
    '<body name="hub" pos="0.2 0.1 1.5" gravcomp="0.4"><freejoint name="hub_root"/>'
    '<inertial pos="0.01 0.02 -0.03" mass="2" diaginertia="0.01 0.02 0.03"/>'
    '<body name="payload" pos="0 0 -0.1" gravcomp="1"><inertial pos="0 0.01 0" mass="0.6" diaginertia="0.001 0.001 0.001"/></body>'
    '<body name="a1" pos="0 0 0.1"',
).replace("</worldbody>", "</body></worldbody>")

#: <option> with several disable flags and another integrator.
FLAGS = """
<mujoco model="flags">
  <compiler angle="radian"/>
  <option timestep="0.01" integrator="implicitfast" gravity="0 0 0">
    <flag gravity="disable" spring="disable" eulerdamp="disable" actuation="disable" clampctrl="disable"/>
  </option>
  <worldbody>
    <body name="b" pos="0 0 1">
      <joint name="j" axis="0 1 0"/>
      <inertial pos="0.1 0 0" mass="1" diaginertia="0.001 0.001 0.001"/>
    </body>
  </worldbody>
</mujoco>
"""

#: Fixtures of tests/mjcf_fixtures.py that warpdyn loads (GRAVCOMP without its free balloon: a second robot).
GRAVCOMP_ARM = mm.GRAVCOMP[: mm.GRAVCOMP.index('    <body name="balloon"')] + mm.GRAVCOMP[mm.GRAVCOMP.index("  </worldbody>") :]
LOADED = {
    **{
        name: mm.FIXTURES[name]
        for name in (
            "ARMATURE",
            "DAMPING",
            "SPRINGS",
            "SPRINGS_DEGREE",
            "MOTOR",
            "POSITION",
            "VELOCITY",
            "GENERAL",
            "MULTI_JOINT",
            "WORLD_CHILDREN",
            "OPTIONS",
            "DRONE",
            "FLOATING_HUMANOID",
            "JOINT_ACTUATORFRCRANGE",
            "ACTUATOR_ARMATURE_DAMPING",
            "UNSUPPORTED",
        )
    },
    "GRAVCOMP_ARM": GRAVCOMP_ARM,
    "GRAVCOMP_LUMPED": GRAVCOMP_LUMPED,
    "GRAVCOMP_LUMPED_FLOATING": GRAVCOMP_LUMPED_FLOATING,
    "FLAGS": FLAGS,
}


def _load(xml, **kwargs):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotModelledWarning)
        return load(xml, **kwargs)


def _id(m, obj, name):
    i = mujoco.mj_name2id(m, obj, name)
    assert i >= 0, name
    return i


def _actuator_share(m, field, j):
    """MuJoCo's mj_actuatorArmature / mj_actuatorDamping (engine_core_util.c): gear^2 * value of the actuators
    with a joint transmission on joint j, by the same arithmetic."""
    values = getattr(m, field)
    aid = int(m.jnt_actuatorid[j])
    if aid == -1:
        return 0.0
    if aid >= 0:
        g = float(m.actuator_gear[aid][0])
        return float(values[aid]) * (g * g)
    total = 0.0
    for k in range(m.nu):
        if m.actuator_trnid[k][0] == j and int(m.actuator_trntype[k]) in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT):
            g = float(m.actuator_gear[k][0])
            total += float(values[k]) * (g * g)
    return total


# ------------------------------------------------------------------------------------ parameters


@pytest.mark.parametrize("name", sorted(LOADED))
def test_joint_parameters_equal_mujoco(name):
    """Per joint, by name: armature = dof_armature (+ gear^2 actuator armature), passive_damping = dof_damping
    (+ gear^2 actuator damping), stiffness = jnt_stiffness, springref = qpos_spring (q = qpos), friction =
    dof_frictionloss, damping (JaxSim's viscous friction) = 0, actuator_force_range = jnt_actfrcrange where
    actuatorfrclimited else +-inf, actuator_gravcomp = jnt_actgravcomp, limits = jnt_range where limited.
    Reference: the MjModel fields (copied numbers: 0 tolerance)."""
    xml = LOADED[name]
    m = mm.load(xml)
    tree = build_tree(_load(xml))
    n = tree.dofs
    for array, shape in (
        ("armature", (n,)),
        ("passive_damping", (n,)),
        ("stiffness", (n,)),
        ("springref", (n,)),
        ("actuator_force_range", (n, 2)),
        ("actuator_gravcomp", (n,)),
    ):
        assert getattr(tree, array).shape == shape, array
    assert tree.actuator_gravcomp.dtype == bool
    assert n == sum(1 for j in range(m.njnt) if int(m.jnt_type[j]) in (mujoco.mjtJoint.mjJNT_HINGE, mujoco.mjtJoint.mjJNT_SLIDE))
    for i, jname in enumerate(tree.joint_names):
        j = _id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)
        dof, adr = m.jnt_dofadr[j], m.jnt_qposadr[j]
        assert tree.armature[i] == m.dof_armature[dof] + _actuator_share(m, "actuator_armature", j), jname
        assert tree.passive_damping[i] == m.dof_damping[dof] + _actuator_share(m, "actuator_damping", j), jname
        assert tree.stiffness[i] == m.jnt_stiffness[j], jname
        assert tree.springref[i] == m.qpos_spring[adr], jname
        assert tree.friction[i] == m.dof_frictionloss[dof], jname
        assert tree.damping[i] == 0.0, jname
        expected = m.jnt_actfrcrange[j] if m.jnt_actfrclimited[j] else [-np.inf, np.inf]
        np.testing.assert_array_equal(tree.actuator_force_range[i], expected, err_msg=jname)
        assert tree.actuator_gravcomp[i] == bool(m.jnt_actgravcomp[j]), jname
        expected = m.jnt_range[j] if m.jnt_limited[j] else [-np.inf, np.inf]
        np.testing.assert_array_equal(tree.position_limits[i], expected, err_msg=jname)
        assert tree.joint_type[i + 1] == (JOINT_REVOLUTE if int(m.jnt_type[j]) == mujoco.mjtJoint.mjJNT_HINGE else JOINT_PRISMATIC)


def test_fixture_values_spot_checks():
    """The fixtures' documented numbers arrive where they belong (mjcf_models.py comments): armature from
    defaults and classes, MuJoCo's damping in passive_damping (not in JaxSim's damping), springref in
    radians for a degree model (30 deg), actuatorfrcrange, actuator armature/damping times gear^2."""
    tree = build_tree(_load(mm.ARMATURE))
    np.testing.assert_array_equal(tree.armature, [0.05, 0.2, 0.1])
    tree = build_tree(_load(mm.DAMPING))
    np.testing.assert_array_equal(tree.passive_damping, [2.0, 0.3, 0.0])
    np.testing.assert_array_equal(tree.damping, [0.0, 0.0, 0.0])
    tree = build_tree(_load(mm.SPRINGS))
    np.testing.assert_array_equal(tree.stiffness, [5.0, 50.0, 1.5])
    np.testing.assert_array_equal(tree.springref, [0.3, -0.05, 0.0])
    tree = build_tree(_load(mm.SPRINGS_DEGREE))
    assert tree.springref[0] == pytest.approx(np.deg2rad(30.0), abs=1e-15) and tree.springref[1] == 0.2
    tree = build_tree(_load(mm.JOINT_ACTUATORFRCRANGE))
    np.testing.assert_array_equal(tree.actuator_force_range, [[-3.0, 3.0]])
    tree = build_tree(_load(mm.ACTUATOR_ARMATURE_DAMPING))
    assert tree.armature[0] == pytest.approx(0.01 + 0.9, abs=1e-15)
    assert tree.passive_damping[0] == pytest.approx(0.1 + 1.8, abs=1e-15)


def test_actuator_armature_and_damping_against_mujoco_forces():
    """ACTUATOR_ARMATURE_DAMPING against what MuJoCo computes with it: the damper at qvel = 1 (qfrc_damper =
    -passive_damping) and the mass matrix minus the same model's without any armature (= armature).
    Tolerance 4e-16 / 1e-12: MuJoCo 4 sums the joint's and the actuator's damping in another order than
    mj_actuatorDamping (1 ulp of 1.9); M - M0 is a difference of O(1) numbers."""
    m = mm.load(mm.ACTUATOR_ARMATURE_DAMPING)
    tree = build_tree(_load(mm.ACTUATOR_ARMATURE_DAMPING))
    damper = mm.passive_forces(m, m.qpos0, np.ones(m.nv)).qfrc_damper
    assert abs(-damper[0] - tree.passive_damping[0]) <= 4.5e-16
    m0 = mm.load(mm.ACTUATOR_ARMATURE_DAMPING.replace(' armature="0.01"', "").replace(' armature="0.001"', ""))
    qpos = np.array([0.3])
    M, M0 = mm.full_mass_matrix(m, qpos), mm.full_mass_matrix(m0, qpos)
    assert abs((M - M0)[0, 0] - tree.armature[0]) <= 1e-12


@pytest.mark.parametrize("name", sorted(LOADED))
def test_actuators_equal_mujoco(name):
    """Per actuator, by name, in MuJoCo's order: joint (kept index and name), gear = gear[0], ctrl/force
    ranges and their limited flags, gain = gainprm[0:3] (fixed/affine), bias = biasprm[0:3] (none/affine);
    every joint-transmission, no-dynamics actuator is there, the others are not. Reference: MjModel fields
    (0 tolerance)."""
    xml = LOADED[name]
    m = mm.load(xml)
    description = _load(xml)
    tree = build_tree(description)
    supported = [
        k
        for k in range(m.nu)
        if int(m.actuator_trntype[k]) == mujoco.mjtTrn.mjTRN_JOINT
        and int(m.actuator_dyntype[k]) == mujoco.mjtDyn.mjDYN_NONE
        and int(m.actuator_gaintype[k]) in (mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtGain.mjGAIN_AFFINE)
        and int(m.actuator_biastype[k]) in (mujoco.mjtBias.mjBIAS_NONE, mujoco.mjtBias.mjBIAS_AFFINE)
    ]
    assert [a.name for a in tree.actuators] == [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, k) for k in supported]
    assert [a.name for a in description.actuators] == [a.name for a in tree.actuators]
    for a, k in zip(tree.actuators, supported):
        jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, m.actuator_trnid[k][0])
        assert a.joint_name == jname and tree.joint_names[a.joint] == jname
        assert a.gear == m.actuator_gear[k][0]
        np.testing.assert_array_equal(a.ctrl_range, m.actuator_ctrlrange[k])
        assert a.ctrl_limited == bool(m.actuator_ctrllimited[k])
        np.testing.assert_array_equal(a.force_range, m.actuator_forcerange[k])
        assert a.force_limited == bool(m.actuator_forcelimited[k])
        np.testing.assert_array_equal(a.gain, m.actuator_gainprm[k][:3])
        np.testing.assert_array_equal(a.bias, m.actuator_biasprm[k][:3])
        assert a.gain_type == ("fixed" if int(m.actuator_gaintype[k]) == mujoco.mjtGain.mjGAIN_FIXED else "affine")
        assert a.bias_type == ("none" if int(m.actuator_biastype[k]) == mujoco.mjtBias.mjBIAS_NONE else "affine")


def test_actuator_shortcuts():
    """MuJoCo's shortcuts as documented in docs/mujoco_semantics.md: position kp=100 kv=5 -> gain (100, 0, 0),
    bias (0, -100, -5); velocity kv=20 -> bias (0, 0, -20); motor -> fixed gain 1, no bias; MOTOR's mot3 is
    ctrllimited=false with its range kept."""
    pos1 = build_tree(_load(mm.POSITION)).actuators[0]
    np.testing.assert_array_equal(pos1.gain, [100.0, 0.0, 0.0])
    np.testing.assert_array_equal(pos1.bias, [0.0, -100.0, -5.0])
    assert (pos1.gear, pos1.force_limited, pos1.bias_type) == (2.0, True, "affine")
    vel1 = build_tree(_load(mm.VELOCITY)).actuators[0]
    np.testing.assert_array_equal(vel1.bias, [0.0, 0.0, -20.0])
    motors = build_tree(_load(mm.MOTOR)).actuators
    assert [(a.name, a.joint, a.gain_type, a.bias_type) for a in motors] == [
        ("mot1", 0, "fixed", "none"),
        ("mot2", 1, "fixed", "none"),
        ("mot3", 2, "fixed", "none"),
        ("mot1b", 0, "fixed", "none"),
    ]
    assert not motors[2].ctrl_limited
    np.testing.assert_array_equal(motors[2].ctrl_range, [-1.0, 1.0])


def test_actuators_on_locked_joints_are_dropped_with_a_warning():
    """Reducing FLOATING_HUMANOID to its legs drops the upper-body actuators with one NotModelledWarning that
    names them (and no leg actuator); the leg actuators point at the reduced tree's joint indices."""
    description = _load(mm.FLOATING_HUMANOID)
    legs = [j.name for j in description.joints if j.name.startswith(("hip", "knee", "ankle"))]
    with pytest.warns(NotModelledWarning) as caught:
        tree = build_tree(description, legs)
    assert len(caught) == 1
    message = str(caught[0].message)
    assert caught[0].filename == __file__
    for name in ("abdomen_z", "abdomen_y", "shoulder_r1", "shoulder_r2", "elbow_r", "shoulder_l1", "shoulder_l2", "elbow_l"):
        assert f"'{name} (on {name})'" in message
    for name in legs:
        assert f"'{name} (on" not in message
    assert [a.name for a in tree.actuators] == legs  # MuJoCo's order
    for a in tree.actuators:
        assert tree.joint_names[a.joint] == a.joint_name == a.name


# ------------------------------------------------------------------------------------ gravcomp


def _world_poses(tree, description, q, world_H_base=None):
    """Host forward kinematics over the tree: W_H_link (nL, 4, 4) and W_H_frame (nF, 4, 4) at joint positions q."""
    H = np.zeros((tree.number_of_links, 4, 4))
    H[0] = description.world_H_base if world_H_base is None else world_H_base
    for i in range(1, tree.number_of_links):
        kind = "revolute" if tree.joint_type[i] == JOINT_REVOLUTE else "prismatic"
        motion = joint_motion(kind, tree.joint_axis[i], tree.joint_pivot[i], q[i - 1])
        H[i] = H[tree.parent[i]] @ tree.parent_H_joint[i] @ motion
    frames = np.array([H[p] @ X for p, X in zip(tree.frame_parent, tree.link_H_frame)]).reshape(-1, 4, 4)
    return H, frames


def _state(m, tree, description, rng):
    """A random MuJoCo qpos, warpdyn's q (= qpos of the kept joints) and the floating base's W_H_B."""
    qpos, _ = mm.random_state(m, rng)
    q = np.array([qpos[m.jnt_qposadr[_id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]] for name in tree.joint_names])
    world_H_base = None
    if not description.fixed_base:
        j = m.body_jntadr[_id(m, mujoco.mjtObj.mjOBJ_BODY, description.base)]
        a = m.jnt_qposadr[j]
        world_H_base = np.eye(4)
        world_H_base[:3, :3] = quaternion_wxyz_to_matrix(qpos[a + 3 : a + 7])
        world_H_base[:3, 3] = qpos[a : a + 3]
    return qpos, q, world_H_base


def _gravcomp_torques(tree, H, g):
    """J_com^T of the forces -gravcomp_mass * g (g the world's gravity, (3,)) at gravcomp_com, per tree joint; for a
    floating base also MuJoCo's free-joint components (world force, torque about the base origin in the base
    frame)."""
    tau = np.zeros(tree.dofs)
    base = np.zeros(6)
    support = tree.support()
    for L in range(tree.number_of_links):
        if tree.gravcomp_mass[L] == 0.0:
            continue
        p = H[L][:3, :3] @ tree.gravcomp_com[L] + H[L][:3, 3]
        f = -tree.gravcomp_mass[L] * np.asarray(g)
        for i in np.flatnonzero(support[L]):
            c = i + 1
            axis = H[c][:3, :3] @ tree.joint_axis[c]
            if tree.joint_type[c] == JOINT_REVOLUTE:
                anchor = H[c][:3, :3] @ tree.joint_pivot[c] + H[c][:3, 3]
                tau[i] += axis @ np.cross(p - anchor, f)
            else:
                tau[i] += axis @ f
        base[:3] += f
        base[3:] += H[0][:3, :3].T @ np.cross(p - H[0][:3, 3], f)
    return tau, base


@pytest.mark.parametrize("name", ["GRAVCOMP_ARM", "GRAVCOMP_LUMPED", "GRAVCOMP_LUMPED_FLOATING"])
def test_gravcomp_lumped_equals_mujoco_qfrc_gravcomp(name):
    """MuJoCo's qfrc_gravcomp (mj_gravcomp: sum_b J_p(b, xipos_b)' gravcomp_b m_b (-opt.gravity), welded
    bodies with their own mass and CoM; all dofs, actuatorgravcomp ones included) equals J^T of the lumped
    per-link forces (-gravcomp_mass g at gravcomp_com) at random qpos, for every kept joint and the free
    base. Tolerance 1e-12 absolute: float64 sums of a few products of O(1) numbers (torques ~ 10 N m)."""
    xml = LOADED[name]
    m = mm.load(xml)
    description = _load(xml)
    tree = build_tree(description)
    g = description.gravity
    rng = np.random.default_rng(7)
    for _ in range(5):
        qpos, q, world_H_base = _state(m, tree, description, rng)
        qfrc = mm.passive_forces(m, qpos, np.zeros(m.nv)).qfrc_gravcomp
        H, _ = _world_poses(tree, description, q, world_H_base)
        tau, base = _gravcomp_torques(tree, H, g)
        for i, jname in enumerate(tree.joint_names):
            dof = m.jnt_dofadr[_id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)]
            assert abs(tau[i] - qfrc[dof]) <= 1e-12, (jname, tau[i], qfrc[dof])
        if not description.fixed_base:
            np.testing.assert_allclose(base, qfrc[:6], rtol=0, atol=1e-12)
        assert np.abs(qfrc).max() > 0.05  # the test sees something


def test_gravcomp_lumping_sums():
    """gravcomp_mass of a link is sum gc_b m_b over its members (GRAVCOMP_LUMPED: a1 1*1 + a1_motor 0.7*0.4
    + a1_cover 0.3*0.1; a2 0.5*0.8 + a2_buoy 2*0.2; a3 1.2*0.5; the massless intermediate a1/ga1 0), and an
    unlumped link's gravcomp_com is its CoM exactly (MuJoCo's body_ipos)."""
    m = mm.load(GRAVCOMP_LUMPED)
    tree = build_tree(_load(GRAVCOMP_LUMPED))
    mass = dict(zip(tree.link_names, tree.gravcomp_mass))
    assert mass["a1/ga1"] == 0.0 and mass["world"] == 0.0
    assert mass["a1"] == pytest.approx(1.0 + 0.28 + 0.03, abs=1e-15)
    assert mass["a2"] == pytest.approx(0.4 + 0.4, abs=1e-15)
    assert mass["a3"] == 1.2 * 0.5
    a3 = tree.link_names.index("a3")
    np.testing.assert_array_equal(tree.gravcomp_com[a3], m.body_ipos[_id(m, mujoco.mjtObj.mjOBJ_BODY, "a3")])
    np.testing.assert_array_equal(tree.gravcomp_com[tree.link_names.index("a1/ga1")], np.zeros(3))
    arm, m = build_tree(_load(GRAVCOMP_ARM)), mm.load(GRAVCOMP_ARM)
    for L, name in enumerate(arm.link_names[1:], start=1):
        b = _id(m, mujoco.mjtObj.mjOBJ_BODY, name)
        assert arm.gravcomp_mass[L] == m.body_gravcomp[b] * m.body_mass[b]
        expected = m.body_ipos[b] if m.body_gravcomp[b] != 0.0 else np.zeros(3)
        np.testing.assert_array_equal(arm.gravcomp_com[L], expected)
    np.testing.assert_array_equal(arm.actuator_gravcomp, [False, True, False])


def test_gravcomp_after_a_reduction():
    """Locking ga2 (at 0.4) and ga4 (at 0.05) lumps more compensated bodies: J^T of the lumped forces still
    equals MuJoCo's qfrc_gravcomp on the kept dofs at a qpos with the locked joints at their locked values
    (1e-12, as above)."""
    m = mm.load(GRAVCOMP_LUMPED)
    description = _load(GRAVCOMP_LUMPED)
    locked = {"ga2": 0.4, "ga4": 0.05}
    tree = build_tree(description, ["ga1", "ga3"], locked)
    rng = np.random.default_rng(3)
    for _ in range(5):
        qpos, q, _ = _state(m, tree, description, rng)
        for name, value in locked.items():
            qpos[m.jnt_qposadr[_id(m, mujoco.mjtObj.mjOBJ_JOINT, name)]] = value
        qfrc = mm.passive_forces(m, qpos, np.zeros(m.nv)).qfrc_gravcomp
        H, _ = _world_poses(tree, description, q)
        tau, _ = _gravcomp_torques(tree, H, description.gravity)
        for i, jname in enumerate(tree.joint_names):
            assert abs(tau[i] - qfrc[m.jnt_dofadr[_id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)]]) <= 1e-12


def test_gravcomp_cancelling_into_a_couple_is_refused():
    """Welded bodies with opposite compensations (gc m = +0.5 and -0.5 at different points) lump into a pure
    couple that one force cannot carry: ValueError naming the link and the bodies."""
    xml = """<mujoco><worldbody><body name="p" pos="0 0 1"><joint name="j" axis="0 1 0"/>
      <body name="up" pos="0.1 0 0" gravcomp="1"><inertial pos="0 0 0" mass="0.5" diaginertia="0.01 0.01 0.01"/></body>
      <body name="down" pos="-0.1 0 0" gravcomp="-1"><inertial pos="0 0 0" mass="0.5" diaginertia="0.01 0.01 0.01"/></body>
      </body></worldbody></mujoco>"""
    with pytest.raises(ValueError, match=r"\['up', 'down'\].*link 'p'.*couple"):
        build_tree(_load(xml))


# ------------------------------------------------------------------------------------ structure and kinematics


@pytest.mark.parametrize(
    "name", ["MULTI_JOINT", "WORLD_CHILDREN", "FLOATING_HUMANOID", "GRAVCOMP_LUMPED", "GRAVCOMP_LUMPED_FLOATING", "UNSUPPORTED"]
)
def test_kinematics_equal_mujoco(name):
    """Host forward kinematics over the tree (parent_H_joint @ joint_motion(q) composed down the tree) equals
    MuJoCo's mj_kinematics at random qpos: xpos/xquat of every body (a kept link or a lumped frame), and
    xaxis of every joint and xanchor of every hinge (= the joint's child link pose applied to its axis and
    pivot; for the first
    joints of a multi-joint body that link is the massless '{body}/{joint}'). Tolerance 1e-12: float64
    products of a few rotations."""
    xml = LOADED[name]
    m = mm.load(xml)
    description = _load(xml)
    tree = build_tree(description)
    rng = np.random.default_rng(11)
    bodies = set()
    for _ in range(10):
        qpos, q, world_H_base = _state(m, tree, description, rng)
        d = mm.make_data(m, qpos)
        mujoco.mj_kinematics(m, d)
        H, F = _world_poses(tree, description, q, world_H_base)
        for names, poses in ((tree.link_names, H), (tree.frame_names, F)):
            for name_, pose in zip(names, poses):
                b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name_)
                if b <= 0:
                    assert "/" in name_ or name_ == "world", name_
                    continue
                bodies.add(name_)
                np.testing.assert_allclose(pose[:3, 3], d.xpos[b], rtol=0, atol=1e-12, err_msg=name_)
                np.testing.assert_allclose(pose[:3, :3], d.xmat[b].reshape(3, 3), rtol=0, atol=1e-12, err_msg=name_)
        for i, jname in enumerate(tree.joint_names, start=1):
            j = _id(m, mujoco.mjtObj.mjOBJ_JOINT, jname)
            if tree.joint_type[i] == JOINT_REVOLUTE:  # a slide's anchor is before its translation, and unused
                anchor = H[i][:3, :3] @ tree.joint_pivot[i] + H[i][:3, 3]
                np.testing.assert_allclose(anchor, d.xanchor[j], rtol=0, atol=1e-12, err_msg=jname)
            np.testing.assert_allclose(H[i][:3, :3] @ tree.joint_axis[i], d.xaxis[j], rtol=0, atol=1e-12, err_msg=jname)
    assert bodies == {mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) for b in range(1, m.nbody)}


def test_multi_joint_body_becomes_a_chain():
    """MULTI_JOINT: a body with joints j1..jk is '{b}/{j1}', ..., '{b}/{j(k-1)}', then b (massless
    intermediates, the body's mass and geoms on b); j1 carries the body's pose, j2..jk an identity origin
    (up to the `ref` MuJoCo subtracts)."""
    description = _load(mm.MULTI_JOINT)
    tree = build_tree(description)
    assert tree.link_names == [
        "world", "base/base_x", "base/base_y", "base", "upper_arm/sh_x", "upper_arm/sh_y", "upper_arm", "forearm/el_1", "forearm"
    ]  # fmt: skip
    assert tree.joint_names == ["base_x", "base_y", "base_yaw", "sh_x", "sh_y", "sh_z", "el_1", "el_2"]
    np.testing.assert_array_equal(tree.parent, [-1, 0, 1, 2, 3, 4, 5, 6, 7])
    mass = dict(zip(tree.link_names, tree.link_mass))
    assert mass["base/base_x"] == mass["upper_arm/sh_y"] == 0.0 and mass["base"] == 3.0 and mass["forearm"] == 0.7
    assert description.fixed_base and description.base == "world"
    by_name = {j.name: j for j in description.joints}
    np.testing.assert_array_equal(by_name["sh_y"].origin, np.eye(4))
    np.testing.assert_array_equal(by_name["el_2"].origin, np.eye(4))
    # ref folded: base_y moves by q - 0.05 along y
    np.testing.assert_allclose(by_name["base_y"].origin, joint_motion("prismatic", np.array([0.0, 1.0, 0.0]), np.zeros(3), -0.05))


def test_world_children_fixed_root():
    """WORLD_CHILDREN: the world is the fixed base; the table and the pedestal (welded to the world) and the
    tool/tcp (welded to the left arm) become frames; the two arms start subtrees in body order."""
    description = _load(mm.WORLD_CHILDREN)
    tree = build_tree(description)
    assert description.base == "world" and description.fixed_base
    assert tree.link_names == ["world", "right_base", "left_base", "right_link", "left_link"] or tree.link_names == [
        "world", "left_base", "right_base", "left_link", "right_link"
    ]  # fmt: skip
    assert set(tree.frame_names) == {"table", "pedestal", "left_tool", "left_tcp"}
    assert tree.link_mass[0] == pytest.approx(25.0, abs=1e-12)  # table and pedestal lumped into the world
    left_tcp = tree.frame_names.index("left_tcp")
    assert tree.link_names[tree.frame_parent[left_tcp]] == "left_link"


def test_drone_is_a_floating_base_without_joints():
    """DRONE: one free body, no joint: a floating base 'drone' with 0 joints, its mass and inertia as MuJoCo's."""
    m = mm.load(mm.DRONE)
    description = load(mm.DRONE)
    tree = build_tree(description)
    assert not description.fixed_base and description.base == "drone"
    assert tree.link_names == ["drone"] and tree.dofs == 0 and tree.actuators == []
    for array in (tree.armature, tree.passive_damping, tree.stiffness, tree.springref, tree.actuator_gravcomp):
        assert array.shape == (0,)
    assert tree.actuator_force_range.shape == (0, 2)
    assert tree.link_mass[0] == m.body_mass[1]
    np.testing.assert_array_equal(tree.link_com[0], m.body_ipos[1])


def test_scenes_of_several_trees():
    """Several free bodies, or a free body beside jointed world children (GRAVCOMP's balloon next to its arm),
    make a scene: the world is the fixed base and each free body hangs from it by a free joint starting at the
    body's pose (MuJoCo's qpos0); a free body beside bodies welded to the world is a floating base, the welded
    bodies dropped as static scenery and listed in the warning; a ball joint is a joint of its own. Reference:
    the fixtures' XML (their bodies, joints and poses)."""
    two = mm.DRONE.replace("</worldbody>", '<body name="drone2" pos="2 0 1"><freejoint name="r2"/><geom size="0.1"/></body></worldbody>')
    scene = load(two)
    assert scene.fixed_base and scene.base == "world"
    assert {(j.name, j.type, j.parent, j.child) for j in scene.joints} == {("drone_root", "free", "world", "drone"), ("r2", "free", "world", "drone2")}
    np.testing.assert_allclose([j.initial_position for j in scene.joints if j.name == "r2"][0], [2.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0])
    arm_and_balloon = load(mm.GRAVCOMP)
    assert arm_and_balloon.base == "world" and {j.type for j in arm_and_balloon.joints} == {"free", "revolute"}
    scenery = mm.FLOATING_HUMANOID.replace(
        "</worldbody>", '<body name="stairs" pos="2 0 0"><geom type="box" size="1 1 0.1"/><body name="step" pos="0 0 0.2"/></body></worldbody>'
    )
    with pytest.warns(NotModelledWarning, match=r"static scenery.*\['stairs', 'step'\]"):
        description = load(scenery)
    assert not description.fixed_base and description.base == "pelvis"
    assert build_tree(description).link_names == build_tree(_load(mm.FLOATING_HUMANOID)).link_names
    ball = load(mm.BALL)
    assert [(j.name, j.type) for j in ball.joints] == [("ball", "ball"), ("ball_hinge", "revolute")]


# ------------------------------------------------------------------------------------ options


def test_options():
    """OPTIONS: gravity (0, 0, -3) (opt.gravity), timestep 0.004, integrator Euler, nothing disabled; FLAGS:
    zero gravity, implicitfast, the disable flags by their XML names; MuJoCo's defaults otherwise ((0, 0, -9.81),
    0.002, Euler). Reference: m.opt (0 tolerance)."""
    description = load(mm.OPTIONS)
    assert (description.gravity.tolist(), description.time_step, description.integrator) == ([0.0, 0.0, -3.0], 0.004, "Euler")
    assert description.disabled == frozenset()
    description = load(FLAGS)
    assert (description.gravity.tolist(), description.time_step, description.integrator) == ([0.0, 0.0, 0.0], 0.01, "implicitfast")
    assert description.disabled == {"gravity", "spring", "eulerdamp", "actuation", "clampctrl"}
    description = load(mm.ARMATURE)
    m = mm.load(mm.ARMATURE)
    assert (description.gravity.tolist(), description.time_step, description.integrator) == (m.opt.gravity.tolist(), m.opt.timestep, "Euler")
    rk4 = mm.OPTIONS.replace('integrator="Euler"', 'integrator="RK4"')
    assert load(rk4).integrator == "RK4"
    assert load(mm.OPTIONS.replace('integrator="Euler"', 'integrator="implicit"')).integrator == "implicit"


@pytest.mark.parametrize("gravity", ["0 0 3", "1 0 -9.81", "0 -0.1 -9.81"])
def test_gravity_in_any_direction_is_the_descriptions(gravity):
    """A gravity with a horizontal or upward component is the description's as written (m.opt.gravity, exact)."""
    xml = mm.OPTIONS.replace('gravity="0 0 -3"', f'gravity="{gravity}"')
    np.testing.assert_array_equal(load(xml).gravity, mm.load(xml).opt.gravity)
    np.testing.assert_array_equal(load(xml).gravity, [float(x) for x in gravity.split()])

