"""Articulated-body algorithm: forward dynamics, one thread per environment.

Featherstone's ABA in link coordinates, gravity entering as a fictitious base acceleration -a_g:
1. v_i = iX_lambda v_lambda + v_J,i,  c_i = v_i x v_J,i + Sdot_i qd_i (kernels/bundles.py's `velocity_product`).
2. From the leaves: IA_i = I_i + sum_c cX_i^T Ia_c cX_i,  pA_i = v_i x* I_i v_i - f_ext_i + sum_c cX_i^T pa_c;
   for each DoF d of link i's joint, the last first (`project_dof`):
   U_d = IA S_d, d_d = S_d^T U_d + armature_d, u_d = tau_d - S_d^T pA,  IA -= U_d U_d^T / d_d,  pA += U_d u_d / d_d;
   then Ia_i = IA, pa_i = pA + Ia_i c_i. A joint of several DoFs is so projected one DoF at a time, as a chain of
   one-DoF joints between massless links in one frame would be (the block projection IA - U D^-1 U^T, D = S^T IA S
   + diag(armature), by elimination). The sums over children are sibling chains (each element written once:
   tape-safe).
3. a'_0 = -IA_0^-1 pA_0 (floating base, its free joint's armature in IA_0 and pA_0: kernels/bundles.py's
   `base_rotor`) or -a_g (fixed base); from the base:
   a'_i = iX_lambda a'_lambda + c_i, then for each DoF d, the first first: qdd_d = (u_d - U_d^T a'_i) / d_d,
   a'_i += S_d qdd_d.
The base acceleration d/dt B_v_WB = a'_0 + a_g is written in the requested representation.

What one pass hands to the next is one scalar record per link and one per DoF (kernels/scratch.py: coalesced on
GPUs; DoF d's at row d + 1, so that a model whose joints have one DoF each has one row per link); what is cheap
to recompute from the joint position (iX_lambda, S_i, c_i) is recomputed instead of stored.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .registers import tuned
from .scratch import SYM66, scratch
from .spatial import BALL, FREE, MIXED, spatial

# Columns of the ABA's scratch record (N, max(nL, nv + 1), ABA_RECORD[+ TRANSFORM with link forces]): a link's at
# row i, a DoF's (_UD) at row d + 1.
_V = 0  # v_i (6): link velocity, link coordinates
_UD = 6  # DoF d's U_d / d_d (6), then u_d / d_d (1)
_IA = 13  # sum over the sibling chain starting at i of iX*_lambda Ia_i lambdaX_i (21: symmetric)
_PA = _IA + SYM66  # the same chain's sum of iX*_lambda pa_i (6)
_A = _PA + 6  # a'_i (6)
_WHL = _A + 6  # W_H_L (7), only with link forces
ABA_RECORD = _WHL
"""Scratch numbers per link without link forces (with them: ABA_RECORD + 7)."""


@factory
def inertia_funcs(scalar) -> types.SimpleNamespace:
    """Spatial-inertia helpers in `scalar`, shared by ABA and CRBA."""
    sp, sc, B = spatial(scalar), scratch(scalar), bundles(scalar)

    @wp.func
    def inertia_to(X: sp.transform, I: sp.mat66):
        """A_X*_B I B_X_A: a symmetric spatial inertia from B to A coordinates, X = A_H_B = (p, R), by 3x3 blocks.

        I = [[K, H], [H^T, L]] goes to [[K', H' - K' p^], [., L' + p^ H' - H'^T p^ - p^ K' p^]] with
        K' = R K R^T, H' = R H R^T, L' = R L R^T (about 200 operations instead of two 6x6 products). The
        products with p^ are cross products (M p^ has the rows m_i x p, p^ M the columns p x m_j), not 3x3
        products whose zeros IEEE arithmetic keeps.
        """
        R = wp.quat_to_matrix(wp.transform_get_rotation(X))
        p = wp.transform_get_translation(X)
        K = sp.mat33(I[0, 0], I[0, 1], I[0, 2], I[1, 0], I[1, 1], I[1, 2], I[2, 0], I[2, 1], I[2, 2])
        H = sp.mat33(I[0, 3], I[0, 4], I[0, 5], I[1, 3], I[1, 4], I[1, 5], I[2, 3], I[2, 4], I[2, 5])
        L = sp.mat33(I[3, 3], I[3, 4], I[3, 5], I[4, 3], I[4, 4], I[4, 5], I[5, 3], I[5, 4], I[5, 5])
        Rt = wp.transpose(R)
        K1 = R * K * Rt
        H1 = R * H * Rt
        KP = wp.matrix_from_rows(wp.cross(K1[0], p), wp.cross(K1[1], p), wp.cross(K1[2], p))  # K' p^
        H1t = wp.transpose(H1)
        PH = wp.matrix_from_cols(wp.cross(p, H1t[0]), wp.cross(p, H1t[1]), wp.cross(p, H1t[2]))  # p^ H'
        KPt = wp.transpose(KP)
        PKP = wp.matrix_from_cols(wp.cross(p, KPt[0]), wp.cross(p, KPt[1]), wp.cross(p, KPt[2]))  # p^ K' p^
        H2 = H1 - KP
        L2 = R * L * Rt + PH + wp.transpose(PH) - PKP
        return sc.sym_upper(sp.mat66(
            K1[0, 0], K1[0, 1], K1[0, 2], H2[0, 0], H2[0, 1], H2[0, 2],
            K1[1, 0], K1[1, 1], K1[1, 2], H2[1, 0], H2[1, 1], H2[1, 2],
            K1[2, 0], K1[2, 1], K1[2, 2], H2[2, 0], H2[2, 1], H2[2, 2],
            H2[0, 0], H2[1, 0], H2[2, 0], L2[0, 0], L2[0, 1], L2[0, 2],
            H2[0, 1], H2[1, 1], H2[2, 1], L2[1, 0], L2[1, 1], L2[1, 2],
            H2[0, 2], H2[1, 2], H2[2, 2], L2[2, 0], L2[2, 1], L2[2, 2],
        ))  # fmt: skip

    @wp.func
    def external_force(controls: B.Controls, repr: int, W_H_L: wp.array3d(dtype=scalar), col: int, env: int, i: int):
        """The external force on link i in its own coordinates, from the controls' link forces in `repr` and
        the link pose stored at W_H_L[env, i, col:col + 7]."""
        X = sc.get_transform(W_H_L, env, i, col)
        return sp.force_from(X, sp.force_repr_to_inertial(repr, X, B.link_force(controls, env, i)))

    @wp.func
    def dof_rotor(model: B.Model, env: int, d: int, implicit_dt: scalar):
        """DoF d's own term of its joint-space inertia: armature_d + implicit_dt damping_d (MuJoCo's implicit
        damping when implicit_dt = dt)."""
        return B.armature_of(model, env, d) + implicit_dt * B.joint_parameter(model.damping, env, d)

    @wp.func
    def joint_force_of(controls: B.Controls, env: int, d: int):
        """The controls' joint force on DoF d, 0 when they hold none."""
        if controls.joint_forces.shape[0] > 0:
            return controls.joint_forces[env, d]
        return scalar(0.0)

    @wp.func
    def project_dof(model: B.Model, controls: B.Controls, env: int, d: int, implicit_dt: scalar, S: sp.vec6, IA: sp.mat66, pA: sp.vec6):
        """ABA's projection of DoF d (motion subspace S) out of an articulated inertia IA and bias force pA (the
        module docstring's step 2): (U_d / d_d, u_d / d_d, IA - U_d U_d^T / d_d, pA + U_d u_d / d_d), with
        d_d = S^T U_d + armature_d + implicit_dt damping_d and u_d with the controls' joint force when given."""
        U = IA * S
        d_inv = scalar(1.0) / (wp.dot(S, U) + dof_rotor(model, env, d, implicit_dt))
        u = joint_force_of(controls, env, d) - wp.dot(S, pA)
        Ud = U * d_inv
        return Ud, u * d_inv, sc.sym_upper(IA - wp.outer(Ud, U)), pA + U * (u * d_inv)

    @wp.func
    def articulated(
        model: B.Model, controls: B.Controls, env: int, d: int, implicit_dt: scalar, S: sp.vec6, IA: sp.mat66, pA: sp.vec6, c_i: sp.vec6
    ):
        """ABA at a link whose joint has the one DoF d (the module docstring's step 2): (U_d / d_d, u_d / d_d,
        Ia_i, pa_i)."""
        Ud, ud, Ia, pA_d = project_dof(model, controls, env, d, implicit_dt, S, IA, pA)
        return Ud, ud, Ia, pA_d + Ia * c_i

    @wp.func
    def free_joint_acceleration(
        model: B.Model, controls: B.Controls, env: int, d: int, implicit_dt: scalar, R: sp.mat33, IA: sp.mat66, pA: sp.vec6, a_i: sp.vec6
    ):
        """(qdd, a'_i + S qdd) at a link whose free joint (DoFs d to d + 5; its motion subspace S = diag(R^T, 1),
        R its own rotation: kernels/joints.py's `free_joint_rotation`) hangs from a parent of known acceleration
        (a fixed base), its DoFs solved together: D qdd = tau - S^T (pA + IA a'_i), D = S^T IA S + diag(`dof_rotor`),
        a'_i = iX_lambda a'_lambda + c_i (`link_acceleration`), by 3x3 blocks (IA = [[K, H], [H^T, L]]:
        D = [[R K R^T, R H], [H^T R^T, L]] + diag(rotor)). It equals the DoF-by-DoF projection and acceleration
        of steps 2 and 3 (the block elimination they perform one DoF at a time), for a joint whose parent's terms
        no one needs (kernels/fused_step.py)."""
        K = sp.mat33(IA[0, 0], IA[0, 1], IA[0, 2], IA[1, 0], IA[1, 1], IA[1, 2], IA[2, 0], IA[2, 1], IA[2, 2])
        H = sp.mat33(IA[0, 3], IA[0, 4], IA[0, 5], IA[1, 3], IA[1, 4], IA[1, 5], IA[2, 3], IA[2, 4], IA[2, 5])
        L = sp.mat33(IA[3, 3], IA[3, 4], IA[3, 5], IA[4, 3], IA[4, 4], IA[4, 5], IA[5, 3], IA[5, 4], IA[5, 5])
        r_lin = sp.vec3(dof_rotor(model, env, d, implicit_dt), dof_rotor(model, env, d + 1, implicit_dt), dof_rotor(model, env, d + 2, implicit_dt))
        r_ang = sp.vec3(dof_rotor(model, env, d + 3, implicit_dt), dof_rotor(model, env, d + 4, implicit_dt), dof_rotor(model, env, d + 5, implicit_dt))
        RH = R * H
        w = pA + IA * a_i
        tau_lin = sp.vec3(joint_force_of(controls, env, d), joint_force_of(controls, env, d + 1), joint_force_of(controls, env, d + 2))
        tau_ang = sp.vec3(joint_force_of(controls, env, d + 3), joint_force_of(controls, env, d + 4), joint_force_of(controls, env, d + 5))
        x1, x2 = sp.solve_spd6_blocks(
            R * K * wp.transpose(R) + wp.diag(r_lin), RH, wp.transpose(RH), L + wp.diag(r_ang), tau_lin - R * sp.lin(w), tau_ang - sp.ang(w)
        )
        return sp.stack(x1, x2), a_i + sp.stack(wp.transpose(R) * x1, x2)

    @wp.func
    def with_implicit_contacts(model: B.Model, controls: B.Controls, env: int, i: int, W_H_L: sp.transform, IA: sp.mat66, pA: sp.vec6):
        """(IA + A_i, pA - g_i + A_i a_g): link i's own articulated inertia and bias force with its contacts' linearly
        implicit terms (controls.link_implicit, link coordinates: kernels/implicit_contacts.py), W_H_L its pose. The
        contacts respond to the link's true acceleration a'_i + a_g, hence A_i a_g (a_g: gravity in link i's
        coordinates, `gravity_in`), as the base's rotor in `base_bias_force`."""
        A = sc.get_sym66(controls.link_implicit, env, i, 0)
        return IA + A, pA - sc.get6(controls.link_implicit, env, i, SYM66) + A * B.gravity_in(model, env, W_H_L)

    @wp.func
    def bias_force(v: sp.vec6, I_v: sp.vec6):
        """A link's velocity-product force v_i x* I_i v_i (link coordinates): v its velocity, I_v its spatial
        inertia times v; its own bias force is this less the external force on it (step 2's first terms of pA_i)."""
        return sp.cross_force(v, I_v)

    @wp.func
    def base_inertia(model: B.Model, env: int, implicit_dt: scalar):
        """A floating base's own articulated inertia (body coordinates), its children's not yet added: I_0 + r 1,
        r its free joint's armature (+ implicit_dt damping: B.base_rotor) (step 3)."""
        return sc.sym_upper(B.spatial_inertia_of(model, env, 0)) + B.base_rotor(model, env, implicit_dt) * wp.identity(n=6, dtype=scalar)

    @wp.func
    def base_bias_force(model: B.Model, env: int, implicit_dt: scalar, B_v: sp.vec6, B_a_g: sp.vec6):
        """A floating base's own bias force (body coordinates) but the external force on it, its children's not
        yet added: v x* I_0 v plus its rotor's (`base_inertia`) velocity product and r a_g: the rotor acts on the
        true acceleration a'_0 + a_g (step 3)."""
        rotor = B.base_rotor(model, env, implicit_dt)
        return bias_force(B_v, B.spatial_inertia_times(model, env, 0, B_v)) + B.base_rotor_bias(model, env, B_v, implicit_dt) + rotor * B_a_g

    @wp.func
    def base_acceleration(model: B.Model, IA: sp.mat66, pA: sp.vec6, B_a_g: sp.vec6):
        """a'_0: -IA_0^-1 pA_0 for a floating base (its whole articulated inertia and bias force), -a_g for a
        fixed one (step 3)."""
        if model.floating_base != 0:
            return -sp.solve_spd6(IA, pA)
        return -B_a_g

    @wp.func
    def link_acceleration(X: sp.transform, a_parent: sp.vec6, c_i: sp.vec6):
        """a'_i before its joint's accelerations: iX_lambda a'_lambda + c_i (step 3)."""
        return sp.motion_from(X, a_parent) + c_i

    @wp.func
    def dof_acceleration(Ud: sp.vec6, ud: scalar, a_i: sp.vec6):
        """qdd_d = u_d / d_d - (U_d / d_d)^T a'_i (step 3), from DoF d's record."""
        return ud - wp.dot(Ud, a_i)

    return types.SimpleNamespace(
        inertia_to=inertia_to,
        external_force=external_force,
        dof_rotor=dof_rotor,
        project_dof=project_dof,
        articulated=articulated,
        free_joint_acceleration=free_joint_acceleration,
        with_implicit_contacts=with_implicit_contacts,
        bias_force=bias_force,
        base_inertia=base_inertia,
        base_bias_force=base_bias_force,
        base_acceleration=base_acceleration,
        link_acceleration=link_acceleration,
        dof_acceleration=dof_acceleration,
    )


MAX_REGISTERS = {wp.float32: 128, wp.float64: None}
"""Register cap per thread on CUDA by scalar, measured on an H200 at N = 65536 (benchmarks/results/dynamics_h200_run2.md):
in float32 the compiler's 168 registers allow 8 or 12 warps per multiprocessor, two waves for 65536 threads;
128 registers (light spills) allow 16 warps, one wave: kernel 0.147 -> 0.113 ms. In float64 a cap spills
heavily (0.21 -> 0.31 ms at 128)."""


@tuned(MAX_REGISTERS)
def kernels(scalar, max_registers, multi_dof: bool):
    """ABA (forward dynamics) in `scalar`, its registers per thread capped on CUDA by `max_registers` (kernels/registers.py),
    for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    sc = scratch(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)
    F = inertia_funcs(scalar)
    inertia_to, external_force, project_dof = F.inertia_to, F.external_force, F.project_dof

    @wp.func
    def put_dof(s: wp.array3d(dtype=scalar), env: int, d: int, Ud: sp.vec6, ud: scalar):
        """DoF d's record (U_d / d_d, u_d / d_d), at row d + 1."""
        sc.put6(s, env, d + 1, _UD, Ud)
        s[env, d + 1, _UD + 6] = ud

    @wp.func
    def articulated_joint(
        model: B.Model, controls: B.Controls, env: int, i: int, implicit_dt: scalar, X: sp.transform, IA: sp.mat66, pA: sp.vec6,
        c_i: sp.vec6, s: wp.array3d(dtype=scalar),
    ):
        """ABA at link i (step 2): (Ia_i, pa_i), its joint's DoFs projected the last first (a ball joint's 3, a
        free joint's 6: loops of fixed length), each DoF's record written to s (`put_dof`); X: the joint's
        transform. A loop per kind rather than one to jm.MAX_DOFS with `k < count` (as RNEA's): that one spilled
        twice the bytes in the multi-DoF variant (ptxas, sm_90: float64 304 B of spill stores against 148)."""
        a = jm.dof_address(model, i)
        if wp.static(multi_dof):
            kind = model.joint_type[i]
            if kind == BALL:
                for k in range(3):
                    d = a + 2 - k
                    Ud, ud, IA, pA = project_dof(model, controls, env, d, implicit_dt, jm.dof_motion(model, i, d, X), IA, pA)
                    put_dof(s, env, d, Ud, ud)
                return IA, pA + IA * c_i
            if kind == FREE:
                for k in range(6):
                    d = a + 5 - k
                    Ud, ud, IA, pA = project_dof(model, controls, env, d, implicit_dt, jm.dof_motion(model, i, d, X), IA, pA)
                    put_dof(s, env, d, Ud, ud)
                return IA, pA + IA * c_i
        Ud, ud, Ia, pa = project_dof(model, controls, env, a, implicit_dt, model.dof_S[a], IA, pA)
        put_dof(s, env, a, Ud, ud)
        return Ia, pa + Ia * c_i

    @wp.func
    def accelerate_dof(s: wp.array3d(dtype=scalar), env: int, d: int, a_i: sp.vec6):
        """DoF d's qdd_d (`dof_acceleration`) from its record in s."""
        return F.dof_acceleration(sc.get6(s, env, d + 1, _UD), s[env, d + 1, _UD + 6], a_i)

    @wp.func
    def accelerate_joint(
        model: B.Model, env: int, i: int, X: sp.transform, a_i: sp.vec6, s: wp.array3d(dtype=scalar), qdd: wp.array2d(dtype=scalar)
    ):
        """ABA at link i (step 3) from a'_i = iX_lambda a'_lambda + c_i: each DoF's qdd_d, the first first, written
        to qdd (N, nv); returns a_i = a'_i + S_i qdd_i."""
        a = jm.dof_address(model, i)
        if wp.static(multi_dof):
            kind = model.joint_type[i]
            if kind == BALL:
                for k in range(3):
                    q_dd = accelerate_dof(s, env, a + k, a_i)
                    qdd[env, a + k] = q_dd
                    a_i = a_i + jm.dof_motion(model, i, a + k, X) * q_dd
                return a_i
            if kind == FREE:
                for k in range(6):
                    q_dd = accelerate_dof(s, env, a + k, a_i)
                    qdd[env, a + k] = q_dd
                    a_i = a_i + jm.dof_motion(model, i, a + k, X) * q_dd
                return a_i
        q_dd = accelerate_dof(s, env, a, a_i)
        qdd[env, a] = q_dd
        return a_i + model.dof_S[a] * q_dd

    @wp.kernel(module="unique", cuda_max_registers=max_registers)
    def aba(
        model: B.Model,
        state: B.State,
        controls: B.Controls,
        repr: int,
        implicit_dt: scalar,
        # scratch
        s: wp.array3d(dtype=scalar),
        # outputs
        base_acceleration: wp.array2d(dtype=scalar),
        joint_accelerations: wp.array2d(dtype=scalar),
    ):
        """base_acceleration (N, 6): d/dt of the base velocity in `repr` (zero for a fixed base);
        joint_accelerations (N, nv).

        controls: joint forces (N, nv) and external link forces (N, nL, 6) in `repr` (either may be absent).
        The joint-space inertia of DoF d is S_d^T IA S_d + armature_d + implicit_dt damping_d: with
        implicit_dt = dt this solves (M + dt diag(damping)) nu_dot = f, MuJoCo's implicit damping (0: none).
        controls' link_implicit (N, nL, 27), given with the link forces: each link's contact terms A_L added to its
        articulated inertia and g_L to its force (kernels/implicit_contacts.py: the step's linearly implicit contacts).
        s (N, max(nL, nv + 1), ABA_RECORD, + 7 with link forces): scratch, columns named at the top of this file.
        """
        env = wp.tid()
        nL = model.parent.shape[0]
        forces = controls.link_forces.shape[0] > 0
        implicit = controls.link_implicit.shape[0] > 0
        W_H_B = B.base_pose(state, env)
        B_v = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(state, env)))
        B_a_g = B.gravity_in(model, env, W_H_B)
        sc.put6(s, env, 0, _V, B_v)
        if forces:
            sc.put_transform(s, env, 0, _WHL, W_H_B)
        # 1. velocities, from the base
        for i in range(1, nL):
            X = jm.joint_transform(model, i, state.joint_positions, env)
            vJ = jm.joint_motion_of(model, i, X, state.joint_velocities, env)
            sc.put6(s, env, i, _V, jm.link_velocity(X, sc.get6(s, env, model.parent[i], _V), vJ))
            if forces:
                sc.put_transform(s, env, i, _WHL, sc.get_transform(s, env, model.parent[i], _WHL) * X)
        # 2. articulated inertias and bias forces, from the leaves
        for k in range(nL - 1):
            i = nL - 1 - k
            X = jm.joint_transform(model, i, state.joint_positions, env)
            v_i = sc.get6(s, env, i, _V)
            c_i = jm.velocity_product(model, i, v_i, jm.joint_motion_of(model, i, X, state.joint_velocities, env))
            IA = sc.sym_upper(B.spatial_inertia_of(model, env, i))
            pA = F.bias_force(v_i, IA * v_i)
            if forces:
                pA = pA - external_force(controls, repr, s, _WHL, env, i)
            if implicit:
                IA, pA = F.with_implicit_contacts(model, controls, env, i, sc.get_transform(s, env, i, _WHL), IA, pA)
            if model.first_child[i] >= 0:
                IA = sc.sym_upper(IA + sc.get_sym66(s, env, model.first_child[i], _IA))
                pA = pA + sc.get6(s, env, model.first_child[i], _PA)
            Ia, pa = articulated_joint(model, controls, env, i, implicit_dt, X, IA, pA, c_i, s)
            chain_I = inertia_to(X, Ia)
            chain_p = sp.force_to(X, pa)
            if model.next_sibling[i] >= 0:
                chain_I = sc.sym_upper(chain_I + sc.get_sym66(s, env, model.next_sibling[i], _IA))
                chain_p = chain_p + sc.get6(s, env, model.next_sibling[i], _PA)
            sc.put_sym66(s, env, i, _IA, chain_I)
            sc.put6(s, env, i, _PA, chain_p)
        # 3. accelerations, from the base
        a0 = -B_a_g
        if model.floating_base != 0:
            IA0 = F.base_inertia(model, env, implicit_dt)
            pA0 = F.base_bias_force(model, env, implicit_dt, B_v, B_a_g)
            if forces:
                pA0 = pA0 - external_force(controls, repr, s, _WHL, env, 0)
            if implicit:
                IA0, pA0 = F.with_implicit_contacts(model, controls, env, 0, W_H_B, IA0, pA0)
            if model.first_child[0] >= 0:
                IA0 = IA0 + sc.get_sym66(s, env, model.first_child[0], _IA)
                pA0 = pA0 + sc.get6(s, env, model.first_child[0], _PA)
            a0 = F.base_acceleration(model, IA0, pA0, B_a_g)
        sc.put6(s, env, 0, _A, a0)
        for i in range(1, nL):
            X = jm.joint_transform(model, i, state.joint_positions, env)
            c_i = jm.velocity_product(model, i, sc.get6(s, env, i, _V), jm.joint_motion_of(model, i, X, state.joint_velocities, env))
            a_i = accelerate_joint(model, env, i, X, F.link_acceleration(X, sc.get6(s, env, model.parent[i], _A), c_i), s, joint_accelerations)
            if model.first_child[i] >= 0:
                sc.put6(s, env, i, _A, a_i)
        base = sp.vec6(scalar(0.0))
        if model.floating_base != 0:
            base = sp.base_acceleration_from_body(repr, W_H_B, B_v, a0 + B_a_g)
        for r in range(6):
            base_acceleration[env, r] = base[r]

    return types.SimpleNamespace(aba=aba)
