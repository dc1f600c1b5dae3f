"""warpdyn against MuJoCo on any MJCF file: M, h, the passive and actuator forces and the accelerations, at
MuJoCo's qpos0 and at random states. benchmarks/menagerie.py runs it over MuJoCo Menagerie and
tests/test_menagerie_fixtures.py over the fixtures derived from it; both import it from here, so the state
mapping lives in one place.

MuJoCo's coordinates to warpdyn's: `mujoco_to_warpdyn_state` is the only code that knows both. A warpdyn
model has a base, floating (MuJoCo's lone free joint) or fixed (a scene of several trees: the world), then its
joints, matched to MuJoCo's by name (an unnamed MuJoCo joint j is warpdyn's "joint{j}") and of the same kind:
hinge and slide positions are MuJoCo's qpos (warpdyn folds `ref` into the joint's origin); a ball joint's
quaternion and angular velocity (child axes) and a scene's free joint's position, quaternion, world linear
velocity and body angular velocity are MuJoCo's own numbers (`wd.joint.position_slice`, `velocity_slice`).
warpdyn's generalized velocity is Mixed: the base's [W_pdot_B; W_omega_WB], then the joints; MuJoCo's free
joint has the world linear velocity of the body origin and the angular velocity in the body frame. So qvel =
T nu with T = blockdiag(I, R^T) on the base and a permutation on the joints, and (T is invertible;
d(R^T w)/dt = R^T dw/dt):
    M = T^T M_mj T,    f = T^T f_mj (any generalized force),    nu_dot = T^-1 qacc.
For a fixed base only warpdyn's joint coordinates are compared (its base block is not a degree of freedom).

MuJoCo's side: one mj_forward with ctrl = 0 (and act = 0) on a copy of the model with mjDSBL_CONSTRAINT set
and no other flag changed: warpdyn has no constraint solver (contacts, joint and tendon limits, equality
constraints, frictionloss are all constraint rows), and with them disabled MuJoCo's qacc is qacc_smooth =
M^-1 (qfrc_passive + qfrc_actuator - qfrc_bias). Everything else MuJoCo computes stays in, so that a feature
warpdyn does not model (tendons, fluid forces, activation dynamics...) shows up as an error. warpdyn's side:
free_floating_mass_matrix (armature included), free_floating_bias_forces (C nu + g, as MuJoCo's qfrc_bias:
neither holds passive forces), free_floating_passive_forces + actuator_forces (ctrl = 0) against
qfrc_passive + qfrc_actuator (their sum, since warpdyn counts actuatorgravcomp as passive and MuJoCo as an
actuator's), and forward_dynamics_aba with those forces (the base's passive wrench applied to the base link,
whose Mixed Jacobian is [1 0]).

Errors are relative, max |warpdyn - MuJoCo| / scale, the largest over the states, with the scale of each
quantity the largest entry of MuJoCo's but never below what the quantity is made of, since an entry that
is zero or a cancellation leaves only rounding to compare (a planar base's h at rest, an arm held by position
servos at qpos0, whose qacc is 1e-16): for h and the forces, max |M| |g| (the weight of the heaviest body the
mass matrix holds); for qacc, the largest entry of M^-1 f and of M^-1 h (the terms it is the difference of).
"""

from __future__ import annotations

import dataclasses
import time
import warnings

import mujoco
import numpy as np

import mjcf_models
import warpdyn as wd

QUANTITIES = ("M", "h", "forces", "qacc")
MATCHED = ("M", "h", "qacc")
"""What must be within tolerance for a model to match MuJoCo (issue 35); forces and start are diagnostics."""


@dataclasses.dataclass
class WarpdynState:
    """A MuJoCo state as warpdyn sees it.

    data_kwargs: keyword arguments of wd.data.Data.build (Mixed base velocity). T: (nv, k), qvel = T nu[keep],
    with nu warpdyn's generalized velocity and keep the indices of its 6 + n coordinates that MuJoCo has."""

    data_kwargs: dict
    T: np.ndarray
    keep: np.ndarray

    def mass_matrix(self, M_mj: np.ndarray) -> np.ndarray:
        """MuJoCo's M in warpdyn's coordinates: T^T M T."""
        return self.T.T @ M_mj @ self.T

    def forces(self, f_mj: np.ndarray) -> np.ndarray:
        """A MuJoCo generalized force in warpdyn's coordinates: T^T f."""
        return self.T.T @ f_mj

    def accelerations(self, qacc: np.ndarray) -> np.ndarray:
        """MuJoCo's qacc as warpdyn's nu_dot[keep]: T^-1 qacc."""
        return np.linalg.solve(self.T, qacc)


def _mujoco_id(mj: mujoco.MjModel, obj, name: str, prefix: str) -> int:
    """MuJoCo's id of warpdyn's joint or body `name` (warpdyn names an unnamed one "{prefix}{id}")."""
    i = mujoco.mj_name2id(mj, obj, name)
    if i < 0 and name.startswith(prefix) and name[len(prefix) :].isdigit():
        i = int(name[len(prefix) :])
        i = i if mujoco.mj_id2name(mj, obj, i) is None else -1
    if i < 0:
        raise KeyError(f"warpdyn's '{name}' is not in MuJoCo's model")
    return i


def _rotation(q_wxyz) -> np.ndarray:
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(q_wxyz, dtype=np.float64) / np.linalg.norm(q_wxyz))
    return R.reshape(3, 3)


def mujoco_to_warpdyn_state(model, mj: mujoco.MjModel, qpos, qvel) -> WarpdynState:
    """warpdyn's state for MuJoCo's (qpos, qvel), and the basis change between their generalized coordinates
    (the module docstring says how). Every MuJoCo dof must be one of warpdyn's: a KeyError or ValueError
    names the one that is not."""
    joint_names = model.joint_names()
    n = model.dofs()
    joints = [_mujoco_id(mj, mujoco.mjtObj.mjOBJ_JOINT, name, "joint") for name in joint_names]
    Joint = mujoco.mjtJoint
    kinds = {Joint.mjJNT_HINGE.value: 1, Joint.mjJNT_SLIDE.value: 2, Joint.mjJNT_BALL.value: 3, Joint.mjJNT_FREE.value: 4}
    for name, j, kind in zip(joint_names, joints, model.tree.joint_type[1:]):
        if kinds.get(int(mj.jnt_type[j])) != int(kind):
            raise ValueError(f"warpdyn's joint '{name}' (kind {int(kind)}) is not of the kind of MuJoCo's (mjtJoint {int(mj.jnt_type[j])})")
    positions, velocities = np.zeros(model.number_of_joint_coordinates()), np.zeros(n)
    dof_adr = np.zeros(n, dtype=int)  # MuJoCo's dof of each of warpdyn's
    for k, j in enumerate(joints):
        q, v = wd.joint.position_slice(model, joint_index=k), wd.joint.velocity_slice(model, joint_index=k)
        a, d = int(mj.jnt_qposadr[j]), int(mj.jnt_dofadr[j])
        positions[q] = np.asarray(qpos)[a : a + q.stop - q.start]
        velocities[v] = np.asarray(qvel)[d : d + v.stop - v.start]
        dof_adr[v] = np.arange(d, d + v.stop - v.start)
    kwargs = dict(joint_positions=positions, joint_velocities=velocities)
    columns = list(dof_adr)
    if model.floating_base():
        body = _mujoco_id(mj, mujoco.mjtObj.mjOBJ_BODY, model.base_link(), "body")
        free = int(mj.body_jntadr[body])
        if mj.body_jntnum[body] != 1 or int(mj.jnt_type[free]) != mujoco.mjtJoint.mjJNT_FREE.value:
            raise ValueError(f"warpdyn's floating base '{model.base_link()}' has no free joint in MuJoCo")
        a, v = int(mj.jnt_qposadr[free]), int(mj.jnt_dofadr[free])
        R = _rotation(qpos[a + 3 : a + 7])
        kwargs.update(
            base_position=np.asarray(qpos[a : a + 3]),
            base_quaternion=np.asarray(qpos[a + 3 : a + 7]) / np.linalg.norm(qpos[a + 3 : a + 7]),
            base_linear_velocity=np.asarray(qvel[v : v + 3]),
            base_angular_velocity=R @ qvel[v + 3 : v + 6],
        )
        keep = np.arange(6 + n)
        T = np.zeros((mj.nv, 6 + n))
        T[v : v + 3, 0:3] = np.eye(3)
        T[v + 3 : v + 6, 3:6] = R.T
        columns = list(range(v, v + 6)) + columns
        offset = 6
    else:
        keep = 6 + np.arange(n)
        T = np.zeros((mj.nv, n))
        offset = 0
    for k, dof in enumerate(dof_adr):
        T[dof, offset + k] = 1.0
    if sorted(columns) != list(range(mj.nv)):
        missing = sorted(set(range(mj.nv)) - set(columns))
        raise ValueError(f"MuJoCo's dofs {missing} (joints {sorted({int(mj.dof_jntid[d]) for d in missing})}) are not warpdyn's")
    return WarpdynState(kwargs, T, keep)


def reference(mj: mujoco.MjModel) -> mujoco.MjModel:
    """A copy of `mj` with mjDSBL_CONSTRAINT set, the only flag changed (the module docstring says why)."""
    return mjcf_models.reference_model(mj)


def mujoco_quantities(ref: mujoco.MjModel, qpos, qvel) -> dict:
    """MuJoCo's M, qfrc_bias, qfrc_passive + qfrc_actuator and qacc at (qpos, qvel), ctrl = 0, act = 0."""
    d = mjcf_models.make_data(ref, qpos, qvel)
    mujoco.mj_forward(ref, d)
    M = np.zeros((ref.nv, ref.nv))
    mujoco.mj_fullM(ref, d, M)
    return {"M": M, "h": d.qfrc_bias.copy(), "forces": d.qfrc_passive + d.qfrc_actuator, "qacc": d.qacc.copy()}


def warpdyn_quantities(model, data) -> dict:
    """warpdyn's M, h, passive + actuator forces (ctrl = 0) and ABA's accelerations under those forces, all
    (6 + n) in the data's (Mixed) representation."""
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    h = wd.model.free_floating_bias_forces(model, data).numpy()
    passive = wd.model.free_floating_passive_forces(model, data).numpy()
    tau = wd.model.actuator_forces(model, data).numpy()
    forces = passive + np.concatenate([np.zeros(6), tau])
    link_forces = np.zeros((model.number_of_links(), 6))
    if model.floating_base():
        link_forces[0] = passive[:6]
    base, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=forces[6:], link_forces=link_forces)
    qacc = np.concatenate([base.numpy(), joints.numpy()])
    return {"M": M, "h": h, "forces": forces, "qacc": qacc}


def relative_error(actual, expected, floor: float = 0.0) -> float:
    """max |actual - expected| / max(max |expected|, floor) (1 where both are 0)."""
    actual, expected = np.asarray(actual, np.float64), np.asarray(expected, np.float64)
    scale = max(float(np.abs(expected).max(initial=0.0)), floor) or 1.0
    return float(np.abs(actual - expected).max(initial=0.0)) / scale


def floors(expected: dict, gravity) -> dict:
    """The scale below which each quantity's error is not measured (the module docstring says why), from
    MuJoCo's quantities in warpdyn's coordinates."""
    M = expected["M"]
    weight = float(np.abs(M).max(initial=0.0)) * float(np.linalg.norm(gravity))
    terms = [np.linalg.solve(M, expected[name]) for name in ("forces", "h")] if M.size else []
    return {"M": 0.0, "h": weight, "forces": weight, "qacc": max((float(np.abs(t).max()) for t in terms), default=0.0)}


def states(mj: mujoco.MjModel, random_states: int, seed: int):
    """MuJoCo's qpos0 at rest, then `random_states` random states (mjcf_models.random_state: hinge and slide
    positions within their limits, random quaternions, velocities N(0, 1)), seeded."""
    yield np.array(mj.qpos0), np.zeros(mj.nv)
    rng = np.random.default_rng(seed)
    for _ in range(random_states):
        yield mjcf_models.random_state(mj, rng)


def start_error(model, mj: mujoco.MjModel) -> float:
    """How far warpdyn's default state (wd.data.Data.build(model)) is from MuJoCo's qpos0: the largest
    difference of base position, base quaternion (either sign) and joint positions."""
    expected = mujoco_to_warpdyn_state(model, mj, mj.qpos0, np.zeros(mj.nv)).data_kwargs
    data = wd.data.Data.build(model)
    error = float(np.abs(data.joint_positions.numpy() - expected["joint_positions"]).max(initial=0.0))
    if model.floating_base():
        error = max(error, float(np.abs(data.base_position.numpy() - expected["base_position"]).max()))
        q, q0 = data.base_quaternion.numpy(), expected["base_quaternion"]
        error = max(error, float(min(np.abs(q - q0).max(), np.abs(q + q0).max())))
    return error


def compare_model(model, mj: mujoco.MjModel, random_states: int = 3, seed: int = 0) -> dict:
    """The largest relative error of each of QUANTITIES over MuJoCo's qpos0 and `random_states` random states,
    and "start": start_error (absolute)."""
    ref = reference(mj)
    errors = dict.fromkeys(QUANTITIES, 0.0)
    for qpos, qvel in states(mj, random_states, seed):
        state = mujoco_to_warpdyn_state(model, mj, qpos, qvel)
        data = wd.data.Data.build(model, **state.data_kwargs)
        ours = warpdyn_quantities(model, data)
        theirs = mujoco_quantities(ref, qpos, qvel)
        keep = state.keep
        expected = {
            "M": state.mass_matrix(theirs["M"]),
            "h": state.forces(theirs["h"]),
            "forces": state.forces(theirs["forces"]),
            "qacc": state.accelerations(theirs["qacc"]),
        }
        actual = {"M": ours["M"][np.ix_(keep, keep)], "h": ours["h"][keep], "forces": ours["forces"][keep], "qacc": ours["qacc"][keep]}
        floor = floors(expected, mj.opt.gravity)
        for name in QUANTITIES:
            errors[name] = max(errors[name], relative_error(actual[name], expected[name], floor[name]))
    errors["start"] = start_error(model, mj)
    if model.tree.equalities:
        errors["constrained"] = constrained_step_error(model, mj, random_states, seed)
    return errors


def constrained_step_error(model, mj: mujoco.MjModel, random_states: int = 3, seed: int = 0) -> float:
    """For a model with equality constraints: the largest relative error of one Euler step's velocity change
    (dt times the constrained accelerations) against mj_step's with MuJoCo's equality rows active (its contacts,
    limits and frictionloss disabled, its Euler damping explicit; warpdyn's copy of the model without contact
    points and static friction, its damping explicit), over compare_model's states; below dt times the qacc floor
    of `floors` (rounding of gravity's and the forces' accelerations) the error is not measured."""
    disable = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_LIMIT) | int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)
    ref = mjcf_models.reference_model(mj, constraints=True, eulerdamp=False, integrator=mujoco.mjtIntegrator.mjINT_EULER, extra_disable=disable)
    model = model.copy()
    model.implicit_damping = False
    model.set_joint_parameters(friction_static=np.zeros(model.dofs()))
    points = len(model.kin_dyn_parameters.contact_parameters.body)
    if points:
        model = wd.contact.with_collidable_points(model, enabled=[False] * points)
    error = 0.0
    for qpos, qvel in states(mj, random_states, seed):
        d = mjcf_models.make_data(ref, qpos, qvel)
        mujoco.mj_step(ref, d)
        state = mujoco_to_warpdyn_state(model, mj, qpos, qvel)
        theirs = mujoco_quantities(reference(mj), qpos, qvel)
        expected = {"M": state.mass_matrix(theirs["M"]), "h": state.forces(theirs["h"]), "forces": state.forces(theirs["forces"])}
        floor = float(mj.opt.timestep) * floors(expected, mj.opt.gravity)["qacc"]
        before = state.data_kwargs
        after = mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **before))
        names = ("joint_velocities",) + (("base_linear_velocity", "base_angular_velocity") if model.floating_base() else ())
        ours = {"joint_velocities": stepped.joint_velocities.numpy()}
        if model.floating_base():
            v = stepped.base_velocity.numpy()
            ours.update(base_linear_velocity=v[:3], base_angular_velocity=v[3:])
        change = np.concatenate([after[name] - before[name] for name in names])
        actual = np.concatenate([ours[name] - before[name] for name in names])
        error = max(error, relative_error(actual, change, floor))
    return error


@dataclasses.dataclass
class Comparison:
    """What compare_file found: MuJoCo's nq, nv, nu; `refused`, the first line of warpdyn's error at load (None
    when it loaded); the warnings warpdyn gave at load (category and first line); warpdyn's dofs; `mapping`,
    why MuJoCo's state has no warpdyn equivalent (a dof warpdyn does not have), `failed`, warpdyn's error while
    evaluating; the errors (compare_model's, empty unless all went through) and the wall time [s]."""

    path: str
    nq: int
    nv: int
    nu: int
    refused: str | None = None
    mapping: str | None = None
    failed: str | None = None
    warnings: list[str] = dataclasses.field(default_factory=list)
    dofs: int | None = None
    errors: dict = dataclasses.field(default_factory=dict)
    seconds: float = 0.0

    def matches(self, tol: float) -> bool:
        return bool(self.errors) and all(self.errors[name] <= tol for name in MATCHED)


def first_line(error: BaseException) -> str:
    text = str(error).strip()
    return f"{type(error).__name__}: {text.splitlines()[0] if text else ''}"


def compare_file(path, dtype=np.float64, random_states: int = 3, seed: int = 0) -> Comparison:
    """Load `path` with MuJoCo (which must compile it) and with warpdyn (in `dtype`; NotModelledWarning and
    every other warning recorded, not raised) and compare them (compare_model)."""
    start = time.perf_counter()
    mj = mujoco.MjModel.from_xml_path(str(path))
    result = Comparison(str(path), mj.nq, mj.nv, mj.nu)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            model = wd.model.Model.build_from_model_description(str(path), dtype=dtype)
    except Exception as error:  # a refusal: reported, not raised
        result.refused = first_line(error)
    else:
        result.warnings = [f"{w.category.__name__}: {str(w.message).splitlines()[0]}" for w in caught]
        result.dofs = model.dofs()
        try:
            mujoco_to_warpdyn_state(model, mj, mj.qpos0, np.zeros(mj.nv))
        except (KeyError, ValueError) as error:  # a dof warpdyn does not have: the mapping says which
            result.mapping = first_line(error)
        else:
            try:
                result.errors = compare_model(model, mj, random_states, seed)
            except Exception as error:  # reported with the entry point, so that one model does not stop a survey
                result.failed = first_line(error)
    result.seconds = time.perf_counter() - start
    return result
