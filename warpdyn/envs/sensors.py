"""An inertial measurement unit on the base, or on another link, of `warpdyn.envs.LeggedEnv` (`LeggedEnvConfig.imu`):
what a real IMU reads, with white noise and a bias per environment (Isaac Lab's and legged_gym's noise models).

    cfg = envs.LeggedEnvConfig(imu=ImuConfig(accelerometer_noise=0.05, gyroscope_noise=0.01, gyroscope_bias=0.02))
    env.imu.linear_acceleration     # (N, 3) [m/s^2] the accelerometer's specific force in the IMU's axes
    env.imu.angular_velocity        # (N, 3) [rad/s] the gyroscope's reading in the IMU's axes

The accelerometer reads the specific force f = R_WI^T (a_I - g): the IMU point's acceleration a_I less gravity g
(the model's `world_gravity`), in the IMU's axes; at rest on flat ground it reads +|g| along the base's up axis,
in free fall zero. The gyroscope reads R_WI^T omega. Each reading is true value + bias + N(0, noise^2) per axis,
the noise drawn afresh at each reading (each policy step, each reset), the bias drawn per environment at each of
its resets and held over its episode.

Where the acceleration comes from: the base's velocity change over the last simulation step of the policy step,
(v(t) - v(t - dt)) / dt with dt = `LeggedEnvConfig.time_step`, read from the Stepper's two state buffers (the
current state and the one the last step started from): the velocity change that step made, so the acceleration
the integrator applied (exactly with MuJoCo's base step, SemiImplicitEulerSO3, which integrates the Mixed velocity;
to O(dt) with JaxSim's, LeggedEnv's, which integrates the Inertial one and adds omega x p; exactly in either at rest
and in free fall), in the same step whose contact forces `Stepper.contact_wrenches` samples, at no cost: no other
dynamics evaluation (a forward-dynamics call at the end state would need its contact forces and torques again).
Isaac Lab's IMU takes the same finite difference over its physics step. A difference over the whole policy step
would instead average the acceleration over `decimation` steps (smoothing impacts). After a reset, the acceleration
is taken as zero (the sensor at rest) until the next step.

On another link (`ImuConfig.link`), the IMU's frame (the link's pose composed with `offset` and `rotation`) is posed
and its point's velocity computed at the current state and at the state one simulation step before
(`wd.link.FrameMotion`, a kinematics pass per state, into fixed buffers), and the accelerometer reads the
difference of the IMU point's velocities over that step, (v_I(t) - v_I(t - dt)) / dt, less gravity, in the IMU's
axes at t; the gyroscope the link's angular velocity in them.
"""

from __future__ import annotations

import dataclasses
import math
import numbers

import torch
import warp as wp

import warpdyn as wd
from .terms import quat_rotate, quat_rotate_inverse

__all__ = ["ImuConfig", "Imu"]

BIAS_DISTRIBUTIONS = ("gaussian", "uniform")


@dataclasses.dataclass(frozen=True)
class ImuConfig:
    """An IMU fixed to the base, or to the link named `link` (None: the base). `offset` (3,) [m]: its position in that
    link's frame; `rotation` (w, x, y, z): the unit quaternion of its axes in that frame (R_LI). White noise: standard deviations `accelerometer_noise`
    [m/s^2] and `gyroscope_noise` [rad/s] per axis and reading. Bias per environment and axis, drawn at each reset:
    `bias_distribution` "gaussian" (N(0, b^2), b the bias field) or "uniform" (U(-b, b)), `accelerometer_bias`
    [m/s^2] and `gyroscope_bias` [rad/s]."""

    offset: tuple = (0.0, 0.0, 0.0)
    rotation: tuple = (1.0, 0.0, 0.0, 0.0)
    accelerometer_noise: float = 0.0
    gyroscope_noise: float = 0.0
    accelerometer_bias: float = 0.0
    gyroscope_bias: float = 0.0
    bias_distribution: str = "gaussian"
    link: str | None = None

    def __post_init__(self):
        if self.link is not None and not (isinstance(self.link, str) and self.link):
            raise TypeError(f"ImuConfig.link must be a link's name or None (the base), got {self.link!r}")
        for name, size in (("offset", 3), ("rotation", 4)):
            value = getattr(self, name)
            if not (isinstance(value, (tuple, list)) and len(value) == size and all(_is_real(v) and math.isfinite(v) for v in value)):
                raise ValueError(f"ImuConfig.{name} must be {size} finite numbers, got {value!r}")
            object.__setattr__(self, name, tuple(float(v) for v in value))
        if abs(math.sqrt(sum(v * v for v in self.rotation)) - 1.0) > 1e-6:
            raise ValueError(f"ImuConfig.rotation must be a unit quaternion (w, x, y, z), got {self.rotation!r}")
        for name in ("accelerometer_noise", "gyroscope_noise", "accelerometer_bias", "gyroscope_bias"):
            value = getattr(self, name)
            if not (_is_real(value) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"ImuConfig.{name} must be a finite number >= 0, got {value!r}")
        if self.bias_distribution not in BIAS_DISTRIBUTIONS:
            raise ValueError(f"ImuConfig.bias_distribution must be one of {BIAS_DISTRIBUTIONS}, got {self.bias_distribution!r}")


def _is_real(value) -> bool:
    """A real number (NumPy's included), not a bool."""
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


class Imu:
    """The IMU's readings and biases, torch tensors (N, 3) on the environment's device, in the IMU's axes:
    `linear_acceleration` [m/s^2] and `angular_velocity` [rad/s] (what the sensor reads: true + bias + noise),
    `true_linear_acceleration` and `true_angular_velocity` (noise- and bias-free: a privileged critic's),
    `accelerometer_bias` and `gyroscope_bias` (this episode's). LeggedEnv calls `reset(mask)` at resets and
    `sense(...)` after each step and reset (`read` for an IMU on the base); the random numbers come from the environment's generator."""

    def __init__(self, config: ImuConfig, num_envs: int, time_step: float, generator: torch.Generator, device, dtype, model=None):
        self.config, self.time_step, self._generator = config, float(time_step), generator
        self._motion = None  # on another link than the base: its frame's motion now and one step before
        if config.link is not None:
            if model is None:
                raise ValueError(f"an IMU on link {config.link!r} needs the model (Imu(..., model=...)) to find that link")
            names = model.link_names()
            if config.link not in names:
                raise ValueError(f"ImuConfig.link {config.link!r} is not a link of model {model.name()!r}; its links: {list(names)}")
            index = names.index(config.link)
            if index > 0:
                frame = dict(link_index=index, position=config.offset, quaternion=config.rotation, num_envs=num_envs)
                self._motion = (wd.link.FrameMotion(model, **frame), wd.link.FrameMotion(model, **frame))
        kw = dict(device=device, dtype=dtype)
        self._offset = torch.tensor(config.offset, **kw)
        self._rotation = torch.tensor(config.rotation, **kw)
        zeros = [torch.zeros(num_envs, 3, **kw) for _ in range(6)]
        self.linear_acceleration, self.angular_velocity, self.true_linear_acceleration, self.true_angular_velocity = zeros[:4]
        self.accelerometer_bias, self.gyroscope_bias = zeros[4:]

    def reset(self, mask: torch.Tensor) -> None:
        """New biases for the environments where `mask` (bool (N,)), drawn from the configured distribution."""
        for bias, scale in ((self.accelerometer_bias, self.config.accelerometer_bias), (self.gyroscope_bias, self.config.gyroscope_bias)):
            if scale == 0.0:
                continue
            if self.config.bias_distribution == "gaussian":
                draw = torch.randn(bias.shape, generator=self._generator, device=bias.device, dtype=bias.dtype) * scale
            else:
                draw = (2.0 * torch.rand(bias.shape, generator=self._generator, device=bias.device, dtype=bias.dtype) - 1.0) * scale
            bias.copy_(torch.where(mask[:, None], draw, bias))

    def sense(self, now, before, quaternion: torch.Tensor, velocities: tuple, gravity: torch.Tensor, mask=None) -> None:
        """The readings after a step: `now` and `before` the data at the current state and one simulation step
        earlier (the same at a reset), quaternion W_Q_B (N, 4) and velocities (now, before) (N, 6) the base's (Mixed,
        torch views of those data), gravity (1, 3) or (N, 3) [m/s^2]; written where `mask`, everywhere for None."""
        if self._motion is None:
            self.read(quaternion, *velocities, gravity, mask)
            return
        W_H_I, v_now = (wp.to_torch(a) for a in self._motion[0](now))
        v_before = v_now if before is now else wp.to_torch(self._motion[1](before)[1])  # at a reset: at rest
        R = W_H_I[:, :3, :3]  # W_R_I: the IMU's axes in the world
        acceleration = (v_now[:, :3] - v_before[:, :3]) / self.time_step
        in_imu = [torch.einsum("nji,nj->ni", R, vector) for vector in (acceleration - gravity, v_now[:, 3:])]
        self._measure(*in_imu, mask)

    def read(self, quaternion: torch.Tensor, velocity: torch.Tensor, previous_velocity: torch.Tensor, gravity: torch.Tensor, mask=None) -> None:
        """The readings of an IMU on the base at its unit quaternion W_Q_B (N, 4) and Mixed velocity [W_pdot_B; W_omega]
        (N, 6) [m/s, rad/s], the one a simulation step of `time_step` before (N, 6) (the same where the sensor is at
        rest), and the world's gravity (1, 3) or (N, 3) [m/s^2]; written where `mask` (bool (N,)), everywhere for None."""
        dt = self.time_step
        omega = velocity[:, 3:]
        acceleration = (velocity[:, :3] - previous_velocity[:, :3]) / dt
        if self.config.offset != (0.0, 0.0, 0.0):  # the IMU point: a_I = a_B + alpha x r + omega x (omega x r)
            alpha = (omega - previous_velocity[:, 3:]) / dt
            r = quat_rotate(quaternion, self._offset.expand(omega.shape[0], 3))  # in world axes
            acceleration = acceleration + torch.cross(alpha, r, dim=1) + torch.cross(omega, torch.cross(omega, r, dim=1), dim=1)
        mount = self._rotation.expand(omega.shape[0], 4)
        in_imu = [quat_rotate_inverse(mount, quat_rotate_inverse(quaternion, vector)) for vector in (acceleration - gravity, omega)]
        self._measure(*in_imu, mask)

    def _measure(self, specific_force: torch.Tensor, angular_velocity: torch.Tensor, mask) -> None:
        """The true values (N, 3) in the IMU's axes, plus bias and noise, into the readings where `mask`."""
        in_imu = (specific_force, angular_velocity)
        pairs = ((self.true_linear_acceleration, self.linear_acceleration, self.accelerometer_bias, self.config.accelerometer_noise),
                 (self.true_angular_velocity, self.angular_velocity, self.gyroscope_bias, self.config.gyroscope_noise))  # fmt: skip
        for value, (true, reading, bias, noise) in zip(in_imu, pairs):
            measured = value + bias
            if noise > 0.0:
                measured = measured + noise * torch.randn(value.shape, generator=self._generator, device=value.device, dtype=value.dtype)
            if mask is not None:
                value, measured = torch.where(mask[:, None], value, true), torch.where(mask[:, None], measured, reading)
            true.copy_(value)
            reading.copy_(measured)
