"""Collidable points: their kinematics, and the soft-contact wrenches of a step's first evaluation, in the
façade's representations (kernels/contact_points.py, kernels/contact_wrenches.py).

The enabled points are targets (frames on links, kernels/bundles.py: Targets) at (L_p_C, identity
rotation): the contact frame C = (W_p_C, [L]). Results have a leading N axis.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.contact_points import kernels as point_kernels
from ..kernels.contact_wrenches import kernels as wrench_kernels
from ..kernels.forces import kernels as force_kernels
from ..types.contact_models import RelaxedRigidContacts, RigidContacts, SoftContacts, register_forces, register_impact
from ..types.enums import VelRepr
from . import collisions
from .bundles import requires_grad, state_bundle
from .contact_stage import point_frames
from .evaluations import contact_evaluation, deformation_rates
from .forces import forces_in, forces_inertial
from .kinematics import link_poses, state_arrays, targets, velocities
from .launch import launch, run
from .step import Evaluation, link_force_input, plan, prepare, torque_reference_input

__all__ = ["point_targets", "positions", "point_velocities", "link_wrenches", "link_wrenches_and_rates", "point_wrenches", "soft_contact_forces", "solved_contact_forces", "rigid_impact", "other_forces", "links_in_contact"]


def point_targets(model):
    """The enabled collidable points as the kernels' Targets (their link, and (L_p_C, identity) in it; one row per
    environment where update_hw_parameters scaled the links per environment)."""
    return model.cached("point targets", lambda: _point_targets(model))


def _point_targets(model):
    params = model.kin_dyn_structure()
    return targets(model, params.enabled_link, point_frames(model, params.contact_parameters.indices_of_enabled_collidable_points))


def positions(model, data, W_H_L: wp.array | None = None) -> wp.array:
    """W_p_C (N, nc, 3) [m]: the world positions of the enabled points (W_H_L: the data's link poses, if at hand)."""
    target = point_targets(model)
    if W_H_L is None:
        _, W_H_L = link_poses(model, data)
    N, nc = data.batch_size, target.link.shape[0]
    W_p_C = arrays.output((nc, 3), N, model.scalar, model.device, requires_grad(model, data))
    launch(point_kernels(model.scalar).point_positions, dim=(N, nc), inputs=[target, W_H_L], outputs=[W_p_C], device=model.device)
    return W_p_C


def point_velocities(model, data) -> wp.array:
    """W_pdot_C (N, nc, 3) [m/s]: the plain time derivative of W_p_C (the linear part of the contact frame's
    Mixed velocity), whatever the data's representation."""
    v = velocities(model, data, point_targets(model), VelRepr.Mixed)
    N, nc = v.shape[0], v.shape[1]
    W_pdot_C = arrays.output((nc, 3), N, model.scalar, model.device, requires_grad(model, data))
    launch(point_kernels(model.scalar).linear_part, dim=(N, nc), inputs=[v], outputs=[W_pdot_C], device=model.device)
    return W_pdot_C


def link_wrenches(model, data, out_repr: int) -> wp.array:
    """(N, nL, 6): the contact wrench on each link in representation `out_repr` (see
    warpdyn.contact.link_contact_forces), zero for links without enabled points."""
    return link_wrenches_and_rates(model, data, out_repr)[0]


def other_forces(model, data, link_forces, joint_force_references) -> tuple:
    """(W_f_ext (N, nL, 6) Inertial or None, tau (N, n) or None): the link forces (in the data's representation)
    and joint forces that act besides the contacts, as a contact evaluation takes them, checked; both None for a
    contact model that does not read them (the soft law)."""
    current = plan(model)
    W_f_ext = link_force_input(current, data, link_forces)
    tau = torque_reference_input(current, data, joint_force_references) if joint_force_references is not None else None
    if not current.contact_stage.reads_other_forces:
        return None, None
    if W_f_ext is not None and data.velocity_representation != VelRepr.Inertial:
        W_f_ext = forces_inertial(model, data, W_f_ext, int(data.velocity_representation))
    return W_f_ext, tau


def link_wrenches_and_rates(model, data, out_repr: int, W_f_ext=None, tau=None) -> tuple[wp.array, wp.array]:
    """((N, nL, 6) `link_wrenches`, m_dot (N, rows, 3) the deformation rates (Model.contact_state_rows)) of one contact evaluation
    (W_f_ext, tau: `other_forces`)."""
    current, ev = contact_evaluation(model, data, W_f_ext, tau)
    N, nL = data.batch_size, model.number_of_links()
    grad = data.requires_grad if ev is None else ev.grad  # the evaluation's: the data, the forces given or the model's parameters
    if ev is not None and current.contact_stage.pairs:  # the stage's W_f_L: its points' and geom pairs' wrenches (+ W_f_ext)
        W_f_L = ev.W_f_L
        if W_f_ext is not None:  # a solved law's W_f_L holds the link forces acting on its free accelerations too
            W_f_L = arrays.output((nL, 6), N, model.scalar, model.device, grad)
            launch(force_kernels(model.scalar).difference, dim=(N, nL, 6), inputs=[ev.W_f_L, W_f_ext], outputs=[W_f_L], device=model.device)
        return forces_in(model, data, W_f_L, out_repr), deformation_rates(current, ev, N)
    out = arrays.output((nL, 6), N, model.scalar, model.device, grad)
    if ev is None:
        out.zero_()
    else:
        launch(
            wrench_kernels(model.scalar).link_wrenches,
            dim=(N, nL),
            inputs=[current.contact_bundle, ev.W_H_L, ev.W_f_C, int(out_repr)],
            outputs=[out],
            device=model.device,
        )
    return out, deformation_rates(current, ev, N)


def point_wrenches(model, data, out_repr: int, W_f_ext=None, tau=None) -> wp.array:
    """(N, nc, 6): each enabled point's contact wrench for C = (W_p_C, [L]) in representation `out_repr`
    (see warpdyn.contact.collidable_point_forces; W_f_ext, tau: `other_forces`)."""
    return _point_wrenches(model, data, out_repr, *contact_evaluation(model, data, W_f_ext, tau))


def soft_contact_forces(model, data, link_forces=None, joint_force_references=None) -> tuple:
    """SoftContacts.compute_contact_forces (warpdyn.types.contact_models): (W_f_C (N, nc, 6), the enabled
    points' Inertial contact wrenches [f; W_p_C x f], {"m_dot": (N, rows, 3)}, the deformation rates, 0
    for disabled points), with the data's environment axis; link_forces and joint_force_references do not
    act on the soft law."""
    current, ev = contact_evaluation(model, data)
    W_f_C = _point_wrenches(model, data, int(VelRepr.Inertial), current, ev)
    m_dot = deformation_rates(current, ev, data.batch_size)
    return arrays.squeeze_env(W_f_C, data.num_envs), {"m_dot": arrays.squeeze_env(m_dot, data.num_envs)}


register_forces(SoftContacts, soft_contact_forces)


def solved_contact_forces(model, data, link_forces=None, joint_force_references=None) -> tuple:
    """RigidContacts' and RelaxedRigidContacts' compute_contact_forces (warpdyn.types.contact_models): (W_f_C
    (N, nc, 6), the enabled points' Inertial contact wrenches, {}), with the data's environment axis, the link
    forces (in the data's representation) and joint forces acting besides the contacts."""
    W_f_ext, tau = other_forces(model, data, link_forces, joint_force_references)
    W_f_C = point_wrenches(model, data, int(VelRepr.Inertial), W_f_ext, tau)
    return arrays.squeeze_env(W_f_C, data.num_envs), {}


register_forces(RigidContacts, solved_contact_forces)
register_forces(RelaxedRigidContacts, solved_contact_forces)


def rigid_impact(model, data):
    """RigidContacts.update_velocity_after_impact: a copy of the data after the impact at its state (the stage's
    `after_step` on the copy's arrays; under a wp.Tape its adjoint is registered where gradients are required)."""
    current, N = prepare(model, data, parameters=False)
    out = data.copy()
    if current.contacts:
        grad = data.requires_grad or model.parameters_require_grad()
        if grad:  # the impact's adjoint reads the copy's gradients (the model's parameters may be all that requires them)
            for a in state_arrays(out)[:5]:
                a.requires_grad = True
        ev = Evaluation(current, N, grad, False, None, aba=False)
        run(current.contact_stage.after_step(current, ev, state_bundle(current.scalar, state_arrays(out)), N), current.device)
    return out


register_impact(RigidContacts, rigid_impact)


def _point_wrenches(model, data, out_repr: int, current, ev) -> wp.array:
    N = data.batch_size
    out = arrays.output((current.count, 6), N, model.scalar, model.device, data.requires_grad if ev is None else ev.grad)
    if ev is not None:
        launch(
            wrench_kernels(model.scalar).point_wrenches,
            dim=(N, current.count),
            inputs=[current.contact_bundle, current.point_out, ev.W_H_L, ev.W_f_C, int(out_repr)],
            outputs=[out],
            device=model.device,
        )
    return out


def links_in_contact(model, data, link_indices) -> wp.array:
    """(N, K) bool: whether each of the links `link_indices` (None: all) has an enabled point at or below the
    terrain or, where model.geom_contacts is set, a geom pair's contact at dist <= 0 (see warpdyn.contact.in_contact)."""
    if link_indices is None:
        links = model.all_links
    else:
        links = wp.array(np.asarray(link_indices, dtype=np.int32), dtype=int, device=model.device)
    _, W_H_L = link_poses(model, data)
    W_p_C = positions(model, data, W_H_L)
    current = plan(model)
    N, K = data.batch_size, links.shape[0]
    current.check_envs(N)
    out = arrays.output((K,), N, wp.bool, model.device)
    launch(
        wrench_kernels(model.scalar).links_below_terrain,
        dim=(N, K),
        inputs=[point_targets(model).link, W_p_C, links, current.terrain],
        outputs=[out],
        device=model.device,
    )
    if model.geom_contacts:
        collisions.mark_links_touching(model, W_H_L, links, out)
    return out
