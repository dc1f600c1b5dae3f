"""`LeggedEnv` as rsl-rl's VecEnv (rsl-rl-lib >= 5: observations as a TensorDict of groups), and `GraphedPPO`: rsl-rl's
PPO whose rollout step, returns and update a GPU replays as CUDA graphs."""

from __future__ import annotations

from itertools import chain

import torch
from rsl_rl.algorithms import PPO
from rsl_rl.env import VecEnv
from rsl_rl.modules import EmpiricalNormalization, GaussianDistribution
from tensordict import TensorDict

from .vector_env import no_collection

__all__ = ["GraphedPPO", "RslRlVecEnv"]


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


class GraphedPPO(PPO):
    """rsl-rl's PPO (rsl-rl-lib 5: its losses, clipping, adaptive learning rate, normalisers, storage and checkpoints)
    with its per-step and per-mini-batch host round trips removed: the learning rate is a tensor the adaptive
    schedule updates on the device, the losses are summed there and read once an update. On a GPU, `act`,
    `compute_returns` and `update` are each captured as a CUDA graph at their second call (the first runs eagerly,
    on a side stream, as capture needs) and replayed after: the trainer's part of a rollout step is one graph launch
    and a few copies, an update one launch (rsl-rl's update launches each mini-batch's kernels from Python and
    synchronises with the host 4 times per mini-batch). Elsewhere the same code runs eagerly. Under a process group
    (rsl-rl's multi_gpu_cfg: one rank per GPU, NCCL; gloo on the CPU) it averages as rsl-rl's PPO does, inside the
    graphs: each mini-batch's gradients (summed over the ranks in one all-reduce, divided by their number) and its KL
    divergence, the learning rate rank 0's (broadcast). What differs from rsl-rl's PPO: the mini-batches' shuffle draws
    its permutation as the order of uniform draws on the device (rsl-rl: torch.randperm). Refused (rsl-rl's PPO does
    them): recurrent models, RND, symmetry, mixed precision, optimizers other than Adam, torch.compile.
    Use it as rsl-rl's algorithm: `cfg["algorithm"]["class_name"] = GraphedPPO`."""

    def __init__(self, actor, critic, storage, **kwargs):
        unsupported = [k for k in ("rnd_cfg", "symmetry_cfg") if kwargs.get(k)]
        if unsupported or actor.is_recurrent or critic.is_recurrent or kwargs.get("use_mixed_precision"):
            raise ValueError(f"GraphedPPO runs feed-forward models without mixed precision; got {unsupported or 'a recurrent model or mixed precision'} (use rsl-rl's PPO)")
        if str(kwargs.get("optimizer", "adam")).lower() != "adam":
            raise ValueError(f"GraphedPPO optimises with Adam (its capturable form), got optimizer={kwargs['optimizer']!r} (use rsl-rl's PPO)")
        super().__init__(actor, critic, storage, **kwargs)
        self._lr = torch.tensor(float(self.learning_rate), device=self.device)
        self._capture = torch.device(self.device).type == "cuda"
        params = chain(self.actor.parameters(), self.critic.parameters())
        self.optimizer = torch.optim.Adam(params, lr=self._lr, capturable=self._capture)
        self._sums = torch.zeros(4, device=self.device)  # value loss, surrogate loss, entropy, learning rate
        self._graphs: dict[str, torch.cuda.CUDAGraph] = {}
        self._warm: set[str] = set()
        self._side = torch.cuda.Stream(device=self.device) if self._capture else None  # the warm-ups' and captures' stream
        self._obs_in: TensorDict | None = None  # the graphs' observations (a copy of the caller's)
        self._act_out: tuple = ()

    def _run(self, name: str, body) -> None:
        """body() eagerly (the CPU; a GPU's first call, on the side stream the capture then uses, as capture needs),
        captured at a GPU's second call, replayed from then on; on the algorithm's device whatever the current one."""
        if not self._capture:
            body()
            return
        with torch.cuda.device(self.device):
            graph = self._graphs.get(name)
            if graph is None:
                if name not in self._warm:
                    self._warm.add(name)
                    self._side.wait_stream(torch.cuda.current_stream())
                    with torch.cuda.stream(self._side):
                        body()
                    torch.cuda.current_stream().wait_stream(self._side)
                    return
                graph = torch.cuda.CUDAGraph()
                with no_collection(), torch.cuda.graph(graph, stream=self._side):
                    body()
                self._graphs[name] = graph
            graph.replay()

    def _observe(self, obs: TensorDict) -> None:
        if self._obs_in is None:
            with torch.inference_mode(False):  # a normal tensor, which calls in and out of inference mode may fill
                self._obs_in = obs.clone()
        else:
            for key, value in obs.items():
                self._obs_in[key].copy_(value)

    def _act(self) -> None:
        _update_distribution(self.actor, self._obs_in)
        actions = _sample(self.actor.distribution).detach()
        values = self.critic(self._obs_in).detach()
        log_prob = self.actor.get_output_log_prob(actions).detach()
        self._act_out = (actions, values, log_prob, tuple(p.detach() for p in self.actor.output_distribution_params))

    def act(self, obs: TensorDict) -> torch.Tensor:
        """Sample actions (N, A) and keep the step's transition (rsl-rl's PPO.act); the actions are the graph's buffer,
        overwritten by the next call."""
        self._observe(obs)
        self._run("act", self._act)
        t = self.transition
        t.hidden_states = (None, None)
        t.actions, t.values, t.actions_log_prob, t.distribution_params = self._act_out
        t.observations = obs
        return t.actions

    def _returns(self) -> None:
        # rsl-rl's compute_returns, writing the advantages in place (it rebinds storage.advantages, which a graph cannot follow)
        st = self.storage
        last_values = self.critic(self._obs_in).detach()
        advantage = torch.zeros_like(last_values)
        for step in reversed(range(st.num_transitions_per_env)):
            next_values = last_values if step == st.num_transitions_per_env - 1 else st.values[step + 1]
            not_terminal = 1.0 - st.dones[step].float()
            delta = st.rewards[step] + not_terminal * self.gamma * next_values - st.values[step]
            advantage = delta + not_terminal * self.gamma * self.lam * advantage
            st.returns[step] = advantage + st.values[step]
        st.advantages.copy_(st.returns - st.values)
        if not self.normalize_advantage_per_mini_batch:
            st.advantages.copy_((st.advantages - st.advantages.mean()) / (st.advantages.std() + 1e-8))

    def compute_returns(self, obs: TensorDict) -> None:
        """rsl-rl's GAE returns and advantages, in the storage's buffers (in place)."""
        self._observe(obs)
        self._run("returns", self._returns)

    def _update(self) -> None:
        st = self.storage
        size = st.num_envs * st.num_transitions_per_env // self.num_mini_batches
        observations = st.observations.flatten(0, 1)
        actions, values, returns = st.actions.flatten(0, 1), st.values.flatten(0, 1), st.returns.flatten(0, 1)
        old_log_prob, advantages = st.actions_log_prob.flatten(0, 1), st.advantages.flatten(0, 1)
        old_params = tuple(p.flatten(0, 1) for p in st.distribution_params)
        self._sums.zero_()
        order = torch.argsort(torch.rand(size * self.num_mini_batches, device=self.device))
        for _ in range(self.num_learning_epochs):
            for i in range(self.num_mini_batches):
                idx = order[i * size : (i + 1) * size]
                adv = advantages[idx]
                if self.normalize_advantage_per_mini_batch:
                    adv = (adv - adv.mean()) / (adv.std() + 1e-8)
                _update_distribution(self.actor, observations[idx])
                log_prob = self.actor.get_output_log_prob(actions[idx])
                value = self.critic(observations[idx])
                params = self.actor.output_distribution_params
                entropy = self.actor.output_entropy
                if self.desired_kl is not None and self.schedule == "adaptive":
                    with torch.no_grad():
                        kl = self.actor.get_kl_divergence(tuple(p[idx] for p in old_params), params).mean()
                        if self.is_multi_gpu:
                            torch.distributed.all_reduce(kl, op=torch.distributed.ReduceOp.SUM)
                            kl /= self.gpu_world_size
                        lr = self._lr
                        lower, higher = torch.clamp(lr / 1.5, min=1e-5), torch.clamp(lr * 1.5, max=1e-2)
                        lr.copy_(torch.where(kl > 2.0 * self.desired_kl, lower, torch.where((kl < 0.5 * self.desired_kl) & (kl > 0.0), higher, lr)))
                        if self.is_multi_gpu:
                            torch.distributed.broadcast(lr, src=0)
                ratio = torch.exp(log_prob - torch.squeeze(old_log_prob[idx]))
                adv = torch.squeeze(adv)
                surrogate = torch.max(-adv * ratio, -adv * torch.clamp(ratio, 1.0 - self.clip_param, 1.0 + self.clip_param)).mean()
                if self.use_clipped_value_loss:
                    clipped = values[idx] + (value - values[idx]).clamp(-self.clip_param, self.clip_param)
                    value_loss = torch.max((value - returns[idx]).pow(2), (clipped - returns[idx]).pow(2)).mean()
                else:
                    value_loss = (returns[idx] - value).pow(2).mean()
                loss = surrogate + self.value_loss_coef * value_loss - self.entropy_coef * entropy.mean()
                self.optimizer.zero_grad()
                loss.backward()
                if self.is_multi_gpu:
                    self._average_gradients()
                torch.nn.utils.clip_grad_norm_(self.actor.parameters(), self.max_grad_norm)
                torch.nn.utils.clip_grad_norm_(self.critic.parameters(), self.max_grad_norm)
                self.optimizer.step()
                self._sums[:3] += torch.stack([value_loss, surrogate, entropy.mean()]).detach()
        self._sums[3] = self._lr

    def _average_gradients(self) -> None:
        """The actor's and critic's gradients averaged over the ranks: summed in one all-reduce of their concatenation
        (rsl-rl: buckets of grad_reduce_bucket_mb; the same sums), divided by the number of ranks."""
        grads = [p.grad for p in chain(self.actor.parameters(), self.critic.parameters()) if p.grad is not None]
        flat = torch.cat([g.reshape(-1) for g in grads])
        torch.distributed.all_reduce(flat, op=torch.distributed.ReduceOp.SUM)
        flat /= self.gpu_world_size
        offset = 0
        for g in grads:
            g.copy_(flat[offset : offset + g.numel()].view_as(g))
            offset += g.numel()

    def update(self) -> dict[str, float]:
        """rsl-rl's PPO update over the stored rollout; returns the mean losses (read once; the normalisers' update,
        rsl-rl's, adds a copy to the device each)."""
        self._run("update", self._update)
        observations = self.storage.observations.flatten(0, 1)
        for model in (self.actor, self.critic):
            _update_normalization(model, observations)
        value, surrogate, entropy, self.learning_rate = self._sums.tolist()
        updates = self.num_learning_epochs * self.num_mini_batches
        self.storage.clear()
        return {"value": value / updates, "surrogate": surrogate / updates, "entropy": entropy / updates}

    def compile(self, mode: str | None = None) -> None:
        """torch.compile is not used (the graphs replace it): a ValueError for a mode."""
        if mode is not None:
            raise ValueError(f"GraphedPPO replays CUDA graphs instead of torch.compile; got torch_compile_mode={mode!r} (use rsl-rl's PPO)")

    def save(self) -> dict:
        """rsl-rl's checkpoint, its optimizer's learning rate a number (rsl-rl's PPO loads it)."""
        saved = super().save()
        for group in saved["optimizer_state_dict"]["param_groups"]:
            group["lr"], group["capturable"] = float(group["lr"]), False
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        """rsl-rl's load; then Adam reads the schedule's learning-rate tensor again (loading replaced its parameter
        groups), its state is the capturable form's, and the graphs are dropped (the next calls capture anew: the
        loaded moments are new tensors)."""
        result = super().load(loaded_dict, load_cfg, strict)
        self._lr.fill_(float(self.optimizer.param_groups[0]["lr"]))
        self.learning_rate = float(self._lr)
        for group in self.optimizer.param_groups:
            group["lr"], group["capturable"] = self._lr, self._capture
        if self._capture:
            for state in self.optimizer.state.values():
                if "step" in state:
                    state["step"] = state["step"].to(device=self.device, dtype=torch.float32)
        self._graphs.clear()
        self._warm.clear()
        return result


def _update_normalization(model, observations: TensorDict) -> None:
    """model.update_normalization(observations), its normaliser's statistics kept in their buffers (rsl-rl's
    EmpiricalNormalization replaces its std tensor, which the captured graphs read)."""
    normalizer = getattr(model, "obs_normalizer", None)
    std = normalizer._std if isinstance(normalizer, EmpiricalNormalization) else None
    model.update_normalization(observations)
    if std is not None and normalizer._std is not std:
        std.copy_(normalizer._std)
        normalizer._std = std


def _update_distribution(model, observations: TensorDict) -> None:
    """The model's action distribution at `observations`, as its forward pass sets it, without a draw."""
    model.distribution.update(model.mlp(model.get_latent(observations)))


def _sample(distribution) -> torch.Tensor:
    """A draw of an rsl-rl distribution that a CUDA graph can capture: a Gaussian's drawn as torch.normal(mean, std)
    draws it (standard normal draws, scaled and shifted: the same numbers from the same generator state), without
    torch.normal's host check of the standard deviation's sign, which a capture does not allow."""
    if isinstance(distribution, GaussianDistribution):
        mean = distribution.mean
        return torch.empty_like(mean).normal_() * distribution.std + mean
    return distribution.sample()
