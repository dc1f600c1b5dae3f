"""JaxSim's math helpers (`jaxsim.math`) as `@wp.func`s, built once per scalar type.

`functions(scalar)` returns a namespace with the same class-like layout as the host module
`warpdyn.math`, so that host code ports to a kernel line by line:

    wm = functions(wp.float64)
    G_Xf_C = wm.Adjoint.from_transform(G_H_W @ W_H_C, True)       # in a kernel

Quaternions are (w, x, y, z) as vec4, transforms mat44, adjoints mat66 with the [linear; angular]
layout A_X_B = [[R, p^ R], [0, R]]. Arguments have JaxSim's names (`transform=`, `inverse=`, ...);
boolean flags have no default (Warp functions need every argument).
"""

import types

import warp as wp

from .factory import factory
from .spatial import spatial


@factory
def functions(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)
    vec3, vec6, mat33, mat44, mat66, quat = sp.vec3, sp.vec6, sp.mat33, sp.mat44, sp.mat66, sp.quat
    vec4 = wp.types.vector(4, scalar)

    @wp.func
    def skew_wedge(vector: vec3):
        """v^ (3, 3), with v^ w = v x w."""
        return wp.skew(vector)

    @wp.func
    def skew_vee(matrix: mat33):
        """The vector of the skew-symmetric part of the matrix."""
        half = scalar(0.5)
        m = matrix
        return vec3(half * (m[2, 1] - m[1, 2]), half * (m[0, 2] - m[2, 0]), half * (m[1, 0] - m[0, 1]))

    @wp.func
    def cross_vx(velocity_sixd: vec6):
        """v x (6, 6) of a 6D velocity [v; w]: [[w^, v^], [0, w^]]."""
        return sp.motion_cross_matrix(velocity_sixd)

    @wp.func
    def cross_vx_star(velocity_sixd: vec6):
        """v x* = -(v x)^T: [[w^, 0], [v^, w^]]."""
        return sp.force_cross_matrix(velocity_sixd)

    @wp.func
    def quaternion_to_xyzw(wxyz: vec4):
        return vec4(wxyz[1], wxyz[2], wxyz[3], wxyz[0])

    @wp.func
    def quaternion_to_wxyz(xyzw: vec4):
        return vec4(xyzw[3], xyzw[0], xyzw[1], xyzw[2])

    @wp.func
    def quaternion_to_dcm(quaternion: vec4):
        """The rotation matrix of the quaternion (w, x, y, z), normalised first."""
        q = quaternion
        return wp.quat_to_matrix(wp.normalize(quat(q[1], q[2], q[3], q[0])))

    @wp.func
    def quaternion_from_dcm(dcm: mat33):
        """The unit quaternion (w, x, y, z) of a rotation matrix, with w >= 0."""
        q = wp.quat_from_matrix(dcm)
        out = vec4(q[3], q[0], q[1], q[2])
        if out[0] < scalar(0.0):
            out = -out
        return out

    @wp.func
    def rotation_from_axis_angle(vector: vec3):
        """The rotation of angle |v| about v / |v| (identity for v = 0)."""
        v = vector
        theta = wp.length(v)
        if theta == scalar(0.0):
            return wp.identity(n=3, dtype=scalar)
        return wp.quat_to_matrix(wp.quat_from_axis_angle(v / theta, theta))

    @wp.func
    def transform_from_rotation_and_translation(rotation: mat33, translation: vec3):
        """A_H_B (4, 4) of A_R_B and A_p_B."""
        return sp.homogeneous(sp.transform(translation, wp.quat_from_matrix(rotation)))

    @wp.func
    def transform_from_quaternion_and_translation(quaternion: vec4, translation: vec3):
        """A_H_B (4, 4) of the quaternion (w, x, y, z) (normalised) and A_p_B."""
        return transform_from_rotation_and_translation(quaternion_to_dcm(quaternion), translation)

    @wp.func
    def rotation_of(H: mat44):
        return mat33(H[0, 0], H[0, 1], H[0, 2], H[1, 0], H[1, 1], H[1, 2], H[2, 0], H[2, 1], H[2, 2])

    @wp.func
    def translation_of(H: mat44):
        return vec3(H[0, 3], H[1, 3], H[2, 3])

    @wp.func
    def transform_inverse(transform: mat44):
        """B_H_A = [[R^T, -R^T p], [0, 1]] of A_H_B = [[R, p], [0, 1]]."""
        Rt = wp.transpose(rotation_of(transform))
        return transform_from_rotation_and_translation(Rt, -(Rt @ translation_of(transform)))

    @wp.func
    def adjoint_from_rotation_and_translation(rotation: mat33, translation: vec3, inverse: wp.bool):
        """A_X_B = [[R, p^ R], [0, R]] of A_H_B = (R, p); with `inverse`, B_X_A = [[R^T, -R^T p^], [0, R^T]]."""
        R = rotation
        P = skew_wedge(translation)
        if inverse:
            Rt = wp.transpose(R)
            return sp.blocks(Rt, -(Rt @ P), mat33(), Rt)
        return sp.blocks(R, P @ R, mat33(), R)

    @wp.func
    def adjoint_from_transform(transform: mat44, inverse: wp.bool):
        """A_X_B (6, 6) of A_H_B; with `inverse`, B_X_A."""
        return adjoint_from_rotation_and_translation(rotation_of(transform), translation_of(transform), inverse)

    @wp.func
    def adjoint_from_quaternion_and_translation(quaternion: vec4, translation: vec3, inverse: wp.bool):
        return adjoint_from_rotation_and_translation(quaternion_to_dcm(quaternion), translation, inverse)

    @wp.func
    def adjoint_to_transform(adjoint: mat66):
        """A_H_B of A_X_B: R is the upper-left block, p = vee(p^ R R^T)."""
        X = adjoint
        R = mat33()
        B = mat33()
        for i in range(3):
            for j in range(3):
                R[i, j] = X[i, j]
                B[i, j] = X[i, j + 3]
        return transform_from_rotation_and_translation(R, skew_vee(B @ wp.transpose(R)))

    @wp.func
    def adjoint_inverse(adjoint: mat66):
        """B_X_A of A_X_B."""
        H = adjoint_to_transform(adjoint)
        return adjoint_from_rotation_and_translation(rotation_of(H), translation_of(H), True)

    @wp.func
    def inertia_to_sixd(mass: scalar, com: vec3, I: mat33):
        """The 6D inertia [[m 1, m c^T], [m c^, I + m c^ c^T]] (I about the CoM, c the CoM)."""
        return sp.spatial_inertia(mass, com, I)

    return types.SimpleNamespace(
        scalar=scalar,
        vec3=vec3,
        vec4=vec4,
        vec6=vec6,
        mat33=mat33,
        mat44=mat44,
        mat66=mat66,
        blocks=sp.blocks,
        Skew=types.SimpleNamespace(wedge=skew_wedge, vee=skew_vee),
        Cross=types.SimpleNamespace(vx=cross_vx, vx_star=cross_vx_star),
        Quaternion=types.SimpleNamespace(
            to_xyzw=quaternion_to_xyzw, to_wxyz=quaternion_to_wxyz, to_dcm=quaternion_to_dcm, from_dcm=quaternion_from_dcm
        ),
        Rotation=types.SimpleNamespace(from_axis_angle=rotation_from_axis_angle),
        Transform=types.SimpleNamespace(
            from_rotation_and_translation=transform_from_rotation_and_translation,
            from_quaternion_and_translation=transform_from_quaternion_and_translation,
            inverse=transform_inverse,
        ),
        Adjoint=types.SimpleNamespace(
            from_rotation_and_translation=adjoint_from_rotation_and_translation,
            from_quaternion_and_translation=adjoint_from_quaternion_and_translation,
            from_transform=adjoint_from_transform,
            to_transform=adjoint_to_transform,
            inverse=adjoint_inverse,
        ),
        Inertia=types.SimpleNamespace(to_sixd=inertia_to_sixd),
    )
