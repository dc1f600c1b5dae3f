"""Recursive Newton-Euler: inverse dynamics, bias and gravity forces, one thread per environment.

Featherstone's RNEA in link coordinates, gravity entering as a fictitious base acceleration -a_g:
    v_i = iX_lambda v_lambda + S_i qd_i,   a_i = iX_lambda a_lambda + S_i qdd_i + v_i x S_i qd_i,
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i + sum_children lambdaX*_c f_c,   tau_i = S_i^T f_i.
The sum over children is a sibling chain, so that every element is written once (tape-safe):
    acc_c = lambdaX*_c f_c + acc_{next sibling of c},   and a link adds acc_{first child}.
The base acceleration and the base wrench are converted from and to the requested representation.
"""

import functools
import types

import warp as wp

from .kinematics import kernels as kinematics_kernels
from .spatial import MIXED, spatial


@functools.cache
def kernels(scalar):
    sp = spatial(scalar)
    base_pose = kinematics_kernels(scalar).base_pose

    @wp.func
    def row6(a: wp.array2d(dtype=scalar), env: int, offset: int):
        return sp.vec6(a[env, offset], a[env, offset + 1], a[env, offset + 2], a[env, offset + 3], a[env, offset + 4], a[env, offset + 5])

    @wp.func
    def link_force(W_f_L: wp.array3d(dtype=scalar), env: int, i: int):
        return sp.vec6(W_f_L[env, i, 0], W_f_L[env, i, 1], W_f_L[env, i, 2], W_f_L[env, i, 3], W_f_L[env, i, 4], W_f_L[env, i, 5])

    @wp.kernel(module="unique")
    def rnea(
        # model
        parent: wp.array(dtype=int),
        joint_type: wp.array(dtype=int),
        X_tree: wp.array(dtype=sp.transform),
        joint_axis: wp.array(dtype=sp.vec3),
        joint_pivot: wp.array(dtype=sp.vec3),
        link_mass: wp.array(dtype=scalar),
        link_com: wp.array(dtype=sp.vec3),
        link_inertia: wp.array(dtype=sp.mat33),
        first_child: wp.array(dtype=int),
        next_sibling: wp.array(dtype=int),
        gravity: scalar,
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        # inputs
        base_acceleration: wp.array2d(dtype=scalar),
        joint_accelerations: wp.array2d(dtype=scalar),
        W_f_L: wp.array3d(dtype=scalar),
        repr: int,
        with_velocity: scalar,
        # scratch
        X_up: wp.array2d(dtype=sp.transform),
        W_H_L: wp.array2d(dtype=sp.transform),
        v: wp.array2d(dtype=sp.vec6),
        a: wp.array2d(dtype=sp.vec6),
        f: wp.array2d(dtype=sp.vec6),
        acc: wp.array2d(dtype=sp.vec6),
        # outputs
        Q: wp.array2d(dtype=scalar),
    ):
        """Q (N, 6 + n) = [f_B; tau]: the generalized forces that produce the given accelerations.

        base_acceleration (N, 6): the derivative of the base velocity in `repr`; joint_accelerations (N, n);
        W_f_L (N, nL, 6): external link forces, Inertial. with_velocity scales the velocities (0 or 1).
        f_B is the base wrench as the generalized force dual to the base velocity in `repr`.
        """
        env = wp.tid()
        W_H_B = base_pose(base_position, base_quaternion, env)
        B_v = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, row6(base_velocity, env, 0) * with_velocity))
        B_a = sp.base_acceleration_to_body(repr, W_H_B, B_v, row6(base_acceleration, env, 0))
        B_a_g = sp.motion_from(W_H_B, sp.vec6(scalar(0.0), scalar(0.0), -gravity, scalar(0.0), scalar(0.0), scalar(0.0)))
        X_up[env, 0] = W_H_B
        W_H_L[env, 0] = W_H_B
        v[env, 0] = B_v
        a[env, 0] = B_a - B_a_g
        nL = parent.shape[0]
        for i in range(1, nL):
            X = X_tree[i] * sp.joint_motion(joint_type[i], joint_axis[i], joint_pivot[i], joint_positions[env, i - 1])
            S = sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i])
            vJ = S * (joint_velocities[env, i - 1] * with_velocity)
            v_i = sp.motion_from(X, v[env, parent[i]]) + vJ
            X_up[env, i] = X
            W_H_L[env, i] = W_H_L[env, parent[i]] * X
            v[env, i] = v_i
            a[env, i] = sp.motion_from(X, a[env, parent[i]]) + S * joint_accelerations[env, i - 1] + sp.cross_motion(v_i, vJ)
        for k in range(nL):
            i = nL - 1 - k
            I = sp.spatial_inertia(link_mass[i], link_com[i], link_inertia[i])
            f_i = I * a[env, i] + sp.cross_force(v[env, i], I * v[env, i]) - sp.force_from(W_H_L[env, i], link_force(W_f_L, env, i))
            if first_child[i] >= 0:
                f_i = f_i + acc[env, first_child[i]]
            f[env, i] = f_i
            if i > 0:
                S = sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i])
                Q[env, 5 + i] = wp.dot(S, f_i)
                up = sp.force_to(X_up[env, i], f_i)
                if next_sibling[i] >= 0:
                    up = up + acc[env, next_sibling[i]]
                acc[env, i] = up
        f_B = sp.base_force_from_body(repr, W_H_B, f[env, 0])
        for r in range(6):
            Q[env, r] = f_B[r]

    return types.SimpleNamespace(rnea=rnea, row6=row6, link_force=link_force)
