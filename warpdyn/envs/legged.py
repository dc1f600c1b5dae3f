"""A batched legged-robot environment: Gymnasium's vector API over a `wd.simulation.Stepper`, torch tensors on
the model's device (see warpdyn.envs)."""

from __future__ import annotations

import dataclasses
import math

import gymnasium as gym
import numpy as np
import torch
import warp as wp
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

import warpdyn as wd

from . import terms
from .actuators import Actuation, ActuatorNet, torque_limits
from .sensors import Imu, ImuConfig
from .terrain_generator import TerrainConfig, TerrainCurriculum, TerrainGenerator
from .vector_env import DIVERGENCE_SPEED, DeviceVectorEnv, check_divergence_speed, follow_divergence_speed, is_real_number

__all__ = ["LeggedEnvConfig", "LeggedEnv", "DEFAULT_OBSERVATIONS", "DEFAULT_REWARDS"]

DEFAULT_OBSERVATIONS: tuple = (
    (terms.base_height, 1.0),
    (terms.projected_gravity, 1.0),
    (terms.base_linear_velocity, 2.0),
    (terms.base_angular_velocity, 0.25),
    (terms.joint_positions, 1.0),
    (terms.joint_velocities, 0.05),
    (terms.actions, 1.0),
    (terms.commands, 1.0),
)
"""(term, scale) pairs whose scaled values, concatenated, are the observation."""

DEFAULT_REWARDS: dict = {
    "track_linear_velocity": (terms.track_linear_velocity, 1.0),
    "track_angular_velocity": (terms.track_angular_velocity, 0.5),
    "alive": (terms.alive, 1.0),
    "upright": (terms.upright, -5.0),
    "height_error": (terms.height_error, -50.0),
    "vertical_velocity": (terms.vertical_velocity_squared, -1.0),
    "torque": (terms.torque_squared, -1e-5),
    "action_rate": (terms.action_rate, -0.01),
    "joint_velocity": (terms.joint_velocity_squared, -1e-3),
}
"""name: (term, weight); the reward is sum(weight * term) * policy_dt."""


@dataclasses.dataclass
class LeggedEnvConfig:
    """What `LeggedEnv` simulates and rewards; units SI (s, m, rad, N m).

    Simulation: `time_step` [s] of the semi-implicit Euler (the joints' damping implicit), `policy_dt` [s] per action
    (decimation = policy_dt / time_step steps), soft contacts `contact_stiffness` K and `contact_damping` D (None:
    JaxSim's damping ratio at that K). Actions: joint position targets default + action_scale * clip(action,
    +-action_clip), followed by a position actuator per joint (kp) and the joint damper (kd) (a model that has actuators
    keeps its own and takes the targets as ctrl). `default_joint_positions` {joint: rad} is the posture the targets are
    taken around and resets start from (joints not named: 0); `torque_limit` [N m] clips each servo's force, one number
    for every joint or {joint: N m} (joints not named: no clip; None: none). Episodes: `episode_seconds` (then
    truncated); terminated when the base falls below `termination_height` x its standing height, tilts beyond
    `termination_tilt` [rad], or its state stops being finite or moves faster than `divergence_speed` [m/s or rad/s]
    (model.divergence_speed, vector_env.DIVERGENCE_SPEED; inf: off) (the health flag: reset and reported in info["invalid"]).
    Commands (vx, vy, yaw rate) drawn uniformly from the ranges at each reset and every `command_seconds`; with
    `heading_command` (legged_gym's) a heading in [-pi, pi] is drawn instead of the yaw rate, which each observation
    then sets to terms.heading_yaw_rate. Pushes: every `push_seconds` of each episode, a random horizontal velocity
    change of at most `push_velocity` [m/s]. Feet: `feet` names the links whose collidable points are the feet (empty:
    every link with enabled points); a foot is in contact while the normal force on its points exceeds
    `contact_force_threshold` [N]; `undesired_contacts` names links (thighs, shanks, the base) whose contact (the same
    test) `env.undesired_contact` (N, links) flags and `terms.undesired_contacts` counts. Domain randomisation at each
    reset: link masses times U(mass_scale), contact friction U(friction). Terrain: flat ground, or with `terrain` (a
    `warpdyn.envs.terrain_generator.TerrainConfig`) its generated heightfield, each environment starting at the centre
    of its tile (`env_origins`, `terrain_levels`); with `terrain_curriculum` an environment whose episode ended goes a
    level up when it walked farther than half a tile from its origin and down when it walked less than half its
    commanded distance (Rudin et al.'s rule, on the device); base heights (observed, rewarded) are taken above the
    origin's, the termination's above the terrain under the base. `height_scan` ((length, width), resolution) [m]: the
    terrain's height on that grid around each base in its yaw frame after every step (`env.height_scan`, (N, P) [m];
    `terms.height_scan` observes the base's height above it). Realism: an observation entry (term, scale, noise) adds
    uniform noise of +-noise to its scaled values at every observation; `action_delay` k applies each action k policy
    steps after the policy gave it (the targets hold the last ones given k steps ago; zero after a reset), while
    `env.actions` (what the action terms read) is the newest. `imu` (a `warpdyn.envs.sensors.ImuConfig`): an IMU on the
    base or a link (`env.imu`; terms.imu_linear_acceleration, terms.imu_angular_velocity). `stumble_ratio`: a foot stumbles when
    its horizontal contact force exceeds this times its vertical one (terms.stumbling). `actuator`: "pd" (the servo
    above), "torque" (torques action_scale * action [N m], clipped at torque_limit) or a
    `warpdyn.envs.actuators.ActuatorNet` (a torch network from the joints' error and velocity history to torques, at
    every simulation step); these two leave the joints without damping and ignore kp and kd.
    """

    time_step: float = 0.002
    policy_dt: float = 0.02
    contact_stiffness: float = 1e5
    contact_damping: float | None = None
    kp: float = 300.0
    kd: float = 5.0
    torque_limit: float | dict | None = None
    default_joint_positions: dict | None = None
    action_scale: float = 0.25
    action_clip: float = 5.0
    episode_seconds: float = 20.0
    termination_height: float = 0.6
    termination_tilt: float = 1.0
    base_height_target: float | None = None  # None: the standing height
    joint_noise: float = 0.1
    lin_vel_x: tuple = (0.0, 0.0)
    lin_vel_y: tuple = (0.0, 0.0)
    yaw_rate: tuple = (0.0, 0.0)
    heading_command: bool = False
    command_seconds: float = 10.0
    tracking_sigma: float = 0.25
    push_seconds: float = 8.0
    push_velocity: float = 0.0
    feet: tuple = ()
    undesired_contacts: tuple = ()  # links whose touching the terrain terms.undesired_contacts penalises
    action_delay: int = 0  # policy steps between an action and the targets it sets (actuation latency)
    contact_force_threshold: float = 1.0
    air_time_target: float = 0.5
    mass_scale: tuple = (1.0, 1.0)
    friction: tuple = (0.5, 0.5)
    observations: tuple = DEFAULT_OBSERVATIONS
    rewards: dict = dataclasses.field(default_factory=lambda: dict(DEFAULT_REWARDS))
    only_positive_rewards: bool = False  # legged_gym's: a step's total reward clipped at 0 (ending an episode early never pays)
    terrain: TerrainConfig | None = None
    terrain_curriculum: bool = True
    height_scan: tuple | None = None  # ((length, width), resolution) [m] of wd.terrain.grid_pattern; None: no scan
    imu: ImuConfig | None = None
    stumble_ratio: float = 5.0
    actuator: str | ActuatorNet = "pd"
    divergence_speed: float = DIVERGENCE_SPEED

    def __post_init__(self):
        self.validate()

    def validate(self) -> None:
        """A TypeError (not a number, a bool or a string given) or ValueError (out of range) naming the field
        and its value, for every numeric field (`_FIELD_CHECKS`): finite, positive or non-negative where the
        physics or the task needs it, ranges (low, high) ordered; and policy_dt a whole number of time steps.
        Run when the config is made (also by dataclasses.replace) and by LeggedEnv, which a config changed in
        place after it was made reaches."""
        for name, (kind, unit) in _FIELD_CHECKS.items():
            _check_field(name, getattr(self, name), kind, unit)
        check_divergence_speed("LeggedEnvConfig", self.divergence_speed)
        decimation = self.policy_dt / self.time_step
        if abs(decimation - round(decimation)) > 1e-6 or round(decimation) < 1:
            raise ValueError(f"LeggedEnvConfig.policy_dt {self.policy_dt} s must be a whole number of time steps of {self.time_step} s")
        if isinstance(self.action_delay, bool) or not isinstance(self.action_delay, (int, np.integer)) or self.action_delay < 0:
            raise ValueError(f"LeggedEnvConfig.action_delay must be an integer >= 0 [policy steps], got {self.action_delay!r}")
        for name in ("feet", "undesired_contacts"):
            links = getattr(self, name)
            if isinstance(links, str) or not all(isinstance(link, str) for link in links):
                raise TypeError(f"LeggedEnvConfig.{name} must be a tuple of link names, got {links!r}")
        limit = self.torque_limit
        limits = limit.values() if isinstance(limit, dict) else () if limit is None else (limit,)
        if (isinstance(limit, dict) and not all(isinstance(k, str) for k in limit)) or not all(is_real_number(v) and math.isfinite(v) and v > 0 for v in limits):
            raise ValueError(f"LeggedEnvConfig.torque_limit must be a positive finite number [N m], {{joint name: N m}} or None, got {limit!r}")
        default = self.default_joint_positions
        if default is not None and not isinstance(default, dict):
            raise TypeError(f"LeggedEnvConfig.default_joint_positions must be a dict {{joint name: angle [rad]}} or None, got {default!r}")
        for joint, value in (default or {}).items():
            _check_field(f"default_joint_positions[{joint!r}]", value, "finite", "rad")
        for k, entry in enumerate(self.observations):
            if not (isinstance(entry, (tuple, list)) and len(entry) in (2, 3) and callable(entry[0])):
                raise TypeError(f"LeggedEnvConfig.observations[{k}] must be (term, scale) or (term, scale, noise), got {entry!r}")
            _check_field(f"observations[{k}] scale", entry[1], "finite", "")
            if len(entry) == 3:
                _check_field(f"observations[{k}] noise", entry[2], "non-negative", "(the scaled term's units)")
        if self.terrain is not None and not isinstance(self.terrain, TerrainConfig):
            raise TypeError(f"LeggedEnvConfig.terrain must be a TerrainConfig (warpdyn.envs.terrain_generator) or None, got {self.terrain!r}")
        if (scan := self.height_scan) is not None:
            if not (isinstance(scan, (tuple, list)) and len(scan) == 2 and isinstance(scan[0], (tuple, list)) and len(scan[0]) == 2):
                raise TypeError(f"LeggedEnvConfig.height_scan must be ((length, width), resolution) [m] or None, got {scan!r}")
            wd.terrain.grid_pattern(scan[0], scan[1])  # its values checked
        if self.imu is not None and not isinstance(self.imu, ImuConfig):
            raise TypeError(f"LeggedEnvConfig.imu must be an ImuConfig (warpdyn.envs.sensors) or None, got {self.imu!r}")
        if not (isinstance(self.actuator, ActuatorNet) or (isinstance(self.actuator, str) and self.actuator in ("pd", "torque"))):
            raise ValueError(f"LeggedEnvConfig.actuator must be 'pd', 'torque' or an ActuatorNet (warpdyn.envs.actuators), got {self.actuator!r}")
        for name in ("terrain_curriculum", "only_positive_rewards", "heading_command"):
            if not isinstance(getattr(self, name), (bool, np.bool_)):
                raise TypeError(f"LeggedEnvConfig.{name} must be True or False, got {getattr(self, name)!r}")
        if self.heading_command and self.yaw_rate[0] == self.yaw_rate[1]:
            raise ValueError(f"LeggedEnvConfig.heading_command clips its yaw rate to yaw_rate's range, which is the single value {self.yaw_rate[0]}: give a range")
        if not isinstance(self.rewards, dict):
            raise TypeError(f"LeggedEnvConfig.rewards must be a dict {{name: (term, weight)}}, got {self.rewards!r}")
        for key, entry in self.rewards.items():
            if not (isinstance(entry, (tuple, list)) and len(entry) == 2 and callable(entry[0])):
                raise TypeError(f"LeggedEnvConfig.rewards[{key!r}] must be a pair (term, weight), got {entry!r}")
            _check_field(f"rewards[{key!r}] weight", entry[1], "finite", "")


_FIELD_CHECKS = {
    "time_step": ("positive", "s"),
    "policy_dt": ("positive", "s"),
    "contact_stiffness": ("positive", "N/m^1.5"),
    "contact_damping": ("positive or None", "N s/m^1.5"),
    "kp": ("non-negative", "N m/rad"),
    "kd": ("non-negative", "N m s/rad"),
    "action_scale": ("positive", "rad"),
    "action_clip": ("positive", ""),
    "episode_seconds": ("positive", "s"),
    "termination_height": ("non-negative", "x the standing height"),
    "termination_tilt": ("positive", "rad"),
    "base_height_target": ("positive or None", "m"),
    "joint_noise": ("non-negative", "rad"),
    "lin_vel_x": ("range", "m/s"),
    "lin_vel_y": ("range", "m/s"),
    "yaw_rate": ("range", "rad/s"),
    "command_seconds": ("positive", "s"),
    "tracking_sigma": ("positive", ""),
    "push_seconds": ("positive", "s"),
    "push_velocity": ("non-negative", "m/s"),
    "contact_force_threshold": ("non-negative", "N"),
    "air_time_target": ("non-negative", "s"),
    "mass_scale": ("positive range", ""),
    "friction": ("non-negative range", ""),
    "stumble_ratio": ("positive", ""),
}
"""LeggedEnvConfig's numeric fields: (what each must be, its unit)."""

_RANGES = {"range": ("", lambda low: True), "positive range": ("0 < ", lambda low: low > 0.0), "non-negative range": ("0 <= ", lambda low: low >= 0.0)}


def _check_field(name: str, value, kind: str, unit: str) -> None:
    """A TypeError or ValueError naming LeggedEnvConfig.<name> and `value` unless it is `kind` (_FIELD_CHECKS)."""
    field, unit = f"LeggedEnvConfig.{name}", f" [{unit}]" if unit else ""
    if kind.endswith("or None") and value is None:
        return
    if kind.endswith("range"):
        prefix, low_ok = _RANGES[kind]
        pair = tuple(value) if isinstance(value, (tuple, list)) else None
        numbers = pair is not None and len(pair) == 2 and all(is_real_number(v) for v in pair)
        if not numbers or not all(math.isfinite(v) for v in pair) or not (low_ok(pair[0]) and pair[0] <= pair[1]):
            raise ValueError(f"{field} must be a range (low, high) of finite numbers with {prefix}low <= high{unit}, got {value!r}")
        return
    if not is_real_number(value):
        raise TypeError(f"{field} must be a number, got {value!r}")
    value = float(value)
    if kind.startswith("positive") and not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{field} must be a positive finite number{unit}{' or None' if kind.endswith('or None') else ''}, got {value}")
    if kind == "non-negative" and not (math.isfinite(value) and value >= 0.0):
        raise ValueError(f"{field} must be a finite number >= 0{unit}, got {value}")
    if kind == "finite" and not math.isfinite(value):
        raise ValueError(f"{field} is {value}; a finite number{unit} is needed")


def _snapshot(cfg: LeggedEnvConfig) -> LeggedEnvConfig:
    """A copy of `cfg` that changes to it (also in place, to its rewards) do not reach."""
    return dataclasses.replace(cfg, rewards=dict(cfg.rewards), observations=tuple(cfg.observations))


class LeggedEnv(DeviceVectorEnv):
    """N environments of a floating-base robot on flat ground, stepped in place on the model's device.

    Gymnasium's vector API with SAME_STEP autoreset: `reset(seed=...)` -> (obs, info); `step(actions)` ->
    (obs, reward, terminated, truncated, info), torch tensors (N, ...) on the device (float32 observations
    and rewards, bool flags), no host synchronisation; the environments that ended are reset at once and
    their new observation returned, the last one in info["final_obs"] where info["_final_obs"]. info also
    holds "invalid" (environments whose state stopped being finite, reset) and "log" (the mean of each
    reward term over the environments, tensors). `episode_statistics()` reads (one synchronisation) the
    mean return and length of the episodes completed since its last call.

    use_graph: on a GPU, "auto" captures a whole `step` (the actions' mapping, the `decimation` simulation
    steps, observations, rewards, resets and randomisation) as one CUDA graph at the second call and
    replays it after, while no other warpdyn thread works on the GPU (otherwise it runs eagerly); True
    requires the capture, False never captures. On the CPU the simulation steps replay a Warp CPU graph and
    the torch ops run eagerly ("auto"; True is refused). Whatever the mode, a step returns new tensors (a
    replay copies its graph's outputs: trainers such as rsl-rl keep the observation they acted on).
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP}
    _replayed = ("state", "joint_torques")

    def __init__(self, model, num_envs: int, cfg: LeggedEnvConfig | None = None, *, seed: int = 0, use_graph="auto"):
        if not model.floating_base():
            raise ValueError(f"LeggedEnv needs a floating-base model; '{model.name()}' is welded to the world")
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
        if use_graph not in ("auto", True, False):
            raise ValueError(f"use_graph must be 'auto', True or False, got {use_graph!r}")
        if model.kin_dyn_structure().enabled_link.shape[0] == 0:
            raise ValueError(f"LeggedEnv needs collidable points to stand on; '{model.name()}' has none enabled")
        if use_graph is True and not model.device.is_cuda:
            raise ValueError(f"use_graph=True captures torch ops in a CUDA graph; '{model.device}' is not a GPU (use 'auto')")
        self.cfg = cfg = cfg if cfg is not None else LeggedEnvConfig()
        if not isinstance(cfg, LeggedEnvConfig):
            raise TypeError(f"cfg must be a LeggedEnvConfig, got {type(cfg).__name__}")
        cfg.validate()  # again: a config's fields may have changed since it was made
        decimation = cfg.policy_dt / cfg.time_step
        self.num_envs = N = int(num_envs)
        self.decimation = int(round(decimation))
        self.use_graph = use_graph
        self.terrain_generator = TerrainGenerator(cfg.terrain, seed=seed) if cfg.terrain is not None else None
        self.model = model = self._simulated(model, N)
        self.device = torch.device(wp.device_to_torch(model.device))
        self.torch_dtype = wp.dtype_to_torch(model.scalar)
        self.max_episode_length = int(math.ceil(cfg.episode_seconds / cfg.policy_dt))
        self._generator = torch.Generator(device=self.device)
        self._generator.manual_seed(seed)
        n = model.dofs()
        na = model.number_of_actuators() if cfg.actuator == "pd" else n
        default = self._default_joint_positions(model)
        self.default_joint_positions = torch.tensor(default, device=self.device, dtype=self.torch_dtype)
        # the standing pose: the default posture, the base upright, its lowest collidable point on the ground (the base
        # at the world's origin here, wherever the description places it: an MJCF free body's or an SDF model's pose;
        # with link lengths per environment (wd.model.with_joint_origins) the tallest environment's)
        upright = dict(base_position=(0.0, 0.0, 0.0), base_quaternion=(1.0, 0.0, 0.0, 0.0))
        posture = wd.data.Data.build(model, num_envs=N, joint_positions=default, **upright)
        lowest = float(wd.contact.collidable_point_positions(model, posture).numpy()[..., 2].min())
        self.standing_height = -lowest
        if cfg.base_height_target is None:
            cfg = self.cfg = dataclasses.replace(cfg, base_height_target=self.standing_height)
        # the state the resets copy from, and the Stepper (on a GPU its launches join the env's graph)
        self._reset_data = wd.data.Data.build(model, num_envs=N, base_position=(0.0, 0.0, self.standing_height), base_quaternion=upright["base_quaternion"],
                                              joint_positions=default)
        stepper_graph = False if model.device.is_cuda else (use_graph and "auto")
        substeps = 1 if isinstance(cfg.actuator, ActuatorNet) else self.decimation  # the network's steps: warpdyn.envs.actuators
        self.stepper = wd.simulation.Stepper(model, self._reset_data, substeps=substeps, use_graph=stepper_graph)
        limits = torque_limits(cfg.torque_limit, model)
        limits = None if limits is None else torch.tensor(limits, device=self.device, dtype=self.torch_dtype)
        self.actuation = Actuation(cfg.actuator, self.stepper, self._reset_data, self.decimation, self.default_joint_positions, limits, stepper_graph)
        # torch views, made once (outside torch.inference_mode: they are written inside it)
        self._reset_views = self._views(self._reset_data)
        self._state_views = {id(d): self._views(d) for d in self.stepper.buffers}
        self._link_mass = wp.to_torch(model.link_mass)
        self._mu = wp.to_torch(model.contact_params.mu)
        self._nominal_mass = self._link_mass[0].clone()
        self._terrain(seed)
        self._scan_pattern = self._scan = self.height_scan = None
        if cfg.height_scan is not None:
            pattern = wd.terrain.grid_pattern(*cfg.height_scan)
            self._scan_pattern = wp.array(pattern, dtype=model.scalar, device=model.device)
            self._scan = wp.zeros((N, len(pattern)), dtype=model.scalar, device=model.device)
            self.height_scan = wp.to_torch(self._scan)
        self._base_point = wp.zeros((1, 2), dtype=model.scalar, device=model.device)  # the terrain under the base: a scan of one point
        self._below = wp.zeros((N, 1), dtype=model.scalar, device=model.device)
        self.terrain_below_base = wp.to_torch(self._below)[:, 0]
        self._reset_mask = torch.zeros(N, dtype=torch.int32, device=self.device)
        self._reset_mask_wp = wp.from_torch(self._reset_mask)
        self.feet, self._foot_points = self._feet(model)
        _, self._undesired_points = self._feet(model, cfg.undesired_contacts, "undesired_contacts")
        # buffers
        f32 = dict(device=self.device, dtype=torch.float32)
        nf = len(self.feet)
        self.actions, self.previous_actions = torch.zeros(N, na, **f32), torch.zeros(N, na, **f32)
        self.commands, self.heading = torch.zeros(N, 3, **f32), torch.zeros(N, **f32)  # heading [rad, world]: cfg.heading_command's
        self.episode_length_buf = torch.zeros(N, dtype=torch.long, device=self.device)
        self.joint_torques = torch.zeros(N, n, device=self.device, dtype=self.torch_dtype)
        self.feet_contact = torch.zeros(N, nf, dtype=torch.bool, device=self.device)
        self.feet_first_contact = torch.zeros(N, nf, dtype=torch.bool, device=self.device)
        self.feet_air_time = torch.zeros(N, nf, **f32)
        self.feet_contact_forces = torch.zeros(N, nf, 3, device=self.device, dtype=self.torch_dtype)
        self.imu = None if cfg.imu is None else Imu(cfg.imu, N, cfg.time_step, self._generator, self.device, self.torch_dtype, model)
        self.undesired_contact = torch.zeros(N, len(self._undesired_points), dtype=torch.bool, device=self.device)
        self._previous_contact = torch.zeros(N, nf, dtype=torch.bool, device=self.device)
        self._action_input = torch.zeros(N, na, **f32)
        self._action_history = torch.zeros(cfg.action_delay + 1, N, na, **f32)  # newest first
        self._return = torch.zeros(N, **f32)
        self._finished = torch.zeros(3, device=self.device, dtype=torch.float64)  # episodes, return sum, length sum
        self._warp_streams: dict = {}
        self._program = self._step_program("a LeggedEnv")
        self._graph_version, self._graph_cfg = model.version, _snapshot(cfg)
        with self._on_device_stream():  # the height scan's launch ordered with the torch ops
            self.state = self._state()
        obs_dim = self._observe().shape[1]
        self.single_observation_space = gym.spaces.Box(-np.inf, np.inf, (obs_dim,), np.float32)
        self.single_action_space = gym.spaces.Box(-cfg.action_clip, cfg.action_clip, (na,), np.float32)
        self.observation_space = batch_space(self.single_observation_space, N)
        self.action_space = batch_space(self.single_action_space, N)

    def _terrain(self, seed: int) -> None:
        """The tiles' centres (levels, columns, 3) and each environment's level, column, origin (N, 3) and the
        height under it (N,): zeros on flat ground."""
        N, kw = self.num_envs, dict(device=self.device, dtype=self.torch_dtype)
        gen = self.terrain_generator
        if gen is None:
            self.env_origins = torch.zeros(N, 3, **kw)
            self.terrain_levels = self.terrain_columns = torch.zeros(N, dtype=torch.long, device=self.device)
        else:
            centres = gen.tile_centre(np.arange(gen.levels)[:, None], np.arange(gen.columns)[None, :])
            self._tile_centres = torch.tensor(centres, **kw)
            start = TerrainCurriculum(gen, N, seed=seed)
            self.terrain_levels = torch.tensor(start.levels, dtype=torch.long, device=self.device)
            self.terrain_columns = torch.tensor(start.columns, dtype=torch.long, device=self.device)
            self.env_origins = self._tile_centres[self.terrain_levels, self.terrain_columns].clone()
        self.terrain_height = self.env_origins[:, 2]

    def _update_terrain_levels(self, mask: torch.Tensor) -> None:
        """Rudin et al.'s curriculum for the environments where `mask` (their episode ended): up a level past half
        a tile from the origin, down under half the commanded distance, a random level past the top; their new
        origins."""
        gen = self.terrain_generator
        position = self._state_views[id(self.stepper.data)]["base_position"]
        walked = (position[:, :2] - self.env_origins[:, :2]).norm(dim=1)
        commanded = self.commands[:, :2].norm(dim=1).to(walked.dtype) * self.cfg.episode_seconds
        up = mask & (walked > gen.config.tile_size / 2.0)
        down = mask & ~up & (walked < 0.5 * commanded)
        levels = self.terrain_levels + up.long() - down.long()
        anywhere = torch.randint(0, gen.levels, levels.shape, generator=self._generator, device=self.device)
        levels = torch.where(levels >= gen.levels, anywhere, levels).clamp(min=0)
        self.terrain_levels.copy_(levels)
        self.env_origins.copy_(torch.where(mask[:, None], self._tile_centres[self.terrain_levels, self.terrain_columns], self.env_origins))

    def _simulated(self, model, N: int):
        """A copy of `model` with the task's actuators, damping, contacts and per-environment parameters."""
        cfg = self.cfg
        model = model.copy()
        if self.terrain_generator is not None:
            model.terrain = self.terrain_generator.terrain
        if model.number_of_actuators() > 0 and cfg.torque_limit is not None and cfg.actuator == "pd":
            raise ValueError(f"torque_limit clips the servos LeggedEnv adds; '{model.name()}' has actuators of its own: set their force_range")
        if cfg.actuator != "pd":
            if model.number_of_actuators() > 0:
                raise ValueError(f"actuator={cfg.actuator!r} drives the joints by joint torques; '{model.name()}' has actuators of its own")
            model.set_joint_parameters(damping=np.zeros(model.dofs()))
        elif model.number_of_actuators() == 0:
            limits = torque_limits(cfg.torque_limit, model)
            limit = None if limits is None else np.stack([-limits, limits], axis=1)
            model = wd.model.add_actuators(model, "position", kp=cfg.kp, force_range=limit)
            model.set_joint_parameters(damping=np.full(model.dofs(), cfg.kd))
        model.integrator = wd.model.IntegratorType.SemiImplicitEuler
        model.implicit_damping = True
        model.time_step = cfg.time_step
        model.divergence_speed = self._divergence_speed = cfg.divergence_speed
        D = cfg.contact_damping if cfg.contact_damping is not None else 2000.0 * (cfg.contact_stiffness / 1e6) ** (2.0 / 3.0)
        mu = wp.array(np.full(N, np.mean(cfg.friction)), dtype=model.scalar, device=model.device)
        model.contact_params = wd.model.SoftContactsParams(K=cfg.contact_stiffness, D=D, mu=mu)
        model.set_link_parameters(mass=np.tile(model.tree.link_mass, (N, 1)))  # per environment: randomised in place
        return model

    def _default_joint_positions(self, model) -> np.ndarray:
        """The default posture (n,) [rad] from cfg.default_joint_positions, checked against the model's joints."""
        names = model.joint_names()
        default = np.zeros(model.dofs())
        for name, value in (self.cfg.default_joint_positions or {}).items():
            if name not in names:
                raise ValueError(f"default_joint_positions names joint '{name}', which '{model.name()}' does not have (its joints: {', '.join(names)})")
            if not np.isfinite(value):
                raise ValueError(f"default_joint_positions['{name}'] is {value}; a finite angle is needed")
            default[names.index(name)] = value
        return default

    def _feet(self, model, names=None, field: str = "feet") -> tuple:
        """(link names, [torch index tensor of each link's enabled collidable points]) of `names` (None: cfg.feet,
        or every link with enabled points when that is empty); a ValueError names `field` and a link that the model
        lacks or that has no enabled points."""
        link_of_point = self.stepper.contact_point_links  # the rows of its contact_wrenches
        links = model.link_names()
        if names is None:
            names = tuple(self.cfg.feet) or tuple(links[i] for i in sorted(set(link_of_point.tolist())))
        points = []
        for link in names:
            if link not in links:
                raise ValueError(f"{field} names link '{link}', which '{model.name()}' does not have (its links: {', '.join(links)})")
            index = np.flatnonzero(link_of_point == links.index(link))
            if index.size == 0:
                raise ValueError(f"{field}: link '{link}' has no enabled collidable points: it cannot touch the ground")
            points.append(torch.tensor(index, device=self.device, dtype=torch.long))
        return tuple(names), points

    def _views(self, data) -> dict:
        return {name: wp.to_torch(getattr(data, f"{name}_state")) for name in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities", "valid")}

    def _state(self) -> terms.State:
        """The state's views and the terrain's heights under (terrain_below_base) and around (height_scan) the bases."""
        if self._scan is not None:  # on the device, into its buffer: inside a captured step too
            wd.terrain.height_scan(self.model, self.stepper.data, self._scan_pattern, out=self._scan)
        wd.terrain.height_scan(self.model, self.stepper.data, self._base_point, out=self._below)
        v = self._state_views[id(self.stepper.data)]
        q = v["base_quaternion"] / v["base_quaternion"].norm(dim=1, keepdim=True)
        down = torch.zeros_like(v["base_position"])
        down[:, 2] = -1.0
        return terms.State(
            base_position=v["base_position"],
            base_quaternion=q,
            joint_positions=v["joint_positions"],
            joint_velocities=v["joint_velocities"],
            base_linear_velocity=terms.quat_rotate_inverse(q, v["base_velocity"][:, :3]),
            base_angular_velocity=terms.quat_rotate_inverse(q, v["base_velocity"][:, 3:]),
            projected_gravity=terms.quat_rotate_inverse(q, down),
            valid=v["valid"],
        )

    def _observe(self) -> torch.Tensor:
        if self.cfg.heading_command:
            self.commands[:, 2] = terms.heading_yaw_rate(self)
        parts = []
        for entry in self.cfg.observations:
            value = (entry[0](self) * entry[1]).reshape(self.num_envs, -1).to(torch.float32)
            if len(entry) == 3 and entry[2] > 0:
                value = value + self._uniform(-entry[2], entry[2], value.shape).to(torch.float32)
            parts.append(value)
        return torch.nan_to_num(torch.cat(parts, dim=1), nan=0.0, posinf=0.0, neginf=0.0)

    def _every(self, seconds: float) -> int:
        return max(1, round(seconds / self.cfg.policy_dt))

    def _resample_commands(self, mask: torch.Tensor) -> None:
        cfg = self.cfg
        new = torch.stack([self._uniform(*r, (self.num_envs,)) for r in (cfg.lin_vel_x, cfg.lin_vel_y, cfg.yaw_rate)], dim=1)
        self.commands.copy_(torch.where(mask[:, None], new.to(torch.float32), self.commands))
        if cfg.heading_command:
            self.heading.copy_(torch.where(mask, self._uniform(-math.pi, math.pi, (self.num_envs,)).to(torch.float32), self.heading))

    def _reset(self, mask: torch.Tensor, curriculum: bool = True) -> None:
        """Reset the environments where `mask` (bool (N,)): a new initial state, parameters and commands; with
        `curriculum` (episodes that ended, not a `reset()`) and a terrain curriculum, their terrain levels first."""
        cfg, N, n = self.cfg, self.num_envs, self.model.dofs()
        if curriculum and self.terrain_generator is not None and cfg.terrain_curriculum:
            self._update_terrain_levels(mask)
        v = self._reset_views
        yaw = self._uniform(-math.pi, math.pi, (N,))
        v["base_quaternion"].copy_(torch.stack([torch.cos(yaw / 2), 0 * yaw, 0 * yaw, torch.sin(yaw / 2)], dim=1))
        lift = torch.zeros_like(self.env_origins)
        lift[:, 2] = self.standing_height + 0.02
        v["base_position"].copy_(self.env_origins + lift)
        v["joint_positions"].copy_(self.default_joint_positions + self._uniform(-cfg.joint_noise, cfg.joint_noise, (N, n)))
        v["base_velocity"].zero_()
        v["joint_velocities"].zero_()
        self._reset_mask.copy_(mask.to(torch.int32))
        self.stepper.set_state(self._reset_data, envs=self._reset_mask_wp)
        masses = self._nominal_mass * self._uniform(*cfg.mass_scale, (N, self._nominal_mass.shape[0]))
        self._link_mass.copy_(torch.where(mask[:, None], masses, self._link_mass))
        self._mu.copy_(torch.where(mask, self._uniform(*cfg.friction, (N,)), self._mu))
        self._resample_commands(mask)
        zero = torch.zeros_like(self.actions)
        self.actions.copy_(torch.where(mask[:, None], zero, self.actions))
        self.previous_actions.copy_(torch.where(mask[:, None], zero, self.previous_actions))
        self._action_history.masked_fill_(mask[None, :, None], 0.0)
        self.actuation.reset(mask)
        if self.imu is not None:
            self.imu.reset(mask)
        self.feet_air_time.masked_fill_(mask[:, None], 0.0)
        self._previous_contact.masked_fill_(mask[:, None], False)
        self.episode_length_buf.masked_fill_(mask, 0)
        self._return.masked_fill_(mask, 0.0)

    def _sync_model(self) -> None:
        """After a setter changed the model (new parameter arrays, a rebuilt Stepper workspace) or a change of
        `cfg` (read when a graph was captured): drop the graphs (the next step runs eagerly, then captures)
        and take new views of the randomised parameters. A `divergence_speed` changed in cfg reaches the model."""
        self._divergence_speed = follow_divergence_speed(self.cfg, self.model, self._divergence_speed)
        if self.model.version == self._graph_version and self.cfg == self._graph_cfg:
            return
        self._program = self._step_program("a LeggedEnv")
        self._graph_version, self._graph_cfg = self.model.version, _snapshot(self.cfg)
        self._link_mass = wp.to_torch(self.model.link_mass)
        self._mu = wp.to_torch(self.model.contact_params.mu)
        if tuple(self._link_mass.shape[:1]) != (self.num_envs,) or tuple(self._mu.shape) != (self.num_envs,):
            raise ValueError(
                f"LeggedEnv randomises link masses and friction per environment: after a setter, model.link_mass has "
                f"shape {tuple(self._link_mass.shape)} and contact_params.mu {tuple(self._mu.shape)}; give them a leading "
                f"axis of {self.num_envs} environments"
            )

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """Reset every environment; seed: reseed the environment's random numbers (states, commands,
        randomisation, pushes). Returns (obs (N, obs_dim), info)."""
        if seed is not None:
            self._generator.manual_seed(int(seed))
        self._sync_model()
        with self._on_device_stream():
            everywhere = torch.ones(self.num_envs, dtype=torch.bool, device=self.device)
            self._reset(everywhere, curriculum=False)
            self.state = self._state()
            self._sense(everywhere)
        self._finished.zero_()
        return self._observe(), {}

    def step(self, actions):
        """Apply `actions` (N, na) for policy_dt; see the class docstring for what comes back."""
        actions = torch.as_tensor(actions, device=self.device, dtype=torch.float32)
        if tuple(actions.shape) != (self.num_envs, self.actions.shape[1]):
            raise ValueError(f"actions has shape {tuple(actions.shape)}; expected {(self.num_envs, self.actions.shape[1])}")
        self._action_input.copy_(actions)
        self._sync_model()
        with self._on_device_stream():  # a replay too: ordered after Warp's pending work
            return self._program.run()

    def _advance(self) -> tuple:
        """One policy step from the actions in `_action_input`: (obs, reward, terminated, truncated, info)."""
        cfg = self.cfg
        self.previous_actions.copy_(self.actions)
        self.actions.copy_(torch.nan_to_num(self._action_input, nan=0.0).clamp(-cfg.action_clip, cfg.action_clip))
        applied = self.actions
        if cfg.action_delay > 0:  # the history shifts one step; the targets take the action given action_delay steps ago
            self._action_history.copy_(torch.roll(self._action_history, 1, dims=0))
            self._action_history[0].copy_(self.actions)
            applied = self._action_history[cfg.action_delay]
        command = cfg.action_scale * applied.to(self.torch_dtype)  # the targets' offsets from the default posture, or torques
        if cfg.push_velocity > 0:
            push = (self.episode_length_buf % self._every(cfg.push_seconds) == 0) & (self.episode_length_buf > 0)
            velocity = self._state_views[id(self.stepper.data)]["base_velocity"]
            kick = self._uniform(-cfg.push_velocity, cfg.push_velocity, (self.num_envs, 2))
            velocity[:, :2] += torch.where(push[:, None], kick, torch.zeros_like(kick))
        self.actuation.step(command)
        self.state = s = self._state()
        self._sense()
        self.joint_torques = self.actuation.joint_torques(s, cfg.kp, cfg.kd)
        self._update_feet()
        self.episode_length_buf += 1
        log, reward = {}, torch.zeros(self.num_envs, device=self.device, dtype=torch.float32)
        for name, (term, weight) in cfg.rewards.items():
            value = term(self).to(torch.float32) * (weight * cfg.policy_dt)
            log[f"/reward/{name}"] = value.mean()
            reward += value
        self.feet_air_time.masked_fill_(self.feet_contact | self._previous_contact, 0.0)
        self._previous_contact.copy_(self.feet_contact)
        invalid = s.valid == 0
        fell = (terms.height_above_terrain(self)[:, 0] < cfg.termination_height * self.standing_height) | (s.projected_gravity[:, 2] > -math.cos(cfg.termination_tilt))
        terminated = fell | invalid
        reward = torch.where(invalid, torch.zeros_like(reward), torch.nan_to_num(reward, nan=0.0, posinf=0.0, neginf=0.0))
        reward = reward.clamp(min=0.0) if cfg.only_positive_rewards else reward
        truncated, done = self._end_episodes(terminated, reward)
        final = self._observe()
        self._reset(done)
        resample = (self.episode_length_buf % self._every(cfg.command_seconds) == 0) & ~done
        self._resample_commands(resample)
        self.state = self._state()
        self._sense(done)
        obs = self._observe()
        info = {"final_obs": final, "_final_obs": done, "invalid": invalid, "log": log}
        return obs, reward, terminated, truncated, info

    def _sense(self, at_rest=None) -> None:
        """The IMU's readings (cfg.imu) at the current state, from the base's acceleration over the last simulation
        step (the two state buffers: warpdyn.envs.sensors); at rest (zero acceleration) where `at_rest` (reset)."""
        if self.imu is not None:
            now = self.stepper.data
            before = now if at_rest is not None else next(data for data in self.stepper.buffers if data is not now)
            velocity = tuple(self._state_views[id(data)]["base_velocity"] for data in (now, before))
            self.imu.sense(now, before, self.state.base_quaternion, velocity, wp.to_torch(self.model.world_gravity).reshape(-1, 3), at_rest)

    def _update_feet(self) -> None:
        """Contact of each foot (normal force above the threshold), its first contact and its air time [s], each
        foot's contact force (its points' sum, world axes [N]); the undesired contacts (the same test)."""
        W_f_C = wp.to_torch(self.stepper.contact_wrenches)
        self.feet_contact_forces.copy_(torch.stack([W_f_C[:, index, :3].sum(dim=1) for index in self._foot_points], dim=1))
        self.feet_contact.copy_(self.feet_contact_forces[..., 2] > self.cfg.contact_force_threshold)
        if self._undesired_points:
            other = torch.stack([W_f_C[:, index, 2].sum(dim=1) for index in self._undesired_points], dim=1)
            self.undesired_contact.copy_(other > self.cfg.contact_force_threshold)
        touching = self.feet_contact | self._previous_contact
        self.feet_first_contact.copy_((self.feet_air_time > 0) & touching)
        self.feet_air_time += self.cfg.policy_dt
