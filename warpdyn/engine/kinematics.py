"""Kinematics launches: link poses, homogeneous matrices, Jacobians and velocities of targets.

A target is a frame rigidly attached to a link (a link itself, a frame, a collidable point), given as the
kernels' `Targets` bundle: (T,) link indices and (T,) poses in their links. Results are (N, T, ...) Warp
arrays in the device's layout (warpdyn.arrays); the caller drops the environment axis of
single-environment data.
"""

from __future__ import annotations

import operator

import warp as wp

from .. import arrays
from ..kernels.bundles import bundles
from ..kernels.jacobians import kernels as jacobian_kernels
from ..kernels.kinematics import kernels as kinematics_kernels
from ..kernels.velocities import kernels as velocity_kernels
from ..types.enums import output_repr
from ..types.data_checks import check_data, state_arrays
from .bundles import model_bundle, requires_grad, state_bundle
from .launch import launch

__all__ = ["state_arrays", "state_of", "targets", "link_targets", "link_poses", "homogeneous", "inverse_adjoints", "poses", "jacobians", "velocities"]


def state_of(model, data, checked: list | None = None):
    """The kernels' State bundle of `data`, kept on the data while its state arrays are the same objects
    (a Data's fields are replaced, not written, by warpdyn; a bundle costs ~10 us of Python to fill).
    checked: what check_data returned for the data just now (its state arrays, a list the checks keep while
    those arrays stay), so that a bundle kept with that list is found by one identity test."""
    cached = data.__dict__.get("_state_bundle")
    if checked is not None and cached is not None and cached[0] is checked:
        return cached[1]
    state = state_arrays(data) if checked is None else checked
    if cached is not None and len(cached[0]) == len(state) and all(map(operator.is_, cached[0], state)):
        bundle = cached[1]
    else:
        bundle = state_bundle(model.scalar, state)
    data.__dict__["_state_bundle"] = (state, bundle)
    return bundle


def targets(model, link: wp.array, link_H_target: wp.array):
    """The kernels' Targets bundle: (T,) link indices and (T,) transforms (shared) or (P, T) (one row per
    environment) on the model's device."""
    bundle = bundles(model.scalar).Targets()
    bundle.link = link
    bundle.link_H_target = link_H_target if link_H_target.ndim == 2 else link_H_target.reshape((1, link_H_target.shape[0]))
    return bundle


def link_targets(model):
    """The links themselves as targets (identity offsets), cached on the model."""
    return model.cached("link targets", lambda: targets(model, model.all_links, model.identity_offsets))


def link_poses(model, data) -> tuple[wp.array, wp.array]:
    """(parent_H_link, W_H_L), each (N, nL) Warp transforms: one launch of forward kinematics."""
    check_data(model, data)
    N, nL = data.batch_size, model.number_of_links()
    transform = wp.types.transformation(model.scalar)
    parent_H_link = arrays.empty((nL,), N, transform, model.device, requires_grad(model, data))
    W_H_L = arrays.empty((nL,), N, transform, model.device, requires_grad(model, data))
    launch(
        kinematics_kernels(model.scalar, model.multi_dof()).forward_kinematics,
        dim=N,
        inputs=[model_bundle(model), state_of(model, data)],
        outputs=[parent_H_link, W_H_L],
        device=model.device,
    )
    return parent_H_link, W_H_L


def homogeneous(model, poses: wp.array, target, requires_grad=False) -> wp.array:
    """(N, T, 4, 4) homogeneous matrices of the targets, poses (N, nL) the links' (or their parents')."""
    N, T = poses.shape[0], target.link.shape[0]
    H = arrays.output((T, 4, 4), N, model.scalar, model.device, requires_grad)
    launch(kinematics_kernels(model.scalar, model.multi_dof()).homogeneous_matrices, dim=(N, T), inputs=[poses, target], outputs=[H], device=model.device)
    return H


def inverse_adjoints(model, poses: wp.array, requires_grad=False) -> wp.array:
    """(N, K, 6, 6): B_X_A, the motion adjoint of each pose A_H_B in poses (N, K)."""
    N, K = poses.shape
    X = arrays.output((K, 6, 6), N, model.scalar, model.device, requires_grad)
    launch(kinematics_kernels(model.scalar, model.multi_dof()).inverse_adjoints, dim=(N, K), inputs=[poses], outputs=[X], device=model.device)
    return X


def poses(model, data, target) -> wp.array:
    """(N, T, 4, 4): the targets' poses in the world, W_H_T, by forward kinematics."""
    _, W_H_L = link_poses(model, data)
    return homogeneous(model, W_H_L, target, requires_grad(model, data))


def jacobians(model, data, target, output_vel_repr) -> wp.array:
    """(N, T, 6, 6 + n) free-floating Jacobians of the targets: columns act on the generalized velocity in
    the data's representation, rows give the target's velocity in `output_vel_repr` (None: the data's)."""
    output_vel_repr = output_repr(data, output_vel_repr)
    _, W_H_L = link_poses(model, data)
    N, T = data.batch_size, target.link.shape[0]
    J = arrays.output((T, 6, 6 + model.dofs()), N, model.scalar, model.device, requires_grad(model, data))
    launch(
        jacobian_kernels(model.scalar, model.multi_dof()).jacobians,
        dim=(N, T),
        inputs=[model_bundle(model), target, W_H_L, int(data.velocity_representation), int(output_vel_repr)],
        outputs=[J],
        device=model.device,
    )
    return J


def velocities(model, data, target, output_vel_repr) -> wp.array:
    """(N, T, 6) velocities of the targets in `output_vel_repr` (None: the data's)."""
    output_vel_repr = output_repr(data, output_vel_repr)
    _, W_H_L = link_poses(model, data)
    N, T = data.batch_size, target.link.shape[0]
    W_v_WL = arrays.empty((model.number_of_links(),), N, wp.types.vector(6, model.scalar), model.device, requires_grad(model, data))
    v = arrays.output((T, 6), N, model.scalar, model.device, requires_grad(model, data))
    launch(
        velocity_kernels(model.scalar, model.multi_dof()).link_velocities,
        dim=N,
        inputs=[model_bundle(model), target, W_H_L, state_of(model, data), int(output_vel_repr)],
        outputs=[W_v_WL, v],
        device=model.device,
    )
    return v
