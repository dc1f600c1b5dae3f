"""Equations of motion (RNEA, CRBA, ABA, Cholesky) against MuJoCo, against each other, and their gradients.

Reference: MuJoCo on the same URDF (fixed links fused, a free joint for floating bases), with contacts,
constraints, joint damping and springs off, so that its qacc solves M qacc + qfrc_bias = qfrc_applied.
MuJoCo's generalized velocity [W_pdot_B; B_omega; sdot] is warpdyn's Mixed one with the angular part
rotated: nu_mj = P nu_mixed, P = blockdiag(1, R^T, 1), so M_mixed = P^T M_mj P and h_mixed = P^T h_mj.
"""

import math

import mujoco
import numpy as np
import pytest
import warp as wp

import gradcheck
import robots
import warpdyn as wd
from warpdyn import VelRepr

# float64: sums of O(100) products of O(1) numbers agree to ~1e-13 absolute; 1e-9 leaves room for
# ill-conditioned random trees. float32: eps 1.2e-7 amplified by the same sums and by M^-1.
TOL = {np.float64: 1e-9, np.float32: 2e-3}


def _ergocub():
    text = robots.ergocub_urdf()
    return text, robots.seed_joints(wd.model.Model.build_from_model_description(text).joint_names())


def _icub_legs():
    text = robots.icub_urdf()
    return text, robots.icub_leg_joints(wd.model.Model.build_from_model_description(text).joint_names())


CASES = {
    "ergocub_legs": _ergocub,
    "icub_full": lambda: (robots.icub_urdf(), None),
    "icub_legs": _icub_legs,
    "pendulum_chain": lambda: (robots.pendulum_chain_urdf(6), None),
    **{f"random_{s}": (lambda s=s: (robots.random_tree_urdf(s), None)) for s in range(20)},
    "random_fixed_base": lambda: (robots.random_tree_urdf(101, fixed_base=True), None),
    "random_deep_chain": lambda: (robots.random_tree_urdf(102, num_links=31, max_depth=30), None),
}


def _build(case, dtype):
    text, considered = CASES[case]()
    model = wd.model.Model.build_from_model_description(text, dtype=dtype, considered_joints=considered)
    mj = robots.mujoco_model(text, considered, floating=model.floating_base())
    off = mujoco.mjtDisableBit
    mj.opt.disableflags |= off.mjDSBL_CONSTRAINT | off.mjDSBL_DAMPER | off.mjDSBL_SPRING
    return model, mj


def _mujoco_at(model, mj, data):
    state = robots.MujocoState(mj, model.joint_names(), model.floating_base())
    state.set(
        data.base_position.numpy(),
        data.base_quaternion.numpy(),
        data.joint_positions.numpy(),
        data.base_velocity.numpy(),
        data.joint_velocities.numpy(),
    )
    n = model.dofs()
    if model.floating_base():
        idx = np.r_[0:6, state.dof_adr]
        P = np.eye(6 + n)
        P[3:6, 3:6] = robots.rotation_wxyz(data.base_quaternion.numpy()).T
    else:
        idx = state.dof_adr
        P = np.eye(n)
    return state, idx, P


@pytest.mark.parametrize("case", list(CASES))
def test_mass_matrix_bias_and_forward_dynamics_match_mujoco(case, dtype):
    """M vs mj_fullM, h vs qfrc_bias, g vs qfrc_bias at rest, ABA and CRB vs qacc with qfrc_applied;
    joint blocks only for fixed bases (MuJoCo has no base there)."""
    model, mj = _build(case, dtype)
    data = wd.data.random_model_data(model, key=7)
    state, idx, P = _mujoco_at(model, mj, data)
    d = state.d
    M_mj = np.zeros((mj.nv, mj.nv))
    mujoco.mj_fullM(mj, d, M_mj)
    b = slice(0, None) if model.floating_base() else slice(6, None)
    tol = TOL[dtype]

    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    np.testing.assert_allclose(M[b, b], P.T @ M_mj[np.ix_(idx, idx)] @ P, atol=tol * max(1.0, np.abs(M).max()))
    h = wd.model.free_floating_bias_forces(model, data).numpy()
    np.testing.assert_allclose(h[b], P.T @ d.qfrc_bias[idx], atol=tol * max(1.0, np.abs(h).max()))

    tau = np.random.default_rng(3).uniform(-5, 5, model.dofs())
    d.qfrc_applied[:] = 0.0
    d.qfrc_applied[state.dof_adr] = tau
    mujoco.mj_forward(mj, d)
    qacc = d.qacc[idx]
    for prefer_aba in (True, False):
        base, joints = wd.model.forward_dynamics(model, data, joint_forces=tau, prefer_aba=prefer_aba)
        expected = np.linalg.solve(P, qacc) if model.floating_base() else qacc
        nu_dot = np.r_[base.numpy(), joints.numpy()]
        scale = max(1.0, np.abs(expected).max())
        np.testing.assert_allclose(nu_dot[b], expected, atol=50 * tol * scale)

    rest = wd.data.Data.build(
        model,
        base_position=data.base_position.numpy(),
        base_quaternion=data.base_quaternion.numpy(),
        joint_positions=data.joint_positions.numpy(),
    )
    state.set(rest.base_position.numpy(), rest.base_quaternion.numpy(), rest.joint_positions.numpy(), np.zeros(6), np.zeros(model.dofs()))
    g = wd.model.free_floating_gravity_forces(model, data).numpy()
    np.testing.assert_allclose(g[b], P.T @ state.d.qfrc_bias[idx], atol=tol * max(1.0, np.abs(g).max()))


@pytest.mark.parametrize("case", ["ergocub_legs", "icub_full", "random_3", "random_fixed_base"])
def test_inverse_dynamics_matches_mujoco(case, dtype):
    """RNEA vs mj_inverse (qfrc_inverse) for random accelerations; Mixed base acceleration mapped to
    MuJoCo's qacc by d/dt(P nu) = P nu_dot + Pdot nu, Pdot nu = [0; -B_omega x R^T W_omega = 0; 0]."""
    model, mj = _build(case, dtype)
    data = wd.data.random_model_data(model, key=11)
    state, idx, P = _mujoco_at(model, mj, data)
    rng = np.random.default_rng(5)
    base_acc = rng.uniform(-2, 2, 6) if model.floating_base() else np.zeros(6)
    joint_acc = rng.uniform(-2, 2, model.dofs())
    f_B, tau = wd.model.inverse_dynamics(model, data, base_acceleration=base_acc, joint_accelerations=joint_acc)
    d = state.d
    nu_dot = np.r_[base_acc, joint_acc] if model.floating_base() else joint_acc
    d.qacc[:] = 0.0
    d.qacc[idx] = P @ nu_dot
    mujoco.mj_inverse(mj, d)
    expected = P.T @ d.qfrc_inverse[idx]
    got = np.r_[f_B.numpy(), tau.numpy()] if model.floating_base() else tau.numpy()
    np.testing.assert_allclose(got, expected, atol=TOL[dtype] * max(1.0, np.abs(expected).max()))


@pytest.mark.parametrize("repr", list(VelRepr))
@pytest.mark.parametrize("case", ["ergocub_legs", "random_4", "random_fixed_base"])
def test_equations_of_motion_identities(case, repr, dtype):
    """In every representation: ABA == CRB; M nu_dot + h == B tau + sum J^T f (the seed's EoM cell);
    RNEA returns tau and f_B = 0 (forward then inverse); M^-1 M == 1; M symmetric. Reference: the
    identities themselves; tolerances as the MuJoCo comparison."""
    model, _ = _build(case, dtype)
    N = 3
    data = wd.data.random_model_data(model, num_envs=N, key=2, velocity_representation=repr)
    rng = np.random.default_rng(9)
    tau = rng.uniform(-5, 5, (N, model.dofs()))
    f_L = rng.uniform(-5, 5, (N, model.number_of_links(), 6))
    base_aba, s_aba = wd.model.forward_dynamics_aba(model, data, joint_forces=tau, link_forces=f_L)
    base_crb, s_crb = wd.model.forward_dynamics_crb(model, data, joint_forces=tau, link_forces=f_L)
    nu_dot = np.concatenate([base_aba.numpy(), s_aba.numpy()], axis=1)
    tol = TOL[dtype]
    np.testing.assert_allclose(np.concatenate([base_crb.numpy(), s_crb.numpy()], axis=1), nu_dot, atol=50 * tol * max(1, np.abs(nu_dot).max()))

    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    h = wd.model.free_floating_bias_forces(model, data).numpy()
    J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
    rhs = np.concatenate([np.zeros((N, 6)), tau], axis=1) + np.einsum("elrg,elr->eg", J, f_L)
    b = slice(0, None) if model.floating_base() else slice(6, None)
    lhs = np.einsum("eij,ej->ei", M, nu_dot) + h
    np.testing.assert_allclose(lhs[:, b], rhs[:, b], atol=20 * tol * max(1, np.abs(rhs).max()))
    np.testing.assert_allclose(M, np.transpose(M, (0, 2, 1)), atol=tol * np.abs(M).max())

    f_B, tau_id = wd.model.inverse_dynamics(
        model, data, base_acceleration=base_aba.numpy(), joint_accelerations=s_aba.numpy(), link_forces=f_L
    )
    np.testing.assert_allclose(tau_id.numpy(), tau, atol=50 * tol * max(1, np.abs(tau).max()))
    if model.floating_base():
        np.testing.assert_allclose(f_B.numpy(), 0.0, atol=50 * tol * max(1, np.abs(tau).max()))

    Minv = wd.model.free_floating_mass_matrix_inverse(model, data).numpy()
    k = b.start
    eye = np.eye(M.shape[1] - k)
    np.testing.assert_allclose(np.einsum("eij,ejk->eik", Minv[:, k:, k:], M[:, k:, k:]), np.broadcast_to(eye, (N, *eye.shape)), atol=1e3 * tol)


def test_seed_inverse_dynamics_recovers_base_wrench():
    """The seed's cell 16: RNEA with the base's link force removed returns that force as f_B, and tau.
    Reference: the notebook's asserts; float64, so 1e-9."""
    model, _ = _build("ergocub_legs", np.float64)
    data = wd.data.random_model_data(model)
    rng = np.random.default_rng(0)
    link_forces = rng.uniform(-10, 10, (model.number_of_links(), 6))
    tau = rng.uniform(-10, 10, model.dofs())
    references = wd.references.References.build(model, data=data, link_forces=link_forces, joint_force_references=tau)
    f_L = references.link_forces(model, data).numpy()
    v_dot_WB, s_ddot = wd.model.forward_dynamics_aba(model, data, link_forces=f_L, joint_forces=tau)
    without_base = f_L.copy()
    without_base[0] = 0.0
    f_B, tau_rnea = wd.model.inverse_dynamics(
        model, data, base_acceleration=v_dot_WB.numpy(), joint_accelerations=s_ddot.numpy(), link_forces=without_base
    )
    np.testing.assert_allclose(tau_rnea.numpy(), tau, atol=1e-9)
    np.testing.assert_allclose(f_B.numpy(), link_forces[0], atol=1e-9)


@wp.kernel
def _weighted_sum(x: wp.array2d(dtype=wp.float64), w: wp.array2d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    env, k = wp.tid()
    wp.atomic_add(loss, 0, x[env, k] * w[env, k])


def _add_weighted_sum(loss, output, weights):
    """loss += sum(output * weights) for an (N, K) output, recorded on the active tape."""
    wp.launch(_weighted_sum, dim=output.shape, inputs=[output, weights], outputs=[loss])


@pytest.mark.parametrize("algorithm", ["aba", "rnea", "crba"])
@pytest.mark.parametrize("repr", [VelRepr.Mixed, VelRepr.Body])
def test_tape_gradients_match_finite_differences(algorithm, repr):
    """wp.Tape gradients of a weighted sum of ABA, RNEA or CRBA outputs with respect to joint positions,
    velocities, torques (or accelerations) and the base state equal central finite differences.
    float64; step 1e-6 gives FD errors ~1e-9 on O(1) quantities, so 1e-6 relative."""
    model, _ = _build("random_2", np.float64)
    N = 2
    base = wd.data.random_model_data(model, num_envs=N, key=4, velocity_representation=repr)
    rng = np.random.default_rng(8)
    u = rng.uniform(-2, 2, (N, model.dofs()))
    n = model.dofs()
    w_base = wp.array(rng.normal(size=(N, 6)), dtype=wp.float64)
    w_joints = wp.array(rng.normal(size=(N, n)), dtype=wp.float64)
    w_matrix = wp.array(rng.normal(size=(N, 6 + n, 6 + n)), dtype=wp.float64)

    def outputs(data, u_array):
        """[(output, its weights)] of the loss."""
        if algorithm == "crba":
            return [(wd.model.free_floating_mass_matrix(model, data), w_matrix)]  # (N, 6 + n, 6 + n), any layout
        if algorithm == "aba":
            b, s = wd.model.forward_dynamics_aba(model, data, joint_forces=u_array)
        else:
            b, s = wd.model.inverse_dynamics(model, data, joint_accelerations=u_array)
        return [(b, w_base), (s, w_joints)]

    def evaluate(data, u_array):
        if algorithm == "crba":
            return gradcheck.weighted_sum(*zip(*outputs(data, u_array)))
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        for x, w in outputs(data, u_array):
            _add_weighted_sum(loss, x, w)
        return loss

    def fresh(values=None, requires_grad=False):
        values = values or {}
        return wd.data.Data.build(
            model,
            base_position=values.get("base_position", base.base_position.numpy()),
            base_quaternion=values.get("base_quaternion", base.base_quaternion.numpy()),
            joint_positions=values.get("joint_positions", base.joint_positions.numpy()),
            joint_velocities=values.get("joint_velocities", base.joint_velocities.numpy()),
            base_linear_velocity=values.get("base_linear_velocity", base.base_velocity.numpy()[:, :3]),
            base_angular_velocity=values.get("base_angular_velocity", base.base_velocity.numpy()[:, 3:]),
            velocity_representation=repr,
            num_envs=N,
            requires_grad=requires_grad,
        )

    data = fresh(requires_grad=True)
    u_array = wp.array(u, dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        loss = evaluate(data, u_array)
    tape.backward(loss)

    def loss_at(**values):
        """The loss summed on the host in a fixed order: the device's atomic sum has none, and on an H100 its
        rounding moved a central difference of M (whose derivative is 0) by 1e-6."""
        u_value = values.pop("u", u)
        return math.fsum(float(t) for x, w in outputs(fresh(values), wp.array(u_value, dtype=wp.float64)) for t in (x.numpy() * w.numpy()).ravel())

    eps = 1e-6
    checks = [("joint_positions", data.joint_positions_state, base.joint_positions.numpy())]
    if algorithm != "crba":
        checks += [
            ("joint_velocities", data.joint_velocities_state, base.joint_velocities.numpy()),
            ("u", u_array, u),
        ]
    checks += [("base_position", data.base_position_state, base.base_position.numpy())]
    for name, array, value in checks:
        grad = array.grad.numpy()
        for env in range(N):
            for k in range(value.shape[1]):
                plus, minus = value.copy(), value.copy()
                plus[env, k] += eps
                minus[env, k] -= eps
                fd = (loss_at(**{name: plus}) - loss_at(**{name: minus})) / (2 * eps)
                assert abs(grad[env, k] - fd) <= 1e-6 * max(1.0, abs(fd)), (name, env, k, grad[env, k], fd)


@pytest.mark.parametrize("num_envs", [None, 3])
def test_calls_after_a_state_array_is_replaced_read_the_new_one(num_envs):
    """A Data whose state array is replaced after a call (a new array object, as warpdyn's functions return) is
    read anew by the next call: the remembered checks, the kept State bundle and the recorded launch's arguments
    follow the replacement. Reference: the same call on a Data built from the new values, bit for bit (the same
    kernel on the same numbers)."""
    model, _ = _build("random_2", np.float64)
    data = wd.data.random_model_data(model, num_envs=num_envs, key=1)
    other = wd.data.random_model_data(model, num_envs=num_envs, key=2)
    calls = {
        "aba": lambda d: wd.model.forward_dynamics_aba(model, d)[1],
        "crba": lambda d: wd.model.free_floating_mass_matrix(model, d),
        "rnea": lambda d: wd.model.free_floating_bias_forces(model, d),
    }
    before = {name: call(data).numpy().copy() for name, call in calls.items()}
    data.joint_positions_state = wp.clone(other.joint_positions_state)
    data.base_quaternion_state = wp.clone(other.base_quaternion_state)
    fresh = wd.data.Data.build(
        model,
        base_position=data.base_position.numpy(),
        base_quaternion=other.base_quaternion.numpy(),
        joint_positions=other.joint_positions.numpy(),
        joint_velocities=data.joint_velocities.numpy(),
        base_linear_velocity=data.base_velocity.numpy()[..., :3],
        base_angular_velocity=data.base_velocity.numpy()[..., 3:],
        num_envs=num_envs,
    )
    for name, call in calls.items():
        after = call(data).numpy()
        assert not np.array_equal(after, before[name]), name
        np.testing.assert_array_equal(after, call(fresh).numpy(), err_msg=name)


@pytest.mark.usefixtures("layout")
def test_forces_given_as_warp_or_numpy_arrays_give_the_same_dynamics():
    """forward_dynamics_aba with joint forces and link forces given as NumPy arrays, as
    contiguous Warp arrays (N, ...) and as shared Warp arrays (per_env), in each layout of the environments
    (warpdyn.engine.input_buffers copies a Warp array byte for byte only into a buffer laid out as it is): bit
    for bit the same results, three calls each (the buffers reused)."""
    model, _ = _build("random_2", np.float64)
    N, n, nL = 3, model.dofs(), model.number_of_links()
    data = wd.data.random_model_data(model, num_envs=N, key=4)
    rng = np.random.default_rng(8)
    for _ in range(3):
        tau, f = rng.normal(0.0, 2.0, (N, n)), rng.normal(0.0, 1.0, (N, nL, 6))
        expected = [a.numpy() for a in wd.model.forward_dynamics_aba(model, data, joint_forces=tau, link_forces=f)]
        got = [a.numpy() for a in wd.model.forward_dynamics_aba(model, data, joint_forces=wp.array(tau, dtype=wp.float64), link_forces=wp.array(f, dtype=wp.float64))]
        for a, b in zip(got, expected):
            np.testing.assert_array_equal(a, b)
        shared = [a.numpy() for a in wd.model.forward_dynamics_aba(model, data, joint_forces=wp.array(tau[0], dtype=wp.float64))]
        per_env = [a.numpy() for a in wd.model.forward_dynamics_aba(model, data, joint_forces=np.broadcast_to(tau[0], (N, n)).copy())]
        for a, b in zip(shared, per_env):
            np.testing.assert_array_equal(a, b)
