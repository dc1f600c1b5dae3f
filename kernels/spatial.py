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

import functools
import types

import warp as wp

BODY = 1
MIXED = 2
INERTIAL = 3

REVOLUTE = 1
PRISMATIC = 2


@functools.cache
def spatial(scalar) -> types.SimpleNamespace:
    """Types and functions of spatial algebra in `scalar` (wp.float32 or wp.float64)."""
    vec3 = wp.types.vector(3, scalar)
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
    def joint_motion(joint_type: int, axis: vec3, pivot: vec3, q: scalar):
        """M(q): the pose of a link in its joint frame at joint position q (see warpdyn.description)."""
        if joint_type == REVOLUTE:
            r = wp.quat_from_axis_angle(axis, q)
            return transform(pivot - wp.quat_rotate(r, pivot), r)
        if joint_type == PRISMATIC:
            return transform(axis * q, quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0)))
        return transform(vec3(scalar(0.0)), quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(1.0)))

    @wp.func
    def motion_subspace(joint_type: int, axis: vec3, pivot: vec3):
        """S, the joint's motion subspace in the link frame: [pivot x axis; axis] or [axis; 0]."""
        if joint_type == REVOLUTE:
            return stack(wp.cross(pivot, axis), axis)
        if joint_type == PRISMATIC:
            return stack(axis, vec3(scalar(0.0)))
        return vec6(scalar(0.0))

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
        scalar=scalar,
        vec3=vec3,
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
        joint_motion=joint_motion,
        motion_subspace=motion_subspace,
        inertial_to_repr=inertial_to_repr,
        mixed_frame=mixed_frame,
        force_repr_to_inertial=force_repr_to_inertial,
        inertial_to_force_repr=inertial_to_force_repr,
        repr_to_inertial=repr_to_inertial,
    )
