"""Forward kinematics: the pose of every link, one thread per environment.

Featherstone's recursion over links in breadth-first order (parent index < child index):
    lambda_H_i = X_tree[i] * M_i(q_i),    W_H_i = W_H_lambda(i) * lambda_H_i,    W_H_0 = W_H_B.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import spatial


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The kernels in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)

    @wp.kernel(module="unique")
    def forward_kinematics(
        model: B.Model,
        state: B.State,
        # outputs
        parent_H_link: wp.array2d(dtype=sp.transform),
        W_H_L: wp.array2d(dtype=sp.transform),
    ):
        """parent_H_link (N, nL): link i in its parent (the base in the world for i = 0); W_H_L (N, nL)."""
        env = wp.tid()
        W_H_B = B.base_pose(state, env)
        parent_H_link[env, 0] = W_H_B
        W_H_L[env, 0] = W_H_B
        for i in range(1, model.parent.shape[0]):
            X = jm.joint_transform(model, i, state.joint_positions, env)
            parent_H_link[env, i] = X
            W_H_L[env, i] = W_H_L[env, model.parent[i]] * X

    @wp.kernel(module="unique")
    def homogeneous_matrices(
        poses: wp.array2d(dtype=sp.transform),
        targets: B.Targets,
        # outputs
        H: wp.array4d(dtype=scalar),
    ):
        """H (N, T, 4, 4): the homogeneous matrix of poses[env, targets.link[t]] * targets.link_H_target[t]."""
        env, t = wp.tid()
        M = sp.homogeneous(poses[env, targets.link[t]] * B.target_pose(targets, env, t))
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
        M = sp.homogeneous(B.base_pose_of(base_position, base_quaternion, env))
        for r in range(4):
            for c in range(4):
                H[env, r, c] = M[r, c]

    @wp.kernel(module="unique")
    def inverse_adjoints(
        poses: wp.array2d(dtype=sp.transform),
        # outputs
        X: wp.array4d(dtype=scalar),
    ):
        """X (N, K, 6, 6): B_X_A of each pose A_H_B (N, K), the motion adjoint from A to B (of parent_H_link:
        i_X_lambda(i), and B_X_W for the base)."""
        env, k = wp.tid()
        M = sp.motion_matrix_from(poses[env, k])
        for r in range(6):
            for c in range(6):
                X[env, k, r, c] = M[r, c]

    return types.SimpleNamespace(
        base_homogeneous_matrix=base_homogeneous_matrix,
        forward_kinematics=forward_kinematics,
        homogeneous_matrices=homogeneous_matrices,
        inverse_adjoints=inverse_adjoints,
    )
