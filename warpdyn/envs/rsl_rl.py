"""`LeggedEnv` as rsl-rl's VecEnv (rsl-rl-lib >= 5: observations as a TensorDict of groups), for its PPO."""

from __future__ import annotations

import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

__all__ = ["RslRlVecEnv"]


class RslRlVecEnv(VecEnv):
    """rsl-rl's view of a `warpdyn.envs.LeggedEnv`: one observation group, "policy" (the actor's and the
    critic's: `obs_groups={"actor": ["policy"], "critic": ["policy"]}`), dones = terminated or truncated,
    extras["time_outs"] = truncated (PPO bootstraps those) and extras["log"] the reward terms' means."""

    def __init__(self, env):
        self.env = env
        self.num_envs = env.num_envs
        self.num_actions = env.single_action_space.shape[0]
        self.max_episode_length = env.max_episode_length
        self.device = env.device
        self.cfg = env.cfg
        self._obs, _ = env.reset()

    @property
    def episode_length_buf(self) -> torch.Tensor:
        return self.env.episode_length_buf

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:  # rsl-rl randomises it at the start of learning
        self.env.episode_length_buf.copy_(value)

    def _group(self, obs: torch.Tensor) -> TensorDict:
        return TensorDict({"policy": obs}, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        return self._group(self._obs)

    def step(self, actions: torch.Tensor):
        obs, reward, terminated, truncated, info = self.env.step(actions)
        self._obs = obs
        dones = (terminated | truncated).to(torch.long)
        extras = {"time_outs": truncated, "log": info["log"]}
        return self._group(obs), reward, dones, extras
