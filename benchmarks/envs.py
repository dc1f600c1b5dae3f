"""Throughput of `warpdyn.envs.LeggedEnv.step`: policy env-steps/s with observations, rewards and resets.

    python benchmarks/envs.py [--device cuda:0] [--sizes 1024,4096,16384] [--dtype float32] [--steps 200]

The seed's ergoCub legs in the `stand` task of examples/rl_locomotion.py (policy at 50 Hz over 10 simulation
steps of 2 ms, pushes, mass and friction randomisation, automatic resets), actions drawn once (uniform in
[-1, 1]) and reused; the policy itself is not timed. For each N: the median time of blocks of `--steps`
env.step calls (device synchronised around each block, after a warm-up that compiles and captures), with
the whole step replayed as one CUDA graph (use_graph=True, GPU only) and run eagerly (use_graph=False:
torch ops and recorded Warp launches). Reports policy env-steps/s (N / step time) and simulation steps/s
(x decimation). Writes a Markdown table to stdout and, with --out, to that file.
"""

from __future__ import annotations

import argparse
import pathlib
import statistics
import time

import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from common import header


def stand_env(N: int, dtype, device, use_graph) -> envs.LeggedEnv:
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=dtype, device=device)
    legs = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    cfg = envs.LeggedEnvConfig(mass_scale=(0.9, 1.1), friction=(0.5, 1.0), push_velocity=0.5, push_seconds=4.0)
    return envs.LeggedEnv(legs, num_envs=N, cfg=cfg, seed=0, use_graph=use_graph)


def time_per_step(env: envs.LeggedEnv, steps: int, blocks: int) -> float:
    """Median seconds per env.step over `blocks` blocks of `steps` calls."""
    generator = torch.Generator(device=env.device).manual_seed(0)
    actions = 2 * torch.rand(env.action_space.shape, generator=generator, device=env.device) - 1
    env.reset(seed=0)
    for _ in range(3):  # compile, capture
        env.step(actions)
    times = []
    for _ in range(blocks):
        wp.synchronize_device(env.model.device)
        t = time.perf_counter()
        for _ in range(steps):
            env.step(actions)
        wp.synchronize_device(env.model.device)
        times.append((time.perf_counter() - t) / steps)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default=None)
    parser.add_argument("--sizes", default="1024,4096,16384")
    parser.add_argument("--dtype", default="float32", choices=["float32", "float64"])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--blocks", type=int, default=5)
    parser.add_argument("--out", default=None)
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    dtype = {"float32": wp.float32, "float64": wp.float64}[args.dtype]
    modes = [("graph", True), ("eager", False)] if device.is_cuda else [("eager", "auto")]
    lines = [
        f"{header(device)}; torch {torch.__version__}",
        "",
        f"LeggedEnv.step, ergoCub legs `stand` task, {args.dtype}, decimation 10 (policy 50 Hz, dt 2 ms); median of "
        f"{args.blocks} blocks of {args.steps} steps",
        "",
        "| N | mode | ms per env.step | policy env-steps/s | simulation steps/s |",
        "| ---: | --- | ---: | ---: | ---: |",
    ]
    for N in (int(x) for x in args.sizes.split(",")):
        for label, use_graph in modes:
            env = stand_env(N, dtype, device, use_graph)
            seconds = time_per_step(env, args.steps, args.blocks)
            rate = N / seconds
            lines.append(f"| {N} | {label} | {seconds * 1e3:.3f} | {rate / 1e6:.3f} M | {rate * env.decimation / 1e6:.2f} M |")
            print(lines[-1], flush=True)
            env.close()
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        pathlib.Path(args.out).write_text(text)


if __name__ == "__main__":
    main()
