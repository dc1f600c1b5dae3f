"""The plain, host-side form that the URDF, MJCF and SDF readers agree on.

A `ModelDescription` is what the parsers agree on: links with their inertial parameters and collision
shapes, joints with their type, axis and origin, which link is the base, and explicit frames (SDF
`<frame>`s) attached to links. Nothing is lumped or reordered here; `warpdyn.tree` does that. All arrays
are float64 NumPy, SI units.

Joint convention (every format): the pose of the child link in the parent link at joint position q is

    parent_H_child(q) = origin @ M(q),

where `origin` is the joint frame in the parent link at q = 0 and M(q) is, in the child frame, a rotation
by q about `axis` through the point `pivot` (revolute), a translation by q along `axis` (prismatic), a
rotation by the unit quaternion q = (w, x, y, z) about `pivot` (ball: 4 positions, 3 velocities, the
child's angular velocity relative to the parent in child axes), or the pose q = (x, y, z, w, x, y, z) of
the child in the joint frame (free: 7 positions, 6 velocities, MuJoCo's: the child origin's linear
velocity relative to the parent in the joint frame's axes, then its angular velocity in child axes).
URDF joints have pivot 0; MJCF joints have their `pos` as pivot; SDF joints have the joint frame's origin
in the child link as pivot. For MJCF hinge and slide joints q is
MuJoCo's qpos: the loader folds MuJoCo's `ref` (qpos0) into `origin`, so that q = qpos everywhere (springs,
actuator lengths and limits included, which MuJoCo also writes in qpos units). A joint's `initial_position`
is where `Data.build` starts it (MuJoCo's qpos0: `ref`, the identity quaternion of a ball joint, a free
body's pose); keyframes (MJCF `<key>`) are kept by name in MuJoCo's qpos/qvel layout.

Elements a description holds that warpdyn does not model are collected, by kind, in
`ModelDescription.not_modelled` and reported by `load` in one `NotModelledWarning`.
"""

from __future__ import annotations

import os
import sys
import warnings
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "ActuatorDescription",
    "NotModelledWarning",
    "warn_not_modelled",
    "CollisionShape",
    "GeomPair",
    "FrameDescription",
    "LinkDescription",
    "JointDescription",
    "Keyframe",
    "ModelDescription",
    "MOVABLE_JOINT_TYPES",
    "JOINT_COORDINATES",
    "JOINT_DOFS",
    "identity_position",
    "finish_tree",
    "homogeneous",
    "joint_motion",
    "axis_angle_to_matrix",
    "quaternion_wxyz_to_matrix",
]

MOVABLE_JOINT_TYPES = ("revolute", "continuous", "prismatic")

JOINT_COORDINATES = {"revolute": 1, "prismatic": 1, "ball": 4, "free": 7}
"""The number of positions of each movable joint type (MuJoCo's nq of a joint)."""

JOINT_DOFS = {"revolute": 1, "prismatic": 1, "ball": 3, "free": 6}
"""The number of velocities (degrees of freedom) of each movable joint type (MuJoCo's nv of a joint)."""


def identity_position(kind: str) -> np.ndarray:
    """The position at which a joint of type `kind` adds no motion: 0, the identity quaternion (ball), the
    identity pose (free)."""
    if kind == "ball":
        return np.array([1.0, 0.0, 0.0, 0.0])
    if kind == "free":
        return np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
    return np.zeros(1)


class NotModelledWarning(UserWarning):
    """A robot description holds elements that warpdyn does not model (listed by kind and name): they are
    read and ignored, or approximated as the message says. Raised once per load."""


_PACKAGE_DIR = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def caller_stacklevel() -> int:
    """The `stacklevel` for warnings.warn, called from the function that calls this, that points at the
    first frame outside the warpdyn package (the user's call), however deep inside warpdyn it is raised."""
    level, frame = 1, sys._getframe(1)  # the caller of this function is level 1 for warnings.warn
    while frame is not None and os.path.abspath(frame.f_code.co_filename).startswith(_PACKAGE_DIR + os.sep):
        frame = frame.f_back
        level += 1
    return level


def warn_not_modelled(where: str, not_modelled: dict[str, list[str]]) -> None:
    """One NotModelledWarning listing `not_modelled` (kind -> names), nothing when it is empty."""
    items = {kind: names for kind, names in not_modelled.items() if names}
    if not items:
        return
    lines = "; ".join(f"{kind}: {names}" for kind, names in items.items())
    warnings.warn(
        f"{where} holds elements that warpdyn does not model: {lines}",
        NotModelledWarning,
        stacklevel=caller_stacklevel(),
    )


@dataclass
class CollisionShape:
    """A collision shape attached to a link.

    kind: "box" (size: full extents (3,)), "sphere" (radius), "ellipsoid" (size: radii along x, y, z (3,)),
    "cylinder" (radius, length along z), "capsule" (radius, length of the cylindrical part along z), "mesh"
    (filename, scale (3,)).
    link_H_shape: (4, 4) pose of the shape in its link frame.
    MJCF geoms also carry what MuJoCo's collision filter and contact parameters read (`GeomPair`): geom (the
    geom's id in MuJoCo's compiled model; -1 for URDF and SDF shapes), name (an unnamed geom g's "geom{g}"), contype and conaffinity (bit masks),
    margin and gap [m], friction (sliding, torsional, rolling), condim, priority. polygons: a mesh's convex
    hull's faces as MuJoCo compiled them (mesh_polynormal, mesh_polyvert; an MJCF's, or a URDF's or SDF's mesh file's
    in `with_self_collision`): (normals (q, 3), unit and outward in the shape's frame; vertex index arrays (q,) into
    `vertices`, counterclockwise about their normal); None elsewhere.
    """

    kind: str
    link_H_shape: np.ndarray
    size: np.ndarray | None = None
    radius: float = 0.0
    length: float = 0.0
    filename: str | None = None
    scale: np.ndarray | None = None
    vertices: np.ndarray | None = None
    geom: int = -1
    name: str = ""
    contype: int = 1
    conaffinity: int = 1
    margin: float = 0.0
    gap: float = 0.0
    friction: tuple = (1.0, 0.005, 0.0001)
    condim: int = 3
    priority: int = 0
    polygons: tuple | None = None


@dataclass
class GeomPair:
    """A pair of geoms that may collide, as MuJoCo's mj_collision decides it before looking at poses (its filters by
    body, weld, bit mask and `<exclude>`; an explicit `<pair>` always), ordered as MuJoCo orders it (geom1's type <=
    geom2's). geom1, geom2: MuJoCo's geom ids (`CollisionShape.geom`); margin, gap [m]: the pair's (the sums of the
    geoms', or the `<pair>`'s); friction (5,): the contact's (sliding twice, torsional, rolling twice: the geoms'
    by priority or maximum, or the `<pair>`'s); condim; explicit: from a `<pair>`."""

    geom1: int
    geom2: int
    margin: float
    gap: float
    friction: tuple
    condim: int
    explicit: bool = False


@dataclass
class LinkDescription:
    """A rigid link: mass [kg], centre of mass `com` (3,) [m] and rotational inertia `inertia` (3, 3)
    [kg m^2] about the centre of mass, both in the link frame.

    visuals: the link's visual shapes (URDF and SDF; primitives with their sizes, meshes by file): not physics, but
    what JaxSim's hardware parametrisation scales (warpdyn.kin_dyn_parameters.HwLinkMetadata). inertial_rotation:
    (3, 3) the axes of the inertial frame in the link (URDF's <inertial><origin rpy>, SDF's inertial pose).

    gravcomp: MuJoCo's `body_gravcomp` (MJCF `<body gravcomp>`; URDF 0): a force gravcomp * mass * |g|
    along +z of the world applied at the centre of mass, that cancels (1), halves (0.5) or exceeds (> 1,
    buoyancy) the link's weight. Massless links (MJCF multi-joint intermediates) have mass 0.
    """

    name: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    collisions: list[CollisionShape] = field(default_factory=list)
    gravcomp: float = 0.0
    visuals: list[CollisionShape] = field(default_factory=list)
    inertial_rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


MUJOCO_SOLREF = (0.02, 1.0)
"""MuJoCo's default solref of a joint's limit and friction rows (jnt_solref, dof_solref where none is given)."""

MUJOCO_SOLIMP = (0.9, 0.95, 0.001, 0.5, 2.0)
"""MuJoCo's default solimp of a joint's limit and friction rows (jnt_solimp, dof_solimp where none is given)."""


@dataclass
class LimitConstraint:
    """MuJoCo's limit constraint of a hinge or slide joint's range [lower, upper] (an MJCF's limited joint; a URDF's or
    SDF's joint with both bounds, with MuJoCo's defaults), or of a ball joint's rotation angle (an MJCF's limited ball):
    its solref (2), solimp (5), margin [rad or m] (the row acts from that far inside the range) and invweight (MuJoCo's
    dof_invweight0, the scale of the row's regularisation R; None: the lumped tree's, warpdyn.description.invweight);
    angle: a ball joint's bound on its rotation angle [rad] (MuJoCo's max of its range), None for a hinge or slide."""

    solref: np.ndarray
    solimp: np.ndarray
    margin: float
    invweight: float | None
    angle: float | None = None


@dataclass
class FrictionConstraint:
    """MuJoCo's friction constraint of a hinge or slide joint with frictionloss (an MJCF's dof_frictionloss; a URDF's
    or SDF's joint friction, with MuJoCo's defaults; the joint's `friction`): its solref (2), solimp (5) and invweight
    (MuJoCo's dof_invweight0; None: the lumped tree's)."""

    solref: np.ndarray
    solimp: np.ndarray
    invweight: float | None


@dataclass
class JointDescription:
    """A joint between two links (see the module docstring for the convention).

    type: "revolute", "prismatic", "ball", "free" or "fixed" ("continuous" is read as a revolute without
    limits); a floating base's joint is "floating" (only between `world` and the base, removed by
    `finish_tree`): a "free" joint is a free body of a scene with several trees (its parent the world).
    origin: (4, 4) joint frame in the parent link at q = 0. axis: (3,) unit vector in the child frame.
    pivot: (3,) point of the rotation axis in the child frame [m].
    lower, upper: position limits [rad or m] (+-inf: none). MuJoCo treats them as constraints: a limited hinge or
    slide joint (an MJCF's; a URDF's or SDF's with both bounds) carries its `limit_constraint`, which a step solves as
    MuJoCo does where `model.limit_constraints` is set; otherwise warpdyn has JaxSim's limit springs (an MJCF's
    NotModelledWarning says so).
    effort, velocity: URDF `<limit>` [N m or N, rad/s or m/s] (MJCF: inf).

    Dynamics parameters ([.] for a revolute / prismatic joint). Two different dampings:
    - damping: JaxSim's viscous friction, tau = -damping * qdot [N m s/rad or N s/m]: URDF `<dynamics
      damping>`; 0 for MJCF (MuJoCo's damping is `passive_damping`).
    - passive_damping: MuJoCo's damper, qfrc_damper = -passive_damping * qdot, integrated implicitly by
      MuJoCo's Euler (see docs/mujoco_semantics.md): MJCF `dof_damping` plus gear^2 * `damping` of the
      actuators with a joint transmission on this joint (MuJoCo >= 3.7, mj_actuatorDamping); URDF 0.
    friction: static friction [N m or N] as JaxSim applies it: URDF `<dynamics friction>`, MJCF
      `frictionloss` (a friction constraint in MuJoCo: a hinge or slide joint with friction carries its
      `friction_constraint`, which a step solves as MuJoCo does where `model.frictionloss_constraints` is set).
    armature: added to the diagonal of the mass matrix [kg m^2 or kg]: MJCF `dof_armature` (defaults
      included) plus gear^2 * `armature` of the actuators on this joint (mj_actuatorArmature); URDF 0.
    stiffness, springref: MuJoCo's joint spring tau = -stiffness * (q - springref) [N m/rad or N/m; rad or
      m], springref in q units (= qpos: MJCF `qpos_spring`, degrees already converted); URDF 0.
    actuator_force_range: (2,) clamp of the total actuator force on this joint (MuJoCo's qfrc_actuator,
      gravcomp of `actuator_gravcomp` joints included) [N m or N]: MJCF `actuatorfrcrange` when
      `actuatorfrclimited`, else (-inf, inf).
    actuator_gravcomp: MJCF `actuatorgravcomp`: the gravity compensation on this joint is part of the
      actuator force (clamped by actuator_force_range) instead of a passive force.
    A ball or free joint's damping, friction, passive_damping and armature apply to each of its degrees of
    freedom alike (MJCF gives one value per joint); its stiffness pulls it back to its initial position (MuJoCo's
    qpos_spring), its limits, effort and velocity limits are not read (none: +-inf).
    initial_position: (nq,) where `Data.build` starts the joint (MuJoCo's qpos0); None: `identity_position`.
    """

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    pivot: np.ndarray = field(default_factory=lambda: np.zeros(3))
    lower: float = -np.inf
    upper: float = np.inf
    effort: float = np.inf
    velocity: float = np.inf
    damping: float = 0.0
    friction: float = 0.0
    passive_damping: float = 0.0
    armature: float = 0.0
    stiffness: float = 0.0
    springref: float = 0.0
    actuator_force_range: np.ndarray = field(default_factory=lambda: np.array([-np.inf, np.inf]))
    actuator_gravcomp: bool = False
    initial_position: np.ndarray | None = None
    limit_constraint: LimitConstraint | None = None
    friction_constraint: FrictionConstraint | None = None

    @property
    def coordinates(self) -> int:
        """The joint's number of positions (1, 4 for a ball joint, 7 for a free one; 0 when fixed)."""
        return JOINT_COORDINATES.get(self.type, 0)

    @property
    def dofs(self) -> int:
        """The joint's number of velocities (1, 3 for a ball joint, 6 for a free one; 0 when fixed)."""
        return JOINT_DOFS.get(self.type, 0)

    def start_position(self) -> np.ndarray:
        """(nq,) the joint's initial position (`initial_position`, else `identity_position`)."""
        if self.initial_position is None:
            return identity_position(self.type)
        return np.asarray(self.initial_position, dtype=np.float64).reshape(self.coordinates)


@dataclass
class Keyframe:
    """A named state of the description (MJCF `<key>`), in MuJoCo's layout: qpos (nq,) and qvel (nv,) over
    MuJoCo's joints (`joints`, the names in MuJoCo's joint order, each with its (qposadr, dofadr)), ctrl (nu,)
    over the description's actuators, time [s]."""

    name: str
    qpos: np.ndarray
    qvel: np.ndarray
    ctrl: np.ndarray
    time: float = 0.0


@dataclass
class FrameDescription:
    """An explicit frame (SDF `<frame>`) rigidly attached to link `link` of the description, at `link_H_frame`
    (4, 4) in that link's frame. `build_tree` makes it a frame of the model (after the lumped links), moved to
    the kept link its link is lumped into. Its name must differ from every link's and every other frame's."""

    name: str
    link: str
    link_H_frame: np.ndarray = field(default_factory=lambda: np.eye(4))


@dataclass
class EqualityDescription:
    """A MuJoCo equality constraint that warpdyn enforces (MJCF `<equality>`, active at the start), solved as
    MuJoCo solves it (warpdyn.engine.equality).

    kind "connect": the point `anchor1` (3,) [m] of body `body1` and the point `anchor2` of body `body2` (each
    in its body's frame; "world" for the world) coincide (3 rows: their difference in world axes);
    kind "weld": as a connect, and the frames body1 (x) rot1 and body2 (x) rot2 (rot1, rot2: unit quaternions
    (w, x, y, z) in their bodies' frames: MuJoCo's relpose and the identity, or the welded sites' frames) turn
    alike (3 more rows: torquescale times the vector part of their relative rotation, MuJoCo's);
    kind "joint": joint1's position q1 follows joint2's q2 (1 row: q1 - q1_0 - sum_k polycoef[k] (q2 - q2_0)^k,
    q_0 MuJoCo's qpos0; joint2 None: q1 - q1_0 - polycoef[0]); kind "tendon": the same of two fixed tendons'
    lengths L = sum_j coef_j q_j (tendon1, tendon2: their (joint, coef) terms; tendon2 None: none), L_0 at qpos0.
    solref (2,), solimp (5,): MuJoCo's softness (eq_solref, eq_solimp); invweight: MuJoCo's approximate inverse
    inertia of the constraint rows (the two bodies' translational body_invweight0, or the two DoFs'
    dof_invweight0, summed), its regularisation R = (1 - imp) / imp invweight; invweight_rotation: a weld's
    rotation rows' (the bodies' rotational body_invweight0, summed)."""

    name: str
    kind: str
    body1: str = "world"
    body2: str = "world"
    anchor1: np.ndarray = field(default_factory=lambda: np.zeros(3))
    anchor2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    joint1: str | None = None
    joint2: str | None = None
    tendon1: list[tuple[str, float]] | None = None
    tendon2: list[tuple[str, float]] | None = None
    rot1: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    rot2: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    torquescale: float = 1.0
    invweight_rotation: float = 0.0
    polycoef: np.ndarray = field(default_factory=lambda: np.zeros(5))
    solref: np.ndarray = field(default_factory=lambda: np.array([0.02, 1.0]))
    solimp: np.ndarray = field(default_factory=lambda: np.array([0.9, 0.95, 0.001, 0.5, 2.0]))
    invweight: float = 0.0


@dataclass
class ActuatorDescription:
    """A MuJoCo actuator with a joint transmission on a hinge or slide joint and no activation dynamics
    (what warpdyn models; the loader drops the others and lists them in its NotModelledWarning).

    With q, qdot the joint's position and velocity (q = MuJoCo's qpos) and ctrl the control:
        u      = clip(ctrl, ctrl_range)               if ctrl_limited (and MuJoCo's clampctrl is not disabled)
        length = gear * q,  velocity = gear * qdot
        gain   = gain[0]                                              gain_type "fixed"
               = gain[0] + gain[1] * length + gain[2] * velocity      gain_type "affine"
        bias   = 0                                                    bias_type "none"
               = bias[0] + bias[1] * length + bias[2] * velocity      bias_type "affine"
        force  = gain * u + bias,  clipped to force_range if force_limited
        tau    = gear * force  on the joint (summed over actuators, then clipped to the joint's
                 actuator_force_range)
    name: the actuator's name. joint: the joint's name. gear: MuJoCo's gear[0] [-]. ctrl_range,
    force_range: (2,) [ctrl units; N m or N of the actuator force, before gear]. gain, bias: (3,)
    MuJoCo's gainprm[0:3], biasprm[0:3] (a position servo is gain (kp, 0, 0), bias (0, -kp, -kv)).
    """

    name: str
    joint: str
    gear: float = 1.0
    ctrl_range: np.ndarray = field(default_factory=lambda: np.zeros(2))
    ctrl_limited: bool = False
    force_range: np.ndarray = field(default_factory=lambda: np.zeros(2))
    force_limited: bool = False
    gain: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0]))
    gain_type: str = "fixed"
    bias: np.ndarray = field(default_factory=lambda: np.zeros(3))
    bias_type: str = "none"


@dataclass
class ModelDescription:
    """A robot as read from its description, before lumping.

    base: name of the base link. fixed_base: whether the base is welded to the world, at world_H_base.
    initial_world_H_base: (4, 4) where the description places a floating base in the world (SDF: the pose
    of the `<model>`, in its `<world>` if any, composed with the base link's pose in the model), the default
    base pose of `Data.build`; None where the description says nothing (URDF, MJCF: the origin) and for a
    fixed base (whose pose is world_H_base).
    links and joints keep the order of the description; joints form a tree rooted at `base`. A fixed
    base named "world" is the MJCF world body when it has several children (bodies welded to the world
    are lumped into it by `build_tree`, each jointed child starts a subtree).
    path: the file it was read from (None for an XML string); relative mesh paths resolve against it.

    MJCF only (URDF: empty, or None):
    actuators: the modelled actuators (see ActuatorDescription) in MuJoCo's order.
    gravity: (3,) the world's gravity [m/s^2, world frame]: MuJoCo's opt.gravity, SDF's `<world><gravity>`
    (None: the description says nothing; the model then takes (0, 0, -9.81)).
    time_step: opt.timestep [s]. integrator: MuJoCo's name, "Euler", "RK4", "implicit",
    "implicitfast" (or "discrete" for MuJoCo >= 4).
    disabled: MuJoCo's disable flags that are set, by their XML names (`<option><flag NAME="disable">`),
    e.g. "gravity" (no gravity, no gravity compensation), "spring", "damper" (both: no passive force at
    all, gravity compensation included), "actuation", "clampctrl", "eulerdamp", "constraint",
    "frictionloss", "limit".
    not_modelled: kind -> names of the elements warpdyn does not model (reported by `load` in one
    NotModelledWarning).
    frames: explicit frames attached to links (`FrameDescription`; SDF `<frame>`s, in the file's order).
    URDF and MJCF have none: their frames are the links that fixed joints weld (`build_tree`).
    keyframes: MJCF `<key>`s (`Keyframe`) in the file's order; mujoco_joints: (name, type, qposadr, dofadr) of
    MuJoCo's joints in MuJoCo's order (the layout of a keyframe's qpos and qvel; the floating base's free joint
    included, named as in the file); empty for URDF and SDF.
    base_joint: a floating base's free joint (MJCF), for its armature, passive_damping and stiffness (MuJoCo
    applies them to the base's 6 DoFs: `warpdyn.description.tree.KinematicTree`); None otherwise.
    equalities: the MJCF equality constraints warpdyn enforces (`EqualityDescription`), in MuJoCo's order.
    geom_pairs: the pairs of geoms on bodies that MuJoCo may collide (`GeomPair`, warpdyn.description.collision_pairs),
    in MuJoCo's order, those of geom types warpdyn's narrow phase collides; empty for URDF and SDF. excludes: an MJCF's
    `<exclude>`s, (body1, body2) names (what the MJCF export writes back). world_geoms: the
    colliding geoms that do not move (on the world body or on bodies welded to it; planes and heightfields aside: the
    terrain), their `link_H_shape` their pose in the world, as MuJoCo places them. ground: the MJCF world body's
    one colliding plane, (unit normal (3,), point (3,)) [world, m] as MuJoCo places it, which a model takes as its terrain;
    None without one (then, and for URDF and SDF, the terrain is the plane z = 0). multiccd: whether MuJoCo's multiCCD
    acts (several contacts where geoms of GJK and EPA's pairs meet face to face: kernels/collision_polygons.py), as the
    MJCF's flags say; on for URDF and SDF, MuJoCo 4's default.
    """

    name: str
    links: list[LinkDescription]
    joints: list[JointDescription]
    base: str
    fixed_base: bool
    world_H_base: np.ndarray
    source: str
    path: str | None = None
    actuators: list[ActuatorDescription] = field(default_factory=list)
    gravity: np.ndarray | None = None
    time_step: float | None = None
    integrator: str | None = None
    disabled: frozenset = frozenset()
    not_modelled: dict[str, list[str]] = field(default_factory=dict)
    frames: list[FrameDescription] = field(default_factory=list)
    initial_world_H_base: np.ndarray | None = None
    keyframes: list[Keyframe] = field(default_factory=list)
    mujoco_joints: list[tuple[str, str, int, int]] = field(default_factory=list)
    base_joint: JointDescription | None = None
    equalities: list[EqualityDescription] = field(default_factory=list)
    geom_pairs: list[GeomPair] = field(default_factory=list)
    world_geoms: list[CollisionShape] = field(default_factory=list)
    excludes: list[tuple[str, str]] = field(default_factory=list)
    ground: tuple[np.ndarray, np.ndarray] | None = None
    multiccd: bool = True

    def link(self, name: str) -> LinkDescription:
        for link in self.links:
            if link.name == name:
                return link
        raise KeyError(name)


def homogeneous(rotation: np.ndarray, translation) -> np.ndarray:
    H = np.eye(4)
    H[:3, :3] = rotation
    H[:3, 3] = translation
    return H


def quaternion_wxyz_to_matrix(q) -> np.ndarray:
    """Rotation matrix (3, 3) of a unit quaternion given as (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=np.float64) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def matrix_to_quaternion_wxyz(R) -> np.ndarray:
    """A unit quaternion (w, x, y, z) of the rotation matrix R (3, 3) (Shepperd's method: the largest of the four
    squares first; either sign of a quaternion is the same rotation)."""
    R = np.asarray(R, dtype=np.float64)
    squares = [1 + np.trace(R), 1 + R[0, 0] - R[1, 1] - R[2, 2], 1 - R[0, 0] + R[1, 1] - R[2, 2], 1 - R[0, 0] - R[1, 1] + R[2, 2]]
    k = int(np.argmax(squares))
    s = 2.0 * np.sqrt(squares[k])
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    q = np.array(q)
    return q / np.linalg.norm(q)


def quaternion_product(a, b) -> np.ndarray:
    """a (x) b, both (w, x, y, z)."""
    aw, av, bw, bv = a[0], np.asarray(a[1:], dtype=np.float64), b[0], np.asarray(b[1:], dtype=np.float64)
    return np.concatenate([[aw * bw - av @ bv], aw * bv + bw * av + np.cross(av, bv)])


def finish_tree(name, links, joints, source, where) -> ModelDescription:
    """Checks that the joints form one tree of named links and joints, and finds its base (a 'world' root is
    the world)."""
    for kind, names in (("link", [link.name for link in links]), ("joint", [joint.name for joint in joints])):
        unnamed = [k for k, n in enumerate(names) if not isinstance(n, str) or not n.strip()]
        if unnamed:
            raise ValueError(f"{where}: the {kind}s at positions {unnamed} (in the description's order) have empty names")
        duplicated = sorted({n for n in names if names.count(n) > 1})
        if duplicated:
            raise ValueError(f"{where}: {kind} names {duplicated} are used more than once")
    link_names = {link.name for link in links}
    children = set()
    for joint in joints:
        for role, link in (("parent", joint.parent), ("child", joint.child)):
            if link not in link_names:
                raise ValueError(f"{where}: joint '{joint.name}' names {role} link '{link}', which is not defined")
        if joint.child in children:
            raise ValueError(f"{where}: link '{joint.child}' is the child of more than one joint")
        children.add(joint.child)
    roots = [link.name for link in links if link.name not in children]
    if len(roots) != 1:
        raise ValueError(f"{where}: expected one root link, found {len(roots)}: {roots}")
    reached, queue = {roots[0]}, [roots[0]]
    by_parent: dict[str, list[str]] = {}
    for joint in joints:
        by_parent.setdefault(joint.parent, []).append(joint.child)
    while queue:
        for child in by_parent.get(queue.pop(), []):
            reached.add(child)
            queue.append(child)
    detached = [link.name for link in links if link.name not in reached]
    if detached:
        raise ValueError(
            f"{where}: links {detached} are not connected to the root link '{roots[0]}': their joints form a cycle"
        )
    base, fixed_base, world_H_base = roots[0], False, np.eye(4)
    if base == "world":
        world_joints = [j for j in joints if j.parent == "world"]
        if len(world_joints) == 1 and world_joints[0].type in ("fixed", "floating"):
            joint = world_joints[0]
            base, fixed_base = joint.child, joint.type == "fixed"
            world_H_base = joint.origin if fixed_base else np.eye(4)
            joints = [j for j in joints if j is not joint]
            links = [link for link in links if link.name != "world"]
        else:
            fixed_base = True
    joints = [_free_inside(j) if j.type == "floating" else j for j in joints]
    for joint in joints:
        if joint.type not in ("revolute", "prismatic", "ball", "free", "fixed"):
            raise ValueError(
                f"{where}: joint '{joint.name}' has type '{joint.type}', which warpdyn does not support inside the tree "
                "(supported: revolute, continuous, prismatic, ball, free, fixed)"
            )
        if source != "mjcf":
            _mujoco_rows(joint)
    return ModelDescription(name, links, joints, base, fixed_base, world_H_base, source)


def _mujoco_rows(joint: JointDescription) -> None:
    """A URDF's or SDF's hinge or slide joint's limit and friction constraints as MuJoCo makes them from the same joint
    (its URDF import: a range with both bounds is limited, `friction` its frictionloss), MuJoCo's default solref,
    solimp and margin 0, their invweight the tree's (None here)."""
    if joint.type not in ("revolute", "prismatic"):
        return
    if np.isfinite(joint.lower) and np.isfinite(joint.upper) and joint.lower < joint.upper:  # equal bounds: MuJoCo ignores them
        joint.limit_constraint = LimitConstraint(solref=np.array(MUJOCO_SOLREF), solimp=np.array(MUJOCO_SOLIMP), margin=0.0, invweight=None)
    if joint.friction > 0.0:
        joint.friction_constraint = FrictionConstraint(solref=np.array(MUJOCO_SOLREF), solimp=np.array(MUJOCO_SOLIMP), invweight=None)


def _free_inside(joint: JointDescription) -> JointDescription:
    """A floating joint that is not a floating base's (URDF's "floating" between two links) as a free joint."""
    return JointDescription(name=joint.name, type="free", parent=joint.parent, child=joint.child, origin=joint.origin)


def joint_motion(kind: str, axis: np.ndarray, pivot: np.ndarray, q) -> np.ndarray:
    """M(q) of the module docstring, as a (4, 4) transform: q a number (revolute, prismatic), a unit
    quaternion (w, x, y, z) (ball) or a pose (x, y, z, w, x, y, z) (free)."""
    if kind == "prismatic":
        return homogeneous(np.eye(3), axis * float(np.reshape(q, -1)[0]))
    if kind == "revolute":
        R = axis_angle_to_matrix(axis, float(np.reshape(q, -1)[0]))
        return homogeneous(R, pivot - R @ pivot)
    if kind == "ball":
        R = quaternion_wxyz_to_matrix(np.reshape(q, 4))
        return homogeneous(R, pivot - R @ pivot)
    if kind == "free":
        q = np.reshape(q, 7)
        return homogeneous(quaternion_wxyz_to_matrix(q[3:]), q[:3])
    return np.eye(4)


def axis_angle_to_matrix(axis, angle: float) -> np.ndarray:
    """Rotation matrix (3, 3) of `angle` [rad] about the unit `axis` (3,)."""
    x, y, z = axis
    c, s = np.cos(angle), np.sin(angle)
    C = 1.0 - c
    return np.array(
        [
            [c + x * x * C, x * y * C - z * s, x * z * C + y * s],
            [y * x * C + z * s, c + y * y * C, y * z * C - x * s],
            [z * x * C - y * s, z * y * C + x * s, c + z * z * C],
        ]
    )

