"""JaxSim 0.9.0's impact after a rigid-contact step (jaxsim.rbda.contacts.rigid's update_velocity_after_impact), on
kernels/rigid_contacts.py's rows and Delassus matrix, one thread per environment.

nu+ = nu - M^-1 J^T lambda with G lambda = J nu over the points then penetrating (G = J M^-1 J^T; their depths and
rows at the new state from kernels/rigid_contacts.py's `rigid_rows` and, for the geom pairs' contact slots, whose rows
are a relative velocity, `rigid_slot_rows`): the velocity nearest nu in M's metric at which every such point is still,
each slot's two bodies moving together at it (a least-squares KKT solve; nu Inertial, the state's
base velocity converted from and back to Mixed at the base's position p). G is singular where the rows outnumber
the DoFs they move: it is solved as A = G + delta I (kernels/rigid_contacts.py's IMPACT_REGULARISATION, 1e-14 of its
largest diagonal entry), so nu+ = P nu, P = I - M^-1 J^T A^-1 J, leaves delta over G's smallest non-zero eigenvalue of
the points' velocity.

Its adjoint (`impact_adjoint`, registered by hand: the state's velocities are replaced in place) holds the
penetrating points: with W = M^-1 nu+bar, rho = A^-1 J W, xi = nu - nu+ and eta = M^-1 J^T rho, nubar = nu+bar -
J^T rho, adj M = sym((W - eta) xi^T), adj J = -lambda (W - eta)^T - rho nu+^T (delta's own dependence on J and M
through G's largest diagonal entry is left out: a term of 1e-14 relative), and the Mixed conversions add their terms
in p.
"""

import types

import warp as wp

from .bundles import bundles
from .cholesky import kernels as cholesky_kernels
from .factory import factory
from .rigid_contacts import IMPACT_REGULARISATION
from .rigid_contacts import kernels as rigid_kernels
from .spatial import MIXED, spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The impact's kernels in `scalar`."""
    sp, B = spatial(scalar), bundles(scalar)
    f64 = wp.float64
    C = cholesky_kernels(f64)
    RC = rigid_kernels(scalar)

    @wp.func
    def impact_rows(
        model: B.Model, depth: wp.array2d(dtype=scalar), J_t: wp.array4d(dtype=scalar), M: wp.array3d(dtype=scalar), env: int,
        nu: wp.array2d(dtype=f64), active: wp.array2d(dtype=wp.int32), J: wp.array3d(dtype=f64), MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64), Lm: wp.array3d(dtype=f64), G: wp.array3d(dtype=f64), LG: wp.array3d(dtype=f64), c: wp.array2d(dtype=f64),
        lam: wp.array2d(dtype=f64), y: wp.array2d(dtype=f64), w: wp.array2d(dtype=f64),
    ):  # fmt: skip
        """The penetrating points' rows J (depth[env, p] > 0 at the new state; active[env, :k] their indices), G = J M^-1
        J^T regularised (IMPACT_REGULARISATION) and factorised into LG, lambda = LG^-T LG^-1 J nu (nu[env] Inertial, K) and xi = M^-1 J^T
        lambda into w; returns m = 3 k, or -1 where more points penetrate than the scratch holds (J's rows / 3)."""
        K = M.shape[1]
        k = int(0)
        for p_i in range(depth.shape[1]):
            if depth[env, p_i] > scalar(0.0):
                if 3 * k >= J.shape[1]:
                    return -1
                active[env, k] = p_i
                for r in range(3):
                    for i in range(K):
                        J[env, 3 * k + r, i] = f64(J_t[env, p_i, r, i])
                k = k + 1
        m = 3 * k
        if m > 0:
            off = RC.solver_offset(model)
            RC.delassus(model, M, J, env, m, M64, Lm, MinvJT, y, w, G)
            for r in range(m):
                t = f64(0.0)
                for i in range(off, K):
                    t = t + J[env, r, i] * nu[env, i]
                c[env, r] = t
            largest = f64(0.0)
            for r in range(m):
                largest = wp.max(largest, G[env, r, r])
            for r in range(m):
                G[env, r, r] = G[env, r, r] + f64(IMPACT_REGULARISATION) * largest
            C.factor(G, env, 0, m, f64(0.0), LG)
            C.substitute(LG, env, m, c, lam, 0)
            for i in range(K):
                t = f64(0.0)
                if i >= off:
                    for r in range(m):
                        t = t + MinvJT[env, r, i] * lam[env, r]
                w[env, i] = t
        return m

    @wp.kernel(module="unique", enable_backward=False)
    def impact_velocities(
        model: B.Model,
        depth: wp.array2d(dtype=scalar),
        J_t: wp.array4d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        # float64 scratch for m rows (m / 3 <= P penetrating points): active (N, P) int; J and MinvJT (N, m, K); M64 and
        # Lm (N, K, K); G and LG (N, m, m); c, lam, y, w (N, max(m, K)); nu (N, K): the velocity before the impact
        # (Inertial), kept for the adjoint
        active: wp.array2d(dtype=wp.int32),
        J: wp.array3d(dtype=f64),
        MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64),
        G: wp.array3d(dtype=f64),
        LG: wp.array3d(dtype=f64),
        c: wp.array2d(dtype=f64),
        lam: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64),
        w: wp.array2d(dtype=f64),
        nu: wp.array2d(dtype=f64),
        # the state, whose velocities are replaced
        state: B.State,
    ):
        """The state's velocities after JaxSim's impact (the module docstring) at the points' depths (N, P) and
        Jacobians J_t (N, P, 6, K) (Mixed, ν Inertial; a geom pair's slot P + slot: its rows in the contact's axes) and
        M (N, K, K) (Inertial base) at the state; a fixed base's velocity is left as it is. An environment where more
        points penetrate than the scratch holds is flagged (state.valid = 0) and its velocities left as they are, or,
        where the state has no health flags (a 0-length valid), its velocities made NaN."""
        env = wp.tid()
        K = M.shape[1]
        W_H_B = B.base_pose(state, env)
        base = sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(state, env))
        for i in range(K):
            if i < 6:
                nu[env, i] = f64(base[i])
            else:
                nu[env, i] = f64(state.joint_velocities[env, i - 6])
        m = impact_rows(model, depth, J_t, M, env, nu, active, J, MinvJT, M64, Lm, G, LG, c, lam, y, w)
        if m < 0 and state.valid.shape[0] > 0:
            state.valid[env] = 0
        elif m < 0:  # data without health flags (update_velocity_after_impact's): its velocities say it
            for i in range(6, K):
                state.joint_velocities[env, i - 6] = scalar(wp.nan)
            for r in range(6):
                state.base_velocity[env, r] = scalar(wp.nan)
        if m > 0:
            for i in range(6, K):
                state.joint_velocities[env, i - 6] = scalar(nu[env, i] - w[env, i])
            if RC.solver_offset(model) == 0:
                nu_plus = sp.vec6(
                    scalar(nu[env, 0] - w[env, 0]), scalar(nu[env, 1] - w[env, 1]), scalar(nu[env, 2] - w[env, 2]),
                    scalar(nu[env, 3] - w[env, 3]), scalar(nu[env, 4] - w[env, 4]), scalar(nu[env, 5] - w[env, 5]),
                )
                mixed = sp.inertial_to_repr(MIXED, W_H_B, nu_plus)
                for r in range(6):
                    state.base_velocity[env, r] = mixed[r]

    @wp.kernel(module="unique", enable_backward=False)
    def impact_adjoint(
        model: B.Model,
        depth: wp.array2d(dtype=scalar),
        J_t: wp.array4d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        active: wp.array2d(dtype=wp.int32),
        J: wp.array3d(dtype=f64),
        MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64),
        G: wp.array3d(dtype=f64),
        LG: wp.array3d(dtype=f64),
        c: wp.array2d(dtype=f64),
        lam: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64),
        w: wp.array2d(dtype=f64),
        nu: wp.array2d(dtype=f64),
        state: B.State,
        # two more float64 vectors (N, max(m, K)) of scratch
        nu_bar: wp.array2d(dtype=f64),
        W: wp.array2d(dtype=f64),
        # the adjoints: the state's velocities' replaced (nu+bar in, nubar out), the rest added into
        adj_state: B.State,
        adj_J_t: wp.array4d(dtype=scalar),
        adj_M: wp.array3d(dtype=scalar),
    ):
        """The adjoint of `impact_velocities` (the module docstring), from `nu` (kept by it) and the state's positions."""
        env = wp.tid()
        K = M.shape[1]
        m = impact_rows(model, depth, J_t, M, env, nu, active, J, MinvJT, M64, Lm, G, LG, c, lam, y, w)
        if m > 0:
            off = RC.solver_offset(model)
            p = wp.transform_get_translation(B.base_pose(state, env))
            adj_p = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
            for i in range(6, K):
                nu_bar[env, i] = f64(adj_state.joint_velocities[env, i - 6])
            if off == 0:  # nu+bar Inertial from the Mixed velocity's adjoint
                g_lin = sp.vec3(adj_state.base_velocity[env, 0], adj_state.base_velocity[env, 1], adj_state.base_velocity[env, 2])
                g_ang = sp.vec3(adj_state.base_velocity[env, 3], adj_state.base_velocity[env, 4], adj_state.base_velocity[env, 5])
                omega_plus = sp.vec3(scalar(nu[env, 3] - w[env, 3]), scalar(nu[env, 4] - w[env, 4]), scalar(nu[env, 5] - w[env, 5]))
                adj_p = adj_p + wp.cross(g_lin, omega_plus)
                g_ang = g_ang + wp.cross(p, g_lin)
                for r in range(3):
                    nu_bar[env, r] = f64(g_lin[r])
                    nu_bar[env, 3 + r] = f64(g_ang[r])
            for i in range(off, K):
                y[env, i - off] = nu_bar[env, i]
            C.substitute(Lm, env, K - off, y, W, off)  # W = M^-1 nu+bar
            for r in range(m):
                t = f64(0.0)
                for i in range(off, K):
                    t = t + J[env, r, i] * W[env, i]
                c[env, r] = t
            C.substitute(LG, env, m, c, y, 0)  # y: rho
            for i in range(off, K):  # c: W - eta
                t = f64(0.0)
                for r in range(m):
                    t = t + MinvJT[env, r, i] * y[env, r]
                c[env, i] = W[env, i] - t
            for i in range(m // 3):
                point = active[env, i]
                for r in range(3):
                    row = 3 * i + r
                    for j in range(off, K):
                        adj = -lam[env, row] * c[env, j] - y[env, row] * (nu[env, j] - w[env, j])
                        adj_J_t[env, point, r, j] = adj_J_t[env, point, r, j] + scalar(adj)
            for r in range(off, K):
                for j in range(off, K):
                    adj_M[env, r, j] = adj_M[env, r, j] + scalar(f64(0.5) * (c[env, r] * w[env, j] + w[env, r] * c[env, j]))
            for i in range(off, K):  # nubar = nu+bar - J^T rho
                t = f64(0.0)
                for r in range(m):
                    t = t + J[env, r, i] * y[env, r]
                nu_bar[env, i] = nu_bar[env, i] - t
            for i in range(6, K):
                adj_state.joint_velocities[env, i - 6] = scalar(nu_bar[env, i])
            if off == 0:  # back to the Mixed velocity's adjoint before the impact
                g_lin = sp.vec3(scalar(nu_bar[env, 0]), scalar(nu_bar[env, 1]), scalar(nu_bar[env, 2]))
                g_ang = sp.vec3(scalar(nu_bar[env, 3]), scalar(nu_bar[env, 4]), scalar(nu_bar[env, 5]))
                omega = sp.vec3(scalar(nu[env, 3]), scalar(nu[env, 4]), scalar(nu[env, 5]))
                adj_p = adj_p - wp.cross(g_lin, omega)
                g_ang = g_ang - wp.cross(p, g_lin)
                for r in range(3):
                    adj_state.base_velocity[env, r] = g_lin[r]
                    adj_state.base_velocity[env, 3 + r] = g_ang[r]
                for r in range(3):
                    adj_state.base_position[env, r] = adj_state.base_position[env, r] + adj_p[r]

    return types.SimpleNamespace(impact_velocities=impact_velocities, impact_adjoint=impact_adjoint)
