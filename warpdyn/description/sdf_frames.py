"""SDFormat's frames and files, for warpdyn.description.sdf: the numbers, booleans and poses of its elements,
the scopes of names (`Scope`), the pose graph that composes every frame's pose from its `relative_to` and the
bodies that `attached_to` chains reach (`FrameGraph`), the version check, and the file an `<include>`'s URI
names (`resolve_include`).

Frames and poses (the frame semantics of http://sdformat.org/tutorials?tut=pose_frame_semantics):

- Every `<pose>` is an edge of one graph: the element's frame placed in the frame its `relative_to` names
  (any link, joint, frame or model of its scope, `outer::inner::name` into nested models, `__model__`, the
  model's own name, `world`), or, without it, in the version's default: a link and a nested model in their
  model's frame, a joint in its child's frame, a frame in the frame it is `attached_to`, a model in
  `<world>` in the world. SDFormat <= 1.6 (no `relative_to`) has the same defaults. A pose is x y z roll
  pitch yaw, R = Rz(yaw) Ry(pitch) Rx(roll) (extrinsic X-Y-Z), `degrees="true"` in degrees, or
  `rotation_format="quat_xyzw"`: x y z qx qy qz qw. The transform between two frames is composed along the
  graph from their lowest common ancestor, so that a URDF-like file (link relative to its joint, joint
  relative to its parent link) gives the URDF's numbers exactly.
- A joint between links P and C: origin = P_H_C at q = 0, axis in C (from the frame `expressed_in`
  names, default the joint frame; SDFormat 1.4: the model frame; 1.5/1.6: the joint frame, the model frame
  with `use_parent_model_frame`), pivot = the joint frame's origin in C. `<parent>` and `<child>` may name
  frames (1.8+): the joint connects the links they are attached to.
- `<frame name attached_to>` (1.7+) becomes a frame of the model on the link that its `attached_to` chain
  reaches (a frame attached to a frame, a joint (its child link), a model (its canonical link), `__model__`).
- Nested `<model>`s and `<include>`s name their elements `outer::inner::link` (the top model's own
  elements are unscoped); `canonical_link`, `placement_frame` and include `<name>`, `<pose>`, `<static>`,
  `<placement_frame>`, `merge="true"` (its elements keep their names; its model frame becomes the frame
  `_merged__NAME__model__`) are honoured. `model://NAME/...` resolves against the including file's
  directory and its ancestors, then SDF_PATH, GZ_SIM_RESOURCE_PATH, IGN_GAZEBO_RESOURCE_PATH and
  GAZEBO_MODEL_PATH (a model directory's `model.config` names its file, else `model.sdf`); `file://`,
  absolute and relative paths (against the including file's directory, or the working directory for an
  XML string) are read as they are.
"""

from __future__ import annotations

import os
import pathlib
import urllib.parse
import warnings
import xml.etree.ElementTree as ET

import numpy as np

from .model import caller_stacklevel, homogeneous, quaternion_wxyz_to_matrix

__all__ = [
    "SUPPORTED_VERSIONS",
    "RESOURCE_PATH_VARIABLES",
    "text",
    "numbers",
    "vector",
    "number",
    "parse_bool",
    "boolean",
    "rpy_matrix",
    "inverse",
    "parse_pose",
    "parse_version",
    "Node",
    "Scope",
    "FrameGraph",
    "resolve_include",
    "model_file",
]

SUPPORTED_VERSIONS = ((1, 4), (1, 11))
"""The first and last SDFormat versions whose rules warpdyn applies (a later 1.x is read with 1.11's rules,
with a warning)."""

RESOURCE_PATH_VARIABLES = ("SDF_PATH", "GZ_SIM_RESOURCE_PATH", "IGN_GAZEBO_RESOURCE_PATH", "GAZEBO_MODEL_PATH")
"""The environment variables (path lists) where `model://NAME` includes are looked up, in this order, after
the including file's directory and its ancestors."""


# ------------------------------------------------------------------------------------------- numbers


def text(element) -> str:
    return (element.text or "").strip() if element is not None else ""


def numbers(written: str, what: str, where: str) -> np.ndarray:
    try:
        return np.array([float(v) for v in written.split()], dtype=np.float64)
    except ValueError:
        raise ValueError(f"{where}: {what} has '{written}', which is not a list of numbers") from None


def vector(element, count: int, what: str, where: str, default) -> np.ndarray:
    if element is None:
        return np.array(default, dtype=np.float64)
    values = numbers(text(element), what, where)
    if len(values) != count or not np.all(np.isfinite(values)):
        raise ValueError(f"{where}: {what} has '{text(element)}': expected {count} finite numbers")
    return values


def number(element, what: str, where: str, default: float, finite: bool = True) -> float:
    if element is None:
        return float(default)
    written = text(element)
    try:
        value = float(written)
    except ValueError:
        raise ValueError(f"{where}: {what} has '{written}', which is not a number") from None
    if np.isnan(value) or (finite and not np.isfinite(value)):
        raise ValueError(f"{where}: {what} is {written}: expected a finite number")
    return value


def parse_bool(written: str, what: str, where: str) -> bool:
    lowered = written.strip().lower()
    if lowered in ("true", "1"):
        return True
    if lowered in ("false", "0"):
        return False
    raise ValueError(f"{where}: {what} has '{written}': expected true, false, 1 or 0")


def boolean(element, what: str, where: str, default: bool) -> bool:
    return default if element is None else parse_bool(text(element), what, where)


def rpy_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """SDFormat's (and URDF's) roll-pitch-yaw: rotations about the fixed X, Y, Z axes, R = Rz Ry Rx."""
    cr, sr, cp, sp, cy, sy = np.cos(roll), np.sin(roll), np.cos(pitch), np.sin(pitch), np.cos(yaw), np.sin(yaw)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def inverse(H: np.ndarray) -> np.ndarray:
    R = H[:3, :3]
    return homogeneous(R.T, -R.T @ H[:3, 3])


# ------------------------------------------------------------------------------------------- poses


def parse_pose(pose, where: str, what: str) -> tuple[np.ndarray, str | None]:
    """(the transform, its relative_to or None) of a `<pose>` element (None: the identity): x y z roll pitch
    yaw, in degrees with degrees="true", or x y z qx qy qz qw with rotation_format="quat_xyzw"."""
    if pose is None:
        return np.eye(4), None
    relative_to = pose.get("relative_to") or None
    values = numbers(text(pose), f"{what} <pose>", where)
    fmt = (pose.get("rotation_format") or "euler_rpy").strip()
    degrees = parse_bool(pose.get("degrees", "false"), f"{what} <pose degrees>", where)
    if fmt == "euler_rpy":
        if len(values) == 0:
            values = np.zeros(6)
        if len(values) != 6:
            raise ValueError(f"{where}: {what} <pose> has {len(values)} numbers: expected x y z roll pitch yaw (6)")
        angles = np.radians(values[3:]) if degrees else values[3:]
        R = rpy_matrix(*angles)
    elif fmt == "quat_xyzw":
        if len(values) != 7:
            raise ValueError(f"{where}: {what} <pose rotation_format='quat_xyzw'> has {len(values)} numbers: expected x y z qx qy qz qw (7)")
        if degrees:
            raise ValueError(f"{where}: {what} <pose> has degrees='true' with rotation_format='quat_xyzw'")
        q = values[3:]
        if not np.all(np.isfinite(q)) or np.linalg.norm(q) < 1e-12:
            raise ValueError(f"{where}: {what} <pose> has the quaternion {q.tolist()}, which is not a rotation")
        R = quaternion_wxyz_to_matrix([q[3], q[0], q[1], q[2]])
    else:
        raise ValueError(f"{where}: {what} <pose rotation_format='{fmt}'>: expected euler_rpy or quat_xyzw")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{where}: {what} <pose> has non-finite values {values.tolist()}")
    return homogeneous(R, values[:3]), relative_to


# ------------------------------------------------------------------------------------------- frames


class Node:
    """A frame of the pose graph: the world, a model's frame, a link, a joint or an explicit frame."""

    def __init__(self, kind: str, name: str, scope, where: str, version):
        self.kind = kind
        self.name = name  # scoped name: what warpdyn names the link or frame, and what messages show
        self.scope = scope  # where its relative_to / attached_to / child names are looked up
        self.where = where
        self.version = version
        self.pose = np.eye(4)
        self.relative_to: str | None = None
        self.attached_to = ""  # frames
        self.child = ""  # joints: the child frame's name
        self.element = None
        self.edge = None  # (parent node, parent_H_node) once resolved
        # models:
        self.own_scope = None
        self.static = False
        self.placement = ""
        self.canonical = ""
        self.first_link = None
        self.first_model = None

    def label(self) -> str:
        return f"{self.kind} '{self.name}'"


class Scope:
    """The names a model (or the world, or the document around a lone model) defines, and its frame."""

    def __init__(self, frame: Node, prefix: str, where: str, version, base_dir, names=None, model_name=""):
        self.frame = frame  # what __model__ names (the world node for the world's scope)
        self.prefix = prefix  # prepended to its elements' names
        self.where = where
        self.version = version
        self.base_dir = base_dir
        self.names: dict[str, Node] = {} if names is None else names
        self.model_name = model_name

    def add(self, local: str, node: Node, element_label: str) -> None:
        if not local:
            raise ValueError(f"{self.where}: a {element_label} has no name")
        if "::" in local:
            raise ValueError(f"{self.where}: {element_label} '{local}': names may not contain '::'")
        if local == "world" or (local.startswith("__") and local.endswith("__") and not local.startswith("_merged__")):
            raise ValueError(f"{self.where}: {element_label} '{local}' uses a name that SDFormat reserves")
        other = self.names.get(local)
        if other is not None:
            raise ValueError(
                f"{self.where}: {element_label} '{self.prefix}{local}' has the name of {other.label()}: names of links, joints, "
                "frames and models must be unique in their model"
            )
        self.names[local] = node


def parse_version(root: ET.Element, where: str) -> tuple[int, int]:
    """(major, minor) of an `<sdf version>`: a ValueError outside 1.4 to 1.x, a warning beyond 1.11."""
    written = root.get("version")
    if written is None:
        raise ValueError(f"{where}: <sdf> has no version attribute (SDFormat 1.4 to 1.11 are read)")
    parts = written.strip().split(".")
    try:
        major, minor = (int(part) for part in parts) if len(parts) == 2 else (None, None)
    except ValueError:
        major = minor = None
    if major is None:
        raise ValueError(f"{where}: <sdf version='{written}'> is not an SDFormat version (1.4 to 1.11 are read)")
    first, last = SUPPORTED_VERSIONS
    if major != 1 or minor < first[1]:
        raise ValueError(
            f"{where}: SDFormat {written} is not read (1.4 to 1.11 are): convert it with `gz sdf -p` (or `ign sdf -p`) first"
        )
    if minor > last[1]:
        warnings.warn(
            f"{where}: SDFormat {written} is newer than 1.11, the last version whose rules warpdyn knows: read with 1.11's rules",
            UserWarning,
            stacklevel=caller_stacklevel(),
        )
    return major, minor


class FrameGraph:
    """The pose graph of a document: its world node, and the frames its scopes define."""

    def __init__(self):
        self.world = Node("world", "world", None, "", SUPPORTED_VERSIONS[1])
        self.world.edge = (None, np.eye(4))
        self.placing: set[int] = set()

    def lookup(self, scope: Scope, name: str, what: str) -> Node:
        """The node `name` names from `scope` (a scoped name a::b::c descends into nested models)."""
        if name == "world":
            return self.world
        if name == "__model__":
            return scope.frame
        parts = name.split("::")
        current = scope
        for k, part in enumerate(parts):
            if part == "__model__":
                node = current.frame
            else:
                node = current.names.get(part)
                if node is None and len(parts) == 1 and part == current.model_name:
                    node = current.frame  # a model's own name inside it (as in SDFormat's tutorial)
            if node is None:
                where_defined = f"model '{current.frame.name}'" if current.frame is not self.world else "the world"
                raise ValueError(f"{scope.where}: {what} names frame '{name}', which {where_defined} does not define")
            if k < len(parts) - 1:
                if node.kind != "model" or node.own_scope is None:
                    raise ValueError(f"{scope.where}: {what} names '{name}', but '{part}' is {node.label()}, not a model")
                current = node.own_scope
        return node

    def parent_of(self, node: Node) -> Node | None:
        """The node that `node`'s pose is expressed in."""
        if node is self.world:
            return None
        what = f"{node.label()} <pose relative_to>"
        if node.relative_to:
            return self.lookup(node.scope, node.relative_to, what)
        if node.kind in ("model", "link"):
            return node.scope.frame
        if node.kind == "joint":
            return self.lookup(node.scope, node.child, f"{node.label()} <child>")
        if node.kind == "frame":
            return self.lookup(node.scope, node.attached_to, f"{node.label()} attached_to") if node.attached_to else node.scope.frame
        raise AssertionError(node.kind)

    def edge(self, node: Node) -> tuple[Node | None, np.ndarray]:
        """(the node `node`'s pose is expressed in, parent_H_node), resolved once (a model with a placement_frame:
        its pose places that frame, so the model frame is the pose times the inverse of model_H_placement)."""
        if node.edge is None:
            parent = self.parent_of(node)
            H = node.pose
            if node.kind == "model" and node.placement:
                if id(node) in self.placing:
                    raise ValueError(f"{node.where}: the placement of {node.label()} depends on itself")
                self.placing.add(id(node))
                placed = self.lookup(node.own_scope, node.placement, f"{node.label()} placement_frame")
                H = H @ inverse(self.down_to(node, placed))
                self.placing.discard(id(node))
            node.edge = (parent, H)
        return node.edge

    def down_to(self, model: Node, node: Node) -> np.ndarray:
        """model_H_node, composed along node's pose chain up to `model` (a placement frame inside it)."""
        H, seen, current = np.eye(4), [], node
        while current is not model:
            if current is None or current is self.world:
                raise ValueError(
                    f"{model.where}: placement_frame '{model.placement}' of {model.label()} is not placed inside the model "
                    "(its pose chain leaves it)"
                )
            if any(current is s for s in seen):
                self.cycle(seen, current)
            seen.append(current)
            parent, E = self.edge(current)
            H = E @ H
            current = parent
        return H

    def cycle(self, chain: list[Node], repeated: Node) -> None:
        start = next(k for k, n in enumerate(chain) if n is repeated)
        names = " -> ".join(f"'{n.name}'" for n in [*chain[start:], repeated])
        raise ValueError(f"{repeated.where}: the poses of {names} are expressed relative to each other in a cycle")

    def transform(self, a: Node, b: Node) -> np.ndarray:
        """a_H_b: composed from the lowest common ancestor of a and b in the pose graph."""
        up: dict[int, np.ndarray] = {}
        chain, T, node = [], np.eye(4), a
        while node is not None:
            if id(node) in up:
                self.cycle(chain, node)
            up[id(node)] = T
            chain.append(node)
            parent, E = self.edge(node)
            T, node = E @ T, parent
        chain, T, node = [], np.eye(4), b
        while id(node) not in up:
            if any(node is n for n in chain):
                self.cycle(chain, node)
            chain.append(node)
            parent, E = self.edge(node)
            T, node = E @ T, parent
        return inverse(up[id(node)]) @ T

    def body_of(self, node: Node, seen=()) -> Node:
        """The link (or the world) that `node` is rigidly attached to."""
        if any(node is n for n in seen):
            chain = [*seen, node]
            start = next(k for k, n in enumerate(chain) if n is node)
            names = " -> ".join(f"'{n.name}'" for n in chain[start:])
            raise ValueError(f"{node.where}: the attached_to chain {names} is a cycle: it never reaches a link")
        seen = (*seen, node)
        if node.kind in ("link", "world"):
            return node
        if node.kind == "joint":
            return self.body_of(self.lookup(node.scope, node.child, f"{node.label()} <child>"), seen)
        if node.kind == "frame":
            target = self.lookup(node.scope, node.attached_to, f"{node.label()} attached_to") if node.attached_to else node.scope.frame
            return self.body_of(target, seen)
        if node.static:
            return self.world
        return self.body_of(self.canonical_link(node), seen)

    def canonical_link(self, model: Node) -> Node:
        if model.canonical:
            link = self.lookup(model.own_scope, model.canonical, f"{model.label()} canonical_link")
            if link.kind != "link":
                raise ValueError(f"{model.where}: {model.label()} canonical_link '{model.canonical}' is {link.label()}, not a link")
            return link
        if model.first_link is not None:
            return model.first_link
        if model.first_model is not None:
            return self.canonical_link(model.first_model)
        raise ValueError(f"{model.where}: {model.label()} has no link")


# ------------------------------------------------------------------------------------------- files


def resolve_include(uri: str, base_dir: pathlib.Path, where: str) -> pathlib.Path:
    """The SDF file an <include><uri> names (see the module docstring), or a ValueError naming the places
    looked at."""
    parsed = urllib.parse.urlparse(uri)
    looked: list[str] = []
    if parsed.scheme == "model":
        name, rest = parsed.netloc, parsed.path.lstrip("/")
        roots = [base_dir, *base_dir.parents]
        for variable in RESOURCE_PATH_VARIABLES:
            roots += [pathlib.Path(d) for d in os.environ.get(variable, "").split(os.pathsep) if d]
        for root in roots:
            for candidate in ([root] if root.name == name else []) + [root / name]:
                found = model_file(candidate / rest if rest else candidate)
                if found is not None:
                    return found
            looked.append(str(root))
        raise ValueError(
            f"{where}: <include> of '{uri}': no model '{name}' in the including file's directory or its ancestors, nor in "
            f"{', '.join(RESOURCE_PATH_VARIABLES)} (looked in {looked})"
        )
    if parsed.scheme == "file":
        path = pathlib.Path(urllib.parse.unquote(parsed.netloc + parsed.path))
    elif len(parsed.scheme) > 1:
        raise ValueError(f"{where}: <include> of '{uri}': only local model://, file:// and paths are read (no download)")
    else:
        path = pathlib.Path(uri).expanduser()
        if not path.is_absolute():
            path = base_dir / path
    found = model_file(path)
    if found is None:
        raise ValueError(f"{where}: <include> of '{uri}': '{path}' is neither an SDF file nor a model directory")
    return found

def model_file(path: pathlib.Path) -> pathlib.Path | None:
    """The SDF file of `path`: the file itself, or a model directory's file (model.config, else model.sdf)."""
    if path.is_file():
        return path
    if not path.is_dir():
        return None
    config = path / "model.config"
    if config.is_file():
        try:
            entries = ET.parse(config).getroot().findall("sdf")
        except ET.ParseError:
            entries = []

        def rank(entry):
            try:
                major, minor = (int(v) for v in entry.get("version", "0.0").split("."))
            except ValueError:
                return (-1, -1)
            return (major, minor) if (major, minor) <= SUPPORTED_VERSIONS[1] else (-1, minor)

        for entry in sorted(entries, key=rank, reverse=True):
            candidate = path / text(entry)
            if text(entry) and candidate.is_file():
                return candidate
    candidate = path / "model.sdf"
    return candidate if candidate.is_file() else None

