"""Fixed input buffers: a caller's values, checked, copied into arrays that recorded launches and captured graphs
keep reading, so that a call neither packs new launch arguments nor makes new bundles (`wd.model.step`'s pooled
steps, warpdyn.engine.fast_step; the dynamics functions on the CPU, warpdyn.engine.dynamics)."""

from __future__ import annotations

import ctypes

import numpy as np
import warp as wp

from .. import arrays
from .launch import copy_launch, run

__all__ = ["InputBuffers"]


class InputBuffers:
    """One buffer (N, *per_env) per input key, in the device's layout (warpdyn.arrays), made at its first value.
    `mine`: the ids of the buffers (a caller's Controls bundles of them can be kept). Not thread-safe: one per
    thread's workspace."""

    def __init__(self, scalar, device, N: int):
        self.scalar, self.device, self.N = scalar, wp.get_device(device), N
        self.arrays: dict = {}  # key -> (buffer, its NumPy view on the CPU, else None)
        self.mine: set = set()

    def fill(self, key, per_env: tuple, value) -> wp.array:
        """The buffer of `key` holding `value`, which the caller has checked (warpdyn.arrays.checked_input: a
        Warp array of the model's dtype on its device, or a float64 ndarray; per_env or (N, *per_env)). On the
        CPU a Warp array laid out as the buffer is copied byte for byte, anything else through NumPy (broadcast
        over the environments); on a GPU by a copy kernel, ordered on the stream before the launches that read it."""
        held = self.arrays.get(key)
        if held is None:
            buffer = arrays.empty(per_env, self.N, self.scalar, self.device)
            held = self.arrays[key] = (buffer, buffer.numpy() if self.device.is_cpu else None)
            self.mine.add(id(buffer))
        buffer, view = held
        if view is not None:
            if isinstance(value, wp.array):
                if value.is_contiguous and buffer.is_contiguous and value.size == buffer.size:  # per_env or (N, *per_env): the same order
                    ctypes.memmove(buffer.ptr, value.ptr, buffer.capacity)
                    return buffer
                value = value.numpy()
            np.copyto(view, value)
            return buffer
        if not isinstance(value, wp.array):
            value = wp.array(np.ascontiguousarray(np.broadcast_to(value, buffer.shape)), dtype=self.scalar, device=self.device)
        elif tuple(value.shape) != tuple(buffer.shape):
            value = arrays.with_env_axis(value, self.N)
        item = copy_launch(self.scalar, value, buffer)
        if item is not None:
            run([item], self.device)
        return buffer
