"""Link velocities by forward recursion, one thread per environment.

In the Inertial representation velocities add along the tree: W_v_Wi = W_v_Wlambda(i) + W_X_i S_i sdot_i,
starting from the base velocity. Targets (links or frames on links) are then written in the output
representation.
"""

import functools
import types

import warp as wp

from .spatial import MIXED, spatial


@functools.cache
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)

    @wp.kernel(module="unique")
    def link_velocities(
        # model
        parent: wp.array(dtype=int),
        joint_type: wp.array(dtype=int),
        joint_axis: wp.array(dtype=sp.vec3),
        joint_pivot: wp.array(dtype=sp.vec3),
        # targets
        target_link: wp.array(dtype=int),
        link_H_target: wp.array(dtype=sp.transform),
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        output_repr: int,
        # outputs
        W_v_WL: wp.array2d(dtype=sp.vec6),
        v: wp.array3d(dtype=scalar),
    ):
        """W_v_WL (N, nL): Inertial link velocities; v (N, T, 6): target velocities in output_repr.

        base_velocity (N, 6) is the state's base velocity, in the Mixed representation.
        """
        env = wp.tid()
        mixed = sp.vec6(
            base_velocity[env, 0],
            base_velocity[env, 1],
            base_velocity[env, 2],
            base_velocity[env, 3],
            base_velocity[env, 4],
            base_velocity[env, 5],
        )
        W_v_WL[env, 0] = sp.repr_to_inertial(MIXED, W_H_L[env, 0], mixed)
        for i in range(1, parent.shape[0]):
            S = sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i])
            W_v_WL[env, i] = W_v_WL[env, parent[i]] + sp.motion_to(W_H_L[env, i], S) * joint_velocities[env, i - 1]
        for t in range(target_link.shape[0]):
            L = target_link[t]
            out = sp.inertial_to_repr(output_repr, W_H_L[env, L] * link_H_target[t], W_v_WL[env, L])
            for r in range(6):
                v[env, t, r] = out[r]

    return types.SimpleNamespace(link_velocities=link_velocities)
