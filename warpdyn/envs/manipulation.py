"""A batched manipulation environment: the Franka Panda picking up a cube and bringing it to a target, after MuJoCo
Playground's PandaPickCube (its scene, `wd.assets.franka_panda_cube_mjcf()`; its actions, observations, rewards,
resets and terminations), on a `wd.simulation.Stepper` with the contacts between the fingertip pads and the cube
acting (model.geom_contacts) and their static friction holding the grasp.

    env = envs.PickCubeEnv(num_envs=4096, device="cuda:0")
    obs, info = env.reset(seed=0)                                   # torch (N, 66) float32
    obs, reward, terminated, truncated, info = env.step(actions)    # actions (N, 8) in [-1, 1]
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import torch
import warp as wp
from gymnasium.vector import AutoresetMode

import warpdyn as wd

from .terms import quat_to_matrix
from .vector_env import DIVERGENCE_SPEED, DeviceVectorEnv, check_divergence_speed

__all__ = ["PickCubeConfig", "PickCubeEnv"]


@dataclasses.dataclass
class PickCubeConfig:
    """What `PickCubeEnv` simulates and rewards; units SI (s, m).

    Simulation: `time_step` [s] of the model's integrator (2 ms: Playground's 5 ms relies on MuJoCo's implicit
    integration of the servos and contacts) and `implicit_contacts` (model.implicit_contacts: the soft law's contacts
    linearly implicit; explicit, a pad that clips the cube's edge, as a policy's approaches do, drives the 0.1 kg
    cube's rotation past the explicit step's stable rate: over 24 scripted approaches a touched cube moved a median
    118 mm at 1 ms explicit and 2.4 mm at 0.5 ms explicit with D = 500 (MuJoCo 1.0 mm), and with D = 2000 0.8 mm at
    2 ms implicit, 148 mm at 1 ms explicit (MuJoCo 0.9 mm over that run's touched cubes): benchmarks/cube_clipping.py;
    tests/test_manipulation.py's pad-on-the-edge test; explicit contacts need D = 500 and 0.5 ms), `limit_constraints`
    and `frictionloss_constraints` (model's: the joints' limits and frictionloss as MuJoCo's constraints; off by
    default: the trained figures of benchmarks/RESULTS.md were measured without them), `policy_dt` [s] per action
    (Playground's ctrl_dt), the soft law's `contact_stiffness` K [N/m^1.5] and `contact_damping` D [N s/m^1.5]
    (D = 2000: at 2 ms the tangential deformation needs dt K / D < 2; explicit contacts would want D = 500 at 1 ms),
    `friction` the terrain's (the floor's) Coulomb coefficient (MuJoCo's cube-floor friction, 1), `divergence_speed`
    [m/s or rad/s] the model's (vector_env.DIVERGENCE_SPEED; inf: off). Task: an action adds `action_scale` times itself (clipped to [-1, 1]) to each of the 8 controls
    (the 7 joints' position targets [rad] and the gripper's opening [m]), clipped to their ranges; episodes of
    `episode_seconds`; the cube starts on the floor `cube_range` [m] around the keyframe `keyframe`'s cube in x and y,
    the target `target_low` to `target_high` [m] from there. `rewards`: name -> scale of the terms (Playground's
    gripper_box 1 - tanh(5 |cube - gripper|), box_target 1 - tanh(5 (0.9 |target - cube| + 0.1 rotation error)) once
    the gripper came within `reach_distance` of the cube, no_floor_collision, robot_target_qpos 1 - tanh(|arm -
    arm at the keyframe|)); the reward is their scaled sum (not times the policy step). An episode ends where the
    cube leaves the box |x|, |y|, |z| <= 1 m or falls below the floor, or the state stops being finite. A step's
    info["log"] holds the terms' means, "success": the fraction of environments whose cube is within
    `success_distance` [m] of its target, and "reached": the fraction whose gripper came within reach_distance of
    the cube this episode (box_target's gate)."""

    time_step: float = 0.002
    policy_dt: float = 0.02
    episode_seconds: float = 3.0
    action_scale: float = 0.04
    contact_stiffness: float = 5e5
    contact_damping: float = 2000.0
    implicit_contacts: bool = True
    limit_constraints: bool = False
    frictionloss_constraints: bool = False
    friction: float = 1.0
    keyframe: str = "home"
    cube_range: float = 0.2
    target_low: tuple = (-0.2, -0.2, 0.2)
    target_high: tuple = (0.2, 0.2, 0.4)
    reach_distance: float = 0.012
    success_distance: float = 0.05
    rewards: dict = dataclasses.field(default_factory=lambda: {"gripper_box": 4.0, "box_target": 8.0, "no_floor_collision": 0.25, "robot_target_qpos": 0.3})
    divergence_speed: float = DIVERGENCE_SPEED

    def validate(self) -> None:
        """A ValueError naming the field whose value is not what it must be."""
        for name in ("time_step", "policy_dt", "episode_seconds", "action_scale", "contact_stiffness", "contact_damping", "reach_distance", "success_distance"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value > 0.0):
                raise ValueError(f"PickCubeConfig.{name} must be a positive finite number, got {value!r}")
        for name in ("friction", "cube_range"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and value >= 0.0):
                raise ValueError(f"PickCubeConfig.{name} must be a finite number >= 0, got {value!r}")
        if not isinstance(self.implicit_contacts, bool):
            raise ValueError(f"PickCubeConfig.implicit_contacts must be True or False, got {self.implicit_contacts!r}")
        for name in ("limit_constraints", "frictionloss_constraints"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"PickCubeConfig.{name} must be True or False, got {getattr(self, name)!r}")
        check_divergence_speed("PickCubeConfig", self.divergence_speed)
        low, high = np.asarray(self.target_low, dtype=float), np.asarray(self.target_high, dtype=float)
        if low.shape != (3,) or high.shape != (3,) or not (np.all(np.isfinite(low)) and np.all(low <= high)):
            raise ValueError(f"PickCubeConfig.target_low and target_high must be 3 finite numbers each, low <= high, got {self.target_low!r}, {self.target_high!r}")
        ratio = self.policy_dt / self.time_step
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(f"PickCubeConfig.policy_dt ({self.policy_dt} s) must be a whole number of time_step ({self.time_step} s)")
        unknown = sorted(set(self.rewards) - set(_TERMS))
        if unknown or not all(isinstance(v, (int, float)) and math.isfinite(v) for v in self.rewards.values()):
            raise ValueError(f"PickCubeConfig.rewards maps terms of {list(_TERMS)} to finite scales, got {self.rewards!r}")


_TERMS = ("gripper_box", "box_target", "no_floor_collision", "robot_target_qpos")
_ARM = tuple(f"joint{i}" for i in range(1, 8))
_FINGERS = ("finger_joint1", "finger_joint2")
_HAND_LINKS = ("link7", "left_finger", "right_finger")  # the hand's capsule is on link7 (the hand is lumped into it)


class PickCubeEnv(DeviceVectorEnv):
    """N environments of the Panda and its cube (`wd.assets.franka_panda_cube_mjcf()`, or `model`: a model of that
    scene), stepped in place on the device, Gymnasium's vector API with SAME_STEP autoreset and torch tensors as
    `LeggedEnv` (its docstring says what a step returns and how a GPU captures it). Observations (66,), float32,
    Playground's: the joint positions (16: the cube's free joint, then the arm's and fingers') and velocities (15),
    the gripper's position (3) and its rotation matrix's last six entries, the cube's likewise (6), the cube from
    the gripper (3), the target from the cube (3), the target's rotation (identity) less the cube's, first six
    entries (6), and the controls less the joints they drive (8). Without `model` the scene is loaded on `device` in
    `dtype`; `seed` seeds the resets' draws. Tensors (N, ...) kept: `target` [m] (each episode's), `cube_position`
    [m] (the cube after the last step, before that step's resets), `reached` (the gripper came within
    reach_distance of the cube this episode)."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int, cfg: PickCubeConfig | None = None, *, model=None, device=None, dtype=np.float32, seed: int = 0, use_graph="auto"):
        self._setup(num_envs, cfg, PickCubeConfig, model, wd.assets.franka_panda_cube_mjcf, dtype, device, seed, use_graph)
        cfg, model, N = self.cfg, self.model, self.num_envs
        kw = dict(device=self.device, dtype=self.torch_dtype)
        # addresses: the cube's free joint and the robot's joints in the joint positions; the controls' joints
        names = model.joint_names()
        cube_link = model.link_names().index("box")
        self._cube = wd.joint.position_slice(model, joint_index=cube_link - 1).start  # link i's joint is joint i - 1
        self._arm = torch.tensor([wd.joint.position_slice(model, joint_index=names.index(j)).start for j in _ARM], device=self.device)
        self._driven = torch.tensor([wd.joint.position_slice(model, joint_index=names.index(j)).start for j in (*_ARM, _FINGERS[0])], device=self.device)
        # the keyframe's state and controls: what resets copy from
        key = next(k for k in model.description.keyframes if k.name == cfg.keyframe)
        self._reset_data = wd.data.keyframe(model, cfg.keyframe, num_envs=N)
        self.stepper = wd.simulation.Stepper(model, self._reset_data, substeps=self.decimation, use_graph=False if model.device.is_cuda else use_graph and "auto")
        self._ctrl = wp.to_torch(self.stepper.ctrl)
        self._home_ctrl = torch.tensor(np.asarray(key.ctrl, dtype=np.float64), **kw)
        self._ctrl.copy_(self._home_ctrl.expand(N, -1))
        ranges = model.actuator_ctrl_range.numpy()
        if ranges.ndim != 2:
            raise ValueError(f"PickCubeEnv clips the controls to one range per actuator; model.actuator_ctrl_range has shape {ranges.shape} (per environment)")
        limits = torch.tensor(ranges, **kw)
        self._low, self._high = limits[:, 0], limits[:, 1]
        self._reset_views = self._views(self._reset_data)
        self._state_views = {id(d): self._views(d) for d in self.stepper.buffers}
        self._home = self._reset_views["joint_positions"][0].clone()
        self._home_cube = self._home[self._cube : self._cube + 3].clone()
        self._target_low, self._target_high = torch.tensor(cfg.target_low, **kw), torch.tensor(cfg.target_high, **kw)
        self._gripper = wd.link.FrameMotion(model, num_envs=N, **_gripper_frame(model))
        self._hand_points = _points_of(self.stepper, _HAND_LINKS, self.device)
        # buffers
        self.target = torch.zeros(N, 3, **kw)
        self.cube_position = torch.zeros(N, 3, **kw)
        self.reached = torch.zeros(N, dtype=torch.bool, device=self.device)
        self._action_input = torch.zeros(N, 8, device=self.device, dtype=torch.float32)
        self._finish_setup(observations=66, actions=8)

    def _simulated(self, model):
        """A copy of `model` with the pads' contacts acting and the task's time step and soft law."""
        cfg = self.cfg
        missing = sorted({"box", *_HAND_LINKS} - set(model.link_names())) + sorted(set(_ARM + _FINGERS) - set(model.joint_names()))
        if missing or model.number_of_actuators() != 8 or cfg.keyframe not in model.keyframe_names():
            raise ValueError(
                f"PickCubeEnv simulates wd.assets.franka_panda_cube_mjcf()'s scene: '{model.name()}' lacks {missing or 'nothing named'}, "
                f"has {model.number_of_actuators()} actuators (8 needed) and keyframes {list(model.keyframe_names())} (needs '{cfg.keyframe}')"
            )
        return self._with_body_contacts(model)

    def _views(self, data) -> dict:
        return {name: wp.to_torch(getattr(data, f"{name}_state")) for name in ("joint_positions", "joint_velocities", "valid")}

    def _frames(self) -> tuple:
        """(gripper position (N, 3), gripper rotation (N, 3, 3), cube position (N, 3), cube rotation (N, 3, 3)) [m,
        world] at the current state."""
        W_H_G = wp.to_torch(self._gripper(self.stepper.data)[0])
        q = self._state_views[id(self.stepper.data)]["joint_positions"]
        cube = q[:, self._cube : self._cube + 7]
        return W_H_G[:, :3, 3], W_H_G[:, :3, :3], cube[:, :3], quat_to_matrix(cube[:, 3:] / cube[:, 3:].norm(dim=1, keepdim=True))

    def _observe(self, frames) -> torch.Tensor:
        gripper, R_G, cube, R_C = frames
        v = self._state_views[id(self.stepper.data)]
        q = v["joint_positions"]
        parts = [q, v["joint_velocities"], gripper, R_G.reshape(-1, 9)[:, 3:], R_C.reshape(-1, 9)[:, 3:], cube - gripper, self.target - cube,
                 _rotation_difference(R_C), self._ctrl - q[:, self._driven]]  # fmt: skip
        return torch.nan_to_num(torch.cat(parts, dim=1).to(torch.float32), nan=0.0, posinf=0.0, neginf=0.0)

    def _terms(self, frames) -> tuple:
        """({name: (N,)} Playground's reward terms at the current state, `reached` latched first; the cube's distance
        to its target (N,) [m]). The hand touches the floor where one of its collidable points pushes on the terrain
        (the Stepper's contact wrenches: at the start of the last simulation step)."""
        gripper, _, cube, R_C = frames
        reach = (cube - gripper).norm(dim=1)
        self.reached |= reach < self.cfg.reach_distance
        rotation_error = _rotation_difference(R_C).norm(dim=1)
        to_target = (self.target - cube).norm(dim=1)
        arm = self._state_views[id(self.stepper.data)]["joint_positions"][:, self._arm]
        W_f_C = wp.to_torch(self.stepper.contact_wrenches)
        on_floor = (W_f_C[:, self._hand_points, 2] > 0.0).any(dim=1)
        return {
            "gripper_box": 1.0 - torch.tanh(5.0 * reach),
            "box_target": (1.0 - torch.tanh(5.0 * (0.9 * to_target + 0.1 * rotation_error))) * self.reached,
            "no_floor_collision": (~on_floor).to(reach.dtype),
            "robot_target_qpos": 1.0 - torch.tanh((arm - self._home[self._arm]).norm(dim=1)),
        }, to_target

    def _advance(self) -> tuple:
        """One policy step from the actions in `_action_input`: (obs, reward, terminated, truncated, info)."""
        cfg = self.cfg
        delta = cfg.action_scale * torch.nan_to_num(self._action_input, nan=0.0).clamp(-1.0, 1.0).to(self.torch_dtype)
        self._ctrl.copy_(torch.minimum(torch.maximum(self._ctrl + delta, self._low), self._high))
        self.stepper.step()
        frames = self._frames()
        values, to_target = self._terms(frames)
        reward = sum((cfg.rewards[name] * values[name] for name in cfg.rewards), torch.zeros_like(to_target)).to(torch.float32).clamp(-1e4, 1e4)
        log = {f"/reward/{name}": value.to(torch.float32).mean() for name, value in values.items()}
        log["/success"] = (to_target < cfg.success_distance).to(torch.float32).mean()
        log["/reached"] = self.reached.to(torch.float32).mean()
        cube = frames[2]
        self.cube_position.copy_(cube)
        invalid = self._state_views[id(self.stepper.data)]["valid"] == 0
        terminated = invalid | (cube.abs() > 1.0).any(dim=1) | (cube[:, 2] < 0.0)
        reward = torch.where(invalid, torch.zeros_like(reward), torch.nan_to_num(reward, nan=0.0))
        self.episode_length_buf += 1
        truncated, done = self._end_episodes(terminated, reward)
        final = self._observe(frames)
        self._reset(done)
        obs = self._observe(self._frames())
        return obs, reward, terminated, truncated, {"final_obs": final, "_final_obs": done, "invalid": invalid, "log": log}

    def _reset(self, mask: torch.Tensor) -> None:
        """New cubes and targets, the keyframe's arm and controls, where `mask` (bool (N,))."""
        N, cfg = self.num_envs, self.cfg
        v = self._reset_views
        cube = self._home_cube + torch.cat([self._uniform(-cfg.cube_range, cfg.cube_range, (N, 2)), torch.zeros(N, 1, device=self.device, dtype=self.torch_dtype)], dim=1)
        q = self._home.expand(N, -1).clone()
        q[:, self._cube : self._cube + 3] = cube
        v["joint_positions"].copy_(q)
        v["joint_velocities"].zero_()
        self._reset_mask.copy_(mask.to(torch.int32))
        self.stepper.set_state(self._reset_data, envs=self._reset_mask_wp)
        target = self._home_cube + self._target_low + (self._target_high - self._target_low) * self._uniform(0.0, 1.0, (N, 3))
        self.target.copy_(torch.where(mask[:, None], target, self.target))
        self._ctrl.copy_(torch.where(mask[:, None], self._home_ctrl.expand(N, -1), self._ctrl))
        self.reached.masked_fill_(mask, False)
        self.episode_length_buf.masked_fill_(mask, 0)
        self._return.masked_fill_(mask, 0.0)

    def _first_observation(self) -> tuple:
        """(obs (N, 66), {}) after a reset of all."""
        return self._observe(self._frames()), {}

    def _take(self, actions: torch.Tensor) -> None:
        """Keep the actions (N, 8) for `_advance` (which clips them to [-1, 1], NaN as 0)."""
        self._action_input.copy_(actions)

    def _snapshot(self) -> tuple:
        """(the model's version, a copy of `cfg` that changes to it, also in place to its rewards, do not reach)."""
        return self.model.version, dataclasses.replace(self.cfg, rewards=dict(self.cfg.rewards))


def _rotation_difference(R: torch.Tensor) -> torch.Tensor:
    """(N, 6): the target's rotation (the identity) less R (N, 3, 3), their first six entries row by row
    (Playground's rotation error terms)."""
    return torch.eye(3, dtype=R.dtype, device=R.device).reshape(9)[:6] - R.reshape(-1, 9)[:, :6]


def _gripper_frame(model) -> dict:
    """FrameMotion's arguments for the scene's gripper site (Menagerie's, 0.1 m along the hand frame's z): the hand
    frame's link and the site's pose in that link."""
    hand = wd.frame.name_to_idx(model, frame_name="hand")
    X = model.link_H_frame.numpy()[hand - model.number_of_links()].astype(np.float64)  # (p, quaternion x y z w)
    quaternion = np.array([X[6], X[3], X[4], X[5]])
    position = X[:3] + np.asarray(wd.math.Quaternion.to_dcm(quaternion)) @ np.array([0.0, 0.0, 0.1])
    return dict(link_index=wd.frame.idx_of_parent_link(model, frame_index=hand), position=position, quaternion=quaternion)


def _points_of(stepper, links: tuple, device) -> torch.Tensor:
    """The rows of the Stepper's contact_wrenches (enabled collidable points) on `links`."""
    indices = [stepper.model.link_names().index(name) for name in links]
    return torch.tensor(np.flatnonzero(np.isin(stepper.contact_point_links, indices)), device=device, dtype=torch.long)

