"""The pairs MuJoCo collides with its general convex solver (mjc_Convex: its native GJK and EPA): here capsule-cylinder,
cylinder-cylinder, cylinder-box, an ellipsoid with a sphere, capsule, ellipsoid, cylinder, box or mesh, and a convex
mesh with a sphere, capsule, cylinder, box or mesh. GJK and EPA give one contact; where the model keeps MuJoCo's
multiCCD (on by default in MuJoCo 4) and the pair's geoms meet face to face or edge to face (a cylinder standing on a
box, a mesh lying on a face), `contacts` gives kernels/collision_polygons.py's contacts instead (up to 4). GJK and EPA
run in float64 whatever the kernels' scalar: their results are held (below), and float32's rounding stalled GJK
between curved surfaces millimetres short.

The geoms are taken as cores inflated by a radius (a sphere: its centre and radius; a capsule: its segment and
radius; an ellipsoid, a cylinder, a box or a mesh: itself and 0; a mesh as its convex hull, the support of its
vertices; an ellipsoid's support along d: diag(r)^2 d / |diag(r) d|, its radii r). GJK (the
closest point to the origin of a simplex of the cores' Minkowski difference, by its faces' affine projections) gives
the cores' distance where they are apart; where they overlap, EPA (the expanding polytope) gives their penetration. Either gives the direction n (unit, geom1 to geom2) of the cores' largest separation
sep(n) = min_b n.b - max_a n.a and the witness points a, b on each core; then, as MuJoCo's d.contact:
dist = n.(b - a) - r1 - r2 [m] (negative where they penetrate), pos midway between the surfaces' witnesses a + r1 n
and b - r2 n [m, world], and the normal n. EPA stops when a support moves the nearest face by less than TOLERANCE of the
pair's size (MuJoCo: ccd_tolerance 1e-6, ccd_iterations 35), when its polytope is full (VERTICES) or when rounding
breaks its convexity (the last good face is kept); GJK when a support gains less than that, when rounding leaves no
progress (the last simplex is kept) or after GJK_ITERATIONS (linear convergence between two curved surfaces:
tests/test_collision_convex.py measures both).

Gradients: n and the witnesses, in their geoms' frames, come from `direction`, whose adjoint is zero (its loops are
not differentiable); dist = n.(b - a) - r1 - r2 is then evaluated at the poses with them held, which is dist's exact
derivative at the optimum (Danskin's theorem for the separation's max-min; the witnesses as accurate as EPA places
them); pos moves with the witnesses fixed on their geoms, and the frame is held.
"""

import types
from typing import Any

import warp as wp

from . import collision_polygons, collision_primitives
from .factory import factory
from .geom_types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE
from .spatial import spatial

VERTICES = 64
"""The most vertices of EPA's polytope (its faces: 2 VERTICES - 4 at most, FACES with the ones a step replaces)."""
FACES = 2 * VERTICES
HORIZON = 64
"""The most edges of the horizon that one support point sees."""
GJK_ITERATIONS = 64
TOLERANCE = 1e-10
"""EPA's and GJK's stopping tolerance, relative to the pair's size (the cores' radii and half-size vectors' lengths;
both run in float64): well above the supports' rounding (~1e-15 of the size), and reached in about 30 steps where
EPA refines a curved surface (its gap about halves a step)."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """`convex` and `contacts` (the module docstring) and their batch kernel `collide` in `scalar` (wp.float32 or
    wp.float64)."""
    sp = spatial(scalar)
    prim = collision_primitives.kernels(scalar)
    poly = collision_polygons.kernels(scalar)
    vec3, mat33 = sp.vec3, sp.mat33
    # GJK and EPA in float64 whatever `scalar` (their results are held, not differentiated): float32's rounding stalls
    # GJK between two curved surfaces millimetres short of the distance
    F = wp.float64
    V3, M33, V4 = wp.vec3d, wp.mat33d, wp.vec4d
    M43 = wp.types.matrix(shape=(4, 3), dtype=F)
    Points = wp.types.matrix(shape=(VERTICES, 3), dtype=F)
    Normals = wp.types.matrix(shape=(FACES, 3), dtype=F)
    FaceValues = wp.types.vector(FACES, F)
    FaceInts = wp.types.vector(FACES, int)
    Edges = wp.types.vector(HORIZON, int)
    tol = F(TOLERANCE)
    zero, one = F(0.0), F(1.0)

    @wp.func
    def core_radius(t: int, s: Any):
        """The radius a geom's core is inflated by: a sphere's or a capsule's, else 0 (s: its size, any scalar)."""
        r = s[0] - s[0]
        if t == SPHERE or t == CAPSULE:
            r = s[0]
        return r

    @wp.func
    def signed(x: F, d: F):
        """x where d >= 0, else -x."""
        if d < F(0.0):
            return -x
        return x

    @wp.func
    def core_support(t: int, s: V3, verts: wp.array(dtype=vec3), vr: wp.vec2i, d: V3):
        """The point of a geom's core farthest along d, in the geom's frame (d too); a mesh's: of its vertices
        verts[vr[0]:vr[0] + vr[1]] (its convex hull's support)."""
        if t == MESH:
            best = V3(verts[vr[0]])
            top = wp.dot(best, d)
            for k in range(vr[0] + 1, vr[0] + vr[1]):
                x = wp.dot(V3(verts[k]), d)
                if x > top:
                    top = x
                    best = V3(verts[k])
            return best
        if t == BOX:
            return V3(signed(s[0], d[0]), signed(s[1], d[1]), signed(s[2], d[2]))
        if t == CYLINDER:
            radial = wp.sqrt(d[0] * d[0] + d[1] * d[1])
            x, y = F(0.0), F(0.0)
            if radial > F(0.0):
                x, y = s[0] * d[0] / radial, s[0] * d[1] / radial
            return V3(x, y, signed(s[1], d[2]))
        if t == CAPSULE:
            return V3(F(0.0), F(0.0), signed(s[1], d[2]))
        if t == ELLIPSOID:
            scaled = wp.cw_mul(s, d)
            norm = wp.length(scaled)
            if norm > F(0.0):
                return wp.cw_mul(s, scaled) / norm
            return V3(s[0], F(0.0), F(0.0))  # (d = 0: any surface point; MuJoCo's too)
        return V3(F(0.0))

    @wp.func
    def world_support(t: int, p: V3, R: M33, s: V3, verts: wp.array(dtype=vec3), vr: wp.vec2i, d: V3):
        """The point of a geom's core (pose p, R) farthest along the world direction d [m, world]."""
        return p + R * core_support(t, s, verts, vr, wp.transpose(R) * d)

    @wp.func
    def held_rows(
        t1: int, p1: V3, R1: M33, s1: V3, t2: int, p2: V3, R2: M33, s2: V3, verts: wp.array(dtype=vec3), vr1: wp.vec2i, vr2: wp.vec2i,
        nrm: V3, wa: V3, wb: V3,
    ):  # fmt: skip
        """(n, geom1's witness in its frame, geom2's in its frame) from GJK's or EPA's witnesses wa, wb [m, world]: an
        ellipsoid's witness is its point farthest along the normal (unique on a strictly convex surface: exact where
        EPA's face interpolates a coarse polytope); a cylinder's, a box's or a mesh's across from an ellipsoid (geom1:
        the pairs are ordered by type) lies on the normal through the ellipsoid's (n.(b - a) unchanged; EPA's lateral
        placement on a face wanders from step to step and would rock the ellipsoid). A sphere's or a capsule's stays
        GJK's or EPA's, on its core."""
        if t1 == ELLIPSOID:
            wa = world_support(t1, p1, R1, s1, verts, vr1, nrm)
        if t2 == ELLIPSOID:
            wb = world_support(t2, p2, R2, s2, verts, vr2, -nrm)
        elif t1 == ELLIPSOID:
            wb = wa + wp.dot(wb - wa, nrm) * nrm
        out = M33(F(0.0))
        out[0] = nrm
        out[1] = wp.transpose(R1) * (wa - p1)
        out[2] = wp.transpose(R2) * (wb - p2)
        return out

    @wp.func
    def project(S: M43, mask: int):
        """(found, |x|^2, lambda): the origin's projection x onto the affine hull of the simplex points S[k] with bit k of
        mask, lambda its barycentric coordinates (zero off the mask); found where the hull is not degenerate and every
        lambda >= 0 (x is then the subset's closest point to the origin)."""
        idx = wp.vec4i(0)
        k = int(0)
        for j in range(4):
            if (mask >> j) & 1 != 0:
                idx[k] = j
                k += 1
        w0 = S[idx[0]]
        lam = V4(F(0.0))
        mu = V3(F(0.0))
        found = bool(True)
        if k == 1:
            lam[idx[0]] = one
            return True, wp.dot(w0, w0), lam
        G = M33(F(0.0))
        r = V3(F(0.0))
        E = M33(F(0.0))
        for a in range(k - 1):
            e = S[idx[a + 1]] - w0
            for c in range(3):
                E[a, c] = e[c]
        for a in range(k - 1):
            r[a] = -wp.dot(E[a], w0)
            for b in range(k - 1):
                G[a, b] = wp.dot(E[a], E[b])
        if k == 2:
            if G[0, 0] <= F(0.0):
                found = False
            else:
                mu[0] = r[0] / G[0, 0]
        elif k == 3:
            det = G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]
            if det <= tol * tol * G[0, 0] * G[1, 1]:
                found = False
            else:
                mu[0] = (r[0] * G[1, 1] - G[0, 1] * r[1]) / det
                mu[1] = (G[0, 0] * r[1] - r[0] * G[1, 0]) / det
        else:
            det = wp.determinant(G)
            if wp.abs(det) <= tol * tol * G[0, 0] * G[1, 1] * G[2, 2]:
                found = False
            else:
                mu = wp.inverse(G) * r
        lam[idx[0]] = one - mu[0] - mu[1] - mu[2]
        for a in range(k - 1):
            lam[idx[a + 1]] = mu[a]
        x = w0
        for a in range(k - 1):
            x = x + mu[a] * E[a]
        for j in range(4):
            if lam[j] < F(0.0):
                found = False
        return found, wp.dot(x, x), lam

    @wp.func
    def closest(S: M43, n: int):
        """(mask, lambda): the face of the simplex of the first n points S whose projection of the origin is the
        simplex's closest point (the least among the faces where it falls inside)."""
        best = F(wp.inf)
        best_mask = int(1)
        best_lam = V4(F(0.0))
        best_lam[0] = one
        for mask in range(1, 1 << n):
            found, d2, lam = project(S, mask)
            if found and d2 < best:
                best, best_mask, best_lam = d2, mask, lam
        return best_mask, best_lam

    @wp.func
    def face_normal(P: Points, i: int, j: int, k: int, centre: V3):
        """The unit normal of the triangle (P[i], P[j], P[k]), pointing away from centre, and the face's order that
        makes it the right-handed one (i, j, k or i, k, j: flipped where the order is reversed)."""
        nrm = wp.cross(P[j] - P[i], P[k] - P[i])
        flipped = False
        if wp.dot(nrm, P[i] - centre) < F(0.0):
            nrm = -nrm
            flipped = True
        length = wp.length(nrm)
        if length > F(0.0):
            nrm = nrm / length
        return nrm, flipped, length > F(0.0)

    @wp.func
    def direction64(t1: int, p1: V3, R1: M33, s1: V3, t2: int, p2: V3, R2: M33, s2: V3, verts: wp.array(dtype=vec3), vr1: wp.vec2i, vr2: wp.vec2i):
        """Rows: the unit direction n from geom1 to geom2 of the cores' largest separation (GJK where they are apart,
        EPA where they overlap), the witness on core1 in geom1's frame, the witness on core2 in geom2's frame; n = 0
        where EPA's polytope degenerates (coincident supports only). Held by the adjoint (`adj_direction`)."""
        scale = core_radius(t1, s1) + wp.length(s1) + core_radius(t2, s2) + wp.length(s2)
        eps = tol * scale
        S = M43(F(0.0))
        SA = M43(F(0.0))
        SB = M43(F(0.0))
        d = p1 - p2
        if wp.dot(d, d) <= eps * eps:
            d = V3(one, zero, zero)
        a = world_support(t1, p1, R1, s1, verts, vr1, d)
        b = world_support(t2, p2, R2, s2, verts, vr2, -d)
        S[0] = a - b
        SA[0] = a
        SB[0] = b
        n = int(1)
        lam = V4(one, zero, zero, zero)
        v = S[0]
        overlap = bool(False)
        for _it in range(GJK_ITERATIONS):
            if not overlap:
                vv = wp.dot(v, v)
                if vv <= eps * eps:
                    overlap = True
                else:
                    a = world_support(t1, p1, R1, s1, verts, vr1, -v)
                    b = world_support(t2, p2, R2, s2, verts, vr2, v)
                    w = a - b
                    if vv - wp.dot(v, w) > eps * wp.sqrt(vv) and n < 4:
                        S1, A1, B1 = S, SA, SB
                        S1[n] = w
                        A1[n] = a
                        B1[n] = b
                        mask, lam4 = closest(S1, n + 1)
                        m = int(0)
                        S2, A2, B2 = M43(F(0.0)), M43(F(0.0)), M43(F(0.0))
                        lam2 = V4(F(0.0))
                        v2 = V3(F(0.0))
                        for j in range(4):
                            if (mask >> j) & 1 != 0:
                                S2[m] = S1[j]
                                A2[m] = A1[j]
                                B2[m] = B1[j]
                                lam2[m] = lam4[j]
                                v2 = v2 + lam4[j] * S1[j]
                                m += 1
                        if m < 4 and wp.dot(v2, v2) >= vv:  # no progress left to rounding: v stays the closest point found
                            break
                        S, SA, SB, n, lam, v = S2, A2, B2, m, lam2, v2
                        if n == 4:
                            overlap = True
                    else:
                        break
        if not overlap:  # apart: the closest points
            wa, wb = V3(F(0.0)), V3(F(0.0))
            for j in range(4):
                wa = wa + lam[j] * SA[j]
                wb = wb + lam[j] * SB[j]
            dv = wb - wa
            return held_rows(t1, p1, R1, s1, t2, p2, R2, s2, verts, vr1, vr2, dv / wp.length(dv), wa, wb)
        # overlapping: EPA from the simplex, grown to a polytope around the origin
        P, PA, PB = Points(F(0.0)), Points(F(0.0)), Points(F(0.0))
        for j in range(n):
            P[j] = S[j]
            PA[j] = SA[j]
            PB[j] = SB[j]
        nv = n
        if n < 4:
            e = V3(one, zero, zero)
            if n == 3:
                e = wp.cross(S[1] - S[0], S[2] - S[0])
            elif n == 2:
                e = S[1] - S[0]
            e = wp.normalize(e)
            u = wp.cross(e, V3(one, zero, zero))
            if wp.length(u) < F(0.5):
                u = wp.cross(e, V3(zero, one, zero))
            u = wp.normalize(u)
            dirs = M33(F(0.0))
            count = int(0)
            if n == 3:
                dirs[0] = e
                dirs[1] = -e
                count = 2
            elif n == 2:
                u2 = wp.cross(e, u)
                half = F(0.8660254037844386)
                dirs[0] = u
                dirs[1] = F(-0.5) * u + half * u2
                dirs[2] = F(-0.5) * u - half * u2
                count = 3
            else:  # one point: a tetrahedron around it
                u2 = wp.cross(e, u)
                dirs[0] = e
                dirs[1] = u
                dirs[2] = u2
                count = 3
            if n == 1:  # the point itself is dropped
                nv = 0
            for j in range(count):
                a = world_support(t1, p1, R1, s1, verts, vr1, dirs[j])
                b = world_support(t2, p2, R2, s2, verts, vr2, -dirs[j])
                P[nv] = a - b
                PA[nv] = a
                PB[nv] = b
                nv += 1
            if n == 1:
                a = world_support(t1, p1, R1, s1, verts, vr1, -(dirs[0] + dirs[1] + dirs[2]))
                b = world_support(t2, p2, R2, s2, verts, vr2, dirs[0] + dirs[1] + dirs[2])
                P[nv] = a - b
                PA[nv] = a
                PB[nv] = b
                nv += 1
        centre = V3(F(0.0))
        for j in range(nv):
            centre = centre + P[j]
        centre = centre / F(nv)
        fi, fj, fk, alive = FaceInts(0), FaceInts(0), FaceInts(0), FaceInts(0)
        normal = Normals(F(0.0))
        fdist = FaceValues(F(0.0))
        nf = int(0)
        # the initial faces: a tetrahedron (4 points), or the bipyramid of 5 (a triangle with apexes 3, 4; a segment 0-1 with 2, 3, 4 around it)
        tri = wp.vec3i(0)
        for c in range(6):
            ok = bool(False)
            if nv == 4 and c < 4:
                tri = wp.vec3i((c + 1) % 4, (c + 2) % 4, (c + 3) % 4)
                ok = True
            elif nv == 5 and n == 3:
                tri = wp.vec3i(c % 3, (c + 1) % 3, 3 + c // 3)
                ok = True
            elif nv == 5:
                tri = wp.vec3i(2 + c % 3, 2 + (c + 1) % 3, c // 3)
                ok = True
            if ok:
                nrm, flipped, proper = face_normal(P, tri[0], tri[1], tri[2], centre)
                fi[nf] = tri[0]
                fj[nf] = tri[1]
                fk[nf] = tri[2]
                if flipped:
                    fj[nf] = tri[2]
                    fk[nf] = tri[1]
                normal[nf] = nrm
                fdist[nf] = wp.dot(nrm, P[tri[0]])
                if not proper:  # a degenerate face (coincident supports): never the nearest
                    fdist[nf] = F(wp.inf)
                alive[nf] = 1
                nf += 1
        nalive = nf
        face = wp.vec3i(0)  # the nearest face so far: its vertices, normal and distance (kept: its slot may be reused)
        face_normal_kept = V3(F(0.0))
        face_dist = F(-1.0)
        for _it in range(VERTICES):
            best = int(-1)
            for f in range(nf):
                if alive[f] == 1:
                    if best < 0:
                        best = f
                    elif fdist[f] < fdist[best]:
                        best = f
            if best < 0 or fdist[best] == F(wp.inf):  # no proper face left (a degenerate polytope): keep the last one
                break
            if fdist[best] < face_dist - eps:  # rounding broke the polytope's convexity: keep the last face
                break
            face = wp.vec3i(fi[best], fj[best], fk[best])
            face_normal_kept = normal[best]
            face_dist = fdist[best]
            nrm = normal[best]
            a = world_support(t1, p1, R1, s1, verts, vr1, nrm)
            b = world_support(t2, p2, R2, s2, verts, vr2, -nrm)
            w = a - b
            if wp.dot(nrm, w) - fdist[best] <= eps or nv == VERTICES:
                break
            P[nv] = w
            PA[nv] = a
            PB[nv] = b
            ei, ej = Edges(0), Edges(0)
            ne = int(0)
            full = bool(False)
            for f in range(nf):
                if alive[f] == 1 and wp.dot(normal[f], w - P[fi[f]]) > F(0.0):
                    alive[f] = 0
                    nalive -= 1
                    for c in range(3):
                        ex, ey = fi[f], fj[f]
                        if c == 1:
                            ex, ey = fj[f], fk[f]
                        elif c == 2:
                            ex, ey = fk[f], fi[f]
                        shared = int(-1)
                        for g in range(ne):
                            if ei[g] == ey and ej[g] == ex:
                                shared = g
                        if shared >= 0:
                            ne -= 1
                            ei[shared] = ei[ne]
                            ej[shared] = ej[ne]
                        elif ne < HORIZON:
                            ei[ne] = ex
                            ej[ne] = ey
                            ne += 1
                        else:
                            full = True
            if full or nalive + ne > FACES:
                break
            slot = int(0)
            for g in range(ne):  # each new face in the first free slot
                while slot < nf and alive[slot] == 1:
                    slot += 1
                f = slot
                if f == nf:
                    nf += 1
                nrm2, flipped, proper = face_normal(P, ei[g], ej[g], nv, centre)
                fi[f] = ei[g]
                fj[f] = ej[g]
                fk[f] = nv
                if flipped:
                    fj[f] = nv
                    fk[f] = ej[g]
                normal[f] = nrm2
                fdist[f] = wp.dot(nrm2, P[ei[g]])
                if not proper:
                    fdist[f] = F(wp.inf)
                alive[f] = 1
            nalive += ne
            nv += 1
        # the witnesses: the origin's projection onto the nearest face, in barycentric coordinates
        nrm = face_normal_kept
        origin_on_face = face_dist * nrm
        va, vb, vc = P[face[0]], P[face[1]], P[face[2]]
        e0, e1, e2 = vb - va, vc - va, origin_on_face - va
        d00, d01, d11, d20, d21 = wp.dot(e0, e0), wp.dot(e0, e1), wp.dot(e1, e1), wp.dot(e2, e0), wp.dot(e2, e1)
        den = d00 * d11 - d01 * d01
        l1, l2 = F(0.0), F(0.0)
        if den > F(0.0):
            l1 = (d11 * d20 - d01 * d21) / den
            l2 = (d00 * d21 - d01 * d20) / den
        l0 = one - l1 - l2
        wa = l0 * PA[face[0]] + l1 * PA[face[1]] + l2 * PA[face[2]]
        wb = l0 * PB[face[0]] + l1 * PB[face[1]] + l2 * PB[face[2]]
        return held_rows(t1, p1, R1, s1, t2, p2, R2, s2, verts, vr1, vr2, nrm, wa, wb)

    @wp.func
    def direction(t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), vr1: wp.vec2i, vr2: wp.vec2i):
        """`direction64` in float64, its rows returned in `scalar`; held by the adjoint (`adj_direction`)."""
        return mat33(direction64(t1, V3(p1), M33(R1), V3(s1), t2, V3(p2), M33(R2), V3(s2), verts, vr1, vr2))

    @wp.func_grad(direction)
    def adj_direction(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), vr1: wp.vec2i, vr2: wp.vec2i, adj_ret: mat33
    ):
        """Held: the direction and the witnesses carry no gradient (the module docstring)."""
        pass

    @wp.func
    def convex(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), vr1: wp.vec2i, vr2: wp.vec2i, margin: scalar
    ):
        """(count, pos [m, world], normal (geom1 to geom2), dist [m]): the pair's contact (the module docstring), count 0
        where dist > margin; MuJoCo's conventions (kernels/collision_primitives.py)."""
        held = direction(t1, p1, R1, s1, t2, p2, R2, s2, verts, vr1, vr2)
        n = held[0]
        r1, r2 = core_radius(t1, s1), core_radius(t2, s2)
        a = p1 + R1 * held[1]
        b = p2 + R2 * held[2]
        dist = wp.dot(n, b - a) - r1 - r2
        a = a + r1 * n
        b = b - r2 * n
        count = int(0)
        if dist <= margin and wp.dot(n, n) > scalar(0.25):  # (a degenerate polytope gives no direction: no contact)
            count = 1
        return count, scalar(0.5) * (a + b), n, dist

    @wp.func
    def contacts(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), vr1: wp.vec2i, vr2: wp.vec2i,
        margin: scalar, multiccd: bool, polygons: poly.Polygons, pr1: wp.vec2i, pr2: wp.vec2i,
    ):  # fmt: skip
        """(count, positions (CONTACTS, 3) [m, world], normals (CONTACTS, 3) (geom1 to geom2), dists (CONTACTS,) [m]):
        the pair's contact (`convex`), or where multiccd and it penetrates, kernels/collision_polygons.py's
        multi-contact if it has one (the meshes' polygons: their (first, count) pr1, pr2 in `polygons`)."""
        P = poly.Quad()
        N = poly.Quad()
        D = poly.Dists()
        count, p, normal, d = convex(t1, p1, R1, s1, t2, p2, R2, s2, verts, vr1, vr2, margin)
        if count == 0:
            return 0, P, N, D
        if multiccd and d < scalar(0.0):
            m, Pm, Nm, Dm = poly.multicontact(t1, p1, R1, s1, t2, p2, R2, s2, verts, polygons, pr1, pr2, normal)
            if m > 0:
                return m, Pm, Nm, Dm
        P[0] = p
        N[0] = normal
        D[0] = d
        return 1, P, N, D

    @wp.kernel(module="unique")
    def collide(
        type1: int, type2: int, pos1: wp.array(dtype=vec3), R1: wp.array(dtype=mat33), size1: wp.array(dtype=vec3),
        pos2: wp.array(dtype=vec3), R2: wp.array(dtype=mat33), size2: wp.array(dtype=vec3), margin: wp.array(dtype=scalar),
        verts: wp.array(dtype=vec3), vr1: wp.array(dtype=wp.vec2i), vr2: wp.array(dtype=wp.vec2i), multiccd: int, polygons: poly.Polygons,
        pr1: wp.array(dtype=wp.vec2i), pr2: wp.array(dtype=wp.vec2i),
        # outputs
        count: wp.array(dtype=int), position: wp.array2d(dtype=vec3), frame: wp.array2d(dtype=mat33), dist: wp.array2d(dtype=scalar),
    ):  # fmt: skip
        """One pair per thread i, as collision_primitives' `collide` writes a pair (its outputs' second axis: 1, or
        CONTACTS where multiccd != 0): count[i] (0 where MuJoCo's bounding-sphere filter drops the pair), the
        contacts' positions, frames and distances (`contacts`)."""
        i = wp.tid()
        n, P, N, D = contacts(type1, pos1[i], R1[i], size1[i], type2, pos2[i], R2[i], size2[i], verts, vr1[i], vr2[i], margin[i], multiccd != 0,
                              polygons, pr1[i], pr2[i])  # fmt: skip
        if not prim.may_touch(type1, pos1[i], R1[i], size1[i], type2, pos2[i], size2[i], margin[i]):
            n = 0
        for k in range(wp.static(collision_polygons.CONTACTS)):
            if k < n:
                position[i, k] = vec3(P[k, 0], P[k, 1], P[k, 2])
                frame[i, k] = prim.contact_frame(vec3(N[k, 0], N[k, 1], N[k, 2]), vec3(scalar(0.0)))
                dist[i, k] = D[k]
        count[i] = n

    return types.SimpleNamespace(scalar=scalar, vec3=vec3, mat33=mat33, Polygons=poly.Polygons, convex=convex, contacts=contacts, collide=collide)
