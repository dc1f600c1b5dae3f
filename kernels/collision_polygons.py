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
  of u, else the hull's edge at its vertex farthest along u whose direction is within EDGE_TOL of perpendicular to u.
MuJoCo finds the features from its EPA's last face's supports; warpdyn from the contact's normal: the same features
where the normal lies within the tolerances. MuJoCo 4.0 places tilted faces' contacts slightly differently (within
5e-6 m at 3 mrad) and may keep another quadrilateral of a polygon of more than four vertices (a cylinder's cap:
tests/test_collision_polygons.py).

Gradients: the features and the clipping are held (`held`, whose adjoint is zero): which vertices, edges and planes
make each contact, in their geoms' frames; `multicontact` makes the point again from them at the poses (a clipped
vertex moving with its geom, an edge's crossing of the clipper's plane, two of the clipper's planes' crossing dropped
onto the clipped face), and its dist and position: their exact derivatives with the features held (as kernels/collision_convex.py
holds its witnesses). A capsule's or cylinder's side is taken under the contact's normal n (GJK and EPA's, as
MuJoCo's): held there, its contacts' derivatives miss the line's turn with n (about the faces' tilt, relative).
"""

import math
import types

import warp as wp

from . import collision_box
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
QUAD_TIE = 1e-5
"""Areas (and distances) within this fraction of each other are tied (`better`)."""
TIE_ABOVE, TIE_BELOW = 1.0 + QUAD_TIE, 1.0 - QUAD_TIE
MINVAL = 1e-15
"""MuJoCo's mjMINVAL: a point within it outside a clipping plane is inside."""

NONE, EDGE, FACE = 0, 1, 2
ORIGINAL, ON_EDGE, ON_PLANES, HELD = 0, 1, 2, 3
"""A clipped point's provenance: a vertex of the clipped feature; where its edge crosses a clipping plane; on two
clipping planes (under a vertex of the clipper where they are neighbours); elsewhere (degenerate: held in the clipped
geom's frame)."""
FACE_FACE, EDGE_FACE, FACE_EDGE = 1, 2, 3
"""The cases of `held`: geom1's face clips geom2's face; geom2's face clips geom1's edge; geom1's face clips geom2's edge."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """`Polygons` (the meshes' hull polygons), `held` and `multicontact` (the module docstring) in `scalar`."""
    box = collision_box.kernels(scalar)
    vec3, mat33 = box.vec3, box.mat33
    Poly = wp.types.matrix(shape=(CLIP, 3), dtype=scalar)
    Held = wp.types.matrix(shape=(4 * CONTACTS + 8, 3), dtype=scalar)
    Codes = wp.types.vector(CLIP, int)
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
                corner = box.cyclic(a, sg * s[a], wp.where(k < 2, s[b], -s[b]), wp.where(k == 0 or k == 3, s[c], -s[c]))
                F[wp.where(sg > zero, k, 3 - k)] = p + R * corner
            return FACE, F, 4, R * box.cyclic(a, sg, zero, zero)
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
        """A mesh's feature along u (its polygons range_ = (first, count) of `polygons`), as `box_feature`: the face
        whose normal is within FACE_TOL of u, else the edge from the hull's vertex farthest along u (the support) to
        a neighbour (the previous vertex of each polygon holding it: every edge at the vertex, as MuJoCo's
        meshEdgeNormals takes them) whose direction is the most nearly perpendicular to u, within EDGE_TOL."""
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
            support = int(-1)
            height = scalar(0.0)
            for q in range(range_[0], range_[0] + range_[1]):
                for k in range(polygons.vertices[q][1]):
                    v = polygons.vertex[polygons.vertices[q][0] + k]
                    h = wp.dot(R * verts[v], u)
                    if support < 0 or h > height:
                        support = v
                        height = h
            across = scalar(EDGE_TOL)
            neighbour = int(-1)
            for q in range(range_[0], range_[0] + range_[1]):
                first, count = polygons.vertices[q][0], polygons.vertices[q][1]
                for k in range(count):
                    if polygons.vertex[first + k] == support:
                        v = polygons.vertex[first + (k + count - 1) % count]
                        edge = R * (verts[v] - verts[support])
                        length = wp.length(edge)
                        if length > scalar(MINVAL) and wp.abs(wp.dot(edge, u)) < across * length:
                            across = wp.abs(wp.dot(edge, u)) / length
                            neighbour = v
            if neighbour < 0:
                return NONE, F, 0, vec3(zero)
            F[0] = p + R * verts[wp.min(support, neighbour)]  # in the order of their indices: which end is the
            F[1] = p + R * verts[wp.max(support, neighbour)]  # support flips where the edge lies flat
            return EDGE, F, 2, vec3(zero)
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
    def common(a1: int, a2: int, b1: int, b2: int):
        """The first of a1, a2 (-1: none) that is b1 or b2, else -1."""
        if a1 >= 0 and (a1 == b1 or a1 == b2):
            return a1
        if a2 >= 0 and (a2 == b1 or a2 == b2):
            return a2
        return -1

    @wp.func
    def edges_of(kind: int, i: int, count: int):
        """The clipped feature's edges (edge e: from its vertex e to e + 1) on which a vertex of this provenance lies."""
        if kind == ORIGINAL:
            if count == 2:
                return 0, -1
            return (i + count - 1) % count, i
        if kind == ON_EDGE:
            return i, -1
        return -1, -1

    @wp.func
    def planes_of(kind: int, i: int, j: int):
        """The clipper's edges' planes (plane e: through its edge from vertex e to e + 1) on which such a vertex lies."""
        if kind == ON_EDGE:
            return j, -1
        if kind == ON_PLANES:
            return i, j
        return -1, -1

    @wp.func
    def clip(F1: Poly, c1: int, n1: vec3, F2: Poly, c2: int):
        """(F2's first c2 points cut by the planes through F1's edges perpendicular to its face (normal n1), their
        count, and each point's provenance: kind, i, j (ORIGINAL: F2's vertex i; ON_EDGE: on F2's edge i and F1's
        plane j; ON_PLANES: on F1's planes i and j; HELD: elsewhere)): MuJoCo's polygonClip, a plane at a time
        (Sutherland-Hodgman)."""
        A = F2
        kind = Codes()
        first = Codes()
        second = Codes()
        for i in range(c2):
            first[i] = i
        n = c2
        for e in range(c1):
            a = F1[e]
            pn = wp.normalize(wp.cross(F1[(e + 1) % c1] - a, n1))
            pd = wp.dot(pn, a)
            B = Poly()
            kind_b = Codes()
            first_b = Codes()
            second_b = Codes()
            m = int(0)
            for i in range(n):
                q = (i + 1) % n
                P = A[i]
                Q = A[q]
                inside1 = wp.dot(P - a, pn) > -scalar(MINVAL)
                inside2 = wp.dot(Q - a, pn) > -scalar(MINVAL)
                if inside1 and inside2:
                    if m < CLIP:
                        B[m] = Q
                        kind_b[m] = kind[q]
                        first_b[m] = first[q]
                        second_b[m] = second[q]
                        m += 1
                elif inside1 or inside2:
                    PQ = Q - P
                    den = wp.dot(pn, PQ)
                    if den != zero:
                        t = (pd - wp.dot(pn, P)) / den
                        if t >= zero and t <= scalar(1.0) and m < CLIP:
                            B[m] = P + t * PQ
                            p1, p2 = edges_of(kind[i], first[i], c2)
                            q1, q2 = edges_of(kind[q], first[q], c2)
                            edge = common(p1, p2, q1, q2)
                            kind_b[m] = HELD
                            first_b[m] = 0
                            second_b[m] = 0
                            if edge >= 0:
                                kind_b[m] = ON_EDGE
                                first_b[m] = edge
                                second_b[m] = e
                            else:
                                p1, p2 = planes_of(kind[i], first[i], second[i])
                                q1, q2 = planes_of(kind[q], first[q], second[q])
                                plane = common(p1, p2, q1, q2)
                                if plane >= 0:
                                    kind_b[m] = ON_PLANES
                                    first_b[m] = plane
                                    second_b[m] = e
                            m += 1
                    if inside2 and m < CLIP:
                        B[m] = Q
                        kind_b[m] = kind[q]
                        first_b[m] = first[q]
                        second_b[m] = second[q]
                        m += 1
            A = B
            kind, first, second = kind_b, first_b, second_b
            n = m
        return A, n, kind, first, second

    @wp.func
    def better(value: scalar, best: scalar, tiebreak: scalar, best_tiebreak: scalar, length: scalar):
        """Whether value beats best: larger by more than QUAD_TIE of it, or tied within QUAD_TIE and a tiebreak [m]
        larger by more than QUAD_TIE of length [m] (so that rounding, float32's or float64's, decides neither)."""
        if value > best * scalar(TIE_ABOVE):
            return True
        return value >= best * scalar(TIE_BELOW) and tiebreak > best_tiebreak + scalar(QUAD_TIE) * length

    @wp.func
    def quad(A: Poly, n: int, w: vec3):
        """The indices (in order) of the quadrilateral of the largest area among the vertices of the convex polygon A
        (n > 4 points): each diagonal (i, j) with the vertex on either side farthest from it; of those tied (a
        regular polygon's), the one whose vertices reach farthest along w (a direction fixed on a geom)."""
        best = wp.vec4i(0, 1, 2, 3)
        largest = scalar(-1.0)
        reach = scalar(-1.0e30)
        length = wp.length(A[n // 2] - A[0])
        for i in range(n):
            for j in range(i + 2, n):
                if j - i <= n - 2:
                    side1 = scalar(-1.0)
                    k1 = int(i + 1)
                    for k in range(i + 1, j):
                        twice = wp.length(wp.cross(A[j] - A[i], A[k] - A[i]))
                        if better(twice, side1, wp.dot(A[k], w), wp.dot(A[k1], w), length):
                            side1 = twice
                            k1 = k
                    side2 = scalar(-1.0)
                    k2 = int((j + 1) % n)
                    for k in range(j + 1, i + n):
                        twice = wp.length(wp.cross(A[j] - A[i], A[k % n] - A[i]))
                        if better(twice, side2, wp.dot(A[k % n], w), wp.dot(A[k2], w), length):
                            side2 = twice
                            k2 = k % n
                    along = wp.dot(A[i] + A[k1] + A[j] + A[k2], w)
                    if better(side1 + side2, largest, along, reach, length):
                        largest = side1 + side2
                        reach = along
                        best = wp.vec4i(i, k1, j, k2)
        return best

    @wp.func
    def local(R: mat33, p: vec3, x: vec3):
        """The world point x [m] in the frame (p, R)."""
        return wp.transpose(R) * (x - p)

    @wp.func
    def held(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), polygons: Polygons,
        pr1: wp.vec2i, pr2: wp.vec2i, n: vec3,
    ):  # fmt: skip
        """What `multicontact` evaluates, held by the adjoint. Rows 4k .. 4k + 3 for contact k, by its provenance
        (`clip`): ORIGINAL and HELD: its point in the clipped geom's frame; ON_EDGE: the clipped edge's two ends in the
        clipped geom's frame, the clipper's edge's two ends in the clipper's; ON_PLANES: the clipper's two edges' ends
        in the clipper's frame. Row 16: the clipper's face's first vertex and 17: its normal, in the clipper's frame; 18: the
        contacts' normal (geom1 to geom2) in geom1's frame (case FACE_EDGE) or geom2's; 19: the clipped face's first
        vertex and 20: its normal, in the clipped geom's frame; 21: (case, count, 0) (case NONE or count 0: no
        multi-contact); 22, 23: the provenances of contacts 0 to 2 and 3."""
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
        Fk, ck, nk, Fc, cc, nc = F1, c1, m1, F2, c2, m2
        pk, Rk, pc, Rc = p1, R1, p2, R2
        normal = -m2
        if case == EDGE_FACE:
            Fk, ck, nk, Fc, cc, nc = F2, c2, m2, F1, c1, m1
            pk, Rk, pc, Rc = p2, R2, p1, R1
        if case == FACE_EDGE:
            normal = m1
        A, na, kind, first, second = clip(Fk, ck, nk, Fc, cc)
        kept = int(0)  # those at or below the clipper's face
        for i in range(na):
            if wp.dot(A[i] - Fk[0], nk) <= zero:
                A[kept] = A[i]
                kind[kept] = kind[i]
                first[kept] = first[i]
                second[kept] = second[i]
                kept += 1
        pick = wp.vec4i(0, 1, 2, 3)
        count = wp.min(kept, CONTACTS)
        if kept > CONTACTS:
            pick = quad(A, kept, wp.normalize(Fc[1] - Fc[0]))
        elif cc == 2 and kept > 2:  # an edge: its two farthest points
            far = scalar(-1.0)
            for i in range(kept):
                for j in range(i + 1, kept):
                    if wp.length_sq(A[j] - A[i]) > far:
                        far = wp.length_sq(A[j] - A[i])
                        pick = wp.vec4i(i, j, 0, 0)
            count = 2
        if cc == 2 and count == 2 and wp.dot(A[pick[1]] - A[pick[0]], Fc[1] - Fc[0]) < zero:  # an edge's points in its order
            pick = wp.vec4i(pick[1], pick[0], 0, 0)
        kinds = wp.vec4i(0)
        for k in range(CONTACTS):
            if k < count:
                c = pick[k]
                kinds[k] = kind[c]
                if kind[c] == ORIGINAL:
                    out[4 * k] = local(Rc, pc, Fc[first[c]])
                elif kind[c] == ON_EDGE:
                    out[4 * k] = local(Rc, pc, Fc[first[c]])
                    out[4 * k + 1] = local(Rc, pc, Fc[(first[c] + 1) % cc])
                    out[4 * k + 2] = local(Rk, pk, Fk[second[c]])
                    out[4 * k + 3] = local(Rk, pk, Fk[(second[c] + 1) % ck])
                elif kind[c] == ON_PLANES:
                    out[4 * k] = local(Rk, pk, Fk[first[c]])
                    out[4 * k + 1] = local(Rk, pk, Fk[(first[c] + 1) % ck])
                    out[4 * k + 2] = local(Rk, pk, Fk[second[c]])
                    out[4 * k + 3] = local(Rk, pk, Fk[(second[c] + 1) % ck])
                else:
                    out[4 * k] = local(Rc, pc, A[c])
        out[16] = local(Rk, pk, Fk[0])
        out[17] = wp.transpose(Rk) * nk
        if case == FACE_EDGE:
            out[18] = wp.transpose(R1) * normal
        else:
            out[18] = wp.transpose(R2) * normal
        out[19] = local(Rc, pc, Fc[0])
        out[20] = wp.transpose(Rc) * nc
        out[21] = vec3(scalar(case), scalar(count), zero)
        out[22] = vec3(scalar(kinds[0]), scalar(kinds[1]), scalar(kinds[2]))
        out[23] = vec3(scalar(kinds[3]), zero, zero)
        return out

    @wp.func_grad(held)
    def adj_held(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), polygons: Polygons,
        pr1: wp.vec2i, pr2: wp.vec2i, n: vec3, adj_ret: Held,
    ):  # fmt: skip
        """Held: the features and the clipping carry no gradient (the module docstring)."""
        pass

    @wp.func
    def row(H: Held, r: int):
        return vec3(H[r, 0], H[r, 1], H[r, 2])

    @wp.func
    def multicontact(
        t1: int, p1: vec3, R1: mat33, s1: vec3, t2: int, p2: vec3, R2: mat33, s2: vec3, verts: wp.array(dtype=vec3), polygons: Polygons,
        pr1: wp.vec2i, pr2: wp.vec2i, n: vec3,
    ):  # fmt: skip
        """(count, positions (CONTACTS, 3) [m, world], normals (CONTACTS, 3) (geom1 to geom2), dists (CONTACTS,) [m]):
        the pair's multi-contact along its contact normal n (the module docstring); count 0 where it has none. Each
        point is made again at the poses from `held`'s: a clipped vertex on its geom, an edge's crossing of the
        clipper's plane, two clipper's planes' crossing dropped along its face's normal onto the clipped face."""
        H = held(t1, p1, R1, s1, t2, p2, R2, s2, verts, polygons, pr1, pr2, n)
        case = int(H[21, 0])
        count = int(H[21, 1])
        P = Quad()
        N = Quad()
        D = Dists()
        if case == NONE:
            return 0, P, N, D
        pk, Rk, pc, Rc = p1, R1, p2, R2
        if case == EDGE_FACE:
            pk, Rk, pc, Rc = p2, R2, p1, R1
        anchor = pk + Rk * row(H, 16)
        face_normal = Rk * row(H, 17)
        normal = R2 * row(H, 18)
        if case == FACE_EDGE:
            normal = R1 * row(H, 18)
        toward = wp.where(case == EDGE_FACE, scalar(-0.5), scalar(0.5))  # from the clipped vertex to the clipper's face
        for k in range(CONTACTS):
            if k < count:
                kind = int(H[22 + k // 3, k % 3])
                v = pc + Rc * row(H, 4 * k)
                if kind == ON_EDGE:
                    a = pk + Rk * row(H, 4 * k + 2)
                    plane = wp.normalize(wp.cross(pk + Rk * row(H, 4 * k + 3) - a, face_normal))
                    along = pc + Rc * row(H, 4 * k + 1) - v
                    den = wp.dot(plane, along)
                    if den != zero:
                        v = v + along * (wp.dot(plane, a - v) / den)
                elif kind == ON_PLANES:  # where the two edges' lines meet in the clipper's face, dropped onto the clipped face
                    a1 = pk + Rk * row(H, 4 * k)
                    d1 = pk + Rk * row(H, 4 * k + 1) - a1
                    a2 = pk + Rk * row(H, 4 * k + 2)
                    d2 = pk + Rk * row(H, 4 * k + 3) - a2
                    corner = a1 + d1 * (wp.dot(wp.cross(a2 - a1, d2), face_normal) / wp.dot(wp.cross(d1, d2), face_normal))
                    clipped_normal = Rc * row(H, 20)
                    v = corner + face_normal * (wp.dot(pc + Rc * row(H, 19) - corner, clipped_normal) / wp.dot(face_normal, clipped_normal))
                d = wp.dot(v - anchor, face_normal)
                P[k] = v + normal * (toward * wp.abs(d))
                N[k] = normal
                D[k] = d
        return count, P, N, D

    return types.SimpleNamespace(Polygons=Polygons, Quad=Quad, Dists=Dists, held=held, multicontact=multicontact)
