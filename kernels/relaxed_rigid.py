"""JaxSim 0.9.0's relaxed-rigid contacts (jaxsim.rbda.contacts.relaxed_rigid) on kernels/rigid_contacts.py's rows,
Delassus matrix G = J M^-1 J^T and wrenches (its module docstring: the points' rows, the float64 linear algebra).

f = -(G + diag(R))^-1 (a - a_ref), per world axis of a penetrating point, with pos = -delta n and vel = p_dot: the
impedance xi in [d_min, d_max] of |pos| / width (MuJoCo's solimp sigmoid with `midpoint` and `power`; d_max beyond
width), a_ref = -(D vel + K xi pos), K = 1 / (d_max tau zeta)^2, D = 2 / (d_max tau) (tau the time constant, zeta
the damping coefficient; JaxSim's formula overwrites its parameters K and D, which it therefore never reads),
R = 2 mu^2 (1 - xi) / (xi + 1e-12) (1 + mu^2) / m, m the point's link's mass. JaxSim minimises |A f + b|^2 by
L-BFGS; here A is factorised: its exact minimiser.

Three launches: `relaxed_rigid_rows` (each point's depth, a_ref and R), `relaxed_rigid_solve` (the forces) and
kernels/rigid_contacts.py's `point_wrenches`; with geom contacts, `relaxed_slot_rows` makes each contact slot a further
point (its rows in the contact's axes, its mu the pair's, its mass the bodies' reduced mass) and
kernels/contact_slots.py's `slot_wrenches` applies their forces to both bodies. Gradients: Warp differentiates the rows and the wrenches (a thread per environment: each
adjoint of a link's pose or a shared parameter from one thread, in order); the solve has a hand-written adjoint,
`relaxed_rigid_solve_adjoint` (the implicit function theorem at the forward pass's penetrating points), which the
engine registers on the tape (warpdyn.engine.launch's Launch.adjoint).
"""

import types

import warp as wp

from .bundles import bundles
from .cholesky import kernels as cholesky_kernels
from .contact_slots import kernels as slot_kernels
from .factory import factory
from .rigid_contacts import kernels as rigid_kernels
from .spatial import spatial

REGULARISATION_FLOOR = 1.0e-12
"""JaxSim's 1e-12 added to the impedance xi in the relaxed-rigid regularisation R's denominator."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The relaxed-rigid contact kernels in `scalar`."""
    sp, B = spatial(scalar), bundles(scalar)
    f64 = wp.float64
    C = cholesky_kernels(f64)
    RC = rigid_kernels(scalar)
    S = slot_kernels(scalar)
    RigidLaw = RC.RigidLaw

    @wp.func
    def impedance(law: RigidLaw, distance: scalar):
        """JaxSim's relaxed-rigid impedance xi of |pos| = distance [m] on one axis."""
        one = scalar(1.0)
        x = distance / law.width
        mid = law.midpoint
        pw = law.power
        y = scalar(0.0)
        if x > scalar(0.0) and x < mid:  # x = 0: y = 0 (pow's derivative there is infinite for a power below 1)
            y = wp.pow(x, pw) / wp.pow(mid, pw - one)
        elif x <= one:
            y = one - wp.pow(one - x, pw) / wp.pow(one - mid, pw - one)
        xi = wp.clamp(law.d_min + y * (law.d_max - law.d_min), law.d_min, law.d_max)
        if x > one:
            xi = law.d_max
        return xi

    @wp.func
    def relaxed_axis(law: RigidLaw, mu: scalar, mass: scalar, delta: scalar, n_r: scalar, p_dot_r: scalar):
        """(a_ref, R) of a penetrating point on one world axis (the module docstring): pos = -delta n_r, its impedance
        xi; mass: the point's link's [kg]."""
        stiffness = scalar(1.0) / (law.d_max * law.time_constant * law.damping_coefficient) ** scalar(2.0)
        damping = scalar(2.0) / (law.d_max * law.time_constant)
        pos = -delta * n_r
        xi = impedance(law, wp.abs(pos))
        a_ref = -(damping * p_dot_r + stiffness * xi * pos)
        R = scalar(2.0) * mu * mu * (scalar(1.0) - xi) / (xi + scalar(REGULARISATION_FLOOR)) * (scalar(1.0) + mu * mu) / mass
        return a_ref, R

    @wp.kernel(module="unique")
    def relaxed_rigid_rows(
        model: B.Model,
        contacts: B.Contacts,
        law: RigidLaw,
        terrain: B.Terrain,
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        # outputs
        depth: wp.array2d(dtype=scalar),
        a_ref: wp.array2d(dtype=sp.vec3),
        R: wp.array2d(dtype=sp.vec3),
    ):
        """Each enabled point's penetration depth delta (N, P) [m] and, where it penetrates, its reference
        acceleration a_ref and regularisation R (N, P) per world axis (`relaxed_axis`; 0 elsewhere), from the link
        poses and Inertial velocities (N, nL). A thread per environment; differentiable (a tape records it)."""
        env = wp.tid()
        mu = B.env_parameter(contacts.mu, env)
        for c in range(contacts.point_link.shape[0]):
            p, p_dot, n, delta, delta_dot = RC.penetration(contacts, terrain, W_H_L, W_v_WL, env, c)
            reference = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
            regularisation = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
            if delta > scalar(0.0):
                mass = B.link_parameter(model.link_mass, env, contacts.point_link[c])
                a0, R0 = relaxed_axis(law, mu, mass, delta, n[0], p_dot[0])
                a1, R1 = relaxed_axis(law, mu, mass, delta, n[1], p_dot[1])
                a2, R2 = relaxed_axis(law, mu, mass, delta, n[2], p_dot[2])
                reference = sp.vec3(a0, a1, a2)
                regularisation = sp.vec3(R0, R1, R2)
            depth[env, c] = delta
            a_ref[env, c] = reference
            R[env, c] = regularisation

    @wp.kernel(module="unique")
    def relaxed_slot_rows(
        model: B.Model, law: RigidLaw, link1: wp.array(dtype=int), link2: wp.array(dtype=int), mu: wp.array(dtype=scalar),
        first: wp.array(dtype=int), slot_pair: wp.array(dtype=int), count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar),
        frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar), J_L: wp.array4d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6),
        W_a_L: wp.array2d(dtype=sp.vec6), points: int,
        # outputs: rows points + slot
        J_t: wp.array4d(dtype=scalar), Jdotnu_t: wp.array3d(dtype=scalar), depth: wp.array2d(dtype=scalar), a_ref: wp.array2d(dtype=sp.vec3),
        R: wp.array2d(dtype=sp.vec3),
    ):  # fmt: skip
        """The geom pairs' contact slots (C; kernels/collisions.py's `geom_contacts` at the same state) as the points
        points + slot of the relaxed-rigid solve: a slot holding a contact at dist < 0 penetrates by delta = -dist; its
        rows (kernels/contact_slots.py's `slot_point`: the velocity of geom2's point relative to geom1's in the contact's
        axes t1, t2, n) and its a_ref and R per axis (`relaxed_axis` with n = (0, 0, 1), the pair's mu, and the pair's
        reduced mass 1 / (1 / m_a + 1 / m_b), the world's mass infinite: JaxSim's link mass on the terrain). A
        frictionless pair (mu 0: condim 1) has tangential rows of zeros with a_ref 0 and R 1, so their forces are 0.
        J_L (N, nL, 6, K): the links' Inertial Jacobians; W_v_WL, W_a_L (N, nL): their Inertial velocities and J̇ν.
        A thread per environment; differentiable (a tape records it)."""
        env = wp.tid()
        zero = scalar(0.0)
        for slot in range(slot_pair.shape[0]):
            i = slot_pair[slot]
            c = points + slot
            delta, frictionless = S.slot_penetration(first, count, dist, mu, env, i, slot)
            reference = sp.vec3(zero, zero, zero)
            regularisation = sp.vec3(zero, zero, zero)
            if delta > zero:
                v = S.slot_point(J_L, W_v_WL, W_a_L, link1[i], link2[i], position, frame, env, slot, c, frictionless, J_t, Jdotnu_t)
                mass = scalar(1.0) / (S.inverse_mass(model, env, link1[i]) + S.inverse_mass(model, env, link2[i]))
                a0, R0 = relaxed_axis(law, mu[i], mass, delta, zero, v[0])
                a1, R1 = relaxed_axis(law, mu[i], mass, delta, zero, v[1])
                a2, R2 = relaxed_axis(law, mu[i], mass, delta, scalar(1.0), v[2])
                reference = sp.vec3(a0, a1, a2)
                regularisation = sp.vec3(R0, R1, R2)
                if frictionless != 0:
                    reference = sp.vec3(zero, zero, a2)
                    regularisation = sp.vec3(scalar(1.0), scalar(1.0), R2)
            depth[env, c] = delta
            a_ref[env, c] = reference
            R[env, c] = regularisation

    @wp.func
    def relaxed_system(
        model: B.Model, J_t: wp.array4d(dtype=scalar), Jdotnu_t: wp.array3d(dtype=scalar), M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar), depth: wp.array2d(dtype=scalar), a_ref: wp.array2d(dtype=sp.vec3), R: wp.array2d(dtype=sp.vec3),
        env: int, active: wp.array2d(dtype=wp.int32), J: wp.array3d(dtype=f64), MinvJT: wp.array3d(dtype=f64), M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64), A: wp.array3d(dtype=f64), LA: wp.array3d(dtype=f64), b: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64), w: wp.array2d(dtype=f64),
    ):
        """The penetrating points' system (float64): their rows (`point_row`), A = G + diag(R) factorised into LA
        and b = a_ref - a (the right-hand side of A f = b); returns the number of rows m = 3 k, or -1 where more
        points penetrate than the scratch holds (J's rows / 3: the stage's max_active_contacts)."""
        k = int(0)
        overflow = int(0)
        for c in range(depth.shape[1]):
            if depth[env, c] > scalar(0.0):
                if 3 * k < J.shape[1]:
                    RC.point_row(J_t, Jdotnu_t, a_free, env, c, k, active, J, b)
                    k = k + 1
                else:
                    overflow = 1
        if overflow != 0:
            return -1
        m = 3 * k
        if m > 0:  # an environment out of contact factorises nothing
            RC.delassus(model, M, J, env, m, M64, Lm, MinvJT, y, w, A)
        for i in range(k):
            c = active[env, i]
            for r in range(3):
                j = 3 * i + r
                b[env, j] = f64(a_ref[env, c][r]) - b[env, j]
                A[env, j, j] = A[env, j, j] + f64(R[env, c][r])
        if m > 0:
            C.factor(A, env, 0, m, f64(0.0), LA)
        return m

    @wp.kernel(module="unique", enable_backward=False)
    def relaxed_rigid_solve(
        model: B.Model,
        J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar),
        depth: wp.array2d(dtype=scalar),
        a_ref: wp.array2d(dtype=sp.vec3),
        R: wp.array2d(dtype=sp.vec3),
        # float64 scratch: active (N, P) int; J and MinvJT (N, 3P, K); M64 and Lm (N, K, K); A and LA (N, 3P, 3P);
        # b, f, y, w (N, max(3P, K))
        active: wp.array2d(dtype=wp.int32),
        J: wp.array3d(dtype=f64),
        MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64),
        A: wp.array3d(dtype=f64),
        LA: wp.array3d(dtype=f64),
        b: wp.array2d(dtype=f64),
        f: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64),
        w: wp.array2d(dtype=f64),
        # output
        force: wp.array2d(dtype=sp.vec3),
    ):
        """force (N, P) [N, world; a slot's in its contact axes]: the relaxed-rigid forces f = (G + diag(R))^-1
        (a_ref - a) of the penetrating points (0 elsewhere), from `relaxed_rigid_rows`' (and `relaxed_slot_rows`')
        outputs, the points' Jacobians J_t (N, P, 6, K) and J̇ν (N, P, 6) (Mixed, ν Inertial), the mass matrix M
        (N, K, K) (Inertial base) and ABA's a_free (N, K); NaN for all where more points penetrate than the scratch
        holds (`relaxed_system`: the step flags that environment). Its adjoint is `relaxed_rigid_solve_adjoint` (a
        tape records it by hand: warpdyn.engine.launch)."""
        env = wp.tid()
        m = relaxed_system(model, J_t, Jdotnu_t, M, a_free, depth, a_ref, R, env, active, J, MinvJT, M64, Lm, A, LA, b, y, w)
        if m > 0:
            C.substitute(LA, env, m, b, f, 0)
        if m < 0:
            for c in range(force.shape[1]):
                force[env, c] = sp.vec3(scalar(wp.nan), scalar(wp.nan), scalar(wp.nan))
        else:
            RC.forces_out(env, m, active, f, force)

    @wp.kernel(module="unique", enable_backward=False)
    def relaxed_rigid_solve_adjoint(
        model: B.Model,
        J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        a_free: wp.array2d(dtype=scalar),
        depth: wp.array2d(dtype=scalar),
        a_ref: wp.array2d(dtype=sp.vec3),
        R: wp.array2d(dtype=sp.vec3),
        active: wp.array2d(dtype=wp.int32),
        J: wp.array3d(dtype=f64),
        MinvJT: wp.array3d(dtype=f64),
        M64: wp.array3d(dtype=f64),
        Lm: wp.array3d(dtype=f64),
        A: wp.array3d(dtype=f64),
        LA: wp.array3d(dtype=f64),
        b: wp.array2d(dtype=f64),
        f: wp.array2d(dtype=f64),
        y: wp.array2d(dtype=f64),
        w: wp.array2d(dtype=f64),
        # the adjoints: read and zeroed (adj_force), added into (the rest)
        adj_force: wp.array2d(dtype=sp.vec3),
        adj_J_t: wp.array4d(dtype=scalar),
        adj_Jdotnu_t: wp.array3d(dtype=scalar),
        adj_M: wp.array3d(dtype=scalar),
        adj_a_free: wp.array2d(dtype=scalar),
        adj_a_ref: wp.array2d(dtype=sp.vec3),
        adj_R: wp.array2d(dtype=sp.vec3),
    ):
        """The adjoint of `relaxed_rigid_solve` (its system recomputed; the active set held), from the implicit
        function theorem for A f = b with A = J M^-1 J^T + diag(R), b = a_ref - J a_free - J̇ν: with b̄ = A^-1 f̄,
        adj a_ref = b̄, adj R = -b̄ ∘ f, and kernels/rigid_contacts.py's `rows_adjoint` for J, J̇ν, M and a_free."""
        env = wp.tid()
        m = wp.max(relaxed_system(model, J_t, Jdotnu_t, M, a_free, depth, a_ref, R, env, active, J, MinvJT, M64, Lm, A, LA, b, y, w), 0)
        RC.adjoint_in(env, m, active, adj_force, y)  # a flagged environment (m < 0: NaN forces) passes no adjoint
        if m > 0:
            C.substitute(LA, env, m, b, f, 0)
            C.substitute(LA, env, m, y, w, 0)  # w: b̄
            for i in range(m // 3):
                c = active[env, i]
                adj_a_ref[env, c] = adj_a_ref[env, c] + sp.vec3(scalar(w[env, 3 * i]), scalar(w[env, 3 * i + 1]), scalar(w[env, 3 * i + 2]))
                adj_R[env, c] = adj_R[env, c] - sp.vec3(
                    scalar(w[env, 3 * i] * f[env, 3 * i]), scalar(w[env, 3 * i + 1] * f[env, 3 * i + 1]), scalar(w[env, 3 * i + 2] * f[env, 3 * i + 2])
                )
            RC.rows_adjoint(model, J, MinvJT, a_free, env, m, active, f, w, b, y, adj_J_t, adj_Jdotnu_t, adj_M, adj_a_free)

    return types.SimpleNamespace(
        relaxed_rigid_rows=relaxed_rigid_rows,
        relaxed_slot_rows=relaxed_slot_rows,
        relaxed_rigid_solve=relaxed_rigid_solve,
        relaxed_rigid_solve_adjoint=relaxed_rigid_solve_adjoint,
    )
