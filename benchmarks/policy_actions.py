"""What a trained PickCubeEnv policy does with its gripper: its deterministic actions over one episode, replayed on
Warp's default device (issue 37: why the 3-minute policies reach the cube and do not lift it).

    python benchmarks/policy_actions.py POLICY.pt [--num-envs 8] [--seed 5]

POLICY.pt: a checkpoint of examples/rl_manipulation.py (its --out holds policy.pt; the action distribution is read
from it, as load_policy does). What runs: --num-envs fresh PickCubeEnv environments (seed --seed), one episode of the
deterministic policy (a Gaussian's mean, a Beta's mode on [-1, 1]: what the environment receives before its clip to
[-1, 1]). Prints, every 30 policy steps and at the end, the gripper action (the 8th: a delta of the gripper's opening,
0.04 m per unit) of each environment, then the range of each action over the episode, and the cubes' heights [m].
"""

from __future__ import annotations

import argparse
import pathlib
import sys
import warnings

import numpy as np
import torch
import warp as wp

import warpdyn.envs as envs

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
from rl_locomotion import load_policy  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("policy")
    parser.add_argument("--num-envs", type=int, default=8)
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args()
    wp.config.quiet = True
    warnings.simplefilter("ignore")
    env = envs.PickCubeEnv(args.num_envs, seed=args.seed)
    vec, policy = load_policy(env, pathlib.Path(args.policy))
    obs = vec.get_observations()
    actions = []
    with torch.inference_mode():
        for k in range(env.max_episode_length):
            a = policy(obs)
            actions.append(a.cpu().numpy())
            obs, _, _, _ = vec.step(a)
            if k % 30 == 0 or k == env.max_episode_length - 1:
                print(f"policy step {k:3d}: gripper action {np.round(actions[-1][:, 7], 2)}, cube height {np.round(env.cube_position[:, 2].cpu().numpy(), 3)}")
    actions = np.array(actions)
    print(f"over the episode, {args.num_envs} environments: each action's range (min, max)")
    for j in range(actions.shape[2]):
        print(f"  action {j}: {actions[:, :, j].min():+.3g} .. {actions[:, :, j].max():+.3g}")


if __name__ == "__main__":
    main()
