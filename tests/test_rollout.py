"""Rollouts (wd.simulation), the contact API's forces and in_contact (wd.contact), and the per-model step plan.

References and tolerances:
- A rollout against `wd.model.step` called in a loop with the same controls: the same kernels on the same
  numbers in the same order, so the results must be bitwise equal (graph or not, either storage, both
  integrators, both dtypes); a difference would be a different computation, not rounding.
- Tape gradients through a rollout against central finite differences of the loss computed by rollouts
  (float64): step h = 1e-5 gives a truncation error ~h^2 |f'''| ~ 1e-10 and a rounding error
  ~eps |f| / h ~ 1e-11 relative, so 1e-6 relative (plus 1e-9 absolute for near-zero entries) is loose.
- Contact wrenches against NumPy from their definitions (point forces from Hunt/Crossley at rest, wrenches
  moved between frames with the link poses of wd.model.forward_kinematics): a few products of O(1)
  numbers, 1e-10 relative in float64 (observed ~1e-15), 2e-5 in float32 (eps 1.2e-7 times lever arms and
  sums over 16 points).
- in_contact against NumPy's terrain heights at the points of wd.contact.collidable_point_positions:
  exact comparisons where the answer is decided by more than rounding (1e-9 m in float64, 1e-5 m in float32).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from warpdyn import VelRepr
from warpdyn.engine import kinematics as engine_kinematics
from warpdyn.engine import evaluations
from warpdyn.engine import step as sim
from warpdyn.simulation import STATE_RECORDS, STEP_RECORDS

ALL_RECORDS = STATE_RECORDS + STEP_RECORDS
REL = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 2e-5}


@functools.cache
def _legs(dtype):
    """The seed's ergoCub legs: 13 links, 12 joints, 32 collidable points on the ankles (16 per foot)."""
    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=dtype)
    return wd.model.reduce(full, robots.seed_joints(full.joint_names()))


def _legs_model(dtype, integrator=wd.model.IntegratorType.SemiImplicitEuler):
    """A shallow copy of the cached legs (its own integrator and parameters, the cached device constants)."""
    model = _legs(dtype).copy()
    model.integrator = integrator
    return model


def _pendulum(dtype, n=4):
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=dtype)
    model.set_joint_parameters(friction_viscous=np.full(n, 0.3))
    return model


def _standing_data(model, N, seed=0, z=(0.56, 0.62)):
    """Random states of the legs with the feet near the ground (z of the base in `z`), some points in contact."""
    return wd.data.random_model_data(
        model,
        key=seed,
        num_envs=N,
        base_pos_bounds=((-0.1, -0.1, z[0]), (0.1, 0.1, z[1])),
        base_rpy_bounds=(-0.3, 0.3),
        joint_pos_bounds=(-0.3, 0.3),
    )


def _state_numpy(data) -> list:
    return [a.numpy() for a in engine_kinematics.state_arrays(data)]


def _stepped(model, data, T, tau=None, forces=None):
    """The data at t = 0 ... T by wd.model.step with per-step controls tau[t], forces[t] (None: none)."""
    out = [data]
    for t in range(T):
        data = wd.model.step(
            model,
            data,
            joint_force_references=None if tau is None else tau[t],
            link_forces=None if forces is None else forces[t],
        )
        out.append(data)
    return out


def _assert_contact_record(record, reference):
    """A contact record against the contact API at the same state: the steps write it from the fused step
    (kernels/fused_step.py), the API from its own kernels, which compute a point's velocity another way:
    equal to rounding (float64 1e-12, float32 1e-5 of the largest wrench)."""
    tolerance = 1e-12 if reference.dtype == np.float64 else 1e-5
    np.testing.assert_allclose(record, reference, rtol=0.0, atol=tolerance * max(1.0, float(np.abs(reference).max())))


def _assert_records_match_steps(model, rec, states, batched=True):
    """Each state record equals the stepped states bitwise (the same kernels); the contact records equal the
    contact API at them to rounding (`_assert_contact_record`)."""
    pick = (lambda a: a) if batched else (lambda a: a[0])
    T = len(states) - 1
    for t, d in enumerate(states):
        x = _state_numpy(d)
        for name, i in (("base_position", 0), ("base_quaternion", 1), ("joint_positions", 2), ("joint_velocities", 4), ("tangential_deformation", 5), ("valid", 6)):
            if name in rec:
                np.testing.assert_array_equal(rec[name].numpy()[t], pick(x[i]), err_msg=f"{name} at t={t}")
        if "base_velocity" in rec:
            np.testing.assert_array_equal(rec["base_velocity"].numpy()[t], d.base_velocity.numpy(), err_msg=f"base_velocity at t={t}")
        if t < T:
            if "link_contact_forces" in rec:
                _assert_contact_record(rec["link_contact_forces"].numpy()[t], wd.contact.link_contact_forces(model, d, output_vel_repr=d.velocity_representation)[0].numpy())
            if "collidable_point_forces" in rec:
                _assert_contact_record(rec["collidable_point_forces"].numpy()[t], wd.contact.collidable_point_forces(model, d).numpy())


# ------------------------------------------------------------------------------ rollout equals steps


@pytest.mark.parametrize("integrator", [wd.model.IntegratorType.SemiImplicitEuler, wd.model.IntegratorType.RungeKutta4], ids=["euler", "rk4"])
@pytest.mark.parametrize("storage,graph", [("ping-pong", True), ("ping-pong", False), ("trajectory", True)])
def test_rollout_equals_repeated_step_bitwise(dtype, integrator, storage, graph):
    """Legs with contacts, per-step per-environment torques and Mixed link forces, every record: the
    rollout's records and final data are step's, bit for bit (same kernels, same order)."""
    model = _legs_model(dtype, integrator)
    N, T = 3, 6
    data = _standing_data(model, N)
    rng = np.random.default_rng(1)
    tau = rng.normal(size=(T, N, model.dofs())) * 5.0
    forces = rng.normal(size=(T, N, model.number_of_links(), 6))
    final, rec = wd.simulation.rollout(
        model, data, steps=T, joint_force_references=tau, link_forces=forces, record=ALL_RECORDS, storage=storage, use_graph=graph
    )
    states = _stepped(model, data, T, tau, forces)
    assert np.any(rec["tangential_deformation"].numpy() != 0.0), "no point touched the ground: the test lost its contacts"
    _assert_records_match_steps(model, rec, states)
    for a, b in zip(_state_numpy(final), _state_numpy(states[-1])):
        np.testing.assert_array_equal(a, b)
    torques = [evaluations.resultant_torques(model, states[t], tau[t]).numpy() for t in range(T)]
    np.testing.assert_array_equal(rec["joint_torques"].numpy(), np.stack(torques))


@pytest.mark.parametrize("repr_", [VelRepr.Body, VelRepr.Inertial], ids=lambda r: r.name)
def test_rollout_in_other_representations(repr_):
    """Body and Inertial data: link forces read and base velocities recorded in the data's representation."""
    model = _legs_model(np.float64)
    N, T = 2, 4
    data = wd.data.random_model_data(model, key=3, num_envs=N, velocity_representation=repr_, base_pos_bounds=((0, 0, 0.58), (0, 0, 0.6)), base_rpy_bounds=(-0.2, 0.2))
    forces = np.random.default_rng(4).normal(size=(T, N, model.number_of_links(), 6))
    final, rec = wd.simulation.rollout(model, data, steps=T, link_forces=forces, record=ALL_RECORDS)
    assert final.velocity_representation == repr_
    _assert_records_match_steps(model, rec, _stepped(model, data, T, None, forces))


def test_single_environment_shapes_and_controls(dtype):
    """Single-environment data: JaxSim's shapes without the N axis, per-step controls (T, n)."""
    model = _legs_model(dtype)
    n, nL, T = model.dofs(), model.number_of_links(), 5
    nc = len(model.kin_dyn_parameters.contact_parameters.body)
    data = _standing_data(model, None)
    tau = np.random.default_rng(2).normal(size=(T, n))
    final, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau, record=ALL_RECORDS)
    expected = {
        "base_position": (T + 1, 3),
        "base_quaternion": (T + 1, 4),
        "joint_positions": (T + 1, n),
        "joint_velocities": (T + 1, n),
        "base_velocity": (T + 1, 6),
        "tangential_deformation": (T + 1, nc, 3),
        "valid": (T + 1,),
        "joint_torques": (T, n),
        "link_contact_forces": (T, nL, 6),
        "collidable_point_forces": (T, 32, 6),
    }
    assert {k: tuple(v.shape) for k, v in rec.items()} == expected
    assert rec["valid"].dtype == wp.int32
    assert final.num_envs is None and final.joint_positions.shape == (n,)
    _assert_records_match_steps(model, rec, _stepped(model, data, T, tau), batched=False)


def test_batched_shapes_and_default_record():
    model = _legs_model(np.float64)
    N, T = 4, 3
    _, rec = wd.simulation.rollout(model, _standing_data(model, N), steps=T)
    assert set(rec) == set(wd.simulation.DEFAULT_RECORD)
    assert rec["base_position"].shape == (T + 1, N, 3)
    assert rec["joint_velocities"].shape == (T + 1, N, model.dofs())


@pytest.mark.parametrize(
    "layout",
    ["shared", "per_env", "per_step_shared", "per_step"],
)
def test_control_layouts_equal_step(layout):
    """Controls constant (n,) / (N, n) or per step (T, 1, n) / (T, N, n), torques and link forces alike."""
    model = _legs_model(np.float64)
    N, T, n, nL = 3, 4, model.dofs(), model.number_of_links()
    rng = np.random.default_rng(5)
    shape_tau = {"shared": (n,), "per_env": (N, n), "per_step_shared": (T, 1, n), "per_step": (T, N, n)}[layout]
    shape_f = {"shared": (nL, 6), "per_env": (N, nL, 6), "per_step_shared": (T, 1, nL, 6), "per_step": (T, N, nL, 6)}[layout]
    tau, forces = rng.normal(size=shape_tau), rng.normal(size=shape_f)
    data = _standing_data(model, N)
    _, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau, link_forces=forces, record=ALL_RECORDS)

    def at(value, t):
        if layout in ("shared", "per_env"):
            return value
        return np.broadcast_to(value[t], (N, *value.shape[2:]))

    states = _stepped(model, data, T, [at(tau, t) for t in range(T)], [at(forces, t) for t in range(T)])
    _assert_records_match_steps(model, rec, states)


def test_warp_controls_and_bad_shapes():
    """Warp arrays are accepted as controls; a 2-D control of batched data must be (N, n), not (T, n)."""
    model = _legs_model(np.float64)
    N, T, n = 2, 3, model.dofs()
    data = _standing_data(model, N)
    tau = np.random.default_rng(6).normal(size=(T, N, n))
    _, a = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau)
    _, b = wd.simulation.rollout(model, data, steps=T, joint_force_references=wp.array(tau, dtype=wp.float64))
    np.testing.assert_array_equal(a["joint_positions"].numpy(), b["joint_positions"].numpy())
    with pytest.raises(ValueError, match="joint_force_references has shape"):
        wd.simulation.rollout(model, data, steps=T, joint_force_references=np.zeros((T, n)))
    with pytest.raises(ValueError, match="link_forces has shape"):
        wd.simulation.rollout(model, data, steps=T, link_forces=np.zeros((T, 6)))
    with pytest.raises(ValueError, match="non-finite"):
        wd.simulation.rollout(model, data, steps=T, joint_force_references=np.full((N, n), np.nan))


def test_bad_arguments():
    model = _legs_model(np.float64)
    data = _standing_data(model, 2)
    with pytest.raises(ValueError, match="steps"):
        wd.simulation.Rollout(model, steps=0)
    with pytest.raises(ValueError, match="unknown quantities"):
        wd.simulation.Rollout(model, steps=2, record=("joint_positions", "energy"))
    with pytest.raises(ValueError, match="storage"):
        wd.simulation.Rollout(model, steps=2, storage="ring")
    with pytest.raises(ValueError, match="callback_every"):
        wd.simulation.rollout(model, data, steps=2, callback=lambda t, d: None, callback_every=0)
    with pytest.raises(ValueError, match="ping-pong"):
        with wp.Tape():
            wd.simulation.rollout(model, data, steps=2, storage="ping-pong")
    wrong = _standing_data(_legs_model(np.float32), 2)
    with pytest.raises(TypeError):
        wd.simulation.rollout(model, wrong, steps=2)


# ------------------------------------------------------------------------------ callbacks and reuse


@pytest.mark.parametrize("graph", [True, False], ids=["graph", "eager"])
def test_callback_runs_at_its_steps_and_may_reset(graph):
    """callback(t, data) after t = every, 2 every, ... <= T with the state at t; a returned Data replaces it."""
    model = _legs_model(np.float64)
    N, T, every = 2, 7, 3
    data = _standing_data(model, N)
    tau = np.random.default_rng(7).normal(size=(T, N, model.dofs()))
    states = _stepped(model, data, T, tau)
    seen = []

    def watch(t, d):
        seen.append(t)
        for a, b in zip(_state_numpy(d), _state_numpy(states[t])):
            np.testing.assert_array_equal(a, b)

    roll = wd.simulation.Rollout(model, steps=T, record=ALL_RECORDS, use_graph=graph)
    roll.run(data, joint_force_references=tau, callback=watch, callback_every=every)
    assert seen == [3, 6]

    # a reset of environment 1 at t = 3 to `fresh`: the rest of the rollout continues from there
    fresh = _standing_data(model, N, seed=11)

    def reset(t, d):
        return d.reset(model, [1], fresh) if t == 3 else None

    final, rec = roll.run(data, joint_force_references=tau, callback=reset, callback_every=every)
    replaced = states[3].reset(model, [1], fresh)
    after = _stepped(model, replaced, T - 3, tau[3:])
    _assert_records_match_steps(model, {k: v[3:] for k, v in rec.items() if k in STATE_RECORDS}, after)
    for a, b in zip(_state_numpy(final), _state_numpy(after[-1])):
        np.testing.assert_array_equal(a, b)


def test_rollout_object_reuses_buffers_and_graphs_with_new_controls():
    """A second run replays the captured graphs on new controls and a new initial state; a new batch size
    reallocates. Results are step's each time."""
    model = _legs_model(np.float64)
    T = 4
    roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions", "joint_torques"))
    for seed, N in ((0, 2), (1, 2), (2, 3)):
        data = _standing_data(model, N, seed=seed)
        tau = np.random.default_rng(seed).normal(size=(T, N, model.dofs()))
        final, rec = roll.run(data, joint_force_references=tau)
        _assert_records_match_steps(model, rec, _stepped(model, data, T, tau))
        if seed == 1:
            assert len(roll._config.graphs) == 1  # the first run's graph, replayed


def test_model_parameter_changes_reach_a_reused_rollout():
    """Changing the model's friction between runs changes the rollout (the plan, and the graph, are rebuilt)."""
    model = _pendulum(np.float64)
    data = wd.data.Data.build(model, joint_positions=np.full(model.dofs(), 0.3))
    roll = wd.simulation.Rollout(model, steps=5, record=("joint_velocities",))
    _, first = roll.run(data)
    first = first["joint_velocities"].numpy().copy()
    model.set_joint_parameters(friction_viscous=np.full(model.dofs(), 5.0))
    _, second = roll.run(data)
    np.testing.assert_array_equal(second["joint_velocities"].numpy()[-1], _stepped(model, data, 5)[-1].joint_velocities.numpy())
    assert not np.array_equal(first[-1], second["joint_velocities"].numpy()[-1])


# ------------------------------------------------------------------------------ gradients


@functools.cache
def _loss_kernels():
    """loss += sum over environments and joints of w_j (s_T + 0.3 sdot_T) + w_j s_{T/2}^2, for records with
    an environment axis (T + 1, N, n) and without one (T + 1, n)."""

    @wp.func
    def term(w: wp.float64, s_T: wp.float64, sd_T: wp.float64, s_h: wp.float64):
        return w * (s_T + wp.float64(0.3) * sd_T) + w * s_h * s_h

    @wp.kernel
    def batched(s: wp.array3d(dtype=wp.float64), sd: wp.array3d(dtype=wp.float64), w: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
        env, j = wp.tid()
        T = s.shape[0] - 1
        wp.atomic_add(out, 0, term(w[j], s[T, env, j], sd[T, env, j], s[T // 2, env, j]))

    @wp.kernel
    def single(s: wp.array2d(dtype=wp.float64), sd: wp.array2d(dtype=wp.float64), w: wp.array(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
        j = wp.tid()
        T = s.shape[0] - 1
        wp.atomic_add(out, 0, term(w[j], s[T, j], sd[T, j], s[T // 2, j]))

    return batched, single


def _loss(model, data, tau, w):
    """The loss of a rollout of a pendulum chain from `data` with per-step torques `tau` (T, ...)."""
    T = tau.shape[0]
    _, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau, record=("joint_positions", "joint_velocities"))
    s, sd = rec["joint_positions"], rec["joint_velocities"]
    out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    batched, single = _loss_kernels()
    if data.num_envs is None:
        wp.launch(single, dim=model.dofs(), inputs=[s, sd, w], outputs=[out])
    else:
        wp.launch(batched, dim=(s.shape[1], model.dofs()), inputs=[s, sd, w], outputs=[out])
    return out


@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched_shared_torques"])
def test_tape_gradient_through_rollout_equals_finite_differences(batched):
    """d loss / d (initial joint positions, per-step torques) by wp.Tape through 10 steps of a 4-link
    pendulum chain with viscous friction, float64, against central differences (h = 1e-5). Batched: 2
    environments sharing per-step torques (T, 1, n), so the torque gradient sums both environments."""
    model = _pendulum(np.float64)
    n, T = model.dofs(), 10
    N = 2 if batched else None
    rng = np.random.default_rng(8)
    s0 = rng.uniform(-0.5, 0.5, size=(n,) if N is None else (N, n))
    v0 = rng.uniform(-0.5, 0.5, size=s0.shape)
    tau = rng.normal(size=(T, n) if N is None else (T, 1, n))
    w = wp.array(rng.normal(size=n), dtype=wp.float64)

    def build(s):
        return wd.data.Data.build(model, joint_positions=s, joint_velocities=v0, num_envs=N)

    s_wp = wp.array(s0, dtype=wp.float64, requires_grad=True)
    tau_wp = wp.array(tau, dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        data = wd.data.Data.build(model, joint_positions=s_wp, joint_velocities=v0, num_envs=N, requires_grad=True)
        loss = _loss(model, data, tau_wp, w)
    tape.backward(loss)
    grad_s, grad_tau = s_wp.grad.numpy(), tau_wp.grad.numpy()

    h = 1e-5

    def f(s, t):
        return float(_loss(model, build(s), wp.array(t, dtype=wp.float64), w).numpy()[0])

    fd_s = np.zeros_like(s0)
    for i in np.ndindex(s0.shape):
        e = np.zeros_like(s0)
        e[i] = h
        fd_s[i] = (f(s0 + e, tau) - f(s0 - e, tau)) / (2 * h)
    fd_tau = np.zeros_like(tau)
    for i in np.ndindex(tau.shape):
        e = np.zeros_like(tau)
        e[i] = h
        fd_tau[i] = (f(s0, tau + e) - f(s0, tau - e)) / (2 * h)
    np.testing.assert_allclose(grad_s, fd_s, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(grad_tau, fd_tau, rtol=1e-6, atol=1e-9)
    assert np.abs(fd_tau).max() > 1e-3  # the torques matter


@functools.cache
def _contact_loss_kernel():
    @wp.kernel
    def loss(p: wp.array2d(dtype=wp.float64), s: wp.array2d(dtype=wp.float64), out: wp.array(dtype=wp.float64)):
        """out = z_B(T) + 0.1 x_B(T) + 0.01 sum_j s_j(T), for single-environment records."""
        j = wp.tid()
        T = p.shape[0] - 1
        term = wp.float64(0.01) * s[T, j]
        if j == 0:
            term = term + p[T, 2] + wp.float64(0.1) * p[T, 0]
        wp.atomic_add(out, 0, term)

    return loss


def test_tape_gradient_through_a_rollout_with_contacts():
    """d loss / d initial joint positions through 8 steps of the legs standing on flat ground (feet 4 mm
    deep, joints moving: contact forces and tangential deformation in every step), float64, against
    central differences (h = 1e-6; the contact force is smooth while the points stay in contact and
    sticking, as here): the contact kernel's adjoint within a rollout. Observed agreement ~2e-9."""
    model = _legs_model(np.float64)
    n, T = model.dofs(), 8
    rng = np.random.default_rng(0)
    s0, v0 = rng.uniform(-0.1, 0.1, n), rng.uniform(-0.2, 0.2, n)
    low = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min()
    p0 = np.array([0.0, 0.0, -low - 0.004])

    def loss(s, grad=False):
        data = wd.data.Data.build(model, base_position=p0, joint_positions=s, joint_velocities=v0, requires_grad=grad)
        _, rec = wd.simulation.rollout(model, data, steps=T, record=("base_position", "joint_positions", "tangential_deformation"))
        out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        wp.launch(_contact_loss_kernel(), dim=n, inputs=[rec["base_position"], rec["joint_positions"]], outputs=[out])
        return out, rec

    s_wp = wp.array(s0, dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        out, rec = loss(s_wp, True)
    tape.backward(out)
    assert np.abs(rec["tangential_deformation"].numpy()).max() > 1e-3
    h = 1e-6
    fd = np.array([(loss(s0 + h * e)[0].numpy()[0] - loss(s0 - h * e)[0].numpy()[0]) / (2 * h) for e in np.eye(n)])
    np.testing.assert_allclose(s_wp.grad.numpy(), fd, rtol=1e-6, atol=1e-9)


# ------------------------------------------------------------------------------ contact API


def _rot(H):
    return H[..., :3, :3], H[..., :3, 3]


def test_link_contact_forces_sum_points_and_convert_representations(dtype):
    """Inertial link wrenches = sums of the Inertial point wrenches of their points; Mixed and Body are the
    same wrench moved to the link origin (world or link axes); Mixed point wrenches are [f; 0], Body
    [R^T f; 0]; the Inertial link wrench is what step adds to the link's external force."""
    model = _legs_model(dtype)
    N = 3
    data = _standing_data(model, N, z=(0.55, 0.58))
    rel = REL[np.dtype(dtype)]
    f_C = wd.contact.collidable_point_forces(model, data, output_vel_repr=VelRepr.Inertial).numpy()
    W_f_L = wd.contact.link_contact_forces(model, data, output_vel_repr=VelRepr.Inertial)[0].numpy()
    assert np.abs(f_C).max() > 1.0, "no contact force: the test lost its contacts"
    body = np.asarray(model.kin_dyn_parameters.contact_parameters.body)[model.kin_dyn_parameters.contact_parameters.indices_of_enabled_collidable_points]
    scale = np.abs(f_C).max()
    expected = np.zeros_like(W_f_L)
    for L in range(model.number_of_links()):
        expected[:, L] = f_C[:, body == L].sum(axis=1)
    np.testing.assert_allclose(W_f_L, expected, rtol=0, atol=rel * scale * 16)
    _, m_dot, W_f_step = evaluations.contact_forces(model, data)
    np.testing.assert_array_equal(W_f_L, W_f_step.numpy())

    W_p_C = wd.contact.collidable_point_positions(model, data).numpy()
    np.testing.assert_allclose(f_C[..., 3:], np.cross(W_p_C, f_C[..., :3]), rtol=0, atol=rel * scale * 4)
    H = wd.model.forward_kinematics(model, data).numpy()
    R, p = _rot(H)
    f, tau = W_f_L[..., :3], W_f_L[..., 3:]
    mixed = np.concatenate([f, tau - np.cross(p, f)], axis=-1)
    body_f = np.concatenate([np.einsum("nlji,nlj->nli", R, f), np.einsum("nlji,nlj->nli", R, tau - np.cross(p, f))], axis=-1)
    for repr_, ref in ((VelRepr.Mixed, mixed), (VelRepr.Body, body_f)):
        with data.switch_velocity_representation(repr_):
            got = wd.contact.link_contact_forces(model, data, output_vel_repr=repr_)[0].numpy()
        np.testing.assert_allclose(got, ref, rtol=0, atol=rel * scale * 16, err_msg=repr_.name)
    point_mixed = wd.contact.collidable_point_forces(model, data, output_vel_repr=VelRepr.Mixed).numpy()
    np.testing.assert_array_equal(point_mixed[..., 3:], 0.0 * point_mixed[..., 3:])
    np.testing.assert_allclose(point_mixed[..., :3], f_C[..., :3], rtol=0, atol=rel * scale)
    R_C = R[np.arange(N)[:, None], body[None, :]]
    point_body = wd.contact.collidable_point_forces(model, data, output_vel_repr=VelRepr.Body).numpy()
    np.testing.assert_allclose(point_body[..., :3], np.einsum("ncji,ncj->nci", R_C, f_C[..., :3]), rtol=0, atol=rel * scale)
    np.testing.assert_allclose(point_body[..., 3:], 0.0, rtol=0, atol=rel * scale * 4)


def test_point_forces_at_rest_follow_hunt_crossley(dtype):
    """At rest with no deformation, a point at depth delta > 0 on flat ground pushes up with
    K (delta + eps)^p delta and no tangential force; points above the ground push nothing."""
    model = _legs_model(dtype)
    model.contact_params = wd.model.SoftContactsParams(K=2e5, D=3000.0, p=0.5)
    tilt = [np.sqrt(1.0 - 0.05**2), 0.05, 0.0, 0.0]  # about x: one foot lower than the other
    z0 = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, base_quaternion=tilt)).numpy()[:, 2]
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, -float(np.median(z0)) + 1e-3], base_quaternion=tilt)
    z = wd.contact.collidable_point_positions(model, data).numpy()[:, 2]
    delta = np.maximum(0.0, -z)
    assert (delta > 0).sum() >= 2 and (delta == 0).sum() >= 2
    f = wd.contact.collidable_point_forces(model, data, output_vel_repr=VelRepr.Mixed).numpy()
    expected = 2e5 * (delta + 2.220446049250313e-16) ** 0.5 * delta
    np.testing.assert_allclose(f[:, 2], expected, rtol=REL[np.dtype(dtype)] * 100, atol=1e-12)
    np.testing.assert_array_equal(f[:, :2], 0.0 * f[:, :2])
    # the links: both ankles get the sum of their points, the others nothing
    W_f_L = wd.contact.link_contact_forces(model, data, output_vel_repr=VelRepr.Inertial)[0].numpy()
    assert np.isclose(W_f_L[:, 2].sum(), expected.sum(), rtol=1e-5)


def test_contact_api_without_enabled_points_and_ignored_inputs():
    model = wd.contact.with_collidable_points(_legs_model(np.float64), enabled=np.zeros(32, dtype=bool))
    data = _standing_data(model, 2)
    assert np.all(wd.contact.link_contact_forces(model, data)[0].numpy() == 0.0)
    assert wd.contact.collidable_point_forces(model, data).shape == (2, 0, 6)
    legs = _legs_model(np.float64)
    data = _standing_data(legs, 2)
    a = wd.contact.link_contact_forces(legs, data)[0].numpy()
    b = wd.contact.link_contact_forces(legs, data, link_forces=np.ones((13, 6)), joint_torques=np.ones(12))[0].numpy()
    np.testing.assert_array_equal(a, b)
    with pytest.raises(ValueError, match="link_forces has shape"):
        wd.contact.link_contact_forces(legs, data, link_forces=np.ones((12, 6)))


@pytest.mark.parametrize(
    "terrain",
    [
        wd.terrain.PlaneTerrain(normal=(0.2, -0.1, 1.0), point=(0.0, 0.0, 0.05)),
        wd.terrain.FlatTerrain(height=0.03),
        wd.terrain.HeightfieldTerrain(np.array([[0.0, 0.05, 0.02], [0.04, -0.02, 0.06], [0.01, 0.03, -0.04]]), origin=(-0.3, -0.3), spacing=(0.3, 0.3)),
    ],
    ids=["plane", "flat", "heightfield"],
)
def test_in_contact_uses_the_terrain_height(terrain, dtype):
    """in_contact: a link is in contact when one of its enabled points has z <= h(x, y) (JaxSim's test)."""
    model = _legs_model(dtype)
    model.terrain = terrain
    N = 64
    data = wd.data.random_model_data(model, key=9, num_envs=N, base_pos_bounds=((-0.2, -0.2, 0.5), (0.2, 0.2, 0.75)), base_rpy_bounds=(-0.4, 0.4), joint_pos_bounds=(-0.3, 0.3))
    p = wd.contact.collidable_point_positions(model, data).numpy().astype(np.float64)
    h = terrain.height(p[..., 0], p[..., 1])
    gap = p[..., 2] - h
    tol = 1e-9 if dtype == np.float64 else 1e-5  # the kernel's h and z round differently from NumPy's
    cp = model.kin_dyn_parameters.contact_parameters
    body = np.asarray(cp.body)[cp.indices_of_enabled_collidable_points]
    links = range(model.number_of_links())
    expected = np.stack([(gap[:, body == L] <= 0.0).any(axis=1) for L in links], axis=1)
    # decided away from ties: a point surely below, or all points surely above (or no points)
    decided = np.stack([(gap[:, body == L] < -tol).any(axis=1) | (gap[:, body == L] > tol).all(axis=1) for L in links], axis=1)
    got = wd.contact.in_contact(model, data).numpy()
    np.testing.assert_array_equal(got[decided], expected[decided])
    assert decided.mean() > 0.95 and expected.any() and not expected.all()
    names = ("r_ankle_2", "l_ankle_2")
    idx = [model.link_names().index(k) for k in names]
    np.testing.assert_array_equal(wd.contact.in_contact(model, data, link_names=names).numpy(), got[:, idx])


# ------------------------------------------------------------------------------ the per-model plan


def _kernel_names(model, data, forces=False):
    plan, N = sim.prepare(model, data)
    ws = sim.Workspace(plan, N, False, forces)
    f = np.zeros((N, plan.nL, 6)) if forces else None
    f = None if f is None else wp.array(f, dtype=plan.scalar)
    launches = sim.step_launches(plan, ws, engine_kinematics.state_arrays(data), sim.state_buffers(plan, N, False), plan.zeros((plan.n,), N), f, int(data.velocity_representation))
    return [k.kernel.key.rsplit("__", 1)[-1] for k in launches]


def test_plan_is_cached_and_rebuilt_when_parameters_change():
    """The kernels a step uses are chosen once per model; replacing a parameter rebuilds the choice."""
    model = _pendulum(np.float64)
    plan = sim.plan(model)
    assert sim.plan(model) is plan and plan.with_friction and not plan.with_limits and not plan.contacts
    model.set_joint_parameters(limit_spring=np.full(model.dofs(), 10.0))
    assert sim.plan(model) is not plan and sim.plan(model).with_limits
    model.actuation_params = wd.model.ActuationParams(enable_friction=False)
    assert not sim.plan(model).with_friction
    legs = _legs_model(np.float64)
    p1 = sim.plan(legs)
    legs.contact_params = wd.model.SoftContactsParams(K=5e5)
    assert sim.plan(legs) is not p1 and sim.plan(legs).contact_bundle.K.numpy()[0] == 5e5


@pytest.mark.parametrize("fused", [True, False], ids=["fused", "launch_list"])
def test_models_launch_only_what_they_need(monkeypatch, fused):
    """The launch list (what a tape records): legs with contacts: actuation, FK, link velocities, the points'
    contact forces, their sums per link, ABA, the contact state's step, integrator; without enabled points: actuation,
    ABA, the contact state's step (the disabled points' deformation carried over), integrator.
    Fused (warpdyn.config.fused_step): the fused step alone (the joint forces in it), with or without points. Each list ends
    with the parameters' device check (kernels/parameter_checks.py). Mixed link forces add FK and a conversion (Inertial ones
    nothing)."""
    monkeypatch.setattr(wd.config, "fused_step", fused)
    legs = _legs_model(np.float64)
    data = _standing_data(legs, 2)
    with_contacts = _kernel_names(legs, data)
    no_contacts = wd.contact.with_collidable_points(legs, enabled=np.zeros(32, dtype=bool))
    without = _kernel_names(no_contacts, data)
    if fused:
        assert with_contacts == without == ["fused_euler_step", "keep_unphysical"], "the joint forces in the fused kernel"
    else:
        assert with_contacts == ["resultant_torques", "forward_kinematics", "link_velocities", "point_contact_forces", "link_contact_forces", "aba", "contact_state_euler", "semi_implicit_euler", "keep_unphysical"]
        assert without == ["resultant_torques", "aba", "contact_state_euler", "semi_implicit_euler", "keep_unphysical"]
    assert len(_kernel_names(no_contacts, data, forces=True)) == len(without) + 2
    inertial = wd.data.random_model_data(legs, key=1, num_envs=2, velocity_representation=VelRepr.Inertial)
    assert len(_kernel_names(no_contacts, inertial, forces=True)) == len(without)
    # the no-contact model still steps as the model whose points never touch (same numbers)
    high = wd.data.random_model_data(legs, key=2, num_envs=2, base_pos_bounds=((0, 0, 5.0), (0, 0, 5.0)))
    a, b = wd.model.step(legs, high), wd.model.step(no_contacts, high)
    for x, y in zip(_state_numpy(a), _state_numpy(b)):
        np.testing.assert_array_equal(x, y)
