"""One row per environment of a parameter the environments share, and the sum of the rows' adjoints in
environment order (warpdyn.engine.determinism: deterministic gradients of shared parameters).

Both act on flat views of contiguous buffers: a parameter of M numbers (its items' components included)
and its copy of (N, M) numbers.
"""

import types

import warp as wp

from .factory import factory


@factory
def kernels(scalar) -> types.SimpleNamespace:
    @wp.kernel(module="unique")
    def tile(shared: wp.array(dtype=scalar), rows: wp.array2d(dtype=scalar)):
        """rows[e, m] = shared[m]; launched over (N, M)."""
        e, m = wp.tid()
        rows[e, m] = shared[m]

    @wp.kernel(module="unique")
    def sum_rows(rows_adjoint: wp.array2d(dtype=scalar), shared_adjoint: wp.array(dtype=scalar)):
        """shared_adjoint[m] += the sum of rows_adjoint[e, m] over e = 0 .. N - 1, in that order; the rows are
        zeroed. Launched over (M,): one thread per number, so no two threads add into one place."""
        m = wp.tid()
        total = scalar(0.0)
        for e in range(rows_adjoint.shape[0]):
            total += rows_adjoint[e, m]
            rows_adjoint[e, m] = scalar(0.0)
        shared_adjoint[m] = shared_adjoint[m] + total

    return types.SimpleNamespace(tile=tile, sum_rows=sum_rows)
