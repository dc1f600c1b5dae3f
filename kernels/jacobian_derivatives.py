"""Time derivatives of free-floating Jacobians, and bias accelerations J̇ν, of frames rigidly attached to links.

Notation as in kernels/jacobians.py: a target F is a frame at link_H_target on link L. The Jacobian with
input representation I and output representation O is
    J = O_X_W · [u_c],    u_c = W_X_A e_c (c < 6, base columns),    u_{6+d} = W_X_{L_d} S_d κ_d (DoFs),
where κ_d = 1 when DoF d's joint supports L (else 0), L_d the link that joint moves, and A is the frame in which the input
representation expresses the base velocity: W (Inertial), B (Body) or B[W] (Mixed); likewise O_X_W maps an
Inertial velocity of F to representation O, whose frame is W (Inertial), F (Body) or F[W] (Mixed).

Every frame C moving with Inertial velocity W_v_WC has d/dt W_X_C = (W_v_WC ×) W_X_C and
d/dt C_X_W = -C_X_W (W_v_WC ×). Hence, column by column (u̇_c = W_v_WA × u_c for the base columns,
u̇_{6+d} = W_v_{W L_d} × u_{6+d} + W_X_{L_d} S̊_d for the DoF columns, S̊_d the apparent derivative of S_d in
L_d: 0 but for a free joint's translations, kernels/bundles.py's `dof_motion_rate`),
    J̇ e_c = O_X_W ((W_v_WC_c − W_v_WO) × u_c [+ W_X_{L_d} S̊_d]),    C_c = A for c < 6, L_d for c = 6 + d,
with the Inertial velocities of the representation frames (`repr_frame_velocity`):
    W (Inertial): 0;    B or F (Body): the body's W_v;    B[W] or F[W] (Mixed): [W_ṗ_origin; 0].
The time derivative is along the motion of the state: the base velocity and the joint velocities.

Bias accelerations J̇ν: summing the columns against ν (in the input representation), with
Σ_c u_c ν_c = W_v_WL,
    J̇ν = O_X_W (W_v_WA × W_v_WB + W_a_L − W_v_WO × W_v_WL),    W_a_L = Σ_{d supports L} u̇_d ṡ_d,
where W_a_L follows the tree in `link_bias_recursion`: W_a_i = W_a_λ(i) + W_v_Wλ(i) × (W_X_i v_J,i) + W_X_i Ṡ_i ṡ_i
(W_v_Wi × u = W_v_Wλ(i) × u, as u × u = 0; Ṡ_i ṡ_i: `joint_motion_rate`), W_a_0 = 0.

Each output element is written once per launch; per-link arrays are written before children read them.
Tape gradients: a name assigned in a dynamic loop must not also be assigned before it (e.g. in an unrolled
loop): Warp 1.19 then treats it as loop-carried and the earlier loop's adjoint reads the later value.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import BODY, MIXED, spatial


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The kernels in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)

    @wp.func
    def repr_frame_velocity(repr: int, W_H_F: sp.transform, W_v_WF: sp.vec6):
        """W_v_WX: the Inertial velocity of the frame X in which `repr` expresses F's velocity.

        X is F (Body), F[W] (Mixed: F's origin moving with W_pdot_F, no rotation) or W (Inertial, at rest).
        """
        if repr == BODY:
            return W_v_WF
        if repr == MIXED:
            W_pdot_F = sp.lin(W_v_WF) + wp.cross(sp.ang(W_v_WF), wp.transform_get_translation(W_H_F))
            return sp.stack(W_pdot_F, sp.vec3(scalar(0.0)))
        return sp.vec6(scalar(0.0))

    @wp.kernel(module="unique")
    def link_bias_recursion(
        model: B.Model,
        W_H_L: wp.array2d(dtype=sp.transform),
        state: B.State,
        # outputs
        W_v_WL: wp.array2d(dtype=sp.vec6),
        W_a_L: wp.array2d(dtype=sp.vec6),
    ):
        """W_v_WL (N, nL): Inertial link velocities; W_a_L (N, nL): Σ_j W_v_{W L_j} × W_X_{L_j} S_j ṡ_j over
        the joints supporting each link. W_H_L (N, nL): the link poses at the state."""
        env = wp.tid()
        W_v_WL[env, 0] = sp.repr_to_inertial(MIXED, W_H_L[env, 0], B.base_velocity_mixed(state, env))
        W_a_L[env, 0] = sp.vec6(scalar(0.0))
        for i in range(1, model.parent.shape[0]):
            vJ = jm.joint_motion_of(model, i, jm.joint_frame_motion(model, i, W_H_L, env), state.joint_velocities, env)
            u = sp.motion_to(W_H_L[env, i], vJ)
            W_v_WL[env, i] = W_v_WL[env, model.parent[i]] + u
            rate = sp.motion_to(W_H_L[env, i], jm.joint_motion_rate(model, i, vJ))
            W_a_L[env, i] = W_a_L[env, model.parent[i]] + sp.cross_motion(W_v_WL[env, model.parent[i]], u) + rate

    @wp.kernel(module="unique")
    def jacobian_derivatives(
        model: B.Model,
        targets: B.Targets,
        # the links' poses and Inertial velocities (N, nL)
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        input_repr: int,
        output_repr: int,
        # outputs
        Jdot: wp.array4d(dtype=scalar),
    ):
        """Jdot (N, T, 6, 6 + nv): d/dt of the Jacobian of target t (kernels/jacobians.py), launched over (N, T)."""
        env, t = wp.tid()
        L = targets.link[t]
        W_H_F = W_H_L[env, L] * B.target_pose(targets, env, t)
        W_H_B = W_H_L[env, 0]
        v_O = repr_frame_velocity(output_repr, W_H_F, W_v_WL[env, L])
        v_A = repr_frame_velocity(input_repr, W_H_B, W_v_WL[env, 0])
        for c in range(6):
            e = sp.vec6(scalar(0.0))
            e[c] = scalar(1.0)
            u = sp.repr_to_inertial(input_repr, W_H_B, e)
            col = sp.inertial_to_repr(output_repr, W_H_F, sp.cross_motion(v_A - v_O, u))
            for r in range(6):
                Jdot[env, t, r, c] = col[r]
        # Fresh names in the dynamic loop: a name assigned there that also exists outside it (as `u` and `col`
        # of the unrolled loop above) becomes loop-carried in Warp's codegen, and its adjoint goes wrong.
        for i in range(1, model.parent.shape[0]):  # link i's joint, joint i - 1
            moves = model.support[L, i - 1] != 0
            X_i = wp.transform_identity(dtype=scalar)
            vJ_i = sp.vec6(scalar(0.0))
            if moves:
                X_i = jm.joint_frame_motion(model, i, W_H_L, env)
                vJ_i = sp.motion_from(W_H_L[env, i], W_v_WL[env, i] - W_v_WL[env, model.parent[i]])
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, i):
                    d = jm.dof_address(model, i) + k_dof
                    col_d = sp.vec6(scalar(0.0))
                    if moves:
                        u_d = sp.motion_to(W_H_L[env, i], jm.dof_motion(model, i, d, X_i))
                        rate_d = sp.motion_to(W_H_L[env, i], jm.dof_motion_rate(model, i, d, X_i, vJ_i))
                        col_d = sp.inertial_to_repr(output_repr, W_H_F, sp.cross_motion(W_v_WL[env, i] - v_O, u_d) + rate_d)
                    for r in range(6):
                        Jdot[env, t, r, 6 + d] = col_d[r]

    @wp.kernel(module="unique")
    def bias_accelerations(
        targets: B.Targets,
        # the links' poses, Inertial velocities and W_a_L (link_bias_recursion) (N, nL)
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        W_a_L: wp.array2d(dtype=sp.vec6),
        input_repr: int,
        output_repr: int,
        # outputs
        a: wp.array3d(dtype=scalar),
    ):
        """a (N, T, 6): J̇ν of target t in output_repr, ν in input_repr; launched over (N, T)."""
        env, t = wp.tid()
        L = targets.link[t]
        W_H_F = W_H_L[env, L] * B.target_pose(targets, env, t)
        W_v_WB = W_v_WL[env, 0]
        v_L = W_v_WL[env, L]
        v_O = repr_frame_velocity(output_repr, W_H_F, v_L)
        v_A = repr_frame_velocity(input_repr, W_H_L[env, 0], W_v_WB)
        acc = sp.cross_motion(v_A, W_v_WB) + W_a_L[env, L] - sp.cross_motion(v_O, v_L)
        out = sp.inertial_to_repr(output_repr, W_H_F, acc)
        for r in range(6):
            a[env, t, r] = out[r]

    return types.SimpleNamespace(
        repr_frame_velocity=repr_frame_velocity,
        link_bias_recursion=link_bias_recursion,
        jacobian_derivatives=jacobian_derivatives,
        bias_accelerations=bias_accelerations,
    )
