"""Shared benchmark helpers: the seed's robot, timing with synchronisation, the report header and the sizes
the throughput benchmarks take."""

from __future__ import annotations

import argparse
import os
import pathlib
import platform
import statistics
import time

import numpy as np
import warp as wp

import warpdyn as wd

EXCLUDED = ("camera", "neck", "wrist", "thumb", "index", "middle", "ring", "pinkie", "torso", "elbow", "shoulder")
ERGOCUB = pathlib.Path(os.environ.get("WARPDYN_ERGOCUB", wd.assets.ergocub_urdf()))
"""The seed's URDF: the one warpdyn ships (warpdyn.assets), or the path in $WARPDYN_ERGOCUB."""


def init_warp() -> None:
    """Quiet Warp with an empty kernel cache, so that first calls measure compilation."""
    import tempfile

    wp.config.kernel_cache_dir = tempfile.mkdtemp(prefix="warpdyn-bench-cache-")
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()


def seed_model(dtype, device, path=ERGOCUB):
    """The seed's ergoCub, legs only (12 joints, 13 links)."""
    full = wd.model.Model.build_from_model_description(path, dtype=dtype, device=device)
    return wd.model.reduce(full, [j for j in full.joint_names() if not any(w in j for w in EXCLUDED)])


def median_time(fn, device, repeats: int, min_seconds: float = 0.2) -> float:
    """Median wall time [s] of fn(), synchronised, over at least `repeats` calls (more while under min_seconds)."""
    times = []
    start = time.perf_counter()
    while len(times) < repeats or (time.perf_counter() - start < min_seconds and len(times) < 1000):
        wp.synchronize_device(device)
        t = time.perf_counter()
        fn()
        wp.synchronize_device(device)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def header(device) -> str:
    import importlib.metadata as md

    versions = ", ".join(f"{p} {md.version(p)}" for p in ("warp-lang", "numpy", "mujoco") if _installed(p))
    name = wp.get_device(device).name
    return f"device: {name} ({wp.get_device(device)}); host: {platform.processor() or platform.machine()}; {versions}"


def _installed(package: str) -> bool:
    import importlib.metadata as md

    try:
        md.version(package)
        return True
    except md.PackageNotFoundError:
        return False


def sizes(max_envs: int) -> list[int]:
    return [n for n in (1, 16, 256, 4096, 16384, 65536) if n <= max_envs]


def add_size_arguments(parser, max_envs: int | None = 65536, max_envs_help: str | None = None) -> None:
    """The throughput benchmarks' --device, --max-envs, --sizes (read by chosen_sizes) and --dtypes."""
    parser.add_argument("--device", default=None)
    parser.add_argument("--max-envs", type=int, default=max_envs, help=max_envs_help)
    parser.add_argument("--sizes", default=None, help="comma-separated N (default: 1, 16, 256, ... up to --max-envs)")
    parser.add_argument("--dtypes", default="float32,float64")


def chosen_sizes(args, max_envs: int) -> list[int]:
    """The N of --sizes, else sizes(max_envs)."""
    return [int(n) for n in args.sizes.split(",")] if args.sizes else sizes(max_envs)


def side_by_side_setup(repeats: int) -> tuple:
    """(args, device, Ns) of a side-by-side cost script (scene_cost.py, constraint_cost.py): --device, --sizes
    (default 1, 4096, 32768 on a GPU, 1, 256, 4096 on the CPU), --dtypes, --repeats (default `repeats`); Warp
    initialised quietly on that device."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--sizes", default=None, help="comma-separated N (default: 1,4096,32768 on a GPU, 1,256,4096 on the CPU)")
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--repeats", type=int, default=repeats)
    args = parser.parse_args()
    wp.config.quiet = True
    wp.init()
    device = wp.get_device(args.device)
    Ns = [int(n) for n in args.sizes.split(",")] if args.sizes else ([1, 4096, 32768] if device.is_cuda else [1, 256, 4096])
    return args, device, Ns


np_dtype = {"float32": np.float32, "float64": np.float64}


def write_reference(path: str, tolerances: dict, inputs, outputs, labels=("state", "result")) -> None:
    """Save, per dtype in `tolerances`, the CPU's inputs(model) and outputs(model, inputs) for a later GPU
    run to compare against (the GPU-consistency scripts' --write-reference)."""
    saved = {}
    for dtype_name in tolerances:
        model = seed_model(np_dtype[dtype_name], "cpu")
        given = inputs(model)
        saved.update({f"{dtype_name}/{labels[0]}/{k}": v for k, v in given.items()})
        saved.update({f"{dtype_name}/{labels[1]}/{k}": v for k, v in outputs(model, given).items()})
    np.savez_compressed(path, **saved)
    print(f"wrote {len(saved)} arrays to {path}")
