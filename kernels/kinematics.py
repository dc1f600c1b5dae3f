"""Forward kinematics: the pose of every link, one thread per environment.

Featherstone's recursion over links in breadth-first order (parent index < child index):
    lambda_H_i = X_tree[i] * M_i(q_i),    W_H_i = W_H_lambda(i) * lambda_H_i,    W_H_0 = W_H_B.
"""

import functools
import types

import warp as wp

from .spatial import spatial


@functools.cache
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)

    @wp.func
    def base_pose(base_position: wp.array2d(dtype=scalar), base_quaternion: wp.array2d(dtype=scalar), env: int):
        """W_H_B from the state's base position (3) and quaternion (w, x, y, z)."""
        p = sp.vec3(base_position[env, 0], base_position[env, 1], base_position[env, 2])
        q = sp.quat_from_wxyz(
            base_quaternion[env, 0], base_quaternion[env, 1], base_quaternion[env, 2], base_quaternion[env, 3]
        )
        return sp.transform(p, q)

    @wp.kernel(module="unique")
    def forward_kinematics(
        # model
        parent: wp.array(dtype=int),
        joint_type: wp.array(dtype=int),
        X_tree: wp.array(dtype=sp.transform),
        joint_axis: wp.array(dtype=sp.vec3),
        joint_pivot: wp.array(dtype=sp.vec3),
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        # outputs
        parent_H_link: wp.array2d(dtype=sp.transform),
        W_H_L: wp.array2d(dtype=sp.transform),
    ):
        """parent_H_link (N, nL): link i in its parent (the base in the world for i = 0); W_H_L (N, nL)."""
        env = wp.tid()
        W_H_B = base_pose(base_position, base_quaternion, env)
        parent_H_link[env, 0] = W_H_B
        W_H_L[env, 0] = W_H_B
        for i in range(1, parent.shape[0]):
            X = X_tree[i] * sp.joint_motion(joint_type[i], joint_axis[i], joint_pivot[i], joint_positions[env, i - 1])
            parent_H_link[env, i] = X
            W_H_L[env, i] = W_H_L[env, parent[i]] * X

    @wp.kernel(module="unique")
    def homogeneous_matrices(
        # inputs
        poses: wp.array2d(dtype=sp.transform),
        target_link: wp.array(dtype=int),
        link_H_target: wp.array(dtype=sp.transform),
        # outputs
        H: wp.array4d(dtype=scalar),
    ):
        """H (N, T, 4, 4): the homogeneous matrix of poses[env, target_link[t]] * link_H_target[t]."""
        env, t = wp.tid()
        M = sp.homogeneous(poses[env, target_link[t]] * link_H_target[t])
        for r in range(4):
            for c in range(4):
                H[env, t, r, c] = M[r, c]

    @wp.kernel(module="unique")
    def base_homogeneous_matrix(
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        # outputs
        H: wp.array3d(dtype=scalar),
    ):
        """H (N, 4, 4): W_H_B."""
        env = wp.tid()
        M = sp.homogeneous(base_pose(base_position, base_quaternion, env))
        for r in range(4):
            for c in range(4):
                H[env, r, c] = M[r, c]

    return types.SimpleNamespace(
        base_homogeneous_matrix=base_homogeneous_matrix,
        base_pose=base_pose, forward_kinematics=forward_kinematics, homogeneous_matrices=homogeneous_matrices
    )
