"""JaxSim's `jaxsim.api.model`: the model and the functions of the whole model.

Link order: breadth-first from the base, siblings by name, as JaxSim (parent index < child index). Joint i
moves link i + 1. Frames: sorted by name, as JaxSim.
Frame indices follow the link indices: frame k has index number_of_links() + k (as in JaxSim).
Every function takes (model, data, *, ...) and returns Warp arrays on the model's device: JaxSim's shapes
for single-environment data, a leading environment axis N for batched data. Scalars (the energies) are
(1,) or (N,) arrays: Warp has no 0-d arrays, and a Python float would synchronise the host and leave the
tape; read one with `float(e.numpy()[0])`.

    M(q) nu_dot + h(q, nu) = B tau + sum_L J_L^T f_L,      h = C(q, nu) nu + g(q),

with nu, nu_dot, the base part of every generalized force, and the link forces f_L all in the data's
velocity representation (JaxSim's convention).
"""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import warp as wp

from . import arrays
from .engine import centroidal, coriolis, derivatives, determinism, dynamics, kinematics
from .engine import hardware
from .engine import joint_origins as origins
from .engine import fast_step as stepping
from .description import NotModelledWarning, UnphysicalInertiaWarning
from .description.model import ActuatorDescription
from .description.tree import JOINT_FREE
from .engine.bundles import requires_grad
from .engine.kinematics import link_targets
from .data import Data
from .math import Quaternion
from .types.enums import IntegratorType, VelRepr, output_repr
from .types.hardware import ScalingFactors, hw_link_metadata, scaled_collisions
from .types.model import Model
from .types.parameters import REGISTRY
from .types.settings import ActuationParams, SoftContactsParams
from .types.terrain import HeightfieldTerrain

JaxSimModel = Model
"""JaxSim's name of the model class (`js.model.JaxSimModel`)."""

PARAMETERS = tuple(REGISTRY)
"""The names of the model parameters (warpdyn.types.parameters): what `parameters_requiring_grad` marks and
the torch bridge's `parameters=` takes."""

__all__ = [
    "Model",
    "JaxSimModel",
    "PARAMETERS",
    "VelRepr",
    "reduce",
    "joint_origins",
    "with_joint_origins",
    "update_hw_parameters",
    "add_actuators",
    "total_mass",
    "parameters_requiring_grad",
    "forward_kinematics",
    "joint_transforms",
    "relative_link_transforms",
    "generalized_free_floating_jacobian",
    "generalized_free_floating_jacobian_derivative",
    "link_bias_accelerations",
    "forward_dynamics",
    "forward_dynamics_aba",
    "forward_dynamics_crb",
    "inverse_dynamics",
    "free_floating_mass_matrix",
    "free_floating_mass_matrix_inverse",
    "free_floating_bias_forces",
    "free_floating_gravity_forces",
    "free_floating_coriolis_matrix",
    "link_spatial_inertia_matrices",
    "total_momentum",
    "total_momentum_jacobian",
    "locked_spatial_inertia",
    "average_velocity",
    "average_velocity_jacobian",
    "kinetic_energy",
    "potential_energy",
    "mechanical_energy",
    "actuator_forces",
    "free_floating_passive_forces",
    "step",
    "ActuationParams",
    "IntegratorType",
    "NotModelledWarning",
    "UnphysicalInertiaWarning",
    "SoftContactsParams",
]


def reduce(model: Model, considered_joints, locked_joint_positions: dict | None = None) -> Model:
    """A model keeping only `considered_joints`; the others are fixed at `locked_joint_positions` (default 0).

    locked_joint_positions: {joint name: position [rad or m]} of any joints of `model`, as JaxSim's: the
    positions of the joints this reduction locks are used, those of kept joints lock nothing (a whole
    posture may be passed); a name that is not a joint of `model` is a ValueError. Joints already locked in
    `model` keep their locked positions. The settings are carried over (time_step, gravity, terrain,
    contact_model, contact_params, actuation_params, integrator, quaternion_tolerance, divergence_speed, implicit_damping,
    geom_contacts, implicit_contacts, equality_projection, built_from), as JaxSim's; the link and joint parameters are the description's (lumping changes the
    links): values set on `model` with the setters are not carried over, set them on the result.
    """
    return model.reduced(considered_joints, locked_joint_positions)


def joint_origins(model: Model) -> tuple[np.ndarray, np.ndarray]:
    """(positions (nj, 3) [m], rotations (nj, 4) (w, x, y, z)): each joint's frame in its parent link at zero
    position (URDF's joint <origin>; JaxSim's λ_H_pre less a revolute joint's pivot), host float64, in joint order;
    (N, nj, 3) and (N, nj, 4) where `with_joint_origins` gave them per environment."""
    if model.joint_origins_per_env is not None:
        return tuple(host.copy() for host in model.joint_origins_per_env)
    return origins.origins_of(model.tree)


def with_joint_origins(model: Model, *, positions=None, rotations=None) -> Model:
    """A model whose joints sit at other frames in their parent links: link lengths and mounting angles as
    kinematic parameters, differentiable, shared by the environments or per environment.

    positions (nj, 3) or (N, nj, 3) [m] and rotations (nj, 4) or (N, nj, 4) (w, x, y, z; normalised, as a joint
    moves) of each joint's frame in its parent link, as `joint_origins` returns them (None: the model's); NumPy
    arrays or Warp arrays of the model's scalar (a Warp array that requires gradients gets them: called under a
    wp.Tape, every function and step of the returned model carries gradients back to it, through the kernels'
    joint terms). Given for N environments (one of the two may be shared), the model serves data of N
    environments, as per-environment parameters do; a free joint's origin (the frame its pose is measured from)
    is the same in every environment. The returned model shares the rest with `model` (`Model.copy`); its host
    tree holds environment 0's joint frames (what `export_updated_model` and the step's stability estimate read:
    export refuses per-environment origins; `reduce` rebuilds the tree from the description, the description's
    origins); the joints' axes and pivots (child frame) do not move.
    Collidable points and frames stay on their links.
    """
    nj = model.number_of_joints()
    current = joint_origins(model)
    given, hosts = {}, {}
    for name, value, width, default in (("positions", positions, 3, current[0]), ("rotations", rotations, 4, current[1])):
        if value is None:
            value = default
        if isinstance(value, wp.array):
            arrays.check_device_array(value, name, model.scalar, model.device)
            host = value.numpy().astype(np.float64)
        else:
            host = arrays.host_numbers(value, name)
        if host.shape[-2:] != (nj, width) or host.ndim not in (2, 3) or (host.ndim == 3 and host.shape[0] == 0):
            raise ValueError(f"{name} has shape {host.shape}, expected ({nj}, {width}) (one row per joint, shared by the environments) "
                             f"or (N, {nj}, {width}) (per environment)")
        if isinstance(value, wp.array):
            given[name] = value if host.ndim == 3 else value.reshape((1, nj, width))
        else:
            given[name] = wp.array(host.reshape((len(host) if host.ndim == 3 else 1, nj, width)), dtype=model.scalar, device=model.device)
        hosts[name] = host.reshape((len(host) if host.ndim == 3 else 1, nj, width))
    counts = {len(host) for host in hosts.values()} - {1}
    if len(counts) > 1:
        raise ValueError(f"with_joint_origins: positions are given for {len(hosts['positions'])} environments, rotations for "
                         f"{len(hosts['rotations'])}: one N (or one of them shared)")
    N = max(len(host) for host in hosts.values())
    position_host, rotation_host = (np.broadcast_to(hosts[k], (N, *hosts[k].shape[1:])) for k in ("positions", "rotations"))
    norms = np.linalg.norm(rotation_host, axis=2)
    for name, host, bad in (("positions", position_host, ~np.isfinite(position_host).all(axis=2)),
                            ("rotations", rotation_host, ~np.isfinite(norms) | (norms < 1e-9))):
        if bad.any():
            env, j = np.argwhere(bad)[0]
            where = f" in environment {env}" if N > 1 else ""
            raise ValueError(f"with_joint_origins: {name} of joint '{model.joint_names()[j]}'{where} is {host[env, j].tolist()}: positions must be "
                             "finite, rotations non-zero finite quaternions (w, x, y, z)")
    for j in np.flatnonzero(np.asarray(model.tree.joint_type)[1:] == JOINT_FREE):
        if N > 1 and (np.ptp(position_host[:, j], axis=0).max() > 0 or np.ptp(rotation_host[:, j], axis=0).max() > 0):
            raise ValueError(f"with_joint_origins: the free joint '{model.joint_names()[j]}' has other origins in other environments; "
                             "a free joint's origin is the frame its pose is measured from, one for all environments")
    terms = origins.joint_terms(model, given["positions"], given["rotations"], N)
    H = np.array(model.tree.parent_H_joint, dtype=np.float64)
    H[1:, :3, :3] = Quaternion.to_dcm(rotation_host[0]).reshape(-1, 3, 3)
    H[1:, :3, 3] = position_host[0]
    tree = dataclasses.replace(model.tree, parent_H_joint=H)
    return model.with_joint_terms(terms, tree, (position_host.copy(), rotation_host.copy()) if N > 1 else None)


def update_hw_parameters(model: Model, scaling_factors: ScalingFactors) -> Model:
    """JaxSim's hardware parametrisation: a model whose parametrised links (warpdyn.types.hardware: a box, cylinder,
    sphere or capsule visual) have their shapes scaled by scaling_factors.dims (nL, 3) and their densities by
    scaling_factors.density (nL,), or either per environment, (N, nL, 3) and (N, nL) (domain randomisation of the
    links' sizes and masses), with the masses, centres of mass and inertias JaxSim derives from them (the shape's
    inertia in the link's inertial axes, the centre of mass scaled) and the joints below them moved as JaxSim moves
    them (each child joint's offset from the centre of mass scaled); the others keep theirs (JaxSim gives them mass
    0). Warp arrays of the model's scalar that require gradients get them when this is called under a wp.Tape
    (kernels/hardware.py). The collidable points move as JaxSim moves them (their offsets from the centres of mass
    scaled in the link axes: a sphere's by its radius factor, a box's by its three; a cylinder's not), and the soft
    law's step reads them from the kernel's output, so that gradients reach the factors through its contacts too (the
    point queries and the rigid models read a host copy: no gradient); the
    description's collision shapes are scaled as JaxSim's export scales them (what `export_updated_model` writes;
    environment 0's when the shapes are per environment, which export refuses). A ValueError when the model's own
    link parameters or joint origins are per environment, and for per-environment shapes where the model's geom
    pairs collide (model.geom_contacts: their shapes are one for all environments)."""
    per_env = {"link_mass", "link_com", "link_inertia", "joint_origins"} & set(model.per_environment_parameters())
    if per_env:
        raise ValueError(f"update_hw_parameters: {sorted(per_env)} are given per environment; the hardware parametrisation sets them")
    if not isinstance(scaling_factors, ScalingFactors):
        raise TypeError(f"scaling_factors must be a wd.kin_dyn_parameters.ScalingFactors, got {type(scaling_factors).__name__}")
    nL = model.number_of_links()
    given, hosts = {}, {}  # the factors on the device as (1 or N, nL, ...), and as checked on the host
    for name, value, item in (("dims", scaling_factors.dims, (3,)), ("density", scaling_factors.density, ())):
        if isinstance(value, wp.array):
            arrays.check_device_array(value, f"scaling_factors.{name}", model.scalar, model.device)
            host = value.numpy()
        else:
            host = arrays.host_numbers(value, f"scaling_factors.{name}")
            value = wp.array(host, dtype=model.scalar, device=model.device)
        per_env = host.ndim == 2 + len(item) and host.shape[0] >= 1
        if host.shape[-1 - len(item):] != (nL, *item) or host.ndim not in (1 + len(item), 2 + len(item)) or host.size == 0:
            shared = (nL, *item)
            raise ValueError(f"scaling_factors.{name} has shape {host.shape}, expected {shared} or (N, {', '.join(map(str, shared))}) "
                             "(one entry per link, in link_names() order; shared or per environment)")
        bad = ~np.isfinite(host) | (host <= 0.0)
        if bad.any():
            at = tuple(int(k) for k in np.argwhere(bad)[0])
            link = model.link_names()[at[1] if per_env else at[0]]
            where = f" in environment {at[0]}" if per_env else ""
            entry = host[at[:2]] if per_env else host[at[:1]]
            raise ValueError(f"scaling_factors.{name} of link '{link}'{where} is {np.asarray(entry).tolist()}: factors must be positive and finite")
        given[name] = value if per_env else value.reshape((1, nL, *item))
        hosts[name] = np.asarray(host, dtype=np.float64).reshape((-1, nL, *item))
    counts = {len(host) for host in hosts.values()} - {1}
    if len(counts) > 1:
        raise ValueError(f"update_hw_parameters: dims are given for {len(hosts['dims'])} environments, density for {len(hosts['density'])}: one N")
    if len(hosts["dims"]) > 1 and model.geom_contacts:
        raise ValueError("update_hw_parameters: shapes per environment, but the model's geom pairs collide (model.geom_contacts) with one "
                         "shape for all environments; scale the shapes shared, or switch geom_contacts off")
    metadata = model.cached("hw link metadata", lambda: hw_link_metadata(model))
    out = hardware.hw_parameters(model, metadata, given["dims"], given["density"])
    moves_joints = bool((metadata.link_shape[np.asarray(metadata.joint_parent, dtype=np.int64)] >= 0).any()) if model.number_of_joints() else False
    moved = with_joint_origins(model, positions=out["positions"], rotations=origins.origins_of(model.tree)[1]) if moves_joints else model.copy()
    moved = moved.with_parameter_arrays({name: out[name] for name in ("link_mass", "link_com", "link_inertia")})
    points = out["points"]
    if points.shape[1] == 0:
        return moved
    params = moved.kin_dyn_structure().with_points(moved, points.numpy()[0].astype(np.float64))  # the host's copy: queries, export
    moved = moved.with_kin_dyn_parameters(params, point_array=points)
    moved.description = scaled_collisions(model.description, model.link_names(), metadata, hosts["dims"][0])
    shaped = {link.name for link in model.description.links if link.collisions}
    members = [f"'{name}' (in '{model.link_names()[L]}')" for name, L in zip(model.tree.frame_names, model.tree.frame_parent)
               if name in shaped and metadata.link_shape[L] >= 0]
    if members:
        warnings.warn(f"update_hw_parameters: the collision shapes of links lumped into parametrised links, {', '.join(members)}, keep their "
                      "size and place in the description (what export_updated_model writes), while their collidable points move with the "
                      "link's scaling as JaxSim moves them", NotModelledWarning, stacklevel=2)
    return moved


def add_actuators(model: Model, kind: str, *, joints=None, kp=None, kv=None, gear=1.0, ctrl_range=None, force_range=None, names=None) -> Model:
    """A model like `model` (its parameters and settings carried over) with an actuator of `kind` on each of
    `joints` (names; default: every joint), after its own actuators: MuJoCo's shortcuts, for robots whose
    description has none (a URDF) or to add servos to an MJCF. With L = gear s and V = gear sdot the
    actuator's force on the joint is gear * force:
        "motor":    force = ctrl
        "position": force = kp (ctrl - L) - kv V      (ctrl: the target position, in gear units)
        "velocity": force = kv (ctrl - V)              (ctrl: the target velocity)
    kp [N m/rad or N/m], kv [N m s/rad or N s/m] and gear: a number or one per joint. ctrl_range and
    force_range (2,) or (len(joints), 2): clips of the control and of the force (None: none). names: the
    actuators' names (default "{joint}_{kind}"). The controls (`ctrl` of `step`, rollouts and the torch
    bridge) follow `model.actuator_names()`; the parameters are then `model.actuator_gain`, ... (set them
    with `set_actuator_parameters`, shared or per environment)."""
    joints = list(model.joint_names() if joints is None else joints)
    count = len(joints)

    def per_joint(value, name, shape=()):
        """value as (count, *shape) (None stays None); the stored parameters check the values."""
        if value is None:
            return None
        try:
            return np.broadcast_to(arrays.host_numbers(value, f"add_actuators: {name}"), (count, *shape))
        except ValueError:
            raise ValueError(f"add_actuators: {name} must be {shape or 'a number'} or one per joint {(count, *shape)}, got {value!r}") from None

    if kind not in ("motor", "position", "velocity"):
        raise ValueError(f"add_actuators: kind must be 'motor', 'position' or 'velocity', got {kind!r}")
    if kind == "position" and kp is None:
        raise ValueError("add_actuators: a 'position' actuator needs kp (and optionally kv)")
    if kind == "velocity" and kv is None:
        raise ValueError("add_actuators: a 'velocity' actuator needs kv")
    kp = per_joint(kp if kp is not None else 0.0, "kp")
    kv = per_joint(kv if kv is not None else 0.0, "kv")
    gear = per_joint(gear, "gear")
    ctrl = per_joint(ctrl_range, "ctrl_range", (2,))
    force = per_joint(force_range, "force_range", (2,))
    names = [f"{joint}_{kind}" for joint in joints] if names is None else list(names)
    if len(names) != count:
        raise ValueError(f"add_actuators: {len(names)} names for {count} joints")
    actuators = []
    for i, joint in enumerate(joints):
        gain, bias = {"motor": (1.0, (0.0, 0.0, 0.0)), "position": (kp[i], (0.0, -kp[i], -kv[i])), "velocity": (kv[i], (0.0, 0.0, -kv[i]))}[kind]
        actuators.append(
            ActuatorDescription(
                name=names[i], joint=joint, gear=float(gear[i]), gain=np.array([gain, 0.0, 0.0]), bias=np.array(bias),
                bias_type="none" if kind == "motor" else "affine",
                ctrl_range=np.array(ctrl[i]) if ctrl is not None else np.zeros(2), ctrl_limited=ctrl is not None,
                force_range=np.array(force[i]) if force is not None else np.zeros(2), force_limited=force is not None,
            )
        )  # fmt: skip
    return model.with_actuators(actuators)


def total_mass(model: Model):
    """The total mass of the model [kg]: a float, or (N,) when the masses are given per environment."""
    total = np.sum(model.link_mass.numpy(), axis=-1)  # the array (edited in place or not), not a host copy
    return float(total) if total.ndim == 0 else total


def parameters_requiring_grad(model: Model, names=("link_mass", "link_com", "link_inertia"), *, deterministic: bool | None = None) -> dict:
    """Mark model parameters whose gradients a wp.Tape should compute; returns {name: Warp array}.

    names, any of: "link_mass" (nL,) [kg], "link_com" (nL,) vec3 [m, link frame], "link_inertia" (nL,)
    mat33 [kg m^2, about the CoM] (see Model.set_link_parameters), "friction_static", "friction_viscous",
    "joint_limit_spring", "joint_limit_damper" (n,) (see Model.set_joint_parameters), "world_gravity" (1,)
    vec3 [m/s^2, world frame] (see Model.set_gravity), each with a leading (N,) when given per environment;
    the contact parameters "K", "D", "mu" ((1,) or (N,)); "terrain_height":
    a FlatTerrain's height ((1,) or (N,)) or a HeightfieldTerrain's heights (nx, ny) (a PlaneTerrain has
    none: ValueError). The model's own arrays get requires_grad (their .grad allocated, zero); the contact
    parameters and the terrain's heights, when numbers or NumPy arrays, become Warp arrays with requires_grad
    that replace them in `model.contact_params` / `model.terrain` (the step's plan is rebuilt once). After
    `tape.backward(loss)` the gradient of the loss is in `arrays[name].grad`, the same shape as the
    parameter: a parameter shared by the environments gets the sum over them, a per-environment one a row
    per environment. On a GPU the environments' adjoints of a shared parameter are added with atomics, in
    an order that varies from run to run (the last bits differ). deterministic=True makes them bit-identical
    run to run: launches under a tape read a copy of each named shared parameter with one row per
    environment, and the rows' adjoints are summed into its .grad in environment order by the tape's
    backward pass (warpdyn.engine.determinism; the sum's rounding differs from the atomics', not its value;
    benchmarks/reproducibility.py measures its cost; the parameter must not change while a tape records).
    False: atomics again; None (the default): each named parameter keeps its setting. A HeightfieldTerrain's
    heights are refused with it (ValueError). A parameter given per environment is deterministic either way, and its rows sum to the
    shared one's gradient (tests/test_reproducibility.py). Zero the grads in place (`tape.zero()`) between
    backward passes: kernels recorded on a tape hold views of the arrays and their gradients, so a .grad
    replaced by a new array afterwards is not the one they write. Each call returns the model's current
    arrays: replacing a parameter later (set_link_parameters, set_joint_parameters, a new contact_params or
    terrain) makes new arrays without gradients (nor determinism).

    What reaches them: ABA, RNEA, CRBA (and what calls them: forward/inverse dynamics, bias forces, mass
    matrix), the Coriolis matrix, the centroidal, momentum and energy functions (`warpdyn.com`, this
    module), `step`, `warpdyn.contact`'s forces and `warpdyn.simulation.Rollout` under a tape. With none marked
    a tape records the same launches as before and nothing extra is allocated. A limit gain or friction that
    requires gradients keeps its term in the step's compiled actuation kernel even where it is zero (a joint
    with a zero limit spring has its limit off: its gradient is 0 there).
    """
    names = (names,) if isinstance(names, str) else tuple(names)
    if deterministic and "terrain_height" in names and isinstance(model.terrain, HeightfieldTerrain):
        raise ValueError(
            "terrain_height with deterministic=True: a HeightfieldTerrain's heights get the adjoints of the cells "
            "under the collidable points from every environment; deterministic gradients are for parameters each "
            "environment reads once (the model's, K, D, mu, a FlatTerrain's height)"
        )
    marked = model.mark_for_gradients(names)
    if deterministic is not None:
        for value in marked.values():
            (determinism.mark if deterministic else determinism.unmark)(value)
    return marked


# Kinematics ------------------------------------------------------------------------------------


def forward_kinematics(model: Model, data, *, parallel: bool | None = None) -> wp.array:
    """W_H_L: the pose of every link in the world, (nL, 4, 4), or (N, nL, 4, 4) for batched data.

    parallel: JaxSim's choice between its sequential and its level-parallel algorithm, which give the same
    numbers; warpdyn has one (a thread per environment), so the value changes nothing."""
    return arrays.squeeze_env(kinematics.poses(model, data, link_targets(model)), data.num_envs)


def joint_transforms(model: Model, joint_positions, base_transform) -> wp.array:
    """i_X_λ(i): the motion adjoint from each link's parent to the link at `joint_positions` (nq,) [rad or m],
    (1 + nj, 6, 6), row 0 B_X_W of `base_transform` W_H_B (4, 4); (N, 1 + nj, 6, 6) for (N, nq) and (N, 4, 4).
    JaxSim's. The links' poses in their parents as (4, 4) matrices: `relative_link_transforms`."""
    q = arrays.host_numbers(joint_positions.numpy() if isinstance(joint_positions, wp.array) else joint_positions, "joint_positions")
    H = arrays.host_numbers(base_transform.numpy() if isinstance(base_transform, wp.array) else base_transform, "base_transform")
    batched = q.ndim == 2 or H.ndim == 3
    N = q.shape[0] if q.ndim == 2 else H.shape[0] if H.ndim == 3 else None
    nq = model.number_of_joint_coordinates()
    if H.shape[-2:] != (4, 4) or q.shape[-1:] != (nq,) or q.ndim > 2 or H.ndim > 3:
        raise ValueError(
            f"joint_transforms: joint_positions ({nq},) or (N, {nq}) and base_transform (4, 4) or "
            f"(N, 4, 4), got {q.shape} and {H.shape}"
        )
    data = Data.build(
        model,
        joint_positions=q,
        base_position=H[..., :3, 3],
        base_quaternion=Quaternion.from_dcm(H[..., :3, :3]),
        num_envs=N if batched else None,
    )
    parent_H_link, _ = kinematics.link_poses(model, data)
    return arrays.squeeze_env(kinematics.inverse_adjoints(model, parent_H_link), data.num_envs)


def relative_link_transforms(model: Model, data) -> wp.array:
    """λ(i)_H_i: the pose of each joint's child link in its parent link, (nj, 4, 4), or (N, nj, 4, 4) batched
    (what warpdyn's `joint_transforms` returned before it took JaxSim's meaning)."""
    if model.number_of_joints() == 0:
        shape = (0, 4, 4) if data.num_envs is None else (data.batch_size, 0, 4, 4)
        return wp.empty(shape, dtype=model.scalar, device=model.device)
    parent_H_link, _ = kinematics.link_poses(model, data)
    joints = model.cached("joint targets", lambda: kinematics.targets(model, model.all_links[1:], model.identity_offsets[1:]))
    H = kinematics.homogeneous(model, parent_H_link, joints, requires_grad(model, data))
    return arrays.squeeze_env(H, data.num_envs)


def generalized_free_floating_jacobian(model: Model, data, *, output_vel_repr=None) -> wp.array:
    """The Jacobians of all links, (nL, 6, 6 + n), or (N, nL, 6, 6 + n) batched.

    Columns act on the generalized velocity in the data's representation; rows give each link's
    velocity in `output_vel_repr` (default: the data's).
    """
    J = kinematics.jacobians(model, data, link_targets(model), output_vel_repr)
    return arrays.squeeze_env(J, data.num_envs)


def generalized_free_floating_jacobian_derivative(model: Model, data, *, output_vel_repr=None) -> wp.array:
    """J̇ of every link: (nL, 6, 6 + n), or (N, nL, 6, 6 + n) for batched data.

    The time derivative of `generalized_free_floating_jacobian(model, data, output_vel_repr=...)` along the
    state's motion: columns act on ν in the data's representation, rows give each link's velocity in
    `output_vel_repr` (default: the data's).
    """
    Jdot = derivatives.jacobian_derivatives(model, data, link_targets(model), output_vel_repr)
    return arrays.squeeze_env(Jdot, data.num_envs)


def link_bias_accelerations(model: Model, data) -> wp.array:
    """J̇ν of every link, in the data's representation: (nL, 6), or (N, nL, 6) for batched data."""
    a = derivatives.bias_accelerations(model, data, link_targets(model), None)
    return arrays.squeeze_env(a, data.num_envs)


# Dynamics --------------------------------------------------------------------------------------


def forward_dynamics_aba(model: Model, data, *, joint_forces=None, link_forces=None, parallel: bool | None = None):
    """(base acceleration (6,), joint accelerations (n,)) by the articulated-body algorithm.

    joint_forces (n,); link_forces (nL, 6) in the data's representation. The base acceleration is the
    derivative of the base velocity in the data's representation (zero for a fixed base). parallel: JaxSim's
    choice between its sequential and its level-parallel algorithm, which give the same numbers; warpdyn has
    one (a thread per environment), so the value changes nothing.
    """
    return dynamics.forward_dynamics_aba(model, data, joint_forces, link_forces)


def forward_dynamics_crb(model: Model, data, *, joint_forces=None, link_forces=None):
    """(base acceleration (6,), joint accelerations (n,)) = M^-1 (B tau - h + sum_L J_L^T f_L), by CRBA
    and a Cholesky solve. Under a wp.Tape the solve's adjoint is the implicit one (kernels/cholesky.py):
    gradients reach the state, the forces and the mass parameters as through forward_dynamics_aba."""
    return dynamics.forward_dynamics_crb(model, data, joint_forces, link_forces)


def forward_dynamics(model: Model, data, *, joint_forces=None, link_forces=None, prefer_aba: bool = True):
    """Forward dynamics by ABA (default) or by CRBA and a Cholesky solve."""
    solver = forward_dynamics_aba if prefer_aba else forward_dynamics_crb
    return solver(model, data, joint_forces=joint_forces, link_forces=link_forces)


def inverse_dynamics(model: Model, data, *, joint_accelerations=None, base_acceleration=None, link_forces=None):
    """(f_B, tau): the base wrench (6,) and joint forces (n,) that produce the given accelerations.

    base_acceleration (6,): the derivative of the base velocity in the data's representation (default 0; a
    welded base does not accelerate: for a fixed-base model it is checked and not applied, as JaxSim's);
    joint_accelerations (n,) (default 0); link_forces (nL, 6) in the data's representation. f_B is the
    generalized force of the base, dual to its velocity in the data's representation: zero when the
    accelerations came from forward dynamics with the same forces. Leading N axis for batched data.
    """
    f_B, tau = dynamics.inverse_dynamics(model, data, joint_accelerations, base_acceleration, link_forces)
    return f_B, tau


def free_floating_mass_matrix(model: Model, data) -> wp.array:
    """M(q): (6 + n, 6 + n) or (N, 6 + n, 6 + n), for the generalized velocity in the data's representation."""
    return dynamics.mass_matrix(model, data)


def free_floating_mass_matrix_inverse(model: Model, data) -> wp.array:
    """M(q)^-1: (6 + n, 6 + n) or batched; for a fixed base, the inverse of the joint block (zeros elsewhere).
    A Cholesky solve, whose adjoint under a wp.Tape is the implicit one, -M^-1 adj M^-1 (kernels/cholesky.py)."""
    return dynamics.mass_matrix_inverse(model, data)


def free_floating_bias_forces(model: Model, data) -> wp.array:
    """h = C(q, nu) nu + g(q): (6 + n,) or (N, 6 + n), in the data's representation."""
    return dynamics.generalized_forces(model, data)


def free_floating_gravity_forces(model: Model, data) -> wp.array:
    """g(q): (6 + n,) or (N, 6 + n), in the data's representation."""
    return dynamics.generalized_forces(model, data, with_velocity=False)


def free_floating_coriolis_matrix(model: Model, data) -> wp.array:
    """C(q, nu): (6 + n, 6 + n), or (N, 6 + n, 6 + n) for batched data, in the data's representation.

    Rows are generalized forces dual to nu (base rows: the base wrench in the representation's frame,
    [N; N m]), columns act on nu (base: the base velocity in the data's representation); C nu = h - g.
    Units: those of M (kg, kg m, kg m^2) per second.
    """
    return arrays.squeeze_env(coriolis.coriolis_matrix(model, data), data.num_envs)


# Momentum and energy ---------------------------------------------------------------------------


def link_spatial_inertia_matrices(model: Model) -> wp.array:
    """L_M_L: the spatial inertia of every link about its origin in link axes, (nL, 6, 6), or (N, nL, 6, 6)
    when the inertial parameters are given per environment, [linear; angular]: [[m 1, -m c^],
    [m c^, I_c - m c^ c^]] (m [kg], c the CoM in the link frame [m], I_c about the CoM [kg m^2])."""
    return centroidal.link_spatial_inertia_matrices(model)


def total_momentum(model: Model, data) -> wp.array:
    """The total momentum in the data's representation: (6,) or (N, 6), [kg m/s; kg m^2/s].

    Expressed in W, B or B[W] (Inertial, Body, Mixed), the angular part about that frame's origin;
    equal to total_momentum_jacobian(model, data) @ ν.
    """
    S = centroidal.sums(model, data)
    return arrays.squeeze_env(centroidal.force_in(model, data, S, centroidal.frame_of(data.velocity_representation)), data.num_envs)


def total_momentum_jacobian(model: Model, data, *, output_vel_repr=None) -> wp.array:
    """J_h: (6, 6 + n) or (N, 6, 6 + n), mapping ν (the data's representation) to the total momentum in
    the frame of output_vel_repr (default: the data's): W, B or B[W]. With the data's representation as
    output it is the first six rows of the mass matrix, as in JaxSim."""
    S = centroidal.sums(model, data)
    J = centroidal.jacobian_in(model, data, S, centroidal.frame_of(output_repr(data, output_vel_repr)), average=False)
    return arrays.squeeze_env(J, data.num_envs)


def locked_spatial_inertia(model: Model, data) -> wp.array:
    """The locked spatial inertia (all joints locked) in the data's representation's frame: (6, 6) or
    (N, 6, 6), [[kg, kg m], [kg m, kg m^2]]; equal to total_momentum_jacobian(model, data)[:, :6]."""
    S = centroidal.sums(model, data)
    return arrays.squeeze_env(centroidal.inertia_in(model, data, S, centroidal.frame_of(data.velocity_representation)), data.num_envs)


def average_velocity(model: Model, data) -> wp.array:
    """The average 6D velocity (locked inertia^-1 times momentum) as a velocity of the data's
    representation's frame (W, B or B[W]): (6,) or (N, 6), [m/s; rad/s]."""
    S = centroidal.sums(model, data)
    return arrays.squeeze_env(centroidal.velocity_in(model, data, S, centroidal.frame_of(data.velocity_representation)), data.num_envs)


def average_velocity_jacobian(model: Model, data, *, output_vel_repr=None) -> wp.array:
    """J_avg: (6, 6 + n) or (N, 6, 6 + n), mapping ν (the data's representation) to the average velocity
    as a velocity of the frame of output_vel_repr (default: the data's).

    JaxSim computes it as O_X_G · average_centroidal_velocity_jacobian and, when the output
    representation differs from the data's, takes G to be G[W] or G[B] after the output rather than the
    data; that agrees with this function except between Body and the other two, where JaxSim's
    result is not the average velocity of any frame. This function applies the proper transform always.
    """
    S = centroidal.sums(model, data)
    J = centroidal.jacobian_in(model, data, S, centroidal.frame_of(output_repr(data, output_vel_repr)), average=True)
    return arrays.squeeze_env(J, data.num_envs)


def kinetic_energy(model: Model, data) -> wp.array:
    """K = 1/2 ν^T M ν = Σ_L 1/2 L_v^T L_M_L L_v [J]: (N,) for batched data, (1,) for one environment."""
    return centroidal.energy(model, data, centroidal.sums(model, data), kinetic=True, potential=False)


def potential_energy(model: Model, data) -> wp.array:
    """U = -m g · W_p_CoM [J], g = model.world_gravity (U grows against gravity; m 9.81 z_CoM by default): (N,) or (1,).

    JaxSim's text computes m z_CoM model.gravity = -9.81 m z_CoM, the opposite sign, with which K + U is not
    conserved; this follows the physics (and MuJoCo's energy[0], -Σ_b m_b gravity · x_b)."""
    return centroidal.energy(model, data, centroidal.sums(model, data), kinetic=False, potential=True)


def mechanical_energy(model: Model, data) -> wp.array:
    """K + U [J]: (N,) or (1,); conserved by the unforced, frictionless dynamics."""
    return centroidal.energy(model, data, centroidal.sums(model, data), kinetic=True, potential=True)


# Simulation ------------------------------------------------------------------------------------


def actuator_forces(model: Model, data, *, ctrl=None) -> wp.array:
    """The force of the model's actuators (MJCF <actuator>) on each joint: (n,) or (N, n) [N m or N],
    MuJoCo's qfrc_actuator. ctrl (na,) or (N, na): the controls, in the order of `model.actuator_names()`
    (None: zero). Each actuator a on joint j gives gear_a clip(gain ctrl_a + bias, force_range) with gain
    and bias affine in its length gear_a s_j and velocity gear_a sdot_j, ctrl clipped to its ctrl_range;
    the sum on a joint is clipped to the joint's actuator_force_range (kernels/actuation.py)."""
    return arrays.squeeze_env(dynamics.actuator_forces(model, data, ctrl), data.num_envs)


def free_floating_passive_forces(model: Model, data) -> wp.array:
    """MuJoCo's qfrc_passive: (6 + n,) or (N, 6 + n) in the data's representation: the joints' springs and
    dampers, -stiffness (s - springref) - damping sdot, and the links' gravity compensation (MJCF gravcomp)
    as generalized forces (its base part: the base wrench dual to the base velocity). JaxSim's friction
    and limit springs are not in it (see `step`)."""
    return arrays.squeeze_env(dynamics.passive_forces(model, data), data.num_envs)


def step(model: Model, data, *, link_forces=None, joint_force_references=None, ctrl=None):
    """The data after one step of `model.time_step` [s] with `model.integrator`, as JaxSim's step.

    link_forces (nL, 6) or (N, nL, 6): external forces in the data's representation, held for the step.
    joint_force_references (n,) or (N, n): joint forces before friction, limits and the torque-speed curve.
    ctrl (na,) or (N, na): the controls of the model's actuators (see `actuator_forces`), held for the step.
    The step also applies the passive forces (`free_floating_passive_forces`; the gravity compensation at
    each RK4 stage) and, when model.implicit_damping, integrates the joints' damping implicitly.
    Returns new Data (same representation) whose arrays are the caller's: no later call overwrites them
    while anything refers to them (the Data, a view, `.numpy()`, a torch tensor, a wp.Tape); `data` is
    unchanged. Outside a wp.Tape the step's intermediate arrays are kept per model and thread, its output
    arrays come from a small pool that hands a set out again once nothing else refers to it, and its
    launches, from a state to a pooled set, are replayed from a graph after a few calls
    (warpdyn.engine.fast_step); under a tape, or when gradients are needed, all are fresh (the adjoint
    reads them later). Not references, so not covered, as with freed memory: a weak reference, `arr.ptr`,
    a `wp.array(ptr=...)` on it, a graph you captured reading it: these see new values once the set is
    handed out again.
    """
    return stepping.step(model, data, link_forces=link_forces, joint_force_references=joint_force_references, ctrl=ctrl)
