"""Equations of motion: RNEA, CRBA and ABA launches, and the Cholesky solves of CRB forward dynamics.

    M(q) nu_dot + h(q, nu) = B tau + sum_L J_L^T f_L,      h = C(q, nu) nu + g(q),

with nu, nu_dot, the base part of every generalized force, and the link forces f_L all in the data's
velocity representation (JaxSim's convention). Each function is one kernel launch (the kernels convert
link forces from the data's representation themselves).

Cost of a call. Outside a `wp.Tape`, a call uses the calling thread's workspace for the model and the data's
batch size (`_Workspace`, one lookup per call): each kernel keeps there a scratch array and a recorded launch
(warpdyn.engine.launch.Recorded), so that a call packs only the arguments that changed since the last one.
Its outputs are arrays that the caller owns, from the workspace's output pools (warpdyn.engine.pool: handed
out again only once nothing else refers to them; fresh when gradients are needed or in a graph capture), and
on the CPU its inputs are copied, after their checks, into the workspace's buffers (`_input`), so that a call
allocates nothing and re-packs nothing. Under a tape every call gets fresh scratch and outputs (with gradients
when the data, an input or a mass parameter requires them), since the adjoint reads them later, and reads its
inputs in place. Absent inputs (no joint forces, no link forces, zero accelerations) reach the kernels as empty
arrays, which skip that work.
Gradients reach the model's link parameters (their .grad) under a tape once they require gradients
(`warpdyn.model.parameters_requiring_grad`).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from .. import arrays, config
from ..kernels.aba import ABA_RECORD
from ..kernels.aba import kernels as aba_kernels
from ..kernels.actuation import mujoco_kernel
from ..kernels.cholesky import kernels as cholesky_kernels
from ..kernels.crba import CRBA_RECORD
from ..kernels.crba import kernels as crba_kernels
from ..kernels.forces import kernels as force_kernels
from ..kernels.rnea import RNEA_RECORD
from ..kernels.rnea import kernels as rnea_kernels
from ..kernels.scratch import TRANSFORM
from ..kernels.state import kernels as state_kernels
from ..types.data_checks import check_data
from . import pool, tape, warp_private
from .input_buffers import InputBuffers
from .bundles import controls_bundle, empty_like_input, model_bundle, model_bundle_and_grad, requires_grad, requires_grad_with
from .kinematics import link_poses, state_of
from .launch import Launch, Recorded, launch, per_thread

__all__ = [
    "requires_grad",
    "generalized_forces",
    "inverse_dynamics",
    "mass_matrix",
    "forward_dynamics_aba",
    "forward_dynamics_crb",
    "mass_matrix_inverse",
    "actuator_forces",
    "passive_forces",
]

_KERNELS = {
    "aba": lambda scalar, registers, multi_dof: aba_kernels(scalar, registers, multi_dof).aba,
    "rnea": lambda scalar, registers, multi_dof: rnea_kernels(scalar, registers, multi_dof).rnea,
    "crba": lambda scalar, registers, multi_dof: crba_kernels(scalar, registers, multi_dof).crba,
}


class _Workspace:
    """What one thread's dynamics calls on a model keep for data of one batch size and shape (see `_workspace`):
    the input buffers (`buffers`) and their Controls bundles (`controls`), the output pools by shapes (`pools`), and each
    kernel with its scratch and recorded launch by (kernel name, scratch width, register setting) (`launches`)."""

    __slots__ = ("buffers", "controls", "pools", "launches")

    def __init__(self, model, N: int):
        self.buffers = InputBuffers(model.scalar, model.device, N)
        self.controls: dict = {}  # (id of joint forces, id of link forces) -> Controls bundle of the buffers
        self.pools: dict = {}
        self.launches: dict = {}


def _workspace(model, data) -> _Workspace:
    """The calling thread's `_Workspace` for `data`'s batch size and shape (one lookup per call)."""
    N, batched = data.batch_size, data.num_envs is not None
    return per_thread(model, ("dynamics", N, batched), lambda: _Workspace(model, N))


def _launch(model, name: str, N: int, width: int, inputs: list, outputs: list, grad: bool, taping: bool, ws: _Workspace) -> None:
    """Launch the kernel `name` over N environments: inputs, then the scratch (N, model.scratch_rows(), width), then
    outputs.

    Under a tape: fresh scratch (with gradients when `grad`) and a plain launch. Otherwise the workspace's
    recorded launch for this kernel, re-packing only the arguments that are not the ones it holds.
    """
    device = model.device
    block_dim, registers = config.cuda_launch.get(name, (None, "tuned")) if device.is_cuda else (None, "tuned")
    if taping:
        scratch = arrays.empty((model.scratch_rows(), width), N, model.scalar, device, grad)
        launch(_KERNELS[name](model.scalar, registers, model.multi_dof()), N, [*inputs, scratch], outputs, device=device, block_dim=block_dim)
        return
    entry = ws.launches.get((name, width, registers))
    if entry is None:
        scratch = arrays.empty((model.scratch_rows(), width), N, model.scalar, device)
        entry = ws.launches[(name, width, registers)] = (_KERNELS[name](model.scalar, registers, model.multi_dof()), scratch, Recorded())
    kernel, scratch, recorded = entry
    recorded.run([Launch(kernel, N, [*inputs, scratch], outputs, block_dim)], device)


def _constant(scalar, value: float):
    """`scalar(value)`, one object per (scalar, value), so that a recorded launch sees the argument it holds."""
    key = (scalar, value)
    constant = _CONSTANTS.get(key)
    if constant is None:
        constant = _CONSTANTS[key] = scalar(value)
    return constant


_CONSTANTS: dict = {}


def _input(model, data, value, name: str, per_env: tuple, taping: bool, ws: _Workspace):
    """None for an absent input, else its (N, *per_env) device array (checked: shape, dtype, device, finite).

    On the CPU outside a tape and a graph capture, a value that requires no gradient is copied (after the same
    checks) into the workspace's buffer for `name` (warpdyn.engine.input_buffers): the kernel, launched at once, reads the same
    numbers, and the launch argument and its Controls bundle stay the same objects from call to call."""
    if value is None:
        return None
    device = model.device
    if not taping and device.is_cpu and not (isinstance(value, wp.array) and value.requires_grad) and not device.is_capturing:
        value = arrays.checked_input(value, name, per_env, data.num_envs, model.scalar, device)
        return ws.buffers.fill(name, per_env, value)
    return arrays.batched_input(value, name, per_env, data.num_envs, model.scalar, device)


def _controls(model, ws: _Workspace, joint_forces, link_forces):
    """controls_bundle of the inputs, made once for the workspace's buffers (see `_input`)."""
    if joint_forces is None and link_forces is None:
        return controls_bundle(model.scalar, model.device)
    mine = ws.buffers.mine
    if (joint_forces is None or id(joint_forces) in mine) and (link_forces is None or id(link_forces) in mine):
        key = (id(joint_forces), id(link_forces))
        bundle = ws.controls.get(key)
        if bundle is None:
            bundle = ws.controls[key] = controls_bundle(model.scalar, model.device, joint_forces, link_forces)
        return bundle
    return controls_bundle(model.scalar, model.device, joint_forces, link_forces)


class _Outputs:
    """Output arrays for a kernel: what the caller gets (`user`) and what the kernel writes (`args`).

    Batched data: (N, *shape) arrays in the device's layout. Single-environment data gets arrays of JaxSim's
    shapes; the kernel sees them with a leading axis of 1, through launch descriptors outside a tape (no view
    objects) and as views of (1, *shape) arrays under one (gradients flow through views).

    Outside a tape and a graph capture, without gradients, the arrays come from the workspace's output pool for
    the shapes (warpdyn.engine.pool: handed out again once nothing else refers to them) and the
    kernel writes them through the pool's aliases or descriptors (`slot`: the set, whose `cache` keeps what a
    caller derives from it); otherwise they are fresh, and batched data's are given to both.
    """

    def __init__(self, model, data, shapes, grad: bool, taping: bool, ws: _Workspace):
        s, d, N = model.scalar, model.device, data.batch_size
        self.slot = None
        if not (grad or taping) and pool.available() and not d.is_capturing:
            shapes = tuple(shapes)
            outputs = ws.pools.get(shapes)
            if outputs is None:
                outputs = ws.pools[shapes] = _output_pool(model, shapes, N, data.num_envs is not None)
            slot = outputs.take()
            if slot is not None:
                self.slot, self.user, self.args = slot, pool.OutputPool.hand_out(slot), slot.shadow
                return
        if data.num_envs is not None:
            self.user = [arrays.output(shape, N, s, d, grad) for shape in shapes]
            self.args = self.user
        elif taping:
            self.args = [arrays.output(shape, 1, s, d, grad) for shape in shapes]
            self.user = [arrays.squeeze_env(a, None) for a in self.args]
        else:
            self.user = [arrays.fill_outputs_with_nan(wp.empty(shape, dtype=s, device=d, requires_grad=grad)) for shape in shapes]
            self.args = [env_axis_descriptor(a) for a in self.user]


def _output_pool(model, shapes: tuple, N: int, batched: bool) -> pool.OutputPool:
    """The pool of output sets of `shapes`: (N, *shape) arrays written through aliases (batched data), or
    arrays of JaxSim's shapes written through launch descriptors (single-environment data)."""
    s, d = model.scalar, model.device
    if batched:
        return pool.OutputPool(lambda: [arrays.output(shape, N, s, d) for shape in shapes], lambda made: [pool.alias(a) for a in made])

    def make():
        return [arrays.fill_outputs_with_nan(wp.empty(shape, dtype=s, device=d)) for shape in shapes]

    return pool.OutputPool(make, lambda made: [env_axis_descriptor(a) for a in made])


def env_axis_descriptor(array: wp.array):
    """A launch argument showing a single environment's contiguous `array` (shape S) as (1, *S)."""
    return warp_private.array_descriptor(array, (1, *array.shape), (array.capacity or 0, *array.strides))


def _rnea(model, data, base_acceleration, joint_accelerations, link_forces, with_velocity: bool, split: bool, with_gravity: bool = True):
    """RNEA (kernels/rnea.py) on user inputs (None: zero): (f_B, tau) when `split`, else Q = [f_B; tau]."""
    checked = check_data(model, data, parameters=True)
    taping, ws = tape.taping(), _workspace(model, data)
    n, nL, N = model.dofs(), model.number_of_links(), data.batch_size
    s, d = model.scalar, model.device
    a_B = _input(model, data, base_acceleration, "base_acceleration", (6,), taping, ws)
    if not model.floating_base():
        a_B = None  # a welded base does not accelerate (as JaxSim's RNEA): the argument is checked, not applied
    s_dd = _input(model, data, joint_accelerations, "joint_accelerations", (n,), taping, ws)
    f_L = _input(model, data, link_forces, "link_forces", (nL, 6), taping, ws)
    bundle, parameters_grad = model_bundle_and_grad(model)
    grad = requires_grad_with(parameters_grad, data, (a_B, s_dd, f_L))
    if split:
        out = _Outputs(model, data, [(6,), (n,)], grad, taping, ws)
        f_B, tau = out.args
    else:
        out = _Outputs(model, data, [(6 + n,)], grad, taping, ws)
        Q = out.args[0]
        parts = out.slot.cache.get("parts") if out.slot is not None else None
        if parts is not None:  # the pool's set: its parts made once
            f_B, tau = parts
        elif taping or data.num_envs is not None:
            f_B, tau = Q[:, :6], (Q[:, 6:] if n > 0 else arrays.empty((0,), N, s, d))
        else:
            size = wp.types.type_size_in_bytes(s)
            f_B = warp_private.array_descriptor(out.user[0], (1, 6), (0, size))
            tau = warp_private.array_descriptor(out.user[0], (1, n), (0, size), 6 * size)
        if out.slot is not None:
            out.slot.cache["parts"] = (f_B, tau)
    empty2 = empty_like_input(s, d, 2)
    inputs = [
        bundle,
        state_of(model, data, checked),
        a_B if a_B is not None else empty2,
        s_dd if s_dd is not None else empty2,
        _controls(model, ws, None, f_L),
        int(data.velocity_representation),
        _constant(s, 1.0 if with_velocity else 0.0),
        _constant(s, 1.0 if with_gravity else 0.0),
    ]
    width = RNEA_RECORD + (TRANSFORM if f_L is not None else 0)
    _launch(model, "rnea", N, width, inputs, [f_B, tau], grad, taping, ws)
    return out.user if split else out.user[0]


def generalized_forces(model, data, base_acceleration=None, joint_accelerations=None, link_forces=None, with_velocity=True):
    """Q (N, 6 + n) = [f_B; tau] from RNEA (see kernels/rnea.py) for batched data, (6 + n,) for single-environment
    data; accelerations and link forces (None: zero) in the data's representation."""
    return _rnea(model, data, base_acceleration, joint_accelerations, link_forces, with_velocity, split=False)


def inverse_dynamics(model, data, joint_accelerations=None, base_acceleration=None, link_forces=None):
    """(f_B, tau) by RNEA (see warpdyn.model.inverse_dynamics)."""
    return _rnea(model, data, base_acceleration, joint_accelerations, link_forces, True, split=True)


def mass_matrix(model, data) -> wp.array:
    """M(q): (6 + n, 6 + n) or (N, 6 + n, 6 + n), for the generalized velocity in the data's representation."""
    checked = check_data(model, data, parameters=True)
    taping, ws = tape.taping(), _workspace(model, data)
    n = model.dofs()
    bundle, parameters_grad = model_bundle_and_grad(model)
    grad = requires_grad_with(parameters_grad, data, ())
    out = _Outputs(model, data, [(6 + n, 6 + n)], grad, taping, ws)
    inputs = [bundle, state_of(model, data, checked), int(data.velocity_representation)]
    _launch(model, "crba", data.batch_size, CRBA_RECORD, inputs, out.args, grad, taping, ws)
    return out.user[0]


def forward_dynamics_aba(model, data, joint_forces=None, link_forces=None):
    """(base acceleration, joint accelerations) by ABA (see warpdyn.model.forward_dynamics_aba)."""
    checked = check_data(model, data, parameters=True)
    taping, ws = tape.taping(), _workspace(model, data)
    n, nL = model.dofs(), model.number_of_links()
    tau = _input(model, data, joint_forces, "joint_forces", (n,), taping, ws)
    f_L = _input(model, data, link_forces, "link_forces", (nL, 6), taping, ws)
    bundle, parameters_grad = model_bundle_and_grad(model)
    grad = requires_grad_with(parameters_grad, data, (tau, f_L))
    out = _Outputs(model, data, [(6,), (n,)], grad, taping, ws)
    inputs = [
        bundle,
        state_of(model, data, checked),
        _controls(model, ws, tau, f_L),
        int(data.velocity_representation),
        _constant(model.scalar, 0.0),  # no implicit damping: the equations of motion as they are
    ]
    width = ABA_RECORD + (TRANSFORM if f_L is not None else 0)
    _launch(model, "aba", data.batch_size, width, inputs, out.args, grad, taping, ws)
    base, joints = out.user
    return base, joints


def _offset(model) -> int:
    return 0 if model.floating_base() else 6


def _batched(data, array):
    return array if data.num_envs is not None else arrays.with_env_axis(array)


def forward_dynamics_crb(model, data, joint_forces=None, link_forces=None):
    """(base acceleration, joint accelerations) = M^-1 (B tau - h + sum_L J_L^T f_L), by CRBA and a Cholesky
    solve. Under a wp.Tape the solve's adjoint is the implicit one (kernels/cholesky.py): gradients reach the
    state, the forces and the link parameters as through forward_dynamics_aba."""
    n, N, s, d = model.dofs(), data.batch_size, model.scalar, model.device
    M = _batched(data, mass_matrix(model, data))
    Q = _batched(data, generalized_forces(model, data, link_forces=link_forces))
    tau = arrays.zeros((n,), N, s, d)
    if joint_forces is not None:
        tau = arrays.batched_input(joint_forces, "joint_forces", (n,), data.num_envs, s, d)
    grad = M.requires_grad or Q.requires_grad or tau.requires_grad
    rhs = arrays.empty((6 + n,), N, s, d, grad)
    launch(state_kernels(s).actuated_minus, dim=N, inputs=[tau, Q], outputs=[rhs], device=d)
    nu_dot = arrays.output((6 + n,), N, s, d, grad)
    K = cholesky_kernels(s)
    offset = _offset(model)
    with tape.suspended() as recording:
        _solve(K, M, rhs, offset, nu_dot)
    if recording is not None and grad:
        recording.record_func(backward=lambda: _solve_adjoint(K, M, rhs, offset, nu_dot), arrays=[M, rhs, nu_dot])
    base = nu_dot[:, :6]
    joints = nu_dot[:, 6:] if n > 0 else arrays.empty((0,), N, s, d)
    return arrays.squeeze_env(base, data.num_envs), arrays.squeeze_env(joints, data.num_envs)


def _solve(K, A, b, offset: int, x) -> None:
    """x = A[offset:, offset:]^-1 b[offset:] (zeros before offset), A (N, k, k), b and x (N, k)."""
    N, k = x.shape
    s, d = A.dtype, A.device
    scratch = (arrays.empty((k, k), N, s, d), arrays.empty((k,), N, s, d))
    launch(K.solve, dim=N, inputs=[A, b, offset, *scratch], outputs=[x], device=d)


def _solve_adjoint(K, A, b, offset: int, x) -> None:
    """Adds the adjoint of x = A^-1 b (see `_solve`) into A.grad and b.grad from x.grad."""
    N, k = x.shape
    y = arrays.empty((k,), N, x.dtype, x.device)
    _solve(K, A, x.grad, offset, y)
    adj_A = A.grad if A.grad is not None else A
    adj_b = b.grad if b.grad is not None else b
    launch(
        K.solve_adjoint,
        dim=(N, k - offset),
        inputs=[x, y, offset, int(A.grad is not None), int(b.grad is not None)],
        outputs=[adj_A, adj_b],
        device=x.device,
    )


def mass_matrix_inverse(model, data) -> wp.array:
    """M(q)^-1: (6 + n, 6 + n) or batched; for a fixed base, the inverse of the joint block (zeros elsewhere).
    A Cholesky solve, whose adjoint under a wp.Tape is the implicit one, -M^-1 adj M^-1 (kernels/cholesky.py)."""
    n, N, s, d = model.dofs(), data.batch_size, model.scalar, model.device
    M = _batched(data, mass_matrix(model, data))
    Minv = arrays.output((6 + n, 6 + n), N, s, d, M.requires_grad)
    K = cholesky_kernels(s)
    offset = _offset(model)
    scratch = (arrays.empty((6 + n, 6 + n), N, s, d), arrays.empty((6 + n, 6 + n), N, s, d))
    with tape.suspended() as recording:
        launch(K.inverse, dim=N, inputs=[M, offset, *scratch], outputs=[Minv], device=d)
    if recording is not None and M.requires_grad:
        recording.record_func(backward=lambda: _inverse_adjoint(K, M, offset, Minv), arrays=[M, Minv])
    return arrays.squeeze_env(Minv, data.num_envs)


def _inverse_adjoint(K, A, offset: int, X) -> None:
    """Adds the adjoint of X = A^-1 (trailing block) into A.grad from X.grad: -X X.grad X, folded onto A's
    lower triangle."""
    N, k = X.shape[0], X.shape[1]
    s, d = X.dtype, X.device
    W = arrays.empty((k, k), N, s, d)
    P = arrays.empty((k, k), N, s, d)
    launch(K.block_product, dim=(N, k - offset), inputs=[X.grad, X, offset], outputs=[W], device=d)
    launch(K.block_product, dim=(N, k - offset), inputs=[X, W, offset], outputs=[P], device=d)
    launch(K.inverse_adjoint, dim=(N, k - offset), inputs=[P, offset], outputs=[A.grad], device=d)


def actuator_forces(model, data, ctrl) -> wp.array:
    """(N, n): the force of the MJCF actuators on each joint for the controls `ctrl` ((na,) or (N, na); None:
    zero), MuJoCo's qfrc_actuator (kernels/actuation.py)."""
    check_data(model, data, parameters=True)
    n, na, N = model.dofs(), model.number_of_actuators(), data.batch_size
    u = _input(model, data, ctrl if ctrl is not None else np.zeros(na), "ctrl", (na,), tape.taping(), _workspace(model, data))
    grad = requires_grad(model, data, u) or model.parameters_require_grad(("actuator",))
    out = arrays.output((n,), N, model.scalar, model.device, grad)
    if n > 0:
        kernel = mujoco_kernel(model.scalar, False, model.actuators_per_joint, model.multi_dof())
        inputs = [model_bundle(model), state_of(model, data), empty_like_input(model.scalar, model.device, 2), u]
        launch(kernel, dim=(N, n), inputs=inputs, outputs=[out], device=model.device)
    return out


def passive_forces(model, data) -> wp.array:
    """(N, 6 + n): MuJoCo's qfrc_passive in the data's representation: the joints' springs and dampers,
    -stiffness (s - springref) - damping sdot, and the passive link forces f (the gravity compensation of the
    links, a floating base's free-joint damper and spring: kernels/forces.py), J^T f (its base part: the base
    wrench dual to the base velocity). J^T f comes from RNEA at rest without gravity, with the link forces:
    -[f_B; tau] = J^T f."""
    check_data(model, data, parameters=True)
    n, nL, N, s, d = model.dofs(), model.number_of_links(), data.batch_size, model.scalar, model.device
    grad = requires_grad(model, data)
    bundle, state = model_bundle(model), state_of(model, data)
    _, W_H_L = link_poses(model, data)
    f_gc = arrays.empty((nL, 6), N, s, d, grad)
    launch(force_kernels(s).passive_link_forces, dim=(N, nL), inputs=[bundle, state, W_H_L, empty_like_input(s, d, 3), int(data.velocity_representation)], outputs=[f_gc], device=d)
    batched = dataclasses.replace(data, num_envs=N)  # RNEA's (N, ...) outputs, whatever the data's shape
    f_B, tau = _rnea(model, batched, None, None, f_gc, with_velocity=False, split=True, with_gravity=False)
    joints = arrays.empty((n,), N, s, d, grad)
    if n > 0:
        empty2 = empty_like_input(s, d, 2)
        launch(mujoco_kernel(s, True, 0, model.multi_dof()), dim=(N, n), inputs=[bundle, state, empty2, empty2], outputs=[joints], device=d)
    out = arrays.output((6 + n,), N, s, d, grad)
    launch(state_kernels(s).passive_from_parts, dim=N, inputs=[f_B, tau, joints], outputs=[out], device=d)
    return out
