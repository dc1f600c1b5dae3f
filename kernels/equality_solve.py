"""The constrained accelerations of MJCF equality constraints (kernels/equality.py's module docstring: MuJoCo's soft
equality constraints), in three launches, one thread per environment:

- `equality_rows` (differentiable: a tape records it): each constraint's rows J (m, K), reference accelerations
  aref = -b J nu - k imp r - J̇ν and regularisation R (m,) (a frame weld's: aref = -(K_P r + K_D J nu), R its own);
- `equality_solve`: f = (J M^-1 J^T + diag(R))^-1 (aref - J a0) and nu_dot = a0 + M^-1 J^T f, or with MuJoCo's
  implicit joint damping the explicit a0 = a0' + dt M^-1 D a0' and nu_dot = a0' + (M + dt D)^-1 J^T f; with joint
  limits and friction rows, over the rows an active set solves for (`active_set`: the limits that push, f > 0, and
  the friction rows within their bounds; the others' f 0 or, saturated, their bound);
- `equality_solve_adjoint`: its adjoint, written by hand (the implicit function theorem; with implicit damping, but
  not with respect to the damping, whose gradients the engine refuses under a tape), registered on the tape by the
  engine (warpdyn.engine.launch's Launch.adjoint), on the rows the active set solved for (the set is locally
  constant: the rows left free or saturated carry no adjoint; a saturated row's force enters as a constant). Without damping: with
  w = M^-1 nudot_bar, fbar = J w, bbar = A^-1 fbar, u = M^-1 J^T f and v = M^-1 J^T bbar (the solved block),
  adj a0 = nudot_bar - J^T bbar, adj aref = bbar, adj R = -bbar f, adj J = f (w - v)^T - bbar (a0 + u)^T,
  adj M = sym((v - w) u^T); `equality_solve_adjoint` gives the damped terms.
"""

import types

import warp as wp

from .bundles import bundles
from .cholesky import kernels as cholesky_kernels
from .equality import FRAME_WELD, FRICTION, LIMIT, MIN_VALUE
from .equality import kernels as equality_kernels
from .factory import factory
from .spatial import MIXED, spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The equality constraints' solve in `scalar`."""
    sp, B = spatial(scalar), bundles(scalar)
    C, E = cholesky_kernels(scalar), equality_kernels(scalar)
    Equalities = E.Equalities

    @wp.kernel(module="unique")
    def equality_rows(
        eq: Equalities,
        x: B.State,
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar),
        dt: scalar,
        refsafe: int,
        # outputs
        J: wp.array3d(dtype=scalar),
        aref: wp.array2d(dtype=scalar),
        R: wp.array2d(dtype=scalar),
    ):
        """J (N, m, K), aref and R (N, m) of the constraints at the state x, its link poses W_H_L and Inertial
        velocities W_v_WL (N, nL) and the anchors' Jacobians J_t (N, T, 6, K) and J̇ν (N, T, 6) (Mixed, ν
        Inertial). dt: the step; refsafe: MuJoCo's time constant raised to 2 dt (0: as given)."""
        env = wp.tid()
        W_H_B = B.base_pose(x, env)
        v_B = sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(x, env))
        for e in range(eq.kind.shape[0]):
            row = eq.row[e]
            residual, bias, rows, distance = E.constraint_rows(eq, x, W_H_L, W_v_WL, J_t, Jdotnu_t, env, e, J, 1)
            if eq.kind[e] == LIMIT and residual[0] >= scalar(0.0):  # a limit within its range: no force (f = 0)
                aref[env, row] = scalar(0.0)
                R[env, row] = scalar(1.0)
            elif eq.kind[e] == FRAME_WELD:  # JaxSim's Baumgarte gains and regularisation
                for a in range(rows):
                    aref[env, row + a] = -eq.baumgarte[e, 1] * E.row_velocity(J, env, row + a, v_B, x) - eq.baumgarte[e, 0] * residual[a]
                    R[env, row + a] = eq.regularization[e]
            else:
                imp = E.impedance(eq, e, distance)
                k_imp, b = E.reference(eq, e, dt, refsafe, imp)
                for a in range(rows):
                    invweight = eq.invweight[e]
                    if a >= 3:  # a weld's rotation rows
                        invweight = eq.invweight_rotation[e]
                    aref[env, row + a] = -b * E.row_velocity(J, env, row + a, v_B, x) - k_imp * residual[a] - bias[a]
                    R[env, row + a] = wp.max(scalar(MIN_VALUE), (scalar(1.0) - imp) * invweight / imp)

    @wp.func
    def solved(active: wp.array2d(dtype=scalar), env: int, r: int):
        """1 where row r is solved for (`active_set`'s state 1), else 0 (a free or a saturated row)."""
        if active[env, r] == scalar(1.0):
            return scalar(1.0)
        return scalar(0.0)

    @wp.func
    def friction_bound(model: B.Model, eq: Equalities, env: int, e: int):
        """Friction constraint e's bound on its force: its joint's frictionloss, friction_static [N m or N]."""
        return B.joint_parameter(model.friction_static, env, eq.term_dof[eq.first1[e]])

    @wp.func
    def gather_solved(active: wp.array2d(dtype=scalar), env: int, m: int, v: wp.array2d(dtype=scalar)):
        """Moves the entries of v[env, 0:m] of the rows solved for (`active`'s 1) to its front, in order; returns
        their number."""
        n = int(0)
        for r in range(m):
            if solved(active, env, r) != scalar(0.0):
                v[env, n] = v[env, r]
                n = n + 1
        return n

    @wp.func
    def scatter_solved(active: wp.array2d(dtype=scalar), env: int, m: int, n: int, v: wp.array2d(dtype=scalar)):
        """The inverse of `gather_solved`: v[env, 0:n] back to the rows solved for, 0 at the others."""
        j = n
        for k in range(m):
            r = m - 1 - k
            value = scalar(0.0)
            if solved(active, env, r) != scalar(0.0):
                j = j - 1
                value = v[env, j]
            v[env, r] = value

    @wp.func
    def saturated_force(model: B.Model, eq: Equalities, active: wp.array2d(dtype=scalar), env: int, e: int):
        """Constraint e's force where it is a friction row saturated at its bound (`active`'s +-2: +-the bound),
        else 0."""
        state = active[env, eq.row[e]]
        if eq.kind[e] == FRICTION and wp.abs(state) == scalar(2.0):
            return wp.sign(state) * friction_bound(model, eq, env, e)
        return scalar(0.0)

    @wp.func
    def masked_solve(model: B.Model, eq: Equalities, A: wp.array3d(dtype=scalar), active: wp.array2d(dtype=scalar), y: wp.array2d(dtype=scalar),
                     env: int, m: int, LA: wp.array3d(dtype=scalar), rhs: wp.array2d(dtype=scalar), w: wp.array2d(dtype=scalar)):
        """The rows' forces w[0:m] in `active`'s states (`active_set`): the solved rows' from their block of A
        (gathered and factorised into LA[0:n, 0:n], n their number) and y less the saturated rows' share,
        A_rs f_s; a saturated friction row's f = +-its bound (`saturated_force`); a free row's 0."""
        for r in range(m):
            rhs[env, r] = y[env, r]
        for e in range(eq.kind.shape[0]):
            f = saturated_force(model, eq, active, env, e)
            if f != scalar(0.0):
                s = eq.row[e]
                for r in range(m):
                    rhs[env, r] = rhs[env, r] - A[env, r, s] * f
        n = gather_solved(active, env, m, rhs)
        i = int(0)
        for r in range(m):
            if solved(active, env, r) != scalar(0.0):
                j = int(0)
                for c in range(r + 1):
                    if solved(active, env, c) != scalar(0.0):
                        LA[env, i, j] = A[env, r, c]
                        j = j + 1
                i = i + 1
        C.factor(LA, env, 0, n, scalar(-1.0), LA)  # in place: factor reads the lower triangle before it writes it
        C.substitute(LA, env, n, rhs, w, 0)
        scatter_solved(active, env, m, n, w)
        for e in range(eq.kind.shape[0]):
            f = saturated_force(model, eq, active, env, e)
            if f != scalar(0.0):
                w[env, eq.row[e]] = f

    @wp.func
    def row_jar(A: wp.array3d(dtype=scalar), R: wp.array2d(dtype=scalar), y: wp.array2d(dtype=scalar), w: wp.array2d(dtype=scalar), env: int,
                m: int, r: int):
        """Row r's jar = J a - aref = (A f)_r - R_r f_r - y_r at the forces f = w[0:m] (`active_set`)."""
        jar = -y[env, r] - R[env, r] * w[env, r]
        for q in range(m):
            if w[env, q] != scalar(0.0):
                jar = jar + A[env, r, q] * w[env, q]
        return jar

    @wp.func
    def active_set(
        model: B.Model, eq: Equalities, x: B.State, A: wp.array3d(dtype=scalar), R: wp.array2d(dtype=scalar), env: int, m: int,
        LA: wp.array3d(dtype=scalar), y: wp.array2d(dtype=scalar), rhs: wp.array2d(dtype=scalar), w: wp.array2d(dtype=scalar),
        active: wp.array2d(dtype=scalar),
    ):
        """The forces w[0:m] of A f = rhs (A = J M^-1 J^T + diag(R)) with the limits' rows unilateral and the friction
        rows bounded, as MuJoCo's solvers reach them: the force of a row with jar = J a - aref is f = -jar / R where
        that obeys the row's bound, else the bound: a limit past its bound (margin included) pushes, f > 0, or is free,
        f = 0 where jar >= 0; a friction row's |f| <= its joint's frictionloss b, f = b where jar <= -R b, -b where
        jar >= R b. Active set, `active` (m) each row's state: 1 solved for (every equality row; a limit past its bound
        and a friction row at first), 0 free (f = 0), +-2 a friction row saturated at +-b. A pass solves
        (`masked_solve`), then moves a limit whose f < 0 to free and a free limit past its bound whose jar < 0 back, a
        friction row whose |f| > b to saturated and a saturated one whose jar leaves its side back; until none
        changes (at most 2 passes per such row, and one more). y: rhs kept; LA: the factor of the last solved block
        (gathered: `masked_solve`); jar: `row_jar`."""
        rows = int(0)
        changed = int(0)
        for r in range(m):
            y[env, r] = rhs[env, r]
            active[env, r] = scalar(1.0)
        for e in range(eq.kind.shape[0]):
            if eq.kind[e] == LIMIT:
                rows = rows + 1
                gap, side = E.limit_gap(eq, x, env, e)
                if gap >= scalar(0.0):
                    active[env, eq.row[e]] = scalar(0.0)
            elif eq.kind[e] == FRICTION:
                rows = rows + 1
                if friction_bound(model, eq, env, e) <= scalar(0.0):
                    active[env, eq.row[e]] = scalar(0.0)
        for it in range(2 * rows + 1):
            masked_solve(model, eq, A, active, y, env, m, LA, rhs, w)
            changed = int(0)
            for e in range(eq.kind.shape[0]):
                r = eq.row[e]
                state = active[env, r]
                if eq.kind[e] == LIMIT:
                    gap, side = E.limit_gap(eq, x, env, e)
                    if gap < scalar(0.0):
                        if state == scalar(1.0) and w[env, r] < scalar(0.0):
                            active[env, r] = scalar(0.0)
                            changed = int(1)
                        elif state == scalar(0.0) and row_jar(A, R, y, w, env, m, r) < scalar(0.0):
                            active[env, r] = scalar(1.0)
                            changed = int(1)
                elif eq.kind[e] == FRICTION and state != scalar(0.0):
                    bound = friction_bound(model, eq, env, e)
                    if state == scalar(1.0):
                        if w[env, r] > bound:
                            active[env, r] = scalar(2.0)
                            changed = int(1)
                        elif w[env, r] < -bound:
                            active[env, r] = scalar(-2.0)
                            changed = int(1)
                    else:
                        jar = row_jar(A, R, y, w, env, m, r)
                        if (state == scalar(2.0) and jar > -R[env, r] * bound) or (state == scalar(-2.0) and jar < R[env, r] * bound):
                            active[env, r] = scalar(1.0)
                            changed = int(1)
            if changed == 0:
                break
        if rows > 0 and changed != 0:  # the last pass changed the set: solve on it
            masked_solve(model, eq, A, active, y, env, m, LA, rhs, w)

    @wp.func
    def free_accelerations(
        model: B.Model, eq: Equalities, x: B.State, J: wp.array3d(dtype=scalar), aref: wp.array2d(dtype=scalar), R: wp.array2d(dtype=scalar),
        M: wp.array3d(dtype=scalar), a_free: wp.array2d(dtype=scalar), implicit_dt: scalar, env: int, off: int, L: wp.array3d(dtype=scalar),
        MinvJT: wp.array3d(dtype=scalar), A: wp.array3d(dtype=scalar), LA: wp.array3d(dtype=scalar), y: wp.array2d(dtype=scalar),
        rhs: wp.array2d(dtype=scalar), w: wp.array2d(dtype=scalar), active: wp.array2d(dtype=scalar), nu_dot: wp.array2d(dtype=scalar),
    ):
        """M^-1 J^T (rows of MinvJT, M factorised into L), nu_dot = a0 (with implicit damping the explicit a0 =
        a0' + dt M^-1 D a0': a floating base's damper d acts on MuJoCo's free-joint coordinates T nu, D's base block
        d T^T T, its force d T^T (T a0' + T_dot nu), T_dot nu = [w x p_dot; 0]), A = J M^-1 J^T + diag(R), rhs = aref -
        J a0 and the forces f in w[0:m] (`active_set`: LA the factor of the rows solved, `active` which); returns (T's
        damper block for the final solve, the number of rows m)."""
        K = M.shape[1]
        m = J.shape[1]
        parent = eq.dof_parent
        base_damper = sp.mat66(scalar(0.0))
        T = sp.mat66(scalar(0.0))
        d_base = scalar(0.0)
        if model.floating_base != 0:
            d_base = B.joint_parameter(model.base_damping, env, 0)
            T = E.base_coordinates(x, env)
            base_damper = d_base * (wp.transpose(T) * T)
        E.inverse_mass_rows(model, M, env, off, parent, J, eq.row_column, L, w, MinvJT, active)  # active: the rows used, until `active_set`
        for i in range(K):
            nu_dot[env, i] = a_free[env, i]
        if implicit_dt > scalar(0.0):
            for i in range(off, K):
                w[env, i] = scalar(0.0)
                if i >= 6:
                    w[env, i] = B.joint_parameter(model.damping, env, i - 6) * a_free[env, i]
            if d_base != scalar(0.0):
                v_mixed = B.base_velocity_mixed(x, env)
                rate = wp.cross(sp.ang(v_mixed), sp.lin(v_mixed))
                a_base = sp.vec6(a_free[env, 0], a_free[env, 1], a_free[env, 2], a_free[env, 3], a_free[env, 4], a_free[env, 5])
                force = d_base * (wp.transpose(T) * (T * a_base + sp.stack(rate, sp.vec3(scalar(0.0)))))
                for i in range(6):
                    w[env, i] = force[i]
            E.tree_solve(L, env, off, parent, w)
            for i in range(off, K):
                nu_dot[env, i] = a_free[env, i] + implicit_dt * w[env, i]
        E.delassus_rows(J, MinvJT, env, off, eq.row_column, active, A)
        for r in range(m):
            s = aref[env, r]
            for c in range(off, K):
                s = s - J[env, r, c] * nu_dot[env, c]
            rhs[env, r] = s
            A[env, r, r] = A[env, r, r] + R[env, r]
        active_set(model, eq, x, A, R, env, m, LA, y, rhs, w, active)
        return base_damper, m

    @wp.kernel(module="unique", enable_backward=False)
    def equality_solve(
        model: B.Model,
        eq: Equalities,
        x: B.State,
        J: wp.array3d(dtype=scalar),
        aref: wp.array2d(dtype=scalar),
        R: wp.array2d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar),
        implicit_dt: scalar,
        # scratch: L (N, K, K), MinvJT (N, m, K), A and LA (N, m, m), y, rhs, w, active (N, max(m, K))
        L: wp.array3d(dtype=scalar),
        MinvJT: wp.array3d(dtype=scalar),
        A: wp.array3d(dtype=scalar),
        LA: wp.array3d(dtype=scalar),
        y: wp.array2d(dtype=scalar),
        rhs: wp.array2d(dtype=scalar),
        w: wp.array2d(dtype=scalar),
        active: wp.array2d(dtype=scalar),
        # output
        nu_dot: wp.array2d(dtype=scalar),
    ):
        """nu_dot (N, K = 6 + nv): the constrained accelerations (Inertial base) from `equality_rows`' outputs, ABA's
        a_free (N, K) and the mass matrix M (N, K, K) (Inertial base); implicit_dt: dt for MuJoCo's implicit joint
        damping, else 0. A fixed base's DoFs (the first six) are not solved for."""
        env = wp.tid()
        K = M.shape[1]
        off = 6
        if model.floating_base != 0:
            off = 0
        base_damper, m = free_accelerations(model, eq, x, J, aref, R, M, a_free, implicit_dt, env, off, L, MinvJT, A, LA, y, rhs, w, active, nu_dot)
        if implicit_dt > scalar(0.0):  # nu_dot = a0' + (M + dt D)^-1 J^T f
            for i in range(off, K):
                s = scalar(0.0)
                for r in range(m):
                    s = s + J[env, r, i] * w[env, r]
                y[env, i] = s
            E.tree_factor(model, M, env, off, eq.dof_parent, implicit_dt, base_damper, L)
            E.tree_solve(L, env, off, eq.dof_parent, y)
            for i in range(off, K):
                nu_dot[env, i] = a_free[env, i] + y[env, i]
        else:
            for i in range(off, K):
                s = nu_dot[env, i]
                for r in range(m):
                    s = s + MinvJT[env, r, i] * w[env, r]
                nu_dot[env, i] = s

    @wp.func
    def damper_form_gradient(p: sp.vec3, a: sp.vec6, b: sp.vec6):
        """The gradient in p of a^T S(p) b, S = [[I, -[p]x], [[p]x, I - [p]x^2]] (a floating base's implicit damper's
        metric in MuJoCo's free-joint coordinates, `equality_solve_adjoint`)."""
        a_l, a_r, b_l, b_r = sp.lin(a), sp.ang(a), sp.lin(b), sp.ang(b)
        return wp.cross(b_l, a_r) - wp.cross(b_r, a_l) - a_r * wp.dot(p, b_r) - b_r * wp.dot(a_r, p) + scalar(2.0) * p * wp.dot(a_r, b_r)

    @wp.func
    def base_damper_adjoint(
        x: B.State, env: int, hd: scalar, g: wp.array2d(dtype=scalar), y_h: wp.array2d(dtype=scalar), v: wp.array2d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar), adj_a_free: wp.array2d(dtype=scalar), adj_x: B.State,
    ):
        """A floating base's implicit damper's terms of `equality_solve_adjoint` (hd = h d): into adj a0' (its base
        part, -hd S v), the state's base position and its Mixed velocity [p_dot; omega]."""
        p = wp.transform_get_translation(B.base_pose(x, env))
        mixed = B.base_velocity_mixed(x, env)
        g_b = sp.vec6(g[env, 0], g[env, 1], g[env, 2], g[env, 3], g[env, 4], g[env, 5])
        y_b = sp.vec6(y_h[env, 0], y_h[env, 1], y_h[env, 2], y_h[env, 3], y_h[env, 4], y_h[env, 5])
        v_b = sp.vec6(v[env, 0], v[env, 1], v[env, 2], v[env, 3], v[env, 4], v[env, 5])
        a_b = sp.vec6(a_free[env, 0], a_free[env, 1], a_free[env, 2], a_free[env, 3], a_free[env, 4], a_free[env, 5])
        v_l, v_r = sp.lin(v_b), sp.ang(v_b)
        S_v = sp.stack(v_l - wp.cross(p, v_r), wp.cross(p, v_l) + v_r - wp.cross(p, wp.cross(p, v_r)))
        for i in range(6):
            adj_a_free[env, i] = adj_a_free[env, i] - hd * S_v[i]
        rho = wp.cross(sp.ang(mixed), sp.lin(mixed))
        adj_p = -hd * (damper_form_gradient(p, g_b, y_b) + damper_form_gradient(p, v_b, a_b) + wp.cross(rho, v_r))
        adj_rho = -hd * (v_l + wp.cross(v_r, p))
        adj_omega = wp.cross(sp.lin(mixed), adj_rho)
        adj_pdot = wp.cross(adj_rho, sp.ang(mixed))
        for r in range(3):
            adj_x.base_position[env, r] = adj_x.base_position[env, r] + adj_p[r]
            adj_x.base_velocity[env, r] = adj_x.base_velocity[env, r] + adj_pdot[r]
            adj_x.base_velocity[env, 3 + r] = adj_x.base_velocity[env, 3 + r] + adj_omega[r]

    @wp.kernel(module="unique", enable_backward=False)
    def equality_solve_adjoint(
        model: B.Model,
        eq: Equalities,
        x: B.State,
        J: wp.array3d(dtype=scalar),
        aref: wp.array2d(dtype=scalar),
        R: wp.array2d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar),
        implicit_dt: scalar,
        L: wp.array3d(dtype=scalar),
        MinvJT: wp.array3d(dtype=scalar),
        A: wp.array3d(dtype=scalar),
        LA: wp.array3d(dtype=scalar),
        y: wp.array2d(dtype=scalar),
        rhs: wp.array2d(dtype=scalar),
        w: wp.array2d(dtype=scalar),
        active: wp.array2d(dtype=scalar),
        u: wp.array2d(dtype=scalar),
        v: wp.array2d(dtype=scalar),
        a0: wp.array2d(dtype=scalar),
        t: wp.array2d(dtype=scalar),
        # the adjoints: read and zeroed (adj_nu_dot), added into (the rest: adj_x the state's base position and
        # velocity, through a floating base's implicit damper)
        adj_nu_dot: wp.array2d(dtype=scalar),
        adj_x: B.State,
        adj_J: wp.array3d(dtype=scalar),
        adj_aref: wp.array2d(dtype=scalar),
        adj_R: wp.array2d(dtype=scalar),
        adj_M: wp.array3d(dtype=scalar),
        adj_a_free: wp.array2d(dtype=scalar),
    ):
        """The adjoint of `equality_solve` (the module docstring), its solve recomputed (a0, t: scratch). With
        MuJoCo's implicit damping (h = implicit_dt; D the joints' damping and a floating base's d S(p), S = T^T T =
        [[I, -[p]x], [[p]x, I - [p]x^2]] in the base's position p; gradients of the damping itself are refused under
        a tape): g = (M + h D)^-1 nudot_bar, y_h = (M + h D)^-1 J^T f, and adj a0' = nudot_bar - J^T bbar - h D v,
        adj J = f (g - v)^T - bbar (a0 + u)^T, adj M = sym(v (u + a0 - a0')^T - g y_h^T); the base's damper adds
        adj p = h d (-grad_p(g^T S y_h) - grad_p(v^T S a0') - rho x v_r) and, through rho = omega x p_dot (its force
        d T^T (T a0' + [rho; 0])), adj rho = -h d (v_l + v_r x p) into the state's Mixed velocity. Without implicit
        damping g = w, y_h = u, a0 = a0'."""
        env = wp.tid()
        K = M.shape[1]
        off = 6
        if model.floating_base != 0:
            off = 0
        parent = eq.dof_parent
        base_damper, m = free_accelerations(model, eq, x, J, aref, R, M, a_free, implicit_dt, env, off, L, MinvJT, A, LA, y, rhs, w, active, a0)  # w: f
        for i in range(K):  # u: nudot_bar on the solved block (the rest passes to a0'), t: J^T f
            g = adj_nu_dot[env, i]
            adj_a_free[env, i] = adj_a_free[env, i] + g
            adj_nu_dot[env, i] = scalar(0.0)
            u[env, i] = scalar(0.0)
            t[env, i] = scalar(0.0)
            if i >= off:
                u[env, i] = g
                s = scalar(0.0)
                for r in range(m):
                    s = s + J[env, r, i] * w[env, r]
                t[env, i] = s
        if implicit_dt > scalar(0.0):
            E.tree_factor(model, M, env, off, parent, implicit_dt, base_damper, L)  # L: M + h D
        E.tree_solve(L, env, off, parent, u)  # u: g
        E.tree_solve(L, env, off, parent, t)  # t: y_h
        for r in range(m):  # rhs: fbar = J g on the rows solved (bbar 0 on those left out)
            s = scalar(0.0)
            for i in range(off, K):
                s = s + J[env, r, i] * u[env, i]
            rhs[env, r] = s
        n = gather_solved(active, env, m, rhs)
        C.substitute(LA, env, n, rhs, y, 0)
        scatter_solved(active, env, m, n, y)  # y: bbar
        for i in range(K):  # v: M^-1 J^T bbar, rhs: M^-1 J^T f (the solved block; 0 elsewhere)
            s_v = scalar(0.0)
            s_f = scalar(0.0)
            if i >= off:
                for r in range(m):
                    s_v = s_v + MinvJT[env, r, i] * y[env, r]
                    s_f = s_f + MinvJT[env, r, i] * w[env, r]
            v[env, i] = s_v
            rhs[env, i] = s_f
        for r in range(m):
            adj_aref[env, r] = adj_aref[env, r] + y[env, r]
            adj_R[env, r] = adj_R[env, r] - y[env, r] * w[env, r]
            for i in range(off, K):
                adj_J[env, r, i] = adj_J[env, r, i] + w[env, r] * (u[env, i] - v[env, i]) - y[env, r] * (a0[env, i] + rhs[env, i])
        for i in range(off, K):
            s = scalar(0.0)
            for r in range(m):
                s = s + J[env, r, i] * y[env, r]
            if i >= 6 and implicit_dt > scalar(0.0):
                s = s + implicit_dt * B.joint_parameter(model.damping, env, i - 6) * v[env, i]
            adj_a_free[env, i] = adj_a_free[env, i] - s
        if implicit_dt > scalar(0.0) and off == 0:
            hd = implicit_dt * B.joint_parameter(model.base_damping, env, 0)
            if hd != scalar(0.0):
                base_damper_adjoint(x, env, hd, u, t, v, a_free, adj_a_free, adj_x)
        for r in range(off, K):
            for c in range(off, K):
                shift_r = rhs[env, r] + a0[env, r] - a_free[env, r]
                shift_c = rhs[env, c] + a0[env, c] - a_free[env, c]
                adj_M[env, r, c] = adj_M[env, r, c] + scalar(0.5) * (v[env, r] * shift_c + shift_r * v[env, c] - u[env, r] * t[env, c] - t[env, r] * u[env, c])

    return types.SimpleNamespace(equality_rows=equality_rows, equality_solve=equality_solve, equality_solve_adjoint=equality_solve_adjoint)
