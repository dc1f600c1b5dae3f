"""The geom pairs' contact slots as points of JaxSim's solved contact laws (kernels/rigid_contacts.py's rigid QP and
impact, kernels/relaxed_rigid.py's solve), one thread per environment.

A geom pair's contact slot (kernels/collisions.py's `geom_contacts`: position, frame (n, t1, t2 rows: MuJoCo's) and
dist) that penetrates (dist < 0) is a point after the collidable points (row points + slot of the solve's arrays):
its rows are the velocity of geom2's material point at the contact relative to geom1's in the contact's axes (t1, t2,
n), from the links' Inertial Jacobians and J̇ν (`slot_point`), so that a force on the rows acts on geom2's body and
its opposite on geom1's (`slot_wrenches`). `rigid_slot_rows` gives a slot the rigid QP's terms (Baumgarte's term on its
normal, the pair's mu for its pyramid); kernels/relaxed_rigid.py's `relaxed_slot_rows` the relaxed-rigid law's.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The contact slots' kernels in `scalar`."""
    sp, B = spatial(scalar), bundles(scalar)

    @wp.func
    def point_motion(W_v_WL: wp.array2d(dtype=sp.vec6), W_a_L: wp.array2d(dtype=sp.vec6), L: int, x: sp.vec3, env: int):
        """(velocity, bias acceleration) [m/s, m/s^2, world] of link L's material point at x [m, world] (0 for the world,
        L = -1): v = v_W + w x x and the classical acceleration's part without the joint accelerations, (J̇ν)_lin +
        (J̇ν)_ang x x + w x v (W_a_L: the links' J̇ν, Inertial)."""
        v = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
        bias = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
        if L >= 0:
            w = sp.ang(W_v_WL[env, L])
            v = sp.lin(W_v_WL[env, L]) + wp.cross(w, x)
            bias = sp.lin(W_a_L[env, L]) + wp.cross(sp.ang(W_a_L[env, L]), x) + wp.cross(w, v)
        return v, bias

    @wp.func
    def link_point_column(J_L: wp.array4d(dtype=scalar), L: int, x: sp.vec3, env: int, j: int):
        """Column j of the linear Jacobian [m/s per unit of nu_j, world] of link L's material point at x (0 for the
        world): J_lin - [x]x J_ang of the link's Inertial Jacobian J_L[env, L] (6, K)."""
        column = sp.vec3(scalar(0.0), scalar(0.0), scalar(0.0))
        if L >= 0:
            lin = sp.vec3(J_L[env, L, 0, j], J_L[env, L, 1, j], J_L[env, L, 2, j])
            ang = sp.vec3(J_L[env, L, 3, j], J_L[env, L, 4, j], J_L[env, L, 5, j])
            column = lin + wp.cross(ang, x)
        return column

    @wp.func
    def slot_point(
        J_L: wp.array4d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6), W_a_L: wp.array2d(dtype=sp.vec6), a: int, b: int,
        position: wp.array3d(dtype=scalar), frame: wp.array4d(dtype=scalar), env: int, slot: int, c: int, frictionless: int,
        J_t: wp.array4d(dtype=scalar), Jdotnu_t: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """Contact slot `slot` of a pair of links a (geom1's) and b (geom2's; -1: the world) as the rows of point c
        in J_t (N, P + C, 6, K) and Jdotnu_t (N, P + C, 6): the velocity of b's material point at the contact relative
        to a's, in the contact's axes (t1, t2, n: MuJoCo's frame rows 1, 2, 0; n from geom1 to geom2), so that a
        force on the rows acts on b and its opposite on a; rows 3 to 5 zero, and the tangential rows too where
        `frictionless` (condim 1). Returns that relative velocity [m/s, contact axes]."""
        x = sp.vec3(position[env, slot, 0], position[env, slot, 1], position[env, slot, 2])
        n = sp.vec3(frame[env, slot, 0, 0], frame[env, slot, 0, 1], frame[env, slot, 0, 2])
        t1 = sp.vec3(frame[env, slot, 1, 0], frame[env, slot, 1, 1], frame[env, slot, 1, 2])
        t2 = sp.vec3(frame[env, slot, 2, 0], frame[env, slot, 2, 1], frame[env, slot, 2, 2])
        keep = scalar(1.0)
        if frictionless != 0:
            keep = scalar(0.0)
        va, ba = point_motion(W_v_WL, W_a_L, a, x, env)
        vb, bb = point_motion(W_v_WL, W_a_L, b, x, env)
        v = vb - va
        bias = bb - ba
        for j in range(J_t.shape[3]):
            d = link_point_column(J_L, b, x, env, j) - link_point_column(J_L, a, x, env, j)
            J_t[env, c, 0, j] = keep * wp.dot(t1, d)
            J_t[env, c, 1, j] = keep * wp.dot(t2, d)
            J_t[env, c, 2, j] = wp.dot(n, d)
            for r in range(3, 6):
                J_t[env, c, r, j] = scalar(0.0)
        Jdotnu_t[env, c, 0] = keep * wp.dot(t1, bias)
        Jdotnu_t[env, c, 1] = keep * wp.dot(t2, bias)
        Jdotnu_t[env, c, 2] = wp.dot(n, bias)
        for r in range(3, 6):
            Jdotnu_t[env, c, r] = scalar(0.0)
        return sp.vec3(wp.dot(t1, v), wp.dot(t2, v), wp.dot(n, v))

    @wp.func
    def slot_penetration(
        first: wp.array(dtype=int), count: wp.array2d(dtype=int), dist: wp.array2d(dtype=scalar), mu: wp.array(dtype=scalar), env: int,
        i: int, slot: int,
    ):  # fmt: skip
        """(delta, frictionless) of contact slot `slot` of pair i: its penetration depth -dist [m] where the slot holds a
        contact (the pair's first count[env, i] slots) at dist < 0, else 0; 1 where the pair's mu is 0 (condim 1)."""
        delta = scalar(0.0)
        if slot - first[i] < count[env, i]:
            delta = wp.max(scalar(0.0), -dist[env, slot])
        frictionless = int(0)
        if mu[i] == scalar(0.0):
            frictionless = 1
        return delta, frictionless

    @wp.func
    def inverse_mass(model: B.Model, env: int, L: int):
        """1 / link L's mass [1/kg]; 0 for the world (L = -1) and a fixed base (link 0 of a fixed-base model)."""
        inverse = scalar(0.0)
        if L > 0 or (L == 0 and model.floating_base != 0):
            inverse = scalar(1.0) / B.mass_of(model, env, L)
        return inverse

    @wp.kernel(module="unique")
    def slot_wrenches(
        link1: wp.array(dtype=int), link2: wp.array(dtype=int), slot_pair: wp.array(dtype=int), position: wp.array3d(dtype=scalar),
        frame: wp.array4d(dtype=scalar), force: wp.array2d(dtype=sp.vec3), points: int,
        # in and out
        W_f_L: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """W_f_L (N, nL, 6) += the Inertial wrenches of the contact slots' forces, force[env, points + slot] (N, P + C)
        in the slot's axes (t1, t2, n: `slot_point`): [f; x x f] on geom2's link, its opposite on geom1's (the world,
        -1, gets none). A thread per environment (its sums in slot order: deterministic), differentiable."""
        env = wp.tid()
        for slot in range(slot_pair.shape[0]):
            f_c = force[env, points + slot]
            n = sp.vec3(frame[env, slot, 0, 0], frame[env, slot, 0, 1], frame[env, slot, 0, 2])
            t1 = sp.vec3(frame[env, slot, 1, 0], frame[env, slot, 1, 1], frame[env, slot, 1, 2])
            t2 = sp.vec3(frame[env, slot, 2, 0], frame[env, slot, 2, 1], frame[env, slot, 2, 2])
            f = f_c[0] * t1 + f_c[1] * t2 + f_c[2] * n
            x = sp.vec3(position[env, slot, 0], position[env, slot, 1], position[env, slot, 2])
            torque = wp.cross(x, f)
            a = link1[slot_pair[slot]]
            b = link2[slot_pair[slot]]
            for r in range(3):  # += is Warp's atomic add, whose adjoint is right
                if b >= 0:
                    W_f_L[env, b, r] += f[r]
                    W_f_L[env, b, 3 + r] += torque[r]
                if a >= 0:
                    W_f_L[env, a, r] -= f[r]
                    W_f_L[env, a, 3 + r] -= torque[r]

    @wp.kernel(module="unique")
    def rigid_slot_rows(
        contacts: B.Contacts, link1: wp.array(dtype=int), link2: wp.array(dtype=int), mu: wp.array(dtype=scalar),
        first: wp.array(dtype=int), slot_pair: wp.array(dtype=int), count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar),
        frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar), J_L: wp.array4d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6),
        W_a_L: wp.array2d(dtype=sp.vec6), points: int,
        # outputs: rows points + slot
        J_t: wp.array4d(dtype=scalar), Jdotnu_t: wp.array3d(dtype=scalar), depth: wp.array2d(dtype=scalar), beta: wp.array2d(dtype=sp.vec3),
        friction: wp.array2d(dtype=scalar),
    ):  # fmt: skip
        """The geom pairs' contact slots (C; kernels/collisions.py's `geom_contacts` at the same state) as the points
        points + slot of the rigid QP: a slot holding a contact at dist < 0 penetrates by delta = -dist at the rate
        delta_dot = -v_n (v: geom2's point's velocity relative to geom1's, `slot_point`'s rows in the contact's axes t1,
        t2, n); Baumgarte's term is (0, 0, K delta + D delta_dot) in those axes and its mu the pair's (0 for condim 1,
        whose tangential rows are zeros: its pyramid holds the tangential forces at 0). J_L (N, nL, 6, K): the links'
        Inertial Jacobians; W_v_WL, W_a_L (N, nL): their Inertial velocities and J̇ν. A thread per environment;
        differentiable (a tape records it)."""
        env = wp.tid()
        zero = scalar(0.0)
        K = B.env_parameter(contacts.K, env)
        D = B.env_parameter(contacts.D, env)
        for slot in range(slot_pair.shape[0]):
            i = slot_pair[slot]
            c = points + slot
            delta, frictionless = slot_penetration(first, count, dist, mu, env, i, slot)
            term = sp.vec3(zero, zero, zero)
            if delta > zero:
                v = slot_point(J_L, W_v_WL, W_a_L, link1[i], link2[i], position, frame, env, slot, c, frictionless, J_t, Jdotnu_t)
                term = sp.vec3(zero, zero, K * delta - D * v[2])
            depth[env, c] = delta
            beta[env, c] = term
            friction[env, c] = mu[i]

    return types.SimpleNamespace(
        point_motion=point_motion,
        link_point_column=link_point_column,
        slot_point=slot_point,
        slot_penetration=slot_penetration,
        inverse_mass=inverse_mass,
        slot_wrenches=slot_wrenches,
        rigid_slot_rows=rigid_slot_rows,
    )
