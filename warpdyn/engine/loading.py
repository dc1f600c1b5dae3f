"""Loading kernel modules: the first launch of a kernel module on a device compiles it, or loads it from
Warp's kernel cache (`wp.config.kernel_cache_dir`). Loads run under one process-wide lock, since Warp's
module loading is not safe from several calling threads at once (one `force_load` may compile several
modules on threads of its own: `preload`). That lock is the kernel factories' (kernels/factory.py), under
which the forward-only twins are made too, since making a Warp kernel parses its source with `ast`. Once a
compilation has taken longer than `NOTICE_AFTER` seconds, warpdyn says on stderr, once per process, that it
is compiling and that the result is cached.
"""

from __future__ import annotations

import os
import sys
import threading

import warp as wp

from .. import config
from ..kernels.factory import BUILD_LOCK
from . import warp_private

NOTICE_AFTER = 1.0
"""Seconds a first load may take before warpdyn says that it is compiling."""

_loaded: set = set()
_lock = BUILD_LOCK
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


def block_size(block_dim: int | None, device) -> int | None:
    """The CUDA threads per block of a launch asking for `block_dim` (None: warpdyn.config.cuda_block_dim); on the
    CPU None (Warp's 1: a CPU module compiled for another block size would be compiled twice) but for blocks of
    threads that Warp runs there (with wp.config.enable_cpu_blocks: the fused step's lanes)."""
    if not device.is_cuda:
        return block_dim if block_dim is not None and block_dim > 1 and wp.config.enable_cpu_blocks else None
    return config.cuda_block_dim if block_dim is None else block_dim


_twins: dict = {}
"""{kernel: its forward-only twin} (see `for_launch`)."""


def for_launch(kernel, adjoint: bool = False):
    """The kernel a launch of `kernel` runs: `kernel` itself for its adjoint or while a wp.Tape records, else its
    forward-only twin: the same code without the backward pass Warp generates, with the kernel's own options
    (register cap, launch bounds), in a module of its own, which compiles faster (benchmarks/cold_start.py). A
    launch that no tape records never runs a backward pass; the forward code is the same, and so are the
    numbers. Differentiating compiles the full kernels too."""
    if adjoint or warp_private.recording_tape() is not None:
        return kernel
    if wp.get_module_options(warp_private.kernel_module(kernel)).get("enable_backward") is False:  # forward-only already: its own twin
        return kernel
    twin = _twins.get(kernel)
    if twin is None:
        with _lock:
            twin = _twins.get(kernel)
            if twin is None:
                func, options = warp_private.kernel_source(kernel)
                own = {k: v for k, v in options.items() if k != "enable_backward"}  # wp.kernel's argument names
                no_backward = {"enable_backward": False}  # a module option: Warp's module hash ignores the kernel's own
                twin = _twins[kernel] = wp.kernel(func, module="unique", module_options=no_backward, **own)
    return twin


def ensure_loaded(kernel, device, block_dim: int | None = None) -> None:
    """Compile or load `kernel`'s module for `device` (and CUDA block size) before a first launch, with
    warpdyn.config.fuse_fp (fixed by the process's first load: warpdyn.config refuses a change after it)."""
    key = (warp_private.kernel_module(kernel), str(device), block_dim)
    if key not in _loaded:
        _load({key}, device, block_dim)


def preload(launches, device) -> None:
    """Compile or load at once, in parallel (Warp's force_load, a thread per module up to the CPUs this process
    may use, or wp.config.load_module_max_workers when set),
    the modules of `launches` (Launch tuples) not loaded on `device` yet: a first step needs about ten, which
    one by one took most of its cold start. Each as `ensure_loaded` loads it."""
    device = wp.get_device(device)
    wanted: dict = {}
    for item in launches:
        block_dim = block_size(item.block_dim, device)
        key = (warp_private.kernel_module(for_launch(item.kernel)), str(device), block_dim)
        if key not in _loaded:
            wanted.setdefault(block_dim, set()).add(key)
    for block_dim, keys in wanted.items():
        _load(keys, device, block_dim)


def _load(keys: set, device, block_dim: int | None) -> None:
    """Load the modules of `keys` ((module, device name, block_dim)) that are not loaded, under the lock."""
    with _lock:
        keys = [key for key in keys if key not in _loaded]
        if not keys:
            return
        with config.fuse_fp_lock:
            if config.loaded_fuse_fp is None:
                config.loaded_fuse_fp = config.fuse_fp
            fuse_fp = config.loaded_fuse_fp
        modules = [key[0] for key in keys]
        for module in modules:
            if wp.get_module_options(module)["fuse_fp"] != fuse_fp:
                wp.set_module_options({"fuse_fp": fuse_fp}, module)
        timer = threading.Timer(NOTICE_AFTER, _notice, args=(device,))
        timer.daemon = True
        timer.start()
        try:
            if len(modules) == 1:
                wp.load_module(modules[0], device=device, block_dim=block_dim)
            else:
                workers = wp.config.load_module_max_workers or len(os.sched_getaffinity(0))
                workers = min(len(modules), workers)
                wp.force_load(device=device, modules=modules, block_dim=block_dim, max_workers=workers)
        finally:
            timer.cancel()
        _loaded.update(keys)
