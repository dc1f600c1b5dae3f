"""Robot descriptions (URDF, MJCF) read into one plain, host-side form.

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

import io
import os
import pathlib
import re
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field

import numpy as np

__all__ = [
    "LinkDescription",
    "JointDescription",
    "CollisionShape",
    "ModelDescription",
    "load",
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


def _homogeneous(rotation: np.ndarray, translation) -> np.ndarray:
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


_XML_DECLARATION = re.compile(r"^\s*<\?xml[^>]*\?>")


def _looks_like_xml(text: str) -> bool:
    return text.lstrip("\ufeff \t\r\n").startswith("<")


def _read_document(model_description) -> tuple[bytes, str | None]:
    """(the document's bytes, its path or None) of a path, an XML string or XML bytes.

    Files and bytes are handed to the XML parsers as bytes, which honour a byte-order mark and the encoding
    an XML declaration names. A string is already decoded: its BOM and XML declaration (whose encoding no
    longer applies) are dropped and the text is encoded as UTF-8.
    """
    if isinstance(model_description, (bytes, bytearray, memoryview)):
        return bytes(model_description), None
    if isinstance(model_description, os.PathLike) or (
        isinstance(model_description, str) and not _looks_like_xml(model_description)
    ):
        path = pathlib.Path(model_description).expanduser()
        if not path.is_file():
            raise FileNotFoundError(f"robot description '{model_description}' does not exist or is not a file")
        return path.read_bytes(), str(path)
    if isinstance(model_description, str):
        text = _XML_DECLARATION.sub("", model_description.lstrip("\ufeff"), count=1)
        return text.encode("utf-8"), None
    raise TypeError(
        "model_description must be a path, an XML string or XML bytes, got an object of type "
        f"{type(model_description).__name__}"
    )


def load(
    model_description, *, is_urdf: bool | None = None, fixed_base: bool | None = None, base_pose=None
) -> ModelDescription:
    """Read a URDF or MJCF description (a path, an XML string or XML bytes) into a `ModelDescription`.

    fixed_base: None keeps what the description says (a root welded to a `world` link, or an MJCF body
    without a free joint, is a fixed base); True welds the base to the world (an MJCF free joint becomes a
    weld) at `base_pose`; False frees a base the description welds to the world. base_pose (4, 4): the
    homogeneous transform W_H_B of the welded base (default: the description's weld, or the identity).
    """
    document, path = _read_document(model_description)
    where = f"'{path}'" if path else "the given XML document"
    try:
        root = ET.fromstring(document)
    except ET.ParseError as error:
        raise ValueError(f"{where} is not well-formed XML: {error}") from None
    if is_urdf is None:
        if root.tag == "robot":
            is_urdf = True
        elif root.tag == "mujoco":
            is_urdf = False
        else:
            raise ValueError(f"{where} has root element <{root.tag}>: expected <robot> (URDF) or <mujoco> (MJCF)")
    description = _load_urdf(document, where) if is_urdf else _load_mjcf(root, path, where)
    description.path = path
    return _with_base(description, fixed_base, base_pose, where)


def _with_base(description: ModelDescription, fixed_base: bool | None, base_pose, where: str) -> ModelDescription:
    """The description with its base welded or freed as `load` documents."""
    if base_pose is not None:
        H = np.asarray(base_pose, dtype=np.float64)
        if H.shape != (4, 4) or not np.all(np.isfinite(H)):
            raise ValueError(f"base_pose must be a finite (4, 4) homogeneous transform, got shape {H.shape}")
        R = H[:3, :3]
        if np.abs(R @ R.T - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0.0 or np.abs(H[3] - [0, 0, 0, 1]).max() > 1e-12:
            raise ValueError("base_pose must be a homogeneous transform: a rotation block (det +1) and last row (0, 0, 0, 1)")
        if fixed_base is False or (fixed_base is None and not description.fixed_base):
            raise ValueError("base_pose places a welded base: pass fixed_base=True (a floating base's pose is in the data)")
    if fixed_base is None or bool(fixed_base) == description.fixed_base:
        if base_pose is not None:
            description.world_H_base = H
        return description
    if fixed_base:
        description.fixed_base = True
        description.world_H_base = np.eye(4) if base_pose is None else H
        return description
    if description.base == "world":
        raise ValueError(
            f"{where}: fixed_base=False, but the world has several bodies welded or jointed to it: there is no one "
            "base to free"
        )
    description.fixed_base = False
    description.world_H_base = np.eye(4)
    return description


# ----------------------------------------------------------------------------------------------- URDF


def _ignore_mesh_uri(fname, dir=None):
    """Meshes are not needed for dynamics: yourdfpy gets back the URI unchanged."""
    return fname


def _load_urdf(document: bytes, where: str) -> ModelDescription:
    import yourdfpy

    try:
        urdf = yourdfpy.URDF.load(
            io.BytesIO(document),
            build_scene_graph=False,
            build_collision_scene_graph=False,
            load_meshes=False,
            load_collision_meshes=False,
            filename_handler=_ignore_mesh_uri,
        )
    except Exception as error:  # yourdfpy raises many kinds of errors for malformed URDF
        raise ValueError(f"{where} is not a valid URDF: {error}") from None
    robot = urdf.robot

    links = []
    for link in robot.links:
        description = LinkDescription(name=link.name)
        if link.inertial is not None:
            origin = link.inertial.origin if link.inertial.origin is not None else np.eye(4)
            inertia = np.asarray(link.inertial.inertia if link.inertial.inertia is not None else np.zeros((3, 3)))
            description.mass = float(link.inertial.mass or 0.0)
            description.com = np.asarray(origin[:3, 3], dtype=np.float64)
            description.inertia = origin[:3, :3] @ inertia @ origin[:3, :3].T
        for collision in link.collisions:
            shape = _urdf_collision_shape(collision)
            if shape is not None:
                description.collisions.append(shape)
        links.append(description)

    names = [link.name for link in links]
    if len(set(names)) != len(names):
        duplicated = sorted({n for n in names if names.count(n) > 1})
        raise ValueError(f"{where} has duplicated link names: {duplicated}")

    joints = []
    mimic = []
    for joint in robot.joints:
        jtype = joint.type
        if joint.mimic is not None:
            mimic.append(joint.name)
        origin = np.asarray(joint.origin if joint.origin is not None else np.eye(4), dtype=np.float64)
        axis = np.asarray(joint.axis if joint.axis is not None else [1.0, 0.0, 0.0], dtype=np.float64)
        description = JointDescription(name=joint.name, type=jtype, parent=joint.parent, child=joint.child, origin=origin)
        if jtype in MOVABLE_JOINT_TYPES:
            norm = np.linalg.norm(axis)
            if not np.isfinite(norm) or norm < 1e-12:
                raise ValueError(f"{where}: joint '{joint.name}' has a zero or non-finite axis {axis.tolist()}")
            description.axis = axis / norm
            description.type = "prismatic" if jtype == "prismatic" else "revolute"
            if joint.limit is not None and jtype != "continuous":
                if joint.limit.lower is not None:
                    description.lower = float(joint.limit.lower)
                if joint.limit.upper is not None:
                    description.upper = float(joint.limit.upper)
            if joint.limit is not None:
                if joint.limit.effort is not None:
                    description.effort = float(joint.limit.effort)
                if joint.limit.velocity is not None:
                    description.velocity = float(joint.limit.velocity)
            if joint.dynamics is not None:
                description.damping = float(joint.dynamics.damping or 0.0)
                description.friction = float(joint.dynamics.friction or 0.0)
        joints.append(description)
    if mimic:
        warnings.warn(
            f"{where}: mimic joints {mimic} are kept as independent joints (their <mimic> coupling is ignored)",
            stacklevel=3,
        )
    return _finish_tree(robot.name, links, joints, "urdf", where)


def _urdf_collision_shape(collision) -> CollisionShape | None:
    origin = np.asarray(collision.origin if collision.origin is not None else np.eye(4), dtype=np.float64)
    geometry = collision.geometry
    if geometry.box is not None:
        return CollisionShape("box", origin, size=np.asarray(geometry.box.size, dtype=np.float64))
    if geometry.sphere is not None:
        return CollisionShape("sphere", origin, radius=float(geometry.sphere.radius))
    if geometry.cylinder is not None:
        return CollisionShape("cylinder", origin, radius=float(geometry.cylinder.radius), length=float(geometry.cylinder.length))
    if geometry.mesh is not None:
        scale = geometry.mesh.scale
        scale = np.ones(3) if scale is None else np.broadcast_to(np.asarray(scale, dtype=np.float64), (3,)).copy()
        return CollisionShape("mesh", origin, filename=geometry.mesh.filename, scale=scale)
    return None


def _finish_tree(name, links, joints, source, where) -> ModelDescription:
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


# ----------------------------------------------------------------------------------------------- MJCF


def _load_mjcf(root: ET.Element, path: str | None, where: str) -> ModelDescription:
    import mujoco

    try:
        if path is not None:  # MuJoCo resolves <include> and asset files against the path
            m = mujoco.MjModel.from_xml_path(path)
        else:
            m = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    except Exception as error:
        raise ValueError(f"{where} is not a valid MJCF: {error}") from None

    def body_name(i):
        return mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, i) or f"body{i}"

    links, joints = [], []
    free_bodies = []
    for b in range(1, m.nbody):
        name = body_name(b)
        link = LinkDescription(name=name, mass=float(m.body_mass[b]), com=np.array(m.body_ipos[b], dtype=np.float64))
        R_i = quaternion_wxyz_to_matrix(m.body_iquat[b])
        link.inertia = R_i @ np.diag(m.body_inertia[b]) @ R_i.T
        _mjcf_collisions(m, b, link, mujoco)
        links.append(link)

        parent = "world" if m.body_parentid[b] == 0 else body_name(m.body_parentid[b])
        origin = _homogeneous(quaternion_wxyz_to_matrix(m.body_quat[b]), m.body_pos[b])
        njnt, adr = int(m.body_jntnum[b]), int(m.body_jntadr[b])
        if njnt == 0:
            joints.append(JointDescription(name=f"{parent}_to_{name}", type="fixed", parent=parent, child=name, origin=origin))
            continue
        if njnt > 1:
            names = [mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, adr + k) for k in range(njnt)]
            raise ValueError(
                f"{where}: body '{name}' has {njnt} joints {names}; warpdyn supports one joint per body "
                "(split the body into a chain of bodies with one joint each)"
            )
        jname = mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_JOINT, adr) or f"joint{adr}"
        jtype = int(m.jnt_type[adr])
        if jtype == mujoco.mjtJoint.mjJNT_FREE:
            if parent != "world":
                raise ValueError(f"{where}: joint '{jname}' has type 'free' inside the tree (body '{name}')")
            free_bodies.append(name)
            joints.append(JointDescription(name=jname, type="floating", parent="world", child=name, origin=origin))
            continue
        if jtype == mujoco.mjtJoint.mjJNT_BALL:
            raise ValueError(
                f"{where}: joint '{jname}' has type 'ball' (spherical), which warpdyn does not support inside the tree"
            )
        kind = "revolute" if jtype == mujoco.mjtJoint.mjJNT_HINGE else "prismatic"
        axis = np.array(m.jnt_axis[adr], dtype=np.float64)
        pivot = np.array(m.jnt_pos[adr], dtype=np.float64)
        qpos0 = float(m.qpos0[m.jnt_qposadr[adr]])
        if qpos0 != 0.0:
            origin = origin @ joint_motion(kind, axis, pivot, -qpos0)
        joint = JointDescription(name=jname, type=kind, parent=parent, child=name, origin=origin, axis=axis, pivot=pivot)
        if m.jnt_limited[adr]:
            joint.lower, joint.upper = (float(v) for v in m.jnt_range[adr])
        dof = int(m.jnt_dofadr[adr])
        joint.damping = float(m.dof_damping[dof])
        joint.friction = float(m.dof_frictionloss[dof])
        joints.append(joint)

    world_children = [j for j in joints if j.parent == "world"]
    if len(world_children) != 1:
        raise ValueError(
            f"{where}: warpdyn models one robot: the world body has {len(world_children)} child bodies "
            f"{[j.child for j in world_children]}"
        )
    world_link = LinkDescription(name="world")
    name = root.get("model") or (pathlib.Path(path).stem if path else "model")
    return _finish_tree(name, [world_link, *links], joints, "mjcf", where)


def _mjcf_collisions(m, b: int, link: LinkDescription, mujoco) -> None:
    for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b]) + int(m.body_geomnum[b])):
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        H = _homogeneous(quaternion_wxyz_to_matrix(m.geom_quat[g]), m.geom_pos[g])
        size = np.array(m.geom_size[g], dtype=np.float64)
        kind = int(m.geom_type[g])
        if kind == mujoco.mjtGeom.mjGEOM_BOX:
            link.collisions.append(CollisionShape("box", H, size=2.0 * size))
        elif kind == mujoco.mjtGeom.mjGEOM_SPHERE:
            link.collisions.append(CollisionShape("sphere", H, radius=float(size[0])))
        elif kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
            link.collisions.append(CollisionShape("cylinder", H, radius=float(size[0]), length=2.0 * float(size[1])))
        elif kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
            link.collisions.append(CollisionShape("capsule", H, radius=float(size[0]), length=2.0 * float(size[1])))
        elif kind == mujoco.mjtGeom.mjGEOM_MESH:
            mesh = int(m.geom_dataid[g])
            start, count = int(m.mesh_vertadr[mesh]), int(m.mesh_vertnum[mesh])
            vertices = np.array(m.mesh_vert[start : start + count], dtype=np.float64)
            link.collisions.append(CollisionShape("mesh", H, vertices=vertices, scale=np.ones(3)))


def joint_motion(kind: str, axis: np.ndarray, pivot: np.ndarray, q: float) -> np.ndarray:
    """M(q) of the module docstring, as a (4, 4) transform."""
    if kind == "prismatic":
        return _homogeneous(np.eye(3), axis * q)
    if kind == "revolute":
        R = axis_angle_to_matrix(axis, q)
        return _homogeneous(R, pivot - R @ pivot)
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

