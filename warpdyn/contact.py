"""Collidable points, their kinematics and their soft-contact forces, as JaxSim's `jaxsim.api.contact`.

The points come from the description's collision shapes (`warpdyn._collidable` says how each shape
becomes points, and in which order); a lumped link's points belong to the link it is lumped into.
`model.kin_dyn_parameters.contact_parameters` lists ALL points (`body`, `point`, `enabled`), as JaxSim;
the functions below return the ENABLED points only, in that order: "nc" is their number. Change the
options or the enabled points with `with_collidable_points`.

The contact frame of a point C on link L is C = (W_p_C, [L]): origin at the point, the link's orientation,
as JaxSim's. Results are Warp arrays on the model's device: JaxSim's shapes for single-environment data,
a leading environment axis N for batched data.
"""

from __future__ import annotations

import copy

import numpy as np
import warp as wp

from .engine import launch as launching
from . import arrays as _arrays
from .types import names as _names
from . import model as _model
from .description.collidable import CollidablePointsOptions, NoCollidablePointsWarning, UnresolvedMeshWarning
from .types.kin_dyn import ContactParameters, FrameParameters, KinDynParameters
from ._simulation import estimate_good_contact_parameters
from .types.enums import VelRepr, output_repr
from .kernels.contact_points import kernels as contact_kernels
from .kernels.contact_wrenches import kernels as wrench_kernels

__all__ = [
    "CollidablePointsOptions",
    "ContactParameters",
    "FrameParameters",
    "KinDynParameters",
    "NoCollidablePointsWarning",
    "UnresolvedMeshWarning",
    "with_collidable_points",
    "collidable_point_kinematics",
    "collidable_point_positions",
    "collidable_point_velocities",
    "in_contact",
    "link_contact_forces",
    "collidable_point_forces",
    "estimate_good_contact_parameters",
    "transforms",
    "jacobian",
    "jacobian_derivative",
]


def with_collidable_points(model, *, options: CollidablePointsOptions | None = None, enabled=None, enabled_links=None):
    """A model like `model` (sharing its device constants) with other collidable points.

    options: how shapes become points (`CollidablePointsOptions`); None keeps the model's.
    enabled: a boolean mask over all the points (after `options` are applied), or
    enabled_links: link names whose points are enabled, the others disabled.
    With neither, every point is enabled. `model` itself is left unchanged.

    Example (JaxSim's behaviour: no mesh points; only the feet in contact):
        model = wd.contact.with_collidable_points(
            model, options=wd.contact.CollidablePointsOptions(shapes=("box", "sphere")),
            enabled_links=("l_ankle_2", "r_ankle_2"))
    """
    if enabled is not None and enabled_links is not None:
        raise ValueError("give either enabled (a mask over the points) or enabled_links (link names), not both")
    if options is not None and not isinstance(options, CollidablePointsOptions):
        raise TypeError(f"options must be a CollidablePointsOptions, got {type(options).__name__}")
    params = model.kin_dyn_parameters if options is None else KinDynParameters.build(model, options)
    if enabled_links is not None:
        if isinstance(enabled_links, str):
            enabled_links = (enabled_links,)
        links = {_names.name_to_idx("link", model.link_names(), name) for name in enabled_links}
        enabled = np.array([b in links for b in params.contact_parameters.body], dtype=bool)
    if enabled is None and not all(params.contact_parameters.enabled):  # neither given: every point enabled
        enabled = np.ones(len(params.contact_parameters.body), dtype=bool)
    if enabled is not None:
        params = params.with_enabled(model, enabled)
    new = copy.copy(model)
    new.__dict__["_kin_dyn_parameters"] = params
    return new


def _enabled(model):
    params = model.kin_dyn_parameters
    return params.enabled_link, params.enabled_link_H_point, params.enabled_point


def _positions(model, data) -> wp.array:
    """W_p_C (N, nc, 3)."""
    link, _, L_p_C = _enabled(model)
    _, W_H_L = _model.link_poses(model, data)
    N, nc = data.batch_size, link.shape[0]
    W_p_C = _arrays.output((nc, 3), N, model.scalar, model.device, data.requires_grad)
    launching.launch(
        contact_kernels(model.scalar).point_positions,
        dim=(N, nc),
        inputs=[link, L_p_C, W_H_L],
        outputs=[W_p_C],
        device=model.device,
    )
    return W_p_C


def collidable_point_positions(model, data) -> wp.array:
    """W_p_C: the world positions of the enabled collidable points [m], (nc, 3) or (N, nc, 3)."""
    return _arrays.squeeze_env(_positions(model, data), data.num_envs)


def collidable_point_velocities(model, data) -> wp.array:
    """W_pdot_C: the velocities of the enabled collidable points [m/s], (nc, 3) or (N, nc, 3).

    The plain time derivative of W_p_C in world coordinates (the linear part of the contact frame's
    Mixed velocity), whatever the data's velocity representation.
    """
    link, link_H_point, _ = _enabled(model)
    v = _model.velocities(model, data, link, link_H_point, VelRepr.Mixed)
    N, nc = data.batch_size, link.shape[0]
    W_pdot_C = _arrays.output((nc, 3), N, model.scalar, model.device, data.requires_grad)
    launching.launch(
        contact_kernels(model.scalar).linear_part, dim=(N, nc), inputs=[v], outputs=[W_pdot_C], device=model.device
    )
    return _arrays.squeeze_env(W_pdot_C, data.num_envs)


def collidable_point_kinematics(model, data) -> tuple[wp.array, wp.array]:
    """(W_p_C, W_pdot_C) of the enabled collidable points: each (nc, 3) or (N, nc, 3)."""
    return collidable_point_positions(model, data), collidable_point_velocities(model, data)


def in_contact(model, data, *, link_names=None) -> wp.array:
    """Whether each link touches the terrain (`model.terrain`): any of its enabled points at or below it.

    JaxSim's test: a point C is below when W_p_C.z <= h(W_p_C.x, W_p_C.y), the terrain's height above the
    point's (x, y) (equality counts). The contact force uses the depth delta = (h - z) n_z instead and acts
    only for delta > 0 strictly, so a point exactly on the terrain is "in contact" with zero force.
    link_names: the links asked about (default: all, in the model's order); a link without enabled points
    is never in contact. (nL,) or (N, nL) bool, or (k,) / (N, k) for k given names.
    """
    from ._simulation import _plan

    if link_names is None:
        links = model.all_links
    else:
        if isinstance(link_names, str):
            link_names = (link_names,)
        idx = [_names.name_to_idx("link", model.link_names(), name) for name in link_names]
        links = wp.array(np.asarray(idx, dtype=np.int32), dtype=int, device=model.device)
    point_link, _, _ = _enabled(model)
    W_p_C = _positions(model, data)
    N, K = data.batch_size, links.shape[0]
    plan = _plan(model)
    plan.check_envs(N)
    out = _arrays.output((K,), N, wp.bool, model.device)
    launching.launch(
        wrench_kernels(model.scalar).links_below_terrain,
        dim=(N, K),
        inputs=[point_link, W_p_C, links, *plan.terrain_args],
        outputs=[out],
        device=model.device,
    )
    return _arrays.squeeze_env(out, data.num_envs)


def _check_ignored_inputs(model, data, link_forces, joint_force_references) -> None:
    """Soft contacts do not depend on these (JaxSim passes them to contact models that do): shapes checked."""
    if link_forces is not None:
        _arrays.batched_input(link_forces, "link_forces", (model.number_of_links(), 6), data.num_envs, model.scalar, model.device)
    if joint_force_references is not None:
        _arrays.batched_input(joint_force_references, "joint_force_references", (model.dofs(),), data.num_envs, model.scalar, model.device)


def link_contact_forces(
    model, data, *, link_forces=None, joint_force_references=None, joint_torques=None, output_vel_repr=None
) -> wp.array:
    """The contact wrench on each link: (nL, 6) or (N, nL, 6), [force; torque], in `output_vel_repr`
    (default: the data's representation), for the link frame L:
    - Inertial: W_f_L = sum over L's enabled points C of [f_C; W_p_C x f_C] (torque about the world origin),
      what JaxSim 0.9's `link_contact_forces` returns and what `step` adds to the link's external force;
    - Mixed: the same force with its torque about the link origin, world axes: [f; tau_W - W_p_L x f];
    - Body: L_X*_W W_f_L, force and torque at the link origin in link axes.
    The point forces are the soft-contact forces (`model.contact_params`, `model.terrain`) at the data's
    state, the ones a step starting there applies. Links without enabled points get zeros.
    link_forces, joint_force_references (alias joint_torques, JaxSim's name): accepted as JaxSim does;
    soft contacts do not depend on them.
    """
    from ._simulation import _contact_evaluation

    if joint_torques is not None:
        if joint_force_references is not None:
            raise ValueError("give joint_force_references or joint_torques (the same argument), not both")
        joint_force_references = joint_torques
    _check_ignored_inputs(model, data, link_forces, joint_force_references)
    out_repr = output_repr(data, output_vel_repr)
    plan, ev = _contact_evaluation(model, data)
    N, nL = data.batch_size, model.number_of_links()
    out = _arrays.output((nL, 6), N, model.scalar, model.device, data.requires_grad)
    if ev is None:
        out.zero_()
    else:
        launching.launch(
            wrench_kernels(model.scalar).link_wrenches,
            dim=(N, nL),
            inputs=[plan.link_first_point, ev.W_H_L, ev.chain, int(out_repr)],
            outputs=[out],
            device=model.device,
        )
    return _arrays.squeeze_env(out, data.num_envs)


def collidable_point_forces(model, data, *, link_forces=None, joint_force_references=None, output_vel_repr=None) -> wp.array:
    """The soft-contact wrench on each enabled point: (nc, 6) or (N, nc, 6), as old JaxSim's
    `collidable_point_forces`, for the contact frame C = (W_p_C, [L]) in `output_vel_repr` (default: the
    data's): Inertial [f; W_p_C x f]; Mixed [f; 0] (f the force in world axes [N], what the contact model
    computes); Body [L_R_W f; 0]. Summed over a link's points (Inertial), they give `link_contact_forces`.
    link_forces, joint_force_references: accepted as JaxSim does; soft contacts do not depend on them.
    """
    from ._simulation import _contact_evaluation

    _check_ignored_inputs(model, data, link_forces, joint_force_references)
    out_repr = output_repr(data, output_vel_repr)
    plan, ev = _contact_evaluation(model, data)
    N = data.batch_size
    out = _arrays.output((plan.count, 6), N, model.scalar, model.device, data.requires_grad)
    if ev is not None:
        launching.launch(
            wrench_kernels(model.scalar).point_wrenches,
            dim=(N, plan.count),
            inputs=[plan.point_link, plan.L_p_C, plan.point_out, ev.W_H_L, ev.W_f_C, int(out_repr)],
            outputs=[out],
            device=model.device,
        )
    return _arrays.squeeze_env(out, data.num_envs)


def transforms(model, data) -> wp.array:
    """W_H_C: the contact frames of the enabled points, C = (W_p_C, [L]) with L the point's link,
    (nc, 4, 4) or (N, nc, 4, 4)."""
    link, link_H_point, _ = _enabled(model)
    _, W_H_L = _model.link_poses(model, data)
    H = _model.homogeneous(model, W_H_L, link, link_H_point, data.requires_grad)
    return _arrays.squeeze_env(H, data.num_envs)


def jacobian(model, data, *, output_vel_repr=None) -> wp.array:
    """The free-floating Jacobians of the enabled points' contact frames: (nc, 6, 6 + n) or (N, nc, 6, 6 + n).

    Columns act on the generalized velocity in the data's representation; rows give the contact
    frame's velocity in `output_vel_repr` (default: the data's): Inertial W_v_WC (= the link's), Body
    C_v_WC, Mixed C[W]_v_WC = [W_pdot_C; W_omega_WL].
    """
    link, link_H_point, _ = _enabled(model)
    J = _model.jacobians(model, data, link, link_H_point, output_vel_repr)
    return _arrays.squeeze_env(J, data.num_envs)


def jacobian_derivative(model, data, *, output_vel_repr=None) -> wp.array:
    """The time derivatives of `jacobian(...)`: (nc, 6, 6 + n) or (N, nc, 6, 6 + n), same representations."""
    from ._derivatives import jacobian_derivatives

    link, link_H_point, _ = _enabled(model)
    Jdot = jacobian_derivatives(model, data, link, link_H_point, output_vel_repr)
    return _arrays.squeeze_env(Jdot, data.num_envs)
