"""Copies of per-environment arrays, for rollouts (warpdyn.simulation): initial states into a rollout's
buffers, controls into its input buffers, states into its records.

Plain kernels rather than `wp.copy`, because a kernel is recorded by `wp.Tape` (its adjoint adds the
destination's gradient to the source's) and captured in graphs whatever the arrays' strides (Warp 1.19
copies strided arrays outside both). Launched over the destination's full shape; every element is written
once. A source may broadcast over the environment axis with a zero stride (see warpdyn.simulation).
"""

import types

import warp as wp

from .factory import factory


@factory
def kernels(scalar) -> types.SimpleNamespace:
    @wp.kernel(module="unique")
    def copy1d(src: wp.array(dtype=scalar), dst: wp.array(dtype=scalar)):
        i = wp.tid()
        dst[i] = src[i]

    @wp.kernel(module="unique")
    def copy2d(src: wp.array2d(dtype=scalar), dst: wp.array2d(dtype=scalar)):
        i, j = wp.tid()
        dst[i, j] = src[i, j]

    @wp.kernel(module="unique")
    def copy3d(src: wp.array3d(dtype=scalar), dst: wp.array3d(dtype=scalar)):
        i, j, k = wp.tid()
        dst[i, j, k] = src[i, j, k]

    @wp.kernel(module="unique")
    def copy4d(src: wp.array4d(dtype=scalar), dst: wp.array4d(dtype=scalar)):
        i, j, k, l = wp.tid()
        dst[i, j, k, l] = src[i, j, k, l]

    return types.SimpleNamespace(copy={1: copy1d, 2: copy2d, 3: copy3d, 4: copy4d})


@factory
def int_kernels() -> types.SimpleNamespace:
    @wp.kernel(module="unique")
    def copy_flags(src: wp.array(dtype=wp.int32), dst: wp.array(dtype=wp.int32)):
        """dst (N,) = src (N,): the health flags."""
        i = wp.tid()
        dst[i] = src[i]

    @wp.kernel(module="unique")
    def copy_flags_2d(src: wp.array2d(dtype=wp.int32), dst: wp.array2d(dtype=wp.int32)):
        """dst (L, N) = src (L, N): health flags of L steps (a rollout's records)."""
        i, j = wp.tid()
        dst[i, j] = src[i, j]

    return types.SimpleNamespace(copy_flags=copy_flags, copy_flags_2d=copy_flags_2d)
