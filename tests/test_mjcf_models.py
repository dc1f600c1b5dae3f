"""The MJCF fixtures and reference helpers of tests/mjcf_models.py, checked against MuJoCo identities.

Every expected value here is computed by hand: from the numbers written in the XML (copied below, not
read back from the compiled model) and independent NumPy formulas (quaternions, geometric Jacobians,
Newton-Euler). MuJoCo supplies only what the identity is about and, where a test says so, intermediate
kinematic quantities (xanchor, xaxis, xipos, ximat) that other tests check on their own.

Tolerances: everything is float64 on O(1)-O(100) numbers through at most a few dozen operations or one
small dense solve, so agreement is at 1e-12 relative; tests use 1e-10 relative to the size of the
reference (at least 1), which leaves room for other BLAS/platforms while a wrong formula, sign, frame
or unit (degrees, gear, springref) gives errors of 1e-3 or more. Exceptions are stated in the test.
"""

from __future__ import annotations

import mjcf_models as mm
import mujoco
import numpy as np
import pytest

TOL = 1e-10
SEEDS = range(5)


def close(actual, expected, tol=TOL):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tol * scale)


# ------------------------------------------------------------------------------- independent math


def quat_mul(a, b):
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


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


def quat_to_rotvec(q):
    """Axis * angle with angle in [0, pi] (the shorter rotation; q and -q are the same rotation)."""
    q = np.asarray(q, float) / np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    s = np.linalg.norm(q[1:])
    return np.zeros(3) if s == 0 else q[1:] / s * 2 * np.arctan2(s, q[0])


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


def dof_columns(m, d, body, point):
    """Geometric Jacobian (3 x nv linear, 3 x nv angular) of a point fixed to `body`, built by hand from
    each ancestor joint's world anchor/axis (MuJoCo's xanchor, xaxis, xmat): hinge: [a x (p - anchor); a],
    slide: [a; 0], ball: columns xmat[:, k] as hinges through the anchor, free: [I 0] then ball-like
    columns about the body origin (rotational qvel is in the body frame)."""
    Jv, Jw = np.zeros((3, m.nv)), np.zeros((3, m.nv))
    b = body
    while b > 0:
        for j in range(m.body_jntadr[b], m.body_jntadr[b] + m.body_jntnum[b]):
            t, v = m.jnt_type[j], m.jnt_dofadr[j]
            anchor, axis, R = d.xanchor[j], d.xaxis[j], d.xmat[b].reshape(3, 3)
            if t == mujoco.mjtJoint.mjJNT_HINGE:
                Jv[:, v], Jw[:, v] = np.cross(axis, point - anchor), axis
            elif t == mujoco.mjtJoint.mjJNT_SLIDE:
                Jv[:, v] = axis
            elif t == mujoco.mjtJoint.mjJNT_BALL:
                for k in range(3):
                    Jv[:, v + k], Jw[:, v + k] = np.cross(R[:, k], point - anchor), R[:, k]
            else:
                Jv[:, v : v + 3] = np.eye(3)
                for k in range(3):
                    Jv[:, v + 3 + k] = np.cross(R[:, k], point - d.xpos[b])
                    Jw[:, v + 3 + k] = R[:, k]
        b = m.body_parentid[b]
    return Jv, Jw


def mass_matrix_by_hand(m, d):
    """M = sum_b m_b Jv_b' Jv_b + Jw_b' (R_b I_b R_b') Jw_b at each body's CoM, + diag(dof_armature)."""
    M = np.diag(np.array(m.dof_armature, float))
    for b in range(1, m.nbody):
        Jv, Jw = dof_columns(m, d, b, d.xipos[b])
        R = d.ximat[b].reshape(3, 3)
        M += m.body_mass[b] * Jv.T @ Jv + Jw.T @ (R @ np.diag(m.body_inertia[b]) @ R.T) @ Jw
    return M


def integrate_by_hand(m, qpos, qvel, h):
    """qpos advanced by h with velocity qvel, joint by joint (hinge/slide: q + h v; ball: q * exp(h w/2)
    with w in the body frame; free: position + h v (world), quaternion as ball)."""
    q = np.array(qpos, float)
    for j in range(m.njnt):
        a, v, t = m.jnt_qposadr[j], m.jnt_dofadr[j], m.jnt_type[j]
        if t == mujoco.mjtJoint.mjJNT_FREE:
            q[a : a + 3] += h * qvel[v : v + 3]
            quat = q[a + 3 : a + 7] / np.linalg.norm(q[a + 3 : a + 7])
            q[a + 3 : a + 7] = quat_mul(quat, quat_exp(qvel[v + 3 : v + 6], h))
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            quat = q[a : a + 4] / np.linalg.norm(q[a : a + 4])
            q[a : a + 4] = quat_mul(quat, quat_exp(qvel[v : v + 3], h))
        else:
            q[a] += h * qvel[v]
    return q


def same_rotation(qa, qb, tol=TOL):
    """Quaternions equal up to sign."""
    qa, qb = np.asarray(qa, float), np.asarray(qb, float)
    close(qa * np.sign(np.dot(qa, qb)), qb, tol)


def by_name(m, objtype, name):
    i = mujoco.mj_name2id(m, objtype, name)
    assert i >= 0, name
    return i


# --------------------------------------------------------------------------------------- fixtures


SIZES = {  # name: (nq, nv, nu, na, nbody), counted by hand from the XML
    "ARMATURE": (3, 3, 0, 0, 4),
    "DAMPING": (3, 3, 0, 0, 4),
    "SPRINGS": (3, 3, 0, 0, 4),
    "SPRINGS_DEGREE": (2, 2, 0, 0, 3),
    "MOTOR": (3, 3, 4, 0, 4),
    "POSITION": (3, 3, 3, 0, 4),
    "VELOCITY": (2, 2, 2, 0, 3),
    "GENERAL": (2, 2, 2, 0, 3),
    "GRAVCOMP": (3 + 7, 3 + 6, 1, 0, 5),
    "MULTI_JOINT": (8, 8, 0, 0, 4),
    "WORLD_CHILDREN": (4, 4, 0, 0, 9),
    "OPTIONS": (1, 1, 0, 0, 2),
    "DRONE": (7, 6, 0, 0, 2),
    "FLOATING_HUMANOID": (7 + 2 + 2 * 3 + 2 * 5, 6 + 2 + 2 * 3 + 2 * 5, 18, 0, 14),
    "BALL": (5, 4, 0, 0, 3),
    "JOINT_ACTUATORFRCRANGE": (1, 1, 2, 0, 2),
    "ACTUATOR_ARMATURE_DAMPING": (1, 1, 1, 0, 2),
    "UNSUPPORTED": (3, 3, 3, 2, 4),
}


@pytest.mark.parametrize("name", sorted(mm.FIXTURES))
def test_fixture_compiles_with_expected_sizes_and_no_contacts(name):
    """Every fixture compiles (MuJoCo's compiler checks inertias: positive, triangle inequality), has the
    sizes counted by hand, has a positive-definite M at random states, and never makes a contact with
    constraints left on (its geoms have contype = conaffinity = 0). Exact integer checks."""
    assert set(SIZES) == set(mm.FIXTURES)
    m = mm.load(mm.FIXTURES[name])
    assert (m.nq, m.nv, m.nu, m.na, m.nbody) == SIZES[name]
    rng = np.random.default_rng(0)
    for _ in range(3):
        qpos, qvel = mm.random_state(m, rng)
        assert np.linalg.eigvalsh(mm.full_mass_matrix(m, qpos)).min() > 0
        d = mm.make_data(m, qpos, qvel)
        mujoco.mj_forward(m, d)
        assert d.ncon == 0


def test_random_state_is_valid():
    """random_state: unit quaternions for free and ball joints, limited hinge/slide inside their range
    (SPRINGS_DEGREE: +-45 degrees = +-pi/4 rad, slide +-0.5), unlimited slides around qpos0. 1e-12: one
    normalisation."""
    rng = np.random.default_rng(1)
    for name in ("FLOATING_HUMANOID", "BALL", "GRAVCOMP", "DRONE"):
        m = mm.load(mm.FIXTURES[name])
        for _ in range(10):
            qpos, qvel = mm.random_state(m, rng)
            assert qvel.shape == (m.nv,)
            for j in range(m.njnt):
                a = m.jnt_qposadr[j] + (3 if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_FREE else 0)
                if m.jnt_type[j] in (mujoco.mjtJoint.mjJNT_FREE, mujoco.mjtJoint.mjJNT_BALL):
                    assert abs(np.linalg.norm(qpos[a : a + 4]) - 1) < 1e-12
    m = mm.load(mm.SPRINGS_DEGREE)
    for _ in range(50):
        qpos, _ = mm.random_state(m, rng)
        assert -np.pi / 4 <= qpos[0] <= np.pi / 4 and -0.5 <= qpos[1] <= 0.5


def test_full_mass_matrix_matches_mj_forward():
    """full_mass_matrix (mj_makeM stage only) equals mj_fullM after a whole mj_forward: the helper runs
    every stage M depends on. Same arithmetic: 1e-12 absolute."""
    rng = np.random.default_rng(2)
    for name in ("FLOATING_HUMANOID", "BALL", "MULTI_JOINT", "UNSUPPORTED"):
        m = mm.load(mm.FIXTURES[name])
        qpos, qvel = mm.random_state(m, rng)
        d = mm.make_data(m, qpos, qvel)
        mujoco.mj_forward(m, d)
        dense = np.zeros((m.nv, m.nv))
        try:
            mujoco.mj_fullM(m, d, dense)
        except TypeError:
            mujoco.mj_fullM(m, dense, d.qM)
        np.testing.assert_allclose(mm.full_mass_matrix(m, d), dense, rtol=0, atol=1e-12)


# --------------------------------------------------------------------------------------- armature


def test_armature_values_follow_defaults():
    """dof_armature from the XML: j1 0.05 (top <default>), j2 0.2 (class geared), j3 0.1 (explicit over
    the class); the humanoid's freejoint ignores <default> (0 on its 6 dofs), its waist/arms 0.02, legs
    0.05 (childclass leg), ankles 0.01; the ball joint's 0.01 on all 3 of its dofs. Exact."""
    np.testing.assert_array_equal(mm.load(mm.ARMATURE).dof_armature, [0.05, 0.2, 0.1])
    expected = [0] * 6 + [0.02] * 8 + ([0.05] * 4 + [0.01]) * 2
    np.testing.assert_array_equal(mm.load(mm.FLOATING_HUMANOID).dof_armature, expected)
    np.testing.assert_array_equal(mm.load(mm.BALL).dof_armature, [0.01, 0.01, 0.01, 0])


def _without_armature(xml):
    spec = mujoco.MjSpec.from_string(xml)
    for joint in spec.joints:
        joint.armature = 0
    return spec.compile()


@pytest.mark.parametrize("name", ["ARMATURE", "FLOATING_HUMANOID", "BALL", "MULTI_JOINT"])
def test_armature_adds_to_the_mass_matrix_diagonal(name):
    """M(q) with armature = M(q) of the same model compiled with every joint's armature set to 0, plus
    diag(dof_armature) (mj_crb initialises M(i,i) with the armature). Same arithmetic: 1e-10."""
    m = mm.load(mm.FIXTURES[name])
    m0 = _without_armature(mm.FIXTURES[name])
    assert not m0.dof_armature.any()
    rng = np.random.default_rng(3)
    for _ in SEEDS:
        qpos, _ = mm.random_state(m, rng)
        close(mm.full_mass_matrix(m, qpos), mm.full_mass_matrix(m0, qpos) + np.diag(m.dof_armature))


@pytest.mark.parametrize("name", ["ARMATURE", "MULTI_JOINT", "WORLD_CHILDREN", "SPRINGS", "MOTOR"])
def test_mass_matrix_by_hand(name):
    """M(q) = sum over bodies of m Jv'Jv + Jw' R I R' Jw at the CoM (hand geometric Jacobians from the
    joints' world anchors and axes) + diag(armature); welded bodies (WORLD_CHILDREN's tool) count with
    their parent's Jacobian. Hinge/slide models. 1e-10."""
    m = mm.load(mm.FIXTURES[name])
    rng = np.random.default_rng(4)
    for _ in SEEDS:
        qpos, _ = mm.random_state(m, rng)
        d = mm.make_data(m, qpos)
        mujoco.mj_kinematics(m, d)
        close(mm.full_mass_matrix(m, qpos), mass_matrix_by_hand(m, d))


# ------------------------------------------------------------------------------ springs, dampers


def test_springs_by_hand():
    """SPRINGS: qfrc_spring = -k (q - springref) with the XML's k = (5, 50, 1.5), springref = (0.3, -0.05,
    0); qfrc_damper = -(0.2, 0, 0) qvel; qfrc_passive = their sum (no gravcomp). `ref` (0.1, 0.02) moves
    qpos0 only, not the spring's rest point. 1e-10."""
    m = mm.load(mm.SPRINGS)
    np.testing.assert_array_equal(m.qpos0, [0.1, 0.02, 0])
    np.testing.assert_array_equal(m.qpos_spring, [0.3, -0.05, 0])
    rng = np.random.default_rng(5)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        p = mm.passive_forces(m, q, v)
        spring = -np.array([5, 50, 1.5]) * (q - np.array([0.3, -0.05, 0]))
        damper = -np.array([0.2, 0, 0]) * v
        close(p.qfrc_spring, spring)
        close(p.qfrc_damper, damper)
        close(p.qfrc_passive, spring + damper)


def test_springs_degree_units():
    """SPRINGS_DEGREE (default compiler angle="degree"): a hinge's ref, springref and range are converted
    to radians (10, 30, +-45 deg), a slide's are not (0.1, 0.2, +-0.5 m). qfrc_spring = -k (q - springref)
    in radians. 1e-12 (one multiplication by pi/180)."""
    m = mm.load(mm.SPRINGS_DEGREE)
    close(m.qpos0, [np.deg2rad(10), 0.1], 1e-12)
    close(m.qpos_spring, [np.deg2rad(30), 0.2], 1e-12)
    close(m.jnt_range, [[-np.pi / 4, np.pi / 4], [-0.5, 0.5]], 1e-12)
    q, v = np.array([0.2, -0.1]), np.array([0.3, 0.4])
    close(mm.passive_forces(m, q, v).qfrc_spring, [-2 * (0.2 - np.pi / 6), -20 * (-0.1 - 0.2)])


def test_damping_by_hand_and_defaults():
    """DAMPING: dof_damping = (2.0 explicit, 0.3 from <default>, 0 explicit override); qfrc_passive =
    -damping * qvel exactly (no springs, no gravcomp). 1e-10."""
    m = mm.load(mm.DAMPING)
    np.testing.assert_array_equal(m.dof_damping, [2.0, 0.3, 0.0])
    rng = np.random.default_rng(6)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        close(mm.passive_forces(m, q, v).qfrc_passive, -np.array([2.0, 0.3, 0.0]) * v)


def test_ball_joint_spring_and_damper_by_hand():
    """BALL: the ball's spring torque is -k * rotvec(q) with rotvec the axis-angle of its quaternion
    relative to qpos_spring = identity (mju_subQuat; k = 0.5), in the child frame like its qvel; its damper
    is -0.2 * qvel on each of its 3 dofs; the hinge's is -0.1 qvel. 1e-10."""
    m = mm.load(mm.BALL)
    np.testing.assert_array_equal(m.qpos_spring[:4], [1, 0, 0, 0])
    rng = np.random.default_rng(7)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        p = mm.passive_forces(m, q, v)
        close(p.qfrc_spring, np.concatenate([-0.5 * quat_to_rotvec(q[:4]), [0]]))
        close(p.qfrc_damper, -np.array([0.2, 0.2, 0.2, 0.1]) * v)


def test_frictionloss_is_a_constraint_not_a_passive_force():
    """UNSUPPORTED's u_j1 frictionloss=0.1: qfrc_passive is identical to that of the same model with
    frictionloss 0 (it is not a passive force), and with constraints on MuJoCo instantiates a
    mjCNSTR_FRICTION_DOF row for it (mj_instantiateFriction) that the frictionless model has not. Exact."""
    m = mm.load(mm.UNSUPPORTED)
    spec = mujoco.MjSpec.from_string(mm.UNSUPPORTED)
    for joint in spec.joints:
        joint.frictionloss = 0
    m0 = spec.compile()
    assert m.dof_frictionloss[0] == 0.1 and not m0.dof_frictionloss.any()
    rng = np.random.default_rng(8)
    q, v = mm.random_state(m, rng)
    np.testing.assert_array_equal(mm.passive_forces(m, q, v).qfrc_passive, mm.passive_forces(m0, q, v).qfrc_passive)
    rows = []
    for model in (m, m0):
        d = mm.make_data(model, q, v)
        mujoco.mj_forward(model, d)
        rows.append(int(np.sum(d.efc_type == mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF)))
    assert rows == [1, 0]


def test_spring_and_damper_flags():
    """mjDSBL_SPRING removes qfrc_spring only, mjDSBL_DAMPER qfrc_damper only; both together remove every
    passive force, gravcomp included (GRAVCOMP: qfrc_gravcomp becomes 0 too). Exact (terms are dropped)."""
    m = mm.load(mm.SPRINGS)
    q, v = np.array([0.5, 0.1, -0.3]), np.array([1.0, -2.0, 0.5])
    full = mm.passive_forces(m, q, v)
    D = mujoco.mjtDisableBit
    nosp = mm.passive_forces(mm.reference_model(m, extra_disable=D.mjDSBL_SPRING), q, v)
    noda = mm.passive_forces(mm.reference_model(m, extra_disable=D.mjDSBL_DAMPER), q, v)
    np.testing.assert_array_equal(nosp.qfrc_passive, full.qfrc_damper)
    np.testing.assert_array_equal(noda.qfrc_passive, full.qfrc_spring)
    g = mm.load(mm.GRAVCOMP)
    qg, vg = mm.random_state(g, np.random.default_rng(9))
    assert np.abs(mm.passive_forces(g, qg, vg).qfrc_gravcomp).max() > 0.1
    both = mm.passive_forces(mm.reference_model(g, extra_disable=D.mjDSBL_SPRING | D.mjDSBL_DAMPER), qg, vg)
    assert not both.qfrc_passive.any() and not both.qfrc_gravcomp.any()


# -------------------------------------------------------------------------------------- actuators


def test_actuator_shortcut_parameters():
    """The parser's shortcut expansion (mjs_setToMotor/Position/Velocity): motor gain [1,0,0] bias none;
    position gain [kp,0,0] bias [0,-kp,-kv] (kv default 0); velocity gain [kv,0,0] bias [0,0,-kv];
    general keeps gainprm/biasprm as written (missing entries 0). Dyntype none (0) everywhere. Exact."""
    FIXED, AFFINE = mujoco.mjtGain.mjGAIN_FIXED, mujoco.mjtGain.mjGAIN_AFFINE
    NONE_B, AFFINE_B = mujoco.mjtBias.mjBIAS_NONE, mujoco.mjtBias.mjBIAS_AFFINE
    cases = {
        "MOTOR": ([[1, 0, 0]] * 4, [[0, 0, 0]] * 4, [FIXED] * 4, [NONE_B] * 4),
        "POSITION": ([[100, 0, 0], [500, 0, 0], [30, 0, 0]], [[0, -100, -5], [0, -500, 0], [0, -30, -2]],
                     [FIXED] * 3, [AFFINE_B] * 3),
        "VELOCITY": ([[20, 0, 0], [4, 0, 0]], [[0, 0, -20], [0, 0, -4]], [FIXED] * 2, [AFFINE_B] * 2),
        "GENERAL": ([[2, 0.5, -0.1], [3, 0, 0]], [[0.3, -4, -0.7], [0, 0, 0]], [AFFINE, FIXED], [AFFINE_B, NONE_B]),
    }
    for name, (gain, bias, gtype, btype) in cases.items():
        m = mm.load(mm.FIXTURES[name])
        np.testing.assert_array_equal(m.actuator_gainprm[:, :3], gain)
        np.testing.assert_array_equal(m.actuator_biasprm[:, :3], bias)
        assert not m.actuator_gainprm[:, 3:].any() and not m.actuator_biasprm[:, 3:].any()
        np.testing.assert_array_equal(m.actuator_gaintype, gtype)
        np.testing.assert_array_equal(m.actuator_biastype, btype)
        assert not m.actuator_dyntype.any()


def test_actuator_limits_resolution():
    """ctrllimited/forcelimited as resolved by the compiler: explicit true/false win; "auto" (the default,
    with compiler autolimits="true", the default) means limited iff the range is given. Exact."""
    expected = {
        "MOTOR": ([1, 1, 0, 0], [0, 0, 0, 0]),
        "POSITION": ([1, 1, 0], [1, 0, 1]),
        "VELOCITY": ([1, 0], [0, 1]),
        "GENERAL": ([1, 0], [1, 0]),
    }
    for name, (ctrl, force) in expected.items():
        m = mm.load(mm.FIXTURES[name])
        np.testing.assert_array_equal(m.actuator_ctrllimited, ctrl, err_msg=name)
        np.testing.assert_array_equal(m.actuator_forcelimited, force, err_msg=name)


def _actuation_cases(name):
    """States and controls from small (every force inside its forcerange, controls inside ctrlrange) to
    large (controls far outside ctrlrange, forces clamped); the test checks that both sides of every clamp
    were exercised."""
    m = mm.load(mm.FIXTURES[name])
    rng = np.random.default_rng(sum(map(ord, name)))
    for scale in (0.01, 0.03, 0.1, 0.3, 1.0, 3.0) * 2:
        q, v = mm.random_state(m, rng)
        q, v = scale * q, scale * v
        u = mm.random_ctrl(m, rng, overshoot=1.5 * max(1.0, scale)) * (min(1, scale))
        yield m, q, v, u, mm.actuator_forces(m, q, v, u)


def _both_sides(values, lo, hi):
    """True when `values` has entries strictly inside (lo, hi) and entries outside."""
    values = np.asarray(values)
    inside = (values > lo) & (values < hi)
    return inside.any() and not inside.all()


def test_motor_by_hand():
    """MOTOR: force = ctrl clamped to ctrlrange when ctrllimited (mot1 [-1,1] explicit, mot2 [-3,2] via
    autolimits; mot3 ctrllimited=false and mot1b unranged: not clamped); length = gear q, velocity = gear
    qdot; qfrc_actuator = sum over actuators of gear * force (mot1 and mot1b add on m1). 1e-10."""
    us = []
    for m, q, v, u, a in _actuation_cases("MOTOR"):
        force = np.array([np.clip(u[0], -1, 1), np.clip(u[1], -3, 2), u[2], u[3]])
        gear = np.array([50, -2.5, 10, 5])
        close(a.actuator_force, force)
        close(a.actuator_length, gear * q[[0, 1, 2, 0]])
        close(a.actuator_velocity, gear * v[[0, 1, 2, 0]])
        close(a.qfrc_actuator, [50 * force[0] + 5 * force[3], -2.5 * force[1], 10 * force[2]])
        close(a.actuator_moment, [[50, 0, 0], [0, -2.5, 0], [0, 0, 10], [5, 0, 0]])
        us.append(u)
    us = np.array(us)
    assert _both_sides(us[:, 0], -1, 1) and _both_sides(us[:, 1], -3, 2) and _both_sides(us[:, 2], -1, 1)


def test_position_by_hand():
    """POSITION: force = kp u - kp L - kv V with u the clamped ctrl, L = gear q, V = gear qdot, then
    clamped to forcerange when forcelimited; qfrc = gear * force. pos1: kp 100, kv 5, gear 2, u in [-1,1],
    force in [-20,20]; pos2: kp 500, kv 0, u in [-0.2,0.2]; pos3: kp 30, kv 2, u free, force in [-4,4]. 1e-10."""
    rows = []
    for m, q, v, u, a in _actuation_cases("POSITION"):
        u1 = np.clip(u[0], -1, 1)
        raw1 = 100 * u1 - 100 * 2 * q[0] - 5 * 2 * v[0]
        raw3 = 30 * u[2] - 30 * q[2] - 2 * v[2]
        f1, f3 = np.clip(raw1, -20, 20), np.clip(raw3, -4, 4)
        f2 = 500 * np.clip(u[1], -0.2, 0.2) - 500 * q[1]
        close(a.actuator_force, [f1, f2, f3])
        close(a.qfrc_actuator, [2 * f1, f2, f3])
        rows.append([u[0], u[1], raw1, raw3])
    rows = np.array(rows)
    assert _both_sides(rows[:, 0], -1, 1) and _both_sides(rows[:, 1], -0.2, 0.2)
    assert _both_sides(rows[:, 2], -20, 20) and _both_sides(rows[:, 3], -4, 4)


def test_velocity_by_hand():
    """VELOCITY: force = kv u - kv V, V = gear qdot. vel1: kv 20, gear 3, u in [-2,2]; vel2: kv 4, force in
    [-1,1]. qfrc = gear * force. 1e-10."""
    rows = []
    for m, q, v, u, a in _actuation_cases("VELOCITY"):
        f1 = 20 * np.clip(u[0], -2, 2) - 20 * 3 * v[0]
        raw2 = 4 * u[1] - 4 * v[1]
        f2 = np.clip(raw2, -1, 1)
        close(a.actuator_force, [f1, f2])
        close(a.qfrc_actuator, [3 * f1, f2])
        rows.append([u[0], raw2])
    rows = np.array(rows)
    assert _both_sides(rows[:, 0], -2, 2) and _both_sides(rows[:, 1], -1, 1)


def test_general_by_hand():
    """GENERAL: gen_affine: gain = 2 + 0.5 L - 0.1 V, bias = 0.3 - 4 L - 0.7 V, L = 1.5 q, V = 1.5 qdot,
    force = clip(gain * clip(u, -1, 1) + bias, -6, 6), qfrc = 1.5 force; gen_fixed: force = 3 u (gear 1,
    no bias, no limits). 1e-10."""
    rows = []
    for m, q, v, u, a in _actuation_cases("GENERAL"):
        L, V = 1.5 * q[0], 1.5 * v[0]
        raw1 = (2 + 0.5 * L - 0.1 * V) * np.clip(u[0], -1, 1) + 0.3 - 4 * L - 0.7 * V
        f1 = np.clip(raw1, -6, 6)
        f2 = 3 * u[1]
        close(a.actuator_force, [f1, f2])
        close(a.qfrc_actuator, [1.5 * f1, f2])
        rows.append([u[0], raw1])
    rows = np.array(rows)
    assert _both_sides(rows[:, 0], -1, 1) and _both_sides(rows[:, 1], -6, 6)


def test_humanoid_actuator_defaults_and_forces():
    """FLOATING_HUMANOID: actuator defaults resolve as written (the main-class <motor ctrlrange> applies to
    every actuator of that class, class "leg" <position> gives kp 200 kv 10 ctrlrange [-1.5,1.5]
    forcerange [-150,150], attributes on the element override), and qfrc_actuator is the sum of
    gear * force in each actuated dof, zero on the free joint. 1e-10."""
    m = mm.load(mm.FLOATING_HUMANOID)
    names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, i) for i in range(m.nu)]
    kp = {"hip_x": 200, "hip_z": 100, "hip_y": 200, "knee": 200}
    kv = {"hip_x": 10, "hip_z": 5, "hip_y": 10, "knee": 10}
    for i, n in enumerate(names):
        key = n[:-2]
        if key in kp:
            np.testing.assert_array_equal(m.actuator_biasprm[i, :3], [0, -kp[key], -kv[key]])
            np.testing.assert_array_equal(m.actuator_forcerange[i], [-150, 150])
            assert m.actuator_forcelimited[i]
            np.testing.assert_array_equal(m.actuator_ctrlrange[i], [-0.1, 2.5] if key == "knee" else [-1.5, 1.5])
        elif key == "ankle":
            np.testing.assert_array_equal(m.actuator_biasprm[i, :3], [0, 0, -8])
            np.testing.assert_array_equal(m.actuator_ctrlrange[i], [-3, 3])
        else:
            np.testing.assert_array_equal(m.actuator_ctrlrange[i], [-0.5, 0.5] if key == "elbow" else [-1, 1])
            assert not m.actuator_forcelimited[i]
    rng = np.random.default_rng(10)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        u = mm.random_ctrl(m, rng)
        a = mm.actuator_forces(m, q, v, u)
        expected = np.zeros(m.nv)
        for i in range(m.nu):
            j = m.actuator_trnid[i, 0]
            qa, da, g = m.jnt_qposadr[j], m.jnt_dofadr[j], m.actuator_gear[i, 0]
            lo, hi = m.actuator_ctrlrange[i]
            uc = np.clip(u[i], lo, hi)
            bias = m.actuator_biasprm[i]
            f = m.actuator_gainprm[i, 0] * uc + bias[1] * g * q[qa] + bias[2] * g * v[da]
            if m.actuator_forcelimited[i]:
                f = np.clip(f, *m.actuator_forcerange[i])
            expected[da] += g * f
        close(a.qfrc_actuator, expected)
        assert not a.qfrc_actuator[:6].any()


def test_clampctrl_and_actuation_flags():
    """mjDSBL_CLAMPCTRL: ctrl is used unclamped (mot1 with ctrl 3 gives 3, not 1) while forcerange
    clamping stays (POSITION pos1 still within +-20); mjDSBL_ACTUATION: qfrc_actuator and actuator_force 0.
    Exact/1e-10."""
    D = mujoco.mjtDisableBit
    m = mm.load(mm.MOTOR)
    q, v, u = np.zeros(3), np.zeros(3), np.array([3.0, 5.0, 0, 0])
    unclamped = mm.reference_model(m, extra_disable=D.mjDSBL_CLAMPCTRL)
    close(mm.actuator_forces(unclamped, q, v, u).actuator_force, [3, 5, 0, 0])
    close(mm.actuator_forces(m, q, v, u).actuator_force, [1, 2, 0, 0])
    a = mm.actuator_forces(mm.reference_model(m, extra_disable=D.mjDSBL_ACTUATION), q, v, u)
    assert not a.qfrc_actuator.any() and not a.actuator_force.any()
    p = mm.load(mm.POSITION)
    p = mm.reference_model(p, extra_disable=D.mjDSBL_CLAMPCTRL)
    f = mm.actuator_forces(p, np.zeros(3), np.zeros(3), [5.0, 0, 0])
    close(f.actuator_force[0], 20)


def test_joint_actuatorfrcrange_clamps_the_joint_total():
    """JOINT_ACTUATORFRCRANGE: actuator_force is per actuator (2 u1 and u2 are not clamped by the joint),
    but qfrc_actuator on a1 = clip(2 * u1 + 1 * u2, -3, 3) (jnt_actfrcrange, applied last in
    mj_fwdActuation). 1e-10."""
    m = mm.load(mm.JOINT_ACTUATORFRCRANGE)
    assert m.jnt_actfrclimited[0]
    for u in ([1, 1], [1, -0.5], [-1, -1], [0.3, 0.2]):
        a = mm.actuator_forces(m, [0.2], [0.1], u)
        close(a.actuator_force, u)
        close(a.qfrc_actuator, [np.clip(2 * u[0] + u[1], -3, 3)])


def test_actuator_armature_and_damping_reflect_through_gear_squared():
    """MuJoCo >= 3.7: ACTUATOR_ARMATURE_DAMPING's motor (gear 30, armature 0.001, damping 0.002) adds
    30^2 * 0.001 = 0.9 to M's diagonal and 30^2 * 0.002 = 1.8 to the joint's damping (qfrc_damper), on top
    of the joint's own 0.01 and 0.1; dof_armature/dof_damping keep the joint's own values. 1e-10."""
    m = mm.load(mm.ACTUATOR_ARMATURE_DAMPING)
    assert m.dof_armature[0] == 0.01 and m.dof_damping[0] == 0.1
    q, v = np.array([0.4]), np.array([-1.3])
    spec = mujoco.MjSpec.from_string(mm.ACTUATOR_ARMATURE_DAMPING)
    for act in spec.actuators:
        act.armature = 0
    m0 = spec.compile()
    close(mm.full_mass_matrix(m, q), mm.full_mass_matrix(m0, q) + 0.9)
    close(mm.passive_forces(m, q, v).qfrc_damper, [-(0.1 + 1.8) * v[0]])


def test_filtered_position_uses_activation():
    """UNSUPPORTED's <position kp=20 timeconst=0.05>: dyntype filterexact, dynprm[0] = 0.05, one act
    state; force = kp * act - kp * q (act, not ctrl), and one Euler step gives act' = act + (ctrl - act)
    (1 - exp(-h/0.05)) (mj_nextActivation). 1e-10."""
    m = mm.load(mm.UNSUPPORTED)
    i = by_name(m, mujoco.mjtObj.mjOBJ_ACTUATOR, "filtered")
    assert m.actuator_dyntype[i] == mujoco.mjtDyn.mjDYN_FILTEREXACT and m.actuator_dynprm[i, 0] == 0.05
    adr = m.actuator_actadr[i]
    q, v = np.array([0.1, -0.2, 0.3]), np.zeros(3)
    ctrl, act = np.zeros(m.nu), np.zeros(m.na)
    ctrl[i], act[adr] = 0.8, 0.25
    a = mm.actuator_forces(m, q, v, ctrl, act)
    close(a.actuator_force[i], 20 * 0.25 - 20 * 0.3)
    h = m.opt.timestep
    step = mm.euler_step(m, q, v, ctrl, act)
    close(step.act[adr], 0.25 + (0.8 - 0.25) * (1 - np.exp(-h / 0.05)))


# --------------------------------------------------------------------------------------- gravcomp


def _gravcomp_by_hand(m, d, gravity, gravcomp):
    qfrc = np.zeros(m.nv)
    for b, g in gravcomp.items():
        Jv, _ = dof_columns(m, d, b, d.xipos[b])
        qfrc += Jv.T @ (-g * m.body_mass[b] * np.asarray(gravity))
    return qfrc


def test_gravcomp_by_hand():
    """GRAVCOMP: qfrc_gravcomp = sum_b J_com,b' (-gravcomp_b * mass_b * gravity) (mj_gravcomp: a force at
    the body CoM, xipos), gravcomp 1 (gl1, balloon), 0.5 (gl2), 0 (gl3), masses 1.0, 0.8, 0.3 from the XML;
    qfrc_passive carries it on every dof except gj2's (actuatorgravcomp), where qfrc_actuator carries it
    (plus the motor, gear 2, on gj1). Jacobians by hand from the joints' anchors/axes. 1e-10."""
    m = mm.load(mm.GRAVCOMP)
    body = {n: by_name(m, mujoco.mjtObj.mjOBJ_BODY, n) for n in ("gl1", "gl2", "gl3", "balloon")}
    np.testing.assert_array_equal(m.body_mass[[body["gl1"], body["gl2"], body["balloon"]]], [1.0, 0.8, 0.3])
    np.testing.assert_array_equal(m.jnt_actgravcomp, [0, 1, 0, 0])
    rng = np.random.default_rng(11)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        u = rng.normal(size=1)
        d = mm.make_data(m, q)
        mujoco.mj_kinematics(m, d)
        expected = _gravcomp_by_hand(m, d, [0, 0, -9.81], {body["gl1"]: 1, body["gl2"]: 0.5, body["balloon"]: 1})
        p = mm.passive_forces(m, q, v)
        a = mm.actuator_forces(m, q, v, u)
        close(p.qfrc_gravcomp, expected)
        passive = expected.copy()
        passive[1] = 0
        close(p.qfrc_passive, passive)
        close(a.qfrc_actuator, [2 * u[0], expected[1]] + [0] * 7)


def test_gravcomp_balloon_floats():
    """GRAVCOMP's free "balloon" (gravcomp 1, CoM off the body origin) at rest: its gravcomp force at the
    CoM cancels gravity at the CoM, so its qacc is 0 at any orientation (the arm's is not, gl3 is not
    compensated). 1e-10 on accelerations of O(10)."""
    m = mm.load(mm.GRAVCOMP)
    rng = np.random.default_rng(12)
    for _ in SEEDS:
        q, _ = mm.random_state(m, rng)
        qacc = mm.forward_acceleration(m, q, np.zeros(m.nv), np.zeros(m.nu))
        close(qacc[3:], np.zeros(6), 1e-10 * 10)
        assert np.abs(qacc[:3]).max() > 1e-3


def test_actuatorgravcomp_without_actuators_is_lost():
    """A MuJoCo quirk a reimplementation must decide on: with actuatorgravcomp on a joint and no actuator
    in the model (nu = 0), mj_fwdActuation returns early, so that joint's gravcomp is in neither
    qfrc_passive nor qfrc_actuator (qfrc_gravcomp still has it). Exact."""
    xml = mm.GRAVCOMP.replace(mm.GRAVCOMP[mm.GRAVCOMP.index("<actuator>") : mm.GRAVCOMP.index("</actuator>") + 11], "")
    m = mm.load(xml)
    assert m.nu == 0
    q, v = mm.random_state(m, np.random.default_rng(13))
    p = mm.passive_forces(m, q, v)
    assert abs(p.qfrc_gravcomp[1]) > 1e-3 and p.qfrc_passive[1] == 0
    assert not mm.actuator_forces(m, q, v, np.zeros(0)).qfrc_actuator.any()


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


def test_free_and_ball_velocity_conventions():
    """DRONE's free joint: qvel[0:3] is the world linear velocity of the body origin, qvel[3:6] the
    angular velocity in the body frame (world = xmat @ qvel[3:6]); BALL's qvel[0:3] is the angular
    velocity in the child frame (world = xmat @ qvel[0:3]). Checked with mj_objectVelocity (mjOBJ_XBODY,
    world orientation: [angular, linear at xpos]). 1e-10."""
    m = mm.load(mm.DRONE)
    rng = np.random.default_rng(17)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        d = mm.make_data(m, q, v)
        mujoco.mj_forward(m, d)
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, 1, vel, 0)
        R = d.xmat[1].reshape(3, 3)
        close(vel[:3], R @ v[3:6])
        close(vel[3:], v[:3])
        close(d.xpos[1], q[:3])
        same_rotation(d.xquat[1], q[3:7] / np.linalg.norm(q[3:7]))
    m = mm.load(mm.BALL)
    for _ in SEEDS:
        q, v = mm.random_state(m, rng)
        d = mm.make_data(m, q, v)
        mujoco.mj_forward(m, d)
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, 1, vel, 0)
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


def test_unsupported_fixture_contents():
    """UNSUPPORTED really carries what UNSUPPORTED_FEATURES lists: density/viscosity > 0 (and fluid forces
    in qfrc_passive when moving), an equality, a fixed tendon with stiffness, a muscle, an activation state,
    a tendon transmission, joint limits, frictionloss. Exact."""
    m = mm.load(mm.UNSUPPORTED)
    assert m.opt.density == 1.2 and m.opt.viscosity == 1.8e-5
    assert m.neq == 1 and m.ntendon == 1 and m.tendon_stiffness[0] == 3
    assert mujoco.mjtDyn.mjDYN_MUSCLE in m.actuator_dyntype and mujoco.mjtGain.mjGAIN_MUSCLE in m.actuator_gaintype
    assert m.na == 2
    assert mujoco.mjtTrn.mjTRN_TENDON in m.actuator_trntype
    assert m.jnt_limited[:2].all() and m.dof_frictionloss[0] == 0.1
    q, v = np.zeros(3), np.array([3.0, -2.0, 1.0])
    _, d = mm._forward(m, q, v)
    assert np.abs(d.qfrc_fluid).max() > 0
    assert set(mm.UNSUPPORTED_FEATURES) == {"fluid", "joint_limits", "frictionloss", "equality", "tendon", "muscle",
                                            "activation", "tendon_transmission"}
