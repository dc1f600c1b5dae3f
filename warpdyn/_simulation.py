"""Simulation: soft contacts with the terrain, actuation, and the integrators of `wd.model.step`.

A step, as JaxSim's `js.model.step` with SoftContacts:
1. the user's link forces (the data's representation) made Inertial; the joint torques from the joint
   force references through friction, limit springs and the torque-speed curve (kernels/actuation.py),
   once per step at its start;
2. the contact forces of the enabled collidable points (kernels/soft_contacts.py) added to the link forces,
   and the rate of the tangential deformation;
3. forward dynamics by ABA in the Inertial representation;
4. the integrator (kernels/integrators.py); environments whose new state is not finite are flagged
   (`data.valid`) and keep their state.
`step` returns new Data (fresh arrays): nothing an adjoint needs is overwritten, so a wp.Tape through
many steps gives gradients. Parts a model does not need are not launched (no enabled collidable points:
no contact kernel) or not compiled (no limit springs, no friction: a kernel without that code).
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np
import warp as wp

from . import _arrays
from .common import VelRepr
from .kernels.actuation import kernel as actuation_kernel
from .kernels.forces import kernels as force_kernels
from .kernels.integrators import kernels as integrator_kernels
from .kernels.soft_contacts import kernels as contact_kernels
from .kernels.state import kernels as state_kernels
from .kernels.velocities import kernels as velocity_kernels
from .terrain import HeightfieldTerrain

__all__ = ["IntegratorType", "SoftContactsParams", "ActuationParams", "step"]


class IntegratorType(enum.IntEnum):
    """The integrators of `step` (JaxSim's names)."""

    SemiImplicitEuler = 1
    RungeKutta4 = 2


@dataclasses.dataclass(frozen=True)
class SoftContactsParams:
    """JaxSim's soft-contact parameters and defaults.

    K: stiffness [N/m^(1+p)]; D: damping [N s/m^(1+q)]; mu: Coulomb friction coefficient (stick and slip);
    p: exponent of the spring term, q: of the damper term. K, D and mu may be arrays (N,), one value per
    environment (domain randomisation).
    """

    K: float | np.ndarray = 1e6
    D: float | np.ndarray = 2000.0
    mu: float | np.ndarray = 0.5
    p: float = 0.5
    q: float = 0.5

    def __post_init__(self):
        for name in ("K", "D", "mu", "p", "q"):
            value = np.asarray(getattr(self, name), dtype=np.float64)
            if value.ndim > 1 or not np.all(np.isfinite(value)) or np.any(value < 0.0):
                raise ValueError(f"SoftContactsParams.{name} must be finite and non-negative (a number or (N,)), got {value}")
        if np.any(np.asarray(self.D) <= 0.0):
            raise ValueError("SoftContactsParams.D must be positive (the deformation relaxes with rate K/D)")


@dataclasses.dataclass(frozen=True)
class ActuationParams:
    """JaxSim's torque-speed curve and whether joint friction applies.

    torque_max [N m]: the bound up to omega_th [rad/s], falling linearly to 0 at omega_max.
    """

    torque_max: float = 3000.0
    omega_th: float = 30.0
    omega_max: float = 100.0
    enable_friction: bool = True

    def __post_init__(self):
        if not (0.0 < self.omega_th < self.omega_max) or self.torque_max < 0.0:
            raise ValueError(f"ActuationParams needs torque_max >= 0 and 0 < omega_th < omega_max, got {self}")


def _per_env(value, name, num_envs, scalar, device) -> wp.array:
    host = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if host.shape not in ((1,), (num_envs,)):
        raise ValueError(f"SoftContactsParams.{name} has shape {host.shape}: give a number or one value per environment ({num_envs},)")
    return wp.array(host, dtype=scalar, device=device)


@dataclasses.dataclass
class _ContactPlan:
    """The enabled collidable points ordered by link, on the device, for the contact kernel."""

    point_link: wp.array
    L_p_C: wp.array
    point_row: wp.array
    row_enabled: wp.array
    link_first_point: wp.array
    count: int
    total: int


def _contact_plan(model) -> _ContactPlan:
    params = model.kin_dyn_parameters
    cp = params.contact_parameters
    key = (id(params), model.device)
    cached = getattr(model, "_contact_plan_cache", None)
    if cached is not None and cached[0] == key:
        return cached[1]
    rows = cp.indices_of_enabled_collidable_points
    links = np.asarray(cp.body, dtype=np.int64)[rows]
    order = np.argsort(links, kind="stable")
    rows, links = rows[order], links[order]
    first = np.full(model.number_of_links(), -1, dtype=np.int32)
    for k in range(len(links) - 1, -1, -1):
        first[links[k]] = k
    enabled = np.zeros(len(cp.body), dtype=np.int32)
    enabled[rows] = 1
    s, d = model.scalar, model.device
    plan = _ContactPlan(
        point_link=wp.array(links.astype(np.int32), dtype=int, device=d),
        L_p_C=wp.array(np.asarray(cp.point, dtype=np.float64)[rows].reshape(-1, 3), dtype=wp.types.vector(3, s), device=d),
        point_row=wp.array(rows.astype(np.int32), dtype=int, device=d),
        row_enabled=wp.array(enabled, dtype=int, device=d),
        link_first_point=wp.array(first, dtype=int, device=d),
        count=len(rows),
        total=len(cp.body),
    )
    model._contact_plan_cache = (key, plan)
    return plan


def _terrain_args(model):
    terrain = model.terrain
    s, d = model.scalar, model.device
    vec3 = wp.types.vector(3, s)
    vec4 = wp.types.vector(4, s)
    if isinstance(terrain, HeightfieldTerrain):
        heights = wp.array(terrain.heights, dtype=s, device=d)
        grid = vec4(*terrain.origin, *terrain.spacing)
        return [terrain.kind, vec3(0.0, 0.0, 1.0), s(0.0), heights, grid]
    normal, h0 = terrain.plane()
    empty = wp.zeros((2, 2), dtype=s, device=d)
    return [terrain.kind, vec3(*normal), s(h0), empty, vec4(0.0, 0.0, 1.0, 1.0)]


def contact_forces(model, data, W_f_ext: wp.array):
    """(W_f_C (N, nc, 6), m_dot (N, nc_all, 3), W_f_L (N, nL, 6)): the Inertial contact wrench of each
    enabled point, the deformation rate of every point, and W_f_ext plus the contact wrenches per link."""
    from .model import link_poses

    plan = _contact_plan(model)
    N, nL = data.batch_size, model.number_of_links()
    s, d, g = model.scalar, model.device, data.requires_grad
    m = tangential_deformation(model, data)
    m_dot = _arrays.output((plan.total, 3), N, s, d, g)
    W_f_C = _arrays.output((plan.count, 6), N, s, d, g)
    if plan.count == 0:
        m_dot.zero_()
        return W_f_C, m_dot, W_f_ext
    W_f_L = _arrays.output((nL, 6), N, s, d, g)
    _, W_H_L = link_poses(model, data)
    W_v_WL = _link_velocities(model, data, W_H_L)
    cp = model.contact_params
    wp.launch(
        contact_kernels(s).contact_forces,
        dim=N,
        inputs=[
            plan.point_link,
            plan.L_p_C,
            plan.point_row,
            plan.row_enabled,
            plan.link_first_point,
            *_terrain_args(model),
            _per_env(cp.K, "K", N, s, d),
            _per_env(cp.D, "D", N, s, d),
            _per_env(cp.mu, "mu", N, s, d),
            s(cp.p),
            s(cp.q),
            W_H_L,
            W_v_WL,
            m,
            W_f_ext,
            _arrays.empty((plan.count,), N, wp.types.vector(6, s), d, g),
        ],
        outputs=[W_f_C, m_dot, W_f_L],
        device=d,
    )
    return W_f_C, m_dot, W_f_L


def _link_velocities(model, data, W_H_L) -> wp.array:
    """W_v_WL (N, nL) vec6: the Inertial velocities of the links."""
    N, nL = data.batch_size, model.number_of_links()
    vec6 = wp.types.vector(6, model.scalar)
    W_v_WL = _arrays.empty((nL,), N, vec6, model.device, data.requires_grad)
    unused = _arrays.empty((0, 6), N, model.scalar, model.device)
    wp.launch(
        velocity_kernels(model.scalar).link_velocities,
        dim=N,
        inputs=[
            model.parent,
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            model.all_links[:0],
            model.identity_offsets[:0],
            W_H_L,
            data.base_velocity_state,
            data.joint_velocities_state,
            int(VelRepr.Inertial),
        ],
        outputs=[W_v_WL, unused],
        device=model.device,
    )
    return W_v_WL


def _link_forces_inertial(model, data, link_forces) -> wp.array:
    """W_f_L (N, nL, 6): `link_forces` ((nL, 6) or (N, nL, 6), in the data's representation) made Inertial."""
    from .model import link_poses

    N, nL, s, d = data.batch_size, model.number_of_links(), model.scalar, model.device
    if link_forces is None:
        return _arrays.zeros((nL, 6), N, s, d)
    forces = _arrays.batched_input(link_forces, "link_forces", (nL, 6), data.num_envs, s, d)
    if data.velocity_representation == VelRepr.Inertial:
        return forces
    _, W_H_L = link_poses(model, data)
    out = _arrays.output((nL, 6), N, s, d, data.requires_grad or forces.requires_grad)
    wp.launch(
        force_kernels(s).link_forces_to_inertial,
        dim=(N, nL),
        inputs=[W_H_L, forces, int(data.velocity_representation)],
        outputs=[out],
        device=d,
    )
    return out


def tangential_deformation(model, data) -> wp.array:
    """The data's contact state m (N, nc_all, 3), checked against the model's points."""
    total = len(model.kin_dyn_parameters.contact_parameters.body)
    m = data.tangential_deformation_state
    if m is None or m.shape[1] != total:
        got = None if m is None else m.shape[1]
        raise ValueError(
            f"data holds the tangential deformation of {got} collidable points but the model has {total}: "
            "build the data from this model (wd.data.Data.build) after changing its collidable points"
        )
    return m


def resultant_torques(model, data, joint_force_references) -> wp.array:
    """tau (N, n): the joint torques a step applies, from the references (see kernels/actuation.py)."""
    n = model.dofs()
    s, d = model.scalar, model.device
    tau_ref = (
        _arrays.zeros((n,), data.batch_size, s, d)
        if joint_force_references is None
        else _arrays.batched_input(joint_force_references, "joint_force_references", (n,), data.num_envs, s, d)
    )
    if n == 0:
        return tau_ref
    with_limits = bool(np.any(model.joint_limit_spring_host != 0.0))
    with_friction = bool(model.actuation_params.enable_friction) and bool(
        np.any(model.friction_static_host != 0.0) or np.any(model.friction_viscous_host != 0.0)
    )
    a = model.actuation_params
    tau = _arrays.output((n,), data.batch_size, s, d, data.requires_grad)
    wp.launch(
        actuation_kernel(s, with_limits, with_friction),
        dim=(data.batch_size, n),
        inputs=[
            model.position_limits,
            model.joint_limit_spring,
            model.joint_limit_damper,
            model.friction_static,
            model.friction_viscous,
            s(a.torque_max),
            s(a.omega_th),
            s(a.omega_max),
            data.joint_positions_state,
            data.joint_velocities_state,
            tau_ref,
        ],
        outputs=[tau],
        device=d,
    )
    return tau


def _derivatives(model, data, tau, W_f_ext):
    """(nu_dot (N, 6 + n) Inertial, m_dot (N, nc_all, 3)) of the state in `data`."""
    from ._dynamics import forward_dynamics_aba

    _, m_dot, W_f_L = contact_forces(model, data, W_f_ext)
    inertial = dataclasses.replace(data, velocity_representation=VelRepr.Inertial, num_envs=data.batch_size)
    base, joints = forward_dynamics_aba(model, inertial, joint_forces=tau, link_forces=W_f_L)
    return base, joints, m_dot


def step(model, data, *, link_forces=None, joint_force_references=None):
    """The data after one step of `model.time_step` [s] with `model.integrator`, as JaxSim's step.

    link_forces (nL, 6) or (N, nL, 6): external forces in the data's representation, held for the step.
    joint_force_references (n,) or (N, n): joint forces before friction, limits and the torque-speed curve.
    Returns new Data (fresh arrays, same representation); `data` is unchanged.
    """
    from . import model as model_module

    model_module._check_data(model, data)
    N = data.batch_size
    s, d, g = model.scalar, model.device, data.requires_grad
    W_f_ext = _link_forces_inertial(model, data, link_forces)
    tau = resultant_torques(model, data, joint_force_references)
    integrator = IntegratorType(model.integrator)
    K = integrator_kernels(s)
    n = model.dofs()
    if integrator == IntegratorType.SemiImplicitEuler:
        base, joints, m_dot = _derivatives(model, data, tau, W_f_ext)
        nu_dot = _join(base, joints, N, n, s, d, g)
        return _integrate(model, data, K.semi_implicit_euler, [nu_dot, m_dot])
    return _rk4(model, data, tau, W_f_ext)


def _join(base, joints, N, n, s, d, g) -> wp.array:
    """nu_dot (N, 6 + n) from the (N, 6) and (N, n) views ABA returns (they share one array)."""
    out = _arrays.empty((6 + n,), N, s, d, g)
    wp.launch(state_kernels(s).join_columns, dim=N, inputs=[base, joints], outputs=[out], device=d)
    return out


def _new_state(model, data):
    N, n = data.batch_size, model.dofs()
    s, d, g = model.scalar, model.device, data.requires_grad
    total = data.tangential_deformation_state.shape[1]
    return [
        _arrays.empty((3,), N, s, d, g),
        _arrays.empty((4,), N, s, d, g),
        _arrays.empty((n,), N, s, d, g),
        _arrays.empty((6,), N, s, d, g),
        _arrays.empty((n,), N, s, d, g),
        _arrays.empty((total, 3), N, s, d, g),
        wp.empty(N, dtype=wp.int32, device=d),
    ]


def _state_arrays(data):
    return [
        data.base_position_state,
        data.base_quaternion_state,
        data.joint_positions_state,
        data.base_velocity_state,
        data.joint_velocities_state,
        data.tangential_deformation_state,
        data.valid_state,
    ]


def _from_arrays(data, arrays):
    return dataclasses.replace(
        data,
        base_position_state=arrays[0],
        base_quaternion_state=arrays[1],
        joint_positions_state=arrays[2],
        base_velocity_state=arrays[3],
        joint_velocities_state=arrays[4],
        tangential_deformation_state=arrays[5],
        valid_state=arrays[6],
    )


def _integrate(model, data, kernel, derivatives):
    out = _new_state(model, data)
    wp.launch(
        kernel,
        dim=data.batch_size,
        inputs=[model.scalar(model.time_step), model.scalar(model.quaternion_tolerance), *_state_arrays(data), *derivatives],
        outputs=out,
        device=model.device,
    )
    return _from_arrays(data, out)


def _rk4(model, data, tau, W_f_ext):
    """The classic RK4 on x = (p, Q, s, v (Inertial), sdot, m); contacts at each stage."""
    K = integrator_kernels(model.scalar)
    N, n, s, d, g = data.batch_size, model.dofs(), model.scalar, model.device, data.requires_grad
    dt = model.time_step
    slopes = []
    stage = data
    for c in (0.5, 0.5, 1.0, None):
        base, joints, m_dot = _derivatives(model, stage, tau, W_f_ext)
        slope = _arrays.empty((K.state_size(n, m_dot.shape[1]),), N, s, d, g)
        wp.launch(
            K.slope,
            dim=N,
            inputs=[*_state_arrays(stage)[:6], base, joints, m_dot],
            outputs=[slope],
            device=d,
        )
        slopes.append(slope)
        if c is not None:
            out = _new_state(model, data)
            wp.launch(K.rk4_stage, dim=N, inputs=[s(c * dt), *_state_arrays(data)[:6], slope], outputs=out[:6], device=d)
            out[6] = data.valid_state
            stage = _from_arrays(data, out)
    out = _new_state(model, data)
    wp.launch(
        K.rk4_combine,
        dim=N,
        inputs=[s(dt), s(model.quaternion_tolerance), *_state_arrays(data), *slopes],
        outputs=out,
        device=d,
    )
    return _from_arrays(data, out)


def estimate_good_contact_parameters(
    model,
    *,
    standard_gravity: float = 9.81,
    static_friction_coefficient: float = 0.5,
    number_of_active_collidable_points_steady_state: int = 1,
    damping_ratio: float = 1.0,
    max_penetration: float | None = None,
) -> SoftContactsParams:
    """JaxSim's estimate: K so that the robot's weight shared by the active points penetrates
    max_penetration (default: 1% of the CoM height above the lowest collidable point at the zero state),
    K = m g / n / delta_max^(1 + p) clipped to 1e6, and D = damping_ratio 2 sqrt(K m) clipped to 1e4."""
    from . import contact, com
    from .data import Data

    m = float(np.sum(model.tree.link_mass))
    nc = int(number_of_active_collidable_points_steady_state)
    if nc < 1:
        raise ValueError(f"number_of_active_collidable_points_steady_state must be >= 1, got {nc}")
    if max_penetration is None:
        zero = Data.build(model)
        height = float(com.com_position(model, zero).numpy()[2])
        if model.floating_base():
            points = contact.collidable_point_positions(model, zero).numpy()
            if len(points):
                height -= float(points[:, 2].min())
        max_penetration = 0.01 * height
    if not max_penetration > 0.0:
        raise ValueError(f"max_penetration must be positive, got {max_penetration}")
    p = 0.5
    K = float(np.clip(m * standard_gravity / nc / max_penetration ** (1.0 + p), 0.0, 1e6))
    D = float(np.clip(damping_ratio * 2.0 * np.sqrt(K * m), 0.0, 1e4))
    return SoftContactsParams(K=K, D=D, mu=static_friction_coefficient, p=p, q=0.5)

