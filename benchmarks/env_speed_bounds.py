"""How fast the environments move under random actions: the smallest divergence bound that flags none of them.

    python benchmarks/env_speed_bounds.py [--device cpu] [--envs ergocub,go1,anymal_c,pick,reorient]
                                          [--bounds 5,8,10,12,15,20,30,50] [--num-envs 64] [--seconds 10]
                                          [--policy POLICY.pt]

For each environment (warpdyn.envs: LeggedEnv on the robots' presets with pushes of 0.5 m/s every 4 s,
PickCubeEnv, CubeReorientEnv; their defaults otherwise) and each bound B [m/s or rad/s]: set the environment's
`divergence_speed` to B, reset with seed 0 and step `--seconds` of policy steps with actions drawn uniformly in
[-1, 1] (one torch generator seeded 0, the same draws for every B), and count the flags: each time an environment is
flagged (info["invalid"]: a base or joint velocity component beyond B at a simulation step) it is reset and goes on,
to be flagged again, so the count may exceed the number of environments.
The smallest B with no flag bounds every velocity component the run reached at its simulation steps. Random actions
jump each target by its whole range every policy step, yet a trained policy can move faster (the Go1's walking policy
needed 20 where random actions needed 15: results/env_speed_bounds_policies_cpu.md). Prints a Markdown table; the
environments' default (warpdyn.envs.vector_env.DIVERGENCE_SPEED) is chosen from it. `go1` needs example-robot-data.
--policy (one environment in --envs): the actions are instead a trained policy's deterministic ones (a checkpoint of
the example that trains that environment, read as examples/rl_locomotion.py's load_policy reads it; needs rsl-rl).
The last column: the mean absolute action given at the last bound (random actions: about 0.5; before the
environment's clip to [-1, 1]).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import pathlib
import sys

import torch
import warp as wp

import warpdyn.envs as envs
from common import header

LEGGED = {"ergocub": envs.robots.ergocub_legs, "go1": envs.robots.go1, "anymal_c": envs.robots.anymal_c}


def make_env(name: str, N: int, device, bound: float):
    """The environment `name` with divergence_speed = bound."""
    if name == "pick":
        return envs.PickCubeEnv(N, envs.manipulation.PickCubeConfig(divergence_speed=bound), device=device, seed=0)
    if name == "reorient":
        return envs.CubeReorientEnv(N, envs.reorient.CubeReorientConfig(divergence_speed=bound), device=device, seed=0)
    preset = LEGGED[name]()
    model = preset.model(device=device)
    cfg = preset.config(model, push_velocity=0.5, push_seconds=4.0)
    return envs.LeggedEnv(model, num_envs=N, cfg=dataclasses.replace(cfg, divergence_speed=bound), seed=0)


class FlagCounter:
    """An environment whose steps count its flags (info["invalid"]) in `flagged` and sum the absolute actions it is
    given (before its clip) in `action_sum`; everything else is the environment's (so that rsl-rl's view of it, which
    drops info["invalid"], can step it)."""

    def __init__(self, env):
        self.env = env
        self.flagged = torch.zeros((), dtype=torch.long, device=env.device)
        self.action_sum = torch.zeros((), dtype=torch.float64, device=env.device)

    def __getattr__(self, name: str):
        return getattr(self.env, name)

    def step(self, actions: torch.Tensor):
        self.action_sum += actions.abs().sum().to(torch.float64)
        out = self.env.step(actions)
        self.flagged += out[-1]["invalid"].sum()
        return out


def trained_policy(env, policy_path: pathlib.Path):
    """(rsl-rl's view of `env`, the deterministic policy of a checkpoint of the example that trains it); a
    checkpoint of another environment is a SystemExit naming it."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    from rl_locomotion import load_policy  # rsl-rl: needed with --policy only

    try:
        return load_policy(env, policy_path)
    except RuntimeError as error:  # the networks' shapes are another environment's
        detail = next((line.strip() for line in str(error).splitlines() if "size mismatch" in line), str(error).splitlines()[0])
        raise SystemExit(f"--policy {policy_path}: not a policy of this environment ({detail})") from None


def count_flags(name: str, N: int, device, bound: float, seconds: float, policy_path: pathlib.Path | None = None) -> tuple[int, int, float]:
    """(flags over the run, policy steps, the mean absolute action given) under uniformly random actions, or the
    deterministic actions of the policy at `policy_path`."""
    env = FlagCounter(make_env(name, N, device, bound))
    steps = math.ceil(seconds / env.cfg.policy_dt)
    env.reset(seed=0)
    if policy_path is not None:
        vec, policy = trained_policy(env, policy_path)
        obs = vec.get_observations()
        with torch.inference_mode():
            for _ in range(steps):
                obs = vec.step(policy(obs))[0]
    else:
        generator = torch.Generator(device=env.device).manual_seed(0)
        for _ in range(steps):
            env.step(2.0 * torch.rand(env.action_space.shape, generator=generator, device=env.device) - 1.0)
    return int(env.flagged), steps, float(env.action_sum) / (steps * env.action_space.shape[0] * env.action_space.shape[1])


def main(argv=None) -> list:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--envs", default="ergocub,go1,anymal_c,pick,reorient")
    parser.add_argument("--bounds", default="5,8,10,12,15,20,30,50")
    parser.add_argument("--num-envs", type=int, default=64)
    parser.add_argument("--seconds", type=float, default=10.0)
    parser.add_argument("--policy", type=pathlib.Path, default=None, help="a trained policy's checkpoint (one environment in --envs)")
    args = parser.parse_args(argv)
    wp.config.quiet = True
    device = wp.get_device(args.device)
    names = args.envs.split(",")
    unknown = sorted(set(names) - {*LEGGED, "pick", "reorient"})
    if unknown:
        parser.error(f"--envs names {unknown}; the environments: {', '.join([*LEGGED, 'pick', 'reorient'])}")
    if args.policy is not None and len(names) != 1:
        parser.error(f"--policy needs one environment in --envs (got {len(names)})")
    if args.policy is not None and not args.policy.is_file():
        parser.error(f"--policy {args.policy}: no such file")
    try:
        bounds = [float(b) for b in args.bounds.split(",")]
    except ValueError:
        parser.error(f"--bounds must be comma-separated numbers [m/s or rad/s], got {args.bounds!r}")
    rows = []
    print(header(device))
    actions = "uniformly random actions" if args.policy is None else f"the deterministic actions of {args.policy}"
    print(f"\n{args.num_envs} environments, {args.seconds:g} s of {actions} each; flags (an environment flagged, reset and flagged again counts each time) per bound B [m/s or rad/s]\n")
    print("| environment | policy steps | " + " | ".join(f"B = {b:g}" for b in bounds) + f" | smallest B with none | mean abs action at B = {bounds[-1]:g} |")
    print("| --- | ---: | " + " | ".join("---:" for _ in bounds) + " | ---: | ---: |")
    for name in names:
        counts = [count_flags(name, args.num_envs, device, b, args.seconds, args.policy) for b in bounds]
        clear = [b for b, (count, _, _) in zip(bounds, counts) if count == 0]
        first = f"{min(clear):g}" if clear else f"> {bounds[-1]:g}"
        rows.append((name, counts, first))
        print(f"| {name} | {counts[0][1]} | " + " | ".join(str(c) for c, _, _ in counts) + f" | {first} | {counts[-1][2]:.3f} |", flush=True)
    return rows


if __name__ == "__main__":
    main()
