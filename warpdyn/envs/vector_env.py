"""What warpdyn's batched environments share (`LeggedEnv`, `PickCubeEnv`): Gymnasium's vector API over a
`wd.simulation.Stepper` whose whole step (torch ops and Warp launches) a GPU captures as one CUDA graph, torch
tensors on the model's device, episode statistics read in one host synchronisation."""

from __future__ import annotations

import contextlib
import gc
import math
import warnings

import gymnasium as gym
import numpy as np
import torch
import warp as wp
from gymnasium.vector.utils import batch_space

import warpdyn as wd

__all__ = ["DIVERGENCE_SPEED", "DeviceVectorEnv", "check_divergence_speed", "follow_divergence_speed", "is_real_number"]


DIVERGENCE_SPEED = 100.0
"""[m/s or rad/s] The environments' default `divergence_speed` (model.divergence_speed): a simulation step from a state
with a base or joint velocity component beyond it flags the environment (reset, info["invalid"]), as a non-finite
state does. Under uniformly random actions (benchmarks/env_speed_bounds.py: 64 environments, 10 s, pushes of 0.5 m/s
on the legged robots; benchmarks/results/env_speed_bounds_cpu.md) none passed 20: the smallest bound that flagged
none was 20 for the ergoCub legs and the Panda with its cube, 15 for the Go1, the ANYmal C and the LEAP hand with its
cube. The default is five times the largest; a divergence passes it by far (docs/simulation.md: a cube once reached a
finite 65 km/s)."""


def is_real_number(value) -> bool:
    """A real number: an int or float (NumPy's included), not a bool."""
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def check_divergence_speed(owner: str, value) -> None:
    """A ValueError naming `owner`.divergence_speed unless `value` is a positive number of m/s or rad/s or inf (off)."""
    if not (is_real_number(value) and float(value) > 0.0):  # NaN fails too
        raise ValueError(f"{owner}.divergence_speed must be a positive number [m/s or rad/s] or inf (off), got {value!r}")


def follow_divergence_speed(cfg, model, applied: float) -> float:
    """Where cfg.divergence_speed differs from `applied` (the value the environment last set from its config: a
    config changed in place), check it and set model.divergence_speed to it (the model's version then changes,
    which recaptures the environment's graph); returns the value now applied. A bound set on the model directly
    stays until the config's changes."""
    if cfg.divergence_speed != applied:
        check_divergence_speed(type(cfg).__name__, cfg.divergence_speed)
        model.divergence_speed = applied = cfg.divergence_speed
    return applied


class DeviceVectorEnv(gym.vector.VectorEnv):
    """The base of a batched environment whose subclass sets `stepper`, `device`, `use_graph`, `num_envs`,
    `max_episode_length`, `episode_length_buf` (long (N,)), `_return` (float32 (N,)), `_generator`
    (torch.Generator), `_finished` (float64 (3,): episodes, return sum, length sum) and `_warp_streams` ({}), and
    defines `_advance()` (one policy step: (obs, reward, terminated, truncated, info)). A manipulation environment
    (`PickCubeEnv`, `CubeReorientEnv`) calls `_setup` and defines `_simulated(model)`, `_reset(mask)`,
    `_first_observation()`, `_take(actions)` and `_snapshot()`, on which the base's `reset`, `step` and `_sync_model`
    run; `LeggedEnv` has its own.
    `_replayed` names the attributes a step points at tensors of its own, which a graph's replay points at the
    graph's."""

    _replayed: tuple = ()

    def _setup(self, num_envs, cfg, config_type: type, model, asset, dtype, device, seed: int, use_graph) -> None:
        """The arguments a manipulation environment takes (`PickCubeEnv`, `CubeReorientEnv`), checked (a ValueError or
        TypeError naming the one that is wrong), and what they set: cfg (config_type()'s when None, validated),
        num_envs, use_graph, decimation and max_episode_length (from cfg's time_step, policy_dt, episode_seconds),
        model (the subclass's `_simulated` copy of `model`, or of `asset()` loaded on `device` in `dtype`, its
        NotModelledWarning silenced: the asset's docs name what it does not model), device, torch_dtype and the
        generator seeded with `seed`."""
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if use_graph not in ("auto", True, False):
            raise ValueError(f"use_graph must be 'auto', True or False, got {use_graph!r}")
        self.cfg = cfg = cfg if cfg is not None else config_type()
        if not isinstance(cfg, config_type):
            raise TypeError(f"cfg must be a {config_type.__name__}, got {type(cfg).__name__}")
        cfg.validate()
        if model is None:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", wd.model.NotModelledWarning)
                model = wd.model.Model.build_from_model_description(asset(), dtype=dtype, device=device)
        if use_graph is True and not model.device.is_cuda:
            raise ValueError(f"use_graph=True captures torch ops in a CUDA graph; '{model.device}' is not a GPU (use 'auto')")
        self.num_envs = int(num_envs)
        self.use_graph = use_graph
        self.decimation = int(round(cfg.policy_dt / cfg.time_step))
        self.max_episode_length = int(math.ceil(cfg.episode_seconds / cfg.policy_dt))
        self.model = self._simulated(model)
        self.device = torch.device(wp.device_to_torch(self.model.device))
        self.torch_dtype = wp.dtype_to_torch(self.model.scalar)
        self._generator = torch.Generator(device=self.device)
        self._generator.manual_seed(seed)

    def _with_body_contacts(self, model):
        """A copy of `model` with its geom pairs' contacts acting and the config's `time_step`, `implicit_contacts`,
        `limit_constraints`, `frictionloss_constraints`, soft law (`contact_stiffness` K, `contact_damping` D,
        `friction` mu) and `divergence_speed`: a manipulation environment's `_simulated` after its checks of the scene."""
        cfg = self.cfg
        model = model.copy()
        model.divergence_speed = self._divergence_speed = cfg.divergence_speed
        model.geom_contacts = True
        model.implicit_contacts = cfg.implicit_contacts
        model.limit_constraints = cfg.limit_constraints
        model.frictionloss_constraints = cfg.frictionloss_constraints
        model.time_step = cfg.time_step
        model.contact_params = wd.model.SoftContactsParams(K=cfg.contact_stiffness, D=cfg.contact_damping, mu=cfg.friction)
        return model

    def _finish_setup(self, observations: int, actions: int) -> None:
        """The rest a manipulation environment keeps, once its own state exists: the episodes' lengths, the reset
        mask (torch and Warp views), the returns and finished-episode sums, the step program and its graph key, and
        the spaces of `observations` float32 observations and `actions` actions in [-1, 1]."""
        N = self.num_envs
        self.episode_length_buf = torch.zeros(N, dtype=torch.long, device=self.device)
        self._reset_mask = torch.zeros(N, dtype=torch.int32, device=self.device)
        self._reset_mask_wp = wp.from_torch(self._reset_mask)
        self._return = torch.zeros(N, device=self.device, dtype=torch.float32)
        self._finished = torch.zeros(3, device=self.device, dtype=torch.float64)
        self._warp_streams = {}
        self._program = self._step_program(f"a {type(self).__name__}")
        self._graph_key = self._snapshot()
        self.single_observation_space = gym.spaces.Box(-np.inf, np.inf, (observations,), np.float32)
        self.single_action_space = gym.spaces.Box(-1.0, 1.0, (actions,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, N)
        self.action_space = batch_space(self.single_action_space, N)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Reset every environment (the subclass's `_reset` of all); seed: reseed its random numbers. Returns the
        subclass's `_first_observation()`: (obs (N, ...), info). LeggedEnv has its own."""
        if seed is not None:
            self._generator.manual_seed(int(seed))
        self._sync_model()
        with self._on_device_stream():
            self._reset(torch.ones(self.num_envs, dtype=torch.bool, device=self.device))
            obs, info = self._first_observation()
        self._finished.zero_()
        return obs, info

    def step(self, actions):
        """Apply `actions` (N, na) for policy_dt (the subclass's `_take(actions)` keeps them for its `_advance`); see
        LeggedEnv.step for what comes back. LeggedEnv has its own."""
        actions = torch.as_tensor(actions, device=self.device, dtype=torch.float32)
        expected = (self.num_envs, *self.single_action_space.shape)
        if tuple(actions.shape) != expected:
            raise ValueError(f"actions has shape {tuple(actions.shape)}; expected {expected}")
        self._take(actions)
        self._sync_model()
        with self._on_device_stream():
            return self._program.run()

    def _sync_model(self) -> None:
        """After a setter changed the model or a change of `cfg` (read when a graph was captured): drop the graphs
        (the next step runs eagerly, then captures). The subclass's `_snapshot()` is what a graph depends on. A
        `divergence_speed` changed in cfg reaches the model (`follow_divergence_speed`)."""
        self._divergence_speed = follow_divergence_speed(self.cfg, self.model, self._divergence_speed)
        if self._graph_key != self._snapshot():
            self.cfg.validate()
            self._program = self._step_program(f"a {type(self).__name__}")
            self._graph_key = self._snapshot()

    def _uniform(self, low, high, shape) -> torch.Tensor:
        """U(low, high) of `shape` from the environment's generator, in its dtype."""
        u = torch.rand(shape, generator=self._generator, device=self.device, dtype=self.torch_dtype)
        return low + (high - low) * u

    def _on_device_stream(self, capturing: bool = False):
        """On a GPU, Warp's launches on torch's current stream, ordered with the torch ops (captured with them):
        outside a capture that stream first waits for Warp's, and Warp's for it at the exit."""
        if not self.device.type == "cuda":
            return contextlib.nullcontext()
        current = torch.cuda.current_stream(self.device)
        stream = self._warp_streams.get(current.cuda_stream)
        if stream is None:
            stream = self._warp_streams[current.cuda_stream] = wp.stream_from_torch(current)
        return wp.ScopedStream(stream, sync_enter=not capturing, sync_exit=not capturing)

    def _step_program(self, what: str):
        """`_advance` as the Stepper's step program (wd.simulation.Stepper): on a GPU captured whole in a torch
        CUDA graph as use_graph allows, at the second step; on the CPU eager (the Stepper replays its Warp CPU
        graph). `what` names the environment in the Stepper's messages."""
        use_graph = self.use_graph if self.device.type == "cuda" else False
        return self.stepper.step_program(self._advance, self._torch_graph, use_graph, what)

    def _torch_graph(self, advance):
        """Capture one `advance()` in a torch CUDA graph, not run (torch's allocations in the graph's memory pool,
        the generator's state registered with it); returns its replay, which points the `_replayed` attributes at
        the graph's tensors and returns copies of the graph's outputs, as an eager step returns new tensors."""
        graph = torch.cuda.CUDAGraph()
        graph.register_generator_state(self._generator)
        with no_collection(), torch.cuda.device(self.device), torch.cuda.graph(graph), self._on_device_stream(capturing=True):
            outputs = advance()
        kept = {name: getattr(self, name) for name in self._replayed}

        def replay() -> tuple:
            with torch.cuda.device(self.device):
                graph.replay()
            for name, value in kept.items():
                setattr(self, name, value)
            return _copied(outputs)

        return replay

    def _end_episodes(self, terminated: torch.Tensor, reward: torch.Tensor) -> tuple:
        """(truncated, done) (bool (N,)) after a step whose `reward` (N,) is final: the episodes that reached
        `max_episode_length` without terminating are truncated; the ended episodes' count, return and length are
        added to `_finished` (episode_statistics reads them)."""
        truncated = (self.episode_length_buf >= self.max_episode_length) & ~terminated
        done = terminated | truncated
        self._return += reward
        self._finished += torch.stack([done.sum(), (self._return * done).sum(), (self.episode_length_buf * done).sum()]).to(torch.float64)
        return truncated, done

    def episode_statistics(self) -> dict:
        """{"episodes", "mean_return", "mean_length"} of the episodes completed since the last call (one
        host synchronisation)."""
        count, total, length = self._finished.tolist()
        self._finished.zero_()
        return {"episodes": int(count), "mean_return": total / count if count else float("nan"), "mean_length": length / count if count else float("nan")}

    def close_extras(self, **kwargs) -> None:
        self._program = None
        self.stepper = None


@contextlib.contextmanager
def no_collection():
    """Python's cyclic garbage collector run, then off until the exit: while a CUDA graph is captured, it must not free
    unreachable Warp arrays, whose device memory may not be released during a capture (CUDA error 900 ends the
    capture)."""
    gc.collect()
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _copied(value):
    """`value` with every tensor in it (in tuples and dicts) cloned."""
    if isinstance(value, torch.Tensor):
        return value.clone()
    if isinstance(value, tuple):
        return tuple(_copied(v) for v in value)
    if isinstance(value, dict):
        return {k: _copied(v) for k, v in value.items()}
    return value
