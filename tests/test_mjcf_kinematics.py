"""Kinematics, options and dynamics of the MJCF fixtures (tests/mjcf_fixtures.py) in MuJoCo, by hand: body
poses of multi-joint bodies and of several world children, `ref`, the free and ball joints' velocity
conventions, `<option>`, one Euler or implicitfast step, Newton-Euler for a free body.

Expected values and tolerances follow tests/test_mjcf_models.py: the XML's numbers and independent NumPy
formulas (quaternions, transforms and integration below, robots.qmul), 1e-10 relative to the size of the
reference (at least 1), exceptions stated in the test.
"""

from __future__ import annotations

import mjcf_models as mm
import mujoco
import numpy as np
import pytest
from mjcf_models import SEEDS, TOL, by_name, close
from robots import qmul


# ------------------------------------------------------------------------------- independent math


def quat_axis_angle(axis, angle):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def quat_exp(w, h):
    """Quaternion of the rotation by the vector w*h (axis w/|w|, angle |w|h)."""
    n = np.linalg.norm(w)
    return np.array([1.0, 0, 0, 0]) if n == 0 else quat_axis_angle(w, n * h)


def quat_to_mat(q):
    q = np.asarray(q, float) / np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


def transform(pos=(0, 0, 0), rot=None):
    T = np.eye(4)
    T[:3, :3] = np.eye(3) if rot is None else rot
    T[:3, 3] = pos
    return T


def hinge(axis, pos, angle):
    """Rotation by `angle` about `axis` through the point `pos` (frame coordinates): Tr(p) R Tr(-p)."""
    R = quat_to_mat(quat_axis_angle(axis, angle))
    return transform(pos) @ transform(rot=R) @ transform(-np.asarray(pos, float))


def slide(axis, dist):
    axis = np.asarray(axis, float) / np.linalg.norm(axis)
    return transform(axis * dist)


def integrate_by_hand(m, qpos, qvel, h):
    """qpos advanced by h with velocity qvel, joint by joint (hinge/slide: q + h v; ball: q * exp(h w/2)
    with w in the body frame; free: position + h v (world), quaternion as ball)."""
    q = np.array(qpos, float)
    for j in range(m.njnt):
        a, v, t = m.jnt_qposadr[j], m.jnt_dofadr[j], m.jnt_type[j]
        if t == mujoco.mjtJoint.mjJNT_FREE:
            q[a : a + 3] += h * qvel[v : v + 3]
            quat = q[a + 3 : a + 7] / np.linalg.norm(q[a + 3 : a + 7])
            q[a + 3 : a + 7] = qmul(quat, quat_exp(qvel[v + 3 : v + 6], h))
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            quat = q[a : a + 4] / np.linalg.norm(q[a : a + 4])
            q[a : a + 4] = qmul(quat, quat_exp(qvel[v : v + 3], h))
        else:
            q[a] += h * qvel[v]
    return q


def same_rotation(qa, qb, tol=TOL):
    """Quaternions equal up to sign."""
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    close(qa * np.sign(np.dot(qa, qb)), qb, tol)


# -------------------------------------------------------------------------------------- kinematics


def _multi_joint_by_hand(q):
    """Body frames of MULTI_JOINT composed by hand from the XML numbers: parent * Tr(pos) Rot(quat) * each
    joint in document order (slide: Tr(axis (q - ref)), hinge: rotation by q - ref about its axis through
    its pos, both in the frame left by the previous joints)."""
    quat = lambda *w: quat_to_mat(np.array(w))
    base = transform([0.1, -0.2, 0.3], quat(0.9238795, 0, 0, 0.3826834))
    base = base @ slide([1, 0, 0], q[0]) @ slide([0, 1, 0], q[1] - 0.05) @ hinge([0, 0, 1], [0.05, 0, 0], q[2])
    upper = base @ transform([0, 0.15, 0.1], quat(0.9659258, 0.2588190, 0, 0))
    for axis, angle in (([1, 0, 0], q[3]), ([0, 1, 0], q[4]), ([0, 0, 1], q[5] - 0.2)):
        upper = upper @ hinge(axis, [0, 0, 0.02], angle)
    fore = upper @ transform([0, 0, -0.3])
    fore = fore @ hinge([0, 1, 0], [0, 0, 0], q[6]) @ hinge([1, 1, 0], [0.03, 0, -0.05], q[7])
    return {"base": base, "upper_arm": upper, "forearm": fore}


def test_multi_joint_kinematics_by_hand():
    """MULTI_JOINT: xpos/xmat of every body equal the hand composition (see _multi_joint_by_hand): joints
    of one body compose in order, each about its own pos/axis in the body frame as moved by the joints
    before it; the body's pos/quat come first; ref (base_y 0.05, sh_z 0.2) is subtracted. The XML quats
    have 7 digits (the compiler normalises them): 1e-9. Also: at qpos0 the pose is the XML pose."""
    m = mm.load(mm.MULTI_JOINT)
    np.testing.assert_array_equal(m.qpos0, [0, 0.05, 0, 0, 0, 0.2, 0, 0])
    rng = np.random.default_rng(14)
    for q in [m.qpos0] + [mm.random_state(m, rng)[0] for _ in SEEDS]:
        xpos, xquat = mm.body_poses(m, q)
        for name, T in _multi_joint_by_hand(q).items():
            b = by_name(m, mujoco.mjtObj.mjOBJ_BODY, name)
            close(xpos[b], T[:3, 3], 1e-9)
            close(quat_to_mat(xquat[b]), T[:3, :3], 1e-9)
    xpos, _ = mm.body_poses(m, m.qpos0)
    close(xpos[by_name(m, mujoco.mjtObj.mjOBJ_BODY, "base")], [0.1, -0.2, 0.3])


def test_world_children_kinematics_by_hand():
    """WORLD_CHILDREN: the table and pedestal stay at their XML poses; left_base = table * Tr(0,0.3,0)
    Rz(90 deg) * Rz(l1); left_link = left_base * Tr(0.3,0,0) Ry(l2); the welded left_tool = left_link *
    Tr(0.25,0,0), the massless left_tcp 0.05 further; right_base = Tr(0,-0.3,0.7) Rz(-45 deg) Rz(r1). The
    fixed rotations use the XML's 7-digit quaternions (normalised by the compiler, as by quat_to_mat): 1e-9."""
    m = mm.load(mm.WORLD_CHILDREN)
    rng = np.random.default_rng(15)
    Rz = lambda a: quat_to_mat(quat_axis_angle([0, 0, 1], a))
    Ry = lambda a: quat_to_mat(quat_axis_angle([0, 1, 0], a))
    for _ in SEEDS:
        q, _ = mm.random_state(m, rng)
        xpos, xquat = mm.body_poses(m, q)
        table = transform([0, 0, 0.7])
        left_base = table @ transform([0, 0.3, 0], quat_to_mat([0.7071068, 0, 0, 0.7071068]) @ Rz(q[0]))
        left_link = left_base @ transform([0.3, 0, 0], Ry(q[1]))
        tool = left_link @ transform([0.25, 0, 0])
        tcp = tool @ transform([0.05, 0, 0])
        right_base = transform([0, -0.3, 0.7], quat_to_mat([0.9238795, 0, 0, -0.3826834]) @ Rz(q[2]))
        right_link = right_base @ transform([0.3, 0, 0], Ry(q[3]))
        expected = {"table": table, "left_base": left_base, "left_link": left_link, "left_tool": tool,
                    "left_tcp": tcp, "right_base": right_base, "right_link": right_link,
                    "pedestal": transform([1, 0, 0.2])}
        for name, T in expected.items():
            b = by_name(m, mujoco.mjtObj.mjOBJ_BODY, name)
            close(xpos[b], T[:3, 3], 1e-9)
            close(quat_to_mat(xquat[b]), T[:3, :3], 1e-9)


def test_world_children_mass_matrix_is_block_diagonal():
    """WORLD_CHILDREN: the two arms are separate trees, so M has no coupling between (l1, l2) and (r1, r2)
    (exactly 0: MuJoCo's sparsity), and the welded tool's mass (0.3 at 0.27 m from l2) is in the left
    arm's M (M[l2,l2] >= 0.3 * 0.27^2 + the link's own). Exact / inequality."""
    m = mm.load(mm.WORLD_CHILDREN)
    M = mm.full_mass_matrix(m, mm.random_state(m, np.random.default_rng(16))[0])
    assert not M[:2, 2:].any() and not M[2:, :2].any()
    assert M[1, 1] >= 0.3 * 0.27**2 + 0.8 * 0.125**2 + 0.0045


def test_ref_moves_the_zero_of_the_joint():
    """SPRINGS: qpos0 = ref (0.1, 0.02, 0) is the XML pose (s2 at (0.4, 0, 1)); at q = 0 the hinge has
    turned by -0.1 rad about y and s2's slide by -0.02 m along its x, so s2 is at Ry(-0.1)(0.4 - 0.02, 0, 0)
    + (0, 0, 1). 1e-12."""
    m = mm.load(mm.SPRINGS)
    s2 = by_name(m, mujoco.mjtObj.mjOBJ_BODY, "s2")
    close(mm.body_poses(m, m.qpos0)[0][s2], [0.4, 0, 1], 1e-12)
    R = quat_to_mat(quat_axis_angle([0, 1, 0], -0.1))
    close(mm.body_poses(m, np.zeros(3))[0][s2], R @ [0.4 - 0.02, 0, 0] + np.array([0, 0, 1]), 1e-12)


def _random_xbody_velocity(m, rng):
    """(q, v, d, vel): a random state of `m`, MuJoCo's data at it and body 1's mj_objectVelocity (mjOBJ_XBODY)."""
    q, v = mm.random_state(m, rng)
    d = mm.make_data(m, q, v)
    mujoco.mj_forward(m, d)
    vel = np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, 1, vel, 0)
    return q, v, d, vel


def test_free_and_ball_velocity_conventions():
    """DRONE's free joint: qvel[0:3] is the world linear velocity of the body origin, qvel[3:6] the
    angular velocity in the body frame (world = xmat @ qvel[3:6]); BALL's qvel[0:3] is the angular
    velocity in the child frame (world = xmat @ qvel[0:3]). Checked with mj_objectVelocity (mjOBJ_XBODY,
    world orientation: [angular, linear at xpos]). 1e-10."""
    m = mm.load(mm.DRONE)
    rng = np.random.default_rng(17)
    for _ in SEEDS:
        q, v, d, vel = _random_xbody_velocity(m, rng)
        R = d.xmat[1].reshape(3, 3)
        close(vel[:3], R @ v[3:6])
        close(vel[3:], v[:3])
        close(d.xpos[1], q[:3])
        same_rotation(d.xquat[1], q[3:7] / np.linalg.norm(q[3:7]))
    m = mm.load(mm.BALL)
    for _ in SEEDS:
        q, v, d, vel = _random_xbody_velocity(m, rng)
        close(vel[:3], d.xmat[1].reshape(3, 3) @ v[:3])
        # the ball rotates after the body's own quat, about its anchor
        body = quat_to_mat([0.9659258, 0, 0.2588190, 0])
        close(d.xmat[1].reshape(3, 3), body @ quat_to_mat(q[:4]), 1e-9)


# ------------------------------------------------------------------------------ options, dynamics


def test_options_and_defaults():
    """OPTIONS: gravity (0, 0, -3), timestep 0.004, integrator Euler as written; a model without <option>
    gets MuJoCo's defaults (gravity (0, 0, -9.81), timestep 0.002, Euler, no disable/enable flags). Exact.
    The pendulum's qacc = (torque of gravity about y - 0.1 qdot) / (Iyy + m r^2), by hand. 1e-10."""
    m = mm.load(mm.OPTIONS)
    np.testing.assert_array_equal(m.opt.gravity, [0, 0, -3])
    assert m.opt.timestep == 0.004 and m.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    dflt = mm.load(mm.ARMATURE)
    np.testing.assert_array_equal(dflt.opt.gravity, [0, 0, -9.81])
    assert dflt.opt.timestep == 0.002 and dflt.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER
    assert dflt.opt.disableflags == 0 and dflt.opt.enableflags == 0
    for q, v in ((0.3, 0.0), (-1.2, 2.0)):
        r = quat_to_mat(quat_axis_angle([0, 1, 0], q)) @ [0.3, 0, 0]
        torque = np.cross(r, [0, 0, -3.0])[1]
        expected = (torque - 0.1 * v) / (0.001 + 0.09)
        close(mm.forward_acceleration(m, [q], [v]), [expected])


def _smooth_force(m, q, v, u):
    """qfrc_smooth = qfrc_passive - qfrc_bias + qfrc_actuator, from the (separately tested) helpers."""
    passive = mm.passive_forces(m, q, v).qfrc_passive
    return passive - mm.bias_forces(m, q, v) + mm.actuator_forces(m, q, v, u).qfrc_actuator


@pytest.mark.parametrize("name", ["DAMPING", "OPTIONS", "FLOATING_HUMANOID", "BALL", "SPRINGS", "DRONE"])
def test_euler_step_by_hand(name):
    """One Euler step: qvel' = qvel + h (M + h diag(dof_damping))^-1 qfrc_smooth (implicit joint damping,
    mj_EulerSkip; only dof damping: actuator kv stays in qfrc_smooth, explicit) and, with eulerdamp
    disabled, qvel' = qvel + h M^-1 qfrc_smooth; qpos' = qpos integrated with qvel' (semi-implicit;
    quaternions q * exp(h w'/2), body frame). Dense numpy solve vs MuJoCo's sparse LDL: 1e-10 relative
    on qvel (velocities of O(10))."""
    m = mm.load(mm.FIXTURES[name])
    h = m.opt.timestep
    rng = np.random.default_rng(18)
    for _ in range(3):
        q, v = mm.random_state(m, rng)
        u = mm.random_ctrl(m, rng)
        M = mm.full_mass_matrix(m, q)
        f = _smooth_force(m, q, v, u)
        for eulerdamp, A in ((True, M + h * np.diag(m.dof_damping)), (False, M)):
            step = mm.euler_step(m, q, v, u, eulerdamp=eulerdamp)
            v_next = v + h * np.linalg.solve(A, f)
            close(step.qvel, v_next)
            close(step.qpos, integrate_by_hand(m, q, v_next, h))
        if m.dof_damping.any():  # the implicit treatment is observable
            assert np.abs(mm.euler_step(m, q, v, u).qvel - mm.euler_step(m, q, v, u, eulerdamp=False).qvel).max() > 1e-9


def test_euler_damper_flag_also_disables_implicit_damping():
    """mjDSBL_DAMPER: no damping force and no implicit damping in Euler either (mj_EulerSkip checks both
    flags): qvel' = qvel + h M^-1 (qfrc_smooth without damper). 1e-10."""
    m = mm.reference_model(mm.load(mm.DAMPING), extra_disable=mujoco.mjtDisableBit.mjDSBL_DAMPER)
    q, v = np.array([0.1, 0.5, -0.4]), np.array([1.0, -2.0, 3.0])
    f = _smooth_force(m, q, v, np.zeros(0))
    close(mm.euler_step(m, q, v).qvel, v + m.opt.timestep * np.linalg.solve(mm.full_mass_matrix(m, q), f))


def test_implicitfast_treats_actuator_kv_implicitly():
    """implicitfast (documented contrast with Euler): qvel' = qvel + h (M - h D)^-1 qfrc_smooth with D =
    -diag(dof_damping) + sum_i gear_i^2 dforce_i/dV (= biasprm[2] for position/velocity servos) for every
    actuator whose force is not at its forcerange limit (mjd_actuator_vel), RNE derivatives dropped.
    POSITION has no joint damping, so D comes from kv alone. 1e-10."""
    m = mm.load(mm.POSITION)
    mi = mm.reference_model(m, integrator=mujoco.mjtIntegrator.mjINT_IMPLICITFAST)
    h = m.opt.timestep
    rng = np.random.default_rng(19)
    gear, kv = np.array([2.0, 1.0, 1.0]), np.array([5.0, 0.0, 2.0])
    lo, hi = np.array([-20, -np.inf, -4]), np.array([20, np.inf, 4])
    seen = set()
    for scale in (0.02, 0.05, 0.2, 1.0):  # small states keep the servos inside forcerange, large ones saturate
        q, v = mm.random_state(m, rng)
        q, v = scale * q, scale * v
        u = mm.random_ctrl(m, rng) * scale
        force = mm.actuator_forces(m, q, v, u).actuator_force
        free = (force > lo) & (force < hi)
        seen.update(zip(range(3), free))
        D = np.diag(np.where(free, -(gear**2) * kv, 0.0))
        f = _smooth_force(m, q, v, u)
        d = mm.make_data(mi, q, v, u)
        mujoco.mj_step(mi, d)
        close(d.qvel, v + h * np.linalg.solve(mm.full_mass_matrix(m, q) - h * D, f))
    assert {(0, True), (0, False), (2, True), (2, False)} <= seen  # both branches of pos1 and pos3 exercised


def test_drone_newton_euler_by_hand():
    """DRONE (free body, CoM c = (0.005, -0.003, 0.01) in the body frame, principal axes rotated by
    iquat): with a world force F and torque T applied at the CoM (xfrc_applied), a_com = g + F/m and
    body-frame wdot = I^-1 (R'T - w x I w) (I = Ri diag(0.004, 0.005, 0.008) Ri'); qacc[3:6] = wdot and
    qacc[0:3] = acceleration of the body origin = a_com - wdot_w x r - w_w x (w_w x r), r = R c. Gravity
    -9.81 on mass 0.8. 1e-10 on O(10) accelerations."""
    m = mm.load(mm.DRONE)
    Ri = quat_to_mat([0.9914449, 0, 0, 0.1305262])
    I = Ri @ np.diag([0.004, 0.005, 0.008]) @ Ri.T
    c, mass = np.array([0.005, -0.003, 0.01]), 0.8
    rng = np.random.default_rng(20)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        F, T = rng.normal(size=3) * 5, rng.normal(size=3) * 0.1
        xfrc = np.zeros((m.nbody, 6))
        xfrc[1] = np.concatenate([F, T])
        qacc = mm.forward_acceleration(m, q, v, xfrc_applied=xfrc)
        R = quat_to_mat(q[3:7])
        w = v[3:6]
        wdot = np.linalg.solve(I, R.T @ T - np.cross(w, I @ w))
        r, w_w, wdot_w = R @ c, R @ w, R @ wdot
        a_origin = np.array([0, 0, -9.81]) + F / mass - np.cross(wdot_w, r) - np.cross(w_w, np.cross(w_w, r))
        close(qacc[3:], wdot, 1e-10 * 10)
        close(qacc[:3], a_origin, 1e-10 * 10)

