"""Kernel launches: every warpdyn launch goes through `launch` (a recorded launch is made by it), singly, as
a list of `Launch`es (`run`), or replayed from a recording (`Recorded`); graphs are captured by `capture`,
when `graphs_allowed` (not while another thread works on that kind of device: a capture would take its work).

The first launch of a kernel module on a device compiles it, or loads it from Warp's kernel cache
(`wp.config.kernel_cache_dir`). That first load runs under one process-wide lock, since Warp's module
loading is not safe from several threads at once; once a compilation has taken longer than
`NOTICE_AFTER` seconds, warpdyn says on stderr, once per process, that it is compiling and that the
result is cached.
"""

from __future__ import annotations

import contextlib
import sys
import threading
from typing import NamedTuple

import warp as wp

from ..arrays import capture_lock, note_thread, other_threads
from .tape import check_thread

NOTICE_AFTER = 1.0
"""Seconds a first load may take before warpdyn says that it is compiling."""

_loaded: set = set()
_lock = threading.RLock()
_noticed = threading.Event()


def _notice(device) -> None:
    if _noticed.is_set():
        return
    _noticed.set()
    print(
        f"warpdyn: compiling Warp kernels for device '{device}' (each algorithm once per device and dtype; a "
        f"model's first step takes seconds to a minute); they are cached in {wp.config.kernel_cache_dir}, so later "
        "runs load them in about a second.",
        file=sys.stderr,
        flush=True,
    )


def ensure_loaded(kernel, device, block_dim: int | None = None) -> None:
    """Compile or load `kernel`'s module for `device` (and CUDA block size) before a first launch."""
    key = (kernel.module, str(device), block_dim)
    if key in _loaded:
        return
    with _lock:
        if key in _loaded:
            return
        timer = threading.Timer(NOTICE_AFTER, _notice, args=(device,))
        timer.daemon = True
        timer.start()
        try:
            wp.load_module(kernel.module, device=device, block_dim=block_dim)
        finally:
            timer.cancel()
        _loaded.add(key)


def launch(kernel, dim, inputs=(), outputs=(), device=None, block_dim: int | None = None, **options):
    """wp.launch (its other options passed on), the kernel's module loaded first (see the module docstring)."""
    device = wp.get_device(device)
    note_thread(device)
    ensure_loaded(kernel, device, block_dim if device.is_cuda else None)
    check_thread()
    return wp.launch(kernel, dim=dim, inputs=inputs, outputs=outputs, device=device, block_dim=block_dim, **options)


class Launch(NamedTuple):
    """One kernel launch: `kernel` over `dim` with `inputs` then `outputs` (and CUDA's `block_dim`)."""

    kernel: object
    dim: object
    inputs: list
    outputs: list
    block_dim: int | None = None


def run(launches, device) -> None:
    """Launch each of `launches` (Launch tuples) in order, through `launch` (a tape records them)."""
    for item in launches:
        launch(item.kernel, item.dim, item.inputs, item.outputs, device=device, block_dim=item.block_dim)


class Recorded:
    """A list of launches recorded once (wp.launch(record_cmd=True)) and replayed: a later `run` with the same
    kernels re-packs only the arguments that are not the ones bound last time (new state arrays, new
    outputs), not the tens of arguments of a step. Outside a tape only: a tape records wp.launch calls.

    Not thread-safe: one per thread (see `per_thread`).
    """

    def __init__(self):
        self._commands: list | None = None

    def run(self, launches, device) -> None:
        commands = self._commands
        if commands is None or len(commands) != len(launches) or any(c[0].kernel is not l.kernel for c, l in zip(commands, launches)):
            commands = self._commands = []
            for item in launches:
                args = [*item.inputs, *item.outputs]
                command = launch(item.kernel, item.dim, args, device=device, block_dim=item.block_dim, record_cmd=True)
                commands.append((command, args, item.dim))
        else:
            for (command, bound, dim), item in zip(commands, launches):
                if dim != item.dim:
                    command.set_dim(item.dim)
                for i, a in enumerate((*item.inputs, *item.outputs)):
                    b = bound[i]
                    if a is b or (type(a) in (int, float) and type(b) is type(a) and a == b):
                        continue
                    command.set_param_at_index(i, a)
                    bound[i] = a
        for command, _, _ in commands:
            command.launch()


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


@contextlib.contextmanager
def capture(device):
    """wp.ScopedCapture on `device` under `capture_lock` (one capture at a time, and no thread's first
    allocation or launch meanwhile); yields the capture (its .graph after the block)."""
    with capture_lock, wp.ScopedCapture(device=device, force_module_load=False) as captured:
        yield captured


def per_thread(model, key, build):
    """`model.cached` for what one thread may use at a time (workspaces, recorded launches): one value per
    (key, calling thread, CUDA stream), so that calls from several threads never share them."""
    stream = model.device.stream if model.device.is_cuda else None
    return model.cached((key, threading.get_ident(), stream), build)
