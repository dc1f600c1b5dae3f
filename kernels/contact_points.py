"""Kinematics of collidable points: positions, the linear part of their velocities, contact with flat ground.

A collidable point C sits at L_p_C in the frame of its link L; its world position is W_p_C = W_H_L L_p_C.
Its velocity is taken from the target-velocity kernel (kernels/velocities.py) with the target frame
(L_p_C, identity rotation): the Mixed velocity of that frame is [W_pdot_C; W_omega_WL], whose linear
part is the plain derivative of W_p_C.
"""

import functools
import types

import warp as wp

from .spatial import spatial


@functools.cache
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)

    @wp.kernel(module="unique")
    def point_positions(
        # points
        point_link: wp.array(dtype=int),
        L_p_C: wp.array(dtype=sp.vec3),
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        # outputs
        W_p_C: wp.array3d(dtype=scalar),
    ):
        """W_p_C (N, nc, 3) [m], launched over (N, nc)."""
        env, c = wp.tid()
        p = wp.transform_point(W_H_L[env, point_link[c]], L_p_C[c])
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
    def links_below_height(
        # points
        point_link: wp.array(dtype=int),
        W_p_C: wp.array3d(dtype=scalar),
        # query
        links: wp.array(dtype=int),
        height: scalar,
        # outputs
        out: wp.array2d(dtype=wp.bool),
    ):
        """out (N, K): whether any point of links[k] has W_p_C.z <= height, launched over (N, K)."""
        env, k = wp.tid()
        below = int(0)
        for c in range(point_link.shape[0]):
            if point_link[c] == links[k] and W_p_C[env, c, 2] <= height:
                below = 1
        out[env, k] = below != 0

    return types.SimpleNamespace(point_positions=point_positions, linear_part=linear_part, links_below_height=links_below_height)
