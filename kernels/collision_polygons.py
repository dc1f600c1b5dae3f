"""MuJoCo's multi-contact between faces (multiCCD; engine_collision_gjk.c's multicontact, polygonClip and polygonQuad),
for the pairs of kernels/collision_convex.py whose geoms have faces or edges: box, cylinder, capsule and mesh.

Where such a pair penetrates (dist < 0) and its features along the contact's normal n (geom1 to geom2) are two faces
whose outward normals oppose within FACE_TOL, or a face and an edge perpendicular to it within EDGE_TOL, the contacts
are the vertices of one feature (the clipped: geom2's face, or the edge) cut by the planes through the other's (the
clipper's) edges perpendicular to its face, those at or below the clipper's face: at most CONTACTS (more: the
quadrilateral of the largest area among them, where MuJoCo 3's polygonQuad kept a large one by a rotating search; an
edge: its two farthest points). Each contact: dist = the vertex's height above the clipper's face [m] (negative below it), its position
midway between the vertex and the clipper's face along the witness direction, its normal the face's (geom1 to geom2):
MuJoCo's witnessOnFace. Where nothing is left, the pair keeps GJK and EPA's one contact.

A geom's feature along its outward direction u (n for geom1, -n for geom2), [m, world]:
- box: the face whose normal is within FACE_TOL of u (its 4 corners), else the edge whose direction is within
  EDGE_TOL of perpendicular to u (its two corners, the others' signs those of u);
- cylinder: the cap whose normal is within FACE_TOL of u (NGON points of its rim, as MuJoCo 4 takes it), else the
  side's segment under u where the axis is within EDGE_TOL of perpendicular to u;
- capsule: its surface's segment under u where the axis is within EDGE_TOL of perpendicular to u;
- mesh: the polygon of its hull (MuJoCo's mesh_polyvert, at most MAX_FACE vertices) whose normal is within FACE_TOL
  of u; a mesh's edges are not features here (MuJoCo's are: an edge of a mesh on a face keeps one contact).
MuJoCo finds the features from its EPA's last face's supports; warpdyn from the contact's normal: the same features
where the normal lies within the tolerances. MuJoCo 4.0 places tilted faces' contacts slightly differently (within
5e-6 m at 3 mrad) and may keep another quadrilateral of a polygon of more than four vertices (a cylinder's cap:
tests/test_collision_polygons.py).

Gradients: the features and the clipping are held (`held`, whose adjoint is zero): each contact's clipped vertex in its
geom's frame and the clipper's face (a vertex and its normal) in the clipper's; dist and the position are evaluated
from them at the poses (the vertices move with their geoms, as kernels/collision_convex.py holds its witnesses).
"""

import math
import types

import warp as wp

from .factory import factory
from .geom_types import BOX, CAPSULE, CYLINDER, MESH

FACE_TOL = 0.996
"""MuJoCo's mjFACE_TOL: two faces meet face to face where their normals' dot product is below -FACE_TOL (5.1 deg)."""
EDGE_TOL = 0.0888
"""MuJoCo's mjEDGE_TOL: an edge lies on a face where its direction's dot product with the face's normal is below this."""
NGON = 16
"""The points of a cylinder's cap's rim (MuJoCo 4's: at multiples of 22.5 degrees about its axis from its x axis)."""
RIM_STEP = 2.0 * math.pi / NGON
"""[rad] The angle between neighbouring points of a cap's rim."""
MAX_FACE = 32
"""The most vertices of a face (a mesh's polygons with more are not faces here)."""
CLIP = 2 * MAX_FACE
"""The most vertices of a clipped polygon (MuJoCo's buffer: twice a face's)."""
CONTACTS = 4
"""The most contacts of a pair (MuJoCo's max_contacts for multiCCD's pairs)."""
MINVAL = 1e-15
"""MuJoCo's mjMINVAL: a point within it outside a clipping plane is inside."""

NONE, EDGE, FACE = 0, 1, 2
FACE_FACE, EDGE_FACE, FACE_EDGE = 1, 2, 3
"""The cases of `held`: geom1's face clips geom2's face; geom2's face clips geom1's edge; geom1's face clips geom2's edge."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """`Polygons` (the meshes' hull polygons), `held` and `multicontact` (the module docstring) in `scalar`."""
    vec3 = wp.types.vector(3, scalar)
    mat33 = wp.types.matrix((3, 3), scalar)
    Poly = wp.types.matrix(shape=(CLIP, 3), dtype=scalar)
    Held = wp.types.matrix(shape=(CONTACTS + 4, 3), dtype=scalar)
    Quad = wp.types.matrix(shape=(CONTACTS, 3), dtype=scalar)
    Dists = wp.types.vector(CONTACTS, scalar)
    zero = scalar(0.0)

    @wp.struct
    class Polygons:
        """The meshes' hull polygons (Q of them): normal (Q,) unit, outward, in the mesh geom's frame; vertices (Q,)
        (first, count) in `vertex`, the polygon's vertices (indices into the narrow phase's vertices) counterclockwise
        about the normal (MuJoCo's mesh_polyvert order)."""

        normal: wp.array(dtype=vec3)
        vertices: wp.array(dtype=wp.vec2i)
        vertex: wp.array(dtype=int)

    @wp.func
    def cyclic(a: int, x: scalar, y: scalar, z: scalar):
        """The vector whose component a is x, a + 1 is y and a + 2 is z (mod 3)."""
        v = vec3(zero)
        v[a] = x
        v[(a + 1) % 3] = y
        v[(a + 2) % 3] = z
        return v

    @wp.func
    def sign(x: scalar):
        return wp.where(x >= zero, scalar(1.0), scalar(-1.0))

    @wp.func
    def box_feature(p: vec3, R: mat33, s: vec3, u: vec3):
        """(kind, points [m, world], count, outward normal of a face) of a box (half sizes s) along u."""
        F = Poly()
        ul = wp.transpose(R) * u
        a = int(0)
        e = int(0)
        for k in range(1, 3):
            if wp.abs(ul[k]) > wp.abs(ul[a]):
                a = k
            if wp.abs(ul[k]) < wp.abs(ul[e]):
                e = k
        if wp.abs(ul[a]) > scalar(FACE_TOL):
            sg = sign(ul[a])
            b, c = (a + 1) % 3, (a + 2) % 3
            for k in range(4):  # clockwise about the outward normal: the edges' planes face inward
                corner = cyclic(a, sg * s[a], wp.where(k < 2, s[b], -s[b]), wp.where(k == 0 or k == 3, s[c], -s[c]))
                F[wp.where(sg > zero, k, 3 - k)] = p + R * corner
            return FACE, F, 4, R * cyclic(a, sg, zero, zero)
        if wp.abs(ul[e]) < scalar(EDGE_TOL):
            corner = vec3(sign(ul[0]) * s[0], sign(ul[1]) * s[1], sign(ul[2]) * s[2])
            corner[e] = -s[e]
            F[0] = p + R * corner
            corner[e] = s[e]
            F[1] = p + R * corner
            return EDGE, F, 2, vec3(zero)
        return NONE, F, 0, vec3(zero)

    @wp.func
    def round_feature(t: int, p: vec3, R: mat33, s: vec3, u: vec3):
        """A cylinder's or a capsule's (radius s[0], half length s[1]) feature along u, as `box_feature`."""
        F = Poly()
        ul = wp.transpose(R) * u
        r, h = s[0], s[1]
        if t == CYLINDER and wp.abs(ul[2]) > scalar(FACE_TOL):
            sg = sign(ul[2])
            rim = int(NGON)
            for k in range(rim):  # clockwise about the outward normal
                angle = -sg * scalar(RIM_STEP) * scalar(k)
                F[k] = p + R * vec3(r * wp.cos(angle), r * wp.sin(angle), sg * h)
            return FACE, F, NGON, R * vec3(zero, zero, sg)
        if wp.abs(ul[2]) < scalar(EDGE_TOL):
            side = vec3(zero)  # the capsule's segment, pushed out by its radius along u
            if t == CYLINDER:
                side = R * (wp.normalize(vec3(ul[0], ul[1], zero)) * r)
            else:
                side = u * r
            F[0] = p + R * vec3(zero, zero, -h) + side
            F[1] = p + R * vec3(zero, zero, h) + side
            return EDGE, F, 2, vec3(zero)
        return NONE, F, 0, vec3(zero)

    @wp.func
    def mesh_feature(p: vec3, R: mat33, verts: wp.array(dtype=vec3), polygons: Polygons, range_: wp.vec2i, u: vec3):
        """A mesh's face along u (its polygons range_ = (first, count) of `polygons`), as `box_feature`."""
        F = Poly()
        best = scalar(FACE_TOL)
        found = int(-1)
        for q in range(range_[0], range_[0] + range_[1]):
            if polygons.vertices[q][1] <= MAX_FACE:
                d = wp.dot(R * polygons.normal[q], u)
                if d > best:
                    best = d
                    found = q
        if found < 0:
            return NONE, F, 0, vec3(zero)
        first, count = polygons.vertices[found][0], polygons.vertices[found][1]
        for k in range(count):  # reversed: clockwise about the outward normal (MuJoCo's meshFace)
            F[k] = p + R * verts[polygons.vertex[first + count - 1 - k]]
        return FACE, F, count, R * polygons.normal[found]

    @wp.func
    def feature(t: int, p: vec3, R: mat33, s: vec3, verts: wp.array(dtype=vec3), polygons: Polygons, range_: wp.vec2i, u: vec3):
        """The geom's feature along u (the module docstring): (kind, points, count, a face's outward normal)."""
        if t == BOX:
            return box_feature(p, R, s, u)
        if t == MESH:
            return mesh_feature(p, R, verts, polygons, range_, u)
        if t == CYLINDER or t == CAPSULE:
            return round_feature(t, p, R, s, u)
        return NONE, Poly(), 0, vec3(zero)

    @wp.func
    def clip(F1: Poly, c1: int, n1: vec3, F2: Poly, c2: int):
        """(F2's first c2 points cut by the planes through F1's edges perpendicular to its face (normal n1), their
        count): MuJoCo's polygonClip, a plane at a time (Sutherland-Hodgman)."""
        A = F2
        n = c2
        for e in range(c1):
            a = F1[e]
            pn = wp.normalize(wp.cross(F1[(e + 1) % c1] - a, n1))
            pd = wp.dot(pn, a)
            B = Poly()
            m = int(0)
            for i in range(n):
                P = A[i]
                Q = A[(i + 1) % n]
                inside1 = wp.dot(P - a, pn) > -scalar(MINVAL)
                inside2 = wp.dot(Q - a, pn) > -scalar(MINVAL)
                if inside1 and inside2:
                    if m < CLIP:
                        B[m] = Q
                        m += 1
                elif inside1 or inside2:
                    PQ = Q - P
                    den = wp.dot(pn, PQ)
                    if den != zero:
                        t = (pd - wp.dot(pn, P)) / den
                        if t >= zero and t <= scalar(1.0) and m < CLIP:
                            B[m] = P + t * PQ
                            m += 1
                    if inside2 and m < CLIP:
                        B[m] = Q
                        m += 1
            A = B
            n = m
        return A, n

    @wp.func
    def quad(A: Poly, n: int):
        """The indices (in order) of the quadrilateral of the largest area among the vertices of the convex polygon A
        (n > 4 points): each diagonal (i, j) with the vertex on either side farthest from it."""
        best = wp.vec4i(0, 1, 2, 3)
        largest = scalar(-1.0)
        for i in range(n):
            for j in range(i + 2, n):
                if j - i <= n - 2:
                    side1 = scalar(-1.0)
                    k1 = int(i + 1)
                    for k in range(i + 1, j):
                        twice = wp.length(wp.cross(A[j] - A[i], A[k] - A[i]))
                        if twice > side1:
                            side1 = twice
                            k1 = k
                    side2 = scalar(-1.0)
                    k2 = int((j + 1) % n)
                    for k in range(j + 1, i + n):
                        twice = wp.length(wp.cross(A[j] - A[i], A[k % n] - A[i]))
                        if twice > side2:
                            side2 = twice
                            k2 = k % n
                    if side1 + side2 > largest:
                        largest = side1 + side2
                        best = wp.vec4i(i, k1, j, k2)
        return best

    @wp.func
    def held(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), polygons: Polygons,
        pr1: wp.vec2i, pr2: wp.vec2i, n: vec3,
    ):  # fmt: skip
        """Rows 0..3: the contacts' clipped vertices in the clipped geom's frame; 4: the clipper's face's first vertex
        and 5: its normal, in the clipper's frame; 6: the contacts' normal (geom1 to geom2) in geom1's frame (case
        FACE_EDGE) or geom2's; 7: (case, count, 0), case NONE or count 0: no multi-contact. Held by the adjoint."""
        out = Held()
        k1, F1, c1, m1 = feature(t1, p1, R1, s1, verts, polygons, pr1, n)
        k2, F2, c2, m2 = feature(t2, p2, R2, s2, verts, polygons, pr2, -n)
        case = NONE
        if k1 == FACE and k2 == FACE and wp.dot(m1, m2) < -scalar(FACE_TOL):
            case = FACE_FACE
        elif k1 == EDGE and k2 == FACE and wp.abs(wp.dot(wp.normalize(F1[1] - F1[0]), m2)) < scalar(EDGE_TOL):
            case = EDGE_FACE
        elif k1 == FACE and k2 == EDGE and wp.abs(wp.dot(wp.normalize(F2[1] - F2[0]), m1)) < scalar(EDGE_TOL):
            case = FACE_EDGE
        if case == NONE:
            return out
        # the clipper (a face) and the clipped (a face or an edge), their frames
        Fk, ck, nk, Fc, cc = F1, c1, m1, F2, c2
        pk, Rk, pc, Rc = p1, R1, p2, R2
        normal = -m2
        if case == EDGE_FACE:
            Fk, ck, nk, Fc, cc = F2, c2, m2, F1, c1
            pk, Rk, pc, Rc = p2, R2, p1, R1
        if case == FACE_EDGE:
            normal = m1
        A, na = clip(Fk, ck, nk, Fc, cc)
        kept = int(0)  # those at or below the clipper's face
        for i in range(na):
            if wp.dot(A[i] - Fk[0], nk) <= zero:
                A[kept] = A[i]
                kept += 1
        pick = wp.vec4i(0, 1, 2, 3)
        count = wp.min(kept, CONTACTS)
        if kept > CONTACTS:
            pick = quad(A, kept)
        elif cc == 2 and kept > 2:  # an edge: its two farthest points
            far = scalar(-1.0)
            for i in range(kept):
                for j in range(i + 1, kept):
                    if wp.length_sq(A[j] - A[i]) > far:
                        far = wp.length_sq(A[j] - A[i])
                        pick = wp.vec4i(i, j, 0, 0)
            count = 2
        for k in range(CONTACTS):
            if k < count:
                out[k] = wp.transpose(Rc) * (A[pick[k]] - pc)
        out[4] = wp.transpose(Rk) * (Fk[0] - pk)
        out[5] = wp.transpose(Rk) * nk
        if case == FACE_EDGE:
            out[6] = wp.transpose(R1) * normal
        else:
            out[6] = wp.transpose(R2) * normal
        out[7] = vec3(scalar(case), scalar(count), zero)
        return out

    @wp.func_grad(held)
    def adj_held(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), polygons: Polygons,
        pr1: wp.vec2i, pr2: wp.vec2i, n: vec3, adj_ret: Held,
    ):  # fmt: skip
        """Held: the features and the clipping carry no gradient (the module docstring)."""
        pass

    @wp.func
    def multicontact(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), polygons: Polygons,
        pr1: wp.vec2i, pr2: wp.vec2i, n: vec3,
    ):  # fmt: skip
        """(count, positions (CONTACTS, 3) [m, world], normals (CONTACTS, 3) (geom1 to geom2), dists (CONTACTS,) [m]):
        the pair's multi-contact along its contact normal n (the module docstring); count 0 where it has none."""
        H = held(t1, p1, R1, s1, t2, p2, R2, s2, verts, polygons, pr1, pr2, n)
        case = int(H[7, 0])
        count = int(H[7, 1])
        P = Quad()
        N = Quad()
        D = Dists()
        if case == NONE:
            return 0, P, N, D
        pk, Rk, pc, Rc = p1, R1, p2, R2
        if case == EDGE_FACE:
            pk, Rk, pc, Rc = p2, R2, p1, R1
        anchor = pk + Rk * vec3(H[4, 0], H[4, 1], H[4, 2])
        face_normal = Rk * vec3(H[5, 0], H[5, 1], H[5, 2])
        normal = R2 * vec3(H[6, 0], H[6, 1], H[6, 2])
        if case == FACE_EDGE:
            normal = R1 * vec3(H[6, 0], H[6, 1], H[6, 2])
        toward = wp.where(case == EDGE_FACE, scalar(-0.5), scalar(0.5))  # from the clipped vertex to the clipper's face
        for k in range(CONTACTS):
            if k < count:
                v = pc + Rc * vec3(H[k, 0], H[k, 1], H[k, 2])
                d = wp.dot(v - anchor, face_normal)
                P[k] = v + normal * (toward * wp.abs(d))
                N[k] = normal
                D[k] = d
        return count, P, N, D

    return types.SimpleNamespace(Polygons=Polygons, Quad=Quad, Dists=Dists, held=held, multicontact=multicontact)
