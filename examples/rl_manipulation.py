"""Train the Franka Panda to pick up a cube and bring it to a target (MuJoCo Playground's PandaPickCube) with rsl-rl's
PPO on warpdyn.envs.PickCubeEnv, the contacts between its fingertip pads and the cube acting.

    pip install -e ".[rl,viz,examples]"
    python examples/rl_manipulation.py --max-minutes 3 --evaluate --out runs/pick     # a GPU: N = 4096
    python examples/rl_manipulation.py --device cpu --num-envs 16 --iterations 2      # a look on the CPU
    torchrun --standalone --nproc_per_node 2 examples/rl_manipulation.py --max-minutes 3 --out runs/pick2   # 2 GPUs, 4096 each

Environment (`warpdyn.envs.PickCubeEnv`, its defaults: PickCubeConfig): the shipped scene
`wd.assets.franka_panda_cube_mjcf()` at 2 ms steps (implicit contacts), the policy at 50 Hz adding 0.04 x its actions to the 8 position
controls, episodes of 3 s; each reset puts the cube within 0.2 m of the keyframe "home"'s and draws a target 0.2 to
0.4 m above the floor around it; Playground's rewards (gripper to cube, cube to target once reached, no hand on the
floor, arm near its keyframe posture). Trainer: examples/rl_locomotion.py's `train` (rsl-rl-lib's PPO as GraphedPPO, the same
flags: --steps-per-env, --epochs, --mini-batches, --learning-rate, --gamma, --entropy-coef), with Playground's
settings for this task as defaults (PICK_PPO) and a Beta policy (bounded actions; `--action-distribution gaussian`:
its mean for the gripper drifted far past the clip). On one H200 six 3-minute runs lifted the cube: success 77 %,
100 %, 98.8 %, 99.2 %, 98.8 % and 99.2 % in 256 fresh environments (seeds 0 to 5; benchmarks/RESULTS.md).

Prints, per iteration: the mean return and length of the completed episodes, env-steps/s, the wall time, and the
means over its steps of the fraction of environments whose gripper has reached the cube ("reached", box_target's
gate), of those whose cube is at its target ("success") and of box_target's term (LOGGED);
`--evaluate` then runs the deterministic policy for one episode in 256 fresh environments (--evaluate-envs) and prints the success
rate (the cube within 5 cm of its target at the episode's end) and the mean distance. Writes `<out>/policy.pt` and
`<out>/rewards.png`.
"""

from __future__ import annotations

import pathlib

import torch

import warpdyn.envs as envs
from rl_locomotion import PPO_DEFAULTS, load_policy, run_task, task_arguments


PICK_PPO = {**PPO_DEFAULTS, "steps_per_env": 10, "epochs": 8, "mini_batches": 8, "gamma": 0.97, "entropy_coef": 0.02}
"""The trainer's settings for this task (the CLI's defaults): Playground's for PandaPickCube with Brax's PPO, its
discount 0.97 and entropy cost 0.02, and its reuse of samples (unrolls of 10 steps, 8 epochs over mini-batches of
5120 samples at 4096 environments: 1.6 gradient steps per thousand samples). With Rudin et al.'s settings
(PPO_DEFAULTS: 0.2 per thousand) the policy learned to hold the gripper near the cube and never to reach it
(benchmarks/RESULTS.md)."""

LOGGED = ("/reached", "/success", "/reward/box_target")
"""PickCubeEnv's info["log"] entries each iteration prints (their means over the iteration): the fraction of
environments whose gripper has reached the cube this episode, the fraction whose cube is at its target, box_target's term."""


def evaluate(policy_path: pathlib.Path, device, seed: int, num_envs: int = 256) -> dict:
    """{"environments", "success", "distance"}: the deterministic policy for one episode in `num_envs` fresh
    environments; success: the fraction whose cube ends within PickCubeConfig.success_distance of its target (an
    episode ended early, the cube out of bounds, fails); distance: the mean of the others' final distance [m]."""
    env = envs.PickCubeEnv(num_envs, device=device, seed=seed)
    vec, policy = load_policy(env, policy_path)
    obs = vec.get_observations()
    failed = torch.zeros(num_envs, dtype=torch.bool, device=env.device)
    with torch.inference_mode():
        for _ in range(env.max_episode_length):
            target = env.target.clone()  # this episode's (the last step's resets draw new ones)
            obs, _, dones, extras = vec.step(policy(obs))
            failed |= dones.bool() & ~extras["time_outs"]
    distance = (target - env.cube_position).norm(dim=1)  # the cube before the last step's resets
    success = ~failed & (distance < env.cfg.success_distance)
    kept = distance[~failed]
    return {"environments": num_envs, "success": float(success.float().mean()), "distance": float(kept.mean()) if kept.numel() else float("nan")}


def main(argv=None) -> list:
    parser = task_arguments(__doc__.split("\n\n")[0], PICK_PPO, "4096 on a GPU, 64 on the CPU", "runs/pick", 2000, "beta")

    def report(args, policy_path, device, env) -> str:
        result = evaluate(policy_path, device, args.seed + 1000, args.evaluate_envs)
        return (f"{result['environments']} fresh environments, one episode: success {result['success']:.1%} "
                f"(cube within {env.cfg.success_distance:g} m of its target), mean distance {result['distance']:.3f} m")  # fmt: skip

    def make(N, device, seed, args):
        return envs.PickCubeEnv(N, device=device, seed=seed)

    def describe(env):
        return f"{env.single_observation_space.shape[0]} observations"

    return run_task(parser, argv, PICK_PPO, (4096, 64), make, "pick cube", describe, "Panda pick cube", LOGGED, report)


if __name__ == "__main__":
    main()
