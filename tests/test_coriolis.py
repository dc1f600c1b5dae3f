"""The free-floating Coriolis matrix (warpdyn.model.free_floating_coriolis_matrix, warpdyn.engine.coriolis), in every representation.

References (no library computes JaxSim's C for us, so it is checked by what defines it):
- C nu = h - g, with h and g from warpdyn's RNEA (tested against MuJoCo's qfrc_bias in test_dynamics).
- Mdot - 2C skew-symmetric, i.e. Mdot = C + C^T, with Mdot the central finite difference of warpdyn's CRBA
  mass matrix (tested against mj_fullM) along the motion: joints along sdot, the base pose exactly along
  its velocity held constant in the data's representation (Body: W_H_B exp(t B_v^); Inertial:
  exp(t W_v^) W_H_B; Mixed: W_p_B + t W_pdot_B and exp(t W_omega^) W_R_B).
- JaxSim's formula evaluated in NumPy from warpdyn's Body Jacobians and Jacobian derivatives (tested against
  MuJoCo and finite differences in test_kinematics_mujoco and test_jacobian_derivatives):
  C_B = sum_L J^T ((v x* M + M v x) J + M Jdot), C = T^T (M_B Tdot + C_B T). For fixed bases JaxSim drops the
  base link and zeroes the base-joint blocks; warpdyn keeps them (see warpdyn.engine.coriolis), so there only the
  joint block is compared with JaxSim's rule, and the whole matrix with the rule without those changes.
- Batched equals single-environment, in both memory layouts; tape gradients equal central finite differences.

Tolerances are relative to the largest entry compared (at least 1). float64: 1e-10 for identities (sums of
O(100) products of O(1) numbers: observed <= 6e-15; a wrong term is O(1), so the margin hides nothing); the
finite difference of M with step 1e-5 has truncation error ~1e-10 |M'''| and round-off ~1e-11 (observed
<= 4e-10), hence 1e-8. float32: 5e-5 (epsilon 1.2e-7 amplified by composed transforms and by inertias of
links metres from the base: observed <= 3e-6); Mdot is then the float64 finite difference.
"""

from __future__ import annotations

import zlib

import numpy as np
import pytest
import warp as wp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

import robots
import warpdyn as wd
from warpdyn import VelRepr
from warpdyn.model import free_floating_coriolis_matrix

REPRS = list(VelRepr)
TOL = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 5e-5}
FD_TOL = 1e-8


CASES = {
    **{f"random_{s}": (lambda s=s: (robots.random_tree_urdf(s), None)) for s in range(4)},
    "random_fixed_101": lambda: (robots.random_tree_urdf(101, fixed_base=True), None),
    "random_fixed_7": lambda: (robots.random_tree_urdf(7, fixed_base=True), None),
    "random_deep_chain": lambda: (robots.random_tree_urdf(102, num_links=31, max_depth=30), None),
    "single_link": lambda: (robots.random_tree_urdf(5, num_links=1), None),
    "pendulum_chain": lambda: (robots.pendulum_chain_urdf(6), None),
    "icub_legs": robots.icub_legs_source,
    "ergocub_seed": robots.ergocub_seed_source,
}
IDENTITY_CASES = list(CASES)
SHORT_CASES = ["random_1", "random_fixed_101", "icub_legs", "ergocub_seed"]

_MODELS: dict = {}


def _model(case, dtype):
    key = (case, np.dtype(dtype))
    if key not in _MODELS:
        text, considered = CASES[case]()
        _MODELS[key] = wd.model.Model.build_from_model_description(text, dtype=dtype, considered_joints=considered)
    return _MODELS[key]


def _seed(*parts) -> int:
    """A fresh, reproducible seed per test and case."""
    return zlib.crc32(repr(parts).encode()) % 100_000


def _scale(*arrays) -> float:
    return max(1.0, *(float(np.abs(a).max()) for a in arrays if a.size))


# ------------------------------------------------------------------------------------ C nu = h - g


@pytest.mark.parametrize("repr", REPRS, ids=lambda r: r.name)
@pytest.mark.parametrize("case", IDENTITY_CASES)
def test_coriolis_times_velocity_is_bias_minus_gravity(case, repr, dtype):
    """C nu = h - g in every row (fixed bases included: warpdyn's h keeps the base rows), N = 3 random
    states. Reference: warpdyn's RNEA (h with and without velocities). Tolerance: module docstring."""
    model = _model(case, dtype)
    N = 3
    data = wd.data.random_model_data(model, num_envs=N, key=_seed("cnu", case, repr), velocity_representation=repr)
    C = free_floating_coriolis_matrix(model, data).numpy()
    h = wd.model.free_floating_bias_forces(model, data).numpy()
    g = wd.model.free_floating_gravity_forces(model, data).numpy()
    nu = data.generalized_velocity.numpy()
    n = model.dofs()
    assert C.shape == (N, 6 + n, 6 + n)
    assert np.all(np.isfinite(C))
    np.testing.assert_allclose(np.einsum("eij,ej->ei", C, nu), h - g, atol=TOL[np.dtype(dtype)] * _scale(h - g, C))


# ------------------------------------------------------------------------------------ Mdot - 2C skew


def _hat(xi) -> np.ndarray:
    """The 4x4 matrix of a twist [v; omega]."""
    H = np.zeros((4, 4))
    H[:3, :3] = robots.skew(xi[3:])
    H[:3, 3] = xi[:3]
    return H


def _pose_along(repr, p, R, v, t):
    """(W_p_B, W_R_B) after time t with the base velocity v held constant in `repr`."""
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = R, p
    if repr == VelRepr.Body:
        H = H @ expm(t * _hat(v))
    elif repr == VelRepr.Inertial:
        H = expm(t * _hat(v)) @ H
    else:
        H[:3, 3] = p + t * np.asarray(v[:3])
        H[:3, :3] = expm(t * robots.skew(v[3:])) @ R
    return H[:3, 3], H[:3, :3]


def _wxyz(R) -> np.ndarray:
    x, y, z, w = Rotation.from_matrix(R).as_quat()
    return np.array([w, x, y, z])


def mass_matrix_derivative(model, data, eps=1e-5) -> np.ndarray:
    """(N, 6 + n, 6 + n): central finite difference of M along the motion of `data`'s state (float64 model)."""
    p = data.base_position.numpy()
    q = data.base_quaternion.numpy()
    s = data.joint_positions.numpy()
    v = data.base_velocity.numpy()
    sdot = data.joint_velocities.numpy()
    repr = data.velocity_representation

    def M_at(t):
        poses = [_pose_along(repr, p[e], robots.rotation_wxyz(q[e]), v[e], t) for e in range(len(p))]
        stepped = wd.data.Data.build(
            model,
            base_position=np.array([pose[0] for pose in poses]),
            base_quaternion=np.array([_wxyz(pose[1]) for pose in poses]),
            joint_positions=s + t * sdot,
            velocity_representation=repr,
            num_envs=len(p),
        )
        return wd.model.free_floating_mass_matrix(model, stepped).numpy()

    return (M_at(eps) - M_at(-eps)) / (2.0 * eps)


@pytest.mark.parametrize("repr", REPRS, ids=lambda r: r.name)
@pytest.mark.parametrize("case", IDENTITY_CASES)
def test_mass_matrix_derivative_minus_twice_coriolis_is_skew(case, repr, dtype):
    """Mdot - 2C is skew-symmetric (Mdot = C + C^T), Mdot by central finite differences of the float64 M
    along the motion (module docstring); for fixed bases the base stays where it is welded. The float32 C
    is compared with the float64 finite difference. Tolerance: FD_TOL (float64), TOL (float32)."""
    model64 = _model(case, np.float64)
    model = _model(case, dtype)
    N = 2
    seed = _seed("skew", case, repr)
    data64 = wd.data.random_model_data(model64, num_envs=N, key=seed, velocity_representation=repr)
    data = wd.data.random_model_data(model, num_envs=N, key=seed, velocity_representation=repr)
    Mdot = mass_matrix_derivative(model64, data64)
    C = free_floating_coriolis_matrix(model, data).numpy().astype(np.float64)
    tol = FD_TOL if np.dtype(dtype) == np.float64 else TOL[np.dtype(dtype)]
    np.testing.assert_allclose(C + np.transpose(C, (0, 2, 1)), Mdot, atol=tol * _scale(Mdot, C))
    skew = Mdot - 2.0 * C
    np.testing.assert_allclose(skew, -np.transpose(skew, (0, 2, 1)), atol=2 * tol * _scale(Mdot, C))


# ------------------------------------------------------------------------------------ JaxSim's formula


def _vx(v) -> np.ndarray:
    X = np.zeros((6, 6))
    X[:3, :3] = X[3:, 3:] = robots.skew(v[3:])
    X[:3, 3:] = robots.skew(v[:3])
    return X


def _adjoint_inverse(R, p) -> np.ndarray:
    """B_X_A for A_H_B = (R, p)."""
    return np.linalg.inv(robots.motion_transform(R, p))


def jaxsim_coriolis(model, data, fixed_base_rule: bool) -> np.ndarray:
    """(N, 6 + n, 6 + n): jaxsim.api.model.free_floating_coriolis_matrix (~0.9) in NumPy, from warpdyn's
    Body Jacobians and their derivatives; `fixed_base_rule` applies JaxSim's fixed-base changes."""
    repr = data.velocity_representation
    with data.switch_velocity_representation(VelRepr.Body):
        J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
        Jdot = wd.model.generalized_free_floating_jacobian_derivative(model, data).numpy()
        M_B = wd.model.free_floating_mass_matrix(model, data).numpy()
        nu_B = data.generalized_velocity.numpy()
    with data.switch_velocity_representation(VelRepr.Inertial):
        W_v_WB = data.base_velocity.numpy()
    with data.switch_velocity_representation(VelRepr.Mixed):
        BW_v_WB = data.base_velocity.numpy()
    I_L = wd.model.link_spatial_inertia_matrices(model).numpy().astype(np.float64)
    p, q = data.base_position.numpy(), data.base_quaternion.numpy()
    N, nL, n = J.shape[0], J.shape[1], model.dofs()
    out = np.zeros((N, 6 + n, 6 + n))
    for e in range(N):
        terms = []
        for L in range(nL):
            v = J[e, L] @ nu_B[e]
            X = -_vx(v).T @ I_L[L] + I_L[L] @ _vx(v)
            terms.append(J[e, L].T @ (X @ J[e, L] + I_L[L] @ Jdot[e, L]))
        if fixed_base_rule:
            C_B = np.sum(terms[1:], axis=0)
            C_B[:6, 6:] = 0.0
            C_B[6:, :6] = 0.0
        else:
            C_B = np.sum(terms, axis=0)
        R = robots.rotation_wxyz(q[e])
        T, Tdot = np.eye(6 + n), np.zeros((6 + n, 6 + n))
        if repr == VelRepr.Inertial:
            T[:6, :6] = _adjoint_inverse(R, p[e])
            Tdot[:6, :6] = -T[:6, :6] @ _vx(W_v_WB[e])
        elif repr == VelRepr.Mixed:
            T[:6, :6] = _adjoint_inverse(R, np.zeros(3))
            Tdot[:6, :6] = -T[:6, :6] @ _vx(np.r_[np.zeros(3), BW_v_WB[e, 3:]])
        out[e] = C_B if repr == VelRepr.Body else T.T @ (M_B[e] @ Tdot + C_B @ T)
    return out


@pytest.mark.parametrize("repr", REPRS, ids=lambda r: r.name)
@pytest.mark.parametrize("case", SHORT_CASES + ["random_fixed_7", "pendulum_chain"])
def test_matches_jaxsim_formula(case, repr):
    """C equals JaxSim's formula evaluated from warpdyn's Jacobians (module docstring). Floating bases: the
    whole matrix. Fixed bases: the joint block against JaxSim's fixed-base rule, and the whole matrix
    against the rule that keeps the base link and the base-joint blocks. float64, TOL."""
    model = _model(case, np.float64)
    data = wd.data.random_model_data(model, num_envs=2, key=_seed("jaxsim", case, repr), velocity_representation=repr)
    C = free_floating_coriolis_matrix(model, data).numpy()
    tol = TOL[np.dtype(np.float64)] * _scale(C)
    np.testing.assert_allclose(C, jaxsim_coriolis(model, data, fixed_base_rule=False), atol=tol)
    if not model.floating_base():
        expected = jaxsim_coriolis(model, data, fixed_base_rule=True)
        np.testing.assert_allclose(C[:, 6:, 6:], expected[:, 6:, 6:], atol=tol)


# ------------------------------------------------------------------------------------ batching


@pytest.mark.parametrize("repr", REPRS, ids=lambda r: r.name)
@pytest.mark.parametrize("case", SHORT_CASES + ["single_link"])
def test_batched_equals_single(case, repr, dtype, layout):
    """Each environment of a batch (N = 3) equals the same state as single-environment data, whose C has
    JaxSim's shape (6 + n, 6 + n); both memory layouts. Same arithmetic, so float64 1e-12 and float32 1e-6."""
    model = _model(case, dtype)
    N = 3
    batch = wd.data.random_model_data(model, num_envs=N, key=_seed("batch", case, repr), velocity_representation=repr)
    C = free_floating_coriolis_matrix(model, batch).numpy()
    n = model.dofs()
    assert C.shape == (N, 6 + n, 6 + n)
    tol = 1e-12 if np.dtype(dtype) == np.float64 else 1e-6
    v = batch.base_velocity.numpy()
    for e in range(N):
        single = wd.data.Data.build(
            model,
            base_position=batch.base_position.numpy()[e],
            base_quaternion=batch.base_quaternion.numpy()[e],
            joint_positions=batch.joint_positions.numpy()[e],
            base_linear_velocity=v[e, :3],
            base_angular_velocity=v[e, 3:],
            joint_velocities=batch.joint_velocities.numpy()[e],
            velocity_representation=repr,
        )
        C_single = free_floating_coriolis_matrix(model, single).numpy()
        assert C_single.shape == (6 + n, 6 + n)
        np.testing.assert_allclose(C_single, C[e], atol=tol * _scale(C[e]), rtol=0)


# ------------------------------------------------------------------------------------ gradients


@wp.kernel
def _weighted_sum(x: wp.array3d(dtype=wp.float64), w: wp.array3d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    env, r, c = wp.tid()
    wp.atomic_add(loss, 0, x[env, r, c] * w[env, r, c])


_STATE = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")


@pytest.mark.parametrize("repr", REPRS, ids=lambda r: r.name)
@pytest.mark.parametrize("case", ["random_2", "random_fixed_7"])
def test_tape_gradients_match_finite_differences(case, repr):
    """wp.Tape gradients of a random weighted sum of C's entries with respect to every state array
    (base position, raw quaternion, joint positions, the stored Mixed base velocity, joint velocities; a
    fixed base's velocity stays zero but its gradient is still checked) equal central finite differences.
    float64; step 1e-6 gives FD errors ~1e-9 on O(1) quantities; 5e-6 relative: on a GPU (fused multiply-adds)
    the tape's rounding reaches 1.5e-6 where the derivative is zero (a fixed base's quaternion)."""
    model = _model(case, np.float64)
    N, n = 2, model.dofs()
    base = wd.data.random_model_data(model, num_envs=N, key=_seed("grad", case, repr), velocity_representation=repr)
    values = {name: getattr(base, f"{name}_state").numpy().copy() for name in _STATE}
    w = wp.array(np.random.default_rng(_seed("w", case, repr)).normal(size=(N, 6 + n, 6 + n)), dtype=wp.float64)

    def data_with(state, requires_grad=False):
        data = wd.data.Data.build(
            model,
            base_position=state["base_position"],
            base_quaternion=state["base_quaternion"],
            joint_positions=state["joint_positions"],
            joint_velocities=state["joint_velocities"],
            velocity_representation=repr,
            num_envs=N,
            requires_grad=requires_grad,
            validate=False,
        )
        data.base_velocity_state.assign(wp.array(state["base_velocity"], dtype=wp.float64))
        return data

    def loss_of(data):
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        C = free_floating_coriolis_matrix(model, data)
        wp.launch(_weighted_sum, dim=(N, 6 + n, 6 + n), inputs=[C, w], outputs=[loss])
        return loss

    data = data_with(values, requires_grad=True)
    tape = wp.Tape()
    with tape:
        loss = loss_of(data)
    tape.backward(loss)

    eps = 1e-6
    checked = 0
    for name in _STATE:
        grad = getattr(data, f"{name}_state").grad.numpy()
        for e in range(N):
            for k in range(values[name].shape[1]):
                plus = {key: value.copy() for key, value in values.items()}
                minus = {key: value.copy() for key, value in values.items()}
                plus[name][e, k] += eps
                minus[name][e, k] -= eps
                fd = (loss_of(data_with(plus)).numpy()[0] - loss_of(data_with(minus)).numpy()[0]) / (2 * eps)
                assert abs(grad[e, k] - fd) <= 5e-6 * max(1.0, abs(fd)), (name, e, k, grad[e, k], fd)
                checked += abs(fd) > 1e-3
    assert checked > N * n  # the loss does depend on the state
