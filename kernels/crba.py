"""Composite-rigid-body algorithm: the free-floating mass matrix, one thread per environment.

Everything is expressed in base coordinates, so that composite inertias add without transforms and
every entry is one dot product (no quantity carried along a loop: tape-safe):
    B_Ic_i = B_I_i + sum_children B_Ic_c   (a sibling chain, each element written once),
    F_i = B_Ic_i B_S_i,   M_ij = B_S_j . F_i for j an ancestor of i (or i itself),
    M_bb = B_Ic_0,   M_bi = F_i.
The body-base matrix M_B is then written in the requested representation, M = T^T M_B T, with
T = blockdiag(T_base, 1) the map from the generalized velocity in that representation to the body one.
"""

import functools
import types

import warp as wp

from .kinematics import kernels as kinematics_kernels
from .spatial import spatial


@functools.cache
def kernels(scalar):
    sp = spatial(scalar)
    base_pose = kinematics_kernels(scalar).base_pose

    @wp.kernel(module="unique")
    def crba(
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
        support: wp.array2d(dtype=int),
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        repr: int,
        # scratch
        B_H_L: wp.array2d(dtype=sp.transform),
        B_S: wp.array2d(dtype=sp.vec6),
        acc: wp.array2d(dtype=sp.mat66),
        F: wp.array2d(dtype=sp.vec6),
        # outputs
        M: wp.array3d(dtype=scalar),
    ):
        """M (N, 6 + n, 6 + n): the mass matrix for the generalized velocity in `repr`."""
        env = wp.tid()
        nL = parent.shape[0]
        n = nL - 1
        B_H_L[env, 0] = sp.transform(sp.vec3(scalar(0.0)), sp.quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0)))
        B_S[env, 0] = sp.vec6(scalar(0.0))
        for i in range(1, nL):
            X = X_tree[i] * sp.joint_motion(joint_type[i], joint_axis[i], joint_pivot[i], joint_positions[env, i - 1])
            B_H_i = B_H_L[env, parent[i]] * X
            B_H_L[env, i] = B_H_i
            B_S[env, i] = sp.motion_to(B_H_i, sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i]))
        for k in range(n):
            i = nL - 1 - k
            iX_B = sp.motion_matrix_from(B_H_L[env, i])
            Ic = wp.transpose(iX_B) * sp.spatial_inertia(link_mass[i], link_com[i], link_inertia[i]) * iX_B
            if first_child[i] >= 0:
                Ic = Ic + acc[env, first_child[i]]
            F[env, i] = Ic * B_S[env, i]
            chain = Ic
            if next_sibling[i] >= 0:
                chain = chain + acc[env, next_sibling[i]]
            acc[env, i] = chain
        Ic0 = sp.spatial_inertia(link_mass[0], link_com[0], link_inertia[0])
        if first_child[0] >= 0:
            Ic0 = Ic0 + acc[env, first_child[0]]
        T = sp.base_T(repr, base_pose(base_position, base_quaternion, env))
        Tt = wp.transpose(T)
        Mbb = Tt * Ic0 * T
        for r in range(6):
            for c in range(6):
                M[env, r, c] = Mbb[r, c]
        for k in range(n):
            col = Tt * F[env, k + 1]
            for r in range(6):
                M[env, r, 6 + k] = col[r]
                M[env, 6 + k, r] = col[r]
        for k in range(n):
            for j in range(n):
                value = scalar(0.0)
                if support[k + 1, j] != 0:
                    value = wp.dot(B_S[env, j + 1], F[env, k + 1])
                elif support[j + 1, k] != 0:
                    value = wp.dot(B_S[env, k + 1], F[env, j + 1])
                M[env, 6 + k, 6 + j] = value

    return types.SimpleNamespace(crba=crba)
