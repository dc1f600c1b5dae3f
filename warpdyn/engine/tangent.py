"""The launches behind warpdyn.autodiff: environments replicated into copies, each copy's state moved along
its tangent vector, a state's tangent coordinates, and the seeds of a batched backward pass
(kernels/tangent.py for the tangent space's conventions).

Row c of a replicated array is copy c % m of environment c // m; copy c of an environment seeds its output
c, so that one backward pass gives every row of every environment's Jacobian.
"""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.tangent import kernels as tangent_kernels
from . import state as states
from .bundles import model_bundle
from .launch import launch

__all__ = ["base_dofs", "tangent_size", "replicated", "moved_state", "state_tangent", "perturbed", "central_differences", "poison_flagged", "flattened", "seed"]


def base_dofs(model) -> int:
    """nb: 6 for a floating base, 0 for a fixed one."""
    return 6 if model.floating_base() else 0


def tangent_size(model) -> int:
    """nx = 2 (nb + nv): the size of a state's tangent vector (kernels/tangent.py)."""
    return 2 * (base_dofs(model) + model.dofs())


def replicated(value: wp.array, copies: int, contiguous: bool = False) -> wp.array:
    """(N m, ...): the environments of `value` (N, ...) of two or three axes, each repeated `copies` times, in the
    device's layout of per-environment arrays (warpdyn.arrays), or row-major when `contiguous`."""
    if value.ndim not in (2, 3):
        raise ValueError(f"replicated: expected an array of two or three axes, got shape {tuple(value.shape)}")
    rows = value.shape[0] * copies
    if contiguous:
        out = wp.empty((rows, *value.shape[1:]), dtype=value.dtype, device=value.device)
    else:
        out = arrays.empty(value.shape[1:], rows, value.dtype, value.device)
    kernels = tangent_kernels(value.dtype, False)
    kernel = kernels.replicate if value.ndim == 2 else kernels.replicate_3d
    launch(kernel, dim=out.shape, inputs=[value, copies], outputs=[out], device=value.device)
    return out


def moved_state(model, data, repr: int, copies: int, dx: wp.array) -> dict:
    """Each environment of `data` in `copies` copies, copy c moved by its tangent vector dx[c] (N m, nx), velocities
    in representation `repr` (the base's rotation tangent in base axes for Body, world axes otherwise): the
    state arrays of N m environments, {"base_position", "base_quaternion", "joint_positions", "base_velocity"
    (Mixed, the state's), "joint_velocities"}. Recorded by a tape; `data`'s arrays are read without gradients."""
    N, s, d = data.batch_size, model.scalar, model.device
    rows = N * copies
    base_v0 = states.base_velocity_in(data, repr, False)
    plain = [wp.clone(a, requires_grad=False) for a in (data.base_position_state, data.base_quaternion_state, data.joint_positions_state, data.joint_velocities_state)]
    grad = dx.requires_grad
    p, Q = arrays.empty((3,), rows, s, d, grad), arrays.empty((4,), rows, s, d, grad)
    joints = arrays.empty((model.number_of_joint_coordinates(),), rows, s, d, grad)
    linear, angular = arrays.empty((3,), rows, s, d, grad), arrays.empty((3,), rows, s, d, grad)
    sdot = arrays.empty((model.dofs(),), rows, s, d, grad)
    launch(
        tangent_kernels(s, model.multi_dof()).moved_state,
        dim=rows,
        inputs=[model_bundle(model), plain[0], plain[1], plain[2], base_v0, plain[3], dx, copies, base_dofs(model), int(repr == 1)],
        outputs=[p, Q, joints, linear, angular, sdot],
        device=d,
    )
    velocity = states.base_velocity_from(p, Q, linear, angular, repr, grad)
    return {"base_position": p, "base_quaternion": Q, "joint_positions": joints, "base_velocity": velocity, "joint_velocities": sdot}


def state_tangent(model, data, repr: int, copies: int = 1, reference: int = -1) -> wp.array:
    """y (N, nx): the tangent coordinates of `data`'s state (kernels/tangent.py's `state_tangent`), velocities in
    `repr`, about each row's own rotations (reference -1: recorded by a tape, its derivative the state's tangent
    map) or about those of copy `reference` of each environment's `copies`."""
    N, s, d = data.batch_size, model.scalar, model.device
    grad = data.base_position_state.requires_grad
    base_v = states.base_velocity_in(data, repr, grad)
    Q_ref, s_ref = (wp.clone(a, requires_grad=False) for a in (data.base_quaternion_state, data.joint_positions_state))
    y = wp.zeros((N, tangent_size(model)), dtype=s, device=d, requires_grad=grad)
    launch(
        tangent_kernels(s, model.multi_dof()).state_tangent,
        dim=N,
        inputs=[model_bundle(model), data.base_position_state, data.base_quaternion_state, data.joint_positions_state, base_v,
                data.joint_velocities_state, Q_ref, s_ref, copies, reference, base_dofs(model), int(repr == 1)],
        outputs=[y],
        device=d,
    )
    return y


def perturbed(model, copies: int, h: float, u: wp.array) -> tuple[wp.array, wp.array]:
    """(dx (N m, nx), u_rows (N m, nu)): the copies of central differences of step h (kernels/tangent.py's
    `perturbations`), m = 2 (nx + nu) + 1, from the controls u (N, nu)."""
    N, s, d = u.shape[0], model.scalar, model.device
    rows = N * copies
    dx = wp.zeros((rows, tangent_size(model)), dtype=s, device=d)
    u_rows = arrays.empty((u.shape[1],), rows, s, d)
    launch(tangent_kernels(s, False).perturbations, dim=rows, inputs=[copies, dx.shape[1], s(h), u], outputs=[dx, u_rows], device=d)
    return dx, u_rows


def central_differences(y: wp.array, copies: int, nu: int, h: float) -> tuple[wp.array, wp.array]:
    """(A (N, nx, nx), B (N, nx, nu)) from the tangents y (N m, nx) of `perturbed`'s copies."""
    s, d = y.dtype, y.device
    N, nx = y.shape[0] // copies, y.shape[1]
    A = wp.empty((N, nx, nx), dtype=s, device=d)
    B = wp.empty((N, nx, nu), dtype=s, device=d)
    launch(tangent_kernels(s, False).central_differences, dim=(N, nx + nu), inputs=[y, copies, nx, s(h)], outputs=[A, B], device=d)
    return A, B


def poison_flagged(outputs, valid_rows: wp.array | None, copies: int, data_valid: wp.array | None) -> None:
    """NaN in each output (N, ...), contiguous, for the environments flagged in the data (data_valid (N,)) or in any
    of their copies by the evaluation (valid_rows (N m,)); on the device, without a synchronisation."""
    for out in outputs:
        rows = out.reshape((out.shape[0], -1))
        none = wp.empty(0, dtype=wp.int32, device=out.device)
        launch(tangent_kernels(out.dtype, False).poison_flagged, dim=rows.shape,
               inputs=[none if valid_rows is None else valid_rows, copies, none if data_valid is None else data_valid], outputs=[rows], device=out.device)


def flattened(value: wp.array) -> wp.array:
    """(N, k): `value` (N,), (N, a) or (N, a, b) as rows, by a launch a tape records ((N, a) as it is)."""
    if value.ndim == 2:
        return value
    kernels = tangent_kernels(value.dtype, False)
    N = value.shape[0]
    if value.ndim == 1:
        out = wp.zeros((N, 1), dtype=value.dtype, device=value.device, requires_grad=value.requires_grad)
        launch(kernels.column, dim=N, inputs=[value], outputs=[out], device=value.device)
        return out
    if value.ndim == 3:
        out = wp.zeros((N, value.shape[1] * value.shape[2]), dtype=value.dtype, device=value.device, requires_grad=value.requires_grad)
        launch(kernels.flatten, dim=value.shape, inputs=[value], outputs=[out], device=value.device)
        return out
    raise ValueError(f"expected an output of one to three axes (environments first), got shape {tuple(value.shape)}")


def seed(y: wp.array, copies: int) -> None:
    """Set the adjoint of `y` (N m, copies), which requires gradients, to seed output c in copy c of each
    environment (then `tape.backward()`)."""
    if y.grad is None:
        raise ValueError("the output does not depend on the differentiated inputs (no gradient reaches it)")
    y.grad.zero_()
    launch(tangent_kernels(y.dtype, False).seed_rows, dim=y.shape[0], inputs=[copies], outputs=[y.grad], device=y.device)
