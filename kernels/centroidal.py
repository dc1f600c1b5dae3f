"""Centroidal quantities, momentum and energy, one thread per environment.

Notation (kernels/spatial.py conventions): G[W] = (W_p_G, [W]) is the frame at the centre of mass G
with the world's orientation. Every sum over links is taken about G in world axes, which keeps
float32 accurate however far the robot is from the world origin:
- link L (mass m_L, CoM c_L in its frame, rotational inertia I_L about the CoM in link axes) has its
  CoM at W_p_CL = W_H_L c_L, d_L = W_p_CL - W_p_G, and rotational inertia W_I_L = W_R_L I_L W_R_L^T;
- a spatial inertia about G in world axes is the triple (m, h, I): m the mass, h = sum m d the first
  moment about G, I the rotational inertia about G; it maps the G[W] velocity v = [u; w] of a rigid
  body to its momentum  M v = [m u - h x w; h x u + I w]  (for one link: h = m d,
  I = W_I_L + m (|d|^2 1 - d d^T));
- the centroidal momentum G[W]_h = sum_L [m_L W_pdot_CL; d_L x m_L W_pdot_CL + W_I_L W_omega_L];
- the kinetic energy K = sum_L 1/2 (m_L |W_pdot_CL|^2 + W_omega_L . W_I_L W_omega_L) + sum_j 1/2 armature_j
  sdot_j^2 (the rotors', so that K = 1/2 nu^T M nu).

Output frames F (codes: spatial's BODY, MIXED, INERTIAL for the base's velocity-representation frames, and
FRAME_GW, FRAME_GB below):
B (Body), B[W] (Mixed), W (Inertial), G[W], G[B] = (W_p_G, [B]). A 6D force (momentum) is written in F
as F_f = F_X*_G G[W]_f; a 6D velocity (average velocity) as F_v = F_X_G G[W]_v, where the average
velocity is G[W]_v = G[W]_M^-1 G[W]_h with the locked inertia G[W]_M = blockdiag(m 1, I_G) (h = 0 about G).

Tape safety: Warp does not differentiate a local that a dynamic loop carries across iterations, so
sums over links are prefix arrays (N, nL), element i = element i - 1 + the term of link i, each
written once; composite (subtree) inertias use a sibling chain, see `momentum_jacobian`.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import BODY, INERTIAL, MIXED, spatial

FRAME_GW = 4
FRAME_GB = 5


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The kernels in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)

    @wp.func
    def unit_quat():
        return sp.quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0))

    @wp.func
    def world_inertia(q: sp.quat, I_c: sp.mat33):
        """W_R I_c W_R^T: a rotational inertia in link axes rotated to world axes."""
        R = wp.quat_to_matrix(q)
        return R * I_c * wp.transpose(R)

    @wp.func
    def parallel_axis(m: scalar, d: sp.vec3):
        """m (|d|^2 1 - d d^T): what a point mass m at d adds to a rotational inertia about the origin."""
        return m * (wp.dot(d, d) * wp.identity(n=3, dtype=scalar) - wp.outer(d, d))

    @wp.func
    def inertia_apply(m: scalar, h: sp.vec3, I: sp.mat33, v: sp.vec6):
        """M v for the spatial inertia (m, h, I) (see the module docstring)."""
        u = sp.lin(v)
        w = sp.ang(v)
        return sp.stack(m * u - wp.cross(h, w), wp.cross(h, u) + I * w)

    @wp.func
    def average_velocity(m: scalar, I: sp.mat33, f: sp.vec6):
        """blockdiag(m 1, I)^-1 f: the velocity of a locked body of inertia (m, 0, I) with momentum f."""
        return sp.stack(sp.lin(f) / m, wp.inverse(I) * sp.ang(f))

    @wp.func
    def frame_from_G(frame: int, W_H_B: sp.transform, W_p_G: sp.vec3):
        """G[W]_H_F: the output frame F (BODY, MIXED, INERTIAL, FRAME_GW or FRAME_GB) seen from G[W]."""
        p_B = wp.transform_get_translation(W_H_B)
        q_B = wp.transform_get_rotation(W_H_B)
        if frame == BODY:
            return sp.transform(p_B - W_p_G, q_B)
        if frame == MIXED:
            return sp.transform(p_B - W_p_G, unit_quat())
        if frame == INERTIAL:
            return sp.transform(-W_p_G, unit_quat())
        if frame == FRAME_GB:
            return sp.transform(sp.vec3(scalar(0.0)), q_B)
        return sp.transform(sp.vec3(scalar(0.0)), unit_quat())

    @wp.func
    def output_column(average: int, G_H_F: sp.transform, m: scalar, I: sp.mat33, f: sp.vec6):
        """A momentum f (about G, world axes) in frame F, or (average != 0) the average velocity it gives."""
        if average != 0:
            return sp.motion_from(G_H_F, average_velocity(m, I, f))
        return sp.force_from(G_H_F, f)

    @wp.kernel(module="unique")
    def centroidal_sums(
        model: B.Model,
        W_H_L: wp.array2d(dtype=sp.transform),
        state: B.State,
        # scratch (N, nL): per link, or prefix sums over links 0..i
        W_v_WL: wp.array2d(dtype=sp.vec6),
        W_p_CL: wp.array2d(dtype=sp.vec3),
        sum_m: wp.array2d(dtype=scalar),
        sum_mp: wp.array2d(dtype=sp.vec3),
        sum_I: wp.array2d(dtype=sp.mat33),
        sum_h: wp.array2d(dtype=sp.vec6),
        sum_K: wp.array2d(dtype=scalar),
        # outputs (N,)
        mass: wp.array(dtype=scalar),
        W_p_G: wp.array(dtype=sp.vec3),
        G_I: wp.array(dtype=sp.mat33),
        G_h: wp.array(dtype=sp.vec6),
        K: wp.array(dtype=scalar),
    ):
        """Per environment: the total mass [kg], W_p_G [m], the rotational inertia about G in world axes
        [kg m^2], the centroidal momentum G[W]_h [kg m/s; kg m^2/s] and the kinetic energy [J].

        W_H_L (N, nL): the link poses at the state; W_v_WL (N, nL) are the Inertial link velocities; W_p_CL
        (N, nL) the world positions of the links' CoMs.
        """
        env = wp.tid()
        nL = model.parent.shape[0]
        W_H_B = W_H_L[env, 0]
        W_v_WL[env, 0] = sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(state, env))
        c0 = wp.transform_point(W_H_B, B.com_of(model, env, 0))
        W_p_CL[env, 0] = c0
        sum_m[env, 0] = B.mass_of(model, env, 0)
        sum_mp[env, 0] = B.mass_of(model, env, 0) * c0
        for i in range(1, nL):
            vJ = jm.joint_motion_of(model, i, jm.joint_frame_motion(model, i, W_H_L, env), state.joint_velocities, env)
            W_v_WL[env, i] = W_v_WL[env, model.parent[i]] + sp.motion_to(W_H_L[env, i], vJ)
            c = wp.transform_point(W_H_L[env, i], B.com_of(model, env, i))
            W_p_CL[env, i] = c
            sum_m[env, i] = sum_m[env, i - 1] + B.mass_of(model, env, i)
            sum_mp[env, i] = sum_mp[env, i - 1] + B.mass_of(model, env, i) * c
        m = sum_m[env, nL - 1]
        p_G = sum_mp[env, nL - 1] / m
        mass[env] = m
        W_p_G[env] = p_G
        for i in range(nL):
            prev_I = sp.mat33(scalar(0.0))
            prev_h = sp.vec6(scalar(0.0))
            prev_K = scalar(0.0)
            if i > 0:
                prev_I = sum_I[env, i - 1]
                prev_h = sum_h[env, i - 1]
                prev_K = sum_K[env, i - 1]
            m_i = B.mass_of(model, env, i)
            c = W_p_CL[env, i]
            d = c - p_G
            I_W = world_inertia(wp.transform_get_rotation(W_H_L[env, i]), B.inertia_of(model, env, i))
            v = W_v_WL[env, i]
            w = sp.ang(v)
            v_c = sp.lin(v) + wp.cross(w, c)
            p_i = m_i * v_c
            I_w = I_W * w
            sum_I[env, i] = prev_I + I_W + parallel_axis(m_i, d)
            sum_h[env, i] = prev_h + sp.stack(p_i, wp.cross(d, p_i) + I_w)
            rotor = scalar(0.0)
            if i > 0:
                rotor = jm.armature_energy(model, env, i, state.joint_velocities)
            else:  # a floating base's free-joint armature on its Mixed velocity (|v|^2 the same in Body)
                v_B = B.base_velocity_mixed(state, env)
                rotor = B.base_rotor(model, env, scalar(0.0)) * wp.dot(v_B, v_B)
            sum_K[env, i] = prev_K + scalar(0.5) * (wp.dot(v_c, p_i) + wp.dot(w, I_w) + rotor)
        G_I[env] = sum_I[env, nL - 1]
        G_h[env] = sum_h[env, nL - 1]
        K[env] = sum_K[env, nL - 1]

    @wp.kernel(module="unique")
    def force_output(
        state: B.State,
        # centroidal sums
        W_p_G: wp.array(dtype=sp.vec3),
        G_h: wp.array(dtype=sp.vec6),
        frame: int,
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 6): the momentum in frame `frame`, F_h = F_X*_G G[W]_h."""
        env = wp.tid()
        G_H_F = frame_from_G(frame, B.base_pose(state, env), W_p_G[env])
        f = sp.force_from(G_H_F, G_h[env])
        for r in range(6):
            out[env, r] = f[r]

    @wp.kernel(module="unique")
    def velocity_output(
        state: B.State,
        # centroidal sums
        mass: wp.array(dtype=scalar),
        W_p_G: wp.array(dtype=sp.vec3),
        G_I: wp.array(dtype=sp.mat33),
        G_h: wp.array(dtype=sp.vec6),
        frame: int,
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, R): the first R = 3 or 6 entries of the average velocity in frame `frame`."""
        env = wp.tid()
        G_H_F = frame_from_G(frame, B.base_pose(state, env), W_p_G[env])
        v = sp.motion_from(G_H_F, average_velocity(mass[env], G_I[env], G_h[env]))
        for r in range(out.shape[1]):
            out[env, r] = v[r]

    @wp.kernel(module="unique")
    def inertia_output(
        state: B.State,
        # centroidal sums
        mass: wp.array(dtype=scalar),
        W_p_G: wp.array(dtype=sp.vec3),
        G_I: wp.array(dtype=sp.mat33),
        frame: int,
        # outputs
        out: wp.array3d(dtype=scalar),
    ):
        """out (N, 6, 6): the locked spatial inertia in frame `frame`, F_X*_G blockdiag(m 1, I_G) G_X_F."""
        env = wp.tid()
        G_H_F = frame_from_G(frame, B.base_pose(state, env), W_p_G[env])
        m = mass[env]
        I = G_I[env]
        for c in range(6):
            e = sp.vec6(scalar(0.0))
            e[c] = scalar(1.0)
            v = sp.motion_to(G_H_F, e)
            col = sp.force_from(G_H_F, sp.stack(m * sp.lin(v), I * sp.ang(v)))
            for r in range(6):
                out[env, r, c] = col[r]

    @wp.kernel(module="unique")
    def energy_output(
        model: B.Model,
        # centroidal sums
        mass: wp.array(dtype=scalar),
        W_p_G: wp.array(dtype=sp.vec3),
        K: wp.array(dtype=scalar),
        kinetic: int,
        potential: int,
        # outputs
        out: wp.array(dtype=scalar),
    ):
        """out (N,): K (kinetic), U = -m g . W_p_G (potential, g the world's gravity), or their sum [J]."""
        env = wp.tid()
        e = scalar(0.0)
        if kinetic != 0:
            e = K[env]
        if potential != 0:
            e = e - mass[env] * wp.dot(B.gravity_of(model, env), W_p_G[env])
        out[env] = e

    @wp.kernel(module="unique")
    def com_output(
        # centroidal sums
        W_p_G: wp.array(dtype=sp.vec3),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 3): W_p_G [m]."""
        env = wp.tid()
        p = W_p_G[env]
        for r in range(3):
            out[env, r] = p[r]

    @wp.kernel(module="unique")
    def momentum_jacobian(
        model: B.Model,
        W_H_L: wp.array2d(dtype=sp.transform),
        input_repr: int,
        # centroidal sums
        mass: wp.array(dtype=scalar),
        W_p_G: wp.array(dtype=sp.vec3),
        G_I: wp.array(dtype=sp.mat33),
        frame: int,
        average: int,
        # scratch (N, nL): composite inertias of subtrees (C) and sibling-chain sums (T), about G
        C_m: wp.array2d(dtype=scalar),
        C_h: wp.array2d(dtype=sp.vec3),
        C_I: wp.array2d(dtype=sp.mat33),
        T_m: wp.array2d(dtype=scalar),
        T_h: wp.array2d(dtype=sp.vec3),
        T_I: wp.array2d(dtype=sp.mat33),
        # outputs
        J: wp.array3d(dtype=scalar),
    ):
        """J (N, 6, 6 + nv): the total momentum Jacobian in frame `frame`, or (average != 0) the average
        velocity Jacobian; columns act on ν in `input_repr`.

        Composite inertias C_i (link i and its descendants) without accumulating in place: with
        first_child(i) the smallest-index child and next_sibling(i) the next larger-index sibling (-1 if
        none), T_i = C_i + T_next_sibling(i) sums C over i and its later siblings, so
        C_i = M_i + T_first_child(i); both indices exceed i, so a sweep from the last link down reads only
        elements already written. Column 6 + d is C_L G[W]_S_d (L: the link DoF d's joint moves); base
        column c is C_0 G[W]_X_W W_v(e_c), e_c the unit base velocity in input_repr.
        """
        env = wp.tid()
        nL = model.first_child.shape[0]
        p_G = W_p_G[env]
        for k in range(nL):
            i = nL - 1 - k
            W_H_i = W_H_L[env, i]
            m_i = B.mass_of(model, env, i)
            d = wp.transform_point(W_H_i, B.com_of(model, env, i)) - p_G
            cm = m_i
            ch = m_i * d
            cI = world_inertia(wp.transform_get_rotation(W_H_i), B.inertia_of(model, env, i)) + parallel_axis(m_i, d)
            fc = model.first_child[i]
            if fc >= 0:
                cm = cm + T_m[env, fc]
                ch = ch + T_h[env, fc]
                cI = cI + T_I[env, fc]
            C_m[env, i] = cm
            C_h[env, i] = ch
            C_I[env, i] = cI
            tm = cm
            th = ch
            tI = cI
            ns = model.next_sibling[i]
            if ns >= 0:
                tm = tm + T_m[env, ns]
                th = th + T_h[env, ns]
                tI = tI + T_I[env, ns]
            T_m[env, i] = tm
            T_h[env, i] = th
            T_I[env, i] = tI
        W_H_B = W_H_L[env, 0]
        G_H_F = frame_from_G(frame, W_H_B, p_G)
        m = mass[env]
        I_G = G_I[env]
        m0 = C_m[env, 0]
        h0 = C_h[env, 0]
        I0 = C_I[env, 0]
        for c in range(6):
            e = sp.vec6(scalar(0.0))
            e[c] = scalar(1.0)
            W_v = sp.repr_to_inertial(input_repr, W_H_B, e)
            G_v = sp.stack(sp.lin(W_v) + wp.cross(sp.ang(W_v), p_G), sp.ang(W_v))
            col = output_column(average, G_H_F, m, I_G, inertia_apply(m0, h0, I0, G_v))
            for r in range(6):
                J[env, r, c] = col[r]
        for L in range(1, nL):
            W_H_j = W_H_L[env, L]
            G_H_j = sp.transform(wp.transform_get_translation(W_H_j) - p_G, wp.transform_get_rotation(W_H_j))
            X_L = jm.joint_frame_motion(model, L, W_H_L, env)
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, L):
                    dof = jm.dof_address(model, L) + k_dof
                    G_S = sp.motion_to(G_H_j, jm.dof_motion(model, L, dof, X_L))
                    col = output_column(average, G_H_F, m, I_G, inertia_apply(C_m[env, L], C_h[env, L], C_I[env, L], G_S))
                    for r in range(6):
                        J[env, r, 6 + dof] = col[r]

    @wp.kernel(module="unique")
    def com_bias_acceleration(
        model: B.Model,
        # the links' poses, Inertial velocities and body-fixed bias accelerations
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        L_a_WL: wp.array3d(dtype=scalar),
        # centroidal sums
        mass: wp.array(dtype=scalar),
        frame: int,
        # scratch (N, nL): prefix sums of the links' m_L W_pddot_CL
        sum_f: wp.array2d(dtype=sp.vec3),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 3): the CoM bias acceleration sum_L m_L W_pddot_CL / m, in the axes of `frame` (G[W]
        or G[B]) [m/s^2].

        L_a_WL (N, nL, 6) are the links' body-fixed bias accelerations J̇ν; with L_v_WL = [v; w], the
        CoM's acceleration in link axes is a_lin + a_ang x c + w x (v + w x c).
        """
        env = wp.tid()
        nL = model.parent.shape[0]
        for i in range(nL):
            prev = sp.vec3(scalar(0.0))
            if i > 0:
                prev = sum_f[env, i - 1]
            W_H_i = W_H_L[env, i]
            v = sp.motion_from(W_H_i, W_v_WL[env, i])
            w = sp.ang(v)
            a_lin = sp.vec3(L_a_WL[env, i, 0], L_a_WL[env, i, 1], L_a_WL[env, i, 2])
            a_ang = sp.vec3(L_a_WL[env, i, 3], L_a_WL[env, i, 4], L_a_WL[env, i, 5])
            c = B.com_of(model, env, i)
            a_c = a_lin + wp.cross(a_ang, c) + wp.cross(w, sp.lin(v) + wp.cross(w, c))
            sum_f[env, i] = prev + B.mass_of(model, env, i) * wp.transform_vector(W_H_i, a_c)
        a = sum_f[env, nL - 1] / mass[env]
        if frame == FRAME_GB:
            a = wp.quat_rotate_inv(wp.transform_get_rotation(W_H_L[env, 0]), a)
        for r in range(3):
            out[env, r] = a[r]

    @wp.kernel(module="unique")
    def link_spatial_inertias(
        model: B.Model,
        # outputs
        out: wp.array4d(dtype=scalar),
    ):
        """out (P, nL, 6, 6), launched over (P, nL): L_M_L = [[m 1, -m c^], [m c^, I_c - m c^ c^]] about each
        link's origin, link axes, for P = 1 (shared parameters) or per environment."""
        env, i = wp.tid()
        m = B.mass_of(model, env, i)
        c = B.com_of(model, env, i)
        I = B.inertia_of(model, env, i) + parallel_axis(m, c)
        for col in range(6):
            e = sp.vec6(scalar(0.0))
            e[col] = scalar(1.0)
            f = inertia_apply(m, m * c, I, e)
            for r in range(6):
                out[env, i, r, col] = f[r]

    @wp.kernel(module="unique")
    def link_com_positions(
        model: B.Model,
        link: int,
        in_link_frame: int,
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 3): the link's CoM, L_p_CoM (in_link_frame) or W_p_CoM [m]."""
        env = wp.tid()
        p = B.com_of(model, env, link)
        if in_link_frame == 0:
            p = wp.transform_point(W_H_L[env, link], p)
        for r in range(3):
            out[env, r] = p[r]

    return types.SimpleNamespace(
        centroidal_sums=centroidal_sums,
        force_output=force_output,
        velocity_output=velocity_output,
        inertia_output=inertia_output,
        energy_output=energy_output,
        com_output=com_output,
        momentum_jacobian=momentum_jacobian,
        com_bias_acceleration=com_bias_acceleration,
        link_spatial_inertias=link_spatial_inertias,
        link_com_positions=link_com_positions,
    )
