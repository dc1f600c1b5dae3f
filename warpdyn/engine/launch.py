"""Kernel launches: every warpdyn launch goes through `launch` (a recorded launch is made by it), singly, as
a list of `Launch`es (`run`), or replayed from a recording (`Recorded`); graphs are captured by `capture`,
when `graphs_allowed` (not while another thread works on that kind of device: a capture would take its work).
Work run again and again is a `Program`, the one mechanism that replays work (`wd.model.step`'s pooled steps,
a Stepper's substeps, a Rollout's chunks, a caller's step around a Stepper: `Stepper.step_program`): eager runs
(recorded launches) first, then a captured graph (Warp's, or the caller's kind: a torch CUDA graph).

A kernel's module is loaded first (warpdyn.engine.loading). Under a recording tape, parameters marked
for deterministic gradients are handed to the launch as one row per environment (warpdyn.engine.determinism).
"""

from __future__ import annotations

import contextlib
import functools
import operator
import threading
from typing import NamedTuple

import warp as wp

from ..arrays import capture_lock, note_thread, other_threads
from ..kernels.rollout import int_kernels as rollout_int_kernels
from ..kernels.rollout import kernels as rollout_kernels
from . import determinism, warp_private
from .loading import block_size, ensure_loaded, for_launch, preload
from .tape import check_thread, suspended


def launch(kernel, dim, inputs=(), outputs=(), device=None, block_dim: int | None = None, **options):
    """wp.launch (its other options passed on) with `block_size(block_dim)` threads per block, the kernel's module
    loaded first (see the module docstring)."""
    device = wp.get_device(device)
    note_thread(device)
    block_dim = block_size(block_dim, device)
    kernel = for_launch(kernel, bool(options.get("adjoint")))
    ensure_loaded(kernel, device, block_dim)
    check_thread()
    if determinism.any_marked() and options.get("record_tape", True) and not (options.get("adjoint") or options.get("record_cmd")):
        inputs = determinism.rows_per_environment(inputs, dim, device)
    return wp.launch(kernel, dim=dim, inputs=inputs, outputs=outputs, device=device, block_dim=block_dim, **options)


class Launch(NamedTuple):
    """One kernel launch: `kernel` over `dim` with `inputs` then `outputs` (and CUDA's `block_dim`). `adjoint`:
    None (a tape records the launch, Warp differentiates it) or a function of no arguments that adds the launch's
    adjoint into its inputs' gradients from its outputs' (a kernel whose adjoint is written by hand: under a tape
    `run` launches it unrecorded and registers that function; a no-op where nothing it reads requires gradients).
    `after_adjoint`: None or a function of no arguments that a tape's backward pass calls once this launch's adjoint
    has run (Warp's adjoint replays the kernel's forward, rewriting its outputs: where a later launch replaced them in
    place, the rigid impact's velocities, the function puts its values back). Both only under a tape: a recorded
    replay (`Recorded`) or a captured graph launches the kernels alone."""

    kernel: object
    dim: object
    inputs: list
    outputs: list
    block_dim: int | None = None
    adjoint: object = None
    after_adjoint: object = None


def copy_launch(scalar, src: wp.array, dst: wp.array):
    """The launch copying src into dst (same logical shape; src may broadcast with zero strides)."""
    if dst.size == 0:
        return None
    if dst.dtype == wp.int32:
        kernels = rollout_int_kernels()
        return Launch(kernels.copy_flags if dst.ndim == 1 else kernels.copy_flags_2d, dst.shape, [src], [dst])
    return Launch(rollout_kernels(scalar).copy[dst.ndim], dst.shape, [src], [dst])


def no_adjoint() -> None:
    """The `Launch.adjoint` of a launch none of whose inputs requires gradients: a tape records it, nothing flows."""


def run(launches, device) -> None:
    """Launch each of `launches` (Launch tuples) in order, through `launch` (a tape records them, or, for a
    Launch with a hand-written `adjoint`, that adjoint; and a Launch's `after_adjoint` before it)."""
    recording = warp_private.recording_tape()
    for item in launches:
        if item.after_adjoint is not None and recording is not None:
            recording.record_func(backward=item.after_adjoint, arrays=[])  # recorded first: its backward runs after the launch's
        if item.adjoint is not None and recording is not None:
            with suspended():
                launch(item.kernel, item.dim, item.inputs, item.outputs, device=device, block_dim=item.block_dim)
            arrays = [a for a in (*item.inputs, *item.outputs) if isinstance(a, wp.array) and a.grad is not None]
            recording.record_func(backward=item.adjoint, arrays=arrays)
            continue
        launch(item.kernel, item.dim, item.inputs, item.outputs, device=device, block_dim=item.block_dim)


_KERNEL = operator.attrgetter("kernel")
_KERNEL_OF_COMMAND = operator.itemgetter(3)


class Recorded:
    """A list of launches recorded once (wp.launch(record_cmd=True)) and replayed: a later `run` with the same
    kernels re-packs only the arguments that are not the ones bound last time (new state arrays, new
    outputs), not the tens of arguments of a step. On the CPU a command runs from an argument struct kept
    between runs (warp_private.CpuLaunch) where Warp would build one per run. Outside a tape only: a tape
    records wp.launch calls.

    Not thread-safe: one per thread (see `per_thread`).
    """

    def __init__(self):
        self._commands: list | None = None  # [command, its bound arguments, its dim, the kernel given] per launch
        self._launches = None

    def run(self, launches, device) -> None:
        """Launch `launches`; a list given again (the same object, unchanged: a caller's cached list) is
        replayed without comparing its arguments."""
        commands = self._commands
        if launches is self._launches:
            for entry in commands:
                entry[0].launch()
            return
        self._launches = None
        if commands is None or len(commands) != len(launches) or not all(map(operator.is_, map(_KERNEL_OF_COMMAND, commands), map(_KERNEL, launches))):
            commands = self._commands = []
            preload(launches, device)
            for item in launches:
                args = [*item.inputs, *item.outputs]
                command = launch(item.kernel, item.dim, args, device=device, block_dim=item.block_dim, record_cmd=True)
                commands.append([warp_private.cpu_launch(command) or command, args, item.dim, item.kernel])
        else:
            for entry, item in zip(commands, launches):
                command, bound = entry[0], entry[1]
                if entry[2] != item.dim:
                    command.set_dim(item.dim)
                    entry[2] = item.dim
                given = (*item.inputs, *item.outputs)
                if all(map(operator.is_, given, bound)):  # the arguments it holds (the usual case)
                    continue
                for i, a in enumerate(given):
                    b = bound[i]
                    if a is b or (type(a) in (int, float) and type(b) is type(a) and a == b):
                        continue
                    command.set_param_at_index(i, a)
                    bound[i] = a
        self._launches = launches
        for entry in commands:
            entry[0].launch()


def graphs_allowed(device, use_graph, what: str) -> bool:
    """Whether `what` ("a Rollout", "a Stepper") captures graphs: use_graph True or "auto" (False: never). A
    capture needs every other thread that works on that kind of device to be finished (see
    warpdyn.arrays.note_thread): with one alive, "auto" replays recorded launches instead and True raises a
    RuntimeError naming them."""
    if use_graph is False:
        return False
    device = wp.get_device(device)
    others = other_threads(device)
    if not others:
        return True
    if use_graph is True:
        raise RuntimeError(
            f"{what} with use_graph=True would capture a graph on '{device}' while threads {others} also work on "
            "that kind of device: Warp's CUDA stream is shared by all threads and its CPU capture records every "
            "thread's operations, so their work would join or break the capture. Use use_graph='auto' (recorded "
            "launches while other threads work there) or False."
        )
    return False


_own_streams: dict = {}
"""{device alias: a Warp stream made by `capture`} for devices found on the null stream."""


@contextlib.contextmanager
def capture(device):
    """wp.ScopedCapture on `device` under `capture_lock` (one capture at a time, and no thread's first
    allocation or launch meanwhile); yields the capture (its .graph after the block).

    A CUDA device whose current stream is the legacy null stream, which cannot be captured, gets a Warp
    stream of its own first (kept as its current stream). Warp 1.19 leaves a device there after threads call
    `array.numpy()` at once: numpy() swaps the device's process-wide current stream to the null stream and
    back, and those swaps interleave."""
    device = wp.get_device(device)
    with capture_lock:
        if device.is_cuda and not device.stream.cuda_stream:
            if device.alias not in _own_streams:
                _own_streams[device.alias] = wp.Stream(device)
            device.set_stream(_own_streams[device.alias])
        with wp.ScopedCapture(device=device, force_module_load=False) as captured:
            yield captured


def capture_graph(launches, device):
    """A graph of `launches` (Launch tuples) to replay with `wp.capture_launch`: Warp's CPU graph on the CPU, a
    CUDA graph on a GPU, captured by `capture` (the caller checks that no other thread works on the device).
    Their modules are loaded first."""
    device = wp.get_device(device)
    preload(launches, device)
    with capture(device) as captured:
        run(launches, device)
    return captured.graph


class Program:
    """Work run again and again, eagerly at first and then as a graph: its first `capture_after` runs, and every
    run while a capture is not allowed (`graphs_allowed(device, use_graph, what)`), run it eagerly; the next
    captures it as a graph (under `capture_lock`), which that run and the later ones replay. The work is
    - a list of `Launch`es on fixed arrays (`capture` None): an eager run replays the commands recorded at the
      first (`Recorded`), the graph is Warp's (`capture_graph`: Warp's CPU graph on the CPU, a CUDA graph on a
      GPU); a run returns None;
    - a Python callable (torch ops around warpdyn's launches): an eager run calls it; `capture(work)` captures
      one call of it, without running it, in the caller's kind of graph (torch.cuda.graph, whose memory pool
      holds its ops' allocations), and returns its replay, a function that launches the graph and returns
      what a run returns.
    `run()` returns what the work returned. `replay`: the captured graph's replay, or None; `eager_runs`: the
    runs not replayed. Not thread-safe: one per thread (see `per_thread`)."""

    def __init__(self, work, device, use_graph="auto", what: str = "a replay", capture_after: int = 0, capture=None):
        if callable(work) != (capture is not None):
            raise TypeError("a Program of a Python callable needs `capture` (its kind of graph); a Program of Launches takes none")
        self.work = work
        self.device = wp.get_device(device)
        self.use_graph, self.what, self.capture_after, self.capture = use_graph, what, capture_after, capture
        self.eager_runs = 0
        self.replay = None
        self._recorded = None

    def run(self):
        if self.replay is None and self.eager_runs >= self.capture_after and graphs_allowed(self.device, self.use_graph, self.what):
            self.replay = self._captured()
        if self.replay is not None:
            return self.replay()
        self.eager_runs += 1
        if self.capture is not None:
            return self.work()
        if self._recorded is None:
            self._recorded = Recorded()
        self._recorded.run(self.work, self.device)
        return None

    def _captured(self):
        """The replay of the work captured as a graph."""
        if self.capture is None:
            return functools.partial(wp.capture_launch, capture_graph(self.work, self.device))
        with capture_lock:
            return self.capture(self.work)


def per_thread(model, key, build):
    """`model.cached` for what one thread may use at a time (workspaces, recorded launches): one value per
    (key, calling thread, CUDA stream), so that calls from several threads never share them."""
    stream = model.device.stream if model.device.is_cuda else None
    return model.cached((key, threading.get_ident(), stream), build)
