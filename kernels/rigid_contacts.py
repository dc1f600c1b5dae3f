"""JaxSim 0.9.0's rigid and relaxed-rigid contacts (jaxsim.rbda.contacts.rigid, .relaxed_rigid): an environment's
contact forces solved together from its mass matrix and its points' Jacobians, one thread per environment.

The points' rows: an enabled point c at p [m, world] moving at p_dot [m/s] over the terrain (height h, unit normal
n) penetrates by delta = max(0, (h - p_z) n_z) at the rate delta_dot = -p_dot.n; it is active where delta > 0.
J_c (3 x K) is its linear Jacobian (Mixed rows, nu Inertial), a_c = J_c a_free + J̇ν_c its acceleration without
contact forces (a_free: ABA's at the joint forces and the other link forces), G = J M^-1 J^T the active points'
Delassus matrix. The force f_c (3, world axes) acts at the point; inactive points get none.

- relaxed rigid: kernels/relaxed_rigid.py, on this module's rows, Delassus matrix and wrenches.
- rigid (`rigid_rows`, `rigid_solve`, `point_wrenches`): f minimises 1/2 f^T (G + eps I) f + (a - beta)^T f over the friction pyramids
  |f_x|, |f_y| <= mu f_z, f_z >= 0 (world axes, JaxSim's), beta = (K delta + D delta_dot) n (Baumgarte's terms),
  solved by a primal-dual interior point (Mehrotra's predictor-corrector, one factorisation per iteration) until
  its residuals and complementarity are below `tol` (JaxSim: qpax, an interior point too).
- impact (rigid, after each step): kernels/rigid_impact.py.
- contacts between bodies (relaxed rigid and rigid): a geom pair's contact slot is a point whose rows are the velocity
  of geom2's point relative to geom1's in the contact's axes (kernels/contact_slots.py); for the rigid QP
  (`rigid_slot_rows` there) its pyramid is in those axes with the pair's mu (each point's mu is an input of the QP)
  and Baumgarte's term on its normal.

The linear algebra runs in float64 whatever the model's dtype: the mass matrix and the points' Jacobian rows are
promoted, M is factorised densely (kernels/cholesky.py), and the Delassus matrix, the solves and the interior
point are float64; the forces and the impact's velocities are rounded back to the model's dtype. The systems are
nearly singular (a foot's 16 corners give 48 rows of rank 6, regularised by 1e-6 or by R ~ 1e-6 / m): solved in
float32, the impact's dependent rows kept pivots of rounding's size instead of 0, and a float32 landing of the legs
fell over. The inputs (M, J, J̇ν) keep the model's dtype's rounding, so float32 rigid landings still decide on
rounding which points stop (the engine's stage warns). The factorisations drop a pivot at or below `drop` times its
diagonal entry (kernels/cholesky.py's `factor`; 0 for the positive-definite solves: a pivot that rounding made
non-positive): that unknown is then 0; the impact's singular Delassus matrix is regularised (IMPACT_REGULARISATION).

Gradients: Warp differentiates `rigid_rows` and `point_wrenches` (a thread per environment); `rigid_solve` has a
hand-written adjoint, `rigid_solve_adjoint` (OptNet's differentiation of the QP's KKT conditions at its active set),
which the engine registers on the tape (warpdyn.engine.launch's Launch.adjoint).
"""

import types

import warp as wp

from .bundles import bundles
from .cholesky import kernels as cholesky_kernels
from .factory import factory
from .soft_contacts import kernels as soft_contact_kernels
from .spatial import spatial

PYRAMID_ROWS = 5
"""The inequality rows of a point's friction pyramid: f_x - mu f_z, f_y - mu f_z, -f_x - mu f_z, -f_y - mu f_z, -f_z."""

ACTIVE_PENALTY = 1.0e8
"""The rigid QP's adjoint holds its active constraints (rows whose dual exceeds their slack) by this weight times
Q's largest diagonal entry: an error of its inverse, 1e-8, against rounding amplified by it."""

IMPACT_REGULARISATION = 1.0e-14
"""The impact's Delassus matrix G (singular where the rows outnumber the motions they constrain: a box face's four
contacts give twelve rows of rank six) is solved as G + delta I, delta this fraction of G's largest diagonal entry:
the rows' null space, which J^T maps to no velocity, stays bounded, and the velocity left at the contacts is delta
over G's smallest non-zero eigenvalue of what it was. Dropping the rows whose Cholesky pivot fell below a threshold
instead kept, on two boxes, a subset of rows whose own condition was 1e8 (a pivot of 2e-5 then one of 1.4e-8):
the impact's velocities carried 3e-8 of noise."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The rigid and relaxed-rigid contact kernels in `scalar`."""
    sp, B = spatial(scalar), bundles(scalar)
    f64 = wp.float64
    vec3d = wp.types.vector(3, f64)
    C = cholesky_kernels(f64)
    T = soft_contact_kernels(scalar)

    @wp.struct
    class RigidLaw:
        """A rigid model's parameters beside the Contacts bundle's (K, D, mu: Baumgarte's terms and the friction
        coefficient, shared (1,) or per environment (N,)): the relaxed-rigid impedance (time_constant [s],
        damping_coefficient, d_min, d_max, width [m], midpoint, power), the rigid QP's regularisation eps [m/s^2/N]
        of the Delassus diagonal, its tolerance tol and its iteration limit."""

        time_constant: scalar
        damping_coefficient: scalar
        d_min: scalar
        d_max: scalar
        width: scalar
        midpoint: scalar
        power: scalar
        eps: scalar
        tol: scalar
        iterations: int

    @wp.func
    def penetration(contacts: B.Contacts, terrain: B.Terrain, W_H_L: wp.array2d(dtype=sp.transform), W_v_WL: wp.array2d(dtype=sp.vec6), env: int, c: int):
        """(p, p_dot, n, delta, delta_dot) of enabled point c: its position and velocity [world], the terrain's
        normal under it, its penetration and rate (0 out of contact; JaxSim's compute_penetration_data)."""
        L = contacts.point_link[c]
        p = wp.transform_point(W_H_L[env, L], B.vec3_parameter(contacts.L_p_C, env, c))
        v = W_v_WL[env, L]
        p_dot = sp.lin(v) + wp.cross(sp.ang(v), p)
        h = T.terrain_height(terrain, T.height_parameter(terrain, env), p[0], p[1])
        n = T.terrain_normal(terrain, p[0], p[1])
        delta = wp.max(scalar(0.0), (h - p[2]) * n[2])
        delta_dot = scalar(0.0)
        if delta > scalar(0.0):
            delta_dot = -wp.dot(p_dot, n)
        return p, p_dot, n, delta, delta_dot

    @wp.func
    def solver_offset(model: B.Model):
        """The first solved DoF: 0 with a floating base, 6 with a fixed one (its base DoFs do not move)."""
        if model.floating_base != 0:
            return 0
        return 6

    @wp.func
    def delassus(
        model: B.Model, M: wp.array3d(dtype=scalar), J: wp.array3d(dtype=f64), env: int, m: int, M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64), MinvJT: wp.array3d(dtype=f64), y: wp.array2d(dtype=f64), w: wp.array2d(dtype=f64),
        G: wp.array3d(dtype=f64),
    ):
        """G[env, :m, :m] = J M^-1 J^T (float64) of the rows J[env, :m] (K columns) and MinvJT[env, :m] = (M^-1 J^T)^T:
        M (N, K, K) promoted to M64, its solved block (a fixed base's DoFs aside) factorised densely into Lm."""
        K = M.shape[1]
        off = solver_offset(model)
        k = K - off
        for r in range(off, K):
            for c in range(off, K):
                M64[env, r, c] = f64(M[env, r, c])
        C.factor(M64, env, off, k, f64(-1.0), Lm)
        for r in range(m):
            for i in range(k):
                y[env, i] = J[env, r, off + i]
            C.substitute(Lm, env, k, y, w, 0)
            for i in range(k):
                MinvJT[env, r, off + i] = w[env, i]
        for r in range(m):
            for q in range(r + 1):
                s = f64(0.0)
                for c in range(off, K):
                    s = s + J[env, r, c] * MinvJT[env, q, c]
                G[env, r, q] = s
                G[env, q, r] = s

    @wp.func
    def point_row(
        J_t: wp.array4d(dtype=scalar), Jdotnu_t: wp.array3d(dtype=scalar), a_free: wp.array2d(dtype=scalar), env: int, c: int,
        i: int, active: wp.array2d(dtype=wp.int32), J: wp.array3d(dtype=f64), a: wp.array2d(dtype=f64),
    ):
        """Point c as the i-th active point (float64): active[env, i] = c, J[env, 3 i + r] its rows (K columns),
        a[env, 3 i + r] = J a_free + J̇ν."""
        active[env, i] = c
        for r in range(3):
            s = f64(Jdotnu_t[env, c, r])
            for j in range(J.shape[2]):
                J[env, 3 * i + r, j] = f64(J_t[env, c, r, j])
                s = s + f64(J_t[env, c, r, j]) * f64(a_free[env, j])
            a[env, 3 * i + r] = s

    @wp.func
    def point_wrench(contacts: B.Contacts, W_H_L: wp.array2d(dtype=sp.transform), env: int, c: int, force: sp.vec3):
        """The Inertial wrench [f; p x f] of the force f [N, world] at point c."""
        p = wp.transform_point(W_H_L[env, contacts.point_link[c]], B.vec3_parameter(contacts.L_p_C, env, c))
        return sp.stack(force, wp.cross(p, force))

    @wp.func
    def rows_adjoint(
        model: B.Model, J: wp.array3d(dtype=f64), MinvJT: wp.array3d(dtype=f64), a_free: wp.array2d(dtype=scalar), env: int, m: int,
        active: wp.array2d(dtype=wp.int32), f: wp.array2d(dtype=f64), g: wp.array2d(dtype=f64), u: wp.array2d(dtype=f64), v: wp.array2d(dtype=f64),
        adj_J_t: wp.array4d(dtype=scalar), adj_Jdotnu_t: wp.array3d(dtype=scalar), adj_M: wp.array3d(dtype=scalar), adj_a_free: wp.array2d(dtype=scalar),
    ):
        """The adjoint of the forces f (m rows) of a system (J M^-1 J^T + D) f = r - (J a_free + J̇ν) with respect to J,
        J̇ν, M and a_free (the implicit function theorem), from g = (J M^-1 J^T + D)^-1 f̄ (then r̄ = g, D̄ = -g f^T):
        with u = M^-1 J^T f and v = M^-1 J^T g (the solved block; u, v (N, >= K) scratch), adj J̇ν = -g,
        adj a_free = -J^T g, adj J = -g (a_free + u)^T - f v^T, adj M = (v u^T + u v^T) / 2; added into the adj_ arrays."""
        K = J.shape[2]
        off = solver_offset(model)
        for j in range(K):
            uj = f64(0.0)
            vj = f64(0.0)
            if j >= off:
                for r in range(m):
                    uj = uj + MinvJT[env, r, j] * f[env, r]
                    vj = vj + MinvJT[env, r, j] * g[env, r]
            u[env, j] = uj
            v[env, j] = vj
        for i in range(m // 3):
            c = active[env, i]
            for r in range(3):
                row = 3 * i + r
                adj_Jdotnu_t[env, c, r] = adj_Jdotnu_t[env, c, r] - scalar(g[env, row])
                for j in range(K):
                    adj = -g[env, row] * (f64(a_free[env, j]) + u[env, j]) - f[env, row] * v[env, j]
                    adj_J_t[env, c, r, j] = adj_J_t[env, c, r, j] + scalar(adj)
        for j in range(K):
            t = f64(0.0)
            for r in range(m):
                t = t + J[env, r, j] * g[env, r]
            adj_a_free[env, j] = adj_a_free[env, j] - scalar(t)
        for r in range(off, K):
            for c in range(off, K):
                adj_M[env, r, c] = adj_M[env, r, c] + scalar(f64(0.5) * (v[env, r] * u[env, c] + u[env, r] * v[env, c]))

    @wp.func
    def forces_out(env: int, m: int, active: wp.array2d(dtype=wp.int32), f: wp.array2d(dtype=f64), force: wp.array2d(dtype=sp.vec3)):
        """force[env] (N, P): the active points' forces f[env, 3 i:3 i + 3] (float64, rounded), 0 elsewhere."""
        for c in range(force.shape[1]):
            force[env, c] = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
        for i in range(m // 3):
            force[env, active[env, i]] = sp.vec3(scalar(f[env, 3 * i]), scalar(f[env, 3 * i + 1]), scalar(f[env, 3 * i + 2]))

    @wp.func
    def adjoint_in(env: int, m: int, active: wp.array2d(dtype=wp.int32), adj_force: wp.array2d(dtype=sp.vec3), g: wp.array2d(dtype=f64)):
        """g[env, :m] = the active points' f̄ (float64); adj_force[env] zeroed (it was read: Warp's rule for an output's
        adjoint)."""
        for i in range(m // 3):
            a = adj_force[env, active[env, i]]
            for r in range(3):
                g[env, 3 * i + r] = f64(a[r])
        for c in range(adj_force.shape[1]):
            adj_force[env, c] = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))

    @wp.kernel(module="unique")
    def point_wrenches(contacts: B.Contacts, W_H_L: wp.array2d(dtype=sp.transform), force: wp.array2d(dtype=sp.vec3), W_f_C: wp.array3d(dtype=scalar)):
        """W_f_C (N, P, 6): the Inertial wrenches of the points' forces (N, P) (`point_wrench`); a thread per
        environment, differentiable."""
        env = wp.tid()
        for c in range(W_f_C.shape[1]):
            wrench = point_wrench(contacts, W_H_L, env, c, force[env, c])
            for r in range(6):
                W_f_C[env, c, r] = wrench[r]

    @wp.func
    def pyramid_row(mu: f64, j: int):
        """Row j (0..4) of a point's friction pyramid G_c (h = 0): f_x - mu f_z, f_y - mu f_z, -f_x - mu f_z,
        -f_y - mu f_z, -f_z."""
        g = vec3d(f64(0.0), f64(0.0), -mu)
        if j == 0:
            g[0] = f64(1.0)
        elif j == 1:
            g[1] = f64(1.0)
        elif j == 2:
            g[0] = f64(-1.0)
        elif j == 3:
            g[1] = f64(-1.0)
        else:
            g[2] = f64(-1.0)
        return g

    @wp.func
    def newton_matrix(
        Q: wp.array3d(dtype=f64), mu: wp.array2d(dtype=f64), env: int, n: int, s: wp.array2d(dtype=f64), z: wp.array2d(dtype=f64), penalty: f64,
        H: wp.array3d(dtype=f64), LH: wp.array3d(dtype=f64),
    ):
        """LH: the Cholesky factor of Q + G^T W G (G block-diagonal, a pyramid per point, so G^T W G is too): with
        penalty 0 the interior point's Newton matrix at the slacks s and duals z, W = S^-1 Z (Mehrotra's predictor and
        corrector share it); with penalty > 0 the active set's, W_j = penalty for a row with z_j > s_j, else 0."""
        for r in range(n):
            for c in range(n):
                H[env, r, c] = Q[env, r, c]
        for i in range(n // 3):
            for j in range(PYRAMID_ROWS):
                row = PYRAMID_ROWS * i + j
                g = pyramid_row(mu[env, i], j)
                weight = z[env, row] / s[env, row]
                if penalty > f64(0.0):
                    weight = f64(0.0)
                    if z[env, row] > s[env, row]:
                        weight = penalty
                for r in range(3):
                    for c in range(3):
                        H[env, 3 * i + r, 3 * i + c] = H[env, 3 * i + r, 3 * i + c] + weight * g[r] * g[c]
        C.factor(H, env, 0, n, f64(0.0), LH)

    @wp.func
    def newton_direction(
        LH: wp.array3d(dtype=f64), mu: wp.array2d(dtype=f64), env: int, n: int, s: wp.array2d(dtype=f64), z: wp.array2d(dtype=f64),
        rd: wp.array2d(dtype=f64), rp: wp.array2d(dtype=f64), rc: wp.array2d(dtype=f64), y: wp.array2d(dtype=f64),
        dx: wp.array2d(dtype=f64), ds: wp.array2d(dtype=f64), dz: wp.array2d(dtype=f64),
    ):
        """The interior point's Newton step (dx, ds, dz) for the residuals rd = Q x + q + G^T z, rp = G x + s and
        rc (complementarity, s z - sigma mu_gap + corrections), with `newton_matrix`'s LH:
        (Q + G^T S^-1 Z G) dx = -rd + G^T S^-1 (rc - Z rp), ds = -rp - G dx, dz = -S^-1 (rc + Z ds)."""
        for r in range(n):
            y[env, r] = -rd[env, r]
        for i in range(n // 3):
            for j in range(PYRAMID_ROWS):
                row = PYRAMID_ROWS * i + j
                g = pyramid_row(mu[env, i], j)
                extra = (rc[env, row] - z[env, row] * rp[env, row]) / s[env, row]
                for r in range(3):
                    y[env, 3 * i + r] = y[env, 3 * i + r] + g[r] * extra
        C.substitute(LH, env, n, y, dx, 0)
        for i in range(n // 3):
            for j in range(PYRAMID_ROWS):
                row = PYRAMID_ROWS * i + j
                g = pyramid_row(mu[env, i], j)
                gdx = g[0] * dx[env, 3 * i] + g[1] * dx[env, 3 * i + 1] + g[2] * dx[env, 3 * i + 2]
                ds[env, row] = -rp[env, row] - gdx
                dz[env, row] = -(rc[env, row] + z[env, row] * ds[env, row]) / s[env, row]

    @wp.func
    def step_to_boundary(env: int, count: int, s: wp.array2d(dtype=f64), z: wp.array2d(dtype=f64), ds: wp.array2d(dtype=f64), dz: wp.array2d(dtype=f64)):
        """The largest alpha in (0, 1] with s + alpha ds >= 0 and z + alpha dz >= 0."""
        alpha = f64(1.0)
        for row in range(count):
            if ds[env, row] < f64(0.0):
                alpha = wp.min(alpha, -s[env, row] / ds[env, row])
            if dz[env, row] < f64(0.0):
                alpha = wp.min(alpha, -z[env, row] / dz[env, row])
        return alpha

    @wp.func
    def residuals(
        Q: wp.array3d(dtype=f64), q: wp.array2d(dtype=f64), mu: wp.array2d(dtype=f64), env: int, n: int, x: wp.array2d(dtype=f64),
        s: wp.array2d(dtype=f64), z: wp.array2d(dtype=f64), rd: wp.array2d(dtype=f64), rp: wp.array2d(dtype=f64),
    ):
        """rd = Q x + q + G^T z, rp = G x + s; returns (max |rd|, max |rp|, the mean s z)."""
        worst_d = f64(0.0)
        worst_p = f64(0.0)
        gap = f64(0.0)
        for r in range(n):
            t = q[env, r]
            for c in range(n):
                t = t + Q[env, r, c] * x[env, c]
            rd[env, r] = t
        for i in range(n // 3):
            for j in range(PYRAMID_ROWS):
                row = PYRAMID_ROWS * i + j
                g = pyramid_row(mu[env, i], j)
                for r in range(3):
                    rd[env, 3 * i + r] = rd[env, 3 * i + r] + g[r] * z[env, row]
                rp[env, row] = g[0] * x[env, 3 * i] + g[1] * x[env, 3 * i + 1] + g[2] * x[env, 3 * i + 2] + s[env, row]
                worst_p = wp.max(worst_p, wp.abs(rp[env, row]))
                gap = gap + s[env, row] * z[env, row]
        for r in range(n):
            worst_d = wp.max(worst_d, wp.abs(rd[env, r]))
        return worst_d, worst_p, gap / f64(float(PYRAMID_ROWS)) / f64(n // 3)

    @wp.kernel(module="unique")
    def rigid_rows(
        contacts: B.Contacts,
        terrain: B.Terrain,
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        # outputs
        depth: wp.array2d(dtype=scalar),
        beta: wp.array2d(dtype=sp.vec3),
        friction: wp.array2d(dtype=scalar),
    ):
        """Each enabled point's penetration depth delta (N, P) [m] and, where it penetrates, Baumgarte's term
        beta = (K delta + D delta_dot) n [m/s^2] (N, P) (0 elsewhere), and its mu (N, P: the environment's), from the
        link poses and Inertial velocities (N, nL); the arrays' rows P on are the geom pairs' slots (kernels/contact_slots.py's `rigid_slot_rows`).
        A thread per environment; differentiable (a tape records it)."""
        env = wp.tid()
        mu = B.env_parameter(contacts.mu, env)
        K = B.env_parameter(contacts.K, env)
        D = B.env_parameter(contacts.D, env)
        for c in range(contacts.point_link.shape[0]):
            p, p_dot, n, delta, delta_dot = penetration(contacts, terrain, W_H_L, W_v_WL, env, c)
            term = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
            if delta > scalar(0.0):
                term = (K * delta + D * delta_dot) * n
            depth[env, c] = delta
            beta[env, c] = term
            friction[env, c] = mu

    @wp.func
    def qp_system(
        model: B.Model, law: RigidLaw, J_t: wp.array4d(dtype=scalar), Jdotnu_t: wp.array3d(dtype=scalar), M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar), depth: wp.array2d(dtype=scalar), beta: wp.array2d(dtype=sp.vec3), friction: wp.array2d(dtype=scalar),
        env: int, active: wp.array2d(dtype=wp.int32), J: wp.array3d(dtype=f64), MinvJT: wp.array3d(dtype=f64), M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64), Q: wp.array3d(dtype=f64), q: wp.array2d(dtype=f64), y: wp.array2d(dtype=f64), w: wp.array2d(dtype=f64),
        mu: wp.array2d(dtype=f64),
    ):
        """The QP of the penetrating points (float64): their rows (`point_row`), Q = J M^-1 J^T + eps I,
        q = J a_free + J̇ν - beta and each one's mu (friction (N, P)) into mu[env, :k]; returns (its size n = 3 k, the
        scale 1 + max |q| of its tolerance), n = -1 where more points penetrate than the scratch holds (J's rows / 3:
        the stage's max_active_contacts)."""
        k = int(0)
        overflow = int(0)
        for c in range(depth.shape[1]):
            if depth[env, c] > scalar(0.0):
                if 3 * k < J.shape[1]:
                    point_row(J_t, Jdotnu_t, a_free, env, c, k, active, J, q)
                    mu[env, k] = f64(friction[env, c])
                    k = k + 1
                else:
                    overflow = 1
        if overflow != 0:
            return -1, f64(1.0)
        n = 3 * k
        if n > 0:  # an environment out of contact factorises nothing
            delassus(model, M, J, env, n, M64, Lm, MinvJT, y, w, Q)
        scale = f64(1.0)
        for i in range(k):
            c = active[env, i]
            for r in range(3):
                q[env, 3 * i + r] = q[env, 3 * i + r] - f64(beta[env, c][r])
                scale = wp.max(scale, wp.abs(q[env, 3 * i + r]))
                Q[env, 3 * i + r, 3 * i + r] = Q[env, 3 * i + r, 3 * i + r] + f64(law.eps)
        return n, scale

    @wp.func
    def interior_point(
        law: RigidLaw, mu: wp.array2d(dtype=f64), env: int, n: int, scale: f64, Q: wp.array3d(dtype=f64), H: wp.array3d(dtype=f64), LH: wp.array3d(dtype=f64),
        q: wp.array2d(dtype=f64), x: wp.array2d(dtype=f64), rd: wp.array2d(dtype=f64), dx: wp.array2d(dtype=f64), y: wp.array2d(dtype=f64),
        s: wp.array2d(dtype=f64), z: wp.array2d(dtype=f64), rp: wp.array2d(dtype=f64), rc: wp.array2d(dtype=f64), ds: wp.array2d(dtype=f64),
        dz: wp.array2d(dtype=f64), ds_aff: wp.array2d(dtype=f64), dz_aff: wp.array2d(dtype=f64),
    ):
        """x[env, :n] = argmin 1/2 x^T Q x + q^T x over the points' friction pyramids (G x <= 0), with the slacks s and
        duals z at it: Mehrotra's predictor-corrector from CVXOPT's start (x from (Q + G^T G) x = -q, s = -G x and
        z = G x shifted to be positive), at most law.iterations iterations, until the residuals and the mean
        complementarity are below law.tol times `scale`."""
        k = n // 3
        tol = f64(law.tol)
        rows = PYRAMID_ROWS * k
        # CVXOPT's start: the solve with S = Z = I and rc = rp = 0 is (Q + G^T G) x = -q; then s = -G x, z = G x
        for row in range(rows):
            s[env, row] = f64(1.0)
            z[env, row] = f64(1.0)
            rp[env, row] = f64(0.0)
            rc[env, row] = f64(0.0)
        for r in range(n):
            rd[env, r] = q[env, r]
        newton_matrix(Q, mu, env, n, s, z, f64(0.0), H, LH)
        newton_direction(LH, mu, env, n, s, z, rd, rp, rc, y, x, ds, dz)
        lowest_s = f64(0.0)
        lowest_z = f64(0.0)
        for row in range(rows):
            s[env, row] = ds[env, row]
            z[env, row] = -ds[env, row]
            lowest_s = wp.min(lowest_s, s[env, row])
            lowest_z = wp.min(lowest_z, z[env, row])
        for row in range(rows):
            s[env, row] = s[env, row] - lowest_s + f64(1.0)
            z[env, row] = z[env, row] - lowest_z + f64(1.0)
        for _ in range(law.iterations):
            worst_d, worst_p, gap = residuals(Q, q, mu, env, n, x, s, z, rd, rp)
            converged = worst_d <= tol * scale and worst_p <= tol * scale and gap <= tol * scale
            # complementarity a thousand times below the tolerance while rounding holds the residuals above it:
            # further steps would only drive s and z to 0 and their ratios to infinity
            exhausted = not gap > f64(1.0e-3) * tol * scale
            if converged or exhausted:
                break
            # predictor: rc = s z
            for row in range(rows):
                rc[env, row] = s[env, row] * z[env, row]
            newton_matrix(Q, mu, env, n, s, z, f64(0.0), H, LH)
            newton_direction(LH, mu, env, n, s, z, rd, rp, rc, y, dx, ds_aff, dz_aff)
            alpha = step_to_boundary(env, rows, s, z, ds_aff, dz_aff)
            gap_aff = f64(0.0)
            for row in range(rows):
                gap_aff = gap_aff + (s[env, row] + alpha * ds_aff[env, row]) * (z[env, row] + alpha * dz_aff[env, row])
            sigma = (gap_aff / f64(float(rows)) / gap) ** f64(3.0)
            # corrector: rc = s z + ds_aff dz_aff - sigma gap
            for row in range(rows):
                rc[env, row] = s[env, row] * z[env, row] + ds_aff[env, row] * dz_aff[env, row] - sigma * gap
            newton_direction(LH, mu, env, n, s, z, rd, rp, rc, y, dx, ds, dz)
            alpha = wp.min(f64(1.0), f64(0.99) * step_to_boundary(env, rows, s, z, ds, dz))
            probe = alpha
            for r in range(n):
                probe = probe + f64(0.0) * dx[env, r]
            for row in range(rows):
                probe = probe + f64(0.0) * (ds[env, row] + dz[env, row])
            if not wp.isfinite(probe):
                break  # a direction rounding made non-finite: keep the last iterate
            for r in range(n):
                x[env, r] = x[env, r] + alpha * dx[env, r]
            for row in range(rows):
                s[env, row] = s[env, row] + alpha * ds[env, row]
                z[env, row] = z[env, row] + alpha * dz[env, row]

    @wp.kernel(module="unique", enable_backward=False)
    def rigid_solve(
        model: B.Model,
        law: RigidLaw,
        J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar),
        depth: wp.array2d(dtype=scalar),
        beta: wp.array2d(dtype=sp.vec3),
        friction: wp.array2d(dtype=scalar),
        # float64 scratch for m rows (m / 3 points at most): active (N, m / 3) int; J and MinvJT (N, m, K); M64 and Lm
        # (N, K, K); Q, H and LH (N, m, m); the vectors q, x, rd, dx, y, w (N, max(m, K)), s, z, rp, rc, ds, dz, ds_aff,
        # dz_aff (N, 5 m / 3) and mu (N, m / 3)
        active: wp.array2d(dtype=wp.int32),
        J: wp.array3d(dtype=f64),
        MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64),
        Q: wp.array3d(dtype=f64),
        H: wp.array3d(dtype=f64),
        LH: wp.array3d(dtype=f64),
        q: wp.array2d(dtype=f64),
        x: wp.array2d(dtype=f64),
        rd: wp.array2d(dtype=f64),
        dx: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64),
        w: wp.array2d(dtype=f64),
        s: wp.array2d(dtype=f64),
        z: wp.array2d(dtype=f64),
        rp: wp.array2d(dtype=f64),
        rc: wp.array2d(dtype=f64),
        ds: wp.array2d(dtype=f64),
        dz: wp.array2d(dtype=f64),
        ds_aff: wp.array2d(dtype=f64),
        dz_aff: wp.array2d(dtype=f64),
        mu: wp.array2d(dtype=f64),
        # output
        force: wp.array2d(dtype=sp.vec3),
    ):
        """force (N, P) [N, world; a slot's in its contact axes]: the rigid forces of the penetrating points (the
        module docstring; 0 elsewhere) from `rigid_rows`' (and `rigid_slot_rows`') outputs, the points' Jacobians J_t
        (N, P, 6, K) and J̇ν (N, P, 6) (Mixed, ν Inertial), the mass matrix M (N, K, K) (Inertial base) and ABA's
        a_free (N, K); NaN for all where more points penetrate than the scratch holds (`qp_system`: the step flags that
        environment). Its adjoint is `rigid_solve_adjoint` (a tape records it by hand: warpdyn.engine.launch)."""
        env = wp.tid()
        n, scale = qp_system(model, law, J_t, Jdotnu_t, M, a_free, depth, beta, friction, env, active, J, MinvJT, M64, Lm, Q, q, y, w, mu)
        if n > 0:
            interior_point(law, mu, env, n, scale, Q, H, LH, q, x, rd, dx, y, s, z, rp, rc, ds, dz, ds_aff, dz_aff)
        if n < 0:
            for c in range(force.shape[1]):
                force[env, c] = sp.vec3(scalar(wp.nan), scalar(wp.nan), scalar(wp.nan))
        else:
            forces_out(env, n, active, x, force)

    @wp.kernel(module="unique", enable_backward=False)
    def rigid_solve_adjoint(
        model: B.Model,
        law: RigidLaw,
        J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar),
        depth: wp.array2d(dtype=scalar),
        beta: wp.array2d(dtype=sp.vec3),
        friction: wp.array2d(dtype=scalar),
        active: wp.array2d(dtype=wp.int32),
        J: wp.array3d(dtype=f64),
        MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64),
        Q: wp.array3d(dtype=f64),
        H: wp.array3d(dtype=f64),
        LH: wp.array3d(dtype=f64),
        q: wp.array2d(dtype=f64),
        x: wp.array2d(dtype=f64),
        rd: wp.array2d(dtype=f64),
        dx: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64),
        w: wp.array2d(dtype=f64),
        s: wp.array2d(dtype=f64),
        z: wp.array2d(dtype=f64),
        rp: wp.array2d(dtype=f64),
        rc: wp.array2d(dtype=f64),
        ds: wp.array2d(dtype=f64),
        dz: wp.array2d(dtype=f64),
        ds_aff: wp.array2d(dtype=f64),
        dz_aff: wp.array2d(dtype=f64),
        mu: wp.array2d(dtype=f64),
        # the adjoints: read and zeroed (adj_force), added into (the rest)
        adj_force: wp.array2d(dtype=sp.vec3),
        adj_J_t: wp.array4d(dtype=scalar),
        adj_Jdotnu_t: wp.array3d(dtype=scalar),
        adj_M: wp.array3d(dtype=scalar),
        adj_a_free: wp.array2d(dtype=scalar),
        adj_beta: wp.array2d(dtype=sp.vec3),
        adj_friction: wp.array2d(dtype=scalar),
    ):
        """The adjoint of `rigid_solve` (its QP solved again; OptNet's differentiation of the KKT conditions
        Q x + q + G^T z = 0, z ∘ G x = 0 at the solution, its active constraints, rows whose dual z_j exceeds their
        slack s_j, held): u = (Q + W G_A^T G_A)^-1 x̄ with W = ACTIVE_PENALTY times Q's largest diagonal entry (the
        equality-constrained KKT solve to 1e-8) gives adj q = -u, so adj beta = u and, by `rows_adjoint` with g = u,
        adj J, J̇ν, M, a_free; adj G = -W (G_A u) x^T - z u^T on the active rows gives adj mu = sum over the active
        friction rows of W (g_j . u) x_z + z_j u_z (G's -mu entries), per point. A flagged environment (n < 0: NaN
        forces) passes no adjoint."""
        env = wp.tid()
        n, scale = qp_system(model, law, J_t, Jdotnu_t, M, a_free, depth, beta, friction, env, active, J, MinvJT, M64, Lm, Q, q, y, w, mu)
        n = wp.max(n, 0)
        adjoint_in(env, n, active, adj_force, w)  # w: x̄ (the interior point does not use w)
        if n > 0:
            interior_point(law, mu, env, n, scale, Q, H, LH, q, x, rd, dx, y, s, z, rp, rc, ds, dz, ds_aff, dz_aff)
            largest = f64(0.0)
            for r in range(n):
                largest = wp.max(largest, Q[env, r, r])
            penalty = f64(ACTIVE_PENALTY) * largest
            newton_matrix(Q, mu, env, n, s, z, penalty, H, LH)
            C.substitute(LH, env, n, w, rd, 0)  # rd: u
            for i in range(n // 3):
                adj_mu = f64(0.0)
                for j in range(4):  # the friction rows, whose -mu entries multiply f_z
                    row = PYRAMID_ROWS * i + j
                    if z[env, row] > s[env, row]:
                        g = pyramid_row(mu[env, i], j)
                        gu = g[0] * rd[env, 3 * i] + g[1] * rd[env, 3 * i + 1] + g[2] * rd[env, 3 * i + 2]
                        adj_mu = adj_mu + penalty * gu * x[env, 3 * i + 2] + z[env, row] * rd[env, 3 * i + 2]
                c = active[env, i]
                adj_beta[env, c] = adj_beta[env, c] + sp.vec3(scalar(rd[env, 3 * i]), scalar(rd[env, 3 * i + 1]), scalar(rd[env, 3 * i + 2]))
                adj_friction[env, c] = adj_friction[env, c] + scalar(adj_mu)
            rows_adjoint(model, J, MinvJT, a_free, env, n, active, x, rd, y, w, adj_J_t, adj_Jdotnu_t, adj_M, adj_a_free)

    return types.SimpleNamespace(
        RigidLaw=RigidLaw,
        penetration=penetration,
        solver_offset=solver_offset,
        delassus=delassus,
        point_row=point_row,
        rows_adjoint=rows_adjoint,
        forces_out=forces_out,
        adjoint_in=adjoint_in,
        point_wrenches=point_wrenches,
        rigid_rows=rigid_rows,
        rigid_solve=rigid_solve,
        rigid_solve_adjoint=rigid_solve_adjoint,
    )
