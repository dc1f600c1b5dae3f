"""Composite-rigid-body algorithm: the free-floating mass matrix, one thread per environment.

Everything is expressed in base coordinates, so that composite inertias add without transforms and
every entry is one dot product (no quantity carried along a loop: tape-safe):
    B_Ic_i = B_I_i + sum_children B_Ic_c   (a sibling chain, each element written once),
    F_d = B_Ic_i B_S_d for each DoF d of link i's joint,   M_kd = B_S_d . F_k for DoF d's joint supporting
    DoF k's link (or the same joint), listed per model,   M_bb = B_Ic_0,   M_bd = F_d.
A sum of rigid-body inertias in one frame is a rigid-body inertia: B_Ic is kept as its mass m, first
moment h = m c and rotational inertia about the base origin I_O (10 numbers, not a 6x6 matrix).
The body-base matrix M_B is then written in the requested representation, M = T^T M_B T, with
T = blockdiag(T_base, 1) the map from the generalized velocity in that representation to the body one.
Scratch is one scalar record per link (row i) and per DoF (row d + 1) (kernels/scratch.py, kernels/aba.py).
"""

import types

import warp as wp

from .aba import inertia_funcs
from .bundles import bundles
from .joints import joints
from .registers import tuned
from .scratch import scratch
from .spatial import BODY, INERTIAL, spatial

# Columns of the CRBA's scratch record (N, max(nL, nv + 1), CRBA_RECORD): a link's at row i, a DoF's at row d + 1.
_BH = 0  # B_H_L (7): link pose in the base
_BS = 7  # B_S_d (6): DoF d's motion subspace, base coordinates
_F = 13  # F_d (6)
_IC = 19  # the sibling chain's composite inertia: m (1), h (3), I_O (6: xx, xy, xz, yy, yz, zz)
CRBA_RECORD = _IC + 10
"""Scratch numbers per link."""


MAX_REGISTERS = {wp.float32: None, wp.float64: None}
"""Register cap per thread on CUDA by scalar (None: the compiler's choice); caps measured on an H200 changed
CRBA by under 5% (benchmarks/results/dynamics_h200_run2.md)."""


@tuned(MAX_REGISTERS)
def kernels(scalar, max_registers, multi_dof: bool):
    """CRBA (the mass matrix) in `scalar`, its registers per thread capped on CUDA by `max_registers` (kernels/registers.py),
    for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp, sc, B = spatial(scalar), scratch(scalar), bundles(scalar)
    jm = joints(scalar, multi_dof)
    inertia_to = inertia_funcs(scalar).inertia_to

    @wp.func
    def get_I_O(s: wp.array3d(dtype=scalar), env: int, i: int):
        """The symmetric I_O of link i's record."""
        xy = s[env, i, _IC + 5]
        xz = s[env, i, _IC + 6]
        yz = s[env, i, _IC + 8]
        return sp.mat33(s[env, i, _IC + 4], xy, xz, xy, s[env, i, _IC + 7], yz, xz, yz, s[env, i, _IC + 9])

    @wp.func
    def get_h(s: wp.array3d(dtype=scalar), env: int, i: int):
        return sp.vec3(s[env, i, _IC + 1], s[env, i, _IC + 2], s[env, i, _IC + 3])

    @wp.kernel(module="unique", cuda_max_registers=max_registers)
    def crba(
        model: B.Model,
        state: B.State,
        repr: int,
        # scratch
        s: wp.array3d(dtype=scalar),
        # outputs
        M: wp.array3d(dtype=scalar),
    ):
        """M (N, 6 + nv, 6 + nv): the mass matrix for the generalized velocity in `repr`.

        The joint block is filled by the model's DoF pairs: M_kj = B_S_j . F_k for (model.pair_k,
        model.pair_j), plus the DoF's armature on the diagonal, zero for (model.zero_k, model.zero_j).
        s (N, max(nL, nv + 1), CRBA_RECORD): scratch, columns named at the top of this file.
        """
        env = wp.tid()
        nL = model.parent.shape[0]
        nv = model.dof_S.shape[0]
        sc.put_transform(s, env, 0, _BH, sp.transform(sp.vec3(scalar(0.0)), sp.quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0))))
        # link poses and motion subspaces in the base, from the base
        for i in range(1, nL):
            X = jm.joint_transform(model, i, state.joint_positions, env)
            B_H_i = sc.get_transform(s, env, model.parent[i], _BH) * X
            sc.put_transform(s, env, i, _BH, B_H_i)
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, i):
                    d = jm.dof_address(model, i) + k_dof
                    sc.put6(s, env, d + 1, _BS, sp.motion_to(B_H_i, jm.dof_motion(model, i, d, X)))
        # composite inertias and F_d, from the leaves
        for k in range(nL - 1):
            i = nL - 1 - k
            B_H_i = sc.get_transform(s, env, i, _BH)
            R = wp.quat_to_matrix(wp.transform_get_rotation(B_H_i))
            m = B.mass_of(model, env, i)
            com = wp.transform_point(B_H_i, B.com_of(model, env, i))
            h = m * com
            I_O = R * B.inertia_of(model, env, i) * wp.transpose(R) + m * (wp.dot(com, com) * wp.identity(n=3, dtype=scalar) - wp.outer(com, com))
            if model.first_child[i] >= 0:
                m = m + s[env, model.first_child[i], _IC]
                h = h + get_h(s, env, model.first_child[i])
                I_O = I_O + get_I_O(s, env, model.first_child[i])
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, i):
                    d = jm.dof_address(model, i) + k_dof
                    S = sc.get6(s, env, d + 1, _BS)
                    sc.put6(s, env, d + 1, _F, sp.stack(m * sp.lin(S) - wp.cross(h, sp.ang(S)), wp.cross(h, sp.lin(S)) + I_O * sp.ang(S)))
            if model.next_sibling[i] >= 0:
                m = m + s[env, model.next_sibling[i], _IC]
                h = h + get_h(s, env, model.next_sibling[i])
                I_O = I_O + get_I_O(s, env, model.next_sibling[i])
            s[env, i, _IC] = m
            s[env, i, _IC + 1] = h[0]
            s[env, i, _IC + 2] = h[1]
            s[env, i, _IC + 3] = h[2]
            s[env, i, _IC + 4] = I_O[0, 0]
            s[env, i, _IC + 5] = I_O[0, 1]
            s[env, i, _IC + 6] = I_O[0, 2]
            s[env, i, _IC + 7] = I_O[1, 1]
            s[env, i, _IC + 8] = I_O[1, 2]
            s[env, i, _IC + 9] = I_O[2, 2]
        # base block (with a floating base's free-joint armature, B.base_rotor) and base-joint columns
        Ic0 = B.spatial_inertia_of(model, env, 0) + B.base_rotor(model, env, scalar(0.0)) * wp.identity(n=6, dtype=scalar)
        if model.first_child[0] >= 0:
            fc = model.first_child[0]
            hc = wp.skew(get_h(s, env, fc))
            I_Oc = get_I_O(s, env, fc)
            mc = s[env, fc, _IC]
            zero = scalar(0.0)
            Ic0 = Ic0 + sp.mat66(
                mc, zero, zero, -hc[0, 0], -hc[0, 1], -hc[0, 2],
                zero, mc, zero, -hc[1, 0], -hc[1, 1], -hc[1, 2],
                zero, zero, mc, -hc[2, 0], -hc[2, 1], -hc[2, 2],
                hc[0, 0], hc[0, 1], hc[0, 2], I_Oc[0, 0], I_Oc[0, 1], I_Oc[0, 2],
                hc[1, 0], hc[1, 1], hc[1, 2], I_Oc[1, 0], I_Oc[1, 1], I_Oc[1, 2],
                hc[2, 0], hc[2, 1], hc[2, 2], I_Oc[2, 0], I_Oc[2, 1], I_Oc[2, 2],
            )  # fmt: skip
        W_H_B = B.base_pose(state, env)
        Mbb = Ic0
        if repr != BODY:
            # T^T Ic0 T with T = B_X_W (Inertial) or B_X_B[W] (Mixed): Ic0 from base to world(-aligned) coordinates
            frame = W_H_B
            if repr != INERTIAL:
                frame = sp.orientation_only(W_H_B)
            Mbb = inertia_to(frame, Ic0)
        for r in range(6):
            for c in range(6):
                M[env, r, c] = Mbb[r, c]
        for k in range(nv):
            col = sp.base_force_from_body(repr, W_H_B, sc.get6(s, env, k + 1, _F))
            for r in range(6):
                M[env, r, 6 + k] = col[r]
                M[env, 6 + k, r] = col[r]
        # joint block: M_kj = M_jk = B_S_j . F_k for each supporting DoF pair, zero between branches
        for p in range(model.pair_k.shape[0]):
            k = model.pair_k[p]
            j = model.pair_j[p]
            value = wp.dot(sc.get6(s, env, j + 1, _BS), sc.get6(s, env, k + 1, _F))
            if j == k:
                value = value + B.armature_of(model, env, k)
            M[env, 6 + k, 6 + j] = value
            if j != k:
                M[env, 6 + j, 6 + k] = value
        for z in range(model.zero_k.shape[0]):
            M[env, 6 + model.zero_k[z], 6 + model.zero_j[z]] = scalar(0.0)

    return types.SimpleNamespace(crba=crba)
