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

import threading

import numpy as np
import warp as wp

from . import config
from .engine import warp_private

capture_lock = threading.RLock()
"""Held while a graph is captured (warpdyn.engine.launch: `capture`, `Program`): Warp captures one graph at a
time, and a thread's first allocation or launch on a device waits for a capture in progress (`note_thread`).
Re-entrant: a capture started inside a caller's capture (torch's) fails in Warp instead of waiting for itself."""

_threads: dict = {}
"""{(device is CUDA, thread ident): thread} of the threads that allocated or launched through warpdyn."""


def note_thread(device) -> None:
    """Count the calling thread among those that allocate or launch on `device`'s kind (CPU or GPU), after any
    capture in progress. A capture takes the work of other threads on that kind of device: Warp's CUDA stream
    is shared by all threads, and its CPU capture records every thread's operations (which then fail). So a
    graph is captured only while no other such thread is alive (`other_threads`)."""
    me = threading.current_thread()
    key = (device.is_cuda, me.ident)
    if _threads.get(key) is me:
        return
    with capture_lock:
        _threads[key] = me


def other_threads(device) -> list[str]:
    """The names of the other live threads that have allocated or launched on `device`'s kind of device."""
    me = threading.current_thread()
    return [t.name for (cuda, _), t in list(_threads.items()) if cuda == device.is_cuda and t is not me and t.is_alive()]


def env_fastest(device) -> bool:
    """Whether per-environment arrays on `device` are stored environment-fastest (warpdyn.config.env_fastest)."""
    return wp.get_device(device).is_cuda if config.env_fastest is None else bool(config.env_fastest)


def empty(shape: tuple, num_envs: int, dtype, device, requires_grad: bool = False) -> wp.array:
    """An uninitialised array of logical shape (num_envs, *shape) in the device's layout."""
    shape = tuple(int(s) for s in shape)
    note_thread(wp.get_device(device))
    if env_fastest(device):
        physical = wp.empty((*shape, num_envs), dtype=dtype, device=device, requires_grad=requires_grad)
        array = physical.transpose((len(shape), *range(len(shape)))) if shape else physical
    else:
        array = wp.empty((num_envs, *shape), dtype=dtype, device=device, requires_grad=requires_grad)
    return array


def output(shape: tuple, num_envs: int, dtype, device, requires_grad: bool = False) -> wp.array:
    """An array for a kernel's output: like `empty`, filled with NaN when warpdyn.config.fill_outputs_with_nan is set."""
    return fill_outputs_with_nan(empty(shape, num_envs, dtype, device, requires_grad))


def fill_outputs_with_nan(array: wp.array) -> wp.array:
    """`array`, filled with NaN when warpdyn.config.fill_outputs_with_nan is set and it holds floats."""
    if config.fill_outputs_with_nan and array.dtype in (wp.float32, wp.float64):
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
    if value.device is not device and str(value.device) != str(device):
        raise ValueError(f"{name} is on device '{value.device}', but the model is on '{device}'")


REAL_KINDS = "iuf"
"""The NumPy dtype kinds a user's numbers may have (signed and unsigned integers, floats): not complex (NumPy's
cast to float would drop the imaginary part with a warning), bool (True would become 1), object, strings,
bytes, datetimes or records."""


def host_numbers(value, name: str) -> np.ndarray:
    """A user's NumPy-like value (a number, a list, a NumPy array, anything `np.asarray` reads) as a float64
    ndarray: the one conversion of users' numbers from the host. A TypeError naming `name` and the dtype for
    values that are not real numbers (see REAL_KINDS), or that NumPy cannot read as an array."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be an array of numbers, got the string {value!r}")
    try:
        host = np.asarray(value)
    except (TypeError, ValueError) as error:
        raise TypeError(f"{name} must be an array of numbers: {error}") from None
    if host.dtype.kind not in REAL_KINDS:
        raise TypeError(f"{name} must be real numbers, got an array of {host.dtype}")
    return host.astype(np.float64, copy=False)


def checked_host(value, name: str, accepted: list) -> np.ndarray:
    """A user's NumPy-like value as float64 (`host_numbers`), with a TypeError (not real numbers) or ValueError
    (a shape not in `accepted`, non-finite values) naming it."""
    host = host_numbers(value, name)
    if host.shape not in accepted:
        raise ValueError(f"{name} has shape {host.shape}, expected one of {accepted}")
    if np.isfinite(host).all():
        return host
    bad = np.argwhere(~np.isfinite(host))
    if bad.size:
        raise ValueError(f"{name} has non-finite values, first at index {tuple(bad[0].tolist())}: {host[tuple(bad[0])]}")
    return host


def strided_view(array: wp.array, shape: tuple, strides: tuple) -> wp.array:
    """A view of `array`'s memory with another shape and strides (in bytes), its gradient likewise, keeping
    `array` alive: a leading axis of 1 or a broadcast axis (stride 0) on any layout, where `reshape` refuses
    non-contiguous arrays. Under a tape the adjoints of reads through a stride-0 axis add up atomically."""
    view = wp.array(ptr=array.ptr, dtype=array.dtype, shape=tuple(shape), strides=tuple(strides), device=array.device)
    if array.grad is not None:
        view.grad = wp.array(ptr=array.grad.ptr, dtype=array.dtype, shape=tuple(shape), strides=tuple(strides), device=array.device)
    warp_private.keep_owner(view, array)  # the memory's owner, as Warp's own views keep theirs
    return view


def with_env_axis(array: wp.array, N: int = 1) -> wp.array:
    """The (N, *S) view of an (S) array: one environment (N = 1) or the same value for N (stride 0)."""
    return strided_view(array, (N, *array.shape), (0, *array.strides))


def checked_input(value, name: str, per_env: tuple, num_envs: int | None, scalar, device):
    """A user's shared (per_env) or per-environment (N, *per_env) value, checked as `batched_input` checks it:
    a Warp array as it is, anything else as a float64 ndarray (`checked_host`)."""
    per_env = tuple(per_env)
    accepted = [per_env] + ([(num_envs, *per_env)] if num_envs is not None else [])
    if isinstance(value, wp.array):
        check_device_array(value, name, scalar, device)
        shape = value.shape
        if shape != per_env and (num_envs is None or shape != accepted[1]):
            raise ValueError(f"{name} has shape {tuple(shape)}, expected one of {accepted}")
        return value
    return checked_host(value, name, accepted)


def batched_input(value, name: str, per_env: tuple, num_envs: int | None, scalar, device) -> wp.array:
    """A (N, *per_env) device array from a shared (per_env) or per-environment (N, *per_env) value.

    A Warp array of the full shape is used as it is (no copy); NumPy-like values are checked and copied.
    """
    N = 1 if num_envs is None else num_envs
    value = checked_input(value, name, per_env, num_envs, scalar, device)
    if isinstance(value, wp.array):
        if tuple(value.shape) == (N, *per_env):
            return value
        return with_env_axis(value, N)  # shared by the environments: read in place, its gradient summed over them
    host = value
    out = empty(per_env, N, scalar, device)
    out.assign(wp.array(np.ascontiguousarray(np.broadcast_to(host, (N, *per_env))), dtype=scalar, device=device))
    return out


def num_envs_argument(value, name: str = "num_envs") -> int | None:
    """A number of environments as an int (None stays None), or a ValueError naming `name` and the value (a
    bool, a float such as 2.0 or a string included)."""
    if value is None:
        return None
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)) or value < 1:
        raise ValueError(f"{name} must be a positive integer or None, got {value!r}")
    return int(value)


def env_mask(envs, num_envs: int, name: str = "envs") -> np.ndarray:
    """A boolean mask (num_envs,) of environments given as an index, indices (negative ones count from the
    end) or a boolean mask of length num_envs; a TypeError or ValueError naming `name` otherwise."""
    values = np.asarray(envs)
    if values.dtype == np.bool_:
        if values.shape != (num_envs,):
            raise ValueError(f"{name} as a boolean mask must have shape ({num_envs},), one entry per environment, got shape {values.shape}")
        return values.copy()
    if values.size == 0:
        return np.zeros(num_envs, dtype=bool)
    if not np.issubdtype(values.dtype, np.integer):
        raise TypeError(f"{name} must be environment indices (integers) or a boolean mask of length {num_envs}, got {envs!r}")
    outside = values[(values < -num_envs) | (values >= num_envs)]
    if outside.size:
        raise ValueError(f"{name} holds environment {int(outside.ravel()[0])}, but there are {num_envs} (indices 0 to {num_envs - 1})")
    mask = np.zeros(num_envs, dtype=bool)
    mask[values.ravel()] = True
    return mask


def names_argument(value, name: str) -> list[str]:
    """A list of names from an iterable of strings; a TypeError naming `name` for one string (which would
    be read as its letters) or elements that are not strings."""
    if isinstance(value, (str, bytes)):
        raise TypeError(f"{name} must be a list of names, got the string {value!r} (write [{value!r}])")
    try:
        names = list(value)
    except TypeError:
        raise TypeError(f"{name} must be a list of names, got {value!r}") from None
    others = [n for n in names if not isinstance(n, str)]
    if others:
        raise TypeError(f"{name} must hold names (strings), got {others[:5]!r}")
    return names


def zeros(shape: tuple, num_envs: int, dtype, device) -> wp.array:
    """A zero array of logical shape (num_envs, *shape)."""
    array = empty(shape, num_envs, dtype, device)
    array.zero_()
    return array


class InputArray(wp.array):
    """A per-environment input a user writes in place, (N, *per_env) in the device's layout (`input_array`): a
    Warp array over memory it does not own, which kernels read as any Warp array, `wp.to_torch` shares and a
    captured graph reads as it is at each replay, and whose `assign` checks what it is given.

    `assign(values)`: values of one environment (per_env), written to every environment, or one row per
    environment (N, *per_env): NumPy-like real numbers (`checked_host`: finite, not complex, bool, object or
    str) or a Warp array of the same dtype (copied on the device, its values unchecked: that would synchronise
    the host). A TypeError or ValueError naming the array, and nothing written, for anything else. Warp's own
    `wp.array.assign` copies by byte count, so an array one environment short used to leave the last
    environment's old values in place. Other writes are the user's and unchecked: `wp.copy`, `fill_`, kernels,
    and writes through a view (`wp.to_torch(array)[:] = ...`, zero-copy) or a slice.
    """

    name: str = "input"

    def assign(self, src) -> None:
        """Check and copy `src` (see the class docstring)."""
        N, per_env = self.shape[0], tuple(self.shape[1:])
        accepted = [per_env, (N, *per_env)]
        if isinstance(src, wp.array):
            if src.dtype != self.dtype:
                raise TypeError(
                    f"{self.name} has dtype {wp.types.type_repr(src.dtype)}, but the model computes in {wp.types.type_repr(self.dtype)}"
                )
            if tuple(src.shape) not in accepted:
                raise ValueError(f"{self.name} has shape {tuple(src.shape)}, expected one of {accepted}")
            wp.copy(self, src if tuple(src.shape) == tuple(self.shape) else with_env_axis(src, N))
            return
        host = checked_host(src, self.name, accepted)
        super().assign(np.ascontiguousarray(np.broadcast_to(host, self.shape)))


def input_array(shape: tuple, num_envs: int, dtype, device, name: str) -> InputArray:
    """A zero `InputArray` of logical shape (num_envs, *shape), named `name` in its errors."""
    owner = zeros(shape, num_envs, dtype, device)
    array = InputArray(ptr=owner.ptr, dtype=dtype, shape=owner.shape, strides=owner.strides, device=owner.device)
    warp_private.keep_owner(array, owner)  # the memory's owner, as Warp's own views keep theirs
    array.name = name
    return array
