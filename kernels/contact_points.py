"""Kinematics of collidable points: positions, and the linear part of their velocities.

A collidable point C sits at L_p_C in the frame of its link L; its world position is W_p_C = W_H_L L_p_C.
Its velocity is taken from the target-velocity kernel (kernels/velocities.py) with the target frame
(L_p_C, identity rotation): the Mixed velocity of that frame is [W_pdot_C; W_omega_WL], whose linear
part is the plain derivative of W_p_C.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)
    B = bundles(scalar)

    @wp.kernel(module="unique")
    def point_positions(
        targets: B.Targets,
        W_H_L: wp.array2d(dtype=sp.transform),
        # outputs
        W_p_C: wp.array3d(dtype=scalar),
    ):
        """W_p_C (N, nc, 3) [m]: the origins of the targets (the collidable points), launched over (N, nc)."""
        env, c = wp.tid()
        p = wp.transform_get_translation(W_H_L[env, targets.link[c]] * B.target_pose(targets, env, c))
        for r in range(3):
            W_p_C[env, c, r] = p[r]

    @wp.kernel(module="unique")
    def linear_part(
        # inputs
        v: wp.array3d(dtype=scalar),
        # outputs
        out: wp.array3d(dtype=scalar),
    ):
        """out (N, nc, 3) = v[:, :, 0:3] of 6D velocities v (N, nc, 6), launched over (N, nc)."""
        env, c = wp.tid()
        for r in range(3):
            out[env, c, r] = v[env, c, r]

    @wp.kernel(module="unique")
    def gather_points(
        rows: wp.array(dtype=int),
        points: wp.array2d(dtype=sp.vec3),
        # outputs
        L_p_C: wp.array2d(dtype=sp.vec3),
    ):
        """L_p_C[e, k] = points[e, rows[k]]: the enabled points (the contact kernels' order) of all the points'
        positions [m, link frames] (P, nc_all), row e environment e's, launched over (P, enabled points)."""
        e, k = wp.tid()
        L_p_C[e, k] = points[e, rows[k]]

    return types.SimpleNamespace(point_positions=point_positions, linear_part=linear_part, gather_points=gather_points)
