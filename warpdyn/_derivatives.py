"""Jacobian derivatives and bias accelerations (J̇ and J̇ν) of links and frames.

The input representation (that of ν) is always the data's; the output representation of the frame's
velocity is `output_vel_repr` (default: the data's). J̇ is the time derivative of the Jacobian along the
state's motion (base velocity and joint velocities): d/dt J(q(t)) = Σ_k ∂J/∂q_k q̇_k. For the algorithm
see warpdyn.kernels.jacobian_derivatives.

`generalized_free_floating_jacobian_derivative` and `link_bias_accelerations` are JaxSim's
`jaxsim.api.model` functions (re-exported by warpdyn.model); `link.jacobian_derivative`,
`link.bias_acceleration` and `frame.jacobian_derivative` build on `jacobian_derivatives` and
`bias_accelerations` below.
"""

from __future__ import annotations

import warp as wp

from .engine import launch as launching
from . import arrays as _arrays
from .types.enums import output_repr
from .kernels.jacobian_derivatives import kernels as derivative_kernels

__all__ = [
    "jacobian_derivatives",
    "bias_accelerations",
    "generalized_free_floating_jacobian_derivative",
    "link_bias_accelerations",
]


def _kinematics(model, data) -> tuple[wp.array, wp.array, wp.array]:
    """(W_H_L, W_v_WL, W_a_L), each (N, nL): link poses, Inertial link velocities, and the bias terms
    Σ_j W_v_{W L_j} × W_X_{L_j} S_j ṡ_j (see the kernel module). Checks the data against the model."""
    # Imported here: warpdyn.model re-exports this module's public functions, so a module-level import of
    # warpdyn.model would make an import cycle.
    from . import model as _model

    _model._check_data(model, data)
    _, W_H_L = _model.link_poses(model, data)
    N, nL = data.batch_size, model.number_of_links()
    vec6 = wp.types.vector(6, model.scalar)
    W_v_WL = _arrays.empty((nL,), N, vec6, model.device, data.requires_grad)
    W_a_L = _arrays.empty((nL,), N, vec6, model.device, data.requires_grad)
    launching.launch(
        derivative_kernels(model.scalar).link_bias_recursion,
        dim=N,
        inputs=[
            model.parent,
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            W_H_L,
            data.base_velocity_state,
            data.joint_velocities_state,
        ],
        outputs=[W_v_WL, W_a_L],
        device=model.device,
    )
    return W_H_L, W_v_WL, W_a_L


def jacobian_derivatives(model, data, target_link: wp.array, link_H_target: wp.array, output_vel_repr=None) -> wp.array:
    """(N, T, 6, 6 + n): J̇ of the targets (frames at link_H_target on target_link), the time derivative
    of `warpdyn.model.jacobians(model, data, target_link, link_H_target, output_vel_repr)`.

    Columns act on ν in the data's representation; rows give the target's velocity in output_vel_repr
    (default: the data's). Units: those of J (1, or m for the linear rows of angular columns) per second.
    """
    output_vel_repr = output_repr(data, output_vel_repr)
    W_H_L, W_v_WL, _ = _kinematics(model, data)
    N, T = data.batch_size, target_link.shape[0]
    Jdot = _arrays.output((T, 6, 6 + model.dofs()), N, model.scalar, model.device, data.requires_grad)
    launching.launch(
        derivative_kernels(model.scalar).jacobian_derivatives,
        dim=(N, T),
        inputs=[
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            model.support,
            target_link,
            link_H_target,
            W_H_L,
            W_v_WL,
            int(data.velocity_representation),
            int(output_vel_repr),
        ],
        outputs=[Jdot],
        device=model.device,
    )
    return Jdot


def bias_accelerations(model, data, target_link: wp.array, link_H_target: wp.array, output_vel_repr=None) -> wp.array:
    """(N, T, 6): J̇ν of the targets (frames at link_H_target on target_link), [linear; angular] in
    output_vel_repr (default: the data's), ν in the data's representation [m/s^2, rad/s^2].

    This is the target's acceleration at zero generalized acceleration (ν̇ = 0 in the data's
    representation), in the output representation's sense: d/dt (J ν) = J ν̇ + J̇ ν.
    """
    output_vel_repr = output_repr(data, output_vel_repr)
    W_H_L, W_v_WL, W_a_L = _kinematics(model, data)
    N, T = data.batch_size, target_link.shape[0]
    a = _arrays.output((T, 6), N, model.scalar, model.device, data.requires_grad)
    launching.launch(
        derivative_kernels(model.scalar).bias_accelerations,
        dim=(N, T),
        inputs=[
            target_link,
            link_H_target,
            W_H_L,
            W_v_WL,
            W_a_L,
            int(data.velocity_representation),
            int(output_vel_repr),
        ],
        outputs=[a],
        device=model.device,
    )
    return a


def generalized_free_floating_jacobian_derivative(model, data, *, output_vel_repr=None) -> wp.array:
    """J̇ of every link: (nL, 6, 6 + n), or (N, nL, 6, 6 + n) for batched data.

    The time derivative of `generalized_free_floating_jacobian(model, data, output_vel_repr=...)` along the
    state's motion: columns act on ν in the data's representation, rows give each link's velocity in
    `output_vel_repr` (default: the data's).
    """
    Jdot = jacobian_derivatives(model, data, model.all_links, model.identity_offsets, output_vel_repr)
    return _arrays.squeeze_env(Jdot, data.num_envs)


def link_bias_accelerations(model, data) -> wp.array:
    """J̇ν of every link, in the data's representation: (nL, 6), or (N, nL, 6) for batched data."""
    a = bias_accelerations(model, data, model.all_links, model.identity_offsets, None)
    return _arrays.squeeze_env(a, data.num_envs)
