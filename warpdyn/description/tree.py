"""The kinematic tree a model computes on: fixed joints lumped, links in breadth-first order.

Orders (documented once, used everywhere):
- Links: breadth-first from the base over the lumped tree, the children of a link sorted by name, as
  JaxSim orders them (so that the order does not depend on the order of the description's elements, and
  JaxSim's indices are warpdyn's). So parent index < child index, and link 0 is the base.
- Joints: joint i is the joint whose child is link i + 1, so joints follow the link order. Each joint has
  its own positions and velocities (`KinematicTree.q_start`, `v_start`: MuJoCo's qposadr and dofadr): one
  of each for a revolute or prismatic joint, 4 and 3 for a ball joint, 7 and 6 for a free one, in joint
  order.
- Frames: every lumped link and the description's explicit frames (`ModelDescription.frames`, SDF
  `<frame>`s), sorted by name, as JaxSim, each on the kept link that its link is lumped into.
- Collision shapes (and so collidable points): by link in the description's order of the links, each
  link's in the description's order, on the kept link it is lumped into (JaxSim's order).

Lumping a fixed joint (or a joint locked by a reduction) moves the child's mass into the parent: its
centre of mass is moved into the parent frame and its inertia rotated and shifted with the parallel-axis
theorem. The lumped link becomes a frame (name, parent link, fixed transform); its collision shapes
move to the parent. Gravity compensation is lumped the same way (see `KinematicTree`); actuators on a
joint that a reduction locks are dropped with a NotModelledWarning.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np

from ..arrays import names_argument
from .invweight import dof_invweight0, inertia_in_frame
from .model import (
    CollisionShape,
    ModelDescription,
    NotModelledWarning,
    caller_stacklevel,
    joint_motion,
    matrix_to_quaternion_wxyz,
    quaternion_product,
)

JOINT_REVOLUTE = 1
JOINT_PRISMATIC = 2
JOINT_BALL = 3
JOINT_FREE = 4
JOINT_KINDS = {"revolute": JOINT_REVOLUTE, "prismatic": JOINT_PRISMATIC, "ball": JOINT_BALL, "free": JOINT_FREE}
"""The joint kinds by description type; the kernels' codes (kernels/spatial.py)."""


@dataclass
class TreeActuator:
    """An `ActuatorDescription` (see there for the force law) on kept joint `joint` (index into the tree's
    joints, 0..n-1; the joint of link joint + 1), named `joint_name`."""

    name: str
    joint: int
    joint_name: str
    gear: float
    ctrl_range: np.ndarray  # (2,) [ctrl units]
    ctrl_limited: bool
    force_range: np.ndarray  # (2,) actuator force before gear [N m or N per unit gear]
    force_limited: bool
    gain: np.ndarray  # (3,) gainprm[0:3]
    gain_type: str  # "fixed" | "affine"
    bias: np.ndarray  # (3,) biasprm[0:3]
    bias_type: str  # "none" | "affine"


@dataclass
class TreeEquality:
    """An equality constraint on the lumped tree (a description's `EqualityDescription`): a connect's or weld's
    anchors p1, p2 [m] in the frames of links link1, link2 (-1: the world), and a weld's frames Q1, Q2 (unit
    quaternions (w, x, y, z): body (x) rot in those links' frames); a joint or fixed-tendon coupling's lengths as
    terms1, terms2 ((tree joint index, coef) pairs: one (j, 1) for a joint; terms2 empty: none) and their values
    at qpos0 ref1, ref2; kind, polycoef, solref, solimp, torquescale, invweight and invweight_rotation as the
    description's. kind "frame_weld": JaxSim's weld of two frames (warpdyn.types.constraints' ConstraintMap; the
    frames' origins p1, p2 and orientations Q1, Q2 in their links), with baumgarte (K_P [1/s^2], K_D [1/s]) and
    regularization (the rows' R) instead of solref, solimp and invweight. kind "limit" or "friction": MuJoCo's limit
    or friction constraint of the joint terms1's [(j, 1)] (its solref, solimp, invweight; a limit's margin [rad or m];
    the bounds the model's position_limits or friction_static; a ball joint's limit its bound on the rotation angle,
    angle [rad], None for the others)."""

    name: str
    kind: str
    link1: int = -1
    link2: int = -1
    p1: np.ndarray = field(default_factory=lambda: np.zeros(3))
    p2: np.ndarray = field(default_factory=lambda: np.zeros(3))
    Q1: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    Q2: np.ndarray = field(default_factory=lambda: np.array([1.0, 0.0, 0.0, 0.0]))
    torquescale: float = 1.0
    invweight_rotation: float = 0.0
    terms1: list[tuple[int, float]] = field(default_factory=list)
    terms2: list[tuple[int, float]] = field(default_factory=list)
    ref1: float = 0.0
    ref2: float = 0.0
    polycoef: np.ndarray = field(default_factory=lambda: np.zeros(5))
    solref: np.ndarray = field(default_factory=lambda: np.zeros(2))
    solimp: np.ndarray = field(default_factory=lambda: np.zeros(5))
    invweight: float = 0.0
    baumgarte: np.ndarray = field(default_factory=lambda: np.zeros(2))
    regularization: float = 0.0
    margin: float = 0.0
    angle: float | None = None
    source: int = -1  # its index in the description's equalities (-1: none, a frame weld)


@dataclass
class KinematicTree:
    """Host-side (NumPy, float64) constants of a lumped tree with nL links, nj joints, nq joint positions,
    nv joint velocities (degrees of freedom) and nF frames.

    Joint arrays (nj,) follow the tree's joint order, DoF arrays (nv,) the joints' velocities (a ball or free
    joint's value repeated over its DoFs), position arrays (nq,) their positions; [a or b] reads "a for a
    revolute, b for a prismatic joint" (a ball or free joint's rotational DoFs are revolute, its translational
    ones prismatic); q is warpdyn's joint position (= MuJoCo's qpos for MJCF). URDF gives 0 (False, +-inf)
    for every MuJoCo-only quantity. Limits, effort and velocity limits of ball and free joints are +-inf.
    - q_start, v_start (nL + 1,) int: link i's joint has positions q_start[i]:q_start[i + 1] and velocities
      v_start[i]:v_start[i + 1] (none for the base: q_start[0] = q_start[1] = 0).
    - qpos0 (nq,): where each joint starts (`JointDescription.start_position`, MuJoCo's qpos0).
    - base_armature, base_damping, base_stiffness: a floating base's free-joint parameters (MJCF), MuJoCo's on
      its 6 DoFs in MuJoCo's coordinates (world linear velocity, body angular velocity): the same numbers in the
      base's Body and Mixed velocities, which differ by a rotation; the spring pulls the base to the
      description's pose (`ModelDescription.initial_world_H_base`, MuJoCo's qpos_spring).
    - per DoF: damping: JaxSim's viscous friction, -damping * qdot [N m s/rad or N s/m] (URDF `<dynamics
      damping>`; 0 for MJCF). friction: static friction [N m or N] (URDF `<dynamics friction>`, MJCF
      frictionloss). passive_damping: MuJoCo's damper, -passive_damping * qdot [N m s/rad or N s/m],
      dof_damping plus gear^2 * actuator damping (MuJoCo's Euler integrates it implicitly unless
      "eulerdamp" or "damper" is in ModelDescription.disabled). armature: added to the DoF's diagonal entry
      of the mass matrix [kg m^2 or kg] (dof_armature plus gear^2 * actuator armature).
    - per joint: stiffness, springref: spring -stiffness * (q - springref) [N m/rad or N/m; rad or m];
      springref is in q units (MuJoCo's qpos_spring; independent of MuJoCo's `ref`, which the origin
      absorbs). A ball or free joint's spring pulls it towards qpos0 (MuJoCo's qpos_spring there); its
      springref is 0.
    - actuator_force_range (n, 2): clamp of the summed actuator torque on the joint (gear * force summed
      over its actuators, plus its gravity compensation when actuator_gravcomp) [N m or N]; +-inf: none.
    - actuator_gravcomp (n,) bool: the joint's share of gravity compensation goes into the actuator torque
      (before the clamp) instead of the passive torque.
    Link arrays (nL,), link order:
    - gravcomp_mass [kg]: sum of gravcomp_b * mass_b over the bodies lumped into the link (gravcomp 0:
      none). The gravity compensation is the force gravcomp_mass * |g| along +z of the WORLD, applied at
      gravcomp_com [m, link frame] (sum(gravcomp_b mass_b c_b) / gravcomp_mass, c_b the member's CoM in the
      link frame; 0 where gravcomp_mass is 0). Exact: parallel forces sum to one force at that point.
      It vanishes when "gravity" is disabled, or both "spring" and "damper" are.
    actuators: the description's actuators on kept joints (`TreeActuator`), in the description's order.
    equalities: the description's equality constraints (`TreeEquality`) whose joints the tree keeps; limits: MuJoCo's
    limit constraints of the joints it keeps (kind "limit": an MJCF's, a URDF's or an SDF's; a step solves them where
    `model.limit_constraints` is set);
    friction_rows: its friction constraints (kind "friction"; where `model.frictionloss_constraints` is set).
    """

    link_names: list[str]
    joint_names: list[str]
    frame_names: list[str]
    parent: np.ndarray  # (nL,) int: parent link index, -1 for the base
    joint_type: np.ndarray  # (nL,) int: JOINT_REVOLUTE / PRISMATIC / BALL / FREE, 0 for the base
    parent_H_joint: np.ndarray  # (nL, 4, 4): joint frame in the parent link at q = 0
    joint_axis: np.ndarray  # (nL, 3): joint axis in the link frame
    joint_pivot: np.ndarray  # (nL, 3): point of a revolute axis in the link frame [m]
    link_mass: np.ndarray  # (nL,) [kg]
    link_com: np.ndarray  # (nL, 3): centre of mass in the link frame [m]
    link_inertia: np.ndarray  # (nL, 3, 3): rotational inertia about the CoM, link axes [kg m^2]
    frame_parent: np.ndarray  # (nF,) int: parent link index
    link_H_frame: np.ndarray  # (nF, 4, 4)
    position_limits: np.ndarray  # (nj, 2): lower, upper [rad or m]; +-inf where unlimited
    effort_limits: np.ndarray  # (nj,) [N m or N]
    velocity_limits: np.ndarray  # (nj,) [rad/s or m/s]
    damping: np.ndarray  # (nv,) viscous friction from the description (URDF; 0 for MJCF)
    friction: np.ndarray  # (nv,) static friction from the description
    collisions: list[list[CollisionShape]]  # per link, shapes in the link frame
    shape_order: list[tuple[int, int]] = field(default_factory=list)  # (link, k) of collisions[link][k], in the description's order
    locked_joints: dict[str, float] = field(default_factory=dict)
    armature: np.ndarray = None  # (nv,) [kg m^2 or kg]
    passive_damping: np.ndarray = None  # (nv,) MuJoCo's damper [N m s/rad or N s/m]
    stiffness: np.ndarray = None  # (nj,) [N m/rad or N/m]
    springref: np.ndarray = None  # (nj,) [rad or m], in q units
    actuator_force_range: np.ndarray = None  # (nj, 2) [N m or N]
    actuator_gravcomp: np.ndarray = None  # (nj,) bool
    gravcomp_mass: np.ndarray = None  # (nL,) [kg]
    gravcomp_com: np.ndarray = None  # (nL, 3) [m], link frame
    actuators: list[TreeActuator] = field(default_factory=list)
    q_start: np.ndarray = None  # (nL + 1,) int
    v_start: np.ndarray = None  # (nL + 1,) int
    qpos0: np.ndarray = None  # (nq,)
    base_armature: float = 0.0  # a floating base's free-joint armature [kg or kg m^2] (MJCF; each of its 6 DoFs)
    base_damping: float = 0.0  # its damper [N s/m or N m s/rad]
    base_stiffness: float = 0.0  # its spring towards the description's base pose [N/m or N m/rad]
    equalities: list[TreeEquality] = field(default_factory=list)
    limits: list[TreeEquality] = field(default_factory=list)  # MuJoCo's limit constraints (kind "limit"), one per limited hinge, slide or ball joint
    friction_rows: list[TreeEquality] = field(default_factory=list)  # its friction constraints (kind "friction"), one per hinge or slide with friction

    def __post_init__(self):
        nj, nL = len(self.joint_names), len(self.link_names)
        if self.q_start is None:  # one position and one velocity per joint
            self.q_start = np.concatenate([[0], np.arange(nL)]).astype(np.int32)
            self.v_start = self.q_start.copy()
        nv, nq = int(self.v_start[-1]), int(self.q_start[-1])
        defaults = {
            "armature": np.zeros(nv),
            "passive_damping": np.zeros(nv),
            "stiffness": np.zeros(nj),
            "springref": np.zeros(nj),
            "actuator_force_range": np.tile([-np.inf, np.inf], (nj, 1)).reshape(nj, 2),
            "actuator_gravcomp": np.zeros(nj, dtype=bool),
            "gravcomp_mass": np.zeros(nL),
            "gravcomp_com": np.zeros((nL, 3)),
            "qpos0": np.zeros(nq),
        }
        for name, value in defaults.items():
            if getattr(self, name) is None:
                setattr(self, name, value)

    @property
    def number_of_links(self) -> int:
        return len(self.link_names)

    @property
    def number_of_joints(self) -> int:
        """nj: the joints (one per link but the base)."""
        return len(self.joint_names)

    @property
    def dofs(self) -> int:
        """nv: the joints' velocities (degrees of freedom)."""
        return int(self.v_start[-1])

    @property
    def coordinates(self) -> int:
        """nq: the joints' positions."""
        return int(self.q_start[-1])

    @property
    def one_dof_joints(self) -> bool:
        """Whether every joint has one position and one velocity (no ball or free joint)."""
        return self.coordinates == self.dofs == self.number_of_joints

    @property
    def free_roots(self) -> bool:
        """Whether every joint has one position and one velocity but free joints whose parent is the base (a
        scene's free bodies and floating robots, below its world)."""
        kinds, parents = np.asarray(self.joint_type[1:]), np.asarray(self.parent[1:])
        several = (kinds == JOINT_BALL) | (kinds == JOINT_FREE)
        return bool(np.all(kinds[several] == JOINT_FREE) and np.all(parents[several] == 0))

    def dof_joint(self) -> np.ndarray:
        """(nv,) int32: the joint of each DoF."""
        return np.repeat(np.arange(self.number_of_joints, dtype=np.int32), np.diff(self.v_start[1:]))

    def dof_kind(self) -> np.ndarray:
        """(nv,) int32: JOINT_REVOLUTE for a rotational DoF, JOINT_PRISMATIC for a translational one (a ball
        joint's 3 rotational, a free joint's 3 translational then 3 rotational)."""
        kinds = []
        for kind in self.joint_type[1:]:
            kinds += {JOINT_BALL: [JOINT_REVOLUTE] * 3, JOINT_FREE: [JOINT_PRISMATIC] * 3 + [JOINT_REVOLUTE] * 3}.get(int(kind), [int(kind)])
        return np.array(kinds, dtype=np.int32)

    def support(self) -> np.ndarray:
        """(nL, nj) int32: 1 where joint j lies on the path from the base to link L."""
        support = np.zeros((self.number_of_links, self.number_of_joints), dtype=np.int32)
        for link in range(1, self.number_of_links):
            support[link] = support[self.parent[link]]
            support[link, link - 1] = 1
        return support


def _combine(bodies):
    """Mass, CoM and inertia about the CoM of rigidly joined bodies given in one frame."""
    total = sum(m for m, _, _ in bodies)
    if total <= 0.0:  # massless bodies: only their rotational inertias (unphysical, but as described) add up
        inertia = sum((I for _, _, I in bodies), np.zeros((3, 3)))
        return 0.0, np.zeros(3), 0.5 * (inertia + inertia.T)
    com = sum(m * c for m, c, _ in bodies) / total
    inertia = np.zeros((3, 3))
    for m, c, I in bodies:
        d = c - com
        inertia += I + m * (d @ d * np.eye(3) - np.outer(d, d))
    return total, com, 0.5 * (inertia + inertia.T)


def _locked_position(joint, value) -> np.ndarray:
    """A locked joint's position (nq,) (a number for a revolute or prismatic joint, a quaternion (w, x, y, z)
    for a ball joint, normalised, a pose (x, y, z, w, x, y, z) for a free one), or an error naming the joint."""
    name, nq = joint.name, joint.coordinates
    what = {1: "a number [rad or m]", 4: "a unit quaternion (w, x, y, z)", 7: "a pose (x, y, z, w, x, y, z)"}[nq]
    try:
        position = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise TypeError(f"locked_joint_positions['{name}'] must be {what}, got {value!r}") from None
    if position.size != nq:
        raise ValueError(f"locked_joint_positions['{name}'] must be {what} ({nq} numbers), got {position.size}")
    if not np.all(np.isfinite(position)):
        shown = position[0] if nq == 1 else position.tolist()
        raise ValueError(f"locked_joint_positions['{name}'] is {shown}: a locked position must be finite")
    if nq > 1:
        norm = np.linalg.norm(position[-4:])
        if norm < 1e-12:
            raise ValueError(f"locked_joint_positions['{name}'] has a zero quaternion {position[-4:].tolist()}")
        position[-4:] /= norm
    return position


def _check_moving_mass(description: ModelDescription, link_names, joints, parents, mass, com, inertia) -> None:
    """A ValueError naming the link when a leaf of the lumped tree has no inertia about its joint's axis (a
    massless leaf, or a point mass on a revolute joint's axis: the joint's acceleration is 0 / 0), or when a
    floating base carries no mass at all. Massless links inside a chain (MJCF's multi-joint bodies, URDF's
    dummy links) are fine: what they carry gives their joints inertia."""
    where = f"'{description.path}'" if description.path else f"model '{description.name}'"
    if not description.fixed_base and float(np.sum(mass)) <= 0.0:
        raise ValueError(f"{where}: the floating base '{link_names[0]}' and everything it carries have no mass")
    has_child = np.zeros(len(link_names), dtype=bool)
    has_child[[p for p in parents if p >= 0]] = True
    scale = max(float(np.abs(inertia).max(initial=0.0)), float(np.max(mass * np.einsum("ij,ij->i", com, com), initial=0.0)))
    for i in range(1, len(link_names)):
        if has_child[i]:
            continue
        joint = joints[i - 1]
        r = com[i] - joint.pivot  # from the joint's pivot to the centre of mass
        about_pivot = inertia[i] + mass[i] * (r @ r * np.eye(3) - np.outer(r, r))
        if joint.type == "prismatic":
            about_axis = mass[i]
        elif joint.type == "revolute":
            axis = joint.axis / np.linalg.norm(joint.axis)
            about_axis = axis @ about_pivot @ axis
        elif joint.type == "ball":
            about_axis = np.linalg.eigvalsh(0.5 * (about_pivot + about_pivot.T))[0]
        else:
            about_axis = min(mass[i], np.linalg.eigvalsh(0.5 * (inertia[i] + inertia[i].T))[0])
        if about_axis <= 1e-12 * scale:
            axes = {"revolute": "its axis", "prismatic": "its axis", "ball": "every axis through its pivot"}.get(joint.type, "every axis (or no mass)")
            raise ValueError(
                f"{where}: link '{link_names[i]}' ends the chain of {joint.type} joint '{joint.name}' but has no inertia about "
                f"{axes} (mass {mass[i]:g} kg): the joint's acceleration is undefined; give the link a mass and inertia, or "
                "make the joint fixed"
            )


def _explicit_frames(description: ModelDescription, kept_of: dict[str, str]) -> list:
    """The description's explicit frames, checked: each on a link of the tree, named unlike every link and
    every other frame (a ValueError naming them)."""
    frames = list(description.frames)
    if not frames:
        return frames
    links = {link.name for link in description.links} | set(kept_of)
    names = [frame.name for frame in frames]
    clashes = sorted({n for n in names if n in links})
    duplicated = sorted({n for n in names if names.count(n) > 1})
    if clashes or duplicated:
        raise ValueError(
            f"model '{description.name}': frame names must differ from link names and from each other: frames named "
            f"like links {clashes}, frames named twice {duplicated}"
        )
    detached = [f"{frame.name} (on '{frame.link}')" for frame in frames if frame.link not in kept_of]
    if detached:
        raise ValueError(f"model '{description.name}': frames {detached} are attached to links that the tree does not have")
    return frames


def build_tree(
    description: ModelDescription,
    considered_joints: list[str] | None = None,
    locked_joint_positions: dict[str, float] | None = None,
) -> KinematicTree:
    """Lump `description` keeping only `considered_joints` (all movable joints when None).

    Joints not considered are fixed at `locked_joint_positions[name]` (default 0) and lumped.
    """
    movable = [j.name for j in description.joints if j.type != "fixed"]
    if considered_joints is None:
        considered = set(movable)
    else:
        considered_joints = names_argument(considered_joints, "considered_joints")
        unknown = [name for name in considered_joints if name not in movable]
        if unknown:
            raise ValueError(
                f"considered_joints names joints that model '{description.name}' does not have as movable joints: {unknown}"
            )
        considered = set(considered_joints)
    by_name = {j.name: j for j in description.joints}
    locked = {name: by_name[name].start_position() for name in movable if name not in considered}
    if locked_joint_positions is not None and not isinstance(locked_joint_positions, dict):
        raise TypeError(f"locked_joint_positions must be a dict {{joint name: position}}, got {type(locked_joint_positions).__name__}")
    for name, value in (locked_joint_positions or {}).items():
        if name not in locked:
            raise ValueError(f"locked_joint_positions names joint '{name}', which is not a locked joint of the model")
        locked[name] = _locked_position(by_name[name], value)

    children: dict[str, list] = {}
    for joint in sorted(description.joints, key=lambda j: j.child):
        children.setdefault(joint.parent, []).append(joint)

    # Walk the description's tree breadth-first; each link finds its kept ancestor.
    kept_of = {description.base: description.base}
    kept_H_link = {description.base: np.eye(4)}
    lumped_order = []
    kept_children: dict[str, list] = {description.base: []}
    queue = [description.base]
    while queue:
        link = queue.pop(0)
        for joint in children.get(link, []):
            child = joint.child
            if joint.type != "fixed" and joint.name in considered:
                kept_of[child] = child
                kept_H_link[child] = np.eye(4)
                kept_children[child] = []
                kept_children[kept_of[link]].append((joint, kept_H_link[link] @ joint.origin))
            else:
                value = locked.get(joint.name, 0.0)  # a fixed joint's is not read
                kept_of[child] = kept_of[link]
                kept_H_link[child] = kept_H_link[link] @ joint.origin @ joint_motion(joint.type, joint.axis, joint.pivot, value)
                lumped_order.append(child)
            queue.append(child)

    # Breadth-first order of the lumped tree, each kept link's children sorted by name (JaxSim walks the reduced
    # graph: a kept link reached through lumped links is ordered among its kept parent's children by its name).
    link_names, joints, parent_H_joint = [description.base], [None], [np.eye(4)]
    parents = [-1]
    head = 0
    while head < len(link_names):
        for joint, H in sorted(kept_children[link_names[head]], key=lambda child: child[0].child):
            link_names.append(joint.child)
            joints.append(joint)
            parent_H_joint.append(H)
            parents.append(head)
        head += 1
    index = {name: i for i, name in enumerate(link_names)}

    nL = len(link_names)
    members: dict[str, list] = {name: [] for name in link_names}
    compensated: dict[str, list] = {name: [] for name in link_names}
    collisions: list[list[CollisionShape]] = [[] for _ in range(nL)]
    shape_order: list[tuple[int, int]] = []
    for link in description.links:
        if link.name not in kept_of:
            continue
        owner = kept_of[link.name]
        H = kept_H_link[link.name]
        if link.mass > 0.0 or np.any(link.inertia != 0.0):  # a massless link's inertia is kept too, as described
            members[owner].append(inertia_in_frame(link.mass, link.com, link.inertia, H))
        if link.gravcomp != 0.0 and link.mass != 0.0:
            compensated[owner].append((link.name, link.gravcomp * link.mass, H[:3, :3] @ link.com + H[:3, 3]))
        for shape in link.collisions:
            moved = CollisionShape(**{**shape.__dict__, "link_H_shape": H @ shape.link_H_shape})
            shape_order.append((index[owner], len(collisions[index[owner]])))
            collisions[index[owner]].append(moved)
    mass, com, inertia = np.zeros(nL), np.zeros((nL, 3)), np.zeros((nL, 3, 3))
    for i, name in enumerate(link_names):
        mass[i], com[i], inertia[i] = _combine(members[name])
    gravcomp_mass, gravcomp_com = np.zeros(nL), np.zeros((nL, 3))
    for i, name in enumerate(link_names):
        forces = compensated[name]
        if not forces:
            continue
        if len(forces) == 1:  # an unlumped body: its own CoM, exactly
            gravcomp_mass[i], gravcomp_com[i] = forces[0][1], forces[0][2]
            continue
        total = sum(w for _, w, _ in forces)
        moment = sum(w * c for _, w, c in forces)
        if total == 0.0:
            if np.any(moment != 0.0):
                raise ValueError(
                    f"model '{description.name}': the gravity compensations of bodies {[b for b, _, _ in forces]}, "
                    f"lumped into link '{name}', cancel into a pure couple, which one force cannot represent"
                )
            continue
        gravcomp_mass[i], gravcomp_com[i] = total, moment / total

    frames = [(f, index[kept_of[f]], kept_H_link[f]) for f in lumped_order]
    for frame in _explicit_frames(description, kept_of):
        frames.append((frame.name, index[kept_of[frame.link]], kept_H_link[frame.link] @ np.asarray(frame.link_H_frame, dtype=np.float64)))
    frames.sort(key=lambda frame: frame[0])
    frame_names = [name for name, _, _ in frames]
    frame_parent = [parent for _, parent, _ in frames]
    link_H_frame = [H for _, _, H in frames]

    movable_joints = joints[1:]
    _check_moving_mass(description, link_names, movable_joints, parents, mass, com, inertia)
    nj = len(movable_joints)
    q_start = np.concatenate([[0, 0], np.cumsum([j.coordinates for j in movable_joints])]).astype(np.int32)
    v_start = np.concatenate([[0, 0], np.cumsum([j.dofs for j in movable_joints])]).astype(np.int32)
    nv = int(v_start[-1])

    def per_dof(values) -> np.ndarray:
        return np.repeat(np.asarray(values, dtype=np.float64).reshape(nj), [j.dofs for j in movable_joints]).reshape(nv)

    one_dof = [j.type in ("revolute", "prismatic") for j in movable_joints]
    joint_index = {j.name: i for i, j in enumerate(movable_joints)}
    actuators, dropped = [], []
    for actuator in description.actuators:
        if actuator.joint in joint_index:
            fields = {k: v for k, v in actuator.__dict__.items() if k != "joint"}
            actuators.append(TreeActuator(joint=joint_index[actuator.joint], joint_name=actuator.joint, **fields))
        else:
            dropped.append(f"{actuator.name} (on {actuator.joint})")
    _warn_dropped(description, "actuators", dropped)
    qpos0 = np.concatenate([np.zeros(0)] + [j.start_position() for j in movable_joints])
    joint_type = np.array([0] + [JOINT_KINDS[j.type] for j in movable_joints], dtype=np.int32)
    axis = np.array([[0.0, 0.0, 1.0]] + [j.axis for j in movable_joints]).reshape(nL, 3)
    pivot = np.array([[0.0, 0.0, 0.0]] + [j.pivot for j in movable_joints]).reshape(nL, 3)
    invweight0 = None  # MuJoCo's dof_invweight0 where a row has none from MuJoCo (a URDF's or SDF's)
    if any(row is not None and row.invweight is None for j in movable_joints for row in (j.limit_constraint, j.friction_constraint)):
        invweight0 = dof_invweight0(parents, [None] + [j.type for j in movable_joints], np.array(parent_H_joint).reshape(nL, 4, 4), axis, pivot,
                                    mass, com, inertia, v_start, per_dof([j.armature for j in movable_joints]), not description.fixed_base)  # fmt: skip

    return KinematicTree(
        link_names=link_names,
        joint_names=[j.name for j in movable_joints],
        frame_names=frame_names,
        parent=np.array(parents, dtype=np.int32),
        joint_type=joint_type,
        parent_H_joint=np.array(parent_H_joint).reshape(nL, 4, 4),
        joint_axis=axis,
        joint_pivot=pivot,
        link_mass=mass,
        link_com=com,
        link_inertia=inertia,
        frame_parent=np.array(frame_parent, dtype=np.int32),
        link_H_frame=np.array(link_H_frame).reshape(len(frame_names), 4, 4),
        position_limits=np.array([[j.lower, j.upper] if one else [-np.inf, np.inf] for j, one in zip(movable_joints, one_dof)]).reshape(nj, 2),
        effort_limits=np.array([j.effort if one else np.inf for j, one in zip(movable_joints, one_dof)]).reshape(nj),
        velocity_limits=np.array([j.velocity if one else np.inf for j, one in zip(movable_joints, one_dof)]).reshape(nj),
        damping=per_dof([j.damping for j in movable_joints]),
        friction=per_dof([j.friction for j in movable_joints]),
        collisions=collisions,
        shape_order=shape_order,
        locked_joints=locked,
        armature=per_dof([j.armature for j in movable_joints]),
        passive_damping=per_dof([j.passive_damping for j in movable_joints]),
        stiffness=np.array([j.stiffness for j in movable_joints], dtype=np.float64).reshape(nj),
        springref=np.array([j.springref if one else 0.0 for j, one in zip(movable_joints, one_dof)], dtype=np.float64).reshape(nj),
        actuator_force_range=np.array([j.actuator_force_range for j in movable_joints], dtype=np.float64).reshape(nj, 2),
        actuator_gravcomp=np.array([j.actuator_gravcomp for j in movable_joints], dtype=bool).reshape(nj),
        gravcomp_mass=gravcomp_mass,
        gravcomp_com=gravcomp_com,
        actuators=actuators,
        q_start=q_start,
        v_start=v_start,
        qpos0=qpos0,
        equalities=_equalities(description, kept_of, kept_H_link, index, joint_index, qpos0, q_start),
        limits=[_joint_row(j, i, "limit", invweight0, v_start) for i, j in enumerate(movable_joints) if j.limit_constraint is not None],
        friction_rows=[_joint_row(j, i, "friction", invweight0, v_start) for i, j in enumerate(movable_joints) if j.friction_constraint is not None],
        **_base_joint_parameters(description),
    )


def _joint_row(joint, index: int, kind: str, invweight0, v_start) -> TreeEquality:
    """Tree joint `index`'s MuJoCo limit ("limit": its `limit_constraint`) or friction ("friction": its
    `friction_constraint`) constraint, a row of that kind on it; its invweight the constraint's, or where it has none
    its DoF's entry of invweight0 (nv,) (`dof_invweight0`: MuJoCo's of this tree; the DoF v_start[index + 1]). Its bounds are the model's: a limit's
    the joint's position_limits (MuJoCo gives a joint a row per bound within the margin, warpdyn one at the nearer bound:
    a step refuses a range narrower than twice the margin), a friction row's its friction_static."""
    data = joint.limit_constraint if kind == "limit" else joint.friction_constraint
    invweight = data.invweight if data.invweight is not None else invweight0[v_start[index + 1]]
    return TreeEquality(name=joint.name, kind=kind, terms1=[(index, 1.0)], solref=np.array(data.solref, dtype=np.float64),
                        solimp=np.array(data.solimp, dtype=np.float64), invweight=float(invweight),
                        margin=float(getattr(data, "margin", 0.0)), angle=getattr(data, "angle", None))  # fmt: skip


def _equalities(description: ModelDescription, kept_of: dict, kept_H_link: dict, index: dict, joint_index: dict, qpos0, q_start) -> list[TreeEquality]:
    """The description's equality constraints on the lumped tree: a connect's or weld's anchors moved to the links
    their bodies are lumped into (a body outside the tree is the world's); a joint or tendon coupling whose joint
    the reduction locks is dropped with a NotModelledWarning."""
    equalities, dropped = [], []

    def on_link(body: str, anchor, rot) -> tuple[int, np.ndarray, np.ndarray]:
        """(link, the anchor in its frame, the frame body (x) rot in its frame (w, x, y, z))."""
        rot = np.asarray(rot, dtype=np.float64)
        if body not in kept_of:  # the world of a floating base's description
            return -1, np.asarray(anchor, dtype=np.float64), rot
        H = kept_H_link[body]
        return index[kept_of[body]], H[:3, :3] @ np.asarray(anchor, dtype=np.float64) + H[:3, 3], quaternion_product(matrix_to_quaternion_wxyz(H[:3, :3]), rot)

    for source, eq in enumerate(description.equalities):
        common = dict(name=eq.name, kind=eq.kind, solref=np.array(eq.solref, dtype=np.float64), solimp=np.array(eq.solimp, dtype=np.float64),
                      invweight=float(eq.invweight), source=source)  # fmt: skip
        if eq.kind in ("connect", "weld"):
            (link1, p1, Q1), (link2, p2, Q2) = on_link(eq.body1, eq.anchor1, eq.rot1), on_link(eq.body2, eq.anchor2, eq.rot2)
            equalities.append(TreeEquality(link1=link1, link2=link2, p1=p1, p2=p2, Q1=Q1, Q2=Q2, torquescale=eq.torquescale,
                                           invweight_rotation=eq.invweight_rotation, **common))  # fmt: skip
        else:  # a joint or fixed-tendon coupling: lengths of (joint, coef) terms
            sides = [[(eq.joint1, 1.0)], [(eq.joint2, 1.0)] if eq.joint2 is not None else []] if eq.kind == "joint" else [eq.tendon1, eq.tendon2 or []]
            joints = [name for side in sides for name, _ in side]
            if any(name not in joint_index for name in joints):
                dropped.append(f"{eq.name} (on {', '.join(joints)})")
                continue
            terms = [[(joint_index[name], float(coef)) for name, coef in side] for side in sides]
            refs = [sum(coef * qpos0[q_start[j + 1]] for j, coef in side) for side in terms]
            equalities.append(TreeEquality(terms1=terms[0], terms2=terms[1], ref1=float(refs[0]), ref2=float(refs[1]), polycoef=np.array(eq.polycoef, dtype=np.float64), **common))
    _warn_dropped(description, "equality constraints", dropped)
    return equalities


def _warn_dropped(description: ModelDescription, what: str, dropped: list[str]) -> None:
    """A NotModelledWarning naming `what` the reduction dropped with the joints it locks (none: no warning)."""
    if dropped:
        warnings.warn(
            f"model '{description.name}': {what} on joints that the reduction locks are dropped: {dropped}",
            NotModelledWarning,
            stacklevel=caller_stacklevel(),
        )


def _base_joint_parameters(description: ModelDescription) -> dict:
    """The floating base's free-joint armature, damping and stiffness (0 for a fixed base or none given)."""
    joint = description.base_joint
    if joint is None or description.fixed_base:
        return {}
    return {"base_armature": joint.armature, "base_damping": joint.passive_damping, "base_stiffness": joint.stiffness}
