"""Observation and reward terms of `warpdyn.envs.LeggedEnv`: functions of the environment's current state,
each returning a torch tensor (N,) or (N, k) on the environment's device, computed with torch ops (no host
synchronisation). A term reads `env.state` (`State`: the base and joint state, with the base velocities
in the base frame and gravity projected into it), `env.actions`, `env.previous_actions`, `env.commands`,
the feet's `env.feet_contact`, `env.feet_first_contact` and `env.feet_air_time` (N, feet) and contact forces
`env.feet_contact_forces` (N, feet, 3) [N], `env.terrain_below_base` (N,) [m], `env.imu` (the IMU's readings), and
`env.joint_torques` (what the environment's own servos and dampers apply: kp (target - s) clipped at
cfg.torque_limit, minus kd sdot; with cfg.actuator "torque" or an ActuatorNet, the torques of the last simulation
step); a task composes them with weights
(`LeggedEnvConfig.rewards`, `.observations`).
"""

from __future__ import annotations

import dataclasses
import math

import torch

__all__ = [
    "State",
    "quat_rotate",
    "quat_rotate_inverse",
    "quat_multiply",
    "quat_to_matrix",
    "base_height",
    "height_above_terrain",
    "imu_linear_acceleration",
    "imu_angular_velocity",
    "height_scan",
    "projected_gravity",
    "base_linear_velocity",
    "base_angular_velocity",
    "joint_positions",
    "joint_velocities",
    "actions",
    "commands",
    "heading_yaw_rate",
    "track_linear_velocity",
    "track_angular_velocity",
    "upright",
    "height_error",
    "torque_squared",
    "action_rate",
    "joint_velocity_squared",
    "vertical_velocity_squared",
    "alive",
    "undesired_contacts",
    "stumbling",
    "height_above_terrain_error",
    "feet_contact",
    "feet_air_time",
    "angular_velocity_xy_squared",
]


def quat_rotate(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """R(q) v for unit quaternions q (N, 4) as (w, x, y, z) and vectors v (N, 3)."""
    w, u = q[:, :1], q[:, 1:]
    return v * (2.0 * w * w - 1.0) + 2.0 * w * torch.cross(u, v, dim=1) + 2.0 * u * (u * v).sum(dim=1, keepdim=True)


def quat_rotate_inverse(q: torch.Tensor, v: torch.Tensor) -> torch.Tensor:
    """R(q)^T v for unit quaternions q (N, 4) as (w, x, y, z) and vectors v (N, 3)."""
    w, u = q[:, :1], q[:, 1:]
    return v * (2.0 * w * w - 1.0) - 2.0 * w * torch.cross(u, v, dim=1) + 2.0 * u * (u * v).sum(dim=1, keepdim=True)


def quat_multiply(p: torch.Tensor, q: torch.Tensor) -> torch.Tensor:
    """The products p q (N, 4) of quaternions (N, 4) as (w, x, y, z): the rotation q, then p."""
    pw, pv, qw, qv = p[:, :1], p[:, 1:], q[:, :1], q[:, 1:]
    return torch.cat([pw * qw - (pv * qv).sum(dim=1, keepdim=True), pw * qv + qw * pv + torch.cross(pv, qv, dim=1)], dim=1)


def quat_to_matrix(q: torch.Tensor) -> torch.Tensor:
    """Rotation matrices (N, 3, 3) of unit quaternions (N, 4) (w, x, y, z): the turned axes as columns."""
    axes = torch.eye(3, dtype=q.dtype, device=q.device)
    return torch.stack([quat_rotate(q, axes[j].expand(q.shape[0], 3)) for j in range(3)], dim=2)


@dataclasses.dataclass
class State:
    """The environments' state as torch tensors (N, ...): W_p_B [m], W_Q_B (w, x, y, z), s [rad], sdot [rad/s],
    B_v (the base origin's velocity in base axes) [m/s], B_omega [rad/s], gravity's direction in base axes,
    and the health flags (1 valid)."""

    base_position: torch.Tensor
    base_quaternion: torch.Tensor
    joint_positions: torch.Tensor
    joint_velocities: torch.Tensor
    base_linear_velocity: torch.Tensor
    base_angular_velocity: torch.Tensor
    projected_gravity: torch.Tensor
    valid: torch.Tensor


# ------------------------------------------------------------------------------------------ observations


def base_height(env) -> torch.Tensor:
    """The base's height above its environment's origin (the ground, or its terrain tile's centre) [m] (N, 1)."""
    return (env.state.base_position[:, 2] - env.terrain_height)[:, None]


def height_scan(env) -> torch.Tensor:
    """The base's height above the terrain at each point of the environment's height scan, less 0.5 m, clipped to
    [-1, 1] [m] (N, P): Isaac Lab's observation (LeggedEnvConfig.height_scan must be set)."""
    if env.height_scan is None:
        raise ValueError("terms.height_scan observes the environment's height scan: set LeggedEnvConfig.height_scan")
    return (env.state.base_position[:, 2:3] - env.height_scan - 0.5).clamp(-1.0, 1.0)


def height_above_terrain(env) -> torch.Tensor:
    """The base's height above the terrain right under its origin [m] (N, 1): base z - h(base x, base y)
    (`env.terrain_below_base`), on any terrain (flat ground, a generated or a given heightfield)."""
    return (env.state.base_position[:, 2] - env.terrain_below_base)[:, None]


def imu_linear_acceleration(env) -> torch.Tensor:
    """The IMU's accelerometer: specific force (acceleration less gravity) in its axes [m/s^2] (N, 3), with its
    bias and noise (LeggedEnvConfig.imu, warpdyn.envs.sensors); +|g| up at rest."""
    return _imu(env).linear_acceleration


def imu_angular_velocity(env) -> torch.Tensor:
    """The IMU's gyroscope: angular velocity in its axes [rad/s] (N, 3), with its bias and noise."""
    return _imu(env).angular_velocity


def _imu(env):
    if env.imu is None:
        raise ValueError("the IMU terms read the environment's IMU: set LeggedEnvConfig.imu (a warpdyn.envs.sensors.ImuConfig)")
    return env.imu


def projected_gravity(env) -> torch.Tensor:
    return env.state.projected_gravity


def base_linear_velocity(env) -> torch.Tensor:
    return env.state.base_linear_velocity


def base_angular_velocity(env) -> torch.Tensor:
    return env.state.base_angular_velocity


def joint_positions(env) -> torch.Tensor:
    """s - s_default."""
    return env.state.joint_positions - env.default_joint_positions


def joint_velocities(env) -> torch.Tensor:
    return env.state.joint_velocities


def actions(env) -> torch.Tensor:
    """The last actions the policy gave (clipped)."""
    return env.actions


def feet_contact(env) -> torch.Tensor:
    """1 for each foot (`env.feet`) whose normal contact force exceeds cfg.contact_force_threshold, else 0."""
    return env.feet_contact.to(torch.float32)


def commands(env) -> torch.Tensor:
    """(vx, vy, yaw rate) wanted, in the base's heading frame [m/s, m/s, rad/s]."""
    return env.commands


def heading_yaw_rate(env) -> torch.Tensor:
    """legged_gym's heading command: 0.5 x the error from the base's heading (the yaw of its x axis, atan2 of the
    rotation's (1, 0) and (0, 0) entries) to env.heading, wrapped to [-pi, pi), clipped to cfg.yaw_rate's range
    [rad/s] (N,). Torch operations on device tensors only: it runs inside the captured step."""
    w, x, y, z = env.state.base_quaternion.unbind(1)
    yaw = torch.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))
    error = torch.remainder(env.heading - yaw + math.pi, 2.0 * math.pi) - math.pi
    return (0.5 * error).clamp(*env.cfg.yaw_rate).to(env.commands.dtype)


# ------------------------------------------------------------------------------------------ rewards


def track_linear_velocity(env) -> torch.Tensor:
    """exp(-|v_cmd - B_v|^2 / sigma) over x, y: 1 when the command is followed."""
    error = (env.commands[:, :2] - env.state.base_linear_velocity[:, :2]).square().sum(dim=1)
    return torch.exp(-error / env.cfg.tracking_sigma)


def track_angular_velocity(env) -> torch.Tensor:
    error = (env.commands[:, 2] - env.state.base_angular_velocity[:, 2]).square()
    return torch.exp(-error / env.cfg.tracking_sigma)


def upright(env) -> torch.Tensor:
    """|g_xy|^2 in base axes: 0 upright (a penalty: give it a negative weight)."""
    return env.state.projected_gravity[:, :2].square().sum(dim=1)


def height_error(env) -> torch.Tensor:
    """(base height above the environment's origin - cfg.base_height_target)^2 [m^2]: flat ground's."""
    return (env.state.base_position[:, 2] - env.terrain_height - env.cfg.base_height_target).square()


def height_above_terrain_error(env) -> torch.Tensor:
    """(base height above the terrain right under it - cfg.base_height_target)^2 [m^2] (N,): Rudin et al.'s
    `base_height` penalty on rough terrain. The terrain under the base's origin, not legged_gym's mean over its
    height scan: exact for any terrain, no scan needed; the mean over a 1.6 x 1.0 m grid mixes in the ground the
    feet stand on, and ahead of them (on stairs, the next steps)."""
    return (env.state.base_position[:, 2] - env.terrain_below_base - env.cfg.base_height_target).square()


def torque_squared(env) -> torch.Tensor:
    return env.joint_torques.square().sum(dim=1)


def action_rate(env) -> torch.Tensor:
    return (env.actions - env.previous_actions).square().sum(dim=1)


def joint_velocity_squared(env) -> torch.Tensor:
    return env.state.joint_velocities.square().sum(dim=1)


def vertical_velocity_squared(env) -> torch.Tensor:
    return env.state.base_linear_velocity[:, 2].square()


def angular_velocity_xy_squared(env) -> torch.Tensor:
    """|B_omega_xy|^2: the base's roll and pitch rates (a penalty)."""
    return env.state.base_angular_velocity[:, :2].square().sum(dim=1)


def feet_air_time(env) -> torch.Tensor:
    """Sum over the feet touching down in this step of (their air time - cfg.air_time_target) [s], while a
    planar velocity above 0.1 m/s is commanded (Rudin et al. 2021): rewards steps of at least that length."""
    steps = ((env.feet_air_time - env.cfg.air_time_target) * env.feet_first_contact).sum(dim=1)
    return steps * (env.commands[:, :2].norm(dim=1) > 0.1)


def undesired_contacts(env) -> torch.Tensor:
    """The number of LeggedEnvConfig.undesired_contacts links touching the terrain (normal force above
    cfg.contact_force_threshold): Isaac Lab's and Rudin et al.'s penalty on thighs, shanks and base (N,)."""
    return env.undesired_contact.sum(dim=1).to(torch.float32)


def stumbling(env) -> torch.Tensor:
    """1 where a foot's horizontal contact force exceeds cfg.stumble_ratio (5: legged_gym's) times its vertical
    one, else 0 (N,): the foot hits a vertical face (a stair's riser, an obstacle's side), Rudin et al.'s penalty.
    Each foot's force is the sum over its points (`env.feet_contact_forces`, world axes)."""
    force = env.feet_contact_forces
    return (force[..., :2].norm(dim=-1) > env.cfg.stumble_ratio * force[..., 2].abs()).any(dim=1).to(torch.float32)


def alive(env) -> torch.Tensor:
    return torch.ones_like(env.state.base_position[:, 0])
