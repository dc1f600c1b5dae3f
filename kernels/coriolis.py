"""The free-floating Coriolis matrix C(q, nu): O(n) composite terms, then O(n^2) dot products.

C is JaxSim's (jaxsim.api.model.free_floating_coriolis_matrix, ~0.9): in the Body representation
    C_B = sum_L L_J_L^T ((L_v_L x* M_L + M_L L_v_L x) L_J_L + M_L L_Jdot_L),
with the doubly-left (body input, body output) link Jacobians, and in representation r
    C = T^T (M_B Tdot + C_B T),   T = blockdiag(T_b, 1_n),   nu_B = T nu,
T_b = B_X_W (Inertial), B_X_B[W] (Mixed), 1 (Body). That C satisfies C nu = h - g and, being of the
form sum_L J^T ((X - X^T) J + M Jdot) with X = v x* M, makes Mdot - 2C skew-symmetric.

Instead of materialising the Jacobians, this follows the recursive structure of Echeandia and Wensing
(2021), "Numerical methods to compute the Coriolis matrix and Christoffel symbols for rigid-body systems",
ASME JCND 16(9): composite per-subtree terms, then one dot product per entry. (Their per-body matrix
B_i = 1/2 ((v x*) I + (I v) x̄* - I (v x)) gives the Christoffel-consistent C; the per-link term below is
JaxSim's instead, so that the result is JaxSim's C, another valid factorisation.) Everything is in base
coordinates (as in crba.py: composite quantities add without transforms, and float32 does not lose digits
to the base's distance from the world origin):
- the columns of the Body-input Jacobian are u_c = e_c for the base (c < 6) and the DoFs' motion subspaces
  S_j = B_X_{L_j} S_j (L_j: the link DoF j's joint moves), and each link's velocity of the world is v_L =
  B_v_WB + sum over its supporting DoFs of S_j sdot_j, all in B coordinates;
- JaxSim's per-link term, moved to B coordinates, is u_a^T ((v_L x*) I_L u_b + I_L udot_b), where udot is
  the world-frame time derivative of a column expressed in B coordinates: udot_c = v_B x e_c (base),
  Sdot_j = v_{L_j} x S_j + B_X_{L_j} S̊_j (DoFs; S̊_j the apparent derivative of a free joint's translational
  columns, kernels/bundles.py's `dof_motion_rate`, 0 otherwise), and I_L is the link's inertia in B coordinates. (The body-frame
  derivative is L_Jdot = L_X_W (udot - v_L x u); its -v_L x u part cancels JaxSim's M_L (v_L x) term.)
- column a acts on the links of its subtree (the base columns on all), so entry (a, b) sums over the
  subtree of the deeper of a and b (zero unless one supports the other), with the composites
      Ic_i = sum_{L in subtree(i)} I_L,    Bc_i = sum_{L in subtree(i)} (v_L x*) I_L;
  C_ab = u_a . (Bc_d u_b + Ic_d udot_b), d the deeper column. Hence, per DoF column i (of link l),
      F_i = Ic_l S_i,   f_i = Bc_l S_i + Ic_l Sdot_i,   g_i = Bc_l^T S_i,
  and, j, k DoFs:  C_kj = S_k . f_j  (k's joint supports j's link: j is the deeper, or the same joint),
                   C_kj = g_k . S_j + F_k . Sdot_j  (j's joint strictly supports k's link),
  C_B base block = Bc_0 + Ic_0 (v_B x), base row of joint k = g_k - v_B x* F_k, base column = f_j.
- The representation change touches only the base rows and columns: Tdot_b = -(w x) T_b with
  w = B_v_WB (Inertial), [0; B_omega] (Mixed), 0 (Body), and the base columns of M_B are [Ic_0; F_k^T],
  so with v_rel = B_v_WB - w ([0] Inertial, [B_v_lin; 0] Mixed, B_v_WB Body):
      C_bb = T_b^T (Bc_0 + Ic_0 (v_rel x)) T_b,   C_{b, 6+j} = T_b^T f_j,   C_{6+k, b} = T_b^T (g_k - v_rel x* F_k),
  and the joint block is the same in every representation.
Fixed bases are treated as floating bases at rest (the base velocity is zero), consistently with
warpdyn's M, h and g, which keep the base rows (see warpdyn._coriolis for how this differs from JaxSim).

Two launches: `coriolis_links` (one thread per environment: the recursions over links, the base rows
and columns) and `coriolis_joints` (one thread per (environment, DoF row): the joint block). Per-DoF records
are at row d + 1.
Tape discipline (kernels/__init__.py): every scratch and output element is written once; the sums over
children are sibling chains as in crba.py; every local assigned in a dynamic loop has a name of its own.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import INERTIAL, MIXED, spatial


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The kernels in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)

    @wp.func
    def base_inertia(B_H_L: sp.transform, mass: scalar, com: sp.vec3, inertia: sp.mat33):
        """A link's spatial inertia in base coordinates: L_X_B^T L_M_L L_X_B."""
        L_X_B = sp.motion_matrix_from(B_H_L)
        return wp.transpose(L_X_B) * sp.spatial_inertia(mass, com, inertia) * L_X_B

    @wp.func
    def relative_base_velocity(repr: int, B_v: sp.vec6):
        """v_rel = B_v_WB - w, where Tdot_b = -(w x) T_b (see the module docstring)."""
        if repr == MIXED:
            return sp.stack(sp.lin(B_v), sp.vec3(scalar(0.0)))
        if repr == INERTIAL:
            return sp.vec6(scalar(0.0))
        return B_v

    @wp.kernel(module="unique")
    def coriolis_links(
        model: B.Model,
        state: B.State,
        repr: int,
        # scratch
        B_H_L: wp.array2d(dtype=sp.transform),
        B_v_L: wp.array2d(dtype=sp.vec6),
        acc_I: wp.array2d(dtype=sp.mat66),
        acc_B: wp.array2d(dtype=sp.mat66),
        # outputs (per DoF d at row d + 1, read by coriolis_joints)
        B_S: wp.array2d(dtype=sp.vec6),
        B_Sdot: wp.array2d(dtype=sp.vec6),
        F: wp.array2d(dtype=sp.vec6),
        f: wp.array2d(dtype=sp.vec6),
        g: wp.array2d(dtype=sp.vec6),
        # outputs
        C: wp.array3d(dtype=scalar),
    ):
        """C (N, 6 + nv, 6 + nv): the base rows and columns, in `repr`; per DoF d (N, nv + 1) at row d + 1, row 0
        unused: B_S_d, B_Sdot_d, F_d = Ic S_d, f_d = Bc S_d + Ic Sdot_d, g_d = Bc^T S_d (the module docstring).
        B_H_L, B_v_L, acc_I, acc_B (N, nL): per link."""
        env = wp.tid()
        nL = model.parent.shape[0]
        W_H_B = B.base_pose(state, env)
        B_v_B = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(state, env)))
        v_rel = relative_base_velocity(repr, B_v_B)
        zero6 = sp.vec6(scalar(0.0))
        B_H_L[env, 0] = sp.transform(sp.vec3(scalar(0.0)), sp.quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0)))
        B_v_L[env, 0] = B_v_B
        B_S[env, 0] = zero6
        B_Sdot[env, 0] = zero6
        F[env, 0] = zero6
        f[env, 0] = zero6
        g[env, 0] = zero6
        # Forward pass: poses, joint axes and world-relative velocities in base coordinates.
        for i in range(1, nL):
            X_i = jm.joint_transform(model, i, state.joint_positions, env)
            B_H_i = B_H_L[env, model.parent[i]] * X_i
            vJ = jm.joint_motion_of(model, i, X_i, state.joint_velocities, env)
            v_i = B_v_L[env, model.parent[i]] + sp.motion_to(B_H_i, vJ)
            B_H_L[env, i] = B_H_i
            B_v_L[env, i] = v_i
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, i):
                    d = jm.dof_address(model, i) + k_dof
                    S_d = sp.motion_to(B_H_i, jm.dof_motion(model, i, d, X_i))
                    B_S[env, d + 1] = S_d
                    B_Sdot[env, d + 1] = sp.cross_motion(v_i, S_d) + sp.motion_to(B_H_i, jm.dof_motion_rate(model, i, d, X_i, vJ))
        # Backward pass: composites Ic, Bc by sibling chains; per joint F, f, g and the base row and column.
        for k in range(nL - 1):
            l = nL - 1 - k
            I_l = base_inertia(B_H_L[env, l], B.mass_of(model, env, l), B.com_of(model, env, l), B.inertia_of(model, env, l))
            Ic_l = I_l
            Bc_l = sp.force_cross_matrix(B_v_L[env, l]) * I_l
            if model.first_child[l] >= 0:
                Ic_l = Ic_l + acc_I[env, model.first_child[l]]
                Bc_l = Bc_l + acc_B[env, model.first_child[l]]
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, l):
                    d = jm.dof_address(model, l) + k_dof
                    S_d = B_S[env, d + 1]
                    F_d = Ic_l * S_d
                    f_d = Bc_l * S_d + Ic_l * B_Sdot[env, d + 1]
                    g_d = wp.transpose(Bc_l) * S_d
                    F[env, d + 1] = F_d
                    f[env, d + 1] = f_d
                    g[env, d + 1] = g_d
                    column = sp.base_force_from_body(repr, W_H_B, f_d)
                    row = sp.base_force_from_body(repr, W_H_B, g_d - sp.cross_force(v_rel, F_d))
                    for r in range(6):
                        C[env, r, 6 + d] = column[r]
                        C[env, 6 + d, r] = row[r]
            chain_I = Ic_l
            chain_B = Bc_l
            if model.next_sibling[l] >= 0:
                chain_I = chain_I + acc_I[env, model.next_sibling[l]]
                chain_B = chain_B + acc_B[env, model.next_sibling[l]]
            acc_I[env, l] = chain_I
            acc_B[env, l] = chain_B
        # The base block.
        # the base's inertia with its free joint's armature a I (body coordinates), which takes JaxSim's link term as
        # an inertia does: skew, and (v x*) a v = [a omega x v; 0], the armature's bias (B.base_rotor_bias)
        I_0 = B.spatial_inertia_of(model, env, 0) + B.base_rotor(model, env, scalar(0.0)) * wp.identity(n=6, dtype=scalar)
        Ic_0 = I_0
        Bc_0 = sp.force_cross_matrix(B_v_B) * I_0
        if model.first_child[0] >= 0:
            Ic_0 = Ic_0 + acc_I[env, model.first_child[0]]
            Bc_0 = Bc_0 + acc_B[env, model.first_child[0]]
        T = sp.base_T(repr, W_H_B)
        C_bb = wp.transpose(T) * (Bc_0 + Ic_0 * sp.motion_cross_matrix(v_rel)) * T
        for a in range(6):
            for b in range(6):
                C[env, a, b] = C_bb[a, b]

    @wp.kernel(module="unique")
    def coriolis_joints(
        model: B.Model,
        # per link, from coriolis_links
        B_S: wp.array2d(dtype=sp.vec6),
        B_Sdot: wp.array2d(dtype=sp.vec6),
        F: wp.array2d(dtype=sp.vec6),
        f: wp.array2d(dtype=sp.vec6),
        g: wp.array2d(dtype=sp.vec6),
        # outputs
        C: wp.array3d(dtype=scalar),
    ):
        """C[:, 6 + k, 6:] (the joint block, row k), launched over (N, nv); model.support[L, J] != 0 when joint J
        moves link L (joint J is link J + 1's; DoF d's joint is model.dof_joint[d])."""
        env, k = wp.tid()
        K = model.dof_joint[k]
        S_k = B_S[env, k + 1]
        F_k = F[env, k + 1]
        g_k = g[env, k + 1]
        for j in range(model.dof_joint.shape[0]):
            J = model.dof_joint[j]
            value = scalar(0.0)
            if model.support[J + 1, K] != 0:
                value = wp.dot(S_k, f[env, j + 1])
            elif model.support[K + 1, J] != 0:
                value = wp.dot(g_k, B_S[env, j + 1]) + wp.dot(F_k, B_Sdot[env, j + 1])
            C[env, 6 + k, 6 + j] = value

    return types.SimpleNamespace(
        coriolis_links=coriolis_links,
        coriolis_joints=coriolis_joints,
    )
