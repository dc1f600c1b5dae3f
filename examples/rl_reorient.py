"""Train the LEAP hand to turn a cube in its palm to goal orientations (MuJoCo Playground's LeapCubeReorient) with
rsl-rl's PPO on warpdyn.envs.CubeReorientEnv, the contacts between the hand's and the cube's boxes acting.

    pip install -e ".[rl,viz,examples]"
    python examples/rl_reorient.py --max-minutes 30 --evaluate --out runs/reorient     # a GPU: N = 8192
    python examples/rl_reorient.py --device cpu --num-envs 16 --iterations 2            # a look on the CPU
    torchrun --standalone --nproc_per_node 2 examples/rl_reorient.py --max-minutes 30 --out runs/reorient2  # 2 GPUs, 8192 each

Environment (`warpdyn.envs.CubeReorientEnv`, its defaults: CubeReorientConfig): the shipped scene
`wd.assets.leap_hand_cube_mjcf()` at 2 ms steps (implicit contacts; the fingers' joint limits and frictionloss as MuJoCo's
constraints), the policy at 20 Hz adding 0.5 x its actions to the 16 position
targets, episodes of 50 s; each reset draws a goal orientation and takes the hand's joints and the cube's pose from a
bank of Playground's reset draws that do not interpenetrate; Playground's noisy observations for the actor and
privileged ones for the critic, its rewards (orientation, cube in the palm, a fall, hand pose, action rate,
energy) and a bonus of 100 at each success (the cube within 0.1 rad of the goal, which then turns to a new one).
Trainer: examples/rl_locomotion.py's `train` (rsl-rl-lib's PPO as GraphedPPO, its flags), with Playground's settings for this task
as defaults (REORIENT_PPO; its networks are (512, 256, 128), the trainer's (256, 128, 64); as Brax's PPO, no clipping of
the value's update: `--clipped-value-loss off`), its fixed learning rate
(`--schedule fixed`) and a Beta policy (`--action-distribution beta`, bounded like Brax's tanh-squashed Gaussian):
with rsl-rl's adaptive schedule and a Gaussian, the 25-minute H200 run's learning rate was at or near the schedule's
floor of 1e-5 and its Gaussian's standard deviation grew from 1 to 9.9 on actions clipped to [-1, 1]
(benchmarks/results/rl_reorient_h200_25min_checkpoints.txt). `--hidden-dims 512,256,128` gives Playground's networks.

Prints, per iteration: the mean return and length of the completed episodes, env-steps/s, the wall time, and the
means over its steps of the fraction of environments at a success, the orientation error [rad] and the
orientation term (LOGGED). `--evaluate` then runs the deterministic policy for --evaluate-seconds in 256 fresh
environments (--evaluate-envs) and prints the successes per environment and the fraction that dropped the cube.
Writes `<out>/policy.pt` and `<out>/rewards.png`.
"""

from __future__ import annotations

import argparse
import pathlib

import torch

import warpdyn.envs as envs
from rl_locomotion import PPO_DEFAULTS, load_policy, run_task, task_arguments

REORIENT_PPO = {**PPO_DEFAULTS, "steps_per_env": 40, "epochs": 4, "mini_batches": 32, "learning_rate": 3e-4, "gamma": 0.99, "entropy_coef": 0.01,
                "clipped_value_loss": False}  # fmt: skip
"""The trainer's settings for this task (the CLI's defaults): Playground's for LeapCubeReorient with Brax's PPO
(unrolls of 40 steps, 4 epochs of 32 mini-batches, learning rate 3e-4, discount 0.99, entropy cost 0.01), and as
Brax's PPO no clipping of the value's update: rsl-rl's moves each value at most 0.2 per iteration towards its return,
and this task's returns run to tens (its rewards per step) and hundreds (100 per success)."""

LOGGED = ("/success", "/orientation_error", "/reward/orientation")
"""CubeReorientEnv's info["log"] entries each iteration prints (their means over the iteration)."""


def evaluate(policy_path: pathlib.Path, device, seed: int, num_envs: int = 256, seconds: float = 20.0, cfg: envs.CubeReorientConfig | None = None) -> dict:
    """{"environments", "seconds", "successes", "dropped"}: the deterministic policy for `seconds` in `num_envs` fresh
    environments (`cfg`: theirs, default CubeReorientConfig()): the mean number of successes per environment (an
    environment that drops the cube restarts and keeps counting) and the fraction of environments that dropped it at
    least once."""
    env = envs.CubeReorientEnv(num_envs, cfg=cfg, device=device, seed=seed)
    vec, policy = load_policy(env, policy_path)
    obs = vec.get_observations()
    successes = torch.zeros(num_envs, device=env.device)
    dropped = torch.zeros(num_envs, dtype=torch.bool, device=env.device)
    with torch.inference_mode():
        for _ in range(int(round(seconds / env.cfg.policy_dt))):
            before = env.successes.clone()
            obs, _, dones, extras = vec.step(policy(obs))
            ended = dones.bool()
            successes += torch.where(ended, before, torch.zeros_like(before)).float()  # an ended episode's count, before its reset
            dropped |= ended & ~extras["time_outs"]
    successes += env.successes.float()
    return {"environments": num_envs, "seconds": seconds, "successes": float(successes.mean()), "dropped": float(dropped.float().mean())}


def parse_time_step(text: str) -> float:
    """--time-step's value [s], checked as CubeReorientConfig checks it (an argparse error with its message)."""
    try:
        cfg = envs.CubeReorientConfig(time_step=float(text))
        cfg.validate()
        return cfg.time_step
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def main(argv=None) -> list:
    parser = task_arguments(__doc__.split("\n\n")[0], REORIENT_PPO, "8192 on a GPU, 16 on the CPU", "runs/reorient", 100000, "beta", "fixed")
    parser.add_argument("--evaluate-seconds", type=float, default=20.0, help="seconds of --evaluate (default 20)")
    parser.add_argument("--time-step", type=parse_time_step, default=envs.CubeReorientConfig.time_step,
                        help=f"the simulation's step [s] (default {envs.CubeReorientConfig.time_step:g}; the policy's 0.05 s a whole number of them; "
                        "a step the soft contacts cannot hold, 8 ms and more at the default contact settings, is refused when the environments are built)")  # fmt: skip

    def report(args, policy_path, device, env) -> str:
        result = evaluate(policy_path, device, args.seed + 1000, args.evaluate_envs, args.evaluate_seconds, cfg=env.cfg)
        return (f"{result['environments']} fresh environments, {result['seconds']:g} s: {result['successes']:.2f} successes per environment "
                f"(the cube within {env.cfg.success_threshold:g} rad of its goal), {result['dropped']:.1%} dropped the cube")  # fmt: skip

    def make(N, device, seed, args):
        return envs.CubeReorientEnv(N, cfg=envs.CubeReorientConfig(time_step=args.time_step), device=device, seed=seed)

    def describe(env):
        return f"{env.single_observation_space.shape[0]} observations (critic {env.single_critic_observation_space.shape[0]})"

    return run_task(parser, argv, REORIENT_PPO, (8192, 16), make, "reorient cube", describe, "LEAP hand cube reorientation", LOGGED, report)


if __name__ == "__main__":
    main()
