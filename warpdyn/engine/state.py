"""The launches behind warpdyn.data.Data: building a state from a user's values, the base velocity in a
representation, the generalized velocity, the base pose, and selecting environments (resets).

State arrays have a leading environment axis N (warpdyn.arrays for their layout); the base velocity is
stored in the Mixed representation, [W_pdot_B; W_omega_WB].
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.kinematics import kernels as kinematics_kernels
from ..kernels.state import kernels as state_kernels
from .launch import launch

__all__ = [
    "state_array",
    "base_velocity_from",
    "base_velocity_in",
    "generalized_velocity",
    "base_transform",
    "normalized_quaternion",
    "select_rows",
    "select_valid",
]


def state_array(value, name: str, per_env: tuple, num_envs: int | None, scalar, device, default=None) -> wp.array:
    """The state array (N, *per_env) in the façade's layout from what a user passed.

    `value` may be None (then `default`, broadcast), array-like or a Warp array, with shape `per_env`
    (shared by all environments) or, for batched data, (N, *per_env). A Warp array is copied on the
    device by a kernel, so that a `wp.Tape` carries gradients back to it.
    """
    N = 1 if num_envs is None else num_envs
    accepted = [tuple(per_env)] + ([(N, *per_env)] if num_envs is not None else [])
    out = arrays.empty(per_env, N, scalar, device)
    if value is None:
        value = np.zeros(per_env) if default is None else default
    if isinstance(value, wp.array):
        arrays.check_device_array(value, name, scalar, device)
        if tuple(value.shape) not in accepted:
            raise ValueError(f"{name} has shape {tuple(value.shape)}, expected one of {accepted}")
        if len(per_env) != 1:
            raise ValueError(f"{name}: pass a NumPy array here; Warp arrays are accepted for one axis per environment")
        src = arrays.with_env_axis(value) if tuple(value.shape) == tuple(per_env) else value
        launch(state_kernels(scalar).broadcast_rows, dim=out.shape, inputs=[src], outputs=[out], device=device)
        return out
    host = np.broadcast_to(arrays.checked_host(value, name, accepted), (N, *per_env))
    out.assign(wp.array(np.ascontiguousarray(host), dtype=scalar, device=device))
    return out


def base_velocity_from(position: wp.array, quaternion: wp.array, linear: wp.array, angular: wp.array, repr: int,
                       requires_grad: bool = False) -> wp.array:
    """(N, 6): the stored (Mixed) base velocity from its linear and angular parts (N, 3) given in `repr`."""
    N, s, d = position.shape[0], position.dtype, position.device
    velocity = arrays.empty((6,), N, s, d, requires_grad)
    launch(state_kernels(s).base_velocity_from_repr, dim=N, inputs=[position, quaternion, linear, angular, int(repr)], outputs=[velocity], device=d)
    return velocity


def base_velocity_in(data, repr: int, requires_grad: bool) -> wp.array:
    """(N, 6): the data's base velocity in representation `repr`."""
    N, s, d = data.batch_size, data.scalar, data.device
    out = arrays.output((6,), N, s, d, requires_grad)
    inputs = [data.base_position_state, data.base_quaternion_state, data.base_velocity_state, int(repr)]
    launch(state_kernels(s).base_velocity_to_repr, dim=N, inputs=inputs, outputs=[out], device=d)
    return out


def generalized_velocity(data, repr: int, requires_grad: bool) -> wp.array:
    """(N, 6 + n): [base velocity in `repr`; sdot]."""
    N, s, d = data.batch_size, data.scalar, data.device
    n = data.joint_velocities_state.shape[1]
    out = arrays.output((6 + n,), N, s, d, requires_grad)
    inputs = [data.base_position_state, data.base_quaternion_state, data.base_velocity_state, data.joint_velocities_state, int(repr)]
    launch(state_kernels(s).generalized_velocity, dim=N, inputs=inputs, outputs=[out], device=d)
    return out


def base_transform(data, requires_grad: bool) -> wp.array:
    """(N, 4, 4): W_H_B."""
    N, s, d = data.batch_size, data.scalar, data.device
    out = arrays.output((4, 4), N, s, d, requires_grad)
    launch(
        kinematics_kernels(s, False).base_homogeneous_matrix,  # (no joint moves the base: the one-DoF variant)
        dim=N,
        inputs=[data.base_position_state, data.base_quaternion_state],
        outputs=[out],
        device=d,
    )
    return out


def normalized_quaternion(data, requires_grad: bool) -> wp.array:
    """(N, 4): the base quaternion (w, x, y, z) normalised."""
    N, s, d = data.batch_size, data.scalar, data.device
    out = arrays.output((4,), N, s, d, requires_grad)
    launch(state_kernels(s).normalized_quaternion, dim=N, inputs=[data.base_quaternion_state], outputs=[out], device=d)
    return out


def select_rows(selected: wp.array, theirs: wp.array, mine: wp.array) -> wp.array:
    """A new array (N, ...) holding `theirs` where selected[env] != 0 and `mine` elsewhere."""
    N, s, d = mine.shape[0], mine.dtype, mine.device
    out = arrays.empty(mine.shape[1:], N, s, d)
    kernels = state_kernels(s)
    kernel = kernels.select_rows_3d if mine.ndim == 3 else kernels.select_rows
    launch(kernel, dim=N, inputs=[selected, theirs, mine], outputs=[out], device=d)
    return out


def select_valid(selected: wp.array, valid: wp.array, scalar) -> wp.array:
    """A new health flag (N,): 1 where selected[env] != 0, valid[env] elsewhere."""
    N, d = valid.shape[0], valid.device
    out = wp.empty(N, dtype=wp.int32, device=d)
    launch(state_kernels(scalar).select_valid, dim=N, inputs=[selected, valid], outputs=[out], device=d)
    return out
