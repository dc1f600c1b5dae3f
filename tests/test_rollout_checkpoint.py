"""Checkpointed rollouts (wd.simulation, storage="checkpointed"): gradients, forward values, memory, errors.

References and tolerances:
- Gradients against storage="trajectory" on the same inputs, float64 on the CPU: the checkpointed backward
  recomputes each segment with the forward's launches on the same numbers and runs their adjoints in the
  same order as the trajectory's tape (the copied records' gradients are added to the states just before
  the steps' adjoints, where the trajectory's loss adjoint adds them), so every gradient must be equal bit
  for bit; any difference would be a missed or doubled term, not rounding. (On a GPU the adjoints'
  atomic additions make both storages' gradients vary in the last bits from run to run: there they are
  compared within 1e-12 of each array's largest entry, which a missed or doubled term would exceed.) The trajectory
  storage's own gradients are checked against central differences in test_rollout.py and
  test_parameter_gradients.py.
- Forward values against "trajectory" and against `wd.model.step` in a loop: the same kernels on the same
  numbers, bitwise.
- Memory: `Rollout.memory_bytes` (computed without allocating) against `Rollout.nbytes` (the buffers a run
  allocated, walked one by one): integers, equal; and the checkpointed state count against its formula.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import warp as wp

import gradcheck
import robots
import warpdyn as wd
from warpdyn import VelRepr
from warpdyn.engine.kinematics import state_arrays

EULER, RK4 = wd.model.IntegratorType.SemiImplicitEuler, wd.model.IntegratorType.RungeKutta4
INTEGRATORS = pytest.mark.parametrize("integrator", [EULER, RK4], ids=["euler", "rk4"])
LEG_PARAMETERS = ("link_mass", "friction_viscous", "K", "terrain_height")
PENDULUM_PARAMETERS = ("link_mass", "friction_viscous", "joint_limit_spring")


@functools.cache
def _legs_base():
    """The seed's ergoCub legs (12 joints, 13 links, 32 collidable points), float64."""
    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=np.float64)
    return wd.model.reduce(full, robots.seed_joints(full.joint_names()))


def _legs(integrator, marked=LEG_PARAMETERS):
    """A copy of the legs with its own integrator and plan; `marked` parameters require gradients (the
    mass and friction arrays are shared by the copies: their gradients are zeroed by `_gradients`)."""
    model = _legs_base().copy()
    model.integrator = integrator
    params = wd.model.parameters_requiring_grad(model, names=marked) if marked else {}
    return model, params


def _pendulum(integrator, n=4):
    """A 4-link chain with viscous friction and limit springs (joints beyond their limits, so the springs act)."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
    model.integrator = integrator
    model.set_joint_parameters(friction_viscous=np.full(n, 0.3), position_limits=np.tile([-0.1, 0.1], (n, 1)), limit_spring=np.full(n, 8.0))
    return model, wd.model.parameters_requiring_grad(model, names=PENDULUM_PARAMETERS)


def _standing(model, N, seed=0, repr_=VelRepr.Mixed):
    """Random states of the legs with the feet near the ground (some points in contact), requiring gradients."""
    return wd.data.random_model_data(
        model,
        key=seed,
        num_envs=N,
        velocity_representation=repr_,
        base_pos_bounds=((-0.1, -0.1, 0.56), (0.1, 0.1, 0.6)),
        base_rpy_bounds=(-0.3, 0.3),
        joint_pos_bounds=(-0.3, 0.3),
        requires_grad=True,
    )


def _loss(arrays: list, seed: int = 3) -> wp.array:
    """sum over the arrays of random weights (drawn from `seed`, one per element) times the array (linear in
    the records; the rollout makes it nonlinear in the inputs)."""
    rng = np.random.default_rng(seed)
    arrays = [x for x in arrays if x.size]
    return gradcheck.weighted_sum(arrays, [wp.array(rng.normal(size=x.shape), dtype=wp.float64) for x in arrays])


def _gradients(model, params, data, controls: dict, record, storage, every=None, use_graph="auto", steps=6):
    """({name: gradient}, records, final state): a rollout under a tape from `data` with the Warp `controls`
    (requiring gradients), loss = _loss of the records and the final joint positions, backward; then
    tape.zero() and a second backward (checkpointed: with the scratch gradients filled with NaN, as an
    interrupted backward could leave them), whose gradients must be the first's."""
    for p in params.values():
        p.grad.zero_()
    state = dict(zip(("p", "Q", "s", "v", "sdot", "m"), state_arrays(data)[:6]))
    watched = {**{f"data.{k}": a for k, a in state.items() if a.requires_grad}, **controls, **params}
    tape = wp.Tape()
    with tape:
        roll = wd.simulation.Rollout(model, steps=steps, record=record, storage=storage, checkpoint_every=every, use_graph=use_graph)
        final, rec = roll.run(data, **controls)
        arrays = [rec[name] for name in record if rec[name].dtype == wp.float64] + [final.joint_positions_state]
        loss = _loss(arrays)
    tape.backward(loss)
    first = {k: a.grad.numpy().copy() for k, a in watched.items()}
    tape.zero()
    assert all(not np.any(a.grad.numpy()) for a in watched.values()), "tape.zero() left a gradient"
    if storage == "checkpointed":  # what an interrupted backward could leave: the next one starts from zero
        for g in roll._config._scratch_grads:
            g.fill_(float("nan"))
    tape.backward(loss)
    for k, a in watched.items():
        _assert_equal_gradient(a.grad.numpy(), first[k], f"{storage}: second backward, {k}")
    tape.zero()
    values = {name: a.numpy().copy() for name, a in rec.items()}
    return first, values, [a.numpy().copy() for a in state_arrays(final)], roll


ON_GPU = wp.get_device().is_cuda


def _assert_equal_gradient(got, ref, message: str) -> None:
    """Bit for bit on the CPU; on a GPU, where the adjoints' atomic additions sum in a varying order, within
    1e-12 of the array's largest entry (the rounding of that order, measured up to 4e-16 on an H100)."""
    if ON_GPU:
        np.testing.assert_allclose(got, ref, rtol=0, atol=1e-12 * np.abs(ref).max(initial=0.0), err_msg=message)
    else:
        np.testing.assert_array_equal(got, ref, err_msg=message)


def _assert_same(got: dict, ref: dict, label: str, gradients: bool = True) -> None:
    """Gradients as `_assert_equal_gradient` says; forward values (gradients=False) bit for bit on the CPU; on a
    GPU within 1e-13 of the array's largest entry: a checkpointed rollout steps unrecorded, its contact kernels a
    thread per point, where "trajectory" storage runs them a thread per environment (warpdyn.engine.contact_stage's
    contacts_per_environment), another compilation of the same operations (measured on an H200: 1.8e-15 in
    joint positions of order 10 after the legs' contacts)."""
    assert got.keys() == ref.keys()
    for k in ref:
        if gradients:
            _assert_equal_gradient(got[k], ref[k], f"{label}: {k}")
        elif ON_GPU:
            np.testing.assert_allclose(got[k], ref[k], rtol=0, atol=1e-13 * np.abs(ref[k]).max(initial=1.0), err_msg=f"{label}: {k}")
        else:
            np.testing.assert_array_equal(got[k], ref[k], err_msg=f"{label}: {k}")


def _assert_scratch_left_zero(roll) -> None:
    """The backward zeroes the gradients of the segment scratch (workspaces, states between checkpoints) once
    and relies on each segment's adjoints leaving them zero (Warp zeroes an element's gradient when the
    adjoint of its writer reads it): after a backward they must all be zero."""
    scratch = roll._config._scratch_grads
    assert scratch, "no scratch gradients"
    for g in scratch:
        assert not np.any(g.numpy()), f"a scratch gradient {g.shape} is left nonzero"


# ------------------------------------------------------------------------------ gradients


@INTEGRATORS
def test_pendulum_gradients_equal_trajectory(integrator):
    """A 4-link pendulum chain, 2 environments, T = 7 steps, per-step per-environment torques (T, N, n) and
    per-step link forces shared by the environments (T, 1, nL, 6) as Warp arrays, link masses, viscous
    friction and limit springs marked: the gradients with respect to the initial joint positions and
    velocities, both controls and the three parameters equal storage="trajectory"'s bit for bit (module
    docstring) for checkpoint_every = 1, 2 and 3 (not dividing 7: a shorter last segment), 7 (one segment)
    and None (the memory-minimising choice), with state records (one of zero size: no collidable points),
    a step record and the final data in the loss; and so does a second backward."""
    model, params = _pendulum(integrator)
    n, nL, N, T = model.dofs(), model.number_of_links(), 2, 7
    rng = np.random.default_rng(1)
    s0, v0 = rng.uniform(-0.5, 0.5, (N, n)), rng.uniform(-1.0, 1.0, (N, n))
    tau_np, f_np = rng.normal(size=(T, N, n)), 0.3 * rng.normal(size=(T, 1, nL, 6))
    record = ("joint_positions", "joint_velocities", "joint_torques", "tangential_deformation")

    def run(storage, every=None):
        data = wd.data.Data.build(model, joint_positions=s0, joint_velocities=v0, num_envs=N, requires_grad=True)
        controls = {
            "joint_force_references": wp.array(tau_np, dtype=wp.float64, requires_grad=True),
            "link_forces": wp.array(f_np, dtype=wp.float64, requires_grad=True),
        }
        return _gradients(model, params, data, controls, record, storage, every, steps=T)

    ref, ref_rec, ref_final, _ = run("trajectory")
    matter = [k for k in ref if not k.startswith("data.") or k in ("data.s", "data.sdot")]  # a fixed base: p, Q, v do not
    assert all(np.abs(ref[k]).max() > 1e-3 for k in matter), {k: np.abs(ref[k]).max() for k in matter}
    for every in (1, 2, 3, 7, None):
        got, rec, final, roll = run("checkpointed", every)
        _assert_scratch_left_zero(roll)
        _assert_same(got, ref, f"checkpoint_every={every}")
        _assert_same(rec, ref_rec, f"records, checkpoint_every={every}", gradients=False)
        for a, b in zip(final, ref_final):
            np.testing.assert_array_equal(a, b)
        assert roll._config.every == (every or roll.memory_bytes(N, joint_force_references=tau_np, link_forces=f_np)["checkpoint_every"])


@INTEGRATORS
@pytest.mark.parametrize("every", [1, 4], ids=lambda e: f"every{e}")
def test_legs_with_contacts_gradients_equal_trajectory(integrator, every):
    """The ergoCub legs standing on the ground (points in contact, tangential deformation growing), 2
    environments in the Body representation, T = 6 steps, per-step torques (T, N, n) and Body link forces
    (T, N, nL, 6) as Warp arrays, link masses, viscous friction, contact stiffness K and terrain height
    marked; every record kind in the loss: state records (joint positions, the Body base velocity, the
    tangential deformation) and step records (joint torques, link contact forces). The gradients with
    respect to the initial state (all six arrays), both controls and the parameters equal "trajectory"'s
    bit for bit (module docstring), with checkpoint_every 1 (all states kept) and 4 (not dividing 6), twice."""
    model, params = _legs(integrator)
    n, nL, N, T = model.dofs(), model.number_of_links(), 2, 6
    rng = np.random.default_rng(2)
    tau_np, f_np = 5.0 * rng.normal(size=(T, N, n)), rng.normal(size=(T, N, nL, 6))
    record = ("joint_positions", "base_velocity", "tangential_deformation", "joint_torques", "link_contact_forces", "valid")

    def run(storage):
        data = _standing(model, N, repr_=VelRepr.Body)
        controls = {
            "joint_force_references": wp.array(tau_np, dtype=wp.float64, requires_grad=True),
            "link_forces": wp.array(f_np, dtype=wp.float64, requires_grad=True),
        }
        return _gradients(model, params, data, controls, record, storage, None if storage == "trajectory" else every, steps=T)

    ref, ref_rec, ref_final, _ = run("trajectory")
    assert np.abs(ref_rec["link_contact_forces"]).max() > 1.0 and np.abs(ref_rec["tangential_deformation"][-1]).max() > 1e-5, "no contact"
    assert all(np.abs(g).max() > 1e-6 for g in ref.values()), {k: np.abs(g).max() for k, g in ref.items()}
    got, rec, final, roll = run("checkpointed")
    _assert_scratch_left_zero(roll)
    _assert_same(got, ref, f"legs, checkpoint_every={every}")
    _assert_same(rec, ref_rec, "records", gradients=False)
    for a, b in zip(final, ref_final):
        np.testing.assert_array_equal(a, b)


def test_shared_controls_single_environment_and_eager_forward():
    """Single-environment legs (Mixed: the base velocity record, a view of the trajectory, is here a copy of
    the checkpointed states) with constant torques (n,) and per-step link forces (T, nL, 6) given as Warp
    arrays, T = 5, checkpoint_every 2 and 5, the forward with and without a graph (use_graph=True is
    allowed under a tape for checkpointed storage: its steps are not recorded): gradients equal
    "trajectory"'s bit for bit (module docstring)."""
    model, params = _legs(EULER)
    n, nL, T = model.dofs(), model.number_of_links(), 5
    rng = np.random.default_rng(4)
    tau_np, f_np = 5.0 * rng.normal(size=(n,)), rng.normal(size=(T, nL, 6))
    record = ("base_position", "base_velocity", "joint_velocities")

    def run(storage, every=None, use_graph="auto"):
        data = _standing(model, None, seed=5)
        controls = {
            "joint_force_references": wp.array(tau_np, dtype=wp.float64, requires_grad=True),
            "link_forces": wp.array(f_np, dtype=wp.float64, requires_grad=True),
        }
        return _gradients(model, params, data, controls, record, storage, every, use_graph, steps=T)

    ref = run("trajectory")[0]
    for every, use_graph in ((2, True), (2, False), (5, "auto")):
        _assert_same(run("checkpointed", every, use_graph)[0], ref, f"every={every}, use_graph={use_graph}")


def test_gpu_layout_on_the_cpu(monkeypatch):
    """The environment-fastest layout of GPUs (transposed views; the backward slices the segment's states
    and records) forced on the CPU: pendulum, RK4, checkpoint_every 3 of T = 7, gradients equal
    "trajectory"'s in the same layout bit for bit (module docstring)."""
    monkeypatch.setattr(wd.config, "env_fastest", True)
    model, params = _pendulum(RK4)
    n, N, T = model.dofs(), 3, 7
    rng = np.random.default_rng(6)
    s0, v0, tau_np = rng.uniform(-0.5, 0.5, (N, n)), rng.uniform(-1.0, 1.0, (N, n)), rng.normal(size=(T, N, n))
    record = ("joint_positions", "joint_torques")

    def run(storage, every=None):
        data = wd.data.Data.build(model, joint_positions=s0, joint_velocities=v0, num_envs=N, requires_grad=True)
        tau = wp.array(tau_np, dtype=wp.float64, requires_grad=True)
        return _gradients(model, params, data, {"joint_force_references": tau}, record, storage, every, steps=T)

    ref = run("trajectory")
    got = run("checkpointed", 3)
    assert not got[3]._config.traj[2].is_contiguous  # the layout is the GPU's
    _assert_same(got[0], ref[0], "GPU layout")
    _assert_same(got[1], ref[1], "GPU layout records")


# ------------------------------------------------------------------------------ forward values


@pytest.mark.parametrize("graph", [True, False], ids=["graph", "eager"])
def test_forward_without_a_tape_equals_steps_and_runs_callbacks(graph):
    """Outside a tape checkpointed storage is a forward rollout (no gradients) whose records and final state
    are `step`'s in a loop, bit for bit; callbacks see the state at their steps (kept or between
    checkpoints) and may replace it."""
    model, _ = _legs(EULER, marked=())
    N, T = 2, 7
    data = _standing(model, N)
    tau = np.random.default_rng(7).normal(size=(T, N, model.dofs()))
    states = [data]
    for t in range(T):
        states.append(wd.model.step(model, states[-1], joint_force_references=tau[t]))
    seen = []

    def watch(t, d):
        seen.append(t)
        np.testing.assert_array_equal(d.joint_positions.numpy(), states[t].joint_positions.numpy())

    record = ("joint_positions", "base_position")
    roll = wd.simulation.Rollout(model, steps=T, storage="checkpointed", checkpoint_every=3, record=record, use_graph=graph)
    final, rec = roll.run(data, joint_force_references=tau, callback=watch, callback_every=2)
    assert seen == [2, 4, 6] and not roll._config.grad
    for t in range(T + 1):
        np.testing.assert_array_equal(rec["joint_positions"].numpy()[t], states[t].joint_positions.numpy())
        np.testing.assert_array_equal(rec["base_position"].numpy()[t], states[t].base_position.numpy())
    np.testing.assert_array_equal(final.joint_velocities.numpy(), states[T].joint_velocities.numpy())
    # a reset at t = 4 of environment 0: the rest continues from the replacement
    fresh = _standing(model, N, seed=9)
    final, rec = roll.run(data, joint_force_references=tau, callback=lambda t, d: d.reset(model, [0], fresh) if t == 4 else None, callback_every=2)
    after = states[4].reset(model, [0], fresh)
    for t in range(4, T):
        after = wd.model.step(model, after, joint_force_references=tau[t])
    np.testing.assert_array_equal(final.joint_positions.numpy(), after.joint_positions.numpy())


# ------------------------------------------------------------------------------ memory


def _state_bytes(model, grad=True) -> int:
    """Bytes of one environment's state: 13 + 2 n + 3 nc_all floats (doubled with gradients) + an int32 flag."""
    nc_all = len(model.kin_dyn_parameters.contact_parameters.body)
    return (13 + 2 * model.dofs() + 3 * nc_all) * 8 * (2 if grad else 1) + 4


@pytest.mark.parametrize(
    "storage,every,taping",
    [
        ("ping-pong", None, False),
        ("trajectory", None, False),
        ("trajectory", None, True),
        ("checkpointed", 1, True),
        ("checkpointed", 3, True),
        ("checkpointed", None, True),
        ("checkpointed", 4, False),
    ],
)
@INTEGRATORS
def test_memory_bytes_equal_the_allocated_buffers(storage, every, taping, integrator):
    """`memory_bytes` (computed from sizes) equals `nbytes` (the buffers a run allocated, with gradients)
    exactly, for each storage, under a tape or not, Body data with per-step torques and shared constant link
    forces, state and step records; the checkpointed states are (ceil(T / S) + 1 + S - 1) states."""
    model, _ = _legs(integrator, marked=())
    N, T = 3, 10
    n, nL = model.dofs(), model.number_of_links()
    tau, forces = np.zeros((T, N, n)), np.zeros((nL, 6))
    record = ("joint_positions", "base_velocity", "valid", "joint_torques", "collidable_point_forces")
    roll = wd.simulation.Rollout(model, steps=T, record=record, storage=storage, checkpoint_every=every)
    data = _standing(model, N, repr_=VelRepr.Body)
    shape_only = np.broadcast_to(0.0, (T, N, n))  # memory_bytes reads only the shape
    expected = roll.memory_bytes(N, grad=taping, velocity_representation=VelRepr.Body, joint_force_references=shape_only, link_forces=forces)
    if taping:
        with wp.Tape():
            roll.run(data, joint_force_references=tau, link_forces=forces)
    else:
        roll.run(data, joint_force_references=tau, link_forces=forces)
    assert expected["total"] == roll.nbytes, expected
    assert expected["total"] == sum(v for k, v in expected.items() if k not in ("total", "checkpoint_every", "graph"))  # graph: host memory
    S = expected["checkpoint_every"]
    if storage == "checkpointed":
        assert S == (every or roll._config.every)
        assert expected["states"] == (-(-T // S) + S) * _state_bytes(model, taping) * N
        if every is None:  # the chosen interval keeps the fewest bytes

            def total(s):
                other = wd.simulation.Rollout(model, steps=T, record=record, storage=storage, checkpoint_every=s)
                return other.memory_bytes(N, velocity_representation=VelRepr.Body, joint_force_references=tau, link_forces=forces)["total"]

            assert expected["total"] == min(total(s) for s in range(1, T + 1))
    elif storage == "trajectory" and taping:
        assert expected["states"] == (T + 1) * _state_bytes(model) * N
    assert S is None or storage == "checkpointed"


def test_checkpointing_keeps_less_than_the_trajectory():
    """For 100 steps of the legs under a tape, the checkpointed rollout with the default interval keeps less
    than a tenth of the trajectory's bytes (the step intermediates, ~100 times a state with RK4, are kept
    for one segment instead of every step), and memory grows linearly with the environments."""
    model, _ = _legs(RK4, marked=())
    T = 100
    traj = wd.simulation.Rollout(model, steps=T, storage="trajectory", record=())
    ckpt = wd.simulation.Rollout(model, steps=T, storage="checkpointed", record=())
    a, b = traj.memory_bytes(64)["total"], ckpt.memory_bytes(64)["total"]
    assert b < a / 10, (a, b)
    assert 2 * ckpt.memory_bytes(32)["total"] == b


# ------------------------------------------------------------------------------ errors


def test_bad_arguments_and_refusals():
    """checkpoint_every must be an integer in 1..steps and is only for checkpointed storage; callbacks are
    refused under a tape with checkpointed storage; ping-pong and use_graph=True are still refused under a
    tape for the other storages."""
    model, _ = _legs(EULER, marked=())
    data = _standing(model, 2)
    for bad in (0, -1, 6, 2.5, True, "3"):
        with pytest.raises(ValueError, match="checkpoint_every"):
            wd.simulation.Rollout(model, steps=5, storage="checkpointed", checkpoint_every=bad)
    for storage in ("auto", "trajectory", "ping-pong"):
        with pytest.raises(ValueError, match="checkpoint_every applies"):
            wd.simulation.Rollout(model, steps=5, storage=storage, checkpoint_every=2)
    with pytest.raises(ValueError, match="storage must be"):
        wd.simulation.Rollout(model, steps=5, storage="checkpoint")
    with pytest.raises(ValueError, match="callbacks are not supported"):
        with wp.Tape():
            wd.simulation.rollout(model, data, steps=4, storage="checkpointed", checkpoint_every=2, callback=lambda t, d: None)
    with pytest.raises(ValueError, match="ping-pong"):
        with wp.Tape():
            wd.simulation.rollout(model, data, steps=2, storage="ping-pong")
    with pytest.raises(ValueError, match="use_graph=True"):
        with wp.Tape():
            wd.simulation.rollout(model, data, steps=2, storage="trajectory", use_graph=True)
    with pytest.raises(ValueError, match="joint_force_references has shape"):
        wd.simulation.Rollout(model, steps=5).memory_bytes(2, joint_force_references=np.zeros((5, model.dofs())))


def test_backward_after_a_later_run_of_the_same_rollout_is_refused():
    """A checkpointed backward recomputes from the Rollout's buffers: after a second run of the same Rollout
    (other initial data) the first tape's backward raises instead of returning the second run's gradients;
    the second tape's backward (after tape.zero(): the refused pass had added its loss's adjoint into the
    records, the Rollout's buffers) equals a fresh Rollout's (reference: that run; bitwise)."""
    model, _ = _legs(EULER, marked=())
    roll = wd.simulation.Rollout(model, steps=4, storage="checkpointed", checkpoint_every=2, record=("joint_positions",))

    def taped(seed):
        data = _standing(model, 2, seed=seed)
        tape = wp.Tape()
        with tape:
            _, rec = roll.run(data)
            loss = _loss([rec["joint_positions"]])
        return tape, loss, data

    first = taped(0)
    second = taped(1)
    with pytest.raises(RuntimeError, match="overwrote"):
        first[0].backward(first[1])
    second[0].zero()  # the refused pass had run the loss's adjoint into the records both tapes share
    second[0].backward(second[1])
    got = second[2].joint_positions_state.grad.numpy()
    roll = wd.simulation.Rollout(model, steps=4, storage="checkpointed", checkpoint_every=2, record=("joint_positions",))
    fresh = taped(1)
    fresh[0].backward(fresh[1])
    _assert_equal_gradient(got, fresh[2].joint_positions_state.grad.numpy(), "a later backward of a fresh run")
    assert np.abs(got).max() > 0.0
