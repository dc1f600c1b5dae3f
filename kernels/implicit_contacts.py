"""The soft law's contacts made linearly implicit in a semi-implicit Euler step (model.implicit_contacts).

A contact's force f(x, v) (kernels/soft_contacts.py's `hunt_crossley_at_depth`) evaluated at the step's start
turns a light body that stiff contacts press faster than the explicit step's stable rate (h c / m or h^2 k / m
beyond about 2; the damper on a 0.1 kg cube's edge: 9 at 1 ms). Linearised about the start instead, a link's
contact force at the step's end is f - h K v_rel - (h C + h^2 K) a_L: C = -df/dv and K = -df/dx at the contact
(3 x 3, world axes), v_rel the contact's relative velocity, a_L the link's own acceleration (the other body's is
held: each link sees its own block, as MuJoCo's implicitfast keeps its own). ABA then solves with, on each link L,

    IA_L += A_L = sum_c J_c^T (h C_c + h^2 K_c) J_c,      pA_L -= g_L = sum_c J_c^T (-h K_c v_rel,c)

in link coordinates (J_c = [1, -r_c^], r_c the contact point from the link's origin): the backward-Euler
linearisation of the contact forces (Baraff and Witkin), exact for a link touching the static world. Per contact,
with delta the penetration depth and the law's K, D, p, q (JaxSim's), where it pushes (f . n > 0):
    normal: c = D (delta + eps)^q, k_n = (1 + p) K (delta + eps)^p (d fn / d delta at a fixed rate);
    tangential, while the contact sticks (|f_t| < mu fn*): c and k_t = K (delta + eps)^p (the deformation's spring,
    which the deformation state integrates at the contact's velocity); sliding: Coulomb's force mu fn* taken as the
    damper mu fn* / |v_t| that gives it at the slip's velocity (so that one step's friction can stop the slip, never
    reverse it: explicit, a light body's sliding corner chattered and grew at 2 ms), at most the sticking one's c + h k_t;
fn* = min(fn, K delta^(1+p)) (kernels/soft_contacts.py's `coulomb_normal_force`, the law's limit in such a step: the
normal force that backward Euler applies to a contact it arrests, without the impact's damper spike). The predicted
normal force h k_n v_n is held to what keeps the force pushing (it never pulls). The terms of a link are a record of
IMPLICIT numbers: A_L's upper triangle (21), then g_L (6).
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .scratch import SYM66, scratch
from .soft_contacts import EPSILON
from .soft_contacts import kernels as soft_contact_kernels
from .spatial import spatial

IMPLICIT = SYM66 + 6
"""The numbers of a link's implicit contact terms: A_L's upper triangle, then g_L (link coordinates)."""


@factory
def kernels(scalar, terrain_kind: int | None = None) -> types.SimpleNamespace:
    """The implicit terms in `scalar`, for any terrain or one kind (kernels/soft_contacts.py's `kernels`)."""
    sp = spatial(scalar)
    sc = scratch(scalar)
    B = bundles(scalar)
    law = soft_contact_kernels(scalar, terrain_kind)

    @wp.func
    def contact_terms(
        f: sp.vec3, depth: scalar, v: sp.vec3, m: sp.vec3, n: sp.vec3, K: scalar, D: scalar, mu: scalar, pe: scalar, qe: scalar, h: scalar
    ):
        """(alpha, beta, g): a contact's h C + h^2 K = alpha n n^T + beta (1 - n n^T) and its predicted force
        g = -h K v [N, world axes], from its force f [N] (`hunt_crossley_at_depth` at the same depth, velocity v of
        the pushed surface relative to the other, deformation m, normal n); zeros where it does not push."""
        zero = scalar(0.0)
        fn = wp.dot(f, n)
        if depth <= zero or fn <= zero:
            return zero, zero, sp.vec3(zero)
        delta_p = law.power(depth + scalar(EPSILON), pe)
        c = law.damper_coefficient(depth, D, qe)
        k_t = K * delta_p
        k_n = (scalar(1.0) + pe) * k_t
        v_n = wp.dot(v, n)
        g = -wp.min(h * k_n * v_n, fn) * n  # the predicted normal force never pulls
        alpha = h * c + h * h * k_n
        beta = zero
        v_t = law.tangential_part(v, n)
        trial = law.trial_tangential_force(delta_p, law.power(depth + scalar(EPSILON), qe), v_t, law.tangential_part(m, n), K, D)
        limit = mu * law.coulomb_normal_force(fn, k_t * depth)
        if wp.length(trial) <= limit:  # sticking (the law's test): the tangential spring and damper act
            beta = h * c + h * h * k_t
            g = g - h * k_t * v_t
        elif limit > zero:  # sliding: Coulomb's force as the damper mu fn / |v_t| that gives it, which can stop the slip but not reverse it; at most the sticking contact's
            speed = wp.length(v_t)
            beta = h * (c + h * k_t)
            if speed * (c + h * k_t) > limit:
                beta = h * limit / speed
        return alpha, beta, g

    @wp.func
    def add_terms(implicit: wp.array3d(dtype=scalar), env: int, L: int, W_H_L: sp.transform, p: sp.vec3, n: sp.vec3, alpha: scalar, beta: scalar, g: sp.vec3):
        """Add to link L's record in implicit (N, nL, IMPLICIT) the terms of a contact at p [m, world] with normal n
        (`contact_terms`' alpha, beta, g: g the force on link L), in link coordinates (W_H_L its pose)."""
        q = wp.transform_get_rotation(W_H_L)
        r = wp.quat_rotate_inv(q, p - wp.transform_get_translation(W_H_L))
        nl = wp.quat_rotate_inv(q, n)
        gl = wp.quat_rotate_inv(q, g)
        M = beta * wp.identity(n=3, dtype=scalar) + (alpha - beta) * wp.outer(nl, nl)
        rx = wp.skew(r)
        Mr = M * rx
        H = -Mr
        Lr = -(rx * Mr)
        A = sp.mat66(
            M[0, 0], M[0, 1], M[0, 2], H[0, 0], H[0, 1], H[0, 2],
            M[1, 0], M[1, 1], M[1, 2], H[1, 0], H[1, 1], H[1, 2],
            M[2, 0], M[2, 1], M[2, 2], H[2, 0], H[2, 1], H[2, 2],
            H[0, 0], H[1, 0], H[2, 0], Lr[0, 0], Lr[0, 1], Lr[0, 2],
            H[0, 1], H[1, 1], H[2, 1], Lr[1, 0], Lr[1, 1], Lr[1, 2],
            H[0, 2], H[1, 2], H[2, 2], Lr[2, 0], Lr[2, 1], Lr[2, 2],
        )  # fmt: skip
        sc.put_sym66(implicit, env, L, 0, sc.get_sym66(implicit, env, L, 0) + A)
        sc.put6(implicit, env, L, SYM66, sc.get6(implicit, env, L, SYM66) + sp.stack(gl, wp.cross(r, gl)))

    @wp.func
    def link_terms(
        contacts: B.Contacts, terrain: B.Terrain, W_H_L: wp.array2d(dtype=sp.transform), W_v_WL: wp.array2d(dtype=sp.vec6), m: wp.array3d(dtype=scalar),
        h: scalar, params: sp.vec3, h0: scalar, env: int, L: int, implicit: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """implicit[env, L] = link L's terms of its enabled points' contacts with the terrain, in the points' order
        (`point_implicit_terms`; params the law's (K, D, mu), h0 the terrain's height parameter)."""
        for a in range(IMPLICIT):
            implicit[env, L, a] = scalar(0.0)
        X = W_H_L[env, L]
        first = contacts.link_first_point[L]
        for k in range(contacts.link_point_count[L]):
            c = first + k
            row = contacts.point_row[c]
            p = wp.transform_point(X, B.vec3_parameter(contacts.L_p_C, env, c))
            v = sp.lin(W_v_WL[env, L]) + wp.cross(sp.ang(W_v_WL[env, L]), p)
            n = law.terrain_normal(terrain, p[0], p[1])
            depth = law.terrain_depth(p, law.terrain_height(terrain, h0, p[0], p[1]), n)
            m_c = sp.vec3(m[env, row, 0], m[env, row, 1], m[env, row, 2])
            f, _ = law.contact_at(contacts, terrain, h0, params, p, v, m_c)
            alpha, beta, g = contact_terms(f, depth, v, m_c, n, params[0], params[1], params[2], contacts.p, contacts.q, h)
            if alpha > scalar(0.0):
                add_terms(implicit, env, L, X, p, n, alpha, beta, g)

    @wp.kernel(module="unique")
    def point_implicit_terms(
        contacts: B.Contacts, terrain: B.Terrain, W_H_L: wp.array2d(dtype=sp.transform), W_v_WL: wp.array2d(dtype=sp.vec6), m: wp.array3d(dtype=scalar),
        h: scalar, env_fastest: int, per_thread: int,
        # outputs
        implicit: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N nL / per_thread threads, each for per_thread consecutive links of an environment (order:
        bundles.env_and_item; per_thread 1, or nL: a thread per environment, as the points' kernels under a tape), at the state of the
        step's contact forces: implicit (N, nL, IMPLICIT) = the link's terms of its enabled points' contacts with the
        terrain (zero for a link without contacts), at the time step h [s]; the geom pairs' contacts add theirs after
        (kernels/collisions.py's `geom_contact_wrenches`). A thread sums its link's points in order (deterministic)."""
        env, chunk = B.env_and_item(wp.tid(), implicit.shape[0], implicit.shape[1] // per_thread, env_fastest)
        params = law.law_parameters(contacts, env)
        h0 = law.height_parameter(terrain, env)
        for L in range(chunk * per_thread, (chunk + 1) * per_thread):
            link_terms(contacts, terrain, W_H_L, W_v_WL, m, h, params, h0, env, L, implicit)

    return types.SimpleNamespace(contact_terms=contact_terms, add_terms=add_terms, point_implicit_terms=point_implicit_terms)
