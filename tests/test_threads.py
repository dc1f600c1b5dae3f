"""Thread safety: every function family called from several Python threads at once gives what the same calls
give one after the other (bit for bit: the same kernels on the same numbers), on one shared model and on
several models; rollouts and Steppers capture graphs from several threads; and kernels compiled for the
first time from several threads at once (a fresh kernel cache, in a fresh interpreter).

Each thread owns its data (its own states: one model's per-thread workspaces must keep them apart) and
repeats its calls, so that the threads' launches interleave."""

import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from warpdyn import VelRepr
from warpdyn.kernels.factory import factory

THREADS = 4
REPEATS = 6


def _legs():
    model = robots.ergocub_seed_with_points(np.float64)
    return wd.model.reduce(model, model.joint_names())


def _data(model, seed, N=3, repr_=VelRepr.Mixed):
    return wd.data.random_model_data(
        model, key=seed, num_envs=N, velocity_representation=repr_,
        base_pos_bounds=((-0.1, -0.1, 0.56), (0.1, 0.1, 0.6)), base_rpy_bounds=(-0.3, 0.3), joint_pos_bounds=(-0.3, 0.3),
    )  # fmt: skip


def _host(value):
    if isinstance(value, (tuple, list)):
        return [_host(v) for v in value]
    if isinstance(value, dict):
        return {k: _host(v) for k, v in value.items()}
    if isinstance(value, wp.array):
        return value.numpy().copy()
    if hasattr(value, "base_position_state"):  # Data
        return [value.base_position_state.numpy().copy(), value.base_quaternion_state.numpy().copy(),
                value.joint_positions_state.numpy().copy(), value.base_velocity_state.numpy().copy(),
                value.joint_velocities_state.numpy().copy(), value.tangential_deformation_state.numpy().copy(),
                value.valid_state.numpy().copy()]  # fmt: skip
    return np.asarray(value)


def _assert_same(got, expected, label):
    if isinstance(expected, list):
        assert len(got) == len(expected), label
        for k, (g, e) in enumerate(zip(got, expected)):
            _assert_same(g, e, f"{label}[{k}]")
    elif isinstance(expected, dict):
        assert got.keys() == expected.keys(), label
        for k in expected:
            _assert_same(got[k], expected[k], f"{label}[{k}]")
    else:
        np.testing.assert_array_equal(got, expected, err_msg=label)


def _in_threads(work, count=THREADS):
    """work(i) in `count` threads started together; their results (host copies) in thread order, or the
    first exception any of them raised."""
    results, errors = [None] * count, []
    barrier = threading.Barrier(count)

    def run(i):
        try:
            barrier.wait()
            results[i] = work(i)
        except BaseException as error:  # noqa: BLE001  (re-raised in the main thread)
            errors.append(error)

    threads = [threading.Thread(target=run, args=(i,)) for i in range(count)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=600)
    assert not any(t.is_alive() for t in threads), "a thread hung"
    if errors:
        raise errors[0]
    return results


FAMILIES = {
    "kinematics": lambda m, d: [wd.model.forward_kinematics(m, d), wd.model.generalized_free_floating_jacobian(m, d),
                                wd.link.velocity(m, d, link_index=3)],
    "dynamics": lambda m, d: [wd.model.forward_dynamics_aba(m, d), wd.model.free_floating_mass_matrix(m, d),
                              wd.model.free_floating_bias_forces(m, d), wd.model.forward_dynamics_crb(m, d),
                              wd.model.inverse_dynamics(m, d, base_acceleration=np.ones(6), joint_accelerations=np.ones(m.dofs()))],
    "centroidal": lambda m, d: [wd.com.com_position(m, d), wd.com.centroidal_momentum(m, d),
                                wd.com.centroidal_momentum_jacobian(m, d), wd.model.mechanical_energy(m, d)],
    "contact": lambda m, d: [wd.contact.link_contact_forces(m, d)[0], wd.contact.collidable_point_positions(m, d)],
    "step": lambda m, d: _steps(m, d, 5),
}  # fmt: skip


def _steps(model, data, count):
    tau = np.linspace(-3.0, 3.0, model.dofs())
    for _ in range(count):
        data = wd.model.step(model, data, joint_force_references=tau)
    return data


@pytest.mark.parametrize("family", list(FAMILIES))
def test_one_model_several_threads_equal_serial_calls(family):
    """One model, a Data per thread: each thread's results equal the serial results of its data, every time."""
    model = _legs()
    call = FAMILIES[family]
    datas = [_data(model, seed=i) for i in range(THREADS)]
    expected = [_host(call(model, d)) for d in datas]

    def work(i):
        return [_host(call(model, datas[i])) for _ in range(REPEATS)]

    for i, repeats in enumerate(_in_threads(work)):
        for r, got in enumerate(repeats):
            _assert_same(got, expected[i], f"{family}: thread {i}, call {r}")


def test_several_models_and_batch_sizes_in_threads():
    """Threads on different models (copies with their own masses) and batch sizes, stepping and computing ABA."""
    base = _legs()
    models = []
    for i in range(THREADS):
        m = base.copy()
        m.set_link_parameters(mass=m.link_mass.numpy() * (1.0 + 0.1 * i))
        models.append(m)
    datas = [_data(models[i], seed=i, N=1 + i) for i in range(THREADS)]

    def call(i):
        d = _steps(models[i], datas[i], 3)
        return [_host(d), _host(wd.model.forward_dynamics_aba(models[i], d))]

    expected = [call(i) for i in range(THREADS)]
    for i, got in enumerate(_in_threads(lambda i: [call(i) for _ in range(3)])):
        for r, g in enumerate(got):
            _assert_same(g, expected[i], f"model {i}, call {r}")


@pytest.mark.parametrize("use_graph", [True, "auto", False], ids=["graph", "auto", "recorded"])
def test_rollouts_and_steppers_in_threads(use_graph):
    """A Rollout and a Stepper per thread (same model), each capturing its graphs (or recording its launches)
    inside the threads: each thread's states equal a serial run's. A capture would take the other threads'
    work (Warp's CUDA stream is shared; its CPU capture records every thread's operations), so "auto" replays
    recorded launches while other threads work on the device, and use_graph=True is refused with a
    RuntimeError that names them."""
    model = _legs()
    datas = [_data(model, seed=10 + i, N=2) for i in range(THREADS)]
    tau = np.linspace(-2.0, 2.0, model.dofs())

    def call(i):
        rollout = wd.simulation.Rollout(model, steps=20, record=("joint_positions",), use_graph=use_graph)
        final, records = rollout.run(datas[i], joint_force_references=tau)
        stepper = wd.simulation.Stepper(model, datas[i], substeps=2, use_graph=use_graph)
        stepper.joint_force_references.assign(np.tile(tau, (2, 1)))
        for _ in range(5):
            stepper.step()
        return [_host(final), _host(records["joint_positions"]), _host(stepper.data)]

    expected = [call(i) for i in range(THREADS)]
    if use_graph is True:
        with pytest.raises(RuntimeError, match="use_graph=True would capture a graph on .* while threads"):
            _in_threads(call)
        return
    for i, got in enumerate(_in_threads(call)):
        _assert_same(got, expected[i], f"thread {i}")


def test_capture_from_a_device_left_on_the_null_stream():
    """Warp 1.19's array.numpy() swaps the device's process-wide current stream to the legacy null stream and
    back; threads calling it at once can leave the device there, where nothing can be captured ("unknown
    stream"). A Rollout then captures on a Warp stream of its own and gives the recorded launches' states."""
    device = wp.get_device(robots.TEST_DEVICE)
    if not device.is_cuda:
        pytest.skip("CUDA streams only")
    model = _legs()
    data = _data(model, seed=3, N=2)
    tau = np.linspace(-2.0, 2.0, model.dofs())
    expected = _host(wd.simulation.Rollout(model, steps=10, use_graph=False).run(data, joint_force_references=tau)[0])
    original = device.stream
    try:
        device.set_stream(device.null_stream)
        final, _ = wd.simulation.Rollout(model, steps=10, use_graph=True).run(data, joint_force_references=tau)
        assert device.stream.cuda_stream, "the device was left on the null stream"
        _assert_same(_host(final), expected, "graph rollout after the null stream")
    finally:
        device.set_stream(original)


def _gradients(model, data, i, between=lambda: None):
    """Two steps and ABA under a tape; the loss (sum of squared joint accelerations) and d loss / d tau.
    between(): called under the tape after the first step."""
    tau = wp.array(np.full((data.batch_size, model.dofs()), 0.5 + i), dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        stepped = wd.model.step(model, data, joint_force_references=tau)
        between()
        stepped = wd.model.step(model, stepped, joint_force_references=tau)
        _, acc = wd.model.forward_dynamics_aba(model, stepped, joint_forces=tau)
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        wp.launch(_sum_squares, dim=acc.shape, inputs=[acc], outputs=[loss])
    tape.backward(loss)
    return [_host(loss), _host(tau.grad)]


def test_tapes_from_several_threads_one_at_a_time():
    """Warp has one recording tape per process: threads that take turns (a lock around the tape's life) get
    their serial gradients, while the other threads keep computing without a tape."""
    model = _legs()
    datas = [_data(model, seed=20 + i, N=2) for i in range(THREADS)]
    expected = [_gradients(model, datas[i], i) for i in range(THREADS)]
    lock = threading.Lock()

    def work(i):
        with lock:
            got = _gradients(model, datas[i], i)
        return got

    for i, got in enumerate(_in_threads(work)):
        _assert_same(got, expected[i], f"thread {i}")
        assert np.abs(got[1]).max() > 0, "no gradient"


def test_a_call_from_another_thread_while_a_tape_records_is_refused():
    """A warpdyn call from thread B while thread A's tape records would land on A's tape: a RuntimeError that
    names both threads; A's tape and gradients are unaffected, and B computes again once A's tape is closed."""
    model = _legs()
    data_a, data_b = _data(model, seed=1, N=2), _data(model, seed=2, N=2)
    expected = _gradients(model, data_a, 0)
    expected_b = _host(wd.model.forward_dynamics_aba(model, data_b))
    recording, done, errors = threading.Event(), threading.Event(), []

    def thread_b():
        recording.wait()
        try:
            wd.model.forward_dynamics_aba(model, data_b)
        except RuntimeError as error:
            errors.append(str(error))
        finally:
            done.set()

    b = threading.Thread(target=thread_b, name="thread-B")
    b.start()

    def let_b_call():
        recording.set()
        done.wait(timeout=60)

    got = _gradients(model, data_a, 0, between=let_b_call)
    b.join()
    assert len(errors) == 1 and "thread-B" in errors[0] and threading.current_thread().name in errors[0], errors
    _assert_same(got, expected, "the tape's thread")
    after = _in_threads(lambda i: _host(wd.model.forward_dynamics_aba(model, data_b)), count=2)
    for got in after:
        _assert_same(got, expected_b, "thread B after the tape")


@wp.kernel
def _sum_squares(x: wp.array2d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    i, j = wp.tid()
    wp.atomic_add(loss, 0, x[i, j] * x[i, j])


FIRST_COMPILE = """
import sys, threading
import numpy as np
import warp as wp
wp.config.kernel_cache_dir = sys.argv[1]
import warpdyn as wd
model = wd.model.Model.build_from_model_description(
    '<robot name="r"><link name="a"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/>'
    '</inertial></link><link name="b"><inertial><mass value="2"/><inertia ixx="1" iyy="2" izz="3" ixy="0" ixz="0" iyz="0"/>'
    '</inertial></link><joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 1 0"/>'
    '<origin xyz="0 0 0.5"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>', device=sys.argv[2])
data = wd.data.Data.build(model, joint_positions=[0.3], joint_velocities=[0.1])
out, errors = [None] * 4, []
barrier = threading.Barrier(4)
def run(i):
    try:
        barrier.wait()
        out[i] = wd.model.free_floating_mass_matrix(model, data).numpy()
    except BaseException as error:
        errors.append(repr(error))
threads = [threading.Thread(target=run, args=(i,)) for i in range(4)]
[t.start() for t in threads]
[t.join() for t in threads]
assert not errors, errors
assert all(np.array_equal(o, out[0]) for o in out), out
print("same", out[0][6, 6])
"""


def test_first_compilation_from_several_threads(tmp_path):
    """Four threads launch a kernel that is not compiled yet (an empty kernel cache): one compiles, the others
    wait for it; all get the same mass matrix (the process neither crashes nor raises)."""
    proc = subprocess.run(
        [sys.executable, "-c", FIRST_COMPILE, str(tmp_path), robots.TEST_DEVICE],
        capture_output=True, text=True, env=dict(os.environ, WARPDYN_VERBOSE="0"), cwd=tmp_path, timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert "same" in proc.stdout


def test_kernel_factories_make_each_result_once_one_thread_at_a_time():
    """kernels/factory.py: eight threads asking a factory for the same result at once get one object, made once (and
    the same object for the same arguments passed another way);
    two results are never made at the same time (Warp parses sources with ast when it makes kernels, which
    CPython 3.11 cannot do in two threads at once: test_first_compilation_from_several_threads failed 4 of 20
    runs on a 2-core CPU when the factories were functools.cache)."""
    calls, inside, overlaps = [], [0], []

    @factory
    def build(key, flag=False):
        inside[0] += 1
        overlaps.append(inside[0])
        time.sleep(0.01)
        calls.append((key, flag))
        inside[0] -= 1
        return object()

    def ask(i):
        return build(i % 2), build(i % 2, flag=True)

    results = _in_threads(ask, count=8)
    assert sorted(calls, key=repr) == sorted([(0, False), (1, False), (0, True), (1, True)], key=repr)
    assert max(overlaps) == 1
    for i, (plain, flagged) in enumerate(results):
        assert plain is build(i % 2) and flagged is build(i % 2, flag=True) and plain is not flagged
    # one result per argument values, however they are passed: by position, by keyword or left to the default
    assert build(0) is build(0, False) is build(key=0) is build(0, flag=False) is build(key=0, flag=False)
    assert build(1, True) is build(key=1, flag=True) and len(calls) == 4
