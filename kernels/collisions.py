"""Contacts between the geoms of a model's pairs (warpdyn.types.geoms): each pair's geoms placed by their links' world
poses, then MuJoCo's narrow phase for their types (kernels/collision_primitives.py, kernels/collision_box.py,
kernels/collision_convex.py), one thread per (environment, pair), each pair writing its fixed slots.

A slot holds a contact's position [m, world], MuJoCo's contact frame (rows: the normal from geom1 to geom2, two
tangents) and the distance between the surfaces [m] (negative: penetration), as MuJoCo's d.contact; a pair's slots
past its count hold position 0, frame 0 and distance +inf.
"""

import types

import warp as wp

from . import collision_box, collision_convex, collision_polygons, collision_primitives, implicit_contacts, soft_contacts
from .bundles import bundles
from .factory import factory
from .geom_types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE
from .spatial import spatial


@factory
def narrow_phase(scalar, convex: bool) -> types.SimpleNamespace:
    """The kernel `geom_contacts` in `scalar` (wp.float32 or wp.float64); convex: with the pairs of
    kernels/collision_convex.py (its GJK and EPA are compiled only into a model's kernel that has such pairs)."""
    prim = collision_primitives.kernels(scalar)
    box = collision_box.kernels(scalar)
    gjk = collision_convex.kernels(scalar)
    sp = spatial(scalar)
    B = bundles(scalar)
    vec2, vec3, mat23, mat33 = prim.vec2, prim.vec3, prim.mat23, prim.mat33

    @wp.func
    def put(env: int, slot: int, p: vec3, frame_: mat33, d: scalar,
            position: wp.array3d(dtype=scalar), frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar)):  # fmt: skip
        """Writes one slot."""
        for r in range(3):
            position[env, slot, r] = p[r]
            for c in range(3):
                frame[env, slot, r, c] = frame_[r, c]
        dist[env, slot] = d

    @wp.kernel(module="unique")
    def geom_contacts(
        link1: wp.array(dtype=int), link2: wp.array(dtype=int), type1: wp.array(dtype=int), type2: wp.array(dtype=int),
        link_H_geom1: wp.array(dtype=sp.transform), link_H_geom2: wp.array(dtype=sp.transform),
        size1: wp.array(dtype=vec3), size2: wp.array(dtype=vec3), margin: wp.array(dtype=scalar),
        first: wp.array(dtype=int), slots: wp.array(dtype=int),
        vertices: wp.array(dtype=vec3), vertices1: wp.array(dtype=wp.vec2i), vertices2: wp.array(dtype=wp.vec2i),
        polygons: gjk.Polygons, polygons1: wp.array(dtype=wp.vec2i), polygons2: wp.array(dtype=wp.vec2i),
        W_H_L: wp.array2d(dtype=sp.transform), env_fastest: int,
        # outputs
        count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar), frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N nP threads, one per environment and pair (order: bundles.env_and_item: with
        environment-fastest arrays a warp holds one pair in 32 environments, one branch of the narrow phase and
        neighbouring numbers): pair i's contacts in environment env (the module docstring), count (N, nP),
        position (N, C, 3), frame (N, C, 3, 3), dist (N, C); margin: the pair's margin + gap [m]; a link -1 is the
        world (its geom's pose given in it); vertices (V,) [m]: the meshes', each in its geom's frame, a pair's geoms'
        (first, count) in vertices1, vertices2 (nP,), their hulls' polygons' in polygons1, polygons2 (nP,); first, slots
        (nP,): the pair's first slot and its slots (a pair of kernels/collision_convex.py with more than one takes
        multiCCD's contacts: kernels/collision_polygons.py)."""
        env, i = B.env_and_item(wp.tid(), W_H_L.shape[0], link1.shape[0], env_fastest)
        X1 = link_H_geom1[i]
        if link1[i] >= 0:
            X1 = W_H_L[env, link1[i]] * X1
        X2 = link_H_geom2[i]
        if link2[i] >= 0:
            X2 = W_H_L[env, link2[i]] * X2
        p1 = wp.transform_get_translation(X1)
        p2 = wp.transform_get_translation(X2)
        R1 = wp.quat_to_matrix(wp.transform_get_rotation(X1))
        R2 = wp.quat_to_matrix(wp.transform_get_rotation(X2))
        t1, t2, s1, s2, e = type1[i], type2[i], size1[i], size2[i], margin[i]
        base = first[i]
        zero = vec3(scalar(0.0))
        n = int(0)
        if prim.may_touch(t1, p1, R1, s1, t2, p2, s2, e):
            if t1 == SPHERE and t2 != MESH and t2 != ELLIPSOID:
                m1 = int(0)
                p = vec3()
                normal = vec3()
                d = scalar(0.0)
                if t2 == SPHERE:
                    m1, p, normal, d = prim.sphere_sphere(p1, R1, s1[0], p2, R2, s2[0], e)
                elif t2 == CAPSULE:
                    m1, p, normal, d = prim.sphere_capsule(p1, R1, s1[0], p2, R2, s2, e)
                elif t2 == CYLINDER:
                    m1, p, normal, d = prim.sphere_cylinder(p1, R1, s1[0], p2, R2, s2, e)
                else:
                    m1, p, normal, d = prim.sphere_box(p1, R1, s1[0], p2, R2, s2, e)
                if m1 > 0:
                    put(env, base, p, prim.contact_frame(normal, zero), d, position, frame, dist)
                n = m1
            elif t1 == CAPSULE and t2 != CYLINDER and t2 != MESH and t2 != ELLIPSOID:
                m2 = int(0)
                P2 = mat23()
                N2 = mat23()
                D2 = vec2()
                if t2 == CAPSULE:
                    m2, P2, N2, D2 = prim.capsule_capsule(p1, R1, s1, p2, R2, s2, e)
                else:
                    m2, P2, N2, D2 = prim.capsule_box(p1, R1, s1, p2, R2, s2, e)
                for k in range(m2):
                    put(env, base + k, P2[k], prim.contact_frame(N2[k], zero), D2[k], position, frame, dist)
                n = m2
            elif t1 == BOX and t2 == BOX:
                m8, P8, N8, D8 = box.box_box(p1, R1, s1, p2, R2, s2, e)
                for k in range(m8):
                    put(env, base + k, P8[k], prim.contact_frame(N8[k], zero), D8[k], position, frame, dist)
                n = m8
            elif wp.static(convex):  # capsule-cylinder, cylinder-cylinder, cylinder-box, the ellipsoids' and the meshes' pairs
                m4, P4, N4, D4 = gjk.contacts(t1, p1, R1, s1, t2, p2, R2, s2, vertices, vertices1[i], vertices2[i], e, slots[i] > 1,
                                              polygons, polygons1[i], polygons2[i])  # fmt: skip
                for k in range(wp.static(collision_polygons.CONTACTS)):
                    if k < m4:
                        put(env, base + k, P4[k], prim.contact_frame(N4[k], zero), D4[k], position, frame, dist)
                n = m4
        count[env, i] = n
        for k in range(n, slots[i]):
            put(env, base + k, zero, mat33(scalar(0.0)), scalar(wp.inf), position, frame, dist)

    return types.SimpleNamespace(geom_contacts=geom_contacts)


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The kernels `geom_contact_rates`, `geom_contact_wrenches`, `damper_stability` and `links_touching` in `scalar`
    (wp.float32 or wp.float64)."""
    law = soft_contacts.kernels(scalar)
    implicit_terms = implicit_contacts.kernels(scalar)
    sp = spatial(scalar)
    B = bundles(scalar)
    vec3 = sp.vec3

    @wp.func
    def slot_contact(
        contacts: B.Contacts, a: int, b: int, mu: scalar, K: scalar, D: scalar, env: int, slot: int, row: int, position: wp.array3d(dtype=scalar),
        frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6), m: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """The soft law at the touching contact in `slot` of a pair of links a and b (-1: the world) with friction mu:
        (its position p [m, world], normal n (geom1 to geom2), velocity v of geom2's point relative to geom1's [m/s],
        depth -dist [m], deformation m_k (row `row` of m), force f on geom2's link [N, world], deformation rate)."""
        p = vec3(position[env, slot, 0], position[env, slot, 1], position[env, slot, 2])
        n = vec3(frame[env, slot, 0, 0], frame[env, slot, 0, 1], frame[env, slot, 0, 2])
        v = vec3(scalar(0.0))  # the world's is 0
        if b >= 0:
            v = v + sp.lin(W_v_WL[env, b]) + wp.cross(sp.ang(W_v_WL[env, b]), p)
        if a >= 0:
            v = v - sp.lin(W_v_WL[env, a]) - wp.cross(sp.ang(W_v_WL[env, a]), p)
        depth = -dist[env, slot]
        m_k = vec3(m[env, row, 0], m[env, row, 1], m[env, row, 2])
        f, md = law.hunt_crossley_at_depth(depth, v, m_k, n, K, D, mu, contacts.p, contacts.q, contacts.implicit)
        return p, n, v, depth, m_k, f, md

    @wp.kernel(module="unique")
    def geom_contact_rates(
        contacts: B.Contacts, link1: wp.array(dtype=int), link2: wp.array(dtype=int), mu: wp.array(dtype=scalar), first: wp.array(dtype=int),
        slot_pair: wp.array(dtype=int), count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar), frame: wp.array4d(dtype=scalar),
        dist: wp.array2d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6), m: wp.array3d(dtype=scalar), env_fastest: int, per_thread: int,
        # outputs
        m_dot: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N C / per_thread threads, each for per_thread consecutive contact slots of an environment
        (order: bundles.env_and_item; per_thread 1, or C: a thread per environment, as the points' kernels under a
        tape: warpdyn.engine.contact_stage's `contacts_per_environment`), after
        `geom_contacts` at the same state: the deformation rate of the contact in slot k (slot_pair: its pair), row
        nc_all + k of m_dot (N, rows, 3) [m/s, world axes] (its deformation that row of the contact state m): the
        law's (`slot_contact`) where the slot holds a touching contact, the relative tangential displacement while it
        sticks (static friction); a relaxation at K / D where it holds none. A slot keeps its deformation while its
        pair's contacts keep their order (a pair's slots are in its narrow phase's order)."""
        env, chunk = B.env_and_item(wp.tid(), m.shape[0], slot_pair.shape[0] // per_thread, env_fastest)
        K = B.env_parameter(contacts.K, env)
        D = B.env_parameter(contacts.D, env)
        for slot in range(chunk * per_thread, (chunk + 1) * per_thread):
            i = slot_pair[slot]
            row = contacts.row_point.shape[0] + slot  # the points' rows come first
            md = vec3(scalar(0.0))
            if slot - first[i] < count[env, i]:
                p, n, v, depth, m_k, f, md = slot_contact(contacts, link1[i], link2[i], mu[i], K, D, env, slot, row, position, frame, dist, W_v_WL, m)
            else:  # an empty slot (its dist +inf), out of contact: nothing else is read
                zero = vec3(scalar(0.0))
                m_k = vec3(m[env, row, 0], m[env, row, 1], m[env, row, 2])
                f, md = law.hunt_crossley_at_depth(scalar(-wp.inf), zero, m_k, zero, K, D, mu[i], contacts.p, contacts.q, contacts.implicit)
            for r in range(3):
                m_dot[env, row, r] = md[r]

    @wp.kernel(module="unique")
    def geom_contact_wrenches(
        contacts: B.Contacts, link1: wp.array(dtype=int), link2: wp.array(dtype=int), mu: wp.array(dtype=scalar), first: wp.array(dtype=int),
        link_pair_start: wp.array(dtype=int), link_pairs: wp.array(dtype=int), count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar),
        frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6), m: wp.array3d(dtype=scalar),
        W_H_L: wp.array2d(dtype=sp.transform), h: scalar, env_fastest: int, per_thread: int,
        # in and out
        W_f_L: wp.array3d(dtype=scalar),
        implicit: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N nL / per_thread threads, each for per_thread consecutive links of an environment (order:
        bundles.env_and_item; per_thread 1, or nL: a thread per environment, as `geom_contact_rates`), after `geom_contacts`
        at the same state: the soft-law force (`slot_contact`: JaxSim's Hunt/Crossley with its tangential deformation
        at the depth -dist along the contact's normal, with the velocity of geom2's point relative to geom1's, the
        pair's mu) of each touching contact of the link's pairs (link_pairs[link_pair_start[L]:link_pair_start[L + 1]],
        in pair order) added to its row of W_f_L (N, nL, 6), Inertial: [f; p x f] where the link holds geom2, its
        opposite where it holds geom1 (the world, link -1, gets none). Where implicit (N, nL, IMPLICIT) has rows
        (model.implicit_contacts), each contact's linearly implicit terms at the time step h [s] are added to the
        link's (kernels/implicit_contacts.py; W_H_L (N, nL) the links' poses). A thread writes its link's rows alone,
        in the pairs' order (the sums are deterministic); a contact's force is so computed by both its links'."""
        env, chunk = B.env_and_item(wp.tid(), W_f_L.shape[0], W_f_L.shape[1] // per_thread, env_fastest)
        K = B.env_parameter(contacts.K, env)
        D = B.env_parameter(contacts.D, env)
        row0 = contacts.row_point.shape[0]  # the points' rows come first
        for L in range(chunk * per_thread, (chunk + 1) * per_thread):
            for e in range(link_pair_start[L], link_pair_start[L + 1]):
                i = link_pairs[e]
                a, b = link1[i], link2[i]
                sign = scalar(1.0)
                if b != L:
                    sign = scalar(-1.0)
                for k in range(count[env, i]):
                    slot = first[i] + k
                    p, n, v, depth, m_k, f, md = slot_contact(contacts, a, b, mu[i], K, D, env, slot, row0 + slot, position, frame, dist, W_v_WL, m)
                    w = sign * f
                    torque = wp.cross(p, w)
                    for r in range(3):  # += is Warp's atomic add (one thread per link: in order), whose adjoint is right
                        W_f_L[env, L, r] += w[r]
                        W_f_L[env, L, 3 + r] += torque[r]
                    if implicit.shape[0] > 0:
                        alpha, beta, g = implicit_terms.contact_terms(f, depth, v, m_k, n, K, D, mu[i], contacts.p, contacts.q, h)
                        if alpha > scalar(0.0):
                            implicit_terms.add_terms(implicit, env, L, W_H_L[env, L], p, n, alpha, beta, sign * g)

    @wp.kernel(module="unique")
    def damper_stability(
        contacts: B.Contacts, model: B.Model, link1: wp.array(dtype=int), link2: wp.array(dtype=int), first: wp.array(dtype=int),
        count: wp.array2d(dtype=int), dist: wp.array2d(dtype=scalar), rate: scalar, guarded: wp.array(dtype=int), damping: wp.array2d(dtype=scalar),
        # in and out
        W_f_L: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N in a step, after `geom_contact_wrenches`: the explicit damper's stability of each lone free body
        (guarded[L] != 0: a free joint's or floating base's link without children). The law damps a contact point's
        velocity isotropically below the Coulomb limit with c = D delta^q, so the body's translation decays at sum c / m
        per step (damping (N, nL): the sums, scratch); where that exceeds `rate` (the integrator's limit / dt) the
        body's wrench is NaN, which the step flags. Rotations (contacts off the centre of mass damp them faster) and two
        free bodies' relative motion (by both masses) are not counted: the Coulomb limit and the normal force's floor at
        0 bound their oscillation as chatter (the pinch's cube at 0.25 ms: stable, though a rotation's linear rate
        exceeds the limit), and a diverging one deepens its contacts until the translation's rate flags it."""
        env = wp.tid()
        D = B.env_parameter(contacts.D, env)
        for L in range(guarded.shape[0]):
            damping[env, L] = scalar(0.0)
        for i in range(link1.shape[0]):
            a, b = link1[i], link2[i]
            for k in range(count[env, i]):
                c = law.damper_coefficient(-dist[env, first[i] + k], D, contacts.q)
                if a >= 0:
                    damping[env, a] = damping[env, a] + c
                if b >= 0:
                    damping[env, b] = damping[env, b] + c
        for L in range(guarded.shape[0]):
            if guarded[L] != 0 and damping[env, L] > rate * B.mass_of(model, env, L):
                W_f_L[env, L, 0] = scalar(wp.nan)

    @wp.kernel(module="unique")
    def links_touching(
        link1: wp.array(dtype=int), link2: wp.array(dtype=int), first: wp.array(dtype=int),
        count: wp.array2d(dtype=int), dist: wp.array2d(dtype=scalar), asked: wp.array(dtype=int),
        # in and out
        touching: wp.array2d(dtype=wp.bool),
    ):  # fmt: skip
        """Launched over N, after `geom_contacts`: touching[env, k] = True where asked[k] (K,) is a link of a pair with a
        contact at dist <= 0 (surfaces touching or penetrating; the world, link -1, is never asked)."""
        env = wp.tid()
        for i in range(link1.shape[0]):
            touches = int(0)
            for k in range(count[env, i]):
                if dist[env, first[i] + k] <= scalar(0.0):
                    touches = 1
            if touches != 0:
                for k in range(asked.shape[0]):
                    if asked[k] == link1[i] or asked[k] == link2[i]:
                        touching[env, k] = True

    return types.SimpleNamespace(
        geom_contact_rates=geom_contact_rates, geom_contact_wrenches=geom_contact_wrenches, damper_stability=damper_stability, links_touching=links_touching
    )
