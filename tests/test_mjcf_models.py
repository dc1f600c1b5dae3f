"""The MJCF fixtures (tests/mjcf_fixtures.py) and reference helpers of tests/mjcf_models.py, checked against
MuJoCo identities: the fixtures themselves, armature and the mass matrix, springs and dampers, gravity
compensation. Actuators: tests/test_mjcf_actuators.py; kinematics, options and dynamics:
tests/test_mjcf_kinematics.py (both follow the rules below).

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
from mjcf_models import SEEDS, by_name, close


# ------------------------------------------------------------------------------- independent math


def quat_to_rotvec(q):
    """Axis * angle with angle in [0, pi] (the shorter rotation; q and -q are the same rotation)."""
    q = np.asarray(q, float) / np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    s = np.linalg.norm(q[1:])
    return np.zeros(3) if s == 0 else q[1:] / s * 2 * np.arctan2(s, q[0])


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


