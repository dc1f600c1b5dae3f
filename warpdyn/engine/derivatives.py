"""Jacobian derivatives and bias accelerations (J̇ and J̇ν) of targets (frames on links).

The input representation (that of ν) is always the data's; the output representation of the target's
velocity is `output_vel_repr` (None: the data's). J̇ is the time derivative of the Jacobian along the
state's motion (base velocity and joint velocities): d/dt J(q(t)) = Σ_k ∂J/∂q_k q̇_k. For the algorithm
see kernels/jacobian_derivatives.py. Results have a leading N axis.
"""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.jacobian_derivatives import kernels as derivative_kernels
from ..types.enums import output_repr
from .bundles import model_bundle, requires_grad
from .kinematics import link_poses, state_of
from .launch import launch

__all__ = ["link_kinematics", "jacobian_derivatives", "bias_accelerations"]


def link_kinematics(model, data) -> tuple[wp.array, wp.array, wp.array]:
    """(W_H_L, W_v_WL, W_a_L), each (N, nL): link poses, Inertial link velocities, and the bias terms
    Σ_j W_v_{W L_j} × W_X_{L_j} S_j ṡ_j (see the kernel module). Checks the data against the model."""
    _, W_H_L = link_poses(model, data)
    N, nL = data.batch_size, model.number_of_links()
    vec6 = wp.types.vector(6, model.scalar)
    W_v_WL = arrays.empty((nL,), N, vec6, model.device, requires_grad(model, data))
    W_a_L = arrays.empty((nL,), N, vec6, model.device, requires_grad(model, data))
    launch(
        derivative_kernels(model.scalar, model.multi_dof()).link_bias_recursion,
        dim=N,
        inputs=[model_bundle(model), W_H_L, state_of(model, data)],
        outputs=[W_v_WL, W_a_L],
        device=model.device,
    )
    return W_H_L, W_v_WL, W_a_L


def jacobian_derivatives(model, data, target, output_vel_repr=None) -> wp.array:
    """(N, T, 6, 6 + n): J̇ of the targets (a kernels' Targets bundle), the time derivative of
    warpdyn.engine.kinematics.jacobians(model, data, target, output_vel_repr). Units: those of J (1, or m
    for the linear rows of angular columns) per second."""
    output_vel_repr = output_repr(data, output_vel_repr)
    W_H_L, W_v_WL, _ = link_kinematics(model, data)
    N, T = data.batch_size, target.link.shape[0]
    Jdot = arrays.output((T, 6, 6 + model.dofs()), N, model.scalar, model.device, requires_grad(model, data))
    launch(
        derivative_kernels(model.scalar, model.multi_dof()).jacobian_derivatives,
        dim=(N, T),
        inputs=[model_bundle(model), target, W_H_L, W_v_WL, int(data.velocity_representation), int(output_vel_repr)],
        outputs=[Jdot],
        device=model.device,
    )
    return Jdot


def bias_accelerations(model, data, target, output_vel_repr=None) -> wp.array:
    """(N, T, 6): J̇ν of the targets, [linear; angular] in output_vel_repr (None: the data's), ν in the data's
    representation [m/s^2, rad/s^2]: the target's acceleration at zero generalized acceleration (ν̇ = 0 in the
    data's representation), in the output representation's sense: d/dt (J ν) = J ν̇ + J̇ ν."""
    output_vel_repr = output_repr(data, output_vel_repr)
    W_H_L, W_v_WL, W_a_L = link_kinematics(model, data)
    N, T = data.batch_size, target.link.shape[0]
    a = arrays.output((T, 6), N, model.scalar, model.device, requires_grad(model, data))
    launch(
        derivative_kernels(model.scalar, model.multi_dof()).bias_accelerations,
        dim=(N, T),
        inputs=[target, W_H_L, W_v_WL, W_a_L, int(data.velocity_representation), int(output_vel_repr)],
        outputs=[a],
        device=model.device,
    )
    return a
