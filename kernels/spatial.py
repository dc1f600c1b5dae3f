"""Spatial algebra as `@wp.func`s, built once per scalar type (float32 or float64).

Conventions used by every kernel:
- A pose is a `wp.transform` A_H_B = (A_p_B, A_R_B): the frame B seen from A. Warp's quaternion is
  (x, y, z, w); the public API's is (w, x, y, z) and is converted by `quat_from_wxyz` alone.
- Spatial motion vectors are [linear; angular], spatial forces [force; torque], as vec6.
- `motion_to(A_H_B, v)` applies A_X_B = [[R, p^ R], [0, R]] to a motion vector in B coordinates;
  `force_to(A_H_B, f)` applies A_X*_B = [[R, 0], [p^ R, R]].
- Velocity representations (the façade's `VelRepr`): Body = 1, Mixed = 2, Inertial = 3. The velocity
  of a frame F is kept in kernels in the Inertial representation W_v_WF = [W_v_O; W_omega], W_v_O being
  the velocity of the point of F that passes through the world origin.
"""

import types

import warp as wp

from .factory import factory

BODY = 1
MIXED = 2
INERTIAL = 3

REVOLUTE = 1
PRISMATIC = 2
BALL = 3
FREE = 4
"""Joint kinds (warpdyn.description.tree's JOINT_*): a ball joint has 4 positions (a quaternion) and 3 velocities,
a free joint 7 (a position and a quaternion) and 6; revolute and prismatic joints 1 each."""


@factory
def spatial(scalar) -> types.SimpleNamespace:
    """Types and functions of spatial algebra in `scalar` (wp.float32 or wp.float64)."""
    vec3 = wp.types.vector(3, scalar)
    vec4 = wp.types.vector(4, scalar)
    vec6 = wp.types.vector(6, scalar)
    mat33 = wp.types.matrix((3, 3), scalar)
    mat44 = wp.types.matrix((4, 4), scalar)
    mat66 = wp.types.matrix((6, 6), scalar)
    quat = wp.types.quaternion(scalar)
    transform = wp.types.transformation(scalar)

    @wp.func
    def homogeneous(X: transform):
        """The (4, 4) homogeneous matrix of a pose."""
        R = wp.quat_to_matrix(wp.transform_get_rotation(X))
        p = wp.transform_get_translation(X)
        zero = scalar(0.0)
        one = scalar(1.0)
        return mat44(R[0, 0], R[0, 1], R[0, 2], p[0], R[1, 0], R[1, 1], R[1, 2], p[1], R[2, 0], R[2, 1], R[2, 2], p[2], zero, zero, zero, one)

    @wp.func
    def quat_from_wxyz(w: scalar, x: scalar, y: scalar, z: scalar):
        return quat(x, y, z, w)

    @wp.func
    def lin(v: vec6):
        return vec3(v[0], v[1], v[2])

    @wp.func
    def ang(v: vec6):
        return vec3(v[3], v[4], v[5])

    @wp.func
    def stack(a: vec3, b: vec3):
        return vec6(a[0], a[1], a[2], b[0], b[1], b[2])

    @wp.func
    def motion_to(X: transform, v: vec6):
        """A_X_B v: a motion vector from B to A coordinates, X = A_H_B."""
        w = wp.quat_rotate(wp.transform_get_rotation(X), ang(v))
        u = wp.quat_rotate(wp.transform_get_rotation(X), lin(v)) + wp.cross(wp.transform_get_translation(X), w)
        return stack(u, w)

    @wp.func
    def motion_from(X: transform, v: vec6):
        """B_X_A v: a motion vector from A to B coordinates, X = A_H_B."""
        q = wp.transform_get_rotation(X)
        w = ang(v)
        u = lin(v) - wp.cross(wp.transform_get_translation(X), w)
        return stack(wp.quat_rotate_inv(q, u), wp.quat_rotate_inv(q, w))

    @wp.func
    def force_to(X: transform, f: vec6):
        """A_X*_B f: a force from B to A coordinates, X = A_H_B."""
        q = wp.transform_get_rotation(X)
        F = wp.quat_rotate(q, lin(f))
        return stack(F, wp.quat_rotate(q, ang(f)) + wp.cross(wp.transform_get_translation(X), F))

    @wp.func
    def force_from(X: transform, f: vec6):
        """B_X*_A f: a force from A to B coordinates, X = A_H_B."""
        q = wp.transform_get_rotation(X)
        F = lin(f)
        tau = ang(f) - wp.cross(wp.transform_get_translation(X), F)
        return stack(wp.quat_rotate_inv(q, F), wp.quat_rotate_inv(q, tau))

    @wp.func
    def cross_motion(v: vec6, m: vec6):
        """v x m, the spatial cross product of motion vectors."""
        return stack(wp.cross(ang(v), lin(m)) + wp.cross(lin(v), ang(m)), wp.cross(ang(v), ang(m)))

    @wp.func
    def cross_force(v: vec6, f: vec6):
        """v x* f, the spatial cross product of a motion and a force."""
        return stack(wp.cross(ang(v), lin(f)), wp.cross(ang(v), ang(f)) + wp.cross(lin(v), lin(f)))

    @wp.func
    def joint_coefficients(joint_type: int, q: scalar):
        """(c, s, alpha, beta) with which a joint at position q moves its link (kernels/bundles.py's
        `joint_transform_from`): (cos q/2, sin q/2, cos q, sin q) for a revolute joint, (1, 0, q, 0) for a
        prismatic one, (1, 0, 0, 0) otherwise (see warpdyn.description's joint_motion)."""
        one = scalar(1.0)
        zero = scalar(0.0)
        if joint_type == REVOLUTE:
            c = wp.cos(scalar(0.5) * q)
            s = wp.sin(scalar(0.5) * q)
            return vec4(c, s, c * c - s * s, scalar(2.0) * s * c)
        if joint_type == PRISMATIC:
            return vec4(one, zero, q, zero)
        return vec4(one, zero, zero, zero)

    @wp.func
    def inertial_to_repr(repr: int, W_H_F: transform, W_v: vec6):
        """The velocity (or Jacobian column) W_v of frame F in representation `repr`."""
        if repr == BODY:
            return motion_from(W_H_F, W_v)
        if repr == MIXED:
            return stack(lin(W_v) + wp.cross(ang(W_v), wp.transform_get_translation(W_H_F)), ang(W_v))
        return W_v

    @wp.func
    def repr_to_inertial(repr: int, W_H_F: transform, v: vec6):
        """The Inertial representation of the velocity v of frame F given in `repr`."""
        if repr == BODY:
            return motion_to(W_H_F, v)
        if repr == MIXED:
            return stack(lin(v) - wp.cross(ang(v), wp.transform_get_translation(W_H_F)), ang(v))
        return v

    @wp.func
    def change_repr(source: int, target: int, W_H_F: transform, v: vec6):
        """The velocity v of frame F given in representation `source`, in `target`; v itself, bit for bit,
        when they are the same (the round trip through Inertial would round differently with fused
        multiply-adds)."""
        if source == target:
            return v
        return inertial_to_repr(target, W_H_F, repr_to_inertial(source, W_H_F, v))

    @wp.func
    def blocks(A: mat33, B: mat33, C: mat33, D: mat33):
        """The (6, 6) matrix [[A, B], [C, D]]."""
        return mat66(
            A[0, 0], A[0, 1], A[0, 2], B[0, 0], B[0, 1], B[0, 2],
            A[1, 0], A[1, 1], A[1, 2], B[1, 0], B[1, 1], B[1, 2],
            A[2, 0], A[2, 1], A[2, 2], B[2, 0], B[2, 1], B[2, 2],
            C[0, 0], C[0, 1], C[0, 2], D[0, 0], D[0, 1], D[0, 2],
            C[1, 0], C[1, 1], C[1, 2], D[1, 0], D[1, 1], D[1, 2],
            C[2, 0], C[2, 1], C[2, 2], D[2, 0], D[2, 1], D[2, 2],
        )  # fmt: skip

    @wp.func
    def motion_cross_matrix(v: vec6):
        """(v x) as a matrix: [[w^, u^], [0, w^]] for v = [u; w]."""
        W = wp.skew(ang(v))
        return blocks(W, wp.skew(lin(v)), mat33(scalar(0.0)), W)

    @wp.func
    def force_cross_matrix(v: vec6):
        """(v x*) as a matrix: [[w^, 0], [u^, w^]] = -(v x)^T for v = [u; w]."""
        W = wp.skew(ang(v))
        return blocks(W, mat33(scalar(0.0)), wp.skew(lin(v)), W)

    @wp.func
    def motion_matrix_from(X: transform):
        """B_X_A as a (6, 6) matrix, X = A_H_B: [[R^T, -R^T p^], [0, R^T]]."""
        Rt = wp.transpose(wp.quat_to_matrix(wp.transform_get_rotation(X)))
        B = -Rt * wp.skew(wp.transform_get_translation(X))
        zero = scalar(0.0)
        return mat66(
            Rt[0, 0], Rt[0, 1], Rt[0, 2], B[0, 0], B[0, 1], B[0, 2],
            Rt[1, 0], Rt[1, 1], Rt[1, 2], B[1, 0], B[1, 1], B[1, 2],
            Rt[2, 0], Rt[2, 1], Rt[2, 2], B[2, 0], B[2, 1], B[2, 2],
            zero, zero, zero, Rt[0, 0], Rt[0, 1], Rt[0, 2],
            zero, zero, zero, Rt[1, 0], Rt[1, 1], Rt[1, 2],
            zero, zero, zero, Rt[2, 0], Rt[2, 1], Rt[2, 2],
        )

    @wp.func
    def spatial_inertia(mass: scalar, com: vec3, inertia: mat33):
        """A link's spatial inertia about its origin, link axes: [[m 1, -m c^], [m c^, I_c - m c^ c^]]."""
        C = wp.skew(com)
        mC = mass * C
        cc = wp.dot(com, com)
        x, y, z = com[0], com[1], com[2]
        Io = inertia + mass * mat33(cc - x * x, -x * y, -x * z, -x * y, cc - y * y, -y * z, -x * z, -y * z, cc - z * z)  # I_c - m c^ c^
        zero = scalar(0.0)
        return mat66(
            mass, zero, zero, -mC[0, 0], -mC[0, 1], -mC[0, 2],
            zero, mass, zero, -mC[1, 0], -mC[1, 1], -mC[1, 2],
            zero, zero, mass, -mC[2, 0], -mC[2, 1], -mC[2, 2],
            mC[0, 0], mC[0, 1], mC[0, 2], Io[0, 0], Io[0, 1], Io[0, 2],
            mC[1, 0], mC[1, 1], mC[1, 2], Io[1, 0], Io[1, 1], Io[1, 2],
            mC[2, 0], mC[2, 1], mC[2, 2], Io[2, 0], Io[2, 1], Io[2, 2],
        )

    @wp.func
    def inertia_times(mass: scalar, com: vec3, inertia: mat33, v: vec6):
        """I v for the spatial inertia I = spatial_inertia(mass, com, inertia) and a motion v = [v_lin; omega]:
        f = m (v_lin - c x omega), [f; inertia omega + c x f], without forming I."""
        f = mass * (lin(v) - wp.cross(com, ang(v)))
        return stack(f, inertia * ang(v) + wp.cross(com, f))

    @wp.func
    def orientation_only(W_H_F: transform):
        """F with its origin moved to the world's origin: (0, W_R_F)."""
        return transform(vec3(scalar(0.0)), wp.transform_get_rotation(W_H_F))

    @wp.func
    def base_T(repr: int, W_H_B: transform):
        """T (6, 6): the body base velocity from the base velocity in `repr`, B_v = T v."""
        if repr == INERTIAL:
            return motion_matrix_from(W_H_B)
        if repr == MIXED:
            return motion_matrix_from(orientation_only(W_H_B))
        return wp.identity(n=6, dtype=scalar)

    @wp.func
    def base_acceleration_to_body(repr: int, W_H_B: transform, B_v: vec6, a: vec6):
        """d/dt B_v_WB from the derivative `a` of the base velocity in `repr` (B_v: the body velocity).

        Inertial: B_X_W a (the term of dT/dt vanishes, B_v x B_v = 0); Mixed: R^T a - [B_w x B_v_lin; 0].
        """
        if repr == INERTIAL:
            return motion_from(W_H_B, a)
        if repr == MIXED:
            body = motion_from(orientation_only(W_H_B), a)
            return body - stack(wp.cross(ang(B_v), lin(B_v)), vec3(scalar(0.0)))
        return a

    @wp.func
    def base_acceleration_from_body(repr: int, W_H_B: transform, B_v: vec6, B_a: vec6):
        """The derivative of the base velocity in `repr` from B_a = d/dt B_v_WB."""
        if repr == INERTIAL:
            return motion_to(W_H_B, B_a)
        if repr == MIXED:
            return motion_to(orientation_only(W_H_B), B_a + stack(wp.cross(ang(B_v), lin(B_v)), vec3(scalar(0.0))))
        return B_a

    @wp.func
    def base_force_from_body(repr: int, W_H_B: transform, B_f: vec6):
        """T^T B_f: a base wrench in body coordinates as the generalized force dual to the base velocity in `repr`."""
        if repr == INERTIAL:
            return force_to(W_H_B, B_f)
        if repr == MIXED:
            return force_to(orientation_only(W_H_B), B_f)
        return B_f

    @wp.func
    def solve_spd6_blocks(A11: mat33, A12: mat33, A21: mat33, A22: mat33, b1: vec3, b2: vec3):
        """(x1, x2) with [[A11, A12], [A21, A22]] [x1; x2] = [b1; b2] for a symmetric positive-definite matrix of
        those 3x3 blocks, by the Schur complement of A11."""
        A11_inv = wp.inverse(A11)
        schur = A22 - A21 * A11_inv * A12
        x2 = wp.inverse(schur) * (b2 - A21 * (A11_inv * b1))
        x1 = A11_inv * (b1 - A12 * x2)
        return x1, x2

    @wp.func
    def solve_spd6(A: mat66, b: vec6):
        """x with A x = b for a symmetric positive-definite A, by 3x3 blocks (`solve_spd6_blocks`)."""
        A11 = mat33(A[0, 0], A[0, 1], A[0, 2], A[1, 0], A[1, 1], A[1, 2], A[2, 0], A[2, 1], A[2, 2])
        A12 = mat33(A[0, 3], A[0, 4], A[0, 5], A[1, 3], A[1, 4], A[1, 5], A[2, 3], A[2, 4], A[2, 5])
        A21 = mat33(A[3, 0], A[3, 1], A[3, 2], A[4, 0], A[4, 1], A[4, 2], A[5, 0], A[5, 1], A[5, 2])
        A22 = mat33(A[3, 3], A[3, 4], A[3, 5], A[4, 3], A[4, 4], A[4, 5], A[5, 3], A[5, 4], A[5, 5])
        x1, x2 = solve_spd6_blocks(A11, A12, A21, A22, lin(b), ang(b))
        return stack(x1, x2)

    @wp.func
    def rotation_vector(q: quat):
        """The rotation vector (axis times angle, angle in (-pi, pi]) of a unit quaternion q, MuJoCo's
        mju_quat2Vel: the shorter of the two rotations q and -q stand for."""
        v = vec3(q[0], q[1], q[2])
        sin_half = wp.length(v)
        if sin_half < scalar(1e-12):  # angle ~ 2 |v|: the limit of angle / sin_half
            return scalar(2.0) * v * wp.sign(q[3])
        angle = scalar(2.0) * wp.atan2(sin_half, q[3])
        if angle > scalar(3.141592653589793):
            angle = angle - scalar(6.283185307179586)
        return v * (angle / sin_half)

    @wp.func
    def mixed_frame(W_H_F: transform):
        """F[W]: the frame at F's origin with the world's orientation."""
        return transform(wp.transform_get_translation(W_H_F), quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0)))

    @wp.func
    def force_repr_to_inertial(repr: int, W_H_F: transform, f: vec6):
        """W_f: a 6D force applied to the body of frame F, given in representation `repr`."""
        if repr == BODY:
            return force_to(W_H_F, f)
        if repr == MIXED:
            return force_to(mixed_frame(W_H_F), f)
        return f

    @wp.func
    def inertial_to_force_repr(repr: int, W_H_F: transform, W_f: vec6):
        """The 6D force W_f applied to the body of frame F, in representation `repr`."""
        if repr == BODY:
            return force_from(W_H_F, W_f)
        if repr == MIXED:
            return force_from(mixed_frame(W_H_F), W_f)
        return W_f

    return types.SimpleNamespace(
        rotation_vector=rotation_vector,
        scalar=scalar,
        vec3=vec3,
        vec4=vec4,
        vec6=vec6,
        mat33=mat33,
        mat44=mat44,
        mat66=mat66,
        homogeneous=homogeneous,
        quat=quat,
        transform=transform,
        quat_from_wxyz=quat_from_wxyz,
        lin=lin,
        ang=ang,
        stack=stack,
        motion_to=motion_to,
        motion_from=motion_from,
        force_to=force_to,
        force_from=force_from,
        cross_motion=cross_motion,
        cross_force=cross_force,
        joint_coefficients=joint_coefficients,
        inertial_to_repr=inertial_to_repr,
        mixed_frame=mixed_frame,
        solve_spd6_blocks=solve_spd6_blocks,
        solve_spd6=solve_spd6,
        motion_matrix_from=motion_matrix_from,
        blocks=blocks,
        motion_cross_matrix=motion_cross_matrix,
        force_cross_matrix=force_cross_matrix,
        spatial_inertia=spatial_inertia,
        inertia_times=inertia_times,
        orientation_only=orientation_only,
        base_T=base_T,
        base_acceleration_to_body=base_acceleration_to_body,
        base_acceleration_from_body=base_acceleration_from_body,
        base_force_from_body=base_force_from_body,
        force_repr_to_inertial=force_repr_to_inertial,
        inertial_to_force_repr=inertial_to_force_repr,
        repr_to_inertial=repr_to_inertial,
        change_repr=change_repr,
    )
