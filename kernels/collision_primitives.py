"""The narrow phase between primitive geoms, as MuJoCo's mj_collision computes it (engine_collision_primitive.c,
engine_collision_box.c, engine_collision_convex.c's plane-ellipsoid), one `@wp.func` per pair of geom types, built
once per scalar type.

MuJoCo's conventions, kept so that the results compare with its d.contact directly:
- A geom's pose is its world position p (vec3, m) and rotation R (mat33, world from geom: column j is the geom's
  axis j; MuJoCo's geom_xmat as a 3x3 matrix). Sizes are MuJoCo's geom_size (m): a sphere's radius; a capsule's and
  a cylinder's radius and half-length along their z axis; a box's half-sizes; an ellipsoid's radii. A plane is
  infinite (its size is not used), its z axis its normal, its surface through p.
- A pair is ordered by type (MuJoCo's mjtGeom: PLANE 0 < SPHERE 2 < CAPSULE 3 < ELLIPSOID 4 < CYLINDER 5 < BOX 6),
  geom1's type <= geom2's; the unit normal points from geom1 into geom2 (geom2 is pushed along +normal). It is the
  first row of MuJoCo's contact frame; `contact_frame` completes the frame as mju_makeFrame does (its second row is
  the capsule's axis for plane-capsule contacts, MuJoCo's only tangent, and is chosen from the normal otherwise).
- dist (m): the signed distance between the surfaces along the normal, negative when they penetrate. pos (m, world):
  the point midway between the two surfaces (MuJoCo's mjContact.pos).
- margin (m): what MuJoCo passes its collision functions, the pair's margin + gap (the sums of both geoms'
  geom_margin and geom_gap, or an explicit pair's). A contact is reported when dist <= margin + gap; MuJoCo keeps
  those with dist >= margin in d.contact (includemargin = margin) but excludes them from the constraints.
- A pair's function returns (count, positions, normals, dists) with a fixed size: the most contacts the pair gives
  (1 with a sphere or an ellipsoid, 2 for plane-capsule, capsule-capsule and capsule-box, 4 for plane-box and
  plane-cylinder); contacts 0 .. count-1 are valid, in MuJoCo's order. Single-contact pairs return a vec3 position
  and normal and a scalar dist. MuJoCo calls them only for pairs whose bounding spheres meet (`may_touch`).
Pairs: plane with sphere, capsule, box, cylinder, ellipsoid; sphere with sphere, capsule, cylinder, box; capsule with
capsule, box. Box-box (MuJoCo's mjc_BoxBox, up to 8 contacts) is kernels/collision_box.py's; not here: the pairs MuJoCo collides with its general convex
solver (mjc_Convex: capsule-cylinder, ellipsoids and cylinders with anything but a plane, meshes).
The thresholds are MuJoCo's (mjMINVAL = 1e-15, as in its single-precision build too), but for PARALLEL_SQ and
CONCENTRIC in float32 and the capsule-capsule parallel test (see their docstrings).
"""

import types
from typing import Any

import warp as wp

from .factory import factory
from .geom_types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, PLANE, SPHERE  # a mesh's size here: (its bounding radius, 0, 0)
from .spatial import spatial

MAX_CONTACTS = 4
"""The most contacts a pair gives (plane-box, plane-cylinder): the size of `collide`'s outputs' second axis."""

MINVAL = 1e-15  # MuJoCo's mjMINVAL
PARALLEL_SQ = {wp.float64: MINVAL * MINVAL, wp.float32: 1e-12}
"""sin^2 of the angle under which plane-cylinder takes a cylinder's caps as parallel to the plane and its rim point
along the cylinder's x axis: MuJoCo's mjMINVAL^2 in float64; in float32 rounding leaves sin ~ 1e-7 of an exactly
flat cylinder, whose rim point would then follow the rounding (MuJoCo too makes some thresholds depend on its
precision: box-box's mjBOXBOX_*). The rim point's depth is off by at most 2 r 1e-6 for it."""
CONCENTRIC = {wp.float64: MINVAL, wp.float32: 1e-6}
"""The distance (m) under which sphere-sphere takes two centers as one and its normal from the spheres' frames:
MuJoCo's mjMINVAL in float64; in float32, rounding leaves ~1e-7 m between points that are one (the nearest points
of two crossing capsules), whose direction is noise."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The pairs' functions and the batch kernel `collide` in `scalar` (wp.float32 or wp.float64)."""
    sp = spatial(scalar)
    vec2, vec3, vec4, mat33 = wp.types.vector(2, scalar), sp.vec3, sp.vec4, sp.mat33
    mat23 = wp.types.matrix((2, 3), scalar)
    mat43 = wp.types.matrix((4, 3), scalar)

    @wp.func
    def axis_of(R: mat33, j: int):
        """Column j of R: the geom's axis j in world coordinates."""
        return vec3(R[0, j], R[1, j], R[2, j])

    @wp.func
    def root(x: scalar):
        """sqrt(x) for x >= 0, its adjoint 0 rather than NaN at 0 (where the values using it do not depend on x)."""
        if x > scalar(0.0):
            return wp.sqrt(x)
        return scalar(0.0)

    @wp.func
    def normalize(v: vec3):
        """(v / |v|, |v|); (1, 0, 0) where |v| < mjMINVAL: MuJoCo's mju_normalize3."""
        norm = root(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
        if norm < scalar(MINVAL):
            return vec3(scalar(1.0), scalar(0.0), scalar(0.0)), norm
        return v * (scalar(1.0) / norm), norm

    @wp.func
    def unit(v: vec3):
        """v / |v| as mju_normalize3 makes it."""
        u, norm = normalize(v)
        return u

    @wp.func
    def contact_frame(normal: vec3, tangent: vec3):
        """MuJoCo's contact frame (mju_makeFrame): rows x = the normal (normalized), y = the tangent made orthogonal
        to x (where |tangent| < 0.5: world y, or world z where |x_y| >= 0.5), z = x cross y."""
        x = unit(normal)
        y = tangent
        if wp.dot(y, y) < scalar(0.25):
            y = vec3(scalar(0.0), scalar(0.0), scalar(1.0))
            if x[1] < scalar(0.5) and x[1] > scalar(-0.5):
                y = vec3(scalar(0.0), scalar(1.0), scalar(0.0))
        y = unit(y - x * wp.dot(x, y))
        return wp.matrix_from_rows(x, y, wp.cross(x, y))

    @wp.func
    def gram(ma: scalar, mb: scalar, mc: scalar, a: vec3, b: vec3):
        """ma mc - mb^2 = |a x b|^2 for ma = a.a, mb = -a.b, mc = b.b, the determinant of the nearest points of two
        segments: MuJoCo's product form in float64; in float32 the cross product's, as the product form cancels to
        noise of 1e-7 ma mc, from which nearly parallel segments would be solved (and parallel ones not seen)."""
        if wp.static(scalar == wp.float32):
            return wp.length_sq(wp.cross(a, b))
        return ma * mc - mb * mb

    # --- planes (MuJoCo's mjc_Plane*) ------------------------------------------------------------------------

    @wp.func
    def plane_point(plane_pos: vec3, normal: vec3, center: vec3, radius: scalar, margin: scalar):
        """A sphere (center, radius) against the plane through plane_pos with unit normal `normal` (mjraw_PlaneSphere)."""
        cdist = wp.dot(center - plane_pos, normal)
        if cdist > margin + radius:
            return 0, vec3(scalar(0.0)), normal, scalar(0.0)
        dist = cdist - radius
        return 1, center + normal * (-dist / scalar(2.0) - radius), normal, dist

    @wp.func
    def plane_sphere(pos1: vec3, R1: mat33, pos2: vec3, radius: scalar, margin: scalar):
        """Plane-sphere, MuJoCo's mjc_PlaneSphere: at most 1 contact."""
        return plane_point(pos1, axis_of(R1, 2), pos2, radius, margin)

    @wp.func
    def plane_capsule(pos1: vec3, R1: mat33, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Plane-capsule, MuJoCo's mjc_PlaneCapsule: the capsule's two end spheres (the +z end first), at most 2
        contacts (2 for a capsule lying on the plane)."""
        segment = size2[1] * axis_of(R2, 2)
        n1, p1, normal, d1 = plane_point(pos1, axis_of(R1, 2), pos2 + segment, size2[0], margin)
        n2, p2, normal2, d2 = plane_point(pos1, axis_of(R1, 2), pos2 - segment, size2[0], margin)
        if n1 == 0:
            p1 = p2
            d1 = d2
        return n1 + n2, wp.matrix_from_rows(p1, p2), wp.matrix_from_rows(normal, normal2), vec2(d1, d2)

    @wp.func
    def plane_box(pos1: vec3, R1: mat33, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Plane-box, MuJoCo's mjc_PlaneBox: the first 4 corners (in the order of their bits x, y, z) below the
        margin and on the plane's side of the box's center, at most 4 contacts."""
        normal = axis_of(R1, 2)
        dist = wp.dot(pos2 - pos1, normal)
        P = mat43()
        N = mat43()
        D = vec4()
        count = int(0)
        for i in range(8):
            local = vec3(
                wp.where((i & 1) != 0, size2[0], -size2[0]),
                wp.where((i & 2) != 0, size2[1], -size2[1]),
                wp.where((i & 4) != 0, size2[2], -size2[2]),
            )
            corner = R2 * local
            ldist = wp.dot(normal, corner)
            if count < 4 and dist + ldist <= margin and ldist <= scalar(0.0):
                d = dist + ldist
                P[count] = (corner + pos2) + normal * (-d / scalar(2.0))
                N[count] = normal
                D[count] = d
                count += 1
        return count, P, N, D

    @wp.func
    def plane_cylinder(pos1: vec3, R1: mat33, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Plane-cylinder, MuJoCo's mjc_PlaneCylinder: the deepest point of the rim of the cap nearer the plane, the
        same point of the other cap, and two more points of the nearer rim a third of a turn away; at most 4. In
        float32 the direction of the deepest rim point is taken in the cylinder's frame: MuJoCo's world-frame
        difference leaves rounding of 1e-7 along the normal, which, for a cylinder within 1e-3 rad of standing
        flat, moves the rim point's depth by more than 1e-5 m."""
        normal = axis_of(R1, 2)
        axis = axis_of(R2, 2)
        prjaxis = wp.dot(normal, axis)
        if prjaxis > scalar(0.0):  # the axis points towards the plane
            axis = -axis
            prjaxis = -prjaxis
        dist0 = wp.dot(pos2 - pos1, normal)
        vec = axis * prjaxis - normal  # -normal without its component along the axis
        if wp.static(scalar == wp.float32):  # that component dropped in the cylinder's frame, exactly
            local = wp.transpose(R2) * normal
            vec = -(R2 * vec3(local[0], local[1], scalar(0.0)))
        len_sqr = wp.dot(vec, vec)
        if len_sqr >= scalar(wp.static(PARALLEL_SQ[scalar])):
            vec = vec * (size2[0] / wp.sqrt(len_sqr))
        else:  # the caps are parallel to the plane: the cylinder's x axis
            vec = axis_of(R2, 0) * size2[0]
        prjvec = wp.dot(vec, normal)
        axis = axis * size2[1]
        prjaxis = prjaxis * size2[1]
        P = mat43()
        N = mat43()
        D = vec4()
        d = dist0 + prjaxis + prjvec
        if d > margin:
            return 0, P, N, D
        P[0] = ((pos2 + vec) + axis) + normal * (-d * scalar(0.5))
        N[0] = normal
        D[0] = d
        count = int(1)
        d = dist0 - prjaxis + prjvec
        if d <= margin:
            P[1] = ((pos2 + vec) - axis) + normal * (-d * scalar(0.5))
            N[1] = normal
            D[1] = d
            count = 2
        d = dist0 + prjaxis - prjvec * scalar(0.5)
        if d <= margin:
            side = unit(wp.cross(vec, axis)) * (size2[0] * wp.sqrt(scalar(3.0)) / scalar(2.0))
            P[count] = (((pos2 + side) + axis) + vec * scalar(-0.5)) + normal * (-d * scalar(0.5))
            P[count + 1] = (((pos2 - side) + axis) + vec * scalar(-0.5)) + normal * (-d * scalar(0.5))
            N[count] = normal
            N[count + 1] = normal
            D[count] = d
            D[count + 1] = d
            count += 2
        return count, P, N, D

    @wp.func
    def plane_ellipsoid(pos1: vec3, R1: mat33, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Plane-ellipsoid, MuJoCo's mjc_PlaneConvex with its ellipsoid support point (mjccd_support): the
        ellipsoid's point deepest along -normal; at most 1 contact."""
        normal = axis_of(R1, 2)
        local = wp.transpose(R2) * (-normal)
        support = wp.cw_mul(unit(wp.cw_mul(local, size2)), size2)
        point = R2 * support + pos2
        dist = wp.dot(normal, point - pos1)
        if dist > margin:
            return 0, vec3(scalar(0.0)), normal, scalar(0.0)
        return 1, point + normal * (scalar(-0.5) * dist), normal, dist

    # --- spheres and capsules (MuJoCo's mjc_Sphere*, mjc_CapsuleCapsule) -------------------------------------

    @wp.func
    def sphere_sphere(pos1: vec3, R1: mat33, r1: scalar, pos2: vec3, R2: mat33, r2: scalar, margin: scalar):
        """Sphere-sphere, MuJoCo's mjraw_SphereSphere: at most 1 contact. Concentric spheres (centers closer than
        CONCENTRIC) take the normal z1 x z2 of their frames' z axes (1, 0, 0 where those are parallel)."""
        dif = pos1 - pos2
        cdist_sqr = wp.dot(dif, dif)
        min_dist = margin + r1 + r2
        if cdist_sqr > min_dist * min_dist:
            return 0, vec3(scalar(0.0)), vec3(scalar(0.0)), scalar(0.0)
        dist = root(cdist_sqr) - r1 - r2
        normal, length = normalize(pos2 - pos1)
        if length < scalar(wp.static(CONCENTRIC[scalar])):
            normal = unit(wp.cross(axis_of(R1, 2), axis_of(R2, 2)))
        return 1, normal * (r1 + dist / scalar(2.0)) + pos1, normal, dist

    @wp.func
    def sphere_capsule(pos1: vec3, R1: mat33, r1: scalar, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Sphere-capsule, MuJoCo's mjraw_SphereCapsule: the sphere against the sphere of the capsule's radius at
        the point of its segment nearest the sphere's center; at most 1 contact."""
        axis = axis_of(R2, 2)
        x = wp.clamp(wp.dot(axis, pos1 - pos2), -size2[1], size2[1])
        return sphere_sphere(pos1, R1, r1, axis * x + pos2, R2, size2[0], margin)

    @wp.func
    def sphere_cylinder(pos1: vec3, R1: mat33, r1: scalar, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Sphere-cylinder, MuJoCo's mjc_SphereCylinder: against the side (a sphere on the axis), a cap (a plane) or
        the rim (a point), whichever the sphere's center faces (a center inside: the nearer of side and cap); at
        most 1 contact."""
        radius = size2[0]
        height = size2[1]
        axis = axis_of(R2, 2)
        vec = pos1 - pos2
        x = wp.dot(axis, vec)
        a_proj = axis * x
        p_proj = vec - a_proj
        p_proj_sqr = wp.dot(p_proj, p_proj)
        side = wp.abs(x) < height
        cap = p_proj_sqr < radius * radius
        if side and cap:  # the center is inside the cylinder
            if height - wp.abs(x) < radius - root(p_proj_sqr):
                side = False
            else:
                cap = False
        if side:
            return sphere_sphere(pos1, R1, r1, a_proj + pos2, R2, radius, margin)
        if cap:
            cap_normal = axis
            if x <= scalar(0.0):
                cap_normal = -axis
            n, pos, normal, dist = plane_point(pos2 + axis * wp.where(x > scalar(0.0), height, -height), cap_normal, pos1, r1, margin)
            return n, pos, -normal, dist
        rim = axis * wp.where(x > scalar(0.0), height, -height) + p_proj * (radius / wp.sqrt(p_proj_sqr)) + pos2
        return sphere_sphere(pos1, R1, r1, rim, R2, scalar(0.0), margin)

    @wp.func
    def capsule_capsule(pos1: vec3, R1: mat33, size1: vec3, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Capsule-capsule, MuJoCo's mjraw_CapsuleCapsule as MuJoCo 4.0.0 runs it: spheres at the segments' nearest
        points, at most 2 contacts. Axes within 1e-4 rad of parallel (|axis1 x axis2| < 1e-4 |axis1| |axis2|, the
        threshold MuJoCo 4.0.0 shows) give a contact at each end of the segments' overlap along axis 1, the lower
        end first: the end of whichever segment bounds the overlap there against its nearest point of the other
        (both ends the same pair where the segments do not overlap). That parallel case is MuJoCo 4.0.0's as measured
        (its source is newer than the 3.12 one at hand, which tries the ends x1 = +-1 first, det < mjMINVAL)."""
        axis1 = axis_of(R1, 2) * size1[1]
        axis2 = axis_of(R2, 2) * size2[1]
        dif = pos1 - pos2
        ma = wp.dot(axis1, axis1)
        mb = -wp.dot(axis1, axis2)
        mc = wp.dot(axis2, axis2)
        u = -wp.dot(axis1, dif)
        v = wp.dot(axis2, dif)
        det = gram(ma, mb, mc, axis1, axis2)
        one = scalar(1.0)
        P = mat23()
        N = mat23()
        D = vec2()
        if wp.length_sq(wp.cross(axis1, axis2)) >= scalar(1e-8) * ma * mc:
            x1 = (mc * u - mb * v) / det
            x2 = (ma * v - mb * u) / det
            if x1 > one:
                x1 = one
                x2 = (v - mb) / mc
            elif x1 < -one:
                x1 = -one
                x2 = (v + mb) / mc
            if x2 > one:
                x2 = one
                x1 = wp.clamp((u - mb) / ma, -one, one)
            elif x2 < -one:
                x2 = -one
                x1 = wp.clamp((u + mb) / ma, -one, one)
            n, p, nrm, d = sphere_sphere(axis1 * x1 + pos1, R1, size1[0], axis2 * x2 + pos2, R2, size2[0], margin)
            P[0] = p
            N[0] = nrm
            D[0] = d
            return n, P, N, D
        e_plus = (u - mb) / ma  # segment 2's ends x2 = +1, -1 projected on segment 1
        e_minus = (u + mb) / ma
        low2 = wp.where(e_plus < e_minus, one, -one)  # segment 2's end lower along axis 1
        count = int(0)
        for end in range(2):  # the overlap's lower end (s = -1), then its upper end (s = 1)
            s = wp.where(end == 0, -one, one)
            e = wp.where(end == 0, wp.min(e_plus, e_minus), wp.max(e_plus, e_minus))
            if s * e < one:  # segment 2's end bounds the overlap there: against its nearest point of segment 1
                c1 = axis1 * wp.clamp(e, -one, one) + pos1
                c2 = pos2 + axis2 * wp.where(end == 0, low2, -low2)
            else:  # segment 1's end: against its nearest point of segment 2
                c1 = pos1 + axis1 * s
                c2 = axis2 * wp.clamp((v - s * mb) / mc, -one, one) + pos2
            n, p, nrm, d = sphere_sphere(c1, R1, size1[0], c2, R2, size2[0], margin)
            if n > 0:
                P[count] = p
                N[count] = nrm
                D[count] = d
                count += 1
        return count, P, N, D

    # --- boxes (MuJoCo's engine_collision_box.c) ---------------------------------------------------------------

    @wp.func
    def sphere_box(pos1: vec3, R1: mat33, r1: scalar, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Sphere-box, MuJoCo's mjraw_SphereBox: the box's point nearest the sphere's center; a center inside the
        box pushes out through the nearest face; at most 1 contact."""
        center = wp.transpose(R2) * (pos1 - pos2)
        clamped = vec3(
            wp.clamp(center[0], -size2[0], size2[0]),
            wp.clamp(center[1], -size2[1], size2[1]),
            wp.clamp(center[2], -size2[2], size2[2]),
        )
        direction, dist = normalize(clamped - center)
        if dist - r1 > margin:
            return 0, vec3(scalar(0.0)), vec3(scalar(0.0)), scalar(0.0)
        if dist <= scalar(MINVAL):  # the center is inside the box
            closest = (size2[0] + size2[1] + size2[2]) * scalar(2.0)
            face = int(0)
            for i in range(6):  # faces -x, +x, -y, +y, -z, +z; the first nearest
                gap = wp.abs(wp.where(i % 2 == 1, size2[i // 2], -size2[i // 2]) - center[i // 2])
                if gap < closest:
                    closest = gap
                    face = i
            nearest = vec3(scalar(0.0))
            nearest[face // 2] = wp.where(face % 2 == 1, scalar(-1.0), scalar(1.0))
            local = center + nearest * ((r1 - closest) / scalar(2.0))
            normal = R2 * nearest
            dist = -closest
        else:
            local = clamped * scalar(0.5) + (center + direction * r1) * scalar(0.5)
            normal = R2 * direction
        return 1, R2 * local + pos2, normal, dist - r1

    @wp.func
    def edge_segment(pos: vec3, halfaxis: vec3, length: scalar, size: vec3, j: int, i: int):
        """The nearest points of the capsule's segment (center pos, half axis, half-length `length`, box frame) and
        the box's edge along axis j through corner i (bit j clear) as mjraw_CapsuleBox solves them: (the edge's
        point x1 and the segment's x2 in [-1, 1], their clamps s1, s2: 0 the low end, 1 inside, 2 the high end, the
        squared distance, whether they are not parallel)."""
        one = scalar(1.0)
        zero = scalar(0.0)
        corner = vec3(  # the edge's center
            wp.where(j == 0, zero, wp.where((i & 1) != 0, size[0], -size[0])),
            wp.where(j == 1, zero, wp.where((i & 2) != 0, size[1], -size[1])),
            wp.where(j == 2, zero, wp.where((i & 4) != 0, size[2], -size[2])),
        )
        half_edge = vec3(wp.where(j == 0, size[0], zero), wp.where(j == 1, size[1], zero), wp.where(j == 2, size[2], zero))
        dif = corner - pos
        ma = size[j] * size[j]
        mb = -size[j] * halfaxis[j]
        mc = length * length
        u = -size[j] * dif[j]
        v = wp.dot(halfaxis, dif)
        det = gram(ma, mb, mc, half_edge, halfaxis)
        if wp.abs(det) < scalar(MINVAL):
            return scalar(0.0), scalar(0.0), 1, 1, scalar(0.0), False
        idet = one / det
        x1 = (mc * u - mb * v) * idet
        x2 = (ma * v - mb * u) * idet
        s1 = int(1)
        s2 = int(1)
        if x1 > one:
            x1 = one
            s1 = 2
            x2 = (v - mb) * (one / mc)
        elif x1 < -one:
            x1 = -one
            s1 = 0
            x2 = (v + mb) * (one / mc)
        if x2 > one or x2 < -one:
            sign = wp.where(x2 > one, one, -one)
            x2 = sign
            s2 = wp.where(x2 > scalar(0.0), 2, 0)
            x1 = (u - sign * mb) * (one / ma)
            s1 = wp.where(x1 > one, 2, wp.where(x1 < -one, 0, s1))
            x1 = wp.clamp(x1, -one, one)
        d = dif + halfaxis * (-x2) + half_edge * x1
        return x1, x2, s1, s2, wp.dot(d, d), True

    @wp.func
    def nearest_edge(pos: vec3, halfaxis: vec3, length: scalar, size: vec3, bestdist: scalar):
        """The index 8 j + i of the box's edge (along axis j through corner i) nearest the capsule's segment, nearer
        than sqrt(bestdist) - mjMINVAL, or -1 (mjraw_CapsuleBox's search, the first of equals)."""
        best = int(-1)
        for index in range(24):  # 24: not unrolled
            if (index % 8 & (1 << index // 8)) == 0:
                x1, x2, s1, s2, dist, solved = edge_segment(pos, halfaxis, length, size, index // 8, index % 8)
                if solved and dist < bestdist - scalar(MINVAL):
                    bestdist = dist
                    best = index
        return best

    @wp.func
    def capsule_box_nearest(pos: vec3, halfaxis: vec3, length: scalar, size: vec3, bestdist: scalar):
        """The capsule's segment (center pos and half axis, box frame) against the box (half-sizes `size`) as
        mjraw_CapsuleBox searches it, bestdist its squared-distance bound: an end of the segment nearest a face or
        the segment against each of the 12 edges. Returns (the segment's nearest point in [-1, 1], the edge's in
        [-1, 1], the kind: -3 or -1 the end -1 or 1 nearest a face, 3 s1 + s2 (`edge_segment`) for an edge, -4 none;
        the face's axis (-1: the end inside the box), the nearest corner's bits, the edge's axis). The edges' loop
        keeps the best edge's index only, and solves that edge again under other names: Warp's adjoint of a dynamic loop
        reads a name used after it as carried."""
        seg = scalar(0.0)
        kind = int(-4)
        face = int(-1)
        for k in range(2):
            end = pos + halfaxis * scalar(2 * k - 1)
            clamped = vec3(wp.clamp(end[0], -size[0], size[0]), wp.clamp(end[1], -size[1], size[1]), wp.clamp(end[2], -size[2], size[2]))
            outside = int(0)
            axis = int(-1)
            for j in range(3):
                if end[j] < -size[j] or end[j] > size[j]:
                    outside += 1
                    axis = j
            end_dist = wp.length_sq(clamped - end)
            if outside <= 1 and end_dist < bestdist:
                bestdist = end_dist
                seg = scalar(2 * k - 1)
                kind = 2 * k - 3
                face = axis
        best = nearest_edge(pos, halfaxis, length, size, bestdist)
        if best < 0:
            return seg, scalar(0.0), kind, face, 0, 0
        axis_j = best // 8
        box_x, seg_x, box_clamp, seg_clamp, nearest, found = edge_segment(pos, halfaxis, length, size, axis_j, best % 8)
        kind = box_clamp * 3 + seg_clamp
        return seg_x, box_x, kind, face, best % 8 + (1 << axis_j) * (kind // 6), axis_j

    @wp.func
    def shorter(x: scalar, num: scalar, h: scalar):
        """min(x, num / |h|) as mjraw_CapsuleBox takes it (`if (e1 < secondpos) secondpos = e1`, num >= 0); x where
        h is 0, without the division (num / 0 is no less than x), whose adjoint would be NaN."""
        if h != scalar(0.0):
            e = num / wp.abs(h)
            if e < x:
                return e
        return x

    @wp.func
    def capsule_box_second(pos: vec3, axis: vec3, halfaxis: vec3, size: vec3, seg: scalar, box: scalar, kind: int,
                           face: int, corner_bits: int, edge: int):
        """Where mjraw_CapsuleBox puts its second sphere, as an offset along the segment from the nearest point
        (in units of the half axis; < -3: none): the farthest point of the segment still over the box face or edge
        that the nearest point lies on, for a segment lying along it."""
        axisdir = wp.where(halfaxis[0] > scalar(0.0), 1, 0) + wp.where(halfaxis[1] > scalar(0.0), 2, 0) + wp.where(halfaxis[2] > scalar(0.0), 4, 0)
        one = scalar(1.0)
        two = scalar(2.0)
        if kind >= 0 and kind // 3 != 1:  # the nearest point is a corner of the box
            c1 = axisdir ^ corner_bits
            if c1 == 0 or c1 == 7:  # pointing to or away from the corner
                return scalar(-4.0)
            mul = one
            de = one - seg
            dp = one + seg
            if c1 == 3 or c1 == 5 or c1 == 6:
                mul = -one
                c1 = 7 - c1
                de = one + seg
                dp = one - seg
            ax = wp.where(c1 == 1, 0, wp.where(c1 == 2, 1, 2))
            ax1 = (ax + 1) % 3
            ax2 = (ax + 2) % 3
            if axis[ax] * axis[ax] > scalar(0.5):  # along the edge
                return shorter(de, two * size[ax], halfaxis[ax]) * mul
            return shorter(shorter(dp, two * size[ax1], halfaxis[ax1]), two * size[ax2], halfaxis[ax2]) * -mul  # along a face
        if kind >= 0:  # the nearest point is inside an edge of the box
            c1 = (axisdir ^ corner_bits) & (7 - (1 << edge))
            if c1 != 1 and c1 != 2 and c1 != 4:  # a T, not a cross: no second point
                return scalar(-4.0)
            ax1 = (edge + 1) % 3
            if wp.abs(axis[ax1]) > wp.abs(axis[(edge + 2) % 3]):
                ax1 = (edge + 2) % 3
            ax2 = 3 - edge - ax1
            mul = -one
            second = one + seg
            if (c1 & (1 << ax2)) != 0:
                mul = one
                second = one - seg
            second = shorter(second, two * size[ax2], halfaxis[ax2])
            e2 = one + box
            if ((axisdir & (1 << edge)) != 0) == ((c1 & (1 << ax2)) != 0):
                e2 = one - box
            return shorter(second, size[edge] * e2, halfaxis[edge]) * mul
        if face == -1:  # an end inside the box
            return scalar(-4.0)
        mul = wp.where(kind == -3, one, -one)
        other = pos + halfaxis * (-mul)
        second = two
        for i in range(3):
            if i != face and halfaxis[i] != scalar(0.0):  # (MuJoCo's e1 is then infinite or NaN: no change)
                for k in range(2):
                    e1 = (wp.where(k == 0, size[i], -size[i]) - other[i]) / halfaxis[i] * mul
                    if e1 > scalar(0.0) and e1 < second:
                        second = e1
        return second * mul

    @wp.func
    def capsule_box(pos1: vec3, R1: mat33, size1: vec3, pos2: vec3, R2: mat33, size2: vec3, margin: scalar):
        """Capsule-box, MuJoCo's mjraw_CapsuleBox: a sphere of the capsule's radius at the segment's point nearest
        the box (sphere-box), and where the segment lies along a face or an edge, a second one at the farthest point
        of the segment still over it; at most 2 contacts."""
        pos = wp.transpose(R2) * (pos1 - pos2)
        axis = wp.transpose(R2) * axis_of(R1, 2)
        halfaxis = axis * size1[1]
        bound = margin + scalar(2.0) * (size1[0] + size1[1] + size2[0] + size2[1] + size2[2])
        seg, box, kind, face, corner_bits, edge = capsule_box_nearest(pos, halfaxis, size1[1], size2, bound)
        P = mat23()
        N = mat23()
        D = vec2()
        if kind == -4:
            return 0, P, N, D
        second = capsule_box_second(pos, axis, halfaxis, size2, seg, box, kind, face, corner_bits, edge)
        n, p, nrm, d = sphere_box(R2 * (pos + halfaxis * seg) + pos2, R1, size1[0], pos2, R2, size2, margin)
        P[0] = p
        N[0] = nrm
        D[0] = d
        if second > scalar(-3.0):
            m, p, nrm, d = sphere_box(R2 * (pos + halfaxis * (second + seg)) + pos2, R1, size1[0], pos2, R2, size2, margin)
            if m > 0:
                P[n] = p
                N[n] = nrm
                D[n] = d
                n += 1
        return n, P, N, D

    # --- MuJoCo's bounding-sphere filter and the batch kernel ----------------------------------------------------

    @wp.func
    def bounding_radius(geom_type: int, size: vec3):
        """MuJoCo's geom_rbound (mjCGeom::GetRBound): the radius of the geom's bounding sphere about its position
        (0 for a plane)."""
        if geom_type == SPHERE:
            return size[0]
        if geom_type == CAPSULE:
            return size[0] + size[1]
        if geom_type == CYLINDER:
            return wp.sqrt(size[0] * size[0] + size[1] * size[1])
        if geom_type == ELLIPSOID:
            return wp.max(wp.max(size[0], size[1]), size[2])
        if geom_type == BOX:
            return wp.sqrt(size[0] * size[0] + size[1] * size[1] + size[2] * size[2])
        if geom_type == MESH:
            return size[0]
        return scalar(0.0)

    @wp.func
    def may_touch(type1: int, pos1: vec3, R1: mat33, size1: vec3, type2: int, pos2: vec3, size2: vec3, margin: scalar):
        """False where MuJoCo's mj_filterSphere drops the pair before its narrow phase: bounding spheres (or geom2's
        sphere and the plane geom1) farther apart than margin. It decides the pairs that exactly touch."""
        r1 = bounding_radius(type1, size1)
        r2 = bounding_radius(type2, size2)
        if r1 > scalar(0.0) and r2 > scalar(0.0):
            dif = pos1 - pos2
            bound = r1 + r2 + margin
            return dif[0] * dif[0] + dif[1] * dif[1] + dif[2] * dif[2] <= bound * bound
        if type1 == PLANE and r2 > scalar(0.0):
            return wp.dot(pos2 - pos1, axis_of(R1, 2)) <= margin + r2
        return True

    # --- the batch kernel -----------------------------------------------------------------------------------

    @wp.func
    def store(i: int, count: int, P: Any, N: Any, D: Any, tangent: vec3,
              position: wp.array2d(dtype=vec3), frame: wp.array2d(dtype=mat33), dist: wp.array2d(dtype=scalar)):
        """Writes contacts 0 .. count-1 of a multi-contact pair to row i of the outputs."""
        for k in range(count):
            position[i, k] = P[k]
            frame[i, k] = contact_frame(N[k], tangent)
            dist[i, k] = D[k]

    @wp.func
    def store_one(i: int, count: int, p: vec3, normal: vec3, d: scalar,
                  position: wp.array2d(dtype=vec3), frame: wp.array2d(dtype=mat33), dist: wp.array2d(dtype=scalar)):
        """Writes the contact of a single-contact pair, if any, to row i of the outputs."""
        if count > 0:
            position[i, 0] = p
            frame[i, 0] = contact_frame(normal, vec3(scalar(0.0)))
            dist[i, 0] = d

    @wp.kernel(module="unique")
    def collide(
        type1: int, type2: int,
        pos1: wp.array(dtype=vec3), R1: wp.array(dtype=mat33), size1: wp.array(dtype=vec3),
        pos2: wp.array(dtype=vec3), R2: wp.array(dtype=mat33), size2: wp.array(dtype=vec3),
        margin: wp.array(dtype=scalar),
        # outputs
        count: wp.array(dtype=int), position: wp.array2d(dtype=vec3), frame: wp.array2d(dtype=mat33), dist: wp.array2d(dtype=scalar),
    ):  # fmt: skip
        """One pair of geoms of types (type1, type2) per thread i, in MuJoCo's order (type1 <= type2): count[i]
        contacts, their positions (N, MAX_CONTACTS) vec3 [m, world], MuJoCo's contact frames (rows: the normal
        from geom1 to geom2, two tangents) and distances [m]; the poses, sizes and margins as the pairs' functions
        take them; no contacts where MuJoCo's bounding-sphere filter (`may_touch`) drops the pair. A pair of types
        without a function here gives count -1."""
        i = wp.tid()
        p1 = pos1[i]
        p2 = pos2[i]
        m1 = R1[i]
        m2 = R2[i]
        s1 = size1[i]
        s2 = size2[i]
        e = margin[i]
        n = int(-1)
        if type1 == PLANE and type2 == SPHERE:
            n, p, nrm, d = plane_sphere(p1, m1, p2, s2[0], e)
            store_one(i, n, p, nrm, d, position, frame, dist)
        elif type1 == PLANE and type2 == CAPSULE:
            n, P2, N2, D2 = plane_capsule(p1, m1, p2, m2, s2, e)
            store(i, n, P2, N2, D2, axis_of(m2, 2), position, frame, dist)
        elif type1 == PLANE and type2 == ELLIPSOID:
            n, p, nrm, d = plane_ellipsoid(p1, m1, p2, m2, s2, e)
            store_one(i, n, p, nrm, d, position, frame, dist)
        elif type1 == PLANE and type2 == CYLINDER:
            n, P4, N4, D4 = plane_cylinder(p1, m1, p2, m2, s2, e)
            store(i, n, P4, N4, D4, vec3(scalar(0.0)), position, frame, dist)
        elif type1 == PLANE and type2 == BOX:
            n, P4, N4, D4 = plane_box(p1, m1, p2, m2, s2, e)
            store(i, n, P4, N4, D4, vec3(scalar(0.0)), position, frame, dist)
        elif type1 == SPHERE and type2 == SPHERE:
            n, p, nrm, d = sphere_sphere(p1, m1, s1[0], p2, m2, s2[0], e)
            store_one(i, n, p, nrm, d, position, frame, dist)
        elif type1 == SPHERE and type2 == CAPSULE:
            n, p, nrm, d = sphere_capsule(p1, m1, s1[0], p2, m2, s2, e)
            store_one(i, n, p, nrm, d, position, frame, dist)
        elif type1 == SPHERE and type2 == CYLINDER:
            n, p, nrm, d = sphere_cylinder(p1, m1, s1[0], p2, m2, s2, e)
            store_one(i, n, p, nrm, d, position, frame, dist)
        elif type1 == SPHERE and type2 == BOX:
            n, p, nrm, d = sphere_box(p1, m1, s1[0], p2, m2, s2, e)
            store_one(i, n, p, nrm, d, position, frame, dist)
        elif type1 == CAPSULE and type2 == CAPSULE:
            n, P2, N2, D2 = capsule_capsule(p1, m1, s1, p2, m2, s2, e)
            store(i, n, P2, N2, D2, vec3(scalar(0.0)), position, frame, dist)
        elif type1 == CAPSULE and type2 == BOX:
            n, P2, N2, D2 = capsule_box(p1, m1, s1, p2, m2, s2, e)
            store(i, n, P2, N2, D2, vec3(scalar(0.0)), position, frame, dist)
        if n > 0 and not may_touch(type1, p1, m1, s1, type2, p2, s2, e):
            n = 0
        count[i] = n

    return types.SimpleNamespace(
        scalar=scalar, vec2=vec2, vec3=vec3, mat23=mat23, mat33=mat33, contact_frame=contact_frame, bounding_radius=bounding_radius, may_touch=may_touch,
        plane_sphere=plane_sphere, plane_capsule=plane_capsule, plane_box=plane_box, plane_cylinder=plane_cylinder, plane_ellipsoid=plane_ellipsoid,
        sphere_sphere=sphere_sphere, sphere_capsule=sphere_capsule, sphere_cylinder=sphere_cylinder, sphere_box=sphere_box,
        capsule_capsule=capsule_capsule, capsule_box=capsule_box, collide=collide,
    )  # fmt: skip
