"""`LeggedEnv` as rsl-rl's VecEnv (rsl-rl-lib >= 5: observations as a TensorDict of groups), for its PPO."""

from __future__ import annotations

import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

__all__ = ["RslRlVecEnv"]


class RslRlVecEnv(VecEnv):
    """rsl-rl's view of a warpdyn environment (`LeggedEnv`, `PickCubeEnv`, `CubeReorientEnv`): the observation group
    "policy", and "critic" where the environment's info holds "critic_obs" (the critic's own observations:
    `obs_groups={"actor": ["policy"], "critic": ["critic"]}`; else the critic reads "policy"), dones = terminated
    or truncated, extras["time_outs"] = truncated (PPO bootstraps those) and extras["log"] the reward terms' means."""

    def __init__(self, env):
        self.env = env
        self.num_envs = env.num_envs
        self.num_actions = env.single_action_space.shape[0]
        self.max_episode_length = env.max_episode_length
        self.device = env.device
        self.cfg = env.cfg
        self._obs, info = env.reset()
        self._critic = info.get("critic_obs")

    @property
    def episode_length_buf(self) -> torch.Tensor:
        return self.env.episode_length_buf

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:  # rsl-rl randomises it at the start of learning
        self.env.episode_length_buf.copy_(value)

    @property
    def obs_groups(self) -> dict:
        """rsl-rl's obs_groups for this environment's observations."""
        return {"actor": ["policy"], "critic": ["critic" if self._critic is not None else "policy"]}

    def _group(self) -> TensorDict:
        groups = {"policy": self._obs} if self._critic is None else {"policy": self._obs, "critic": self._critic}
        return TensorDict(groups, batch_size=[self.num_envs], device=self.device)

    def get_observations(self) -> TensorDict:
        return self._group()

    def step(self, actions: torch.Tensor):
        self._obs, reward, terminated, truncated, info = self.env.step(actions)
        self._critic = info.get("critic_obs")
        dones = (terminated | truncated).to(torch.long)
        extras = {"time_outs": truncated, "log": info["log"]}
        return self._group(), reward, dones, extras
