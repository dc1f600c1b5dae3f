"""External 6D forces on links: conversion between representations and from frames to their links.

Link forces are kept in the Inertial representation W_f_L = [W_f; W_tau about the world origin]; in the
Body and Mixed representations the force acts at the link (or frame) origin, in link (or world) axes.
"""

import functools
import types

import warp as wp

from .spatial import spatial


@functools.cache
def kernels(scalar):
    sp = spatial(scalar)

    @wp.kernel(module="unique")
    def forces_to_inertial(
        # targets
        target_link: wp.array(dtype=int),
        link_H_target: wp.array(dtype=sp.transform),
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        forces: wp.array3d(dtype=scalar),
        repr: int,
        previous: wp.array3d(dtype=scalar),
        additive: int,
        # outputs
        W_f_L: wp.array3d(dtype=scalar),
    ):
        """W_f_L (N, nL, 6): forces (N, T, 6) on the targets, in `repr`, moved to their links.

        A link that a target names gets the sum of its targets' forces, plus previous[env, L] when
        additive; every other link keeps previous[env, L].
        """
        env = wp.tid()
        for L in range(W_H_L.shape[1]):
            total = sp.vec6(scalar(0.0))
            named = int(0)
            for t in range(target_link.shape[0]):
                if target_link[t] == L:
                    named = 1
                    f = sp.vec6(
                        forces[env, t, 0], forces[env, t, 1], forces[env, t, 2],
                        forces[env, t, 3], forces[env, t, 4], forces[env, t, 5],
                    )
                    total = total + sp.force_repr_to_inertial(repr, W_H_L[env, L] * link_H_target[t], f)
            for r in range(6):
                keep = previous[env, L, r]
                if named == 1 and additive == 0:
                    keep = scalar(0.0)
                W_f_L[env, L, r] = keep + total[r]

    @wp.kernel(module="unique")
    def inertial_to_forces(
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        W_f_L: wp.array3d(dtype=scalar),
        repr: int,
        # outputs
        f_L: wp.array3d(dtype=scalar),
    ):
        """f_L (N, nL, 6): the Inertial link forces W_f_L in `repr` (link as the body frame)."""
        env, L = wp.tid()
        W_f = sp.vec6(W_f_L[env, L, 0], W_f_L[env, L, 1], W_f_L[env, L, 2], W_f_L[env, L, 3], W_f_L[env, L, 4], W_f_L[env, L, 5])
        f = sp.inertial_to_force_repr(repr, W_H_L[env, L], W_f)
        for r in range(6):
            f_L[env, L, r] = f[r]

    @wp.kernel(module="unique")
    def link_forces_to_inertial(
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        f_L: wp.array3d(dtype=scalar),
        repr: int,
        # outputs
        W_f_L: wp.array3d(dtype=scalar),
    ):
        """W_f_L (N, nL, 6): link forces f_L (N, nL, 6) given in `repr` (link as the body frame), Inertial."""
        env, L = wp.tid()
        f = sp.vec6(f_L[env, L, 0], f_L[env, L, 1], f_L[env, L, 2], f_L[env, L, 3], f_L[env, L, 4], f_L[env, L, 5])
        W_f = sp.force_repr_to_inertial(repr, W_H_L[env, L], f)
        for r in range(6):
            W_f_L[env, L, r] = W_f[r]

    return types.SimpleNamespace(
        forces_to_inertial=forces_to_inertial,
        inertial_to_forces=inertial_to_forces,
        link_forces_to_inertial=link_forces_to_inertial,
    )
