"""Contacts between the geoms of a model's pairs (warpdyn.types.geoms): each pair's geoms placed by their links' world
poses, then MuJoCo's narrow phase for their types (kernels/collision_primitives.py, kernels/collision_box.py), one
thread per (environment, pair), each pair writing its fixed slots.

A slot holds a contact's position [m, world], MuJoCo's contact frame (rows: the normal from geom1 to geom2, two
tangents) and the distance between the surfaces [m] (negative: penetration), as MuJoCo's d.contact; a pair's slots
past its count hold position 0, frame 0 and distance +inf.
"""

import types

import warp as wp

from . import collision_box, collision_primitives, implicit_contacts, soft_contacts
from .bundles import bundles
from .collision_primitives import BOX, CAPSULE, CYLINDER, SPHERE
from .factory import factory
from .spatial import spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The kernels `geom_contacts` and `geom_contact_wrenches` in `scalar` (wp.float32 or wp.float64)."""
    prim = collision_primitives.kernels(scalar)
    box = collision_box.kernels(scalar)
    law = soft_contacts.kernels(scalar)
    implicit_terms = implicit_contacts.kernels(scalar)
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
        W_H_L: wp.array2d(dtype=sp.transform), env_fastest: int,
        # outputs
        count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar), frame: wp.array4d(dtype=scalar), dist: wp.array2d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N nP threads, one per environment and pair (order: bundles.env_and_item: with
        environment-fastest arrays a warp holds one pair in 32 environments, one branch of the narrow phase and
        neighbouring numbers): pair i's contacts in environment env (the module docstring), count (N, nP),
        position (N, C, 3), frame (N, C, 3, 3), dist (N, C); margin: the pair's margin + gap [m]; a link -1 is the
        world (its geom's pose given in it)."""
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
            if t1 == SPHERE:
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
            elif t1 == CAPSULE:
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
        count[env, i] = n
        for k in range(n, slots[i]):
            put(env, base + k, zero, mat33(scalar(0.0)), scalar(wp.inf), position, frame, dist)

    @wp.kernel(module="unique")
    def geom_contact_wrenches(
        contacts: B.Contacts, link1: wp.array(dtype=int), link2: wp.array(dtype=int), mu: wp.array(dtype=scalar), first: wp.array(dtype=int),
        slots: wp.array(dtype=int), count: wp.array2d(dtype=int), position: wp.array3d(dtype=scalar), frame: wp.array4d(dtype=scalar),
        dist: wp.array2d(dtype=scalar), W_v_WL: wp.array2d(dtype=sp.vec6), m: wp.array3d(dtype=scalar),
        W_H_L: wp.array2d(dtype=sp.transform), h: scalar,
        # outputs
        m_dot: wp.array3d(dtype=scalar),
        # in and out
        W_f_L: wp.array3d(dtype=scalar),
        implicit: wp.array3d(dtype=scalar),
    ):  # fmt: skip
        """Launched over N, after `geom_contacts` at the same state: each contact's soft-law force (JaxSim's
        Hunt/Crossley with its tangential deformation, kernels/soft_contacts.py's `hunt_crossley_at_depth`, at the
        depth -dist along the contact's normal, with the velocity of geom2's point relative to geom1's, the pair's mu)
        added to W_f_L (N, nL, 6), Inertial: [f; p x f] on geom2's link, its opposite on geom1's (none on the world,
        link -1). The deformation of the contact in slot k is row nc_all + k of the contact state m (N, rows, 3) [m,
        world axes], its rate written to the same row of m_dot: the relative tangential displacement while the contact
        sticks (static friction), relaxing at K / D where the slot holds no touching contact. A slot keeps its
        deformation while its pair's contacts keep their order (a pair's slots are in its narrow phase's order).
        Where implicit (N, nL, IMPLICIT) has rows (model.implicit_contacts), each contact's linearly implicit terms at
        the time step h [s] are added to both links' (kernels/implicit_contacts.py; W_H_L (N, nL) the links' poses).
        One thread walks an environment's pairs in order (the sums are deterministic)."""
        env = wp.tid()
        K = B.env_parameter(contacts.K, env)
        D = B.env_parameter(contacts.D, env)
        row0 = contacts.row_point.shape[0]  # the points' rows come first
        zero = vec3(scalar(0.0))
        for i in range(link1.shape[0]):
            a, b = link1[i], link2[i]
            touching = count[env, i]
            for k in range(slots[i]):
                slot = first[i] + k
                row = row0 + slot
                m_k = vec3(m[env, row, 0], m[env, row, 1], m[env, row, 2])
                if k < touching:
                    p = vec3(position[env, slot, 0], position[env, slot, 1], position[env, slot, 2])
                    n = vec3(frame[env, slot, 0, 0], frame[env, slot, 0, 1], frame[env, slot, 0, 2])
                    v = zero  # the velocity of geom2's point relative to geom1's (the world's is 0)
                    if b >= 0:
                        v = v + sp.lin(W_v_WL[env, b]) + wp.cross(sp.ang(W_v_WL[env, b]), p)
                    if a >= 0:
                        v = v - sp.lin(W_v_WL[env, a]) - wp.cross(sp.ang(W_v_WL[env, a]), p)
                    depth = -dist[env, slot]
                    f, md = law.hunt_crossley_at_depth(depth, v, m_k, n, K, D, mu[i], contacts.p, contacts.q)
                    for r in range(3):
                        m_dot[env, row, r] = md[r]
                    torque = wp.cross(p, f)
                    for r in range(3):  # += is Warp's atomic add (one thread: in order), whose adjoint is right
                        if b >= 0:
                            W_f_L[env, b, r] += f[r]
                            W_f_L[env, b, 3 + r] += torque[r]
                        if a >= 0:
                            W_f_L[env, a, r] -= f[r]
                            W_f_L[env, a, 3 + r] -= torque[r]
                    if implicit.shape[0] > 0:
                        alpha, beta, g = implicit_terms.contact_terms(f, depth, v, m_k, n, K, D, mu[i], contacts.p, contacts.q, h)
                        if alpha > scalar(0.0):
                            if b >= 0:
                                implicit_terms.add_terms(implicit, env, b, W_H_L[env, b], p, n, alpha, beta, g)
                            if a >= 0:
                                implicit_terms.add_terms(implicit, env, a, W_H_L[env, a], p, n, alpha, beta, -g)
                else:  # an empty slot (its dist +inf), out of contact: its deformation relaxes, nothing else is read
                    f_none, md_none = law.hunt_crossley_at_depth(scalar(-wp.inf), zero, m_k, zero, K, D, mu[i], contacts.p, contacts.q)
                    for r in range(3):
                        m_dot[env, row, r] = md_none[r]

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
        geom_contacts=geom_contacts, geom_contact_wrenches=geom_contact_wrenches, damper_stability=damper_stability, links_touching=links_touching
    )
