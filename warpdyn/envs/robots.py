"""Legged robots for `LeggedEnv`, set up from a description and a few names (issue 39): `LeggedRobot`, and the
presets `ergocub_legs()` (shipped), `go1()` (the pip package example-robot-data's Unitree Go1), `anymal_c()`
(ANYbotics' ANYmal C, shipped from MuJoCo Menagerie) and `go2()` (Unitree's Go2, shipped from MuJoCo Menagerie).

    robot = LeggedRobot(description="my_quadruped.urdf", feet=("FL_foot", "FR_foot", "RL_foot", "RR_foot"),
                        posture={"FL_knee": -1.4, ...}, settings=dict(kp=25.0, kd=0.6, base_height_target=0.3))
    env = robot.env(num_envs=4096, push_velocity=0.5)      # LeggedEnvConfig fields override `settings`

The feet's collision shapes become the contact points (`contact_shapes`, `sphere_points`; `lower_half` keeps a
foot's points below the centre of its shapes: a round foot meets the ground with its lower half); `other_links`
(e.g. the thighs, for rough terrain, where LeggedEnvConfig.undesired_contacts penalises their touching) touch the
terrain with the points of their shapes of the kinds `other_shapes` (a box's corners) and `contact_shapes`; no other
link has any. The posture is a {joint: position} dict or the name of an MJCF keyframe.
"""

from __future__ import annotations

import dataclasses

import numpy as np

import warpdyn as wd

from . import terms
from .legged import LeggedEnv, LeggedEnvConfig

__all__ = ["LeggedRobot", "ergocub_legs", "go1", "anymal_c", "go2", "GO1_REWARDS"]

GO1_REWARDS = {  # Rudin et al. (2021)'s flat-ground terms and weights, with warpdyn's height and tilt terms
    "track_linear_velocity": (terms.track_linear_velocity, 1.0),
    "track_angular_velocity": (terms.track_angular_velocity, 0.5),
    "vertical_velocity": (terms.vertical_velocity_squared, -2.0),
    "angular_velocity_xy": (terms.angular_velocity_xy_squared, -0.05),
    "upright": (terms.upright, -1.0),
    "height_error": (terms.height_error, -10.0),
    "torque": (terms.torque_squared, -2e-4),
    "action_rate": (terms.action_rate, -0.01),
    "feet_air_time": (terms.feet_air_time, 1.0),
}
"""The Go1, ANYmal C and Go2 presets' rewards."""


@dataclasses.dataclass(frozen=True)
class LeggedRobot:
    """A legged robot: `description` (a path or the text of a URDF, SDF or MJCF, or a function returning one: a pip
    package's file), `feet` (link names), `joints` (the joints kept, the others locked at 0; None: all),
    `posture` ({joint: position [rad or m]} or an MJCF keyframe's name; None: the description's zero), how the feet
    touch (`contact_shapes`, `sphere_points`, `lower_half`; warpdyn.contact.CollidablePointsOptions), the other links
    that touch the terrain (`other_links`, with their shapes of the kinds `other_shapes` and `contact_shapes`) and
    `settings`, LeggedEnvConfig fields of this robot (gains, torque limit, height target, rewards...)."""

    description: object
    feet: tuple
    joints: tuple | None = None
    posture: dict | str | None = None
    contact_shapes: tuple = ("box", "sphere", "ellipsoid", "cylinder", "capsule")
    sphere_points: int = 50
    lower_half: bool = False
    other_links: tuple = ()
    other_shapes: tuple = ("box",)
    settings: dict = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        for name in ("feet", "other_links", "contact_shapes", "other_shapes"):
            value = getattr(self, name)
            if isinstance(value, str) or not isinstance(value, (tuple, list)) or not all(isinstance(v, str) for v in value):
                raise TypeError(f"LeggedRobot.{name} must be a tuple of names, got {value!r}")

    def model(self, device=None, dtype=np.float32) -> wd.model.Model:
        """The model: its joints reduced to `joints`, its contact points on the feet and `other_links`."""
        source = self.description() if callable(self.description) else self.description
        model = wd.model.Model.build_from_model_description(source, dtype=dtype, device=device)
        if self.joints is not None:
            model = wd.model.reduce(model, considered_joints=list(self.joints))
        for role, names in (("feet", self.feet), ("other_links", self.other_links)):
            missing = [name for name in names if name not in model.link_names()]
            if missing:
                raise ValueError(f"{role} {missing} are not links of '{model.name()}' (its links: {', '.join(model.link_names())})")
        options = wd.contact.CollidablePointsOptions(shapes=tuple(self.contact_shapes), sphere_points=self.sphere_points)
        model = wd.contact.with_collidable_points(model, options=options)
        cp = model.kin_dyn_parameters.contact_parameters
        links = model.link_names()
        feet = {links.index(name) for name in self.feet}
        enabled = np.array([b in feet for b in cp.body], dtype=bool)
        if self.lower_half:
            point = np.asarray(cp.point, dtype=np.float64)
            for foot in feet:
                centre = self._shape_centre(model, foot)
                mine = np.asarray(cp.body) == foot
                enabled[mine] &= point[mine, 2] < centre
        without = [name for name in self.feet if not enabled[np.asarray(cp.body) == links.index(name)].any()]
        if without:
            raise ValueError(f"feet {without} have no collision shape of the kinds {list(self.contact_shapes)}: they cannot touch the ground")
        if not self.other_links:
            return wd.contact.with_collidable_points(model, options=options, enabled=enabled)
        return self._with_other_links(model, options, enabled)

    def _with_other_links(self, model, feet_options, feet_enabled) -> wd.model.Model:
        """`model` with the feet's points (those `feet_enabled` of `feet_options`' points, found again by link and
        position among the points of both option sets' shapes) and every point of `other_links`' shapes."""
        feet_cp = model.kin_dyn_parameters.contact_parameters
        feet = {(b, tuple(p)) for b, p, on in zip(feet_cp.body, np.asarray(feet_cp.point, dtype=np.float64).round(12), feet_enabled) if on}
        kinds = tuple(dict.fromkeys((*self.contact_shapes, *self.other_shapes)))
        options = dataclasses.replace(feet_options, shapes=kinds)
        model = wd.contact.with_collidable_points(model, options=options)
        cp = model.kin_dyn_parameters.contact_parameters
        others = {model.link_names().index(name) for name in self.other_links}
        points = np.asarray(cp.point, dtype=np.float64).round(12)
        enabled = np.array([b in others or (b, tuple(p)) in feet for b, p in zip(cp.body, points)], dtype=bool)
        bare = [name for name in self.other_links if not enabled[np.asarray(cp.body) == model.link_names().index(name)].any()]
        if bare:
            raise ValueError(f"other_links {bare} have no collision shape of the kinds {list(kinds)}: they cannot touch the ground")
        return wd.contact.with_collidable_points(model, options=options, enabled=enabled)

    def _shape_centre(self, model, link: int) -> float:
        """The z [m, link frame] of the centre of `link`'s collision shapes of the kinds that make points."""
        shapes = [s for s in model.tree.collisions[link] if s.kind in self.contact_shapes]
        return float(np.mean([s.link_H_shape[2, 3] for s in shapes]))

    def config(self, model=None, **overrides) -> LeggedEnvConfig:
        """LeggedEnvConfig of `settings`, the feet (in `model`'s link order when given: the feet terms' order) and the
        posture (a keyframe's read from `model`), then `overrides`."""
        feet = tuple(self.feet) if model is None else tuple(name for name in model.link_names() if name in self.feet)
        fields = {**self.settings, "feet": feet}
        if self.posture is not None:
            fields["default_joint_positions"] = self._posture(model)
        return LeggedEnvConfig(**{**fields, **overrides})

    def _posture(self, model) -> dict:
        if isinstance(self.posture, dict):
            return dict(self.posture)
        if model is None:
            raise ValueError(f"posture '{self.posture}' is an MJCF keyframe: config() needs the model to read it")
        keyframe = wd.data.keyframe(model, self.posture)
        return dict(zip(model.joint_names(), (float(v) for v in keyframe.joint_positions.numpy())))

    def env(self, num_envs: int, *, device=None, dtype=np.float32, seed: int = 0, use_graph="auto", **overrides) -> LeggedEnv:
        """A LeggedEnv of this robot (`overrides`: LeggedEnvConfig fields)."""
        model = self.model(device=device, dtype=dtype)
        return LeggedEnv(model, num_envs=num_envs, cfg=self.config(model, **overrides), seed=seed, use_graph=use_graph)


def ergocub_legs() -> LeggedRobot:
    """The shipped ergoCub's 12 leg joints (the others locked), its four foot boxes' corners as contacts."""
    return LeggedRobot(
        description=wd.assets.ergocub_urdf,
        feet=("l_ankle_2", "r_ankle_2"),
        joints=tuple(wd.assets.ERGOCUB_LEG_JOINTS),
        settings=dict(mass_scale=(0.9, 1.1), friction=(0.5, 1.0)),
    )


def go1() -> LeggedRobot:
    """example-robot-data's Unitree Go1 (pip install example-robot-data): the lower halves of its foot spheres (20
    points each) as contacts, the standing posture, its actuators' gains and torque limit, Rudin et al.'s
    flat-ground rewards."""
    return LeggedRobot(
        description=lambda: wd.assets.example_robot_data_urdf("go1"),
        feet=tuple(wd.assets.GO1_FEET),
        posture=dict(wd.assets.GO1_STANDING_POSE),
        contact_shapes=("sphere",),
        sphere_points=20,
        lower_half=True,
        settings=dict(kp=20.0, kd=0.5, torque_limit=23.7, base_height_target=0.30, mass_scale=(0.9, 1.1), friction=(0.5, 1.25),
                      rewards=GO1_REWARDS),
    )


def anymal_c() -> LeggedRobot:
    """The shipped ANYmal C (MuJoCo Menagerie's, wd.assets.anymal_c_mjcf()): the lower halves of its four foot
    spheres (20 points each) as contacts, Menagerie's keyframe "standing", legged_gym's ANYmal C gains (its
    anymal_c_rough_config's PD drive: stiffness 80 N m/rad, damping 2 N m s/rad on every joint; legged_gym
    itself drives the ANYmal C with an actuator network by default), Menagerie's torque limit (80 N m), the
    standing height as the height target, Rudin et al.'s flat-ground rewards."""
    return LeggedRobot(
        description=wd.assets.anymal_c_mjcf,
        feet=tuple(wd.assets.ANYMAL_C_FEET),
        posture="standing",
        contact_shapes=("sphere",),
        sphere_points=20,
        lower_half=True,
        settings=dict(kp=80.0, kd=2.0, torque_limit=wd.assets.ANYMAL_C_TORQUE_LIMIT, mass_scale=(0.9, 1.1), friction=(0.5, 1.25),
                      rewards=GO1_REWARDS),
    )


def go2() -> LeggedRobot:
    """The shipped Go2 (MuJoCo Menagerie's, wd.assets.go2_mjcf()): the lower halves of its four foot spheres (20
    points each) as contacts, unitree_rl_gym's Go2 posture and gains (GO2RoughCfg in
    legged_gym/envs/go2/go2_config.py of github.com/unitreerobotics/unitree_rl_gym: its default joint angles,
    GO2_STANDING_POSE, and its PD drive, stiffness 20 N m/rad and damping 0.5 N m s/rad on every joint; on
    Menagerie's keyframe "home", whose knees bend further, these gains let the Go2 sink and fall),
    GO2_TORQUE_LIMITS (Menagerie's motor ranges: 23.7 N m on the hips and thighs, 45.43 N m on the knees), the standing height
    as the height target, Rudin et al.'s flat-ground rewards."""
    return LeggedRobot(
        description=wd.assets.go2_mjcf,
        feet=tuple(wd.assets.GO2_FEET),
        posture=dict(wd.assets.GO2_STANDING_POSE),
        contact_shapes=("sphere",),
        sphere_points=20,
        lower_half=True,
        settings=dict(kp=20.0, kd=0.5, torque_limit=dict(wd.assets.GO2_TORQUE_LIMITS), mass_scale=(0.9, 1.1), friction=(0.5, 1.25),
                      rewards=GO1_REWARDS),
    )
