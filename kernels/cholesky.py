"""Batched dense Cholesky factorisation and solves of symmetric positive-definite matrices.

Used for the mass matrix (forward dynamics by CRBA, and its inverse). Works on the trailing block
A[offset:, offset:] so that a fixed-base model solves only its joint block. The inner sums are
loop-carried, so wp.Tape must not differentiate these kernels line by line: the façade launches them
outside the tape and registers their adjoints, written from the implicit-function theorem
(`solve_adjoint`, `inverse_adjoint`): for x = A^-1 b, y = A^-1 adj_x gives adj_b = y and
adj_A = -y x^T; for X = A^-1, adj_A = -X adj_X X (A symmetric). The factorisation reads only A's lower
triangle, so those adjoints are folded onto it: adj_A[i, j] gets the (i, j) and (j, i) terms (i > j).
"""

import types

import warp as wp

from .factory import factory


@factory
def kernels(scalar):
    @wp.func
    def factor(A: wp.array3d(dtype=scalar), env: int, offset: int, k: int, drop: scalar, L: wp.array3d(dtype=scalar)):
        """L (lower, k x k) with L L^T = A[offset:offset + k, offset:offset + k]. drop < 0: A positive definite. drop
        >= 0: A positive semi-definite; a pivot at most drop times its diagonal entry (a row that depends on the
        ones before it) is dropped: its column of L is 0, which `substitute` reads as an unknown set to 0."""
        for j in range(k):
            s = A[env, offset + j, offset + j]
            for p in range(j):
                s = s - L[env, j, p] * L[env, j, p]
            L[env, j, j] = scalar(0.0)
            if drop < scalar(0.0) or s > drop * A[env, offset + j, offset + j]:
                Ljj = wp.sqrt(s)
                L[env, j, j] = Ljj
                for i in range(j + 1, k):
                    t = A[env, offset + i, offset + j]
                    for p in range(j):
                        t = t - L[env, i, p] * L[env, j, p]
                    L[env, i, j] = t / Ljj
            else:
                for i in range(j + 1, k):
                    L[env, i, j] = scalar(0.0)
            for i in range(j + 1, k):
                L[env, j, i] = scalar(0.0)

    @wp.func
    def substitute(L: wp.array3d(dtype=scalar), env: int, k: int, y: wp.array2d(dtype=scalar), x: wp.array2d(dtype=scalar), at: int):
        """x[env, at:at + k] = (L L^T)^-1 y[env, 0:k] (L: `factor`'s), by forward then back substitution; y is
        overwritten. An unknown whose pivot `factor` dropped is 0."""
        for i in range(k):
            s = y[env, i]
            for p in range(i):
                s = s - L[env, i, p] * y[env, p]
            y[env, i] = scalar(0.0)
            if L[env, i, i] != scalar(0.0):
                y[env, i] = s / L[env, i, i]
        for r in range(k):
            i = k - 1 - r
            s = y[env, i]
            for p in range(i + 1, k):
                s = s - L[env, p, i] * x[env, at + p]
            x[env, at + i] = scalar(0.0)
            if L[env, i, i] != scalar(0.0):
                x[env, at + i] = s / L[env, i, i]

    @wp.kernel(module="unique")
    def solve(
        # inputs
        A: wp.array3d(dtype=scalar),
        b: wp.array2d(dtype=scalar),
        offset: int,
        # scratch
        L: wp.array3d(dtype=scalar),
        y: wp.array2d(dtype=scalar),
        # outputs
        x: wp.array2d(dtype=scalar),
    ):
        """x (N, K): zeros in [:offset], and A[offset:, offset:]^-1 b[offset:] after (A (N, K, K), b (N, K))."""
        env = wp.tid()
        factor(A, env, offset, A.shape[1] - offset, scalar(-1.0), L)
        k = A.shape[1] - offset
        for i in range(k):
            y[env, i] = b[env, offset + i]
        substitute(L, env, k, y, x, offset)
        for i in range(offset):
            x[env, i] = scalar(0.0)

    @wp.kernel(module="unique")
    def inverse(
        # inputs
        A: wp.array3d(dtype=scalar),
        offset: int,
        # scratch
        L: wp.array3d(dtype=scalar),
        y: wp.array3d(dtype=scalar),
        # outputs
        X: wp.array3d(dtype=scalar),
    ):
        """X (N, K, K): A[offset:, offset:]^-1 in the trailing block, zeros elsewhere."""
        env = wp.tid()
        factor(A, env, offset, A.shape[1] - offset, scalar(-1.0), L)
        K = A.shape[1]
        k = K - offset
        for c in range(k):
            for i in range(k):
                s = scalar(0.0)
                if i == c:
                    s = scalar(1.0)
                for p in range(i):
                    s = s - L[env, i, p] * y[env, p, c]
                y[env, i, c] = s / L[env, i, i]
            for r in range(k):
                i = k - 1 - r
                s = y[env, i, c]
                for p in range(i + 1, k):
                    s = s - L[env, p, i] * X[env, offset + p, offset + c]
                X[env, offset + i, offset + c] = s / L[env, i, i]
        for i in range(K):
            for j in range(K):
                if i < offset or j < offset:
                    X[env, i, j] = scalar(0.0)

    @wp.kernel(module="unique")
    def solve_adjoint(
        # inputs
        x: wp.array2d(dtype=scalar),
        y: wp.array2d(dtype=scalar),
        offset: int,
        with_A: int,
        with_b: int,
        # outputs, accumulated
        adj_A: wp.array3d(dtype=scalar),
        adj_b: wp.array2d(dtype=scalar),
    ):
        """The adjoint of `solve`, launched over (N, k) rows of the block: x (N, K) its solution, y (N, K) =
        A^-1 adj_x (by `solve`); adj_b += y and adj_A[i, j] -= y_i x_j + y_j x_i (i > j), y_i x_i (i = j),
        in the lower triangle of the block (with_A, with_b: whether to accumulate each)."""
        env, r = wp.tid()
        i = offset + r
        if with_b != 0:
            adj_b[env, i] = adj_b[env, i] + y[env, i]
        if with_A != 0:
            for c in range(r):
                j = offset + c
                adj_A[env, i, j] = adj_A[env, i, j] - (y[env, i] * x[env, j] + y[env, j] * x[env, i])
            adj_A[env, i, i] = adj_A[env, i, i] - y[env, i] * x[env, i]

    @wp.kernel(module="unique")
    def block_product(
        # inputs
        A: wp.array3d(dtype=scalar),
        B: wp.array3d(dtype=scalar),
        offset: int,
        # outputs
        C: wp.array3d(dtype=scalar),
    ):
        """C = A B on the trailing blocks [offset:, offset:] (N, K, K), launched over (N, k) rows."""
        env, r = wp.tid()
        i = offset + r
        K = A.shape[1]
        for j in range(offset, K):
            s = scalar(0.0)
            for p in range(offset, K):
                s = s + A[env, i, p] * B[env, p, j]
            C[env, i, j] = s

    @wp.kernel(module="unique")
    def inverse_adjoint(
        # inputs
        P: wp.array3d(dtype=scalar),
        offset: int,
        # outputs, accumulated
        adj_A: wp.array3d(dtype=scalar),
    ):
        """The adjoint of `inverse` from P = X adj_X X (N, K, K) (X = A^-1 symmetric): adj_A[i, j] -= P_ij +
        P_ji (i > j), P_ii (i = j), in the lower triangle of the block; launched over (N, k) rows."""
        env, r = wp.tid()
        i = offset + r
        for c in range(r):
            j = offset + c
            adj_A[env, i, j] = adj_A[env, i, j] - (P[env, i, j] + P[env, j, i])
        adj_A[env, i, i] = adj_A[env, i, i] - P[env, i, i]

    return types.SimpleNamespace(
        factor=factor, substitute=substitute, solve=solve, inverse=inverse, solve_adjoint=solve_adjoint, block_product=block_product, inverse_adjoint=inverse_adjoint
    )
