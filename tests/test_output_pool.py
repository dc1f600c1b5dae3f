"""The pooled wd.model.step (warpdyn.engine.fast_step) and its output pool (warpdyn.engine.pool).

Reference: warpdyn.engine.step.step, the path that allocates fresh arrays and runs the same kernels on the same
numbers, so every state must be equal bit for bit. The pool's contract: a set of output arrays is handed out
again only when nothing but the pool refers to its arrays, so nothing a caller can still see is overwritten;
each holder a user may keep is checked (it keeps the set from being reused, and letting it go frees it)."""

import dataclasses
import gc
import threading
import weakref

import numpy as np
import pytest
import torch
import warp as wp

import robots
import warpdyn as wd
from warpdyn import VelRepr
from warpdyn.engine import fast_step, pool
from warpdyn.engine import step as fresh
from warpdyn.engine.kinematics import state_arrays

STATE = (
    "base_position_state",
    "base_quaternion_state",
    "joint_positions_state",
    "base_velocity_state",
    "joint_velocities_state",
    "tangential_deformation_state",
    "valid_state",
)
ON_CPU = wp.get_device(robots.TEST_DEVICE).is_cpu


def test_reference_counts_are_exact_here():
    """The pool needs CPython's exact reference counts (with the GIL); the interpreters warpdyn supports have
    them, so the tests below always run (elsewhere every call would allocate, and this test says why they fail)."""
    assert pool.available()


def _legs(integrator=robots.SIE):
    model = robots.ergocub_seed_with_points(np.float64)
    model = wd.model.reduce(model, model.joint_names())  # its own plan, settings and pools
    model.integrator = integrator
    return model


def _standing(model, N, repr_=VelRepr.Mixed, seed=0):
    """The legs standing, the feet 3 mm deep, joints within 0.05 rad of zero: they stay healthy for 200 steps
    under the tests' torques (N(0, 0.5) N m) and link forces (N(0, 1))."""
    lowest = float(wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min())
    joints = np.random.default_rng(seed).uniform(-0.05, 0.05, (1 if N is None else N, model.dofs()))
    return wd.data.Data.build(
        model, num_envs=N, base_position=(0.0, 0.0, -lowest - 0.003), joint_positions=joints[0] if N is None else joints, velocity_representation=repr_,
    )  # fmt: skip


def _host(data) -> dict:
    return {name: getattr(data, name).numpy().copy() for name in STATE}


def _assert_same(a, b, label):
    a, b = (x if isinstance(x, dict) else _host(x) for x in (a, b))
    for name in STATE:
        np.testing.assert_array_equal(a[name], b[name], err_msg=f"{label}: {name}")


def _assert_close(a, b, label):
    """Equal to rounding (float64, 1e-12 of each quantity's size): a step under a tape or with gradients runs
    the launch list, the pooled and fresh paths without them the fused kernel (tests/test_fused_step.py)."""
    a, b = (x if isinstance(x, dict) else _host(x) for x in (a, b))
    for name in STATE:
        np.testing.assert_allclose(a[name], b[name], rtol=0.0, atol=1e-12 * max(1.0, float(np.abs(b[name]).max())), err_msg=f"{label}: {name}")


def _slot(model, data):
    N = data.batch_size
    return fast_step.steps_of(model, N).pool.slot_of(state_arrays(data))


def test_pool_hands_out_a_set_again_only_when_nobody_holds_it():
    """The pool alone (arrays of a CPU or GPU device): a set is free right after it is made, busy while any
    array of it is held (a list, a view), free again once let go; at most `size` sets, then None."""
    made = []

    def make():
        made.append(1)
        return [wp.zeros(3, dtype=wp.float64), wp.zeros((2, 2), dtype=wp.float32)]

    outputs = pool.OutputPool(make, shadow=lambda arrays: [pool.alias(a) for a in arrays], size=2)
    first = outputs.take()
    assert first.lent and not first.free() and len(made) == 1, "taken, not handed out: lent"
    held = outputs.hand_out(first)
    assert not first.lent and not first.free() and all(a is b for a, b in zip(held, first.arrays))
    del held
    assert first.free() and outputs.take() is first and len(made) == 1
    outputs.hand_out(first)
    assert all(s.ptr == a.ptr and s._ref is None for s, a in zip(first.shadow, first.arrays)), "aliases keep nothing alive"
    held = [first.arrays[1]]
    assert not first.free()
    second = outputs.take()
    assert second is not first and len(made) == 2
    outputs.hand_out(second)
    view = second.arrays[0][1:]
    assert outputs.take() is None, "both sets are held: no third"
    del held
    assert outputs.take() is first
    outputs.hand_out(first)
    assert outputs.take(busy=first) is None
    del view
    gc.collect()
    assert outputs.take(busy=first) is second
    outputs.hand_out(second)
    assert outputs.slot_of(list(second.arrays)) is second and outputs.slot_of([second.arrays[0], first.arrays[1]]) is None
    second.arrays[0].requires_grad = True  # a set marked for gradients is not handed out again
    assert not second.free()
    kept = []  # arrays that something else refers to as they are made (a capture that records them, say)
    leaky = pool.OutputPool(lambda: kept.append(wp.zeros(3, dtype=wp.float64)) or kept[-1:])
    assert leaky.take() is None and leaky.slots == []


@pytest.mark.parametrize("N", [None, 3], ids=["single", "batched"])
@pytest.mark.parametrize("integrator", [robots.SIE, robots.RK4], ids=["euler", "rk4"])
def test_a_loop_equals_fresh_steps_bitwise_and_cycles_two_sets(integrator, N):
    """200 steps `data = step(model, data, ...)` of the legs in contact with new torques at every step (NumPy,
    or a Warp array every third step), Body link forces in the second half: every state equals that of the
    fresh path. The outputs cycle through two sets of the pool (the same two pointers), replayed from graphs."""
    steps = 200
    device = wp.get_device(robots.TEST_DEVICE)
    if device.is_cuda and not device.stream.cuda_stream:
        # Warp 1.19's array.numpy() from several threads at once (tests/test_threads.py) can leave the device on
        # the legacy null stream; the first capture then gives it a stream of its own (launch.capture), and the
        # pool, one per stream, starts again with new sets. Start on a capturable stream, as a capture leaves it.
        device.set_stream(wp.Stream(device))
    model = _legs(integrator)
    n, nL = model.dofs(), model.number_of_links()
    data = expected = _standing(model, N, VelRepr.Body)
    batch = () if N is None else (N,)
    rng = np.random.default_rng(1)
    pointers = []
    for t in range(steps):
        tau = rng.normal(0, 0.5, (*batch, n))
        if t % 3 == 2:
            tau = wp.array(tau, dtype=wp.float64)
        f = rng.normal(0, 1, (*batch, nL, 6)) if t >= steps // 2 else None
        data = wd.model.step(model, data, joint_force_references=tau, link_forces=f)
        expected = fresh.step(model, expected, joint_force_references=tau, link_forces=f)
        _assert_same(data, expected, f"step {t}")
        assert data.velocity_representation == VelRepr.Body and data.num_envs == N
        pointers.append(data.joint_positions_state.ptr)
    assert np.abs(data.tangential_deformation_state.numpy()).max() > 0, "no contact"
    assert data.valid_state.numpy().all()
    pooled = fast_step.steps_of(model, 1 if N is None else N)
    assert len(pooled.pool.slots) == 2 and _slot(model, data) is not None
    assert len(set(pointers[2:])) == 2 and pointers[2::2] == [pointers[2]] * len(pointers[2::2])
    assert len(pooled.graphs) >= 4, pooled.graphs.keys()  # 2 pairs, without and with link forces


def test_stepping_one_state_again_and_again():
    """The same user-built data stepped with new torques each call (the `foreign` input: replayed from graphs
    after CAPTURE_AFTER calls), then edited in place (the graphs read its memory as it is then), then another
    data: every result equals the fresh path's, and every result is a pool set."""
    model = _legs()
    n = model.dofs()
    data = _standing(model, 2)
    rng = np.random.default_rng(3)
    for k in range(6):
        tau = rng.normal(0, 0.5, (2, n))
        got = wd.model.step(model, data, joint_force_references=tau)
        _assert_same(got, fresh.step(model, data, joint_force_references=tau), f"call {k}")
        assert _slot(model, got) is not None
    assert any(key[0] == "foreign" for key in fast_step.steps_of(model, 2).graphs)
    data.joint_positions_state.assign(rng.uniform(-0.2, 0.2, (2, n)))
    _assert_same(wd.model.step(model, data), fresh.step(model, data), "edited in place")
    other = _standing(model, 2, seed=5)
    for _ in range(4):
        _assert_same(wd.model.step(model, other), fresh.step(model, other), "another data")
    held = fast_step.steps_of(model, 2).foreign[0]
    assert all(a is b for a, b in zip(held, state_arrays(other))), "the last user-built state is the one kept"


def test_a_step_inside_a_step_gets_another_set():
    """A finalizer that steps while a step runs (fired as the step lets go of the previous user-built input
    state) gets another set than the outer step; both results equal the fresh path's."""
    model = _legs()
    kept = wd.model.step(model, _standing(model, 2))
    first = _standing(model, 2, seed=5)
    wd.model.step(model, first)  # the pooled steps keep its arrays (the `foreign` input)
    nested = []
    weakref.finalize(first.joint_positions_state, lambda: nested.append(wd.model.step(model, kept)))
    del first
    second = _standing(model, 2, seed=6)
    outer = wd.model.step(model, second)
    assert len(nested) == 1, "the finalizer ran inside the step"
    assert nested[0].joint_positions_state is not outer.joint_positions_state
    _assert_same(outer, fresh.step(model, second), "outer")
    _assert_same(nested[0], fresh.step(model, kept), "nested")


def test_representations_batch_sizes_and_non_finite_states_through_the_pool():
    """One model stepped in turn with each velocity representation and two batch sizes (each its own launch
    lists and graphs), and with an environment driven non-finite: every result equals the fresh path's,
    health flags included."""
    model = _legs()
    for N in (2, 3):
        datas = {r: _standing(model, N, r, seed=N) for r in (VelRepr.Body, VelRepr.Mixed, VelRepr.Inertial)}
        expected = dict(datas)
        for t in range(4):
            for r in datas:
                datas[r] = wd.model.step(model, datas[r])
                expected[r] = fresh.step(model, expected[r])
                _assert_same(datas[r], expected[r], f"N = {N}, {r.name}, step {t}")
                assert datas[r].velocity_representation == r
        assert {key[2] for key in fast_step.steps_of(model, N).programs} == {int(r) for r in datas}
    data = expected = _standing(model, 2)
    tau = np.zeros((2, model.dofs()))
    tau[1, 0] = np.nan  # in a Warp array, a non-finite control flags its environment (NumPy's is refused)
    tau = wp.array(tau, dtype=wp.float64)
    for t in range(3):
        data = wd.model.step(model, data, joint_force_references=tau)
        expected = fresh.step(model, expected, joint_force_references=tau)
        _assert_same(data, expected, f"non-finite, step {t}")
    assert data.valid_state.numpy().tolist() == [1, 0]


def _holders():
    """Ways to keep a step's result (or a part of it) that a user has: each must keep the set from reuse."""
    holders = {
        "data": lambda d: d,
        "field": lambda d: d.joint_positions_state,
        "view [0]": lambda d: d.joint_positions_state[0],
        "property": lambda d: d.joint_positions,
        "slice": lambda d: d.base_velocity_state[:, 3:],
        "strided view": lambda d: wd.arrays.strided_view(d.base_position_state, (3,), (d.base_position_state.strides[1],)),
        "wp.array(copy=False)": lambda d: wp.array(d.joint_velocities_state, copy=False),
        "closure": lambda d: (lambda q=d.valid_state: q),
        "list": lambda d: [d.tangential_deformation_state],
        "dlpack": lambda d: wp.to_dlpack(d.joint_positions_state),
    }
    if ON_CPU:  # on a GPU .numpy() is a copy, which nothing overwrites
        holders["numpy view"] = lambda d: d.joint_positions_state.numpy()
    if not wd.arrays.env_fastest(robots.TEST_DEVICE):  # Warp reshapes contiguous arrays only (not the GPU layout)
        holders["reshape"] = lambda d: d.joint_positions_state.reshape((-1,))
        holders["flatten"] = lambda d: d.base_quaternion_state.flatten()
    return holders


@pytest.mark.parametrize("holder", list(_holders()))
def test_a_held_result_is_never_overwritten(holder):
    """A result of the loop is kept only through `holder`, then 12 more steps run: its set is not handed out,
    its memory keeps the values it had (bitwise); once the holder is let go, the set is free again."""
    model = _legs()
    data = _standing(model, None)
    for _ in range(3):
        data = wd.model.step(model, data, joint_force_references=np.ones(model.dofs()))
    slot = _slot(model, data)
    kept = _holders()[holder](data)
    before = {name: a.numpy().copy() for name, a in zip(STATE, slot.arrays)}
    data = wd.model.step(model, data)
    gc.collect()
    assert not slot.free(), f"{holder} does not count"
    for t in range(12):
        data = wd.model.step(model, data, joint_force_references=np.full(model.dofs(), float(t)))
        assert _slot(model, data) is not slot
    _assert_same(before, {name: a.numpy() for name, a in zip(STATE, slot.arrays)}, holder)
    del kept
    gc.collect()
    assert slot.free(), f"letting {holder} go does not free the set"


def test_a_torch_tensor_keeps_its_result():
    """wp.to_torch (zero copy) and torch.from_dlpack of results of the loop: their values stay while later steps
    run, and the sets are free once the tensors are gone."""
    model = _legs()
    data = _standing(model, 2)
    data = wd.model.step(model, data)
    tensor = wp.to_torch(data.joint_positions_state)
    slot = _slot(model, data)
    data = wd.model.step(model, data)
    other = torch.from_dlpack(data.base_velocity_state)
    held = tensor.clone(), other.clone()
    other_slot = _slot(model, data)
    for _ in range(10):
        data = wd.model.step(model, data, joint_force_references=np.ones(model.dofs()))
    assert torch.equal(tensor, held[0]) and torch.equal(other, held[1])
    assert not slot.free() and not other_slot.free()
    del tensor, other
    gc.collect()
    assert slot.free() and other_slot.free()


def test_a_tape_keeps_the_state_it_read():
    """forward_dynamics_aba of a pooled result under a wp.Tape (the tape keeps the State bundle, which keeps the
    arrays); the result is then let go and 10 more steps run; the tape's gradient equals that of a tape on a
    copy of the state: the steps did not overwrite what the adjoint reads."""
    model = _legs()
    n = model.dofs()
    data = _standing(model, None)
    for _ in range(3):
        data = wd.model.step(model, data)
    copy = dataclasses.replace(data, **{name: wp.clone(getattr(data, name)) for name in STATE})
    slot = _slot(model, data)

    def gradient(d):
        tau = wp.array(np.linspace(-1, 1, n), dtype=wp.float64, requires_grad=True)
        tape = wp.Tape()
        with tape:
            _, joints = wd.model.forward_dynamics_aba(model, d, joint_forces=tau)
        return tape, tau, joints

    tape, tau, joints = gradient(data)
    del data
    data = copy
    for _ in range(10):
        data = wd.model.step(model, data, joint_force_references=np.ones(n))
    assert not slot.free()
    tape.backward(grads={joints: wp.array(np.ones(n), dtype=wp.float64)})
    ref_tape, ref_tau, ref_joints = gradient(copy)
    ref_tape.backward(grads={ref_joints: wp.array(np.ones(n), dtype=wp.float64)})
    np.testing.assert_array_equal(tau.grad.numpy(), ref_tau.grad.numpy())
    assert np.abs(tau.grad.numpy()).max() > 0
    tape.reset()
    del tape, joints
    gc.collect()
    assert slot.free()


def test_under_a_tape_and_with_gradients_steps_are_fresh():
    """Under a wp.Tape, or when the data or a parameter requires gradients, a step's arrays are not the pool's
    (the adjoint reads them later); the results equal the fresh path's (to rounding: `_assert_close`)."""
    model = _legs()
    data = wd.model.step(model, _standing(model, 2))
    with wp.Tape():
        taped = wd.model.step(model, data)
    assert _slot(model, taped) is None
    _assert_close(taped, fresh.step(model, data), "taped")
    tau = wp.array(np.ones((2, model.dofs())), dtype=wp.float64, requires_grad=True)
    assert _slot(model, wd.model.step(model, data, joint_force_references=tau)) is None
    model.mark_for_gradients(["link_mass"])
    assert _slot(model, wd.model.step(model, data)) is None


def test_a_model_change_after_graphs_exist():
    """Graphs exist after 8 steps; then setters (friction on, a new time step) change the plan: the next steps
    follow the new values as the fresh path does (a new model version, a new pool)."""
    model = _legs()
    data = expected = _standing(model, 2)
    rng = np.random.default_rng(4)

    def run(k):
        nonlocal data, expected
        for t in range(k):
            tau = rng.normal(0, 0.5, (2, model.dofs()))
            data = wd.model.step(model, data, joint_force_references=tau)
            expected = fresh.step(model, expected, joint_force_references=tau)
            _assert_same(data, expected, f"version {model.version}, step {t}")

    run(8)
    first = fast_step.steps_of(model, 2)
    assert len(first.graphs) >= 2
    model.set_joint_parameters(friction_static=np.full(model.dofs(), 0.5), friction_viscous=np.full(model.dofs(), 0.2))
    run(6)
    second = fast_step.steps_of(model, 2)
    assert second is not first and second.plan.with_friction and len(second.graphs) >= 1
    model.time_step = 5e-4
    run(6)
    assert fast_step.steps_of(model, 2).plan.dt == 5e-4 and data.valid_state.numpy().all()


def test_inputs_copied_on_the_device():
    """The GPU's way of filling the input buffers (a copy kernel, a host value uploaded first), forced on any
    device: NumPy (shared and per environment), shared and full Warp arrays, link forces, bitwise as fresh."""
    model = _legs()
    n, nL = model.dofs(), model.number_of_links()
    data = expected = _standing(model, 3, VelRepr.Inertial)
    data = wd.model.step(model, data, joint_force_references=np.zeros(n), link_forces=np.zeros((nL, 6)))
    expected = fresh.step(model, expected, joint_force_references=np.zeros(n), link_forces=np.zeros((nL, 6)))
    pooled = fast_step.steps_of(model, 3)
    for k, (buffer, _) in list(pooled.buffers.arrays.items()):
        pooled.buffers.arrays[k] = (buffer, None)
    rng = np.random.default_rng(6)
    for t in range(8):
        tau = (rng.normal(0, 0.5, n), rng.normal(0, 0.5, (3, n)))[t % 2]
        tau = wp.array(tau, dtype=wp.float64) if t % 4 >= 2 else tau
        f = rng.normal(0, 1, (nL, 6)) if t % 3 else wp.array(rng.normal(0, 1, (3, nL, 6)), dtype=wp.float64)
        data = wd.model.step(model, data, joint_force_references=tau, link_forces=f)
        expected = fresh.step(model, expected, joint_force_references=tau, link_forces=f)
        _assert_same(data, expected, f"step {t}")


def test_actuators_through_the_pool():
    """An MJCF humanoid with position servos driven by `ctrl` (NumPy, then absent): the loop equals the fresh path."""
    import mjcf_models as mm

    model = wd.model.Model.build_from_model_description(mm.FLOATING_HUMANOID, dtype=np.float64)
    N, na = 2, model.number_of_actuators()
    data = expected = wd.data.Data.build(model, num_envs=N, joint_positions=np.random.default_rng(0).uniform(-0.3, 0.3, (N, model.dofs())))
    rng = np.random.default_rng(2)
    for t in range(10):
        u = rng.uniform(-1, 1, (N, na)) if t < 6 else None
        data = wd.model.step(model, data, ctrl=u)
        expected = fresh.step(model, expected, ctrl=u)
        _assert_same(data, expected, f"step {t}")


def test_bad_inputs_to_a_pooled_step_are_named():
    """Inputs to a step of a pooled result get the errors of warpdyn.arrays.batched_input, and the pool steps on."""
    model = _legs()
    n = model.dofs()
    data = wd.model.step(model, _standing(model, None))
    with pytest.raises(ValueError, match=r"joint_force_references has shape \(3,\)"):
        wd.model.step(model, data, joint_force_references=np.zeros(3))
    with pytest.raises(ValueError, match="joint_force_references has non-finite values"):
        wd.model.step(model, data, joint_force_references=np.full(n, np.nan))
    with pytest.raises(TypeError, match="link_forces has dtype"):
        wd.model.step(model, data, link_forces=wp.zeros((model.number_of_links(), 6), dtype=wp.float32))
    with pytest.raises(TypeError, match="ctrl must be an array of numbers"):
        wd.model.step(model, data, ctrl="one")
    _assert_same(wd.model.step(model, data), fresh.step(model, data), "after the errors")


def test_two_threads_step_one_model():
    """Two threads step the same model at once, each its own states and torques: 12 rounds of a new Data (built in
    the thread) stepped 5 times, with ABA at each step; every state and acceleration equals the serial fresh
    path's. On the CPU no graph is captured while another thread runs (Warp's CPU capture is process-wide: the
    other thread's builds and launches would go through it and fail); each thread has its own pool."""
    model = _legs()
    n = model.dofs()
    lowest = float(wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min())

    def program(k, step):
        rng = np.random.default_rng(10 + k)
        states = []
        for _ in range(12):
            joints = rng.uniform(-0.05, 0.05, (2, n))
            d = wd.data.Data.build(model, num_envs=2, base_position=(0.0, 0.0, -lowest - 0.003), joint_positions=joints)
            for _ in range(5):
                d = step(model, d, joint_force_references=rng.normal(0, 0.5, (2, n)))
                states.append({**_host(d), "aba": wd.model.forward_dynamics_aba(model, d)[1].numpy().copy()})
        return states

    expected = [program(k, fresh.step) for k in (0, 1)]
    got, graphs, errors = [None, None], [None, None], []
    barrier = threading.Barrier(2)

    def worker(k):
        try:
            barrier.wait()
            got[k] = program(k, wd.model.step)
            graphs[k] = len(fast_step.steps_of(model, 2).graphs)
        except Exception as error:  # noqa: BLE001 - reported below
            errors.append(error)

    threads = [threading.Thread(target=worker, args=(k,)) for k in (0, 1)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not errors, errors
    for k in (0, 1):
        for t, (a, b) in enumerate(zip(got[k], expected[k])):
            for name in a:
                np.testing.assert_array_equal(a[name], b[name], err_msg=f"thread {k}, step {t}: {name}")
    if ON_CPU:
        assert graphs == [0, 0]


def _dynamics(model, data, tau, f):
    """The dynamics functions whose outputs come from pools, with inputs where they take them."""
    return {
        "aba": wd.model.forward_dynamics_aba(model, data, joint_forces=tau, link_forces=f),
        "crb": wd.model.forward_dynamics_crb(model, data, joint_forces=tau, link_forces=f),
        "mass matrix": wd.model.free_floating_mass_matrix(model, data),
        "mass matrix inverse": wd.model.free_floating_mass_matrix_inverse(model, data),
        "bias": wd.model.free_floating_bias_forces(model, data),
        "gravity": wd.model.free_floating_gravity_forces(model, data),
        "inverse": wd.model.inverse_dynamics(model, data, joint_accelerations=tau, base_acceleration=np.full(6, 0.5), link_forces=f),
        "passive": wd.model.free_floating_passive_forces(model, data),
    }


def _hosts(results: dict) -> dict:
    return {k: [a.numpy().copy() for a in (v if isinstance(v, tuple | list) else [v])] for k, v in results.items()}


@pytest.mark.parametrize("N", [None, 2], ids=["single", "batched"])
def test_dynamics_outputs_from_pools_equal_fresh_ones(N):
    """Each dynamics function, with NumPy and Warp inputs (shared and per environment, contiguous or strided views;
    copied into the thread's buffers on the CPU), equals its result under a wp.Tape (fresh outputs and inputs)
    bitwise, call after call; a result let go is handed out again (the same array), a held one (its NumPy values)
    is not overwritten."""
    model = _legs()
    n, nL = model.dofs(), model.number_of_links()
    batch = () if N is None else (N,)
    rng = np.random.default_rng(7)
    held = None
    for k in range(5):
        data = _standing(model, N, (VelRepr.Body, VelRepr.Mixed)[k % 2], seed=k)
        tau = rng.normal(0, 1, (*batch, n)) if k % 2 else wp.array(rng.normal(0, 1, n), dtype=wp.float64)
        f = rng.normal(0, 1, (nL, 6)) if k < 2 else wp.array(rng.normal(0, 1, (*batch, nL, 6)), dtype=wp.float64)
        if k == 4:  # strided views: every other number of wider arrays
            every = (slice(None),) * (len(batch) + 1)
            tau = wp.array(rng.normal(0, 1, (*batch, n, 2)), dtype=wp.float64)[(*every, 0)]
            f = wp.array(rng.normal(0, 1, (*batch, nL, 6, 2)), dtype=wp.float64)[(*every, slice(None), 0)]
            assert not (tau.is_contiguous or f.is_contiguous)
        got = _hosts(_dynamics(model, data, tau, f))
        with wp.Tape():
            expected = _hosts(_dynamics(model, data, tau, f))
        for name in got:
            for a, b in zip(got[name], expected[name]):
                np.testing.assert_array_equal(a, b, err_msg=f"call {k}: {name}")
        if held is None:
            held = wd.model.free_floating_mass_matrix(model, data)
            values = held.numpy().copy()
    np.testing.assert_array_equal(held.numpy(), values)
    first = wd.model.forward_dynamics_aba(model, data)[1]
    pointer = first.ptr
    del first
    assert wd.model.forward_dynamics_aba(model, data)[1].ptr == pointer
    kept = wd.model.forward_dynamics_aba(model, data)[1]
    assert wd.model.forward_dynamics_aba(model, data)[1].ptr != kept.ptr


def test_dynamics_inputs_with_gradients_are_read_in_place():
    """An input that requires gradients is not copied: outside a tape the outputs are fresh arrays that require
    gradients (not a pool's), and under a tape its gradient arrives (ABA's joint forces)."""
    model = _legs()
    n = model.dofs()
    data = _standing(model, None)
    tau = wp.array(np.linspace(-1, 1, n), dtype=wp.float64, requires_grad=True)
    _, first = wd.model.forward_dynamics_aba(model, data, joint_forces=tau)
    _, second = wd.model.forward_dynamics_aba(model, data, joint_forces=tau)
    assert first.requires_grad and second.requires_grad and first.ptr != second.ptr
    tape = wp.Tape()
    with tape:
        _, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=tau)
    tape.backward(grads={joints: wp.array(np.ones(n), dtype=wp.float64)})
    assert np.abs(tau.grad.numpy()).max() > 0
    assert joints.requires_grad


def test_a_plan_change_without_a_new_model_version():
    """A parameter's requires_grad set directly (no setter, so no new model version) changes the step's plan
    (gravity compensation kept for its gradient): steps before, during (to rounding: with gradients, the launch
    list) and after give the same states, and each plan gets its own workspaces (an AttributeError once: the
    old plan's workspace had no such buffer)."""
    model = _legs()
    data = _standing(model, 2)
    before = _host(fresh.step(model, data))  # the fresh path's per-thread workspace, made for this plan
    model.gravcomp_mass.requires_grad = True
    try:
        during = _host(wd.model.step(model, data))
    finally:
        model.gravcomp_mass.requires_grad = False
    after = _host(wd.model.step(model, data))
    _assert_close(during, before, "gravity compensation marked")
    _assert_same(after, before, "unmarked")
