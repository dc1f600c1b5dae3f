"""Equations of motion: RNEA, CRBA and ABA behind JaxSim's `jaxsim.api.model` functions.

    M(q) nu_dot + h(q, nu) = B tau + sum_L J_L^T f_L,      h = C(q, nu) nu + g(q),

with nu, nu_dot, the base part of every generalized force, and the link forces f_L all in the data's
velocity representation (JaxSim's convention). Each function is one kernel launch (plus the conversion
of link forces from the data's representation when they are given), re-exported by `warpdyn.model`.
"""

from __future__ import annotations

import warp as wp

from . import _arrays
from .common import VelRepr
from .kernels.aba import kernels as aba_kernels
from .kernels.cholesky import kernels as cholesky_kernels
from .kernels.crba import kernels as crba_kernels
from .kernels.forces import kernels as force_kernels
from .kernels.rnea import kernels as rnea_kernels
from .kernels.state import kernels as state_kernels


def _scratch(model, data, dtype, per_env=None):
    shape = (model.number_of_links(),) if per_env is None else per_env
    return _arrays.empty(shape, data.batch_size, dtype, model.device, data.requires_grad)


def _types(model):
    s = model.scalar
    return wp.types.transformation(s), wp.types.vector(6, s), wp.types.matrix((6, 6), s)


def link_forces_inertial(model, data, link_forces) -> wp.array:
    """W_f_L (N, nL, 6): `link_forces` ((nL, 6) or (N, nL, 6), in the data's representation) made Inertial."""
    nL = model.number_of_links()
    if link_forces is None:
        return _arrays.zeros((nL, 6), data.batch_size, model.scalar, model.device)
    forces = _arrays.batched_input(link_forces, "link_forces", (nL, 6), data.num_envs, model.scalar, model.device)
    if data.velocity_representation == VelRepr.Inertial:
        return forces
    from .model import link_poses

    _, W_H_L = link_poses(model, data)
    out = _arrays.output((nL, 6), data.batch_size, model.scalar, model.device, data.requires_grad)
    wp.launch(
        force_kernels(model.scalar).link_forces_to_inertial,
        dim=(data.batch_size, nL),
        inputs=[W_H_L, forces, int(data.velocity_representation)],
        outputs=[out],
        device=model.device,
    )
    return out


def _input(model, data, value, name, per_env):
    if value is None:
        return _arrays.zeros(per_env, data.batch_size, model.scalar, model.device)
    return _arrays.batched_input(value, name, per_env, data.num_envs, model.scalar, model.device)


def generalized_forces(model, data, base_acceleration, joint_accelerations, W_f_L, with_velocity=True) -> wp.array:
    """Q (N, 6 + n) = [f_B; tau] from RNEA (see kernels/rnea.py); accelerations in the data's representation."""
    from .model import _check_data

    _check_data(model, data)
    transform, vec6, _ = _types(model)
    n = model.dofs()
    Q = _arrays.output((6 + n,), data.batch_size, model.scalar, model.device, data.requires_grad)
    wp.launch(
        rnea_kernels(model.scalar).rnea,
        dim=data.batch_size,
        inputs=[
            model.parent,
            model.joint_type,
            model.X_tree,
            model.joint_axis,
            model.joint_pivot,
            model.link_mass,
            model.link_com,
            model.link_inertia,
            model.first_child,
            model.next_sibling,
            model.gravity,
            data.base_position_state,
            data.base_quaternion_state,
            data.joint_positions_state,
            data.base_velocity_state,
            data.joint_velocities_state,
            base_acceleration,
            joint_accelerations,
            W_f_L,
            int(data.velocity_representation),
            1.0 if with_velocity else 0.0,
            _scratch(model, data, transform),
            _scratch(model, data, transform),
            _scratch(model, data, vec6),
            _scratch(model, data, vec6),
            _scratch(model, data, vec6),
            _scratch(model, data, vec6),
        ],
        outputs=[Q],
        device=model.device,
    )
    return Q


def inverse_dynamics(model, data, *, joint_accelerations=None, base_acceleration=None, link_forces=None):
    """(f_B, tau): the base wrench (6,) and joint forces (n,) that produce the given accelerations.

    base_acceleration (6,): the derivative of the base velocity in the data's representation (default 0);
    joint_accelerations (n,) (default 0); link_forces (nL, 6) in the data's representation. f_B is the
    generalized force of the base, dual to its velocity in the data's representation: zero when the
    accelerations came from forward dynamics with the same forces. Leading N axis for batched data.
    """
    n = model.dofs()
    Q = generalized_forces(
        model,
        data,
        _input(model, data, base_acceleration, "base_acceleration", (6,)),
        _input(model, data, joint_accelerations, "joint_accelerations", (n,)),
        link_forces_inertial(model, data, link_forces),
    )
    return _arrays.squeeze_env(Q[:, :6], data.num_envs), _arrays.squeeze_env(Q[:, 6:], data.num_envs)


def free_floating_bias_forces(model, data) -> wp.array:
    """h = C(q, nu) nu + g(q): (6 + n,) or (N, 6 + n), in the data's representation."""
    zero6 = _arrays.zeros((6,), data.batch_size, model.scalar, model.device)
    zero_n = _arrays.zeros((model.dofs(),), data.batch_size, model.scalar, model.device)
    Q = generalized_forces(model, data, zero6, zero_n, link_forces_inertial(model, data, None))
    return _arrays.squeeze_env(Q, data.num_envs)


def free_floating_gravity_forces(model, data) -> wp.array:
    """g(q): (6 + n,) or (N, 6 + n), in the data's representation."""
    zero6 = _arrays.zeros((6,), data.batch_size, model.scalar, model.device)
    zero_n = _arrays.zeros((model.dofs(),), data.batch_size, model.scalar, model.device)
    Q = generalized_forces(model, data, zero6, zero_n, link_forces_inertial(model, data, None), with_velocity=False)
    return _arrays.squeeze_env(Q, data.num_envs)


def free_floating_mass_matrix(model, data) -> wp.array:
    """M(q): (6 + n, 6 + n) or (N, 6 + n, 6 + n), for the generalized velocity in the data's representation."""
    from .model import _check_data

    _check_data(model, data)
    transform, vec6, mat66 = _types(model)
    n = model.dofs()
    M = _arrays.output((6 + n, 6 + n), data.batch_size, model.scalar, model.device, data.requires_grad)
    wp.launch(
        crba_kernels(model.scalar).crba,
        dim=data.batch_size,
        inputs=[
            model.parent,
            model.joint_type,
            model.X_tree,
            model.joint_axis,
            model.joint_pivot,
            model.link_mass,
            model.link_com,
            model.link_inertia,
            model.first_child,
            model.next_sibling,
            model.support,
            data.base_position_state,
            data.base_quaternion_state,
            data.joint_positions_state,
            int(data.velocity_representation),
            _scratch(model, data, transform),
            _scratch(model, data, vec6),
            _scratch(model, data, mat66),
            _scratch(model, data, vec6),
        ],
        outputs=[M],
        device=model.device,
    )
    return _arrays.squeeze_env(M, data.num_envs)


def forward_dynamics_aba(model, data, *, joint_forces=None, link_forces=None):
    """(base acceleration (6,), joint accelerations (n,)) by the articulated-body algorithm.

    joint_forces (n,); link_forces (nL, 6) in the data's representation. The base acceleration is the
    derivative of the base velocity in the data's representation (zero for a fixed base).
    """
    from .model import _check_data

    _check_data(model, data)
    transform, vec6, mat66 = _types(model)
    n = model.dofs()
    tau = _input(model, data, joint_forces, "joint_forces", (n,))
    W_f_L = link_forces_inertial(model, data, link_forces)
    nu_dot = _arrays.output((6 + n,), data.batch_size, model.scalar, model.device, data.requires_grad)
    wp.launch(
        aba_kernels(model.scalar).aba,
        dim=data.batch_size,
        inputs=[
            model.parent,
            model.joint_type,
            model.X_tree,
            model.joint_axis,
            model.joint_pivot,
            model.link_mass,
            model.link_com,
            model.link_inertia,
            model.first_child,
            model.next_sibling,
            model.gravity,
            int(model.floating_base()),
            data.base_position_state,
            data.base_quaternion_state,
            data.joint_positions_state,
            data.base_velocity_state,
            data.joint_velocities_state,
            tau,
            W_f_L,
            int(data.velocity_representation),
            _scratch(model, data, transform),
            _scratch(model, data, transform),
            _scratch(model, data, vec6),
            _scratch(model, data, vec6),
            _scratch(model, data, vec6),
            _scratch(model, data, model.scalar),
            _scratch(model, data, model.scalar),
            _scratch(model, data, mat66),
            _scratch(model, data, vec6),
            _scratch(model, data, vec6),
        ],
        outputs=[nu_dot],
        device=model.device,
    )
    return _arrays.squeeze_env(nu_dot[:, :6], data.num_envs), _arrays.squeeze_env(nu_dot[:, 6:], data.num_envs)


def _offset(model) -> int:
    return 0 if model.floating_base() else 6


def forward_dynamics_crb(model, data, *, joint_forces=None, link_forces=None):
    """(base acceleration (6,), joint accelerations (n,)) = M^-1 (B tau - h + sum_L J_L^T f_L), by CRBA
    and a Cholesky solve (not differentiated by wp.Tape: use forward_dynamics_aba for gradients)."""
    n = model.dofs()
    M = free_floating_mass_matrix(model, data)
    M = M if data.num_envs is not None else M.reshape((1, 6 + n, 6 + n))
    zero6 = _arrays.zeros((6,), data.batch_size, model.scalar, model.device)
    zero_n = _arrays.zeros((n,), data.batch_size, model.scalar, model.device)
    tau = _input(model, data, joint_forces, "joint_forces", (n,))
    Q = generalized_forces(model, data, zero6, zero_n, link_forces_inertial(model, data, link_forces))
    rhs = _arrays.empty((6 + n,), data.batch_size, model.scalar, model.device)
    wp.launch(
        state_kernels(model.scalar).actuated_minus, dim=data.batch_size, inputs=[tau, Q], outputs=[rhs], device=model.device
    )
    nu_dot = _arrays.output((6 + n,), data.batch_size, model.scalar, model.device)
    wp.launch(
        cholesky_kernels(model.scalar).solve,
        dim=data.batch_size,
        inputs=[
            M,
            rhs,
            _offset(model),
            _arrays.empty((6 + n, 6 + n), data.batch_size, model.scalar, model.device),
            _arrays.empty((6 + n,), data.batch_size, model.scalar, model.device),
        ],
        outputs=[nu_dot],
        device=model.device,
    )
    return _arrays.squeeze_env(nu_dot[:, :6], data.num_envs), _arrays.squeeze_env(nu_dot[:, 6:], data.num_envs)


def free_floating_mass_matrix_inverse(model, data) -> wp.array:
    """M(q)^-1: (6 + n, 6 + n) or batched; for a fixed base, the inverse of the joint block (zeros elsewhere).
    A Cholesky solve, not differentiated by wp.Tape."""
    n = model.dofs()
    M = free_floating_mass_matrix(model, data)
    M = M if data.num_envs is not None else M.reshape((1, 6 + n, 6 + n))
    Minv = _arrays.output((6 + n, 6 + n), data.batch_size, model.scalar, model.device)
    wp.launch(
        cholesky_kernels(model.scalar).inverse,
        dim=data.batch_size,
        inputs=[
            M,
            _offset(model),
            _arrays.empty((6 + n, 6 + n), data.batch_size, model.scalar, model.device),
            _arrays.empty((6 + n, 6 + n), data.batch_size, model.scalar, model.device),
        ],
        outputs=[Minv],
        device=model.device,
    )
    return _arrays.squeeze_env(Minv, data.num_envs)


def forward_dynamics(model, data, *, joint_forces=None, link_forces=None, prefer_aba: bool = True):
    """Forward dynamics by ABA (default) or by CRBA and a Cholesky solve."""
    solver = forward_dynamics_aba if prefer_aba else forward_dynamics_crb
    return solver(model, data, joint_forces=joint_forces, link_forces=link_forces)
