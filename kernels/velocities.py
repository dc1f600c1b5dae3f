"""Link velocities by forward recursion, one thread per environment.

In the Inertial representation velocities add along the tree: W_v_Wi = W_v_Wlambda(i) + W_X_i v_J,i with
v_J,i = S_i(q) sdot_i the joint's velocity in link coordinates, starting from the base velocity. Targets (links or frames on links) are then written in the output
representation.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import MIXED, spatial


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The kernels in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)

    @wp.kernel(module="unique")
    def link_velocities(
        model: B.Model,
        targets: B.Targets,
        W_H_L: wp.array2d(dtype=sp.transform),
        state: B.State,
        output_repr: int,
        # outputs
        W_v_WL: wp.array2d(dtype=sp.vec6),
        v: wp.array3d(dtype=scalar),
    ):
        """W_v_WL (N, nL): Inertial link velocities; v (N, T, 6): target velocities in output_repr.

        W_H_L (N, nL): the link poses at the state (forward kinematics).
        """
        env = wp.tid()
        W_v_WL[env, 0] = sp.repr_to_inertial(MIXED, W_H_L[env, 0], B.base_velocity_mixed(state, env))
        for i in range(1, model.parent.shape[0]):
            vJ = jm.joint_motion_of(model, i, jm.joint_frame_motion(model, i, W_H_L, env), state.joint_velocities, env)
            W_v_WL[env, i] = W_v_WL[env, model.parent[i]] + sp.motion_to(W_H_L[env, i], vJ)
        for t in range(targets.link.shape[0]):
            L = targets.link[t]
            out = sp.inertial_to_repr(output_repr, W_H_L[env, L] * B.target_pose(targets, env, t), W_v_WL[env, L])
            for r in range(6):
                v[env, t, r] = out[r]

    return types.SimpleNamespace(link_velocities=link_velocities)
