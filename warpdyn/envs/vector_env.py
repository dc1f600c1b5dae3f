"""What warpdyn's batched environments share (`LeggedEnv`, `PickCubeEnv`): Gymnasium's vector API over a
`wd.simulation.Stepper` whose whole step (torch ops and Warp launches) a GPU captures as one CUDA graph, torch
tensors on the model's device, episode statistics read in one host synchronisation."""

from __future__ import annotations

import contextlib

import gymnasium as gym
import torch
import warp as wp

__all__ = ["DeviceVectorEnv"]


class DeviceVectorEnv(gym.vector.VectorEnv):
    """The base of a batched environment whose subclass sets `stepper`, `device`, `use_graph`, `num_envs`,
    `max_episode_length`, `episode_length_buf` (long (N,)), `_return` (float32 (N,)), `_generator`
    (torch.Generator), `_finished` (float64 (3,): episodes, return sum, length sum) and `_warp_streams` ({}), and
    defines `_advance()` (one policy step: (obs, reward, terminated, truncated, info)).
    `_replayed` names the attributes a step points at tensors of its own, which a graph's replay points at the
    graph's."""

    _replayed: tuple = ()

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
        with torch.cuda.device(self.device), torch.cuda.graph(graph), self._on_device_stream(capturing=True):
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


def _copied(value):
    """`value` with every tensor in it (in tuples and dicts) cloned."""
    if isinstance(value, torch.Tensor):
        return value.clone()
    if isinstance(value, tuple):
        return tuple(_copied(v) for v in value)
    if isinstance(value, dict):
        return {k: _copied(v) for k, v in value.items()}
    return value
