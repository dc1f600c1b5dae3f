"""Batched dense Cholesky factorisation and solves of symmetric positive-definite matrices.

Used for the mass matrix (forward dynamics by CRBA, and its inverse). Works on the trailing block
A[offset:, offset:] so that a fixed-base model solves only its joint block. The inner sums are
loop-carried, so these kernels are not differentiated by wp.Tape: gradients of forward dynamics go
through the articulated-body algorithm (kernels/aba.py).
"""

import functools
import types

import warp as wp


@functools.cache
def kernels(scalar):
    @wp.func
    def factor(A: wp.array3d(dtype=scalar), env: int, offset: int, L: wp.array3d(dtype=scalar)):
        """L (lower, k x k) with L L^T = A[offset:, offset:]."""
        k = A.shape[1] - offset
        for j in range(k):
            s = A[env, offset + j, offset + j]
            for p in range(j):
                s = s - L[env, j, p] * L[env, j, p]
            Ljj = wp.sqrt(s)
            L[env, j, j] = Ljj
            for i in range(j + 1, k):
                t = A[env, offset + i, offset + j]
                for p in range(j):
                    t = t - L[env, i, p] * L[env, j, p]
                L[env, i, j] = t / Ljj
                L[env, j, i] = scalar(0.0)

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
        factor(A, env, offset, L)
        k = A.shape[1] - offset
        for i in range(k):
            s = b[env, offset + i]
            for p in range(i):
                s = s - L[env, i, p] * y[env, p]
            y[env, i] = s / L[env, i, i]
        for r in range(k):
            i = k - 1 - r
            s = y[env, i]
            for p in range(i + 1, k):
                s = s - L[env, p, i] * x[env, offset + p]
            x[env, offset + i] = s / L[env, i, i]
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
        factor(A, env, offset, L)
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

    return types.SimpleNamespace(solve=solve, inverse=inverse)
