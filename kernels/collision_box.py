"""The box-box narrow phase, MuJoCo's mjc_BoxBox (engine_collision_box.c) as MuJoCo 4.0.0 runs it: a separating-axis
test over the 15 axes (3 faces of each box, 9 cross products of their edges), then a contact manifold: for a face
axis the incident box's face clipped against the reference face's rectangle (Sutherland-Hodgman), every clipped
vertex within the margin a contact, at most 8; for an edge axis one contact between the two supporting edges.

The conventions are kernels/collision_primitives.py's (poses, sizes, margin + gap, the normal from geom1 to geom2,
dist, pos midway between the surfaces, MuJoCo's contact frame and bounding-sphere filter, reused from there). MuJoCo
orders the contacts of a face manifold as the clipped polygon's vertices; all of a pair's contacts share its normal
and have no tangent. The thresholds are MuJoCo's mjBOXBOX_* of its build of the same precision. Where two of
MuJoCo's candidates tie to the last bit (two faces equally deep, an incident face equally opposed to two of the
reference's), its strict comparisons choose by rounding, here as in MuJoCo, whose products round differently (Warp's
compiled code fuses multiply-adds): coincident boxes may take either box's face, its normal opposite.
"""

import types

import warp as wp

from . import collision_primitives
from .collision_primitives import MINVAL
from .factory import factory
from .geom_types import BOX

MAX_CONTACTS = 8
"""The most contacts of a box pair: the incident face, a 4-gon, clipped by the reference face's 4 sides, has at most 8
vertices. MuJoCo would keep up to CLIP_CAPACITY, which needs rounding to part two of them by more than the
deduplication radius (DUPEPS); the first 8 are kept."""

CLIP_CAPACITY = 12
"""MuJoCo's mjBOXBOX_MAXVERT: the vertices a clipped polygon may hold, rounding's near-duplicates of its at most 8
distinct vertices included (the acceptance drops those)."""

MAXVAL = 1e10  # MuJoCo's mjMAXVAL
EDGEBIAS = 1e-6  # mjBOXBOX_EDGEBIAS: an edge axis must beat the best face axis by this relative amount
SEPEPS = {wp.float64: 1e-13, wp.float32: 1e-6}
"""mjBOXBOX_SEPEPS: the separation tests' slack, times the summed half-sizes (m/m)."""
PAREPS = {wp.float64: 1e-16, wp.float32: 1e-7}
"""mjBOXBOX_PAREPS: sin^2 of the angle between two edges below which their cross product is no axis."""
SGNEPS = {wp.float64: 1e-9, wp.float32: 1e-5}
"""mjBOXBOX_SGNEPS: a component of the edge axis below which the supporting edge is ambiguous (both are tried)."""
DUPEPS = {wp.float64: 1e-14, wp.float32: 1e-10}
"""mjBOXBOX_DUPEPS: clipped vertices closer than sqrt(DUPEPS) times the reference face's half-diagonal are one."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """`box_box` and the batch kernel `collide` in `scalar` (wp.float32 or wp.float64)."""
    primitives = collision_primitives.kernels(scalar)
    contact_frame = primitives.contact_frame
    may_touch = primitives.may_touch
    vec3 = primitives.vec3
    mat33 = primitives.mat33
    vec8 = wp.types.vector(MAX_CONTACTS, scalar)
    mat83 = wp.types.matrix((MAX_CONTACTS, 3), scalar)
    polygon = wp.types.matrix((CLIP_CAPACITY, 3), scalar)

    @wp.func
    def cyclic(a: int, za: scalar, zb: scalar, zc: scalar):
        """The vector with component a = za, (a + 1) % 3 = zb, (a + 2) % 3 = zc."""
        if a == 0:
            return vec3(za, zb, zc)
        if a == 1:
            return vec3(zc, za, zb)
        return vec3(zb, zc, za)

    @wp.func
    def column(M: mat33, j: int):
        """Column j of M."""
        return vec3(M[0, j], M[1, j], M[2, j])

    @wp.func
    def flip(x: scalar, negate: bool):
        """-x where negate, x otherwise."""
        return wp.where(negate, -x, x)

    @wp.func
    def edge_axis(rot: mat33, i: int, j: int):
        """e_i x (box2's axis j), box1's frame, unnormalized: its component i is 0."""
        return cyclic(i, scalar(0.0), -rot[(i + 2) % 3, j], rot[(i + 1) % 3, j])

    @wp.func
    def separating_axis(rot: mat33, pos21: vec3, pos12: vec3, size1: vec3, size2: vec3, septol: scalar):
        """mjc_BoxBox's stage 1: the axis of greatest separation (code 0..2 box1's face, 3..5 box2's, 6 + 3 i + j box1's
        edge i x box2's edge j; an edge beats the faces by EDGEBIAS) and the best face axis, with their separations
        (m); code -1 where an axis separates the boxes by more than septol. rot: box2's axes in box1's frame (columns);
        pos21, pos12: each box's center in the other's frame (m)."""
        sep_best = scalar(-MAXVAL)
        code = int(-1)
        for i in range(3):
            radius2 = wp.abs(rot[i, 0]) * size2[0] + wp.abs(rot[i, 1]) * size2[1] + wp.abs(rot[i, 2]) * size2[2]
            sep = wp.abs(pos21[i]) - size1[i] - radius2
            if sep > septol:
                return -1, -1, sep, sep
            if sep > sep_best:
                sep_best = sep
                code = i
        for j in range(3):
            radius1 = wp.abs(rot[0, j]) * size1[0] + wp.abs(rot[1, j]) * size1[1] + wp.abs(rot[2, j]) * size1[2]
            sep = wp.abs(pos12[j]) - size2[j] - radius1
            if sep > septol:
                return -1, -1, sep, sep
            if sep > sep_best:
                sep_best = sep
                code = 3 + j
        sep_face = sep_best
        code_face = code
        for i in range(3):
            i1 = (i + 1) % 3
            i2 = (i + 2) % 3
            for j in range(3):
                j1 = (j + 1) % 3
                j2 = (j + 2) % 3
                ax1 = -rot[i2, j]
                ax2 = rot[i1, j]
                norm2 = ax1 * ax1 + ax2 * ax2
                if norm2 >= scalar(wp.static(PAREPS[scalar])):  # else nearly parallel edges: no axis
                    inv = scalar(1.0) / wp.sqrt(norm2)
                    ax1 = ax1 * inv
                    ax2 = ax2 * inv
                    radius1 = size1[i1] * wp.abs(ax1) + size1[i2] * wp.abs(ax2)
                    b1 = ax1 * rot[i1, j1] + ax2 * rot[i2, j1]
                    b2 = ax1 * rot[i1, j2] + ax2 * rot[i2, j2]
                    radius2 = size2[j1] * wp.abs(b1) + size2[j2] * wp.abs(b2)
                    sep = wp.abs(ax1 * pos21[i1] + ax2 * pos21[i2]) - radius1 - radius2
                    if sep > septol:
                        return -1, -1, sep, sep
                    if sep - scalar(EDGEBIAS) * wp.abs(sep) > sep_best and sep > sep_face:
                        sep_best = sep
                        code = 6 + 3 * i + j
        return code, code_face, sep_best, sep_face

    @wp.func
    def prefer_face(rot: mat33, code: int, code_face: int, sep_best: scalar, sep_face: scalar):
        """mjc_BoxBox's substitution: an edge axis within ~8 degrees of the best face axis (|cos| > 0.99) that beats it
        by less than 5% of the face's depth gives way to the face (its manifold of several points)."""
        if code < 6:
            return code
        axis = edge_axis(rot, (code - 6) // 3, (code - 6) % 3)
        axis = axis * (scalar(1.0) / wp.sqrt(wp.dot(axis, axis)))  # mju_normalize3 (|axis|^2 >= PAREPS)
        face_dot = scalar(0.0)
        if code_face < 3:
            face_dot = wp.abs(axis[code_face])
        else:
            face_dot = wp.abs(wp.dot(axis, column(rot, code_face - 3)))
        if face_dot > scalar(0.99) and sep_best < sep_face + scalar(0.05) * wp.abs(sep_face) + scalar(MINVAL):
            return code_face
        return code

    @wp.func
    def edge_witness(rot: mat33, pos21: vec3, size1: vec3, size2: vec3, axis: vec3, a2: vec3, i: int, j: int,
                     flip1: int, flip2: int):
        """The nearest points (box1's frame, m) of box1's edge along e_i and box2's along its axis j, each at the
        corner supporting `axis` (box1 along +axis, box2 along -axis; a2: axis in box2's frame), the corner's
        component flip1 (flip2 for box2's) flipped where >= 0; mjc_BoxBox's clamped segment solution."""
        i1 = (i + 1) % 3
        i2 = (i + 2) % 3
        j1 = (j + 1) % 3
        j2 = (j + 2) % 3
        c11 = flip(wp.where(axis[i1] >= scalar(0.0), size1[i1], -size1[i1]), flip1 == i1)
        c12 = flip(wp.where(axis[i2] >= scalar(0.0), size1[i2], -size1[i2]), flip1 == i2)
        cc1 = flip(wp.where(a2[j1] >= scalar(0.0), -size2[j1], size2[j1]), flip2 == j1)
        cc2 = flip(wp.where(a2[j2] >= scalar(0.0), -size2[j2], size2[j2]), flip2 == j2)
        c2 = rot * cyclic(j, scalar(0.0), cc1, cc2) + pos21
        d2 = column(rot, j)
        b = d2[i]
        denom = scalar(1.0) - b * b
        e = c2 - cyclic(i, scalar(0.0), c11, c12)
        d1e = e[i]
        d2e = wp.dot(d2, e)
        s = scalar(0.0)
        if denom >= scalar(MINVAL):
            s = (d1e - b * d2e) / denom
        s = wp.clamp(s, -size1[i], size1[i])
        t = wp.clamp(b * s - d2e, -size2[j], size2[j])
        s = wp.clamp(d1e + b * t, -size1[i], size1[i])
        return cyclic(i, s, c11, c12), c2 + d2 * t

    @wp.func
    def edge_contact(pos1: vec3, R1: mat33, rot: mat33, pos21: vec3, size1: vec3, size2: vec3, code: int,
                     septol: scalar):
        """mjc_BoxBox's stage 2a: the edge axis code (box1's edge i x box2's edge j), oriented from box1 to box2, and
        its supporting edges' nearest points (an ambiguous corner, an axis component below SGNEPS, tried both
        ways; the nearest pair kept, the first of equals). Returns (count 0 or 1, the midpoint (world, m), the normal
        (world), the witness points' distance along the axis (m))."""
        i = (code - 6) // 3
        j = (code - 6) % 3
        axis = edge_axis(rot, i, j)
        axis = axis * (scalar(1.0) / wp.sqrt(wp.dot(axis, axis)))
        if wp.dot(axis, pos21) < scalar(0.0):
            axis = -axis
        a2 = wp.transpose(rot) * axis
        ambig = scalar(wp.static(SGNEPS[scalar]))
        amb1 = wp.where(wp.abs(axis[(i + 1) % 3]) < ambig, (i + 1) % 3, wp.where(wp.abs(axis[(i + 2) % 3]) < ambig, (i + 2) % 3, -1))
        amb2 = wp.where(wp.abs(a2[(j + 1) % 3]) < ambig, (j + 1) % 3, wp.where(wp.abs(a2[(j + 2) % 3]) < ambig, (j + 2) % 3, -1))
        best = scalar(MAXVAL)
        choice = int(0)
        for v in range(4):  # v // 2 flips box1's ambiguous component, v % 2 box2's
            if (v // 2 == 0 or amb1 >= 0) and (v % 2 == 0 or amb2 >= 0):
                p1, p2 = edge_witness(rot, pos21, size1, size2, axis, a2, i, j, wp.where(v // 2 == 1, amb1, -1), wp.where(v % 2 == 1, amb2, -1))
                gap2 = wp.length_sq(p2 - p1)
                if gap2 < best:
                    best = gap2
                    choice = v
        w1, w2 = edge_witness(rot, pos21, size1, size2, axis, a2, i, j, wp.where(choice // 2 == 1, amb1, -1), wp.where(choice % 2 == 1, amb2, -1))
        dist = wp.dot(w2 - w1, axis)
        return wp.where(dist > septol, 0, 1), R1 * ((w1 + w2) * scalar(0.5)) + pos1, R1 * axis, dist

    @wp.func
    def clip(n: int, poly: polygon, coord: int, sign: scalar, limit: scalar):
        """The polygon's first n vertices (x, y, z rows, z interpolated along) clipped to sign * v[coord] <= limit
        (MuJoCo's clipHalfPlane: each inside vertex, then the crossing of each edge that strictly crosses)."""
        out = polygon()
        m = int(0)
        for k in range(CLIP_CAPACITY):
            if k < n:
                p = poly[k]
                q = poly[wp.where(k + 1 == n, 0, k + 1)]
                dp = sign * p[coord] - limit
                dq = sign * q[coord] - limit
                if dp <= scalar(0.0) and m < CLIP_CAPACITY:
                    out[m] = p
                    m += 1
                if ((dp < scalar(0.0) and dq > scalar(0.0)) or (dp > scalar(0.0) and dq < scalar(0.0))) and m < CLIP_CAPACITY:
                    out[m] = p + (q - p) * (dp / (dp - dq))
                    m += 1
        return m, out

    @wp.func
    def duplicate(accepted: mat83, count: int, v: vec3, dupe2: scalar):
        """Whether v's (x, y) lies within sqrt(dupe2) of one of the first `count` accepted vertices'."""
        for q in range(MAX_CONTACTS):
            if q < count:
                dx = accepted[q, 0] - v[0]
                dy = accepted[q, 1] - v[1]
                if dx * dx + dy * dy < dupe2:
                    return True
        return False

    @wp.func
    def face_contacts(pos1: vec3, R1: mat33, size1: vec3, pos2: vec3, R2: mat33, size2: vec3, rot: mat33,
                      pos21: vec3, pos12: vec3, code: int, margin: scalar):
        """mjc_BoxBox's stage 2b: the face axis `code`'s box is the reference, the other's face most opposed to it
        the incident face; its corners in the reference face's coordinates (x, y along the face's other two axes,
        z the height above the face, m) clipped to the face's rectangle; each vertex with z <= margin (near-duplicates
        dropped) a contact midway between the face and the vertex, dist z, the normal the face's, from geom1 to
        geom2. Returns (count, positions (world, m), normals, dists (m))."""
        ref1 = code < 3
        a = wp.where(ref1, code, code - 3)
        size_ref = size1
        size_inc = size2
        pos_ref = pos1
        R_ref = R1
        center = pos21  # the incident box's center in the reference frame
        rinc = rot  # the incident box's axes in the reference frame (columns)
        if not ref1:
            size_ref = size2
            size_inc = size1
            pos_ref = pos2
            R_ref = R2
            center = pos12
            rinc = wp.transpose(rot)
        sgn = wp.where(center[a] >= scalar(0.0), scalar(1.0), scalar(-1.0))
        b = int(0)
        for k in range(1, 3):
            if wp.abs(rinc[a, k]) > wp.abs(rinc[a, b]):
                b = k
        tinc = wp.where(sgn * rinc[a, b] > scalar(0.0), scalar(-1.0), scalar(1.0))
        ax = (a + 1) % 3
        ay = (a + 2) % 3
        mid = center + column(rinc, b) * (tinc * size_inc[b])
        du = column(rinc, (b + 1) % 3) * size_inc[(b + 1) % 3]
        dv = column(rinc, (b + 2) % 3) * size_inc[(b + 2) % 3]
        mid = vec3(mid[ax], mid[ay], sgn * mid[a] - size_ref[a])
        du = vec3(du[ax], du[ay], sgn * du[a])
        dv = vec3(dv[ax], dv[ay], sgn * dv[a])
        poly = polygon()
        poly[0] = mid + du + dv
        poly[1] = mid - du + dv
        poly[2] = mid - du - dv
        poly[3] = mid + du - dv
        n = int(4)
        for c in range(4):  # x <= sx, -x <= sx, y <= sy, -y <= sy
            n, poly = clip(n, poly, c // 2, wp.where(c % 2 == 0, scalar(1.0), scalar(-1.0)), size_ref[wp.where(c < 2, ax, ay)])
        dupe2 = scalar(wp.static(DUPEPS[scalar])) * (size_ref[ax] * size_ref[ax] + size_ref[ay] * size_ref[ay])
        normal = column(R_ref, a) * wp.where(ref1, sgn, -sgn)
        accepted = mat83()
        P = mat83()
        N = mat83()
        D = vec8()
        count = int(0)
        for k in range(CLIP_CAPACITY):
            if k < n:
                v = poly[k]
                if v[2] <= margin and count < MAX_CONTACTS and not duplicate(accepted, count, v, dupe2):
                    accepted[count] = v
                    P[count] = R_ref * cyclic(a, sgn * (size_ref[a] + scalar(0.5) * v[2]), v[0], v[1]) + pos_ref
                    N[count] = normal
                    D[count] = v[2]
                    count += 1
        return count, P, N, D

    @wp.func
    def box_box(pos1: vec3, R1: mat33, size1: vec3, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Box-box, MuJoCo's mjc_BoxBox: the separating-axis test, then a face's clipped manifold (at most 8 contacts,
        in the clipped polygon's order) or an edge pair's one contact. Poses, sizes (half-sizes, m) and margin as
        kernels/collision_primitives.py's pairs take them; returns (count, positions (MAX_CONTACTS, 3) (world, m),
        normals (MAX_CONTACTS, 3) from box1 to box2, dists (MAX_CONTACTS,) (m))."""
        rot = wp.transpose(R1) * R2
        pos21 = wp.transpose(R1) * (pos2 - pos1)
        pos12 = wp.transpose(R2) * (pos1 - pos2)
        septol = margin + scalar(wp.static(SEPEPS[scalar])) * (size1[0] + size1[1] + size1[2] + size2[0] + size2[1] + size2[2])
        code, code_face, sep_best, sep_face = separating_axis(rot, pos21, pos12, size1, size2, septol)
        code = prefer_face(rot, code, code_face, sep_best, sep_face)
        if code < 0:
            return 0, mat83(), mat83(), vec8()
        if code < 6:
            return face_contacts(pos1, R1, size1, pos2, R2, size2, rot, pos21, pos12, code, margin)
        P = mat83()
        N = mat83()
        D = vec8()
        n, p, normal, d = edge_contact(pos1, R1, rot, pos21, size1, size2, code, septol)
        P[0] = p
        N[0] = normal
        D[0] = d
        return n, P, N, D

    @wp.kernel(module="unique")
    def collide(
        pos1: wp.array(dtype=vec3), R1: wp.array(dtype=mat33), size1: wp.array(dtype=vec3),
        pos2: wp.array(dtype=vec3), R2: wp.array(dtype=mat33), size2: wp.array(dtype=vec3),
        margin: wp.array(dtype=scalar),
        # outputs
        count: wp.array(dtype=int), position: wp.array2d(dtype=vec3), frame: wp.array2d(dtype=mat33), dist: wp.array2d(dtype=scalar),
    ):  # fmt: skip
        """One box pair per thread i, as collision_primitives' `collide` writes a pair: count[i] contacts, their
        positions (N, MAX_CONTACTS) vec3 [m, world], MuJoCo's contact frames (rows: the normal from box1 to box2,
        two tangents) and distances [m]; none where MuJoCo's bounding-sphere filter (`may_touch`) drops the pair."""
        i = wp.tid()
        n, P, N, D = box_box(pos1[i], R1[i], size1[i], pos2[i], R2[i], size2[i], margin[i])
        if not may_touch(BOX, pos1[i], R1[i], size1[i], BOX, pos2[i], size2[i], margin[i]):
            n = 0
        for k in range(MAX_CONTACTS):
            if k < n:
                position[i, k] = P[k]
                frame[i, k] = contact_frame(N[k], vec3(scalar(0.0)))
                dist[i, k] = D[k]
        count[i] = n

    return types.SimpleNamespace(scalar=scalar, vec3=vec3, mat33=mat33, cyclic=cyclic, box_box=box_box, collide=collide)
