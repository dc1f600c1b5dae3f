"""How `warpdyn.envs.LeggedEnv` turns actions into joint torques besides its built-in PD servo
(`LeggedEnvConfig.actuator`): "torque", the actions as joint torques, or an `ActuatorNet`, a learned actuator model
(Hwangbo et al. 2019; Isaac Lab's ActuatorNetMLP) mapping each joint's recent position errors and velocities to
its torque.

    net = torch.nn.Sequential(torch.nn.Linear(2 * 3, 32), torch.nn.Softsign(), torch.nn.Linear(32, 1))
    cfg = envs.LeggedEnvConfig(actuator=ActuatorNet(net, history=3))

Both write the torques into the Stepper's `joint_force_references`, and the model then has no actuators and no
joint damping of its own (the network, or the policy, is the whole actuator; "pd" keeps kp and kd).

An ActuatorNet runs at every simulation step, as Isaac Lab's does (an actuator's dynamics, its history included,
are those of the physics' rate; held over a policy step of `decimation` steps, a stiff learned servo would act on a
20 ms old error). The environment's step stays one program, captured whole in a CUDA graph on a GPU with the
network's torch ops: the Stepper a StepProgram captures may step only once per policy step, so LeggedEnv's own
Stepper takes one simulation step, the last; the `decimation - 1` before it run on a second Stepper of one step per
call, the state copied to it before and back after (two copies of the state per policy step, on the device). Each
step's history shifts by one and reads the state that step starts from. "torque" holds the policy's torques over the
policy step (one write, the Stepper's `decimation` steps unchanged).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import torch
import warp as wp

import warpdyn as wd

__all__ = ["ActuatorNet", "Actuation"]


@dataclasses.dataclass(frozen=True)
class ActuatorNet:
    """A learned actuator: `network`, a torch callable (an nn.Module, a function) mapping the input (N, n, 2 history)
    to joint torques (N, n) or (N, n, 1) [N m], where the last axis holds the joint's position errors target - s [rad]
    over the last `history` simulation steps, newest first, then its velocities sdot [rad/s], newest first (zeros
    before an episode's first steps). The targets are the PD mode's, default + action_scale * action; the torques are
    clipped at LeggedEnvConfig.torque_limit. The network runs without autograd, with no host synchronisation allowed
    (it is captured in the step's CUDA graph on a GPU)."""

    network: object
    history: int = 1

    def __post_init__(self):
        if not callable(self.network):
            raise TypeError(f"ActuatorNet.network must be a torch callable (an nn.Module or a function), got {self.network!r}")
        if isinstance(self.history, (bool, np.bool_)) or not isinstance(self.history, (int, np.integer)) or self.history < 1:
            raise ValueError(f"ActuatorNet.history must be an integer >= 1 [simulation steps], got {self.history!r}")

    @property
    def name(self) -> str:
        """The network's name for messages: its class's (a module) or its qualified name (a function)."""
        return getattr(self.network, "__qualname__", None) or type(self.network).__name__


class Actuation:
    """A LeggedEnv's actuation of mode "pd" (the targets as the model's actuators' ctrl), "torque" or an ActuatorNet
    (see the module docstring). `torques` (N, n) [N m]: those applied in the last simulation step ("torque", an
    ActuatorNet); with an ActuatorNet, `position_errors` and `velocities` (N, n, history) [rad, rad/s], the network's
    input history, newest first."""

    def __init__(self, mode, stepper, reset_data, decimation: int, default: torch.Tensor, torque_limit: torch.Tensor | None, use_graph):
        self.mode, self.decimation, self.torque_limit = mode, int(decimation), torque_limit
        self.stepper, self.default, self._ctrl = stepper, default, wp.to_torch(stepper.ctrl)
        N, n = stepper.batch_size, default.shape[0]
        kw = dict(device=default.device, dtype=default.dtype)
        self.torques = torch.zeros(N, n, **kw)
        self.inner = None
        if isinstance(mode, ActuatorNet):
            if stepper.substeps != 1:
                raise ValueError(f"an ActuatorNet steps a Stepper of one simulation step per call; this one takes {stepper.substeps}")
            if decimation > 1:
                self.inner = wd.simulation.Stepper(stepper.model, reset_data, substeps=1, use_graph=use_graph)
            self.position_errors = torch.zeros(N, n, mode.history, **kw)
            self.velocities = torch.zeros(N, n, mode.history, **kw)
        steppers = [s for s in (stepper, self.inner) if s is not None]
        self._forces = {id(s): wp.to_torch(s.joint_force_references) for s in steppers}
        self._joints = {id(d): (wp.to_torch(d.joint_positions_state), wp.to_torch(d.joint_velocities_state)) for s in steppers for d in s.buffers}

    def step(self, command: torch.Tensor) -> None:
        """One policy step of the environment's Stepper from `command` (N, n) = action_scale * action: torques
        [N m] ("torque") or target offsets from the default posture [rad] ("pd", an ActuatorNet)."""
        if self.mode == "pd":
            self._ctrl.copy_(self.default + command)
            self.stepper.step()
            return
        if self.mode == "torque":
            torques = command if self.torque_limit is None else command.clamp(-self.torque_limit, self.torque_limit)
            self._forces[id(self.stepper)].copy_(torques)
            self.torques.copy_(torques)
            self.stepper.step()
            return
        targets = self.default + command
        if self.inner is not None:
            self.inner.set_state(self.stepper.data)
            for _ in range(self.decimation - 1):
                self._apply(targets, self.inner)
                self.inner.step()
            self.stepper.set_state(self.inner.data)
        self._apply(targets, self.stepper)
        self.stepper.step()

    def _apply(self, targets: torch.Tensor, stepper) -> None:
        """The network's torques at `stepper`'s current state into its joint_force_references; the history shifted."""
        s, sdot = self._joints[id(stepper.data)]
        for history, newest in ((self.position_errors, targets - s), (self.velocities, sdot)):
            history.copy_(torch.roll(history, 1, dims=2))
            history[:, :, 0] = newest
        inputs = torch.cat([self.position_errors, self.velocities], dim=2)
        with torch.no_grad():
            out = self.mode.network(inputs)
        N, n = self.torques.shape
        if not isinstance(out, torch.Tensor) or tuple(out.shape) not in ((N, n), (N, n, 1)):
            got = f"shape {tuple(out.shape)}" if isinstance(out, torch.Tensor) else type(out).__name__
            raise ValueError(
                f"the ActuatorNet's network {self.mode.name} returned {got} from its input {tuple(inputs.shape)} (environments, joints, "
                f"2 x history {self.mode.history}); joint torques ({N}, {n}) or ({N}, {n}, 1) are needed"
            )
        torques = out.reshape(N, n).to(self.torques.dtype)
        if self.torque_limit is not None:
            torques = torques.clamp(-self.torque_limit, self.torque_limit)
        self._forces[id(stepper)].copy_(torques)
        self.torques.copy_(torques)

    def joint_torques(self, state, kp: float, kd: float) -> torch.Tensor:
        """The joint torques (N, n) [N m] at `state` (warpdyn.envs.terms.State) after a step: "pd", the servo's
        kp (target - s) clipped at torque_limit less the damper's kd sdot; else the torques of the last simulation
        step."""
        if self.mode != "pd":
            return self.torques.clone()
        servo = kp * (self._ctrl - state.joint_positions)
        if self.torque_limit is not None:
            servo = servo.clamp(-self.torque_limit, self.torque_limit)
        return servo - kd * state.joint_velocities

    def reset(self, mask: torch.Tensor) -> None:
        """Empty the history and the torques of the environments where `mask` (bool (N,))."""
        self.torques.masked_fill_(mask[:, None], 0.0)
        if isinstance(self.mode, ActuatorNet):
            self.position_errors.masked_fill_(mask[:, None, None], 0.0)
            self.velocities.masked_fill_(mask[:, None, None], 0.0)


def torque_limits(limit, model) -> np.ndarray | None:
    """(n,) [N m] per joint of LeggedEnvConfig.torque_limit (a number, or {joint: N m} with inf where a joint is not
    named), None for none; a ValueError names a joint the model lacks."""
    if limit is None:
        return None
    names = model.joint_names()
    if not isinstance(limit, dict):
        return np.full(len(names), float(limit))
    unknown = sorted(set(limit) - set(names))
    if unknown:
        raise ValueError(f"LeggedEnvConfig.torque_limit names joints {unknown} that '{model.name()}' does not have (its joints: {', '.join(names)})")
    return np.array([float(limit.get(name, np.inf)) for name in names])
