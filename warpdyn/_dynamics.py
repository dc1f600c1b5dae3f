"""Equations of motion: RNEA, CRBA and ABA behind JaxSim's `jaxsim.api.model` functions.

    M(q) nu_dot + h(q, nu) = B tau + sum_L J_L^T f_L,      h = C(q, nu) nu + g(q),

with nu, nu_dot, the base part of every generalized force, and the link forces f_L all in the data's
velocity representation (JaxSim's convention). Each function is one kernel launch (the kernels convert
link forces from the data's representation themselves), re-exported by `warpdyn.model`.

Cost of a call. Outside a `wp.Tape`, each kernel keeps per model a scratch array and a recorded launch
(`wp.launch(record_cmd=True)`) for the last batch size it ran: a call then packs only the arguments that
changed since the last one (the outputs, the inputs), allocates only its outputs, and on the CPU passes
NumPy inputs to the kernel in place. Calls are ordered on the device's stream, so consecutive calls may
share scratch; each CUDA stream gets its own. Under a tape every call gets fresh scratch (with gradients
when the data or an input requires them), since the adjoint reads it later. Outputs are always fresh
arrays that the caller owns. Absent inputs (no joint forces, no link forces, zero accelerations) reach
the kernels as null arrays, which skip that work.

Gradients with respect to the model's mass parameters (link_mass, link_com, link_inertia: arrays the
kernels read in place, see `model_args`) accumulate into those arrays' .grad under a tape once they
require gradients (`warpdyn.model.parameters_requiring_grad`); the recorded launches are never used under
a tape, so they cannot bypass them. When none does, a taped call costs what it did.
"""

from __future__ import annotations

import weakref

import numpy as np
import warp as wp

from .engine import launch as launching
from . import arrays as _arrays
from . import config
from .engine import tape as _tape
from .kernels.aba import ABA_RECORD
from .kernels.aba import kernels as aba_kernels
from .kernels.cholesky import kernels as cholesky_kernels
from .kernels.crba import CRBA_RECORD
from .kernels.crba import kernels as crba_kernels
from .kernels.rnea import RNEA_RECORD
from .kernels.rnea import kernels as rnea_kernels
from .kernels.scratch import TRANSFORM
from .kernels.state import kernels as state_kernels


_KERNELS = {
    "aba": lambda scalar, registers: aba_kernels(scalar, registers).aba,
    "rnea": lambda scalar, registers: rnea_kernels(scalar, registers).rnea,
    "crba": lambda scalar, registers: crba_kernels(scalar, registers).crba,
}

_SCRATCH = object()
"""The scratch argument's place in a kernel's argument list."""

_recorded: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""model -> {(kernel name, scratch width, stream): _Recorded}."""


class _Recorded:
    """A kernel's recorded launch for one batch size, the scratch it owns and the arguments it holds."""

    __slots__ = ("N", "block_dim", "launch", "bound")

    def __init__(self, N, block_dim, launch, bound):
        self.N, self.block_dim, self.launch, self.bound = N, block_dim, launch, bound


def _taping() -> bool:
    """Whether a wp.Tape is recording (True when this Warp version does not say)."""
    return _tape.taping()


def _launch(model, name: str, N: int, width: int, args: list, grad: bool) -> None:
    """Launch the kernel `name` over N environments with `args`, the scratch (N, nL, width) at _SCRATCH's place.

    Under a tape: fresh scratch (with gradients when `grad`) and a plain launch. Otherwise the model's
    recorded launch for this kernel, re-packing only the arguments that are not the ones it holds.
    """
    device = model.device
    block_dim, registers = config.cuda_launch.get(name, (None, "tuned")) if device.is_cuda else (None, "tuned")
    kernel = _KERNELS[name](model.scalar, registers)
    nL = model.number_of_links()
    if _taping():
        scratch = _arrays.empty((nL, width), N, model.scalar, device, grad)
        inputs = [scratch if a is _SCRATCH else a for a in args]
        launching.launch(kernel, dim=N, inputs=inputs, device=device, block_dim=block_dim)
        return
    cache = _recorded.get(model)
    if cache is None:
        cache = _recorded[model] = {}
    key = (name, width, device.stream if device.is_cuda else None)
    entry = cache.get(key)
    if entry is None or entry.N != N or entry.launch.kernel is not kernel or entry.block_dim != block_dim:
        scratch = _arrays.empty((nL, width), N, model.scalar, device)
        bound = [scratch if a is _SCRATCH else a for a in args]
        launch = launching.launch(kernel, dim=N, inputs=bound, device=device, block_dim=block_dim, record_cmd=True)
        entry = cache[key] = _Recorded(N, block_dim, launch, bound)
    else:
        bound, launch = entry.bound, entry.launch
        for i, a in enumerate(args):
            b = bound[i]
            if a is b or a is _SCRATCH or (type(a) in (int, float) and type(b) is type(a) and a == b):
                continue
            launch.set_param_at_index(i, a)
            bound[i] = a
    entry.launch.launch()


_pairs: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()
"""model -> CRBA's joint pairs (pair_k, pair_j, zero_k, zero_j), device int arrays."""


def _joint_pairs(model) -> list:
    """CRBA's joint pairs: (k, j) with joint j supporting link k + 1 (M_kj = B_S_j . F_k, mirrored), and
    (k, j) with neither joint supporting the other's link (M_kj = 0)."""
    pairs = _pairs.get(model)
    if pairs is None:
        n = model.dofs()
        support = np.asarray(model.support.numpy()).reshape(model.number_of_links(), n)[1:] != 0
        k, j = np.nonzero(support)
        zk, zj = np.nonzero(~(support | support.T))
        pairs = _pairs[model] = [wp.array(a.astype(np.int32), dtype=int, device=model.device) for a in (k, j, zk, zj)]
    return pairs


def model_args(model) -> list:
    """The model constants that lead the RNEA, CRBA, ABA and Coriolis kernels' parameters, in their order."""
    return [
        model.parent,
        model.joint_type,
        model.X_tree,
        model.joint_axis,
        model.joint_pivot,
        model.kernel_parameter("link_mass"),
        model.kernel_parameter("link_com"),
        model.kernel_parameter("link_inertia"),
        model.first_child,
        model.next_sibling,
    ]


def _input(model, data, value, name: str, per_env: tuple, taping: bool):
    """None (the kernel's null array) for an absent input, else its (N, *per_env) kernel argument."""
    if value is None:
        return None
    if not taping and not model.device.is_cuda and not isinstance(value, wp.array):
        return _arrays.host_input(value, name, per_env, data.num_envs, model.dtype)
    return _arrays.batched_input(value, name, per_env, data.num_envs, model.scalar, model.device)


class _Outputs:
    """Fresh output arrays for a kernel: what the caller gets (`user`) and what the kernel writes (`args`).

    Batched data: (N, *shape) arrays in the device's layout, given to both. Single-environment data gets
    arrays of JaxSim's shapes; the kernel sees them with a leading axis of 1, through launch views outside
    a tape (no view objects) and as views of (1, *shape) arrays under one (gradients flow through views).
    """

    def __init__(self, model, data, shapes, grad: bool, taping: bool):
        s, d, N = model.scalar, model.device, data.batch_size
        if data.num_envs is not None:
            self.user = [_arrays.output(shape, N, s, d, grad) for shape in shapes]
            self.args = self.user
        elif taping:
            self.args = [_arrays.output(shape, 1, s, d, grad) for shape in shapes]
            self.user = [_arrays.squeeze_env(a, None) for a in self.args]
        else:
            self.user = [wp.empty(shape, dtype=s, device=d, requires_grad=grad) for shape in shapes]
            if config.fill_outputs_with_nan:
                for a in self.user:
                    a.fill_(float("nan"))
            self.args = [_arrays.with_env_axis(a) for a in self.user]


def mass_parameters_require_grad(model) -> bool:
    """Whether link_mass, link_com or link_inertia requires gradients (warpdyn.model.parameters_requiring_grad)."""
    return model.link_mass.requires_grad or model.link_com.requires_grad or model.link_inertia.requires_grad


def requires_grad(model, data) -> bool:
    """Whether outputs of a function of the state and the mass parameters need gradient arrays."""
    return data.requires_grad or mass_parameters_require_grad(model)


def _grad(model, data, *inputs) -> bool:
    """Whether the data's state, an input or a mass parameter of the model (link_mass, link_com, link_inertia)
    requires gradients (Data.requires_grad, without its name lookups): then outputs and scratch get gradient
    arrays, so that the adjoint reaches the parameters' .grad."""
    return (
        model.link_mass.requires_grad
        or model.link_com.requires_grad
        or model.link_inertia.requires_grad
        or data.base_position_state.requires_grad
        or data.base_quaternion_state.requires_grad
        or data.joint_positions_state.requires_grad
        or data.base_velocity_state.requires_grad
        or data.joint_velocities_state.requires_grad
        or any(isinstance(x, wp.array) and x.requires_grad for x in inputs)
    )


def _check(model, data) -> None:
    """warpdyn.model._check_data, its common case first: same scalar, joint count and device object, and no
    parameter given per environment."""
    state = data.joint_positions_state
    if state.dtype is model.scalar and state.shape[1] == model.dofs() and state.device is model.device and not model._per_env_parameters:
        return
    from .model import _check_data

    _check_data(model, data, parameters=True)


def _rnea(model, data, base_acceleration, joint_accelerations, link_forces, with_velocity: bool, split: bool):
    """RNEA (kernels/rnea.py) on user inputs (None: zero): (f_B, tau) when `split`, else Q = [f_B; tau]."""
    _check(model, data)
    taping = _taping()
    n, nL, N = model.dofs(), model.number_of_links(), data.batch_size
    a_B = _input(model, data, base_acceleration, "base_acceleration", (6,), taping)
    s_dd = _input(model, data, joint_accelerations, "joint_accelerations", (n,), taping)
    f_L = _input(model, data, link_forces, "link_forces", (nL, 6), taping)
    grad = _grad(model, data, a_B, s_dd, f_L)
    if split:
        out = _Outputs(model, data, [(6,), (n,)], grad, taping)
        f_B, tau = out.args
    else:
        out = _Outputs(model, data, [(6 + n,)], grad, taping)
        Q = out.args[0]
        if taping or data.num_envs is not None:
            f_B, tau = Q[:, :6], (Q[:, 6:] if n > 0 else None)
        else:
            size = wp.types.type_size_in_bytes(model.scalar)
            f_B = _arrays.launch_view(out.user[0], (1, 6), (0, size))
            tau = _arrays.launch_view(out.user[0], (1, n), (0, size), 6 * size)
    args = [
        *model_args(model),
        model.gravity,
        data.base_position_state,
        data.base_quaternion_state,
        data.joint_positions_state,
        data.base_velocity_state,
        data.joint_velocities_state,
        a_B,
        s_dd,
        f_L,
        int(data.velocity_representation),
        1.0 if with_velocity else 0.0,
        _SCRATCH,
        f_B,
        tau,
    ]
    width = RNEA_RECORD + (TRANSFORM if f_L is not None else 0)
    _launch(model, "rnea", N, width, args, grad)
    return out.user if split else out.user[0]


def generalized_forces(model, data, base_acceleration=None, joint_accelerations=None, link_forces=None, with_velocity=True):
    """Q (N, 6 + n) = [f_B; tau] from RNEA (see kernels/rnea.py) for batched data, (6 + n,) for single-environment
    data; accelerations and link forces (None: zero) in the data's representation."""
    return _rnea(model, data, base_acceleration, joint_accelerations, link_forces, with_velocity, split=False)


def inverse_dynamics(model, data, *, joint_accelerations=None, base_acceleration=None, link_forces=None):
    """(f_B, tau): the base wrench (6,) and joint forces (n,) that produce the given accelerations.

    base_acceleration (6,): the derivative of the base velocity in the data's representation (default 0);
    joint_accelerations (n,) (default 0); link_forces (nL, 6) in the data's representation. f_B is the
    generalized force of the base, dual to its velocity in the data's representation: zero when the
    accelerations came from forward dynamics with the same forces. Leading N axis for batched data.
    """
    f_B, tau = _rnea(model, data, base_acceleration, joint_accelerations, link_forces, True, split=True)
    return f_B, tau


def free_floating_bias_forces(model, data) -> wp.array:
    """h = C(q, nu) nu + g(q): (6 + n,) or (N, 6 + n), in the data's representation."""
    return generalized_forces(model, data)


def free_floating_gravity_forces(model, data) -> wp.array:
    """g(q): (6 + n,) or (N, 6 + n), in the data's representation."""
    return generalized_forces(model, data, with_velocity=False)


def free_floating_mass_matrix(model, data) -> wp.array:
    """M(q): (6 + n, 6 + n) or (N, 6 + n, 6 + n), for the generalized velocity in the data's representation."""
    _check(model, data)
    taping = _taping()
    n = model.dofs()
    grad = _grad(model, data)
    out = _Outputs(model, data, [(6 + n, 6 + n)], grad, taping)
    args = [
        *model_args(model),
        *_joint_pairs(model),
        data.base_position_state,
        data.base_quaternion_state,
        data.joint_positions_state,
        int(data.velocity_representation),
        _SCRATCH,
        out.args[0],
    ]
    _launch(model, "crba", data.batch_size, CRBA_RECORD, args, grad)
    return out.user[0]


def forward_dynamics_aba(model, data, *, joint_forces=None, link_forces=None):
    """(base acceleration (6,), joint accelerations (n,)) by the articulated-body algorithm.

    joint_forces (n,); link_forces (nL, 6) in the data's representation. The base acceleration is the
    derivative of the base velocity in the data's representation (zero for a fixed base).
    """
    _check(model, data)
    taping = _taping()
    n, nL = model.dofs(), model.number_of_links()
    tau = _input(model, data, joint_forces, "joint_forces", (n,), taping)
    f_L = _input(model, data, link_forces, "link_forces", (nL, 6), taping)
    grad = _grad(model, data, tau, f_L)
    out = _Outputs(model, data, [(6,), (n,)], grad, taping)
    args = [
        *model_args(model),
        model.gravity,
        int(model.floating_base()),
        data.base_position_state,
        data.base_quaternion_state,
        data.joint_positions_state,
        data.base_velocity_state,
        data.joint_velocities_state,
        tau,
        f_L,
        int(data.velocity_representation),
        _SCRATCH,
        *out.args,
    ]
    width = ABA_RECORD + (TRANSFORM if f_L is not None else 0)
    _launch(model, "aba", data.batch_size, width, args, grad)
    base, joints = out.user
    return base, joints


def _offset(model) -> int:
    return 0 if model.floating_base() else 6


def _batched(model, data, array):
    return array if data.num_envs is not None else array.reshape((1, *array.shape))


def forward_dynamics_crb(model, data, *, joint_forces=None, link_forces=None):
    """(base acceleration (6,), joint accelerations (n,)) = M^-1 (B tau - h + sum_L J_L^T f_L), by CRBA
    and a Cholesky solve. Under a wp.Tape the solve's adjoint is the implicit one (kernels/cholesky.py):
    gradients reach the state, the forces and the mass parameters as through forward_dynamics_aba."""
    n, N, s, d = model.dofs(), data.batch_size, model.scalar, model.device
    M = _batched(model, data, free_floating_mass_matrix(model, data))
    Q = _batched(model, data, generalized_forces(model, data, link_forces=link_forces))
    tau = _arrays.zeros((n,), N, s, d)
    if joint_forces is not None:
        tau = _arrays.batched_input(joint_forces, "joint_forces", (n,), data.num_envs, s, d)
    grad = M.requires_grad or Q.requires_grad or tau.requires_grad
    rhs = _arrays.empty((6 + n,), N, s, d, grad)
    launching.launch(state_kernels(s).actuated_minus, dim=N, inputs=[tau, Q], outputs=[rhs], device=d)
    nu_dot = _arrays.output((6 + n,), N, s, d, grad)
    K = cholesky_kernels(s)
    offset = _offset(model)
    with _tape.suspended() as tape:
        _solve(K, M, rhs, offset, nu_dot)
    if tape is not None and grad:
        tape.record_func(backward=lambda: _solve_adjoint(K, M, rhs, offset, nu_dot), arrays=[M, rhs, nu_dot])
    return _arrays.squeeze_env(nu_dot[:, :6], data.num_envs), _arrays.squeeze_env(nu_dot[:, 6:], data.num_envs)


def _solve(K, A, b, offset: int, x) -> None:
    """x = A[offset:, offset:]^-1 b[offset:] (zeros before offset), A (N, k, k), b and x (N, k)."""
    N, k = x.shape
    s, d = A.dtype, A.device
    scratch = (_arrays.empty((k, k), N, s, d), _arrays.empty((k,), N, s, d))
    launching.launch(K.solve, dim=N, inputs=[A, b, offset, *scratch], outputs=[x], device=d)


def _solve_adjoint(K, A, b, offset: int, x) -> None:
    """Adds the adjoint of x = A^-1 b (see `_solve`) into A.grad and b.grad from x.grad."""
    N, k = x.shape
    y = _arrays.empty((k,), N, x.dtype, x.device)
    _solve(K, A, x.grad, offset, y)
    adj_A = A.grad if A.grad is not None else A
    adj_b = b.grad if b.grad is not None else b
    launching.launch(
        K.solve_adjoint,
        dim=(N, k - offset),
        inputs=[x, y, offset, int(A.grad is not None), int(b.grad is not None)],
        outputs=[adj_A, adj_b],
        device=x.device,
    )


def free_floating_mass_matrix_inverse(model, data) -> wp.array:
    """M(q)^-1: (6 + n, 6 + n) or batched; for a fixed base, the inverse of the joint block (zeros elsewhere).
    A Cholesky solve, whose adjoint under a wp.Tape is the implicit one, -M^-1 adj M^-1 (kernels/cholesky.py)."""
    n, N, s, d = model.dofs(), data.batch_size, model.scalar, model.device
    M = _batched(model, data, free_floating_mass_matrix(model, data))
    Minv = _arrays.output((6 + n, 6 + n), N, s, d, M.requires_grad)
    K = cholesky_kernels(s)
    offset = _offset(model)
    scratch = (_arrays.empty((6 + n, 6 + n), N, s, d), _arrays.empty((6 + n, 6 + n), N, s, d))
    with _tape.suspended() as tape:
        launching.launch(K.inverse, dim=N, inputs=[M, offset, *scratch], outputs=[Minv], device=d)
    if tape is not None and M.requires_grad:
        tape.record_func(backward=lambda: _inverse_adjoint(K, M, offset, Minv), arrays=[M, Minv])
    return _arrays.squeeze_env(Minv, data.num_envs)


def _inverse_adjoint(K, A, offset: int, X) -> None:
    """Adds the adjoint of X = A^-1 (trailing block) into A.grad from X.grad: -X X.grad X, folded onto A's
    lower triangle."""
    N, k = X.shape[0], X.shape[1]
    s, d = X.dtype, X.device
    W = _arrays.empty((k, k), N, s, d)
    P = _arrays.empty((k, k), N, s, d)
    launching.launch(K.block_product, dim=(N, k - offset), inputs=[X.grad, X, offset], outputs=[W], device=d)
    launching.launch(K.block_product, dim=(N, k - offset), inputs=[X, W, offset], outputs=[P], device=d)
    launching.launch(K.inverse_adjoint, dim=(N, k - offset), inputs=[P, offset], outputs=[A.grad], device=d)


def forward_dynamics(model, data, *, joint_forces=None, link_forces=None, prefer_aba: bool = True):
    """Forward dynamics by ABA (default) or by CRBA and a Cholesky solve."""
    solver = forward_dynamics_aba if prefer_aba else forward_dynamics_crb
    return solver(model, data, joint_forces=joint_forces, link_forces=link_forces)
