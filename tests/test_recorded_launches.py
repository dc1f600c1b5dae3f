"""Recorded launches (warpdyn.engine.launch.Recorded): replayed with re-bound arguments, they compute what a
fresh wp.launch computes. On the CPU a replay runs from an argument struct kept between runs
(warpdyn.engine.warp_private.CpuLaunch), so the tests cover what that struct must follow: a re-bound array or
number, a struct's field assigned in place after recording (Warp packs a struct as its live ctype), a new launch
size, and a CPU graph capture, which must record the launch."""

import numpy as np
import pytest
import warp as wp

import robots
from warpdyn.engine import warp_private
from warpdyn.engine.launch import Launch, Recorded


@wp.struct
class Scale:
    factor: wp.float64
    offset: wp.array(dtype=wp.float64)


@wp.kernel
def _affine(p: Scale, x: wp.array(dtype=wp.float64), power: int, y: wp.array(dtype=wp.float64)):
    i = wp.tid()
    y[i] = p.factor * wp.pow(x[i], wp.float64(power)) + p.offset[0]


def _scale(factor: float, offset: float, device="cpu") -> Scale:
    p = Scale()
    p.factor = wp.float64(factor)
    p.offset = wp.array([offset], dtype=wp.float64, device=device)
    return p


CPU_BACKEND = pytest.mark.skipif(not wp.is_cpu_available(), reason="this Warp build has no CPU backend (LLVM)")


def _expected(factor, x, power, offset):
    return factor * x**power + offset


@CPU_BACKEND
def test_a_recorded_cpu_launch_runs_from_a_kept_argument_struct():
    x = wp.array(np.arange(4.0), dtype=wp.float64, device="cpu")
    y = wp.zeros(4, dtype=wp.float64, device="cpu")
    command = wp.launch(_affine, dim=4, inputs=[_scale(2.0, 1.0), x, 2], outputs=[y], device="cpu", record_cmd=True)
    fast = warp_private.cpu_launch(command)
    assert isinstance(fast, warp_private.CpuLaunch), "the pinned Warp has what CpuLaunch reads"
    assert fast.kernel is command.kernel
    fast.launch()
    np.testing.assert_array_equal(y.numpy(), _expected(2.0, np.arange(4.0), 2, 1.0))


def test_replays_follow_rebound_arguments_struct_fields_and_sizes():
    """On the tests' device (the CPU's CpuLaunch, or CUDA's packed parameters)."""
    d = robots.TEST_DEVICE
    x1 = wp.array(np.arange(6.0), dtype=wp.float64, device=d)
    x2 = wp.array(np.arange(6.0) + 10.0, dtype=wp.float64, device=d)
    y1, y2 = (wp.zeros(6, dtype=wp.float64, device=d) for _ in range(2))
    p = _scale(2.0, 1.0, d)
    recorded = Recorded()
    recorded.run([Launch(_affine, 6, [p, x1, 2], [y1])], d)
    np.testing.assert_array_equal(y1.numpy(), _expected(2.0, np.arange(6.0), 2, 1.0))
    assert isinstance(recorded._commands[0][0], warp_private.CpuLaunch) == wp.get_device(d).is_cpu
    # another input array, another number, another output
    recorded.run([Launch(_affine, 6, [p, x2, 3], [y2])], d)
    np.testing.assert_array_equal(y2.numpy(), _expected(2.0, np.arange(6.0) + 10.0, 3, 1.0))
    # the struct bound at recording, a field assigned in place: the next replay reads the new values
    p.factor = wp.float64(-0.5)
    p.offset = wp.array([7.0], dtype=wp.float64, device=d)
    same = [Launch(_affine, 6, [p, x2, 3], [y2])]
    recorded.run(same, d)
    np.testing.assert_array_equal(y2.numpy(), _expected(-0.5, np.arange(6.0) + 10.0, 3, 7.0))
    # the same list again (replayed without comparing its arguments), after the struct changed again
    p.factor = wp.float64(4.0)
    recorded.run(same, d)
    np.testing.assert_array_equal(y2.numpy(), _expected(4.0, np.arange(6.0) + 10.0, 3, 7.0))
    # a smaller launch: only its first entries are written
    y3 = wp.full(6, -1.0, dtype=wp.float64, device=d)
    recorded.run([Launch(_affine, 2, [p, x1, 1], [y3])], d)
    np.testing.assert_array_equal(y3.numpy(), [7.0, 11.0, -1.0, -1.0, -1.0, -1.0])


@CPU_BACKEND
def test_a_cpu_graph_capture_records_a_replayed_launch():
    x = wp.array(np.arange(3.0), dtype=wp.float64, device="cpu")
    y = wp.zeros(3, dtype=wp.float64, device="cpu")
    p = _scale(1.0, 0.0)
    recorded = Recorded()
    recorded.run([Launch(_affine, 3, [p, x, 1], [y])], "cpu")
    with wp.ScopedCapture(device="cpu", force_module_load=False) as capture:
        recorded.run([Launch(_affine, 3, [p, x, 2], [y])], "cpu")
    y.zero_()
    wp.capture_launch(capture.graph)
    np.testing.assert_array_equal(y.numpy(), [0.0, 1.0, 4.0])
    x.assign(np.array([3.0, 2.0, 1.0]))
    wp.capture_launch(capture.graph)
    np.testing.assert_array_equal(y.numpy(), [9.0, 4.0, 1.0])


def _adjoint_scale(device) -> Scale:
    p = Scale()
    p.offset = wp.zeros(1, dtype=wp.float64, device=device)
    return p


def test_launches_that_warp_runs_otherwise_are_left_to_it():
    """An adjoint launch on the CPU (where the tests run on the CPU), a CUDA launch (where they run on a GPU)."""
    device = robots.TEST_DEVICE
    x = wp.array(np.arange(3.0), dtype=wp.float64, device=device, requires_grad=True)
    y = wp.zeros(3, dtype=wp.float64, device=device, requires_grad=True)
    p = _scale(1.0, 0.0, device)
    if wp.get_device(device).is_cpu:
        command = wp.launch(
            _affine, dim=3, inputs=[p, x, 2], outputs=[y], device=device, record_cmd=True, adjoint=True,
            adj_inputs=[_adjoint_scale(device), x.grad, 0], adj_outputs=[y.grad],
        )  # fmt: skip
    else:
        command = wp.launch(_affine, dim=3, inputs=[p, x, 2], outputs=[y], device=device, record_cmd=True)
    assert warp_private.cpu_launch(command) is None
