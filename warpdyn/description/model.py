"""The plain, host-side form that the URDF and MJCF readers agree on.

A `ModelDescription` is what the parsers agree on: links with their inertial parameters and collision
shapes, joints with their type, axis and origin, and which link is the base. Nothing is lumped or
reordered here; `warpdyn.tree` does that. All arrays are float64 NumPy, SI units.

Joint convention (both formats): the pose of the child link in the parent link at joint position q is

    parent_H_child(q) = origin @ M(q),

where `origin` is the joint frame in the parent link at q = 0 and M(q) is, in the child frame, a rotation
by q about `axis` through the point `pivot` (revolute) or a translation by q along `axis` (prismatic).
URDF joints have pivot 0; MJCF joints have their `pos` as pivot.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "CollisionShape",
    "LinkDescription",
    "JointDescription",
    "ModelDescription",
    "MOVABLE_JOINT_TYPES",
    "finish_tree",
    "homogeneous",
    "joint_motion",
    "axis_angle_to_matrix",
    "quaternion_wxyz_to_matrix",
]

MOVABLE_JOINT_TYPES = ("revolute", "continuous", "prismatic")


@dataclass
class CollisionShape:
    """A collision shape attached to a link.

    kind: "box" (size: full extents (3,)), "sphere" (radius), "cylinder" (radius, length along z),
    "capsule" (radius, length of the cylindrical part along z), "mesh" (filename, scale (3,)).
    link_H_shape: (4, 4) pose of the shape in its link frame.
    """

    kind: str
    link_H_shape: np.ndarray
    size: np.ndarray | None = None
    radius: float = 0.0
    length: float = 0.0
    filename: str | None = None
    scale: np.ndarray | None = None
    vertices: np.ndarray | None = None


@dataclass
class LinkDescription:
    """A rigid link: mass [kg], centre of mass `com` (3,) [m] and rotational inertia `inertia` (3, 3)
    [kg m^2] about the centre of mass, both in the link frame."""

    name: str
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    collisions: list[CollisionShape] = field(default_factory=list)


@dataclass
class JointDescription:
    """A joint between two links (see the module docstring for the convention).

    type: "revolute", "prismatic" or "fixed" ("continuous" is read as a revolute without limits).
    origin: (4, 4) joint frame in the parent link at q = 0. axis: (3,) unit vector in the child frame.
    pivot: (3,) point of the rotation axis in the child frame [m].
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


@dataclass
class ModelDescription:
    """A robot as read from its description, before lumping.

    base: name of the base link. fixed_base: whether the base is welded to the world, at world_H_base.
    links and joints keep the order of the description; joints form a tree rooted at `base`.
    path: the file it was read from (None for an XML string); relative mesh paths resolve against it.
    """

    name: str
    links: list[LinkDescription]
    joints: list[JointDescription]
    base: str
    fixed_base: bool
    world_H_base: np.ndarray
    source: str
    path: str | None = None

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


def finish_tree(name, links, joints, source, where) -> ModelDescription:
    """Checks that the joints form one tree and finds its base (a 'world' root is the world)."""
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
    for joint in joints:
        if joint.type not in ("revolute", "prismatic", "fixed"):
            raise ValueError(
                f"{where}: joint '{joint.name}' has type '{joint.type}', which warpdyn does not support inside the tree "
                "(supported: revolute, continuous, prismatic, fixed)"
            )
    return ModelDescription(name, links, joints, base, fixed_base, world_H_base, source)


def joint_motion(kind: str, axis: np.ndarray, pivot: np.ndarray, q: float) -> np.ndarray:
    """M(q) of the module docstring, as a (4, 4) transform."""
    if kind == "prismatic":
        return homogeneous(np.eye(3), axis * q)
    if kind == "revolute":
        R = axis_angle_to_matrix(axis, q)
        return homogeneous(R, pivot - R @ pivot)
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

