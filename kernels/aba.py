"""Articulated-body algorithm: forward dynamics, one thread per environment.

Featherstone's ABA in link coordinates, gravity entering as a fictitious base acceleration -a_g:
1. v_i = iX_lambda v_lambda + S_i qd_i,  c_i = v_i x S_i qd_i.
2. From the leaves: IA_i = I_i + sum_c cX_i^T Ia_c cX_i,  pA_i = v_i x* I_i v_i - f_ext_i + sum_c cX_i^T pa_c,
   U_i = IA_i S_i, d_i = S_i^T U_i, u_i = tau_i - S_i^T pA_i,
   Ia_i = IA_i - U_i U_i^T / d_i,  pa_i = pA_i + Ia_i c_i + U_i u_i / d_i.
   The sums over children are sibling chains (each element written once: tape-safe).
3. a'_0 = -IA_0^-1 pA_0 (floating base) or -a_g (fixed base); from the base:
   a'_i = iX_lambda a'_lambda + c_i,  qdd_i = (u_i - U_i^T a'_i) / d_i,  a'_i += S_i qdd_i.
The base acceleration d/dt B_v_WB = a'_0 + a_g is written in the requested representation.
"""

import functools
import types

import warp as wp

from .kinematics import kernels as kinematics_kernels
from .rnea import kernels as rnea_kernels
from .spatial import MIXED, spatial


@functools.cache
def kernels(scalar):
    sp = spatial(scalar)
    base_pose = kinematics_kernels(scalar).base_pose
    row6 = rnea_kernels(scalar).row6
    link_force = rnea_kernels(scalar).link_force

    @wp.kernel(module="unique")
    def aba(
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
        floating_base: int,
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        # inputs
        joint_forces: wp.array2d(dtype=scalar),
        W_f_L: wp.array3d(dtype=scalar),
        repr: int,
        # scratch
        X_up: wp.array2d(dtype=sp.transform),
        W_H_L: wp.array2d(dtype=sp.transform),
        v: wp.array2d(dtype=sp.vec6),
        c: wp.array2d(dtype=sp.vec6),
        U: wp.array2d(dtype=sp.vec6),
        d: wp.array2d(dtype=scalar),
        u: wp.array2d(dtype=scalar),
        acc_I: wp.array2d(dtype=sp.mat66),
        acc_p: wp.array2d(dtype=sp.vec6),
        a: wp.array2d(dtype=sp.vec6),
        # outputs
        nu_dot: wp.array2d(dtype=scalar),
    ):
        """nu_dot (N, 6 + n): the base acceleration in `repr` (zero for a fixed base), then qdd.

        joint_forces (N, n); W_f_L (N, nL, 6): external link forces, Inertial.
        """
        env = wp.tid()
        nL = parent.shape[0]
        W_H_B = base_pose(base_position, base_quaternion, env)
        B_v = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, row6(base_velocity, env, 0)))
        B_a_g = sp.motion_from(W_H_B, sp.vec6(scalar(0.0), scalar(0.0), -gravity, scalar(0.0), scalar(0.0), scalar(0.0)))
        X_up[env, 0] = W_H_B
        W_H_L[env, 0] = W_H_B
        v[env, 0] = B_v
        for i in range(1, nL):
            X = X_tree[i] * sp.joint_motion(joint_type[i], joint_axis[i], joint_pivot[i], joint_positions[env, i - 1])
            vJ = sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i]) * joint_velocities[env, i - 1]
            v_i = sp.motion_from(X, v[env, parent[i]]) + vJ
            X_up[env, i] = X
            W_H_L[env, i] = W_H_L[env, parent[i]] * X
            v[env, i] = v_i
            c[env, i] = sp.cross_motion(v_i, vJ)
        for k in range(nL - 1):
            i = nL - 1 - k
            I = sp.spatial_inertia(link_mass[i], link_com[i], link_inertia[i])
            IA = I
            pA = sp.cross_force(v[env, i], I * v[env, i]) - sp.force_from(W_H_L[env, i], link_force(W_f_L, env, i))
            if first_child[i] >= 0:
                IA = IA + acc_I[env, first_child[i]]
                pA = pA + acc_p[env, first_child[i]]
            S = sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i])
            U_i = IA * S
            d_i = wp.dot(S, U_i)
            u_i = joint_forces[env, i - 1] - wp.dot(S, pA)
            U[env, i] = U_i
            d[env, i] = d_i
            u[env, i] = u_i
            Ia = IA - wp.outer(U_i, U_i) / d_i
            pa = pA + Ia * c[env, i] + U_i * (u_i / d_i)
            Xm = sp.motion_matrix_from(X_up[env, i])
            chain_I = wp.transpose(Xm) * Ia * Xm
            chain_p = wp.transpose(Xm) * pa
            if next_sibling[i] >= 0:
                chain_I = chain_I + acc_I[env, next_sibling[i]]
                chain_p = chain_p + acc_p[env, next_sibling[i]]
            acc_I[env, i] = chain_I
            acc_p[env, i] = chain_p
        a0 = -B_a_g
        if floating_base != 0:
            I0 = sp.spatial_inertia(link_mass[0], link_com[0], link_inertia[0])
            IA0 = I0
            pA0 = sp.cross_force(B_v, I0 * B_v) - sp.force_from(W_H_B, link_force(W_f_L, env, 0))
            if first_child[0] >= 0:
                IA0 = IA0 + acc_I[env, first_child[0]]
                pA0 = pA0 + acc_p[env, first_child[0]]
            a0 = -sp.solve_spd6(IA0, pA0)
        a[env, 0] = a0
        for i in range(1, nL):
            S = sp.motion_subspace(joint_type[i], joint_axis[i], joint_pivot[i])
            a_i = sp.motion_from(X_up[env, i], a[env, parent[i]]) + c[env, i]
            qdd = (u[env, i] - wp.dot(U[env, i], a_i)) / d[env, i]
            a[env, i] = a_i + S * qdd
            nu_dot[env, 5 + i] = qdd
        base = sp.vec6(scalar(0.0))
        if floating_base != 0:
            base = sp.base_acceleration_from_body(repr, W_H_B, B_v, a0 + B_a_g)
        for r in range(6):
            nu_dot[env, r] = base[r]

    return types.SimpleNamespace(aba=aba)
