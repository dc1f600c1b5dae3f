"""A batched dexterous-manipulation environment: the LEAP hand turning a cube in its palm to a goal orientation, after
MuJoCo Playground's LeapCubeReorient (its scene, `wd.assets.leap_hand_cube_mjcf()`; its actions, observations,
rewards, goal updates, resets and termination; not its domain randomisation nor its perturbations, off in its
defaults), on a `wd.simulation.Stepper` with the contacts between the hand's and the cube's boxes acting
(model.geom_contacts).

    env = envs.CubeReorientEnv(num_envs=4096, device="cuda:0")
    obs, info = env.reset(seed=0)                  # torch (N, 57) float32; info["critic_obs"] (N, 116)
    obs, reward, terminated, truncated, info = env.step(actions)    # actions (N, 16) in [-1, 1]
"""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import torch
import warp as wp
from gymnasium.vector import AutoresetMode

import warpdyn as wd

from .terms import quat_multiply, quat_to_matrix
from .vector_env import DIVERGENCE_SPEED, DeviceVectorEnv, check_divergence_speed

__all__ = ["CubeReorientConfig", "CubeReorientEnv"]

_TERMS = ("orientation", "position", "termination", "hand_pose", "action_rate", "joint_velocity", "energy")
_TIPS = ("th_tip", "if_tip", "mf_tip", "rf_tip")


@dataclasses.dataclass
class CubeReorientConfig:
    """What `CubeReorientEnv` simulates and rewards; units SI (s, m, rad).

    Simulation: `time_step` [s] (2 ms: Playground's 10 ms relies on MuJoCo's implicit constraint solver) and
    `implicit_contacts` (model.implicit_contacts: the soft law's contacts linearly implicit; explicit, the 0.108 kg
    cube on the fingers' boxes needs 0.5 ms, as PickCubeConfig's cube; implicit at 2 ms, 128 hands under smooth random
    actions for 10 s: none flagged, the cube at 1.2 m/s at most, as at 1 ms with D = 500: benchmarks/reorient_stability.py),
    `limit_constraints` (model.limit_constraints: the fingers' joint limits as MuJoCo's limit constraints, as Playground's
    hand has them; without them the fingers pass their ranges: benchmarks/reorient_vs_mujoco.py),
    `frictionloss_constraints` (model.frictionloss_constraints: the joints' frictionloss as MuJoCo's friction
    constraints, as Playground's; without them JaxSim's static friction, none on a joint at rest), `policy_dt` [s] per
    action (Playground's ctrl_dt), the soft law's `contact_stiffness` K [N/m^1.5], `contact_damping`
    D [N s/m^1.5] (2000: at 2 ms the tangential deformation needs dt K / D < 2; a cube put 2 mm or more into the hand by
    Playground's reset draws leaves at a median 0.84 m/s, 1.8 m/s at 1 ms with D = 500), the floor's `friction` and
    `divergence_speed` [m/s or rad/s] the model's (vector_env.DIVERGENCE_SPEED; inf: off). Task: an action adds `action_scale` times itself
    (clipped to [-1, 1]) to each of the 16 position targets, clipped to their ranges; episodes of `episode_seconds`;
    a reset draws the goal orientation uniformly and takes the hand's joints (the targets there) and the cube's pose
    from a bank of `reset_bank` states drawn when the environment is built as Playground draws its resets (the
    joints around the keyframe "home"'s, normal, `hand_noise` [rad], clipped to the ranges; the cube at
    `cube_start` [m] give or take `cube_range` [m] on each axis in a uniformly random orientation) and kept where
    no two boxes penetrate by more than `reset_depth` [m]: MuJoCo's constraints push a deep initial penetration out
    over tens of milliseconds, warpdyn's soft law throws the cube out of it, implicit or not (8 in 10 of Playground's
    draws penetrate by more than 2 mm, up to 3 cm). Where the cube's orientation is within
    `success_threshold` [rad] of the goal's (a success) the goal starts to turn at 1 to 5 rad/s about each axis,
    that rate decaying by 0.8 per policy step (Playground's goal update: a new goal without a reset). Observations
    carry uniform noise of `noise["joint_pos"]` [rad] and `noise["cube_pos"]` [m], and `noise["cube_ori"]` times a
    standard normal on the quaternion's components (renormalised). `rewards`: name -> scale of Playground's terms
    (orientation: dm_control's linear tolerance of the orientation error, 1 within 0.2 rad, 0.1 at 0.2 + pi rad (a
    margin of pi); position: the same of the cube's distance from the palm's grasp site, 1 within 2 cm, margin 5 cm;
    termination: 1 where the cube fell; hand_pose: the squared distance of the joints from the keyframe's;
    action_rate: |a - a_prev|^2 + |a - 2 a_prev + a_prev2|^2; joint_velocity: |sdot / 4|^2; energy: sum |sdot| |servo force|, the
    servos' force before the joints' actuatorfrcrange clamps it, as Playground's reads MuJoCo's actuator_force);
    the reward is their scaled sum times policy_dt, plus `success_reward` at each success. An episode ends where
    the cube falls below z = -0.05 m or the state stops being finite."""

    time_step: float = 0.002
    implicit_contacts: bool = True
    limit_constraints: bool = True
    frictionloss_constraints: bool = True
    policy_dt: float = 0.05
    episode_seconds: float = 50.0
    action_scale: float = 0.5
    contact_stiffness: float = 5e5
    contact_damping: float = 2000.0
    friction: float = 1.0
    hand_noise: float = 0.1
    cube_start: tuple = (0.1, 0.0, 0.05)
    cube_range: float = 0.01
    reset_bank: int = 4096
    reset_depth: float = 0.001
    success_threshold: float = 0.1
    success_reward: float = 100.0
    noise: dict = dataclasses.field(default_factory=lambda: {"joint_pos": 0.05, "cube_pos": 0.02, "cube_ori": 0.1})
    rewards: dict = dataclasses.field(default_factory=lambda: {
        "orientation": 5.0, "position": 0.5, "termination": -100.0, "hand_pose": -0.5, "action_rate": -0.001, "joint_velocity": 0.0, "energy": -1e-3})  # fmt: skip
    divergence_speed: float = DIVERGENCE_SPEED

    def validate(self) -> None:
        """A ValueError naming the field whose value is not what it must be."""
        for name in ("time_step", "policy_dt", "episode_seconds", "action_scale", "contact_stiffness", "contact_damping", "success_threshold"):
            value = getattr(self, name)
            if not (_is_number(value) and value > 0.0):
                raise ValueError(f"CubeReorientConfig.{name} must be a positive finite number, got {value!r}")
        if not isinstance(self.implicit_contacts, bool):
            raise ValueError(f"CubeReorientConfig.implicit_contacts must be True or False, got {self.implicit_contacts!r}")
        for name in ("limit_constraints", "frictionloss_constraints"):
            if not isinstance(getattr(self, name), bool):
                raise ValueError(f"CubeReorientConfig.{name} must be True or False, got {getattr(self, name)!r}")
        check_divergence_speed("CubeReorientConfig", self.divergence_speed)
        if isinstance(self.reset_bank, bool) or not isinstance(self.reset_bank, int) or self.reset_bank < 1:
            raise ValueError(f"CubeReorientConfig.reset_bank must be a positive integer, got {self.reset_bank!r}")
        for name in ("friction", "hand_noise", "cube_range", "success_reward", "reset_depth"):
            value = getattr(self, name)
            if not (_is_number(value) and value >= 0.0):
                raise ValueError(f"CubeReorientConfig.{name} must be a finite number >= 0, got {value!r}")
        start = np.asarray(self.cube_start, dtype=float)
        if start.shape != (3,) or not np.all(np.isfinite(start)):
            raise ValueError(f"CubeReorientConfig.cube_start must be 3 finite numbers [m], got {self.cube_start!r}")
        ratio = self.policy_dt / self.time_step
        if abs(ratio - round(ratio)) > 1e-9 * ratio:
            raise ValueError(f"CubeReorientConfig.policy_dt ({self.policy_dt} s) must be a whole number of time_step ({self.time_step} s)")
        if set(self.noise) != {"joint_pos", "cube_pos", "cube_ori"} or not all(_is_number(v) and v >= 0.0 for v in self.noise.values()):
            raise ValueError(f"CubeReorientConfig.noise maps joint_pos, cube_pos and cube_ori to finite numbers >= 0, got {self.noise!r}")
        unknown = sorted(set(self.rewards) - set(_TERMS))
        if unknown or not all(_is_number(v) for v in self.rewards.values()):
            raise ValueError(f"CubeReorientConfig.rewards maps terms of {list(_TERMS)} to finite scales, got {self.rewards!r}")


def _is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


class CubeReorientEnv(DeviceVectorEnv):
    """N environments of the LEAP hand and its cube (`wd.assets.leap_hand_cube_mjcf()`, or `model`: a model of that
    scene), stepped in place on the device, Gymnasium's vector API with SAME_STEP autoreset and torch tensors as
    `LeggedEnv` (its docstring says what a step returns and how a GPU captures it). Observations (57,), float32,
    Playground's "state": the noisy joint angles (16, the actuators' order), their difference from the position
    targets (16), the palm's grasp site less the noisy cube position (3), the last six entries of the rotation
    matrix of the noisy cube orientation times the goal's inverse (6) and the last actions (16).
    info["critic_obs"] (116,), Playground's "privileged_state" without its perturbation terms (off): the
    observations, then the joint angles and velocities (16 + 16), the fingertips from the grasp site (12: thumb,
    index, middle, ring), the exact cube position error (3) and orientation error (6), and the cube's velocity (6:
    its origin's linear velocity in world axes, its angular velocity in its own axes, the free joint's). Without
    `model` the scene is loaded on `device` in `dtype`; `seed` seeds the draws. Tensors (N, ...) kept: `goal` (the
    goal orientation (w, x, y, z)), `successes` (this episode's count)."""

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(self, num_envs: int, cfg: CubeReorientConfig | None = None, *, model=None, device=None, dtype=np.float32, seed: int = 0, use_graph="auto"):
        self._setup(num_envs, cfg, CubeReorientConfig, model, wd.assets.leap_hand_cube_mjcf, dtype, device, seed, use_graph)
        cfg, model, N = self.cfg, self.model, self.num_envs
        kw = dict(device=self.device, dtype=self.torch_dtype)
        # addresses: the hand's joints in the actuators' order, the cube's free joint
        names = model.joint_names()
        hand = [names.index(j) for j in wd.assets.LEAP_HAND_JOINTS]
        self._q = torch.tensor([wd.joint.position_slice(model, joint_index=j).start for j in hand], device=self.device)
        self._v = torch.tensor([wd.joint.velocity_slice(model, joint_index=j).start for j in hand], device=self.device)
        cube = names.index("cube_freejoint")
        self._cube_q = wd.joint.position_slice(model, joint_index=cube).start
        self._cube_v = wd.joint.velocity_slice(model, joint_index=cube).start
        self._reset_data = wd.data.keyframe(model, "home", num_envs=N)
        self.stepper = wd.simulation.Stepper(model, self._reset_data, substeps=self.decimation, use_graph=False if model.device.is_cuda else use_graph and "auto")
        self._ctrl = wp.to_torch(self.stepper.ctrl)
        ranges = torch.tensor(model.actuator_ctrl_range.numpy(), **kw)
        self._low, self._high = ranges[:, 0], ranges[:, 1]
        gain, bias = model.actuator_gain.numpy(), model.actuator_bias.numpy()
        self._kp, self._kv = torch.tensor(gain[:, 0], **kw), torch.tensor(-bias[:, 2], **kw)
        self._views = {id(d): {n: wp.to_torch(getattr(d, f"{n}_state")) for n in ("joint_positions", "joint_velocities", "valid")} for d in (*self.stepper.buffers, self._reset_data)}
        self._home = self._views[id(self._reset_data)]["joint_positions"][0].clone()
        self._home_hand = self._home[self._q].clone()
        self._cube_start = torch.tensor(cfg.cube_start, **kw)
        self._bank = self._draw_bank()
        sites = _site_positions(model, ("grasp_site", *_TIPS))
        self._palm = torch.tensor(sites["grasp_site"][1], **kw)  # the mount is fixed to the world
        self._tips = [wd.link.FrameMotion(model, num_envs=N, link_index=sites[t][0], position=sites[t][1]) for t in _TIPS]
        # buffers
        self.goal = torch.zeros(N, 4, **kw)
        self._conjugate = torch.tensor([1.0, -1.0, -1.0, -1.0], **kw)  # times a unit quaternion: its inverse
        self._goal_rate = torch.zeros(N, 3, **kw)
        self.successes = torch.zeros(N, device=self.device, dtype=torch.long)
        self._actions = torch.zeros(3, N, 16, device=self.device, dtype=torch.float32)  # this step's, the last, the one before
        self._finish_setup(observations=57, actions=16)
        self.single_critic_observation_space = gym.spaces.Box(-np.inf, np.inf, (116,), np.float32)

    def _simulated(self, model):
        """A copy of `model` with the geom pairs' contacts acting and the task's time step and soft law."""
        expected = tuple(f"{j}_act" for j in wd.assets.LEAP_HAND_JOINTS)
        missing = sorted({"cube"} - set(model.link_names())) + sorted({"cube_freejoint", *wd.assets.LEAP_HAND_JOINTS} - set(model.joint_names()))
        if missing or model.actuator_names() != expected or "home" not in model.keyframe_names():
            raise ValueError(
                f"CubeReorientEnv simulates wd.assets.leap_hand_cube_mjcf()'s scene: '{model.name()}' lacks {missing or 'nothing named'}, "
                f"has the actuators {list(model.actuator_names())} ({list(expected)} needed) and keyframes {list(model.keyframe_names())} (needs 'home')"
            )
        return self._with_body_contacts(model)

    def _state(self) -> tuple:
        """(joint angles (N, 16), joint velocities (N, 16), cube position (N, 3) [m], cube orientation (N, 4) (w, x,
        y, z), cube velocity (N, 6)) at the current state."""
        v = self._views[id(self.stepper.data)]
        q, u = v["joint_positions"], v["joint_velocities"]
        cube = q[:, self._cube_q : self._cube_q + 7]
        return q[:, self._q], u[:, self._v], cube[:, :3], cube[:, 3:] / cube[:, 3:].norm(dim=1, keepdim=True), u[:, self._cube_v : self._cube_v + 6]

    def _orientation_error(self, quaternion: torch.Tensor) -> tuple:
        """(the angle [rad] (N,) between `quaternion` and the goal, the last six entries of the rotation matrix of
        quaternion times the goal's inverse (N, 6))."""
        difference = quat_multiply(quaternion, self.goal * self._conjugate)
        difference = difference / difference.norm(dim=1, keepdim=True)
        angle = 2.0 * torch.asin(difference[:, 1:].norm(dim=1).clamp(max=1.0))
        return angle, quat_to_matrix(difference).reshape(-1, 9)[:, 3:]

    def _observe(self, state) -> tuple:
        """(observations (N, 57), critic observations (N, 116)) float32, the noise drawn from the generator."""
        noise = self.cfg.noise
        s, sdot, cube, quaternion, cube_velocity = state
        noisy_s = s + self._uniform(-1.0, 1.0, s.shape) * noise["joint_pos"]
        noisy_cube = cube + self._uniform(-1.0, 1.0, cube.shape) * noise["cube_pos"]
        noisy_quaternion = quaternion + torch.randn(quaternion.shape, generator=self._generator, device=self.device, dtype=self.torch_dtype) * noise["cube_ori"]
        noisy_quaternion = noisy_quaternion / noisy_quaternion.norm(dim=1, keepdim=True)
        obs = torch.cat([noisy_s, noisy_s - self._ctrl, self._palm - noisy_cube, self._orientation_error(noisy_quaternion)[1], self._actions[1].to(s.dtype)], dim=1)
        tips = [wp.to_torch(tip(self.stepper.data)[0])[:, :3, 3] - self._palm for tip in self._tips]
        critic = torch.cat([obs, s, sdot, *tips, self._palm - cube, self._orientation_error(quaternion)[1], cube_velocity], dim=1)
        clean = lambda x: torch.nan_to_num(x.to(torch.float32), nan=0.0, posinf=0.0, neginf=0.0)  # noqa: E731
        return clean(obs), clean(critic)

    def _terms(self, state, fell: torch.Tensor) -> dict:
        """{name: (N,)} Playground's reward terms at the current state, for this step's actions."""
        s, sdot, cube, quaternion, _ = state
        angle, _ = self._orientation_error(quaternion)
        a, a1, a2 = self._actions
        servo = self._kp * (self._ctrl - s) - self._kv * sdot  # MuJoCo's actuator_force: the joint's actuatorfrcrange clamps only qfrc_actuator
        return {
            "orientation": _tolerance(angle, 0.2, math.pi),
            "position": _tolerance((self._palm - cube).norm(dim=1), 0.02, 0.05),
            "termination": fell.to(angle.dtype),
            "hand_pose": ((s - self._home_hand) ** 2).sum(dim=1),
            "action_rate": ((a - a1) ** 2).sum(dim=1).to(angle.dtype) + ((a - 2.0 * a1 + a2) ** 2).sum(dim=1).to(angle.dtype),
            "joint_velocity": ((sdot / 4.0) ** 2).sum(dim=1),
            "energy": (sdot.abs() * servo.abs()).sum(dim=1),
        }, angle

    def _advance(self) -> tuple:
        """One policy step from the actions in `_actions[0]`: (obs, reward, terminated, truncated, info)."""
        cfg = self.cfg
        delta = cfg.action_scale * self._actions[0].to(self.torch_dtype)
        self._ctrl.copy_(torch.minimum(torch.maximum(self._ctrl + delta, self._low), self._high))
        self.stepper.step()
        state = self._state()
        invalid = self._views[id(self.stepper.data)]["valid"] == 0
        fell = state[2][:, 2] < -0.05
        values, angle = self._terms(state, fell)
        success = angle < cfg.success_threshold
        reward = sum((cfg.rewards[name] * values[name] for name in cfg.rewards), torch.zeros_like(angle)) * cfg.policy_dt + cfg.success_reward * success
        reward = torch.where(invalid, torch.zeros_like(reward), torch.nan_to_num(reward, nan=0.0)).to(torch.float32)
        log = {f"/reward/{name}": value.to(torch.float32).mean() for name, value in values.items()}
        log["/success"] = success.to(torch.float32).mean()
        log["/orientation_error"] = angle.to(torch.float32).mean()
        self.successes += success
        self._turn_goals(success)
        terminated = invalid | fell
        self.episode_length_buf += 1
        truncated, done = self._end_episodes(terminated, reward)
        final, final_critic = self._observe(state)
        self._actions[2].copy_(self._actions[1])
        self._actions[1].copy_(self._actions[0])
        self._reset(done)
        obs, critic = self._observe(self._state())
        info = {"final_obs": final, "_final_obs": done, "critic_obs": critic, "final_critic_obs": final_critic, "invalid": invalid, "log": log}
        return obs, reward, terminated, truncated, info

    def _turn_goals(self, success: torch.Tensor) -> None:
        """Playground's goal update: where a success, the goal starts turning at 3 +- 2 rad/s about each axis (its
        own), elsewhere that rate decays by 0.8; the goal turns by the rate over two policy steps."""
        rate = torch.where(success[:, None], 3.0 + self._uniform(-2.0, 2.0, (self.num_envs, 3)), 0.8 * self._goal_rate)
        self._goal_rate.copy_(rate)
        angle = rate.norm(dim=1, keepdim=True) * 2.0 * self.cfg.policy_dt
        axis = rate / rate.norm(dim=1, keepdim=True).clamp(min=1e-12)
        turn = torch.cat([torch.cos(0.5 * angle), axis * torch.sin(0.5 * angle)], dim=1)
        goal = quat_multiply(self.goal, turn)
        self.goal.copy_(goal / goal.norm(dim=1, keepdim=True))

    def _draws(self, n: int) -> torch.Tensor:
        """(n, nq) joint positions as Playground's resets draw them (CubeReorientConfig's docstring)."""
        cfg = self.cfg
        q = self._home.expand(n, -1).clone()
        hand = self._home_hand + cfg.hand_noise * torch.randn(n, 16, generator=self._generator, device=self.device, dtype=self.torch_dtype)
        q[:, self._q] = torch.minimum(torch.maximum(hand, self._low), self._high)
        q[:, self._cube_q : self._cube_q + 3] = self._cube_start + self._uniform(-cfg.cube_range, cfg.cube_range, (n, 3))
        q[:, self._cube_q + 3 : self._cube_q + 7] = _uniform_quaternions(self, n)
        return q

    def _draw_bank(self, batch: int = 1024, rounds: int = 100) -> torch.Tensor:
        """(reset_bank, nq): draws whose boxes penetrate by at most reset_depth (wd.contact.geom_contacts)."""
        kept, count = [], 0
        data = wd.data.keyframe(self.model, "home", num_envs=batch)
        q = wp.to_torch(data.joint_positions_state)
        for _ in range(rounds):
            q.copy_(self._draws(batch))
            depth = -wp.to_torch(wd.contact.geom_contacts(self.model, data).distance).reshape(batch, -1).min(dim=1).values
            good = q[depth <= self.cfg.reset_depth].clone()
            kept.append(good)
            count += good.shape[0]
            if count >= self.cfg.reset_bank:
                return torch.cat(kept)[: self.cfg.reset_bank]
        raise ValueError(f"CubeReorientEnv: {count} of {batch * rounds} drawn resets penetrate by at most reset_depth = {self.cfg.reset_depth} m; "
                         f"{self.cfg.reset_bank} are needed (raise reset_depth or cube_start's height)")  # fmt: skip

    def _reset(self, mask: torch.Tensor) -> None:
        """States from the bank, the targets at their joints, and new goals, where `mask` (bool (N,))."""
        N = self.num_envs
        q = self._bank[torch.randint(self._bank.shape[0], (N,), generator=self._generator, device=self.device)]
        v = self._views[id(self._reset_data)]
        v["joint_positions"].copy_(q)
        v["joint_velocities"].zero_()
        self._reset_mask.copy_(mask.to(torch.int32))
        self.stepper.set_state(self._reset_data, envs=self._reset_mask_wp)
        self._ctrl.copy_(torch.where(mask[:, None], q[:, self._q], self._ctrl))
        self.goal.copy_(torch.where(mask[:, None], _uniform_quaternions(self, N), self.goal))
        self._goal_rate.masked_fill_(mask[:, None], 0.0)
        self._actions[1:].masked_fill_(mask[None, :, None], 0.0)
        self.successes.masked_fill_(mask, 0)
        self.episode_length_buf.masked_fill_(mask, 0)
        self._return.masked_fill_(mask, 0.0)

    def _first_observation(self) -> tuple:
        """(obs (N, 57), {"critic_obs": (N, 116)}) after a reset of all."""
        obs, critic = self._observe(self._state())
        return obs, {"critic_obs": critic}

    def _take(self, actions: torch.Tensor) -> None:
        """Keep the actions (N, 16), clipped to [-1, 1], NaN as 0; info["critic_obs"] after a step holds the
        critic's observations (its resets included)."""
        self._actions[0].copy_(torch.nan_to_num(actions, nan=0.0).clamp(-1.0, 1.0))

    def _snapshot(self) -> tuple:
        """(the model's version, a copy of `cfg` that changes to it, also in place to its dicts, do not reach)."""
        return self.model.version, dataclasses.replace(self.cfg, rewards=dict(self.cfg.rewards), noise=dict(self.cfg.noise))


def _tolerance(x: torch.Tensor, bound: float, margin: float) -> torch.Tensor:
    """dm_control's tolerance of x >= 0 with bounds (0, bound), `margin` and the linear sigmoid (value 0.1 at the
    margin): 1 within the bound, then falling linearly to 0 at bound + margin / 0.9."""
    return (1.0 - 0.9 * (x - bound).clamp(min=0.0) / margin).clamp(min=0.0)


def _uniform_quaternions(env, n: int) -> torch.Tensor:
    """(n, 4) uniformly random unit quaternions (w, x, y, z), Shoemake's method (Playground's uniform_quat)."""
    u = env._uniform(0.0, 1.0, (n, 3))
    a, b = torch.sqrt(1.0 - u[:, 0]), torch.sqrt(u[:, 0])
    t1, t2 = 2.0 * math.pi * u[:, 1], 2.0 * math.pi * u[:, 2]
    return torch.stack([a * torch.sin(t1), a * torch.cos(t1), b * torch.sin(t2), b * torch.cos(t2)], dim=1)


def _site_positions(model, names: tuple) -> dict:
    """{site name: (its link, its position in that link (3,) [m])} from MuJoCo's compile of the MJCF that `model` was
    loaded from: a site on a link's body is at MuJoCo's site_pos there; one on a body welded to the world is on the
    world's link 0, at its world position."""
    import mujoco  # the MJCF loader's dependency

    m = mujoco.MjModel.from_xml_path(str(model.description.path))
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    out = {}
    for name in names:
        site = m.site(name)
        body = int(site.bodyid[0])
        if int(m.body_weldid[body]) == 0:
            out[name] = (0, np.array(d.site_xpos[site.id]))
        else:
            out[name] = (model.link_names().index(m.body(body).name), np.array(site.pos))
    return out
