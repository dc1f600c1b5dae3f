"""Actuators of the MJCF fixtures (tests/mjcf_fixtures.py) as MuJoCo computes them, by hand: the parser's
shortcuts (motor, position, velocity, general), ctrl/force limits and their resolution, the clampctrl and
actuation flags, a joint's actuatorfrcrange, actuator armature and damping, activation dynamics.

Expected values and tolerances follow tests/test_mjcf_models.py: the XML's numbers and NumPy formulas,
1e-10 relative to the size of the reference (at least 1), exceptions stated in the test.
"""

from __future__ import annotations

import mjcf_models as mm
import mujoco
import numpy as np
from mjcf_models import SEEDS, by_name, close


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


