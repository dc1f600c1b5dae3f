"""A model's quantities at a state, made of the step's stages (warpdyn.engine.step): the joint torques a step
applies (`resultant_torques`, JaxSim's actuation model), the torque-speed curve's bounds (`torque_limits`),
one contact evaluation (`contact_evaluation`, `contact_forces`), and one step with given joint torques
(`integrate`, JaxSim's integrator functions). Each launches the step's own kernels on fresh arrays, so that
a tape records them and gradients flow."""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.actuation import kernel as actuation_kernel
from ..kernels.actuation import torque_speed_curve
from ..types.enums import IntegratorType, VelRepr
from .bundles import state_bundle
from .kinematics import state_arrays
from .launch import Launch, run
from .step import (
    Evaluation,
    Plan,
    Workspace,
    ctrl_input,
    evaluate,
    inputs_require_grad,
    joint_forces,
    prepare,
    state_buffers,
    step_inputs,
    step_launches,
    torque_reference_input,
    with_state,
)

__all__ = ["resultant_torques", "torque_limits", "contact_evaluation", "contact_forces", "integrate"]


def resultant_torques(model, data, joint_force_references, ctrl=None, jaxsim_only: bool = False) -> wp.array:
    """tau (N, n): the joint forces a step applies, from the references and the actuators' controls (see
    kernels/actuation.py); jaxsim_only: JaxSim's part alone (references, friction, limits, the torque-speed
    curve), without MuJoCo's passive forces and actuators."""
    current, N = prepare(model, data)
    tau_ref = torque_reference_input(current, data, joint_force_references)
    u = ctrl_input(current, data, ctrl)
    if current.n == 0:
        return arrays.empty((0,), N, current.scalar, current.device)
    grad = data.requires_grad or inputs_require_grad(tau_ref, u) or model.parameters_require_grad()
    tau = arrays.output((current.n,), N, current.scalar, current.device, grad)
    X = state_bundle(current.scalar, state_arrays(data))
    if jaxsim_only:
        kernel = actuation_kernel(current.scalar, current.with_limits, current.with_friction, multi_dof=current.multi_dof, static_friction=current.static_friction)
        run([Launch(kernel, (N, current.n), [current.model, *current.torque_curve, X, tau_ref, u], [tau])], current.device)
        return tau
    held = arrays.output((current.n,), N, current.scalar, current.device, grad) if current.stage_forces else None
    run(joint_forces(current, X, tau_ref, u, tau, held), current.device)
    return tau


def torque_limits(model, data) -> wp.array:
    """tau_lim (N, n) [N m or N]: JaxSim's torque-speed curve at each joint's velocity (kernels/actuation.py)."""
    current, N = prepare(model, data, parameters=False)
    tau_lim = arrays.output((current.n,), N, current.scalar, current.device, data.requires_grad)
    if current.n > 0:
        X = state_bundle(current.scalar, state_arrays(data))
        run([Launch(torque_speed_curve(current.scalar).torque_limits, (N, current.n), [*current.torque_curve, X], [tau_lim])], current.device)
    return tau_lim


def contact_evaluation(model, data, W_f_ext=None, tau=None) -> tuple[Plan, Evaluation | None]:
    """(plan, ev): ev holds FK, link velocities and the contact kernel's results at the data's state (fresh
    arrays), None without enabled points. W_f_ext (N, nL, 6) Inertial or None (zero); tau (N, n) the joint
    forces or None (zero): the forces that act besides the contacts, which JaxSim's rigid models read."""
    current, N = prepare(model, data, parameters=False)
    if not current.contacts:
        return current, None
    grad = data.requires_grad or inputs_require_grad(W_f_ext, tau) or model.parameters_require_grad()
    ev = Evaluation(current, N, grad, W_f_ext is not None, None, aba=False)
    X = state_bundle(current.scalar, state_arrays(data))
    run(evaluate(current, ev, X, tau, W_f_ext, False, aba=False), current.device)
    return current, ev


def contact_forces(model, data, W_f_ext: wp.array | None = None, tau: wp.array | None = None):
    """(W_f_C (N, nc, 6), m_dot (N, rows, 3), W_f_L (N, nL, 6)): the Inertial contact wrench of each
    enabled point (ordered by link), the deformation rate of every row of the contact state, and W_f_ext (Inertial; None: zero)
    plus the contact wrenches per link; tau (N, n): the joint forces (None: zero), read by the rigid models."""
    current, ev = contact_evaluation(model, data, W_f_ext, tau)
    N, s, d = data.batch_size, current.scalar, current.device
    if ev is None:
        W_f_L = W_f_ext
        if W_f_L is None:
            W_f_L = arrays.zeros((current.nL, 6), N, s, d)
        return arrays.output((0, 6), N, s, d), deformation_rates(current, ev, N), W_f_L
    return ev.W_f_C, ev.m_dot, ev.W_f_L


def deformation_rates(current: Plan, ev: Evaluation | None, N: int) -> wp.array:
    """m_dot (N, rows, 3) [m/s] (Model.contact_state_rows) of a contact evaluation (`contact_evaluation`): zeros without enabled points."""
    if ev is not None:
        return ev.m_dot
    m_dot = arrays.output((current.state_rows, 3), N, current.scalar, current.device)
    m_dot.zero_()
    return m_dot


def integrate(model, data, integrator, link_forces=None, joint_torques=None):
    """New Data after one step of `integrator` (an IntegratorType) from `data`, with the joint torques
    `joint_torques` (N, n) given as JaxSim's actuation model's output (see step_launches' torques_given; None:
    zero) and the Inertial link forces `link_forces` (N, nL, 6) or None: JaxSim's integrator functions
    (warpdyn.integrators). Fresh arrays, launched without recording (a tape records them)."""
    integrator = IntegratorType(integrator)
    twin = model if model.integrator == integrator else model.cached(("integrator twin", integrator), lambda: model.replace(integrator=integrator))
    current, N = prepare(twin, data, health=True)
    tau, f_user, u = step_inputs(current, data, joint_torques, link_forces, None)
    grad = data.requires_grad or inputs_require_grad(tau, f_user) or model.parameters_require_grad()
    y = state_buffers(current, N, grad)
    ws = Workspace(current, N, grad, f_user is not None)
    launches = step_launches(current, ws, state_arrays(data), y, tau, f_user, int(VelRepr.Inertial), ctrl=u, torques_given=True)
    run(launches, current.device)
    return with_state(data, y)
