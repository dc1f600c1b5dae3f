"""wp.Tape gradients with respect to model parameters shared by all environments (issue 5), float64.

The reference everywhere is central finite differences of the same loss computed without a tape, one
parameter entry at a time, with step h = 1e-6 relative to the entry's magnitude (h = 1e-6 |x|, or 1e-6
where x = 0: an absolute step of 1e-6 on K = 1e6 would be lost in rounding). Truncation error is
O(h^2) ~ 1e-12 relative and rounding ~ 1e-16 / 1e-6 = 1e-10 relative to the loss, so the bound is
rtol 1e-6 (atol 1e-9 for entries whose gradient is ~0; for a loss summed over many outputs, 1e-10 times the
sum of its terms' magnitudes when that is larger: its rounding, which a GPU's contractions make differ
from the CPU's), on gradients times the entry's size (d loss /
d log x for K and D), so that one atol fits parameters of every magnitude. Parameters are marked with
`wd.model.parameters_requiring_grad`, and their gradients are read from the returned arrays' .grad.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from gradcheck import weighted_sum

RTOL, ATOL, STEP = 1e-6, 1e-9, 1e-6


def _scale(name: str, x: np.ndarray) -> np.ndarray:
    """The size of a parameter's entries: |x| for K and D (large), else max(|x|, 1). Steps are STEP times it,
    and gradients are compared times it (d loss / d log x for K and D), so that atol means the same for all."""
    return np.abs(x) if name in ("K", "D") else np.maximum(np.abs(x), 1.0)


def _weighted_size(outputs, weights) -> float:
    """sum |w x| over the outputs: the size of the loss sum w x, whose rounding the differences divide by the step."""
    return sum(float(np.sum(np.abs(w.numpy() * x.numpy()))) for x, w in zip(outputs, weights))


def _finite_differences(arrays: dict, f) -> dict:
    """{name: d f / d array} by central differences, perturbing each entry of each Warp array in place."""
    result = {}
    for name, array in arrays.items():
        x0 = array.numpy().copy()
        fd = np.zeros_like(x0)
        scale = _scale(name, x0)
        for i in np.ndindex(x0.shape):
            h = STEP * float(scale[i])
            x = x0.copy()
            x[i] += h
            array.assign(x)
            up = f()
            x[i] -= 2 * h
            array.assign(x)
            down = f()
            fd[i] = (up - down) / (2 * h)
        array.assign(x0)
        result[name] = fd
    return result


def _assert_gradients(arrays: dict, fd: dict, loss_size: float = 0.0) -> None:
    """Tape gradients against the differences fd: rtol RTOL, atol ATOL or, when larger, the differences'
    rounding for a loss of size loss_size (the sum of its terms' magnitudes): 1e-16 / STEP of it."""
    atol = max(ATOL, 1e-16 / STEP * loss_size)
    for name, array in arrays.items():
        assert array.grad is not None, name
        grad = array.grad.numpy()
        assert grad.shape == fd[name].shape, name
        scale = _scale(name, array.numpy())
        np.testing.assert_allclose(grad * scale, fd[name] * scale, rtol=RTOL, atol=atol, err_msg=name)
    assert max(np.abs(g * _scale(k, arrays[k].numpy())).max() for k, g in fd.items()) > 1e-3, "the parameters do not matter"


# ------------------------------------------------------------------------------ dynamics


def _random_tree():
    return wd.model.Model.build_from_model_description(robots.random_tree_urdf(3, num_links=5), dtype=np.float64)


def _dynamics_outputs(model, data, tau, a):
    """The outputs of ABA, RNEA and CRBA at one state, as a list of (N, ...) arrays."""
    base, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=tau)
    f_B, tau_id = wd.model.inverse_dynamics(model, data, joint_accelerations=a[:, 6:], base_acceleration=a[:, :6])
    M = wd.model.free_floating_mass_matrix(model, data)
    return [base, joints, f_B, tau_id, M]


def test_dynamics_gradients_with_respect_to_link_masses_coms_and_inertias():
    """d loss / d (link_mass, link_com, link_inertia) of loss = sum of random weights times the outputs of ABA
    (base and joint accelerations), RNEA (base wrench and joint torques) and CRBA (mass matrix), for 2
    environments of a random 5-link floating tree in the Mixed representation: tape vs central differences
    (see the module docstring; h = 1e-6, rtol 1e-6). Every one of the 9 entries of each inertia is perturbed
    on its own (both the tape and the differences see the kernels' function of all 9)."""
    model = _random_tree()
    n, N = model.dofs(), 2
    rng = np.random.default_rng(1)
    data = wd.data.random_model_data(model, key=2, num_envs=N)
    tau = wp.array(rng.normal(size=(N, n)), dtype=wp.float64)
    a = wp.array(rng.normal(size=(N, 6 + n)), dtype=wp.float64)
    shapes = [(N, 6), (N, n), (N, 6), (N, n), (N, 6 + n, 6 + n)]
    weights = [wp.array(rng.normal(size=s), dtype=wp.float64) for s in shapes]
    params = wd.model.parameters_requiring_grad(model, names=("link_mass", "link_com", "link_inertia"))
    assert params["link_mass"] is model.link_mass

    tape = wp.Tape()
    with tape:
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        weighted_sum(_dynamics_outputs(model, data, tau, a), weights, out=loss)
    tape.backward(loss)

    def f():
        return sum(float(np.sum(w.numpy() * x.numpy())) for x, w in zip(_dynamics_outputs(model, data, tau, a), weights))

    _assert_gradients(params, _finite_differences(params, f), _weighted_size(_dynamics_outputs(model, data, tau, a), weights))


def _centroidal_outputs(model, data):
    """Centroidal, energy and Coriolis outputs that read the mass parameters, as a list of 2-D or 3-D arrays."""
    N = data.batch_size
    return [
        wd.com.com_position(model, data),
        wd.com.centroidal_momentum(model, data),
        wd.com.bias_acceleration(model, data),
        wd.model.total_momentum(model, data),
        wd.model.mechanical_energy(model, data).reshape((N, 1)),
        wd.model.locked_spatial_inertia(model, data),
        wd.model.total_momentum_jacobian(model, data),
        wd.model.free_floating_coriolis_matrix(model, data),
        wd.model.link_spatial_inertia_matrices(model),
    ]


def test_centroidal_energy_and_coriolis_gradients_with_respect_to_mass_parameters():
    """d loss / d (link_mass, link_com, link_inertia) of random weights times the CoM position, centroidal
    momentum, CoM bias acceleration, total momentum, mechanical energy, locked inertia, momentum Jacobian,
    Coriolis matrix and link spatial inertias, for 2 environments of the random 5-link floating tree (Body
    representation): tape vs central differences (module docstring; rtol 1e-6)."""
    model = _random_tree()
    N = 2
    rng = np.random.default_rng(3)
    data = wd.data.random_model_data(model, key=5, num_envs=N, velocity_representation=wd.VelRepr.Body)
    weights = [wp.array(rng.normal(size=x.shape), dtype=wp.float64) for x in _centroidal_outputs(model, data)]
    params = wd.model.parameters_requiring_grad(model, names=("link_mass", "link_com", "link_inertia"))
    tape = wp.Tape()
    with tape:
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        weighted_sum(_centroidal_outputs(model, data), weights, out=loss)
    tape.backward(loss)

    def f():
        return sum(float(np.sum(w.numpy() * x.numpy())) for x, w in zip(_centroidal_outputs(model, data), weights))

    _assert_gradients(params, _finite_differences(params, f), _weighted_size(_centroidal_outputs(model, data), weights))


@pytest.mark.parametrize("fixed", [False, True], ids=["floating", "fixed-base"])
def test_crb_forward_dynamics_and_mass_matrix_inverse_gradients(fixed):
    """forward_dynamics_crb and free_floating_mass_matrix_inverse solve with a Cholesky factor whose adjoint
    is registered on the tape (the implicit one, kernels/cholesky.py). References: (1) forward_dynamics_aba
    computes the same accelerations, so the tape gradients of sum(w * accelerations) w.r.t. the joint
    positions, velocities, joint forces and the mass parameters must equal ABA's (rtol 1e-9: two algorithms,
    float64 rounding amplified by cond(M)); (2) d sum(W * M^-1) = -tr(W^T M^-1 dM M^-1), so the gradient of
    sum(W * M^-1) w.r.t. the link masses and joint positions equals the tape gradient of sum(-(M^-1 W M^-1)
    * M) through CRBA (rtol 1e-9; central differences of M^-1 lose ~1e-7 to rounding, cond(M) ~ 1e4 here).
    A fixed base solves the joint block only (offset 6)."""
    urdf = robots.pendulum_chain_urdf(4) if fixed else robots.random_tree_urdf(3, num_links=5)
    model = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
    n, N = model.dofs(), 2
    rng = np.random.default_rng(7)
    state = wd.data.random_model_data(model, key=8, num_envs=N)
    s0, v0 = state.joint_positions_state.numpy(), state.joint_velocities_state.numpy()
    params = wd.model.parameters_requiring_grad(model, names=("link_mass", "link_com", "link_inertia"))
    w = [wp.array(rng.normal(size=(N, 6)), dtype=wp.float64), wp.array(rng.normal(size=(N, n)), dtype=wp.float64)]
    tau0 = rng.normal(size=(N, n))

    def gradients(solver):
        s = wp.array(s0, dtype=wp.float64, requires_grad=True)
        v = wp.array(v0, dtype=wp.float64, requires_grad=True)
        tau = wp.array(tau0, dtype=wp.float64, requires_grad=True)
        tape = wp.Tape()
        with tape:
            data = wd.data.Data.build(model, base_position=state.base_position_state.numpy(), base_quaternion=state.base_quaternion_state.numpy(), joint_positions=s, joint_velocities=v, num_envs=N, requires_grad=True)
            base, joints = solver(model, data, joint_forces=tau)
            loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
            weighted_sum([base, joints] if not fixed else [joints], w if not fixed else w[1:], out=loss)
        tape.backward(loss)
        out = {"s": s.grad.numpy().copy(), "v": v.grad.numpy().copy(), "tau": tau.grad.numpy().copy()}
        out.update({k: a.grad.numpy().copy() for k, a in params.items()})
        tape.zero()
        return out

    aba, crb = gradients(wd.model.forward_dynamics_aba), gradients(wd.model.forward_dynamics_crb)
    for grads in (aba, crb):  # ABA reads an inertia's upper triangle, CRBA all of it: compare symmetric directions
        grads["link_inertia"] = grads["link_inertia"] + np.swapaxes(grads["link_inertia"], -1, -2)
    for k, g in aba.items():
        np.testing.assert_allclose(crb[k], g, rtol=1e-9, atol=1e-9 * np.abs(g).max(), err_msg=k)
        assert np.abs(g).max() > 1e-6, k

    W = rng.normal(size=(N, 6 + n, 6 + n))

    def inverse_gradients(weights, of_inverse: bool):
        s = wp.array(s0, dtype=wp.float64, requires_grad=True)
        tape = wp.Tape()
        with tape:
            data = wd.data.Data.build(
                model,
                base_position=state.base_position_state.numpy(),
                base_quaternion=state.base_quaternion_state.numpy(),
                joint_positions=s,
                num_envs=N,
                requires_grad=True,
            )
            f = wd.model.free_floating_mass_matrix_inverse if of_inverse else wd.model.free_floating_mass_matrix
            out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
            weighted_sum([f(model, data)], [wp.array(weights, dtype=wp.float64)], out=out)
        tape.backward(out)
        grads = {"s": s.grad.numpy().copy(), "link_mass": params["link_mass"].grad.numpy().copy()}
        tape.zero()
        return grads

    X = wd.model.free_floating_mass_matrix_inverse(model, wd.data.Data.build(
        model, base_position=state.base_position_state.numpy(), base_quaternion=state.base_quaternion_state.numpy(), joint_positions=s0, num_envs=N
    )).numpy()
    got = inverse_gradients(W, True)
    expected = inverse_gradients(-np.einsum("eij,ejk,ekl->eil", X, W, X), False)  # dL = -tr(W^T X dM X)
    for k, g in expected.items():
        np.testing.assert_allclose(got[k], g, rtol=1e-9, atol=1e-9 * np.abs(g).max(), err_msg=k)
        assert np.abs(g).max() > 1e-6, k


def test_single_environment_data_and_unmarked_parameters():
    """Single-environment data gives the same parameter gradient as batched data of one environment
    (reference: the batched call; exact up to the summation order, rtol 1e-12); without marked parameters
    a taped call leaves the model's arrays without gradients."""
    model = _random_tree()
    data = wd.data.random_model_data(model, key=4)
    tape = wp.Tape()
    with tape:
        M = wd.model.free_floating_mass_matrix(model, data)
    assert model.link_mass.grad is None and not M.requires_grad
    params = wd.model.parameters_requiring_grad(model, names="link_mass")
    grads = []
    for d in (data, wd.data.random_model_data(model, key=4, num_envs=1)):
        tape = wp.Tape()
        with tape:
            M = wd.model.free_floating_mass_matrix(model, d)
            loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
            M1 = M if M.ndim == 3 else wd.arrays.with_env_axis(M)  # (1, k, k): a view, whatever the layout
            weighted_sum([M1], [wp.ones((1, *M.shape[-2:]), dtype=wp.float64)], out=loss)
        tape.backward(loss)
        grads.append(params["link_mass"].grad.numpy().copy())
        tape.zero()
    np.testing.assert_allclose(grads[0], grads[1], rtol=1e-12)
    assert np.abs(grads[0]).max() > 0.0


@pytest.mark.parametrize(
    "name", [p.name for p in (*wd.types.parameters.LINK_PARAMETERS, *wd.types.parameters.JOINT_PARAMETERS, *wd.types.parameters.ACTUATOR_PARAMETERS, *wd.types.parameters.WORLD_PARAMETERS)]
)
def test_each_link_and_joint_parameter_marked_makes_dynamics_outputs_carry_gradients(name):
    """Marking any link, joint or world parameter gives the dynamics functions' outputs gradient arrays (they enter
    ABA, RNEA and CRBA); an actuator parameter does not (the dynamics functions do not read it)."""
    model = robots.build(robots.random_tree_urdf(2, num_links=4), np.float64, is_urdf=True)
    data = wd.data.random_model_data(model, key=1, num_envs=2)
    assert not wd.model.forward_dynamics_aba(model, data)[1].requires_grad
    wd.model.parameters_requiring_grad(model, names=name)
    group = wd.types.parameters.REGISTRY[name].group
    outputs = [*wd.model.forward_dynamics_aba(model, data), wd.model.free_floating_mass_matrix(model, data), *wd.model.inverse_dynamics(model, data)]
    assert [o.requires_grad for o in outputs] == [group in ("link", "joint", "world")] * len(outputs), group


# ------------------------------------------------------------------------------ rollouts


@functools.cache
def _rollout_loss_kernel():
    @wp.kernel
    def loss(s: wp.array3d(dtype=wp.float64), sd: wp.array3d(dtype=wp.float64), w: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
        """out += sum over environments and joints of w_j (s_T + 0.3 sdot_T + s_{T/2}^2)."""
        env, j = wp.tid()
        T = s.shape[0] - 1
        wp.atomic_add(out, 0, w[j] * (s[T, env, j] + wp.float64(0.3) * sd[T, env, j] + s[T // 2, env, j] * s[T // 2, env, j]))

    return loss


@pytest.mark.parametrize("integrator", list(wd.model.IntegratorType), ids=lambda i: i.name)
def test_rollout_gradients_with_respect_to_masses_friction_and_limit_gains(integrator):
    """d loss / d (link_mass, friction_static, friction_viscous, joint_limit_spring, joint_limit_damper)
    through 15 steps (dt 1 ms, both integrators) of a 4-link pendulum chain, 2 environments, all joints
    beyond their limits and every joint speed above 1e-2 rad/s at every step (so the limit clamps and the
    Coulomb friction's sign stay away from their switches, where a perturbation of 1e-6 would cross them):
    tape vs central differences (module docstring; rtol 1e-6)."""
    n, N, T = 4, 2, 15
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
    model.time_step = 1e-3
    model.integrator = integrator
    rng = np.random.default_rng(5)
    model.set_joint_parameters(
        position_limits=np.tile([-0.1, 0.1], (n, 1)),
        limit_spring=rng.uniform(5.0, 15.0, n),
        limit_damper=rng.uniform(0.05, 0.2, n),
        friction_static=rng.uniform(0.1, 0.5, n),
        friction_viscous=rng.uniform(0.1, 0.5, n),
    )
    s0 = rng.choice([-1.0, 1.0], size=(N, n)) * rng.uniform(0.3, 0.6, size=(N, n))
    v0 = rng.choice([-1.0, 1.0], size=(N, n)) * rng.uniform(3.0, 5.0, size=(N, n))
    tau = wp.array(0.5 * rng.normal(size=(T, N, n)), dtype=wp.float64)
    w = wp.array(rng.normal(size=n), dtype=wp.float64)
    names = ("link_mass", "friction_static", "friction_viscous", "joint_limit_spring", "joint_limit_damper")
    params = wd.model.parameters_requiring_grad(model, names=names)

    def loss():
        data = wd.data.Data.build(model, joint_positions=s0, joint_velocities=v0, num_envs=N)
        _, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau, record=("joint_positions", "joint_velocities"))
        out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        wp.launch(_rollout_loss_kernel(), dim=(N, n), inputs=[rec["joint_positions"], rec["joint_velocities"], w], outputs=[out])
        return out, rec

    tape = wp.Tape()
    with tape:
        out, rec = loss()
    tape.backward(out)
    s, sd = rec["joint_positions"].numpy(), rec["joint_velocities"].numpy()
    assert np.abs(s).min() > 0.1 and np.abs(sd).min() > 1e-2, "a limit clamp or the friction's sign is at its switch"
    fd = _finite_differences(params, lambda: float(loss()[0].numpy()[0]))
    _assert_gradients(params, fd)
    assert all(np.abs(fd[k]).max() > 1e-4 for k in names)


def test_reused_rollout_and_step_caches_do_not_bypass_marked_parameters():
    """A Rollout object and `step` first run outside a tape (recorded launches, shared workspace, CUDA graph
    where available), then parameters are marked and both run under a tape: the gradients equal those of a
    fresh model marked from the start (reference: that model; exact, the same launches, rtol 1e-12)."""
    n, T = 3, 5

    def build():
        model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
        model.set_joint_parameters(friction_viscous=np.full(n, 0.2))
        return model

    v0 = np.array([0.5, -1.0, 2.0])
    names = ("link_mass", "friction_viscous")

    def gradients(model, rollout):
        data = wd.data.Data.build(model, joint_positions=[0.1, 0.2, 0.3], joint_velocities=v0)
        params = wd.model.parameters_requiring_grad(model, names=names)
        tape = wp.Tape()
        with tape:
            final, _ = rollout.run(data)
            final = wd.model.step(model, final)
            loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
            v = final.joint_velocities_state
            weighted_sum([v], [wp.array(np.array([[1.0, -2.0, 0.5]]), dtype=wp.float64)], out=loss)
        tape.backward(loss)
        return {k: a.grad.numpy().copy() for k, a in params.items()}

    fresh = build()
    expected = gradients(fresh, wd.simulation.Rollout(fresh, steps=T))
    model = build()
    rollout = wd.simulation.Rollout(model, steps=T)
    data = wd.data.Data.build(model, joint_positions=[0.1, 0.2, 0.3], joint_velocities=v0)
    wd.model.step(model, rollout.run(data)[0])
    got = gradients(model, rollout)
    for k in names:
        np.testing.assert_allclose(got[k], expected[k], rtol=1e-12, err_msg=k)
        assert np.abs(got[k]).max() > 1e-6, k


def test_step_gradient_reaches_friction_that_is_zero():
    """A zero friction marked for gradients keeps its term in the compiled actuation kernel: d (sum of the
    joint velocities after one step) / d friction_viscous equals -dt sum_k (M^-1)_{kj} sdot_j, the
    analytic value at zero friction (reference: M from CRBA; rtol 1e-9, rounding of the two paths)."""
    n = 3
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
    model.set_joint_parameters(friction_static=np.zeros(n), friction_viscous=np.zeros(n))
    params = wd.model.parameters_requiring_grad(model, names=("friction_viscous",))
    v0 = np.array([0.5, -1.0, 2.0])
    data = wd.data.Data.build(model, joint_positions=[0.1, 0.2, 0.3], joint_velocities=v0)
    tape = wp.Tape()
    with tape:
        new = wd.model.step(model, data)
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        v = new.joint_velocities_state
        weighted_sum([v], [wp.ones(v.shape, dtype=wp.float64)], out=loss)
    tape.backward(loss)
    M = wd.model.free_floating_mass_matrix(model, data).numpy()[6:, 6:]
    expected = -model.time_step * np.linalg.inv(M).sum(axis=0) * v0
    np.testing.assert_allclose(params["friction_viscous"].grad.numpy(), expected, rtol=1e-9)


# ------------------------------------------------------------------------------ contacts


@functools.cache
def _contact_loss_kernel():
    @wp.kernel
    def loss(p: wp.array3d(dtype=wp.float64), v: wp.array3d(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
        """out += sum over environments of z_B(T) + 0.1 x_B(T) + 0.01 vx_B(T) + 0.02 vz_B(T)."""
        env = wp.tid()
        T = p.shape[0] - 1
        term = p[T, env, 2] + wp.float64(0.1) * p[T, env, 0] + wp.float64(0.01) * v[T, env, 0] + wp.float64(0.02) * v[T, env, 2]
        wp.atomic_add(out, 0, term)

    return loss


BOX_URDF = """<robot name="box"><link name="box"><inertial><mass value="2"/>
<inertia ixx="0.013333333333333334" iyy="0.013333333333333334" izz="0.013333333333333334" ixy="0" ixz="0" iyz="0"/>
</inertial><collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link></robot>"""


def _contact_rollout_gradients(model, data, T, names):
    params = wd.model.parameters_requiring_grad(model, names=names)
    N = data.batch_size

    def loss():
        _, rec = wd.simulation.rollout(model, data, steps=T, record=("base_position", "base_velocity", "tangential_deformation"))
        out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        p, v = rec["base_position"], rec["base_velocity"]
        if p.ndim == 2:
            p, v = p.reshape((p.shape[0], 1, 3)), v.reshape((v.shape[0], 1, 6))
        wp.launch(_contact_loss_kernel(), dim=N, inputs=[p, v], outputs=[out])
        return out, rec

    tape = wp.Tape()
    with tape:
        out, rec = loss()
    tape.backward(out)
    return params, rec, _finite_differences(params, lambda: float(loss()[0].numpy()[0]))


def test_box_sliding_in_contact_gradients_with_respect_to_K_D_mu():
    """d loss / d (K, D, mu) through 20 steps (dt 1 ms) of a 2 kg box sliding at 1 m/s on flat ground with
    its 4 bottom corners 1 mm deep the whole time (sliding throughout: the friction cone is saturated, so
    mu matters), 2 environments with shared K, D (numbers, (1,) gradients) and mu per environment ((2,)
    gradients): tape vs central differences (module docstring; rtol 1e-6)."""
    model = wd.model.Model.build_from_model_description(BOX_URDF, dtype=np.float64)
    model.time_step = 1e-3
    model.contact_params = wd.model.SoftContactsParams(K=1e5, D=1e3, mu=np.array([0.3, 0.5]))
    N = 2
    data = wd.data.Data.build(
        model, base_position=[0.0, 0.0, 0.099], base_linear_velocity=[1.0, 0.2, 0.0], num_envs=N
    )
    params, rec, fd = _contact_rollout_gradients(model, data, 20, ("K", "D", "mu"))
    assert model.contact_params.K is params["K"] and params["K"].shape == (1,) and params["mu"].shape == (2,)
    z = rec["base_position"].numpy()[..., 2]
    assert np.all(z < 0.1), "a corner left the ground"
    assert np.all(rec["base_velocity"].numpy()[..., 0] > 0.5), "the box stopped sliding"
    _assert_gradients(params, fd)
    assert all(np.abs(fd[k] * _scale(k, params[k].numpy())).max() > 1e-6 for k in ("K", "D", "mu"))


def test_legs_standing_gradients_with_respect_to_K_D_mu():
    """d loss / d (K, D, mu) through 8 steps of the seed's ergoCub legs standing on flat ground (feet 4 mm
    deep, joints moving; contact forces and tangential deformation in every step, sticking, so d/d mu is
    ~0 on both sides), single environment: tape vs central differences (module docstring; rtol 1e-6)."""
    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=np.float64)
    model = wd.model.reduce(full, robots.seed_joints(full.joint_names()))
    n = model.dofs()
    rng = np.random.default_rng(0)
    s0, v0 = rng.uniform(-0.1, 0.1, n), rng.uniform(-0.2, 0.2, n)
    low = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min()
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, -low - 0.004], joint_positions=s0, joint_velocities=v0)
    params, rec, fd = _contact_rollout_gradients(model, data, 8, ("K", "D", "mu"))
    assert np.abs(rec["tangential_deformation"].numpy()).max() > 1e-4
    _assert_gradients(params, fd)


def test_bad_parameter_names_and_contact_arrays_are_refused():
    """Unknown names, and contact parameters as Warp arrays of another dtype or rank, raise ValueError."""
    model = wd.model.Model.build_from_model_description(BOX_URDF, dtype=np.float64)
    with pytest.raises(ValueError, match="unknown names"):
        wd.model.parameters_requiring_grad(model, names=("link_masses",))
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, 0.099])
    with pytest.raises(ValueError, match=r"a number or \(N,\)"):
        wd.model.SoftContactsParams(K=wp.array([[1e5]], dtype=wp.float64), D=1e3)
    model.contact_params = wd.model.SoftContactsParams(K=wp.array([1e5], dtype=wp.float32), D=1e3)
    with pytest.raises(ValueError, match="Warp array"):
        wd.model.step(model, data)


def test_gradient_at_a_contact_onset_is_the_one_sided_derivative_from_outside():
    """What the tape returns where the derivative is undefined (docs/differentiation.md, 'Where the derivative is not defined'): a
    box whose 4 bottom corners lie exactly on the ground (penetration 0, moving down at 0.1 m/s). The
    gradient of the total normal force with respect to the base height is the derivative of the no-contact
    branch plus the spring's K eps^p per point (eps = 2.2e-16, p = 0.5: 4 x 1.5e-2 N/m at K = 1e6), i.e.
    practically 0 and finite; 1 um lower (inside) it is the soft model's derivative, large (the damper's
    D q delta^(q - 1) delta_dot) and equal to central differences with steps that stay inside (h = 1e-9 m;
    rtol 1e-5: rounding of forces ~1e1 N over 2 h)."""
    model = wd.model.Model.build_from_model_description(BOX_URDF, dtype=np.float64)
    K, eps, p = model.contact_params.K, 2.220446049250313e-16, model.contact_params.p

    def normal_force(z: float, grad: bool):
        data = wd.data.Data.build(model, base_position=[0.0, 0.0, z], base_linear_velocity=[0.0, 0.0, -0.1], requires_grad=grad)
        tape = wp.Tape()
        with tape:
            f = wd.contact.link_contact_forces(model, data)[0]
            out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
            weighted_sum([f], [wp.array(np.array([[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]]), dtype=wp.float64)], out=out)
        if grad:
            tape.backward(out)
            return float(out.numpy()[0]), float(data.base_position_state.grad.numpy()[0, 2])
        return float(out.numpy()[0]), None

    force, dfdz = normal_force(0.1, True)
    assert force == 0.0 and np.isfinite(dfdz)
    assert abs(dfdz) <= 4 * K * eps**p * 1.01
    z, h = 0.1 - 1e-6, 1e-9
    force, dfdz = normal_force(z, True)
    fd = (normal_force(z + h, False)[0] - normal_force(z - h, False)[0]) / (2 * h)
    assert force > 0.0 and abs(dfdz) > 1e4
    np.testing.assert_allclose(dfdz, fd, rtol=1e-5)
