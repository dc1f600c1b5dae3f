"""Device arrays of the façade: their layout, and the checking of what users pass in.

Every array with an environment axis is handed to kernels and users with its logical shape
(N, ...), the environment first, as JaxSim's batched arrays. Its physical layout depends on the device:
- on a GPU, environment-fastest: the transposed view of a contiguous (..., N) buffer, so the threads of
  a warp, which own neighbouring environments, read and write neighbouring addresses (coalesced);
- on the CPU, environment-major: (N, ...) contiguous, so the one thread that walks an environment's
  links reads and writes contiguous memory.
`warpdyn.config.env_fastest` overrides the choice (True or False; None chooses by device).
benchmarks/kinematics.py measures both layouts on both kinds of device.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from . import config

try:  # Warp's array descriptor: what a launch receives for an array argument
    from warp._src.types import array_t as _array_t
except ImportError:  # pragma: no cover - other Warp versions: launch_view builds array objects instead
    _array_t = None

def env_fastest(device) -> bool:
    """Whether per-environment arrays on `device` are stored environment-fastest (warpdyn.config.env_fastest)."""
    return wp.get_device(device).is_cuda if config.env_fastest is None else bool(config.env_fastest)


def empty(shape: tuple, num_envs: int, dtype, device, requires_grad: bool = False) -> wp.array:
    """An uninitialised array of logical shape (num_envs, *shape) in the device's layout."""
    shape = tuple(int(s) for s in shape)
    if env_fastest(device):
        physical = wp.empty((*shape, num_envs), dtype=dtype, device=device, requires_grad=requires_grad)
        array = physical.transpose((len(shape), *range(len(shape)))) if shape else physical
    else:
        array = wp.empty((num_envs, *shape), dtype=dtype, device=device, requires_grad=requires_grad)
    return array


def output(shape: tuple, num_envs: int, dtype, device, requires_grad: bool = False) -> wp.array:
    """An array for a kernel's output: like `empty`, filled with NaN when warpdyn.config.fill_outputs_with_nan is set."""
    array = empty(shape, num_envs, dtype, device, requires_grad)
    if config.fill_outputs_with_nan and dtype in (wp.float32, wp.float64):
        array.fill_(float("nan"))
    return array


def squeeze_env(array: wp.array, num_envs: int | None) -> wp.array:
    """The array itself for batched data, its environment 0 (dropping the axis) for single-environment data."""
    if num_envs is not None:
        return array
    if 0 in tuple(array.shape[1:]):
        return wp.empty(tuple(array.shape[1:]), dtype=array.dtype, device=array.device)
    return array[0]


def check_device_array(value: wp.array, name: str, scalar, device) -> None:
    """A TypeError or ValueError naming `name` when a Warp array has the wrong dtype or device."""
    if value.dtype != scalar:
        raise TypeError(
            f"{name} has dtype {wp.types.type_repr(value.dtype)}, but the model computes in {wp.types.type_repr(scalar)}"
        )
    if str(value.device) != str(device):
        raise ValueError(f"{name} is on device '{value.device}', but the model is on '{device}'")


def state_array(value, name: str, per_env: tuple, num_envs: int | None, scalar, device, default=None) -> wp.array:
    """The state array (N, *per_env) in the façade's layout from what a user passed.

    `value` may be None (then `default`, broadcast), array-like or a Warp array, with shape `per_env`
    (shared by all environments) or, for batched data, (N, *per_env). A Warp array is copied on the
    device by a kernel, so that a `wp.Tape` carries gradients back to it.
    """
    N = 1 if num_envs is None else num_envs
    accepted = [tuple(per_env)] + ([(N, *per_env)] if num_envs is not None else [])
    out = empty(per_env, N, scalar, device)
    if value is None:
        value = np.zeros(per_env) if default is None else default
    if isinstance(value, wp.array):
        check_device_array(value, name, scalar, device)
        if tuple(value.shape) not in accepted:
            raise ValueError(f"{name} has shape {tuple(value.shape)}, expected one of {accepted}")
        from .engine import launch as launching
        from .kernels.state import kernels

        if len(per_env) != 1:
            raise ValueError(f"{name}: pass a NumPy array here; Warp arrays are accepted for one axis per environment")
        src = value.reshape((1, per_env[0])) if tuple(value.shape) == tuple(per_env) else value
        launching.launch(kernels(scalar).broadcast_rows, dim=out.shape, inputs=[src], outputs=[out], device=device)
        return out
    try:
        host = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{name} must be an array of numbers: {error}") from None
    if host.shape not in accepted:
        raise ValueError(f"{name} has shape {host.shape}, expected one of {accepted}")
    if not np.all(np.isfinite(host)):
        raise ValueError(f"{name} has non-finite values")
    host = np.broadcast_to(host, (N, *per_env))
    out.assign(wp.array(np.ascontiguousarray(host), dtype=scalar, device=device))
    return out


def batched_input(value, name: str, per_env: tuple, num_envs: int | None, scalar, device) -> wp.array:
    """A (N, *per_env) device array from a shared (per_env) or per-environment (N, *per_env) value.

    A Warp array of the full shape is used as it is (no copy); NumPy-like values are checked and copied.
    """
    N = 1 if num_envs is None else num_envs
    accepted = [tuple(per_env)] + ([(N, *per_env)] if num_envs is not None else [])
    if isinstance(value, wp.array):
        check_device_array(value, name, scalar, device)
        if tuple(value.shape) not in accepted:
            raise ValueError(f"{name} has shape {tuple(value.shape)}, expected one of {accepted}")
        if tuple(value.shape) == (N, *per_env):
            return value
        return value.reshape((1, *per_env)) if N == 1 else batched_input(value.numpy(), name, per_env, num_envs, scalar, device)
    try:
        host = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{name} must be an array of numbers: {error}") from None
    if host.shape not in accepted:
        raise ValueError(f"{name} has shape {host.shape}, expected one of {accepted}")
    if not np.all(np.isfinite(host)):
        raise ValueError(f"{name} has non-finite values")
    out = empty(per_env, N, scalar, device)
    out.assign(wp.array(np.ascontiguousarray(np.broadcast_to(host, (N, *per_env))), dtype=scalar, device=device))
    return out


def zeros(shape: tuple, num_envs: int, dtype, device) -> wp.array:
    """A zero array of logical shape (num_envs, *shape)."""
    array = empty(shape, num_envs, dtype, device)
    array.zero_()
    return array


def launch_view(array: wp.array, shape: tuple, strides: tuple, offset: int = 0):
    """A launch argument that shows `array`'s memory from `offset` bytes with `shape` and byte `strides`.

    Cheaper than a view object (a Warp array descriptor, ~1 µs against ~8 µs for `array[...]` on a slow
    CPU), for the launches of `warpdyn._dynamics` that no wp.Tape records: the descriptor carries no
    gradient and does not keep `array` alive, so the caller keeps it.
    """
    ptr = (array.ptr or 0) + offset
    if _array_t is None:
        return wp.array(ptr=ptr, shape=shape, strides=strides, dtype=array.dtype, device=array.device)
    return _array_t(ptr, 0, len(shape), shape, strides)


def with_env_axis(array: wp.array):
    """A launch argument showing a single environment's contiguous `array` (shape S) as (1, *S) (see launch_view)."""
    return launch_view(array, (1, *array.shape), (array.capacity or 0, *array.strides))


def host_input(value, name: str, per_env: tuple, num_envs: int | None, np_dtype) -> np.ndarray:
    """A user's NumPy-like input as a (N, *per_env) NumPy array of `np_dtype`, checked, for a CPU launch.

    Warp's CPU launches read NumPy arrays in place, so this skips the device array and its copy; a value
    shared by all environments is broadcast with a zero stride. Raises as `batched_input` does.
    """
    N = 1 if num_envs is None else num_envs
    try:
        host = np.asarray(value, dtype=np_dtype)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{name} must be an array of numbers: {error}") from None
    if host.shape != per_env and (num_envs is None or host.shape != (N, *per_env)):
        accepted = [tuple(per_env)] + ([(N, *per_env)] if num_envs is not None else [])
        raise ValueError(f"{name} has shape {host.shape}, expected one of {accepted}")
    if not np.isfinite(host).all():
        raise ValueError(f"{name} has non-finite values")
    if host.shape == per_env:
        host = host.reshape((1, *per_env)) if N == 1 else np.broadcast_to(host, (N, *per_env))
    return host
