"""Soft contacts of collidable points with the terrain: JaxSim's SoftContacts (Hunt/Crossley), per point.

For a point at p with velocity v and tangential deformation m (the contact state), on terrain of
height h(x, y) and unit normal n (see warpdyn.terrain), with eps = 2.22e-16 (float64's, as JaxSim):
    delta = max(0, (h - p_z) n_z),  delta_dot = -v.n if delta > 0 else 0,
    fn = max(0, K (delta + eps)^p delta + D (delta + eps)^q delta_dot),
    v_t = v - (v.n) n,  m_n = (m.n) n,  m_t = m - m_n,
    f_t = -(K (delta + eps)^p m_t + D (delta + eps)^q v_t)             (sticking trial force),
    sticking when delta <= 0 or |f_t| <= mu fn; otherwise f_t = min(mu fn, |f_t|) f_t / |f_t|;
    f_t = 0 when delta <= 0,
    m_dot = -(K/D) m (no contact), v_t - (K/D) m_n (sticking), -(f_t + K (delta + eps)^p m_t) / (D (delta + eps)^q) (slipping).
The force f = fn n + f_t acts at p; its wrench on the point's link, Inertial, is [f; p x f].
A NaN terrain height or normal (a heightfield or height array written in place, which no host check sees)
gives a NaN force, so that the step flags the environment: wp.max(0, NaN) is 0, which would read it as no
contact.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import spatial

EPSILON = 2.220446049250313e-16
FLAT, PLANE, HEIGHTFIELD = 0, 1, 2


@factory
def kernels(scalar, terrain_kind: int | None = None):
    """The functions and kernels in `scalar`, for any terrain (terrain_kind None: its kind is read from the
    bundle at run time) or for one kind (FLAT, PLANE, HEIGHTFIELD): a constant, so that the compiler drops the
    other kinds' code; on a flat terrain the normal's components are then not multiplied either (the numbers
    are the same but for the sign of zeros, and a NaN in one component of a point's velocity or deformation
    stays in that component; a NaN height still gives a NaN force)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    vec4 = B.vec4
    FLAT_ONLY = terrain_kind == FLAT

    if terrain_kind is None:

        @wp.func
        def kind_of(terrain: B.Terrain):
            """The terrain's kind: read from the bundle."""
            return terrain.kind

    else:

        @wp.func
        def kind_of(terrain: B.Terrain):
            """The terrain's kind: the functions' (a constant)."""
            return wp.static(terrain_kind)

    @wp.func
    def normal_part(u: sp.vec3, n: sp.vec3):
        """u.n (u's z on a flat terrain)."""
        if wp.static(FLAT_ONLY):
            return u[2]
        return wp.dot(u, n)

    @wp.func
    def along_normal(n: sp.vec3, a: scalar):
        """a n (on a flat terrain (0, 0, a))."""
        if wp.static(FLAT_ONLY):
            return sp.vec3(scalar(0.0), scalar(0.0), a)
        return a * n

    @wp.func
    def tangential_part(u: sp.vec3, n: sp.vec3):
        """u - (u.n) n (on a flat terrain (u_x, u_y, 0))."""
        if wp.static(FLAT_ONLY):
            return sp.vec3(u[0], u[1], scalar(0.0))
        return u - wp.dot(u, n) * n

    @wp.func
    def heightfield_cell(hf: wp.array2d(dtype=scalar), grid: vec4, x: scalar, y: scalar):
        """The heightfield cell under (x, y), clamped to the grid's edges: its lower corner (i, j) and the
        fractions (a, b) of (x, y) across it, in [0, 1]."""
        u = wp.clamp((x - grid[0]) / grid[2], scalar(0.0), scalar(float(hf.shape[0] - 1)))
        v = wp.clamp((y - grid[1]) / grid[3], scalar(0.0), scalar(float(hf.shape[1] - 1)))
        i = wp.min(int(u), hf.shape[0] - 2)
        j = wp.min(int(v), hf.shape[1] - 2)
        return i, j, u - scalar(float(i)), v - scalar(float(j))

    @wp.func
    def height_parameter(terrain: B.Terrain, env: int):
        """The terrain's height [m] in environment env: a flat terrain's, a plane's at (0, 0) (unused by a heightfield)."""
        return terrain.height[wp.min(env, terrain.height.shape[0] - 1)]

    @wp.func
    def terrain_height(terrain: B.Terrain, h0: scalar, x: scalar, y: scalar):
        """h(x, y), h0 the environment's `height_parameter`. Flat: h0. Plane: through (0, 0, h0) with the unit
        normal. Heightfield: the grid's heights, bilinear, clamped to its edges."""
        hf = terrain.heights
        n = terrain.normal
        if kind_of(terrain) == HEIGHTFIELD:
            i, j, a, b = heightfield_cell(hf, terrain.grid, x, y)
            one = scalar(1.0)
            return (
                (one - a) * (one - b) * hf[i, j]
                + a * (one - b) * hf[i + 1, j]
                + (one - a) * b * hf[i, j + 1]
                + a * b * hf[i + 1, j + 1]
            )
        if kind_of(terrain) == PLANE:
            return h0 - (n[0] * x + n[1] * y) / n[2]
        return h0

    @wp.func
    def terrain_normal(terrain: B.Terrain, x: scalar, y: scalar):
        """The unit normal at (x, y): constant for flat and plane terrains, from the bilinear gradient otherwise."""
        hf = terrain.heights
        grid = terrain.grid
        if kind_of(terrain) == HEIGHTFIELD:
            i, j, a, b = heightfield_cell(hf, grid, x, y)
            one = scalar(1.0)
            dhdx = ((one - b) * (hf[i + 1, j] - hf[i, j]) + b * (hf[i + 1, j + 1] - hf[i, j + 1])) / grid[2]
            dhdy = ((one - a) * (hf[i, j + 1] - hf[i, j]) + a * (hf[i + 1, j + 1] - hf[i + 1, j])) / grid[3]
            return wp.normalize(sp.vec3(-dhdx, -dhdy, one))
        if kind_of(terrain) == PLANE:
            return terrain.normal
        return sp.vec3(scalar(0.0), scalar(0.0), scalar(1.0))

    @wp.func
    def power(x: scalar, e: scalar):
        """x^e for x > 0: a square root for e = 1/2 (JaxSim's exponents): correctly rounded, where pow(x, 1/2)
        may be off by its own error of a few ulps, and cheaper."""
        if e == scalar(0.5):
            return wp.sqrt(x)
        return wp.pow(x, e)

    @wp.func
    def damper_coefficient(depth: scalar, D: scalar, qe: scalar):
        """D (delta + eps)^q [N s/m] at a penetration `depth` [m] (0 out of contact): the law's damping of the normal
        and, below the Coulomb limit, the tangential velocity (`hunt_crossley_at_depth`), isotropic."""
        if depth > scalar(0.0):
            return D * power(depth + scalar(EPSILON), qe)
        return scalar(0.0)

    @wp.func
    def trial_tangential_force(delta_p: scalar, delta_q: scalar, v_t: sp.vec3, m_t: sp.vec3, K: scalar, D: scalar):
        """The tangential force [N] of the spring-damper, -(K (delta + eps)^p m_t + D (delta + eps)^q v_t), given
        (delta + eps)^p and ^q: the contact sticks while its length is within Coulomb's limit mu fn."""
        return -(K * delta_p * m_t + D * delta_q * v_t)

    @wp.func
    def coulomb_normal_force(fn: scalar, spring: scalar):
        """The normal force [N] that bounds a linearly implicit step's friction: min(fn, the spring's part K delta^(1+p)).
        Backward Euler applies the force at the step's end, and a contact the step arrests ends with its damper's part
        spent: at an impact (delta_dot > 0) fn's damper part, D delta^q delta_dot, may be many times the spring's, and
        friction bounded by it over the whole step would kick the body sideways (a 0.1 kg cube's corner hitting at
        0.77 m/s at 2 ms: 4 m/s). A separating contact's fn is below the spring's part and bounds it itself."""
        return wp.min(fn, spring)

    @wp.func
    def hunt_crossley_at_depth(depth: scalar, v: sp.vec3, m: sp.vec3, n: sp.vec3, K: scalar, D: scalar, mu: scalar, pe: scalar, qe: scalar, implicit: int):
        """(f (3,), m_dot (3,)): the law at a penetration `depth` [m] along the unit normal n (the force pushes
        along +n), v the velocity [m/s] of the pushed surface relative to the other. implicit != 0 (a step's
        linearly implicit contacts): the Coulomb limit is mu times `coulomb_normal_force`, not the normal force."""
        zero = scalar(0.0)
        eps = scalar(EPSILON)
        delta = wp.max(zero, depth)
        delta_dot = zero
        # (delta + eps)^p and ^q only in contact: out of it every term they scale is 0 or replaced below
        delta_p = zero
        delta_q = zero
        if delta > zero:
            delta_dot = -normal_part(v, n)
            delta_p = power(delta + eps, pe)
            delta_q = delta_p
            if qe != pe:
                delta_q = power(delta + eps, qe)
        fn = wp.max(zero, K * delta_p * delta + D * delta_q * delta_dot)
        # out of contact no tangential force (nor its terms: a zero f_t's length is a square root's slow path)
        f_t = sp.vec3(zero)
        m_dot = -(K / D) * m
        if delta > zero:
            v_t = tangential_part(v, n)
            m_n = along_normal(n, normal_part(m, n))
            m_t = tangential_part(m, n)
            f_t = trial_tangential_force(delta_p, delta_q, v_t, m_t, K, D)
            norm = wp.length(f_t)
            limit = mu * fn
            if implicit != 0:
                limit = mu * coulomb_normal_force(fn, K * delta_p * delta)
            m_dot = v_t - (K / D) * m_n
            if norm > limit:
                direction = sp.vec3(zero)
                if norm > eps:
                    direction = f_t / norm
                f_t = wp.min(limit, norm) * direction
                m_dot = -(f_t + K * delta_p * m_t) / (D * delta_q)
        if depth != depth:  # noqa: PLR0124 (NaN test) a NaN height (written in place): a NaN force, which the step flags
            f_t = sp.vec3(depth)
        return along_normal(n, fn) + f_t, m_dot

    @wp.func
    def terrain_depth(p: sp.vec3, h: scalar, n: sp.vec3):
        """The penetration depth [m] of a point at p into a terrain of height h and unit normal n there, along n (the
        height's excess over p's, times n_z): negative above the terrain."""
        return (h - p[2]) * n[2]

    @wp.func
    def hunt_crossley(
        p: sp.vec3, v: sp.vec3, m: sp.vec3, h: scalar, n: sp.vec3, K: scalar, D: scalar, mu: scalar, pe: scalar, qe: scalar, implicit: int
    ):
        """(f (3,), m_dot (3,)): the contact force [N, world axes] and the deformation rate [m/s] of a point at p
        on a terrain of height h and normal n there."""
        return hunt_crossley_at_depth(terrain_depth(p, h, n), v, m, n, K, D, mu, pe, qe, implicit)

    @wp.func
    def law_parameters(contacts: B.Contacts, env: int):
        """The law's parameters in environment env, (K, D, mu) (each shared (1,) or per environment (N,))."""
        return sp.vec3(B.env_parameter(contacts.K, env), B.env_parameter(contacts.D, env), B.env_parameter(contacts.mu, env))

    @wp.func
    def contact_at(contacts: B.Contacts, terrain: B.Terrain, h0: scalar, law: sp.vec3, p: sp.vec3, v: sp.vec3, m: sp.vec3):
        """(f, m_dot): the contact force [N, world axes] of a point at p [m, world] with the velocity v [m/s] and
        the deformation m, and its m_dot; h0 the environment's `height_parameter`, law its `law_parameters`."""
        h = terrain_height(terrain, h0, p[0], p[1])
        n = terrain_normal(terrain, p[0], p[1])
        return hunt_crossley(p, v, m, h, n, law[0], law[1], law[2], contacts.p, contacts.q, contacts.implicit)

    @wp.func
    def point_wrench(
        contacts: B.Contacts, terrain: B.Terrain, h0: scalar, law: sp.vec3, L_p_C: sp.vec3, W_H_L: sp.transform, W_v_WL: sp.vec6, m: sp.vec3
    ):
        """(the Inertial wrench [f; p x f] of a point's contact force, its m_dot) for a point at L_p_C on its link,
        at the pose W_H_L with the Inertial velocity W_v_WL, with the deformation m; h0 the environment's
        `height_parameter`, law its `law_parameters`."""
        p = wp.transform_point(W_H_L, L_p_C)
        f, m_dot = contact_at(contacts, terrain, h0, law, p, sp.lin(W_v_WL) + wp.cross(sp.ang(W_v_WL), p), m)
        return sp.stack(f, wp.cross(p, f)), m_dot

    @wp.kernel(module="unique")
    def point_contact_forces(
        contacts: B.Contacts,
        terrain: B.Terrain,
        # the links' poses and Inertial velocities (N, nL), the contact state (N, rows, 3): its first nc_all rows the points
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        m: wp.array3d(dtype=scalar),
        env_fastest: int,
        rows_per_thread: int,
        # outputs
        W_f_C: wp.array3d(dtype=scalar),
        m_dot: wp.array3d(dtype=scalar),
    ):
        """Launched over N nc_all / rows_per_thread threads (order: bundles.env_and_item), each for
        rows_per_thread consecutive rows of the points' contact state (the geom pairs' slots after them are
        kernels/collisions.py's): 1 (a thread per point, the points of an
        environment are independent) or nc_all (a thread per environment: under a tape, each adjoint of a
        link's pose, velocity and per-environment parameter then comes from one thread, in a fixed order).
        W_f_C (N, P, 6) the Inertial wrench of each enabled point's contact force, in the enabled points' order
        (by link); m_dot's first nc_all rows (N, rows, 3): every point's, 0 for disabled ones. K, D, mu and the terrain's height:
        (1,) or (N,) (shared or per environment)."""
        env, chunk = B.env_and_item(wp.tid(), m.shape[0], contacts.row_point.shape[0] // rows_per_thread, env_fastest)
        for row in range(chunk * rows_per_thread, (chunk + 1) * rows_per_thread):
            c = contacts.row_point[row]
            if c < 0:
                for a in range(3):
                    m_dot[env, row, a] = scalar(0.0)
            else:
                L = contacts.point_link[c]
                m_c = sp.vec3(m[env, row, 0], m[env, row, 1], m[env, row, 2])
                law = law_parameters(contacts, env)
                w, md = point_wrench(contacts, terrain, height_parameter(terrain, env), law, B.vec3_parameter(contacts.L_p_C, env, c), W_H_L[env, L], W_v_WL[env, L], m_c)
                for a in range(6):
                    W_f_C[env, c, a] = w[a]
                for a in range(3):
                    m_dot[env, row, a] = md[a]

    @wp.func
    def link_contact_wrench(contacts: B.Contacts, W_f_C: wp.array3d(dtype=scalar), env: int, L: int):
        """The sum of link L's enabled points' Inertial wrenches: the rows link_first_point[L] ..
        + link_point_count[L] of W_f_C (N, P, 6) (a link's points are consecutive); zero without points."""
        total = sp.vec6(scalar(0.0))
        first = contacts.link_first_point[L]
        for k in range(contacts.link_point_count[L]):
            c = first + k
            total = total + sp.vec6(W_f_C[env, c, 0], W_f_C[env, c, 1], W_f_C[env, c, 2], W_f_C[env, c, 3], W_f_C[env, c, 4], W_f_C[env, c, 5])
        return total

    @wp.kernel(module="unique")
    def link_contact_forces(
        contacts: B.Contacts,
        W_f_C: wp.array3d(dtype=scalar),
        W_f_ext: wp.array3d(dtype=scalar),
        env_fastest: int,
        links_per_thread: int,
        # outputs
        W_f_L: wp.array3d(dtype=scalar),
    ):
        """W_f_L (N, nL, 6) = W_f_ext + the contact wrenches of each link's points (Inertial), launched over
        N nL / links_per_thread threads (order: bundles.env_and_item), each for links_per_thread consecutive
        links: 1 or nL (a thread per environment, as point_contact_forces under a tape)."""
        env, chunk = B.env_and_item(wp.tid(), W_f_L.shape[0], W_f_L.shape[1] // links_per_thread, env_fastest)
        for L in range(chunk * links_per_thread, (chunk + 1) * links_per_thread):
            total = link_contact_wrench(contacts, W_f_C, env, L)
            for a in range(6):
                W_f_L[env, L, a] = W_f_ext[env, L, a] + total[a]

    return types.SimpleNamespace(
        vec4=vec4,
        height_parameter=height_parameter,
        terrain_height=terrain_height,
        terrain_normal=terrain_normal,
        hunt_crossley=hunt_crossley,
        hunt_crossley_at_depth=hunt_crossley_at_depth,
        coulomb_normal_force=coulomb_normal_force,
        terrain_depth=terrain_depth,
        damper_coefficient=damper_coefficient,
        power=power,
        tangential_part=tangential_part,
        trial_tangential_force=trial_tangential_force,
        law_parameters=law_parameters,
        contact_at=contact_at,
        point_wrench=point_wrench,
        point_contact_forces=point_contact_forces,
        link_contact_wrench=link_contact_wrench,
        link_contact_forces=link_contact_forces,
    )


@factory
def points_kernel(scalar):
    """`hunt_crossley_points`: the law at independent points (warpdyn.types.contact_models' host functions)."""
    law = kernels(scalar)
    vec3 = wp.types.vector(3, scalar)

    @wp.kernel(module="unique")
    def hunt_crossley_points(
        p: wp.array(dtype=vec3),
        v: wp.array(dtype=vec3),
        m: wp.array(dtype=vec3),
        h: wp.array(dtype=scalar),
        n: wp.array(dtype=vec3),
        K: wp.array(dtype=scalar),
        D: wp.array(dtype=scalar),
        mu: wp.array(dtype=scalar),
        pe: scalar,
        qe: scalar,
        # outputs
        f: wp.array(dtype=vec3),
        m_dot: wp.array(dtype=vec3),
    ):
        """The law (`hunt_crossley`) at each point, with its own K, D and mu: one thread per point."""
        i = wp.tid()
        fi, mi = law.hunt_crossley(p[i], v[i], m[i], h[i], n[i], K[i], D[i], mu[i], pe, qe, 0)
        f[i] = fi
        m_dot[i] = mi

    return hunt_crossley_points

