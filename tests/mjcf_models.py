"""MuJoCo reference helpers for the hand-written MJCF fixtures of tests/mjcf_fixtures.py, which this module
re-exports: every fixture constant, `FIXTURES` and `UNSUPPORTED_FEATURES` are importable from here too;
and the checks that tests/test_mjcf_models.py, test_mjcf_actuators.py and test_mjcf_kinematics.py share.

The helpers take an MjModel compiled from any of them, a state (qpos, qvel) and controls and return
MuJoCo's quantities. They never change the model they are given: they work on a copy with the disable
flags they need (`reference_model`). Constraints (contacts, joint limits, equality, frictionloss) are
disabled with mjDSBL_CONSTRAINT wherever they would interfere, so that what is returned is the smooth
(unconstrained) dynamics that warpdyn models. Semantics and source references: docs/mujoco_semantics.md.

Conventions (MuJoCo's): qpos of a free joint is [x y z qw qx qy qz] (world position of the body frame,
unit quaternion of its orientation); its qvel is [world linear velocity of the body origin, angular
velocity in the body frame]; a ball joint has qpos [qw qx qy qz] and qvel the angular velocity in the
child (body) frame. Hinge and slide joints move by qpos - qpos0 (qpos0 = the joint's `ref`).
"""

from __future__ import annotations

import copy
from typing import NamedTuple

import mujoco
import numpy as np

from mjcf_fixtures import *  # noqa: F403  (the fixtures, FIXTURES, UNSUPPORTED_FEATURES)


# --------------------------------------------------------------------------------------------- helpers


def load(xml: str) -> mujoco.MjModel:
    """Compile an MJCF string (mujoco.MjModel.from_xml_string)."""
    return mujoco.MjModel.from_xml_string(xml)


def reference_model(
    m: mujoco.MjModel,
    *,
    constraints: bool = False,
    eulerdamp: bool = True,
    integrator: int | None = None,
    extra_disable: int = 0,
) -> mujoco.MjModel:
    """A copy of `m` with mjOption flags set for a reference computation; `m` is not changed.

    constraints=False sets mjDSBL_CONSTRAINT (no contacts, joint/tendon limits, equality or frictionloss
    rows: mj_fwdConstraint leaves qacc = qacc_smooth). eulerdamp=False sets mjDSBL_EULERDAMP (the Euler
    integrator then treats dof damping explicitly). integrator, if given, replaces m.opt.integrator
    (mjtIntegrator). extra_disable is OR-ed into m.opt.disableflags (mjtDisableBit)."""
    mc = copy.deepcopy(m)
    flags = int(mc.opt.disableflags) | int(extra_disable)
    if not constraints:
        flags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    if not eulerdamp:
        flags |= int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
    mc.opt.disableflags = flags
    if integrator is not None:
        mc.opt.integrator = int(integrator)
    return mc


def make_data(m: mujoco.MjModel, qpos=None, qvel=None, ctrl=None, act=None) -> mujoco.MjData:
    """A fresh MjData with the given state (defaults: qpos0, zero qvel, ctrl and act); nothing computed."""
    d = mujoco.MjData(m)
    if qpos is not None:
        d.qpos[:] = qpos
    if qvel is not None:
        d.qvel[:] = qvel
    if ctrl is not None:
        d.ctrl[:] = ctrl
    if act is not None:
        d.act[:] = act
    return d


def _forward(m, qpos, qvel, ctrl=None, act=None, **flags):
    mc = reference_model(m, **flags)
    d = make_data(mc, qpos, qvel, ctrl, act)
    mujoco.mj_forward(mc, d)
    return mc, d


def full_mass_matrix(m: mujoco.MjModel, d) -> np.ndarray:
    """The dense joint-space inertia matrix M(q) (nv x nv), armature included.

    `d` is an MjData (its qpos is used; it is not modified) or a qpos array. Runs mj_fwdPosition's
    inertia stage (mj_kinematics, mj_comPos, mj_makeM: mj_crb puts dof_armature, plus gear^2 times any
    actuator armature on MuJoCo >= 3.7, on the diagonal; tendon armature adds armature * J_ten' J_ten) and
    densifies the CSR matrix mjData.M with mj_fullM (MuJoCo >= 3.10: mj_fullM(m, d, dst); before:
    mj_fullM(m, dst, d.qM))."""
    qpos = d.qpos if isinstance(d, mujoco.MjData) else d
    dd = make_data(m, qpos)
    mujoco.mj_kinematics(m, dd)
    mujoco.mj_comPos(m, dd)
    mujoco.mj_tendon(m, dd)
    mujoco.mj_makeM(m, dd)
    dst = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, dd, dst)
    except TypeError:  # MuJoCo < 3.10
        mujoco.mj_fullM(m, dst, dd.qM)
    return dst


class Passive(NamedTuple):
    qfrc_passive: np.ndarray  # total, as used in qfrc_smooth
    qfrc_spring: np.ndarray  # -stiffness (q - springref) (hinge/slide), ball/free: -stiffness * subQuat
    qfrc_damper: np.ndarray  # -damping * qvel (per dof)
    qfrc_gravcomp: np.ndarray  # all bodies' gravcomp, including joints that route it to qfrc_actuator


def passive_forces(m: mujoco.MjModel, qpos, qvel) -> Passive:
    """MuJoCo's passive forces (mj_passive, through mj_forward with constraints disabled).

    qfrc_passive = qfrc_spring + qfrc_damper (+ qfrc_fluid, qfrc_adhesion, tendon springs/dampers when
    the model has them) + qfrc_gravcomp on the dofs of joints without actuatorgravcomp. Flags: m's own
    (mjDSBL_SPRING, mjDSBL_DAMPER, mjDSBL_GRAVITY are respected), plus mjDSBL_CONSTRAINT, which passive
    forces do not depend on."""
    _, d = _forward(m, qpos, qvel)
    return Passive(d.qfrc_passive.copy(), d.qfrc_spring.copy(), d.qfrc_damper.copy(), d.qfrc_gravcomp.copy())


class Actuation(NamedTuple):
    qfrc_actuator: np.ndarray  # (nv,) moment' * actuator_force, + actuatorgravcomp, clamped by jnt_actfrcrange
    actuator_force: np.ndarray  # (nu,) gain * ctrl(clamped) + bias, clamped to forcerange when forcelimited
    actuator_length: np.ndarray  # (nu,) gear * qpos (joint transmission on hinge/slide)
    actuator_velocity: np.ndarray  # (nu,) gear * qvel
    actuator_moment: np.ndarray  # (nu, nv) dense; gear in the joint's dof column


def actuator_forces(m: mujoco.MjModel, qpos, qvel, ctrl, act=None) -> Actuation:
    """MuJoCo's actuation (mj_transmission, mj_fwdActuation through mj_forward, constraints disabled).

    Uses m's flags (mjDSBL_CLAMPCTRL, mjDSBL_ACTUATION, opt.disableactuator respected). ctrl is d.ctrl
    before clamping; act (na,) is the activation state for actuators with dynamics (default 0)."""
    _, d = _forward(m, qpos, qvel, ctrl, act)
    nout = len(d.actuator_force)  # = nu for the scalar (joint/tendon) actuators of these fixtures
    moment = np.zeros((nout, m.nv))
    for r in range(nout):
        for k in range(d.moment_rowadr[r], d.moment_rowadr[r] + d.moment_rownnz[r]):
            moment[r, d.moment_colind[k]] = d.actuator_moment[k]
    return Actuation(
        d.qfrc_actuator.copy(),
        d.actuator_force.copy(),
        d.actuator_length.copy(),
        d.actuator_velocity.copy(),
        moment,
    )


def bias_forces(m: mujoco.MjModel, qpos, qvel) -> np.ndarray:
    """qfrc_bias = C(q, qdot) qdot + g(q) (mj_rne with zero acceleration, in mj_fwdVelocity), honouring
    m.opt.gravity and mjDSBL_GRAVITY; gravcomp is not in it (it is in qfrc_passive/qfrc_actuator)."""
    _, d = _forward(m, qpos, qvel)
    return d.qfrc_bias.copy()


def forward_acceleration(
    m: mujoco.MjModel, qpos, qvel, ctrl=None, act=None, qfrc_applied=None, xfrc_applied=None
) -> np.ndarray:
    """qacc from mj_forward with mjDSBL_CONSTRAINT: qacc = qacc_smooth = M^-1 qfrc_smooth, where
    qfrc_smooth = qfrc_passive - qfrc_bias + qfrc_applied + qfrc_actuator + J' xfrc_applied
    (mj_fwdAcceleration). M includes armature. Other flags are m's."""
    mc = reference_model(m)
    d = make_data(mc, qpos, qvel, ctrl, act)
    if qfrc_applied is not None:
        d.qfrc_applied[:] = qfrc_applied
    if xfrc_applied is not None:
        d.xfrc_applied[:] = xfrc_applied
    mujoco.mj_forward(mc, d)
    return d.qacc.copy()


class Step(NamedTuple):
    qpos: np.ndarray
    qvel: np.ndarray
    act: np.ndarray


def euler_step(
    m: mujoco.MjModel, qpos, qvel, ctrl=None, act=None, *, eulerdamp: bool = True, xfrc_applied=None
) -> Step:
    """One mj_step with the Euler integrator (m.opt.timestep h), constraints disabled.

    mj_Euler: if eulerdamp and any dof has damping (dof_damping, polynomial damping or actuator damping),
    qacc_e = (M + h diag(damping))^-1 qfrc_smooth, else qacc_e = qacc; then (mj_advance)
    qvel' = qvel + h qacc_e, qpos' = mj_integratePos(qpos, qvel', h) (semi-implicit: the new velocity;
    quaternions: q * exp(h w'/2) in the body frame, free-joint position: += h v'), act' from act_dot.
    Only joint damping is implicit: actuator kv/biasprm[2] terms stay explicit under Euler."""
    mc = reference_model(m, eulerdamp=eulerdamp, integrator=mujoco.mjtIntegrator.mjINT_EULER)
    d = make_data(mc, qpos, qvel, ctrl, act)
    if xfrc_applied is not None:
        d.xfrc_applied[:] = xfrc_applied
    mujoco.mj_step(mc, d)
    return Step(d.qpos.copy(), d.qvel.copy(), d.act.copy())


def body_poses(m: mujoco.MjModel, qpos) -> tuple[np.ndarray, np.ndarray]:
    """(xpos (nbody, 3), xquat (nbody, 4) wxyz) of every body frame from mj_kinematics; body 0 is the world."""
    d = make_data(m, qpos)
    mujoco.mj_kinematics(m, d)
    return d.xpos.copy(), d.xquat.copy()


def random_state(m: mujoco.MjModel, rng: np.random.Generator, vel_scale: float = 1.0):
    """A valid random (qpos, qvel).

    Hinge/slide: uniform in the joint range when limited (m.jnt_limited), else hinge in [-pi, pi] and
    slide in [-0.3, 0.3] around qpos0. Ball: a uniformly random unit quaternion (wxyz). Free: qpos0's
    position + U(-0.5, 0.5)^3 and a random unit quaternion. qvel ~ N(0, vel_scale^2) for every dof."""
    qpos = np.array(m.qpos0, dtype=float)
    for j in range(m.njnt):
        a = m.jnt_qposadr[j]
        t = m.jnt_type[j]
        if t == mujoco.mjtJoint.mjJNT_FREE:
            qpos[a : a + 3] = m.qpos0[a : a + 3] + rng.uniform(-0.5, 0.5, 3)
            qpos[a + 3 : a + 7] = _random_quat(rng)
        elif t == mujoco.mjtJoint.mjJNT_BALL:
            qpos[a : a + 4] = _random_quat(rng)
        elif m.jnt_limited[j]:
            lo, hi = m.jnt_range[j]
            qpos[a] = rng.uniform(lo, hi)
        elif t == mujoco.mjtJoint.mjJNT_HINGE:
            qpos[a] = rng.uniform(-np.pi, np.pi)
        else:
            qpos[a] = m.qpos0[a] + rng.uniform(-0.3, 0.3)
    qvel = rng.normal(0.0, vel_scale, m.nv)
    return qpos, qvel


def random_ctrl(m: mujoco.MjModel, rng: np.random.Generator, overshoot: float = 1.5) -> np.ndarray:
    """Random controls that also fall outside ctrlrange: uniform over the range widened by `overshoot`
    about its centre when the actuator is ctrllimited, N(0, 1) otherwise."""
    ctrl = rng.normal(0.0, 1.0, m.nu)
    for i in range(m.nu):
        if m.actuator_ctrllimited[i]:
            lo, hi = m.actuator_ctrlrange[i]
            c, r = 0.5 * (lo + hi), 0.5 * (hi - lo) * overshoot
            ctrl[i] = rng.uniform(c - r, c + r)
    return ctrl


def _random_quat(rng: np.random.Generator) -> np.ndarray:
    q = rng.normal(size=4)
    return q / np.linalg.norm(q)


# ------------------------------------- checks shared by tests/test_mjcf_models.py, _actuators.py, _kinematics.py

TOL = 1e-10
SEEDS = range(5)


def close(actual, expected, tol=TOL):
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
    np.testing.assert_allclose(actual, expected, rtol=0, atol=tol * scale)


def by_name(m, objtype, name):
    i = mujoco.mj_name2id(m, objtype, name)
    assert i >= 0, name
    return i
