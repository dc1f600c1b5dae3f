"""wd.math: JaxSim's math helpers on the host (NumPy, batched) and as @wp.funcs in kernels.

References: independent NumPy formulas written here (cross products, Hamilton products, np.linalg.inv,
kinetic energy), the repository's other implementation of Rodrigues' formula
(warpdyn.description.axis_angle_to_matrix) and, for the @wp.func versions, the host versions (themselves
checked against the formulas). Tolerances: host float64 1e-12 (a handful of products of O(1) numbers;
observed ~1e-15); finite differences of quaternion integration 1e-8 (step 1e-6: truncation ~1e-12,
rounding ~1e-10); kernels vs host float64 1e-12, float32 2e-5 relative to the entries' size (float32
epsilon 1.2e-7 times a few products of entries up to ~3; observed ≤ 1e-15 and ≤ 2e-7).
"""

import numpy as np
import pytest
import warp as wp

import warpdyn as wd
from warpdyn.description import axis_angle_to_matrix
from warpdyn.math import Adjoint, Cross, Inertia, Quaternion, Rotation, Skew, Transform

K = 7


def _random(seed=0):
    rng = np.random.default_rng(seed)
    q = rng.normal(size=(K, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    q[0] = [0.0, 0.6, 0.8, 0.0]  # a half-turn: the trace < 0 branch of from_dcm
    q[1] = [1.0, 0.0, 0.0, 0.0]
    p = rng.uniform(-2.0, 2.0, size=(K, 3))
    return rng, q, p


def _hamilton(a, b):
    w1, x1, y1, z1 = np.moveaxis(a, -1, 0)
    w2, x2, y2, z2 = np.moveaxis(b, -1, 0)
    return np.stack([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ], axis=-1)


def _rotate(q, x):
    """x rotated by the unit quaternion q: the vector part of q (x) [0; x] (x) q*."""
    conj = q * np.array([1.0, -1.0, -1.0, -1.0])
    pure = np.concatenate([np.zeros((*x.shape[:-1], 1)), x], axis=-1)
    return _hamilton(_hamilton(q, pure), conj)[..., 1:]


def _homogeneous(R, p):
    H = np.zeros((*R.shape[:-2], 4, 4))
    H[..., :3, :3], H[..., :3, 3], H[..., 3, 3] = R, p, 1.0
    return H


# ------------------------------------------------------------------------------------------ host


def test_skew_and_cross():
    """Skew.wedge(v) w = v x w, vee inverts wedge; Cross.vx(v) m and vx_star(v) f equal the spatial
    cross products written with np.cross; vx_star = -vx^T. Batched shapes kept."""
    rng = np.random.default_rng(1)
    v, w = rng.normal(size=(K, 3)), rng.normal(size=(K, 3))
    W = Skew.wedge(v)
    assert W.shape == (K, 3, 3) and Skew.wedge(v[0]).shape == (3, 3)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", W, w), np.cross(v, w), atol=1e-12)
    np.testing.assert_allclose(Skew.vee(W), v, atol=1e-15)
    s, m, f = rng.normal(size=(K, 6)), rng.normal(size=(K, 6)), rng.normal(size=(K, 6))
    lin, ang = s[:, :3], s[:, 3:]
    ref_m = np.concatenate([np.cross(ang, m[:, :3]) + np.cross(lin, m[:, 3:]), np.cross(ang, m[:, 3:])], axis=1)
    ref_f = np.concatenate([np.cross(ang, f[:, :3]), np.cross(ang, f[:, 3:]) + np.cross(lin, f[:, :3])], axis=1)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", Cross.vx(s), m), ref_m, atol=1e-12)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", Cross.vx_star(s), f), ref_f, atol=1e-12)
    np.testing.assert_array_equal(Cross.vx_star(s), -np.swapaxes(Cross.vx(s), 1, 2))


def test_quaternions():
    """to_dcm rotates as q (x) [0; x] (x) q* (after normalising); from_dcm inverts it (w >= 0, half-turns
    included); to_xyzw / to_wxyz permute; derivative equals central differences of integration
    (world and body angular velocities); integration composes with Rodrigues' rotation."""
    rng, q, _ = _random(2)
    x = rng.normal(size=(K, 3))
    R = Quaternion.to_dcm(3.0 * q)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", R, x), _rotate(q, x), atol=1e-12)
    np.testing.assert_allclose(R @ np.swapaxes(R, 1, 2), np.tile(np.eye(3), (K, 1, 1)), atol=1e-12)
    back = Quaternion.from_dcm(R)
    np.testing.assert_allclose(back, q * np.where(q[:, :1] < 0, -1.0, 1.0), atol=1e-12)
    assert np.all(back[:, 0] >= 0)
    np.testing.assert_array_equal(Quaternion.to_xyzw(q)[:, 3], q[:, 0])
    np.testing.assert_array_equal(Quaternion.to_wxyz(Quaternion.to_xyzw(q)), q)
    omega = rng.normal(size=(K, 3))
    h = 1e-6
    for body in (False, True):
        qdot = Quaternion.derivative(q, omega, omega_in_body_fixed=body)
        assert qdot.shape == (K, 4)
        fd = (Quaternion.integration(q, h, omega, body) - Quaternion.integration(q, -h, omega, body)) / (2 * h)
        np.testing.assert_allclose(qdot, fd, atol=1e-8)
        dt = 0.3
        Rdt = np.array([axis_angle_to_matrix(w / np.linalg.norm(w), np.linalg.norm(w) * dt) for w in omega])
        expected = R @ Rdt if body else Rdt @ R
        np.testing.assert_allclose(Quaternion.to_dcm(Quaternion.integration(q, dt, omega, body)), expected, atol=1e-12)
    # The stabilisation term pulls |q| back towards 1.
    grown = 1.1 * q
    assert np.all(np.sum(grown * Quaternion.derivative(grown, omega), axis=1) < 0)


def test_rotations():
    """Rotation.x/y/z and from_axis_angle against warpdyn.description.axis_angle_to_matrix."""
    rng = np.random.default_rng(3)
    for axis, fn in enumerate((Rotation.x, Rotation.y, Rotation.z)):
        theta = rng.uniform(-3, 3, size=K)
        np.testing.assert_allclose(fn(theta), [axis_angle_to_matrix(np.eye(3)[axis], t) for t in theta], atol=1e-12)
    v = rng.normal(size=(K, 3))
    ref = [axis_angle_to_matrix(u / np.linalg.norm(u), np.linalg.norm(u)) for u in v]
    np.testing.assert_allclose(Rotation.from_axis_angle(v), ref, atol=1e-12)
    np.testing.assert_array_equal(Rotation.from_axis_angle(np.zeros(3)), np.eye(3))


def test_transforms_and_adjoints():
    """Transform.from_quaternion_and_translation and inverse against np.linalg.inv; Adjoint.from_transform
    maps motion vectors as [R v + p x R w; R w] and, inverted and transposed, forces as [R f; R t + p x R f];
    inverse=True equals np.linalg.inv; to_transform and Adjoint.inverse invert; the adjoint of a product is
    the product of the adjoints."""
    rng, q, p = _random(4)
    H = Transform.from_quaternion_and_translation(quaternion=q, translation=p)
    R = Quaternion.to_dcm(q)
    np.testing.assert_allclose(H, _homogeneous(R, p), atol=1e-15)
    np.testing.assert_allclose(Transform.inverse(H), np.linalg.inv(H), atol=1e-12)
    np.testing.assert_allclose(Transform.from_quaternion_and_translation(q, p, inverse=True), np.linalg.inv(H), atol=1e-12)
    np.testing.assert_allclose(Transform.from_rotation_and_translation(R, p), H, atol=1e-15)
    np.testing.assert_array_equal(Transform.from_quaternion_and_translation(), np.eye(4))
    X = Adjoint.from_transform(H)
    assert X.shape == (K, 6, 6) and Adjoint.from_transform(H[0]).shape == (6, 6)
    v, f = rng.normal(size=(K, 6)), rng.normal(size=(K, 6))
    Rw = np.einsum("kij,kj->ki", R, v[:, 3:])
    ref_v = np.concatenate([np.einsum("kij,kj->ki", R, v[:, :3]) + np.cross(p, Rw), Rw], axis=1)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", X, v), ref_v, atol=1e-12)
    Xinv = Adjoint.from_transform(H, inverse=True)
    np.testing.assert_allclose(Xinv, np.linalg.inv(X), atol=1e-12)
    Rf = np.einsum("kij,kj->ki", R, f[:, :3])
    ref_f = np.concatenate([Rf, np.einsum("kij,kj->ki", R, f[:, 3:]) + np.cross(p, Rf)], axis=1)
    np.testing.assert_allclose(np.einsum("kji,kj->ki", Xinv, f), ref_f, atol=1e-12)
    np.testing.assert_allclose(Adjoint.to_transform(X), H, atol=1e-12)
    np.testing.assert_allclose(Adjoint.inverse(X), Xinv, atol=1e-12)
    np.testing.assert_allclose(Adjoint.from_quaternion_and_translation(q, p), X, atol=1e-15)
    np.testing.assert_allclose(Adjoint.from_rotation_and_translation(R, p, inverse=True), Xinv, atol=1e-15)
    np.testing.assert_allclose(Adjoint.from_transform(H[:-1] @ H[1:]), X[:-1] @ X[1:], atol=1e-12)


def test_inertia():
    """Inertia.to_sixd gives the kinetic energy 1/2 m |v + w x c|^2 + 1/2 w^T I w as 1/2 nu^T M nu;
    to_params inverts it."""
    rng = np.random.default_rng(5)
    m = rng.uniform(0.5, 3.0, size=K)
    c = rng.normal(size=(K, 3))
    A = rng.normal(size=(K, 3, 3))
    I = A @ np.swapaxes(A, 1, 2)
    M = Inertia.to_sixd(m, c, I)
    nu = rng.normal(size=(K, 6))
    v_com = nu[:, :3] + np.cross(nu[:, 3:], c)
    energy = 0.5 * m * np.sum(v_com**2, axis=1) + 0.5 * np.einsum("ki,kij,kj->k", nu[:, 3:], I, nu[:, 3:])
    np.testing.assert_allclose(0.5 * np.einsum("ki,kij,kj->k", nu, M, nu), energy, rtol=1e-12)
    m2, c2, I2 = Inertia.to_params(M)
    np.testing.assert_allclose(m2, m, rtol=1e-14)
    np.testing.assert_allclose(c2, c, atol=1e-12)
    np.testing.assert_allclose(I2, I, atol=1e-12)


def test_inputs_dtypes_and_errors():
    """float32 stays float32, integers become float64, Warp arrays are read, wrong shapes raise ValueError."""
    H32 = np.eye(4, dtype=np.float32)
    assert Adjoint.from_transform(H32).dtype == np.float32
    assert Transform.inverse(H32).dtype == np.float32
    assert Skew.wedge(np.array([1, 2, 3])).dtype == np.float64
    H = np.tile(np.eye(4), (3, 1, 1))
    H[:, :3, 3] = [[1, 2, 3], [4, 5, 6], [7, 8, 9]]
    np.testing.assert_array_equal(Transform.inverse(wp.array(H, dtype=wp.float64)), Transform.inverse(H))
    with pytest.raises(ValueError, match=r"transform must have shape \(\.\.\., 4, 4\)"):
        Adjoint.from_transform(np.eye(3))
    with pytest.raises(ValueError, match="quaternion"):
        Quaternion.to_dcm(np.ones(3))


# ---------------------------------------------------------------------------------------- kernels


def test_wp_functions_equal_host_functions(dtype):
    """Every @wp.func of wd.math.functions(scalar), called in one kernel with JaxSim's keyword names,
    equals the host function on the same inputs, including the seed's G_Xf_C line
    (Adjoint.from_transform(G_H_W @ W_H_C, inverse=True))."""
    scalar = wp.float64 if np.dtype(dtype) == np.float64 else wp.float32
    wm = wd.math.functions(scalar)

    @wp.kernel(module="unique")
    def evaluate(
        v3: wp.array(dtype=wm.vec3),
        v6: wp.array(dtype=wm.vec6),
        q: wp.array(dtype=wm.vec4),
        H: wp.array(dtype=wm.mat44),
        I: wp.array(dtype=wm.mat33),
        mass: wp.array(dtype=scalar),
        G_H_W: wm.mat44,
        wedge: wp.array(dtype=wm.mat33),
        vee: wp.array(dtype=wm.vec3),
        vx: wp.array(dtype=wm.mat66),
        vx_star: wp.array(dtype=wm.mat66),
        dcm: wp.array(dtype=wm.mat33),
        from_dcm: wp.array(dtype=wm.vec4),
        xyzw: wp.array(dtype=wm.vec4),
        axis_angle: wp.array(dtype=wm.mat33),
        T_qp: wp.array(dtype=wm.mat44),
        T_inv: wp.array(dtype=wm.mat44),
        X: wp.array(dtype=wm.mat66),
        X_inv: wp.array(dtype=wm.mat66),
        X_qp: wp.array(dtype=wm.mat66),
        X_to_H: wp.array(dtype=wm.mat44),
        X_inverse: wp.array(dtype=wm.mat66),
        M6: wp.array(dtype=wm.mat66),
        G_Xf_C: wp.array(dtype=wm.mat66),
    ):
        k = wp.tid()
        wedge[k] = wm.Skew.wedge(vector=v3[k])
        vee[k] = wm.Skew.vee(matrix=wedge[k] + wp.transpose(I[k]) - I[k])
        vx[k] = wm.Cross.vx(velocity_sixd=v6[k])
        vx_star[k] = wm.Cross.vx_star(v6[k])
        dcm[k] = wm.Quaternion.to_dcm(quaternion=q[k])
        from_dcm[k] = wm.Quaternion.from_dcm(dcm=dcm[k])
        xyzw[k] = wm.Quaternion.to_xyzw(q[k])
        axis_angle[k] = wm.Rotation.from_axis_angle(vector=v3[k])
        T_qp[k] = wm.Transform.from_quaternion_and_translation(quaternion=q[k], translation=v3[k])
        T_inv[k] = wm.Transform.inverse(transform=H[k])
        X[k] = wm.Adjoint.from_transform(transform=H[k], inverse=False)
        X_inv[k] = wm.Adjoint.from_transform(H[k], True)
        X_qp[k] = wm.Adjoint.from_quaternion_and_translation(quaternion=q[k], translation=v3[k], inverse=True)
        X_to_H[k] = wm.Adjoint.to_transform(adjoint=X[k])
        X_inverse[k] = wm.Adjoint.inverse(adjoint=X[k])
        M6[k] = wm.Inertia.to_sixd(mass[k], v3[k], I[k])
        G_Xf_C[k] = wm.Adjoint.from_transform(transform=G_H_W @ H[k], inverse=True)

    rng, q, p = _random(6)
    v3 = rng.normal(size=(K, 3))
    v3[1] = 0.0  # from_axis_angle at zero
    v6 = rng.normal(size=(K, 6))
    H = _homogeneous(Quaternion.to_dcm(q[::-1]), p)
    A = rng.normal(size=(K, 3, 3))
    I = A @ np.swapaxes(A, 1, 2)
    mass = rng.uniform(0.5, 3.0, size=K)
    G_H_W = Transform.inverse(_homogeneous(np.eye(3), np.array([0.1, -0.2, 0.7])))
    host = {
        "wedge": Skew.wedge(v3),
        "vee": v3,
        "vx": Cross.vx(v6),
        "vx_star": Cross.vx_star(v6),
        "dcm": Quaternion.to_dcm(q),
        "from_dcm": Quaternion.from_dcm(Quaternion.to_dcm(q)),
        "xyzw": Quaternion.to_xyzw(q),
        "axis_angle": Rotation.from_axis_angle(v3),
        "T_qp": Transform.from_quaternion_and_translation(q, v3),
        "T_inv": Transform.inverse(H),
        "X": Adjoint.from_transform(H),
        "X_inv": Adjoint.from_transform(H, inverse=True),
        "X_qp": Adjoint.from_quaternion_and_translation(q, v3, inverse=True),
        "X_to_H": H,
        "X_inverse": Adjoint.from_transform(H, inverse=True),
        "M6": Inertia.to_sixd(mass, v3, I),
        "G_Xf_C": Adjoint.from_transform(G_H_W @ H, inverse=True),
    }
    types = {
        "wedge": wm.mat33, "vee": wm.vec3, "vx": wm.mat66, "vx_star": wm.mat66, "dcm": wm.mat33, "from_dcm": wm.vec4,
        "xyzw": wm.vec4, "axis_angle": wm.mat33, "T_qp": wm.mat44, "T_inv": wm.mat44, "X": wm.mat66, "X_inv": wm.mat66,
        "X_qp": wm.mat66, "X_to_H": wm.mat44, "X_inverse": wm.mat66, "M6": wm.mat66, "G_Xf_C": wm.mat66,
    }  # fmt: skip
    outputs = {name: wp.empty(K, dtype=t) for name, t in types.items()}
    for out in outputs.values():
        out.fill_(float("nan"))  # unwritten outputs fail
    wp.launch(
        evaluate,
        dim=K,
        inputs=[
            wp.array(v3, dtype=wm.vec3), wp.array(v6, dtype=wm.vec6), wp.array(q, dtype=wm.vec4),
            wp.array(H, dtype=wm.mat44), wp.array(I, dtype=wm.mat33), wp.array(mass, dtype=scalar), wm.mat44(G_H_W),
        ],
        outputs=list(outputs.values()),
    )  # fmt: skip
    tol = 1e-12 if np.dtype(dtype) == np.float64 else 2e-5
    for name, ref in host.items():
        got = outputs[name].numpy()
        assert got.shape == ref.shape, name
        np.testing.assert_allclose(got, ref, rtol=0, atol=tol * max(1.0, np.abs(ref).max()), err_msg=name)
