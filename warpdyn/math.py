"""JaxSim's math helpers (`jaxsim.math`), host-side in NumPy, and as `@wp.func`s for kernels.

Host side: the classes below mirror JaxSim's (same names, static methods, keyword names). Every
function takes arrays with any leading batch axes (so the notebook's `jax.vmap` is not needed),
accepts NumPy arrays, array-likes and Warp arrays (copied to the host), computes in the input's float
type (float32 stays float32; integers become float64) and returns NumPy arrays.

Kernel side: `functions(scalar)` (wp.float32 or wp.float64) gives the same layout as `@wp.func`s:
`wm.Adjoint.from_transform(H, True)`, `wm.Transform.inverse(H)`, `wm.Quaternion.to_dcm(q)`,
`wm.Skew.wedge(v)`, `wm.Cross.vx(v)`... (see warpdyn/kernels/math_funcs.py).

Conventions (as JaxSim): quaternions (w, x, y, z); 6D vectors [linear; angular]; the adjoint of
A_H_B = (R, p) is A_X_B = [[R, p^ R], [0, R]], mapping motion vectors from B to A; the transform of
6D forces from B to A is A_X*_B = B_X_A^T.

Differences from JaxSim: `Quaternion.derivative` returns (..., 4) (JaxSim: a (4, 1) column);
`Quaternion.to_dcm` and `Transform.from_quaternion_and_translation` normalise the quaternion
(jaxlie's `as_matrix` does the same implicitly, so `normalize_quaternion` changes nothing);
`Quaternion.from_dcm` returns the quaternion with w >= 0.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .kernels.math_funcs import functions
from .types.kin_dyn import JointModel
from .types.model import STANDARD_GRAVITY

__all__ = [
    "STANDARD_GRAVITY",
    "Skew",
    "Cross",
    "Quaternion",
    "Rotation",
    "Transform",
    "Adjoint",
    "Inertia",
    "JointModel",
    "safe_norm",
    "supported_joint_motion",
    "functions",
]



def _array(x, name: str, last: tuple) -> np.ndarray:
    """`x` as a floating NumPy array whose trailing axes are `last`."""
    if isinstance(x, wp.array):
        x = x.numpy()
    a = np.asarray(x)
    if not np.issubdtype(a.dtype, np.floating):
        a = a.astype(np.float64)
    if a.shape[a.ndim - len(last) :] != tuple(last) or a.ndim < len(last):
        raise ValueError(f"{name} must have shape (..., {', '.join(map(str, last))}), got {a.shape}")
    return a


def _dtype(*arrays) -> np.dtype:
    return np.result_type(*arrays)


class Skew:
    """Skew-symmetric matrices of 3D vectors."""

    @staticmethod
    def wedge(vector) -> np.ndarray:
        """v^ (..., 3, 3) with v^ w = v x w, of v (..., 3)."""
        v = _array(vector, "vector", (3,))
        out = np.zeros((*v.shape[:-1], 3, 3), dtype=v.dtype)
        out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
        out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
        out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
        return out

    @staticmethod
    def vee(matrix) -> np.ndarray:
        """The vector (..., 3) of the skew-symmetric part of matrix (..., 3, 3)."""
        m = _array(matrix, "matrix", (3, 3))
        return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0], m[..., 1, 0] - m[..., 0, 1]], axis=-1)


def _blocks(A, B, C, D) -> np.ndarray:
    """[[A, B], [C, D]] of (..., 3, 3) blocks."""
    return np.concatenate([np.concatenate([A, B], axis=-1), np.concatenate([C, D], axis=-1)], axis=-2)


class Cross:
    """Spatial cross-product matrices of 6D velocities [v; w]."""

    @staticmethod
    def vx(velocity_sixd) -> np.ndarray:
        """v x (..., 6, 6) = [[w^, v^], [0, w^]]: (v x) m is the cross product of motion vectors."""
        v = _array(velocity_sixd, "velocity_sixd", (6,))
        w = Skew.wedge(v[..., 3:])
        return _blocks(w, Skew.wedge(v[..., :3]), np.zeros_like(w), w)

    @staticmethod
    def vx_star(velocity_sixd) -> np.ndarray:
        """v x* (..., 6, 6) = -(v x)^T = [[w^, 0], [v^, w^]]: the cross product of a motion and a force."""
        return -np.swapaxes(Cross.vx(velocity_sixd), -1, -2)


class Quaternion:
    """Unit quaternions (w, x, y, z)."""

    @staticmethod
    def to_xyzw(wxyz) -> np.ndarray:
        q = _array(wxyz, "wxyz", (4,))
        return q[..., [1, 2, 3, 0]]

    @staticmethod
    def to_wxyz(xyzw) -> np.ndarray:
        q = _array(xyzw, "xyzw", (4,))
        return q[..., [3, 0, 1, 2]]

    @staticmethod
    def to_dcm(quaternion) -> np.ndarray:
        """The rotation matrix (..., 3, 3) of quaternion (..., 4) (w, x, y, z), normalised first."""
        q = _array(quaternion, "quaternion", (4,))
        q = q / np.linalg.norm(q, axis=-1, keepdims=True)
        w, x, y, z = (q[..., i] for i in range(4))
        rows = [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
        return np.stack([np.stack(r, axis=-1) for r in rows], axis=-2)

    @staticmethod
    def from_dcm(dcm) -> np.ndarray:
        """The unit quaternion (..., 4) (w, x, y, z), w >= 0, of rotation matrices (..., 3, 3) (Shepperd's method)."""
        R = _array(dcm, "dcm", (3, 3))
        batch = R.shape[:-2]
        Rf = R.reshape(-1, 3, 3)
        out = np.empty((len(Rf), 4), dtype=R.dtype)
        for k, M in enumerate(Rf):
            t = np.trace(M)
            if t > 0.0:
                s = 2.0 * np.sqrt(1.0 + t)
                q = [0.25 * s, (M[2, 1] - M[1, 2]) / s, (M[0, 2] - M[2, 0]) / s, (M[1, 0] - M[0, 1]) / s]
            else:
                i = int(np.argmax(np.diag(M)))
                j, l = (i + 1) % 3, (i + 2) % 3
                s = 2.0 * np.sqrt(max(1.0 + M[i, i] - M[j, j] - M[l, l], 1e-300))
                q = [(M[l, j] - M[j, l]) / s, 0.0, 0.0, 0.0]
                q[1 + i] = 0.25 * s
                q[1 + j] = (M[j, i] + M[i, j]) / s
                q[1 + l] = (M[l, i] + M[i, l]) / s
            q = np.asarray(q) / np.linalg.norm(q)
            out[k] = q if q[0] >= 0.0 else -q
        return out.reshape(*batch, 4)

    @staticmethod
    def derivative(quaternion, omega, omega_in_body_fixed: bool = False, K: float = 0.1) -> np.ndarray:
        """dQ/dt (..., 4) of Q (..., 4) rotating with angular velocity omega (..., 3) (world frame, or
        body frame with `omega_in_body_fixed`), with JaxSim's Baumgarte term K |w| (1 - |Q|) that pulls
        |Q| back to 1."""
        q = _array(quaternion, "quaternion", (4,))
        w = _array(omega, "omega", (3,))
        batch = np.broadcast_shapes(q.shape[:-1], w.shape[:-1])
        q, w = np.broadcast_to(q, (*batch, 4)), np.broadcast_to(w, (*batch, 3))
        stabilisation = K * np.maximum(np.linalg.norm(w, axis=-1), 1e-6) * (1.0 - np.linalg.norm(q, axis=-1))
        pure = np.concatenate([np.zeros((*batch, 1), dtype=w.dtype), w], axis=-1)
        rate = _quat_mul(q, pure) if omega_in_body_fixed else _quat_mul(pure, q)
        return 0.5 * (rate + stabilisation[..., None] * q)

    @staticmethod
    def integration(quaternion, dt, omega, omega_in_body_fixed: bool = False) -> np.ndarray:
        """Q(t + dt) (..., 4) under constant angular velocity omega (..., 3): exp(dt w) Q (world omega)
        or Q exp(dt w) (body omega), on the manifold."""
        q = _array(quaternion, "quaternion", (4,))
        w = _array(omega, "omega", (3,)) * np.asarray(dt, dtype=np.float64)[..., None]
        angle = np.linalg.norm(w, axis=-1, keepdims=True)
        small = angle < 1e-8
        scale = np.where(small, 0.5 - angle**2 / 48.0, np.sin(0.5 * angle) / np.where(small, 1.0, angle))
        dq = np.concatenate([np.cos(0.5 * angle), scale * w], axis=-1)
        out = _quat_mul(q, dq) if omega_in_body_fixed else _quat_mul(dq, q)
        return out.astype(_dtype(q, _array(omega, "omega", (3,))))


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (..., 4) (w, x, y, z)."""
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, axis=-1, keepdims=True), aw * bv + bw * av + np.cross(av, bv)], axis=-1)


class Rotation:
    """Rotation matrices."""

    @staticmethod
    def _about(axis: int, theta) -> np.ndarray:
        t = np.asarray(theta)
        t = t if t.dtype.kind == "f" else t.astype(np.float64)
        c, s = np.cos(t), np.sin(t)
        R = np.zeros((*t.shape, 3, 3), dtype=t.dtype)
        i, j = [(1, 2), (2, 0), (0, 1)][axis]
        R[..., axis, axis] = 1.0
        R[..., i, i], R[..., i, j], R[..., j, i], R[..., j, j] = c, -s, s, c
        return R

    @staticmethod
    def x(theta) -> np.ndarray:
        """Rotation (..., 3, 3) of theta [rad] about x."""
        return Rotation._about(0, theta)

    @staticmethod
    def y(theta) -> np.ndarray:
        return Rotation._about(1, theta)

    @staticmethod
    def z(theta) -> np.ndarray:
        return Rotation._about(2, theta)

    @staticmethod
    def from_axis_angle(vector) -> np.ndarray:
        """The rotation (..., 3, 3) of angle |v| about v / |v| (Rodrigues), identity for v = 0."""
        v = _array(vector, "vector", (3,))
        theta = np.linalg.norm(v, axis=-1)[..., None, None]
        safe = np.where(theta > 0.0, theta, 1.0)
        K = Skew.wedge(v) / safe
        eye = np.broadcast_to(np.eye(3, dtype=v.dtype), K.shape)
        return eye + np.sin(theta) * K + (1.0 - np.cos(theta)) * (K @ K)


    @staticmethod
    def log_vee(R) -> np.ndarray:
        """The rotation vector (..., 3) of rotation matrices R (..., 3, 3): axis times angle in [0, pi], the
        logarithm of SO(3) (the inverse of `from_axis_angle`). The angle is atan2(|vee(R)|, (tr R - 1) / 2),
        accurate at every angle; near pi the axis comes from R + R^T, elsewhere from the skew part vee(R) =
        sin(angle) axis over sin(angle)."""
        R = _array(R, "R", (3, 3))
        skew = Skew.vee(R)  # sin(angle) * axis
        sin = np.linalg.norm(skew, axis=-1)
        cos = 0.5 * (np.trace(R, axis1=-2, axis2=-1) - 1.0)
        angle = np.arctan2(sin, cos)
        small = angle < 1e-6
        scale = np.where(small, 1.0 + angle**2 / 6.0, angle / np.where(sin > 0.0, sin, 1.0))
        out = scale[..., None] * skew
        near_pi = angle > np.pi - 1e-3
        if np.any(near_pi):
            # (R + R^T) / 2 = cos I + (1 - cos) a a^T: the axis from its largest diagonal entry's column
            S = 0.5 * (R + np.swapaxes(R, -1, -2)) - cos[..., None, None] * np.eye(3)
            column = np.argmax(np.diagonal(S, axis1=-2, axis2=-1), axis=-1)
            axis = np.take_along_axis(S, column[..., None, None], axis=-1)[..., 0]
            norm = np.linalg.norm(axis, axis=-1, keepdims=True)
            axis = axis / np.where(norm > 0.0, norm, 1.0)  # (rows away from pi, where S may vanish, are not used)
            axis = axis * np.where(np.sum(axis * skew, axis=-1, keepdims=True) < 0.0, -1.0, 1.0)  # the sign of sin * axis
            out = np.where(near_pi[..., None], angle[..., None] * axis, out)
        return out


class Transform:
    """Homogeneous transforms A_H_B (..., 4, 4)."""

    @staticmethod
    def from_rotation_and_translation(rotation=None, translation=None, inverse: bool = False) -> np.ndarray:
        """A_H_B of A_R_B (..., 3, 3) and A_p_B (..., 3) (defaults: identity, zero); B_H_A with `inverse`."""
        R = _array(np.eye(3) if rotation is None else rotation, "rotation", (3, 3))
        p = _array(np.zeros(3) if translation is None else translation, "translation", (3,))
        dtype = _dtype(R, p)
        batch = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
        if inverse:
            R, p = np.swapaxes(R, -1, -2), -np.einsum("...ij,...j->...i", np.swapaxes(R, -1, -2), p)
        H = np.zeros((*batch, 4, 4), dtype=dtype)
        H[..., :3, :3] = R
        H[..., :3, 3] = p
        H[..., 3, 3] = 1.0
        return H

    @staticmethod
    def from_quaternion_and_translation(
        quaternion=None, translation=None, inverse: bool = False, normalize_quaternion: bool = False
    ) -> np.ndarray:
        """A_H_B of the quaternion (..., 4) (w, x, y, z) and A_p_B (..., 3); B_H_A with `inverse`.
        The quaternion is always normalised (see the module docstring)."""
        q = np.array([1.0, 0.0, 0.0, 0.0]) if quaternion is None else quaternion
        return Transform.from_rotation_and_translation(Quaternion.to_dcm(q), translation, inverse)

    @staticmethod
    def inverse(transform) -> np.ndarray:
        """B_H_A (..., 4, 4) of A_H_B (..., 4, 4): [[R^T, -R^T p], [0, 1]]."""
        H = _array(transform, "transform", (4, 4))
        return Transform.from_rotation_and_translation(H[..., :3, :3], H[..., :3, 3], inverse=True)


class Adjoint:
    """Adjoint matrices A_X_B (..., 6, 6) = [[R, p^ R], [0, R]] of A_H_B = (R, p), [linear; angular]."""

    @staticmethod
    def from_rotation_and_translation(rotation=None, translation=None, inverse: bool = False) -> np.ndarray:
        """A_X_B of A_R_B (..., 3, 3) and A_p_B (..., 3); B_X_A = [[R^T, -R^T p^], [0, R^T]] with `inverse`."""
        R = _array(np.eye(3) if rotation is None else rotation, "rotation", (3, 3))
        p = _array(np.zeros(3) if translation is None else translation, "translation", (3,))
        batch = np.broadcast_shapes(R.shape[:-2], p.shape[:-1])
        R = np.broadcast_to(R, (*batch, 3, 3)).astype(_dtype(R, p))
        P = Skew.wedge(np.broadcast_to(p, (*batch, 3))).astype(R.dtype)
        zero = np.zeros_like(R)
        if inverse:
            Rt = np.swapaxes(R, -1, -2)
            return _blocks(Rt, -Rt @ P, zero, Rt)
        return _blocks(R, P @ R, zero, R)

    @staticmethod
    def from_quaternion_and_translation(
        quaternion=None, translation=None, inverse: bool = False, normalize_quaternion: bool = False
    ) -> np.ndarray:
        q = np.array([1.0, 0.0, 0.0, 0.0]) if quaternion is None else quaternion
        return Adjoint.from_rotation_and_translation(Quaternion.to_dcm(q), translation, inverse)

    @staticmethod
    def from_transform(transform, inverse: bool = False) -> np.ndarray:
        """A_X_B (..., 6, 6) of A_H_B (..., 4, 4); B_X_A with `inverse`."""
        H = _array(transform, "transform", (4, 4))
        return Adjoint.from_rotation_and_translation(H[..., :3, :3], H[..., :3, 3], inverse)

    @staticmethod
    def to_transform(adjoint) -> np.ndarray:
        """A_H_B (..., 4, 4) of A_X_B (..., 6, 6)."""
        X = _array(adjoint, "adjoint", (6, 6))
        R = X[..., :3, :3]
        return Transform.from_rotation_and_translation(R, Skew.vee(X[..., :3, 3:] @ np.swapaxes(R, -1, -2)))

    @staticmethod
    def inverse(adjoint) -> np.ndarray:
        """B_X_A (..., 6, 6) of A_X_B."""
        H = Adjoint.to_transform(adjoint)
        return Adjoint.from_rotation_and_translation(H[..., :3, :3], H[..., :3, 3], inverse=True)


class Inertia:
    """6D inertia matrices M = [[m 1, m c^T], [m c^, I + m c^ c^T]] in a frame where the CoM is at c."""

    @staticmethod
    def to_sixd(mass, com, I) -> np.ndarray:
        """M (..., 6, 6) of mass (...), com (..., 3) and the inertia I (..., 3, 3) about the CoM."""
        c = Skew.wedge(_array(com, "com", (3,)))
        I = _array(I, "I", (3, 3))
        m = np.asarray(mass)[..., None, None]
        ct = np.swapaxes(c, -1, -2)
        eye = np.broadcast_to(np.eye(3), c.shape)
        return _blocks(m * eye, m * ct, m * c, I + m * (c @ ct))

    @staticmethod
    def to_params(M) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(mass (...), com (..., 3), I (..., 3, 3) about the CoM) of M (..., 6, 6)."""
        M = _array(M, "M", (6, 6))
        m = np.trace(M[..., :3, :3], axis1=-2, axis2=-1) / 3.0
        mC = M[..., 3:, :3]
        c = Skew.vee(mC) / m[..., None]
        I = M[..., 3:, 3:] - mC @ np.swapaxes(mC, -1, -2) / m[..., None, None]
        return m, c, I


def safe_norm(array, *, axis=None, keepdims: bool = False) -> np.ndarray:
    """The Euclidean norm of `array` over `axis` (all axes when None), 0 for a zero array: JaxSim's norm
    whose gradient is finite at 0 (NumPy computes no gradient; in kernels, `functions(scalar)` has
    `safe_norm`)."""
    a = _array(array, "array", ())
    return np.sqrt(np.sum(a * a, axis=axis, keepdims=keepdims))


def supported_joint_motion(joint_types, joint_positions, joint_axes) -> np.ndarray:
    """pre_H_suc (..., 4, 4): the motion of joints of `joint_types` (...) (0 fixed, 1 revolute, 2 prismatic,
    JaxSim's codes) at `joint_positions` (...) [rad or m] along the unit `joint_axes` (..., 3): a rotation
    by q about the axis, a translation by q along it, or the identity."""
    types = np.asarray(joint_types)
    q = _array(joint_positions, "joint_positions", ())
    axes = _array(joint_axes, "joint_axes", (3,))
    batch = np.broadcast_shapes(types.shape, q.shape, axes.shape[:-1])
    types, q, axes = np.broadcast_to(types, batch), np.broadcast_to(q, batch), np.broadcast_to(axes, (*batch, 3))
    unknown = sorted(set(np.unique(types).tolist()) - {0, 1, 2})
    if unknown:
        raise ValueError(f"joint_types must be 0 (fixed), 1 (revolute) or 2 (prismatic), got {unknown}")
    H = np.zeros((*batch, 4, 4), dtype=np.result_type(q, axes))
    H[...] = np.eye(4)
    revolute, prismatic = types == 1, types == 2
    H[..., :3, :3] = np.where(revolute[..., None, None], Rotation.from_axis_angle(q[..., None] * axes), H[..., :3, :3])
    H[..., :3, 3] = np.where(prismatic[..., None], q[..., None] * axes, 0.0)
    return H
