"""SDFormat 1.4 to 1.11, read with xml.etree into a `ModelDescription` (see warpdyn.description.model for
the conventions). No Gazebo or sdformat library is involved; docs/formats_sdf.md lists what is read, what
is refused and what the NotModelledWarning names.

Frames, poses, nested models and includes: warpdyn.description.sdf_frames states the rules.

The base: a floating model's base is the root of its joints' tree; `initial_world_H_base` is its pose in
the world (its `<world>`'s placement, its own `<pose>`). A `<static>` model, or a fixed joint from
`world`, welds the base (`world_H_base`); movable joints from `world` make the world the fixed base.

Joints: revolute, continuous (a revolute without position limits), prismatic, ball (about the joint frame's
origin) and fixed; `<axis><initial_position>` is where `Data.build` starts the joint. Limits of
+-1e16 or beyond (the <= 1.10 defaults) are none; lower > upper is read as unlimited, as ODE (Gazebo
classic's engine) ignores inverted stops, and named in the warning; a negative effort or velocity limit
is none (the spec: "not enforced"). `<dynamics>`: damping -> JointDescription.damping (JaxSim's viscous
friction), friction -> friction (static), spring_stiffness / spring_reference -> stiffness / springref.

Links: `<inertial>` mass, CoM (the inertial pose's translation) and inertia rotated from the inertial frame
into the link frame; SDFormat's defaults (1 kg, diag(1, 1, 1) kg m^2) where it says nothing, named in the
warning. Collisions: box, sphere, cylinder, capsule, mesh (uri, scale; a relative mesh path of an included
file made absolute against that file's directory); other geometries are named in the warning.

Differences from JaxSim 0.9.0's rod parser: docs/formats_sdf.md, "Compared with JaxSim 0.9.0". Visuals: their box, sphere,
cylinder and capsule primitives, for JaxSim's hardware parametrisation (nothing else of them is read or noted).
"""

from __future__ import annotations

import pathlib
import urllib.parse
import xml.etree.ElementTree as ET

import numpy as np

from .model import CollisionShape, FrameDescription, JointDescription, LinkDescription, ModelDescription, finish_tree
from .sdf_frames import (
    RESOURCE_PATH_VARIABLES,
    SUPPORTED_VERSIONS,
    FrameGraph,
    Node,
    Scope,
    boolean,
    number,
    parse_bool,
    parse_pose,
    parse_version,
    resolve_include,
    text,
    vector,
)

__all__ = ["load_sdf", "SUPPORTED_VERSIONS", "RESOURCE_PATH_VARIABLES"]

UNLIMITED = 1e16
"""Joint limits at or beyond this magnitude are none (SDFormat <= 1.10 writes -1e16, 1e16 for 'no limit')."""

# The kinds of the NotModelledWarning, in the order the message lists them.
SENSORS = "sensors (their plugins included)"
PLUGINS = "plugins"
JOINT_PHYSICS = "joint <physics> settings (engine-specific: ODE cfm/erp, implicit_spring_damper, Simbody...)"
LIMIT_STOPS = (
    "joint-limit <stiffness>/<dissipation> (JaxSim reads them as its limit spring and damper; warpdyn's limit springs "
    "stay off: model.set_joint_parameters(limit_spring=..., limit_damper=...))"
)
INVERTED_LIMITS = "joint limits with lower > upper (read as unlimited: ODE, Gazebo classic's engine, ignores inverted stops)"
MIMIC = "mimic joints (kept as independent joints: their <mimic> coupling is ignored)"
STATIC_JOINTS = (
    "movable joints of a static model (Gazebo moves no link of a static model; warpdyn welds its base to the world "
    "and keeps its joints)"
)
DEFAULT_INERTIAL = (
    "links without <inertial>, <mass> or <inertia> values (given SDFormat's defaults: mass 1 kg, inertia diag(1, 1, 1) "
    "kg m^2)"
)
FLUID_ADDED_MASS = "fluid added mass (<fluid_added_mass>)"
SURFACES = (
    "collision contact settings (<surface> friction, bounce and contact stiffness, <max_contacts>, <laser_retro>: "
    "warpdyn's contact parameters are the model's, model.contact_params)"
)
GEOMETRIES = "collision geometries without collidable points (plane, heightmap, polyline, cone, image)"
SUBMESHES = "mesh <submesh> selections (the whole mesh is used)"
LINK_GRAVITY = "links with <gravity>false</gravity> (warpdyn applies gravity to every link)"
SELF_COLLISION = "self collision (<self_collide>: warpdyn's contacts are between collidable points and the terrain)"
KINEMATIC = "kinematic links (<kinematic>: simulated as dynamic links)"
VELOCITY_DECAY = "link <velocity_decay>"
WIND = "wind (<enable_wind>, <wind>)"
LIGHTS = "lights"
ACTORS = "actors"
EMITTERS = "projectors, audio sources and sinks, batteries and particle emitters"
WORLD_SETTINGS = (
    "world settings (<physics> engine, solver and rates: warpdyn's integrator and contact model are its own; scene, "
    "atmosphere, magnetic field, coordinates...)"
)
WORLD_FRAMES = "frames fixed in the world beside a floating model (not frames of the model)"
LEGACY_FRAMES = (
    "SDFormat 1.5/1.6 <frame> elements and <pose frame=...> attributes (never given semantics: ignored, as Gazebo "
    "ignores them)"
)
OTHER_VERSION = "elements of other SDFormat versions (ignored in this file's version)"
OTHER = "other elements (not read)"

_KIND_ORDER = (
    SENSORS, PLUGINS, JOINT_PHYSICS, LIMIT_STOPS, INVERTED_LIMITS, MIMIC, STATIC_JOINTS, DEFAULT_INERTIAL,
    FLUID_ADDED_MASS, SURFACES, GEOMETRIES, SUBMESHES, LINK_GRAVITY, SELF_COLLISION, KINEMATIC, VELOCITY_DECAY, WIND, LIGHTS,
    ACTORS, EMITTERS, WORLD_SETTINGS, WORLD_FRAMES, LEGACY_FRAMES, OTHER_VERSION, OTHER,
)  # fmt: skip

_REFUSED_JOINTS = {
    "universal": "two rotational degrees of freedom", "revolute2": "two rotational degrees of freedom",
    "screw": "coupled rotation and translation", "gearbox": "a gear constraint between two joints",
}  # fmt: skip
_NAMED = {  # child elements listed by name wherever they appear
    "sensor": SENSORS, "plugin": PLUGINS, "light": LIGHTS, "actor": ACTORS, "projector": EMITTERS, "audio_sink": EMITTERS,
    "audio_source": EMITTERS, "battery": EMITTERS, "particle_emitter": EMITTERS,
}  # fmt: skip
_FLAGS = {  # boolean child elements: (the default, which has no effect; the kind that names a link or model that changes it)
    "gravity": (True, LINK_GRAVITY), "self_collide": (False, SELF_COLLISION), "kinematic": (False, KINEMATIC),
    "enable_wind": (False, WIND), "must_be_base_link": (False, OTHER), "allow_auto_disable": (True, None),
}  # fmt: skip
_UNSUPPORTED_GEOMETRIES = ("plane", "heightmap", "polyline", "cone", "image")
_WORLD_SETTINGS = ("physics", "scene", "gui", "atmosphere", "magnetic_field", "spherical_coordinates", "audio", "road",
                   "population", "state")  # fmt: skip


# ------------------------------------------------------------------------------------------- the reader


class _Reader(FrameGraph):
    """The elements of a document and of the files it includes, read into the frame graph and then into a
    ModelDescription; `notes` collects what is not modelled."""

    def __init__(self, where: str, path: str | None):
        super().__init__()
        self.world.where = where
        self.notes: dict[str, list[str]] = {}
        self.models: list[Node] = []  # every model node, top first
        self.links: list[Node] = []
        self.joints: list[Node] = []
        self.frames: list[Node] = []
        self.including: list[str] = [] if path is None else [str(pathlib.Path(path).resolve())]
        self.top_where = where
        self.gravity: np.ndarray | None = None
        self.time_step: float | None = None

    def note(self, kind: str, name: str) -> None:
        names = self.notes.setdefault(kind, [])
        if name not in names:
            names.append(name)

    # ------------------------------------------------------------------ poses

    def pose_of(self, element, where: str, what: str) -> tuple[np.ndarray, str | None]:
        """(the pose, its relative_to or None) of the `<pose>` child of `element` (in the file `where`)."""
        return self.parse_pose(element.find("pose") if element is not None else None, where, what)

    def parse_pose(self, pose, where: str, what: str) -> tuple[np.ndarray, str | None]:
        if pose is not None and pose.get("frame"):
            self.note(LEGACY_FRAMES, f"{what} <pose frame='{pose.get('frame')}'>")
        return parse_pose(pose, where, what)

    def others(self, element, kind: str, name: str, where: str, read=()) -> None:
        """Notes the children of `element` (the `kind` named `name`: link, model, joint, collision, world) that are
        not `read`: sensors, plugins, lights... by name; flags that differ from their default (which has no
        effect); anything else as OTHER."""
        owner = f"<{name}>" if kind in ("world", "sdf") else f"{kind} '{name}'"
        for child in element:
            tag = child.tag
            if tag in read:
                continue
            if tag in _NAMED:
                self.note(_NAMED[tag], f"{name}/{child.get('name', child.get('filename', tag))}")
            elif tag in _FLAGS:
                default, flagged = _FLAGS[tag]
                if flagged is not None and boolean(child, f"{owner} <{tag}>", where, default) != default:
                    self.note(flagged, f"{owner} <{tag}>" if flagged is OTHER else name)
            elif tag == "velocity_decay":
                if any(number(child.find(k), f"{owner} <velocity_decay><{k}>", where, 0.0) for k in ("linear", "angular")):
                    self.note(VELOCITY_DECAY, name)
            elif tag == "frame":
                self.note(LEGACY_FRAMES, f"{owner} <frame name='{child.get('name', '')}'>")
            elif tag == "wind":
                self.note(WIND, f"{owner} <wind>")
            elif tag == "physics" and kind == "joint":
                self.note(JOINT_PHYSICS, name)
            elif tag in _WORLD_SETTINGS and kind == "world":
                self.note(WORLD_SETTINGS, f"<{tag}>")
            else:
                self.note(OTHER, f"{owner} <{tag}>")

    # ------------------------------------------------------------------ elements

    def document(self, root: ET.Element, where: str, base_dir: pathlib.Path) -> Node:
        """The one model of the document (in its <world> or alone), read with everything it includes."""
        version = parse_version(root, where)
        worlds, models = root.findall("world"), root.findall("model")
        self.others(root, "sdf", "sdf", where, read=("world", "model"))  # lights, actors
        if len(worlds) > 1:
            raise ValueError(f"{where} has {len(worlds)} worlds {[w.get('name') for w in worlds]}: warpdyn reads one")
        if worlds and models:
            raise ValueError(f"{where} has a <world> and, beside it, models {[m.get('name') for m in models]}")
        if worlds:
            return self.world_element(worlds[0], where, version, base_dir)
        if not models:
            raise ValueError(f"{where} has no <model> (nor a <world> holding one)")
        if len(models) > 1:
            raise ValueError(
                f"{where} has {len(models)} models {[m.get('name') for m in models]} under <sdf>: warpdyn simulates one tree "
                "(several trees are not supported yet)"
            )
        scope = Scope(self.world, "", where, version, base_dir)
        return self.model(models[0], scope, where, version, base_dir, top=True)

    def world_element(self, world: ET.Element, where: str, version, base_dir) -> Node:
        scope = Scope(self.world, "", where, version, base_dir, model_name="")
        tops: list[Node] = []
        for child in world:
            tag = child.tag
            if tag == "model":
                tops.append(self.model(child, scope, where, version, base_dir, top=True))
            elif tag == "include":
                model = self.include(child, scope, top=True)
                if model is not None:
                    tops.append(model)
            elif tag == "frame":
                self.frame(child, scope)
            elif tag == "joint":
                self.joint(child, scope)
            elif tag == "gravity":
                self.read_gravity(child, where)
            elif tag == "physics":
                self.read_physics(child, world, where)
        self.others(world, "world", "world", where, read=("model", "include", "frame", "joint", "gravity", "physics"))
        if self.gravity is None:
            physics_gravity = [p.find("gravity") for p in world.findall("physics") if p.find("gravity") is not None]
            if physics_gravity:  # SDFormat <= 1.5 keeps gravity in <physics>
                self.read_gravity(physics_gravity[0], where)
            else:
                self.gravity = np.array([0.0, 0.0, -9.8])  # SDFormat's default <gravity> of a world
        if len(tops) != 1:
            raise ValueError(
                f"{where}: the world holds {len(tops)} models {[m.name for m in tops]}: warpdyn simulates one tree (several "
                "trees, static scenery or a ground plane beside the robot, are not supported yet: warpdyn's terrain is the "
                "ground)"
            )
        return tops[0]

    def read_gravity(self, element, where: str) -> None:
        self.gravity = vector(element, 3, "<world><gravity>", where, (0.0, 0.0, -9.8)) + 0.0  # no -0.0

    def read_physics(self, physics, world, where: str) -> None:
        engines = world.findall("physics")
        chosen = next((p for p in engines if parse_bool(p.get("default", "false"), "<physics default>", where)), engines[0])
        if physics is chosen and physics.find("max_step_size") is not None:
            self.time_step = number(physics.find("max_step_size"), "<physics><max_step_size>", where, 0.001)
        settings = [c.tag for c in physics if c.tag not in ("max_step_size", "gravity")]
        if settings or physics.get("type"):
            self.note(WORLD_SETTINGS, f"<physics name='{physics.get('name', 'default_physics')}' type='{physics.get('type', 'ode')}'>")

    def model(self, element, parent: Scope, where: str, version, base_dir, *, top=False, name=None, pose=None,
              static=None, placement=None, merge=False) -> Node:
        local = name if name is not None else element.get("name", "")
        if top:
            global_name, prefix = local, ""
        else:
            global_name = parent.prefix + local
            prefix = global_name + "::"
        if merge:
            global_name, prefix = f"{parent.prefix}_merged__{local}__model__", parent.prefix
        node = Node("model", global_name, parent, where, version)
        node.element = element
        if pose is not None:  # an include's <pose>, in the including file
            node.pose, node.relative_to = self.parse_pose(pose, parent.where, f"<include> of model '{local}'")
        else:
            node.pose, node.relative_to = self.pose_of(element, where, f"model '{global_name}'")
        node.placement = placement if placement is not None else element.get("placement_frame", "")
        node.canonical = element.get("canonical_link", "") if version >= (1, 7) else ""
        node.static = static if static is not None else boolean(element.find("static"), f"model '{global_name}' <static>", where, False)
        node.static |= parent.frame is not self.world and parent.frame.static  # a static model's nested models are static
        if merge:
            parent.add(f"_merged__{local}__model__", node, "merged model frame")
            scope = Scope(node, parent.prefix, where, version, base_dir, parent.names, model_name=local)
            self.frames.append(node)
        else:
            parent.add(local, node, "model")
            scope = Scope(node, prefix, where, version, base_dir, model_name=local)
        node.own_scope = scope
        self.models.append(node)
        for child in element:
            tag = child.tag
            if tag == "link":
                link = self.link(child, scope)
                if node.first_link is None:
                    node.first_link = link
            elif tag == "joint":
                self.joint(child, scope)
            elif tag == "frame" and version >= (1, 7):
                self.frame(child, scope)
            elif tag in ("model", "include"):
                nested = self.model(child, scope, where, version, base_dir) if tag == "model" else self.include(child, scope)
                if nested is not None and node.first_model is None:
                    node.first_model = nested
        read = ("link", "joint", "model", "include", "pose", "static", "frame" if version >= (1, 7) else "")
        self.others(element, "model", global_name, where, read)  # allow_auto_disable: a solver's sleeping, not dynamics
        if node.first_link is None and node.first_model is None and node.canonical == "":
            raise ValueError(f"{where}: {node.label()} has no link")
        return node

    def include(self, element, scope: Scope, *, top=False) -> Node | None:
        where = scope.where
        uri = text(element.find("uri"))
        if not uri:
            raise ValueError(f"{where}: an <include> has no <uri>")
        path = resolve_include(uri, scope.base_dir, where)
        resolved = str(path.resolve())
        if resolved in self.including:
            raise ValueError(f"{where}: <include> of '{uri}' includes '{path}', which is already being read (an include cycle)")
        try:
            root = ET.parse(path).getroot()
        except (ET.ParseError, OSError) as error:
            raise ValueError(f"{where}: <include> of '{uri}': '{path}' is not a readable XML file: {error}") from None
        inner_where = f"'{path}'"
        if root.tag != "sdf":
            raise ValueError(f"{inner_where} (included as '{uri}' by {where}) has root element <{root.tag}>, not <sdf>")
        version = parse_version(root, inner_where)
        self.others(root, "sdf", "sdf", inner_where, read=("world", "model"))  # lights, actors
        models = root.findall("model")
        if root.findall("world") or len(models) > 1:
            raise ValueError(f"{inner_where} (included as '{uri}' by {where}) must hold one <model>, not worlds or several models")
        for plugin in element.findall("plugin"):
            self.note(PLUGINS, f"<include {uri}>/{plugin.get('name', plugin.get('filename', 'plugin'))}")
        if not models:
            return None  # a light or an actor, noted above
        merge = parse_bool(element.get("merge", "false"), f"<include {uri}> merge", where)
        if merge and top:
            raise ValueError(f"{where}: <include merge='true'> of '{uri}' is only allowed inside a model")
        name = text(element.find("name")) or None
        static = element.find("static")
        placement = text(element.find("placement_frame")) or None
        pose = element.find("pose")
        if placement is not None and pose is None:
            raise ValueError(f"{where}: <include> of '{uri}' has a <placement_frame> but no <pose>")
        self.including.append(resolved)
        model = self.model(
            models[0], scope, inner_where, version, path.resolve().parent, top=top, name=name, pose=pose,
            static=None if static is None else boolean(static, f"<include {uri}><static>", where, False),
            placement=placement, merge=merge,
        )
        self.including.pop()
        return model

    def link(self, element, scope: Scope) -> Node:
        local = element.get("name", "")
        node = Node("link", scope.prefix + local, scope, scope.where, scope.version)
        scope.add(local, node, "link")
        node.element = element
        node.pose, node.relative_to = self.pose_of(element, scope.where, node.label())
        self.links.append(node)
        return node

    def joint(self, element, scope: Scope) -> Node:
        local = element.get("name", "")
        node = Node("joint", scope.prefix + local, scope, scope.where, scope.version)
        if scope.version >= (1, 7):
            scope.add(local, node, "joint")
        elif not local:
            raise ValueError(f"{scope.where}: a <joint> has no name")
        node.element = element
        node.child = text(element.find("child"))
        if not node.child:
            raise ValueError(f"{scope.where}: joint '{node.name}' has no <child>")
        if not text(element.find("parent")):
            raise ValueError(f"{scope.where}: joint '{node.name}' has no <parent>")
        if node.child == "world":
            raise ValueError(f"{scope.where}: joint '{node.name}' has the world as <child>: only <parent> may be 'world'")
        node.pose, node.relative_to = self.pose_of(element, scope.where, node.label())
        self.joints.append(node)
        return node

    def frame(self, element, scope: Scope) -> Node:
        local = element.get("name", "")
        node = Node("frame", scope.prefix + local, scope, scope.where, scope.version)
        scope.add(local, node, "frame")
        node.element = element
        node.attached_to = element.get("attached_to", "")
        node.pose, node.relative_to = self.pose_of(element, scope.where, node.label())
        self.frames.append(node)
        return node

    # ------------------------------------------------------------------ descriptions

    def link_description(self, node: Node) -> LinkDescription:
        element, where, name = node.element, node.where, node.name
        link = LinkDescription(name=name)
        inertial = element.find("inertial")
        defaults = []
        if inertial is None:
            defaults.append("<inertial>")
            mass, H, I = 1.0, np.eye(4), np.eye(3)
        else:
            if parse_bool(inertial.get("auto", "false"), f"link '{name}' <inertial auto>", where):
                raise ValueError(
                    f"{where}: link '{name}' has <inertial auto='true'>: warpdyn does not compute inertias from collision "
                    "geometry; give <mass> and <inertia>"
                )
            if inertial.find("mass") is None:
                defaults.append("<mass>")
            mass = number(inertial.find("mass"), f"link '{name}' <inertial><mass>", where, 1.0)
            H, relative_to = self.pose_of(inertial, where, f"link '{name}' <inertial>")
            if relative_to:
                H = self.transform(node, self.lookup(node.scope, relative_to, f"link '{name}' <inertial><pose relative_to>")) @ H
            block = inertial.find("inertia")
            if block is None:
                defaults.append("<inertia>")
            v = {}
            for key, default in (("ixx", 1.0), ("ixy", 0.0), ("ixz", 0.0), ("iyy", 1.0), ("iyz", 0.0), ("izz", 1.0)):
                entry = block.find(key) if block is not None else None
                if block is not None and entry is None and default != 0.0:  # a missing product of inertia is 0
                    defaults.append(f"<{key}>")
                v[key] = number(entry, f"link '{name}' <inertia><{key}>", where, default)
            I = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]], [v["ixz"], v["iyz"], v["izz"]]])
            if inertial.find("fluid_added_mass") is not None:
                self.note(FLUID_ADDED_MASS, name)
            read = ("mass", "pose", "inertia", "fluid_added_mass", "density", "auto_inertia_params")
            self.others(inertial, "link", name, where, read)
        if defaults:
            self.note(DEFAULT_INERTIAL, f"{name} ({', '.join(defaults)})")
        link.mass = mass
        link.com = np.array(H[:3, 3], dtype=np.float64)
        link.inertia = H[:3, :3] @ I @ H[:3, :3].T
        link.inertial_rotation = np.array(H[:3, :3], dtype=np.float64)
        for child in element.findall("visual"):
            shape = self.visual(child, node)
            if shape is not None:
                link.visuals.append(shape)
        for child in element.findall("collision"):
            shape = self.collision(child, node)
            if shape is not None:
                link.collisions.append(shape)
        self.others(element, "link", name, where, read=("inertial", "pose", "visual", "collision"))  # visuals: not physics
        return link

    def visual(self, element, link: Node) -> CollisionShape | None:
        """A <visual>'s primitive in the link frame (the module docstring), None for any other geometry."""
        label = f"{link.name}/{element.get('name', 'visual')}"
        H, relative_to = self.pose_of(element, link.where, f"visual '{label}'")
        if relative_to:
            H = self.transform(link, self.lookup(link.scope, relative_to, f"visual '{label}' <pose relative_to>")) @ H
        geometry = element.find("geometry")
        shape = None if geometry is None or not len(geometry) else geometry[0]
        return None if shape is None else self.primitive(shape, H, f"visual '{label}' <{shape.tag}>", link.where)

    @staticmethod
    def primitive(shape, H: np.ndarray, what: str, where: str) -> CollisionShape | None:
        """A box, sphere, ellipsoid, cylinder or capsule geometry element as a shape at H (SDFormat's defaults); None else."""
        if shape.tag in ("box", "ellipsoid"):  # a box's full extents, an ellipsoid's radii
            tag = "size" if shape.tag == "box" else "radii"
            return CollisionShape(shape.tag, H, size=vector(shape.find(tag), 3, f"{what}<{tag}>", where, (1.0, 1.0, 1.0)))
        if shape.tag == "sphere":
            return CollisionShape("sphere", H, radius=number(shape.find("radius"), f"{what}<radius>", where, 1.0))
        if shape.tag in ("cylinder", "capsule"):
            radius = number(shape.find("radius"), f"{what}<radius>", where, 1.0 if shape.tag == "cylinder" else 0.5)
            return CollisionShape(shape.tag, H, radius=radius, length=number(shape.find("length"), f"{what}<length>", where, 1.0))
        return None

    def collision(self, element, link: Node) -> CollisionShape | None:
        where, scope = link.where, link.scope
        label = f"{link.name}/{element.get('name', 'collision')}"
        H, relative_to = self.pose_of(element, where, f"collision '{label}'")
        if relative_to:
            H = self.transform(link, self.lookup(scope, relative_to, f"collision '{label}' <pose relative_to>")) @ H
        if any(element.find(tag) is not None for tag in ("surface", "max_contacts", "laser_retro")):
            self.note(SURFACES, label)
        read = ("pose", "geometry", "density", "auto_inertia_params", "surface", "max_contacts", "laser_retro")
        self.others(element, "collision", label, where, read)
        geometry = element.find("geometry")
        shapes = [] if geometry is None else list(geometry)
        if not shapes:
            return None
        shape = shapes[0]
        kind, what = shape.tag, f"collision '{label}' <{shape.tag}>"
        if kind in ("box", "sphere", "ellipsoid", "cylinder", "capsule"):
            return self.primitive(shape, H, what, where)
        if kind == "mesh":
            uri = text(shape.find("uri"))
            if not uri:
                raise ValueError(f"{where}: {what} has no <uri>")
            parsed = urllib.parse.urlparse(uri)
            if not parsed.scheme and not pathlib.Path(uri).is_absolute() and link.where != self.top_where:
                uri = str(scope.base_dir / uri)  # an included file's relative mesh: against that file
            scale = vector(shape.find("scale"), 3, f"{what}<scale>", where, (1.0, 1.0, 1.0))
            if shape.find("submesh") is not None:
                self.note(SUBMESHES, label)
            return CollisionShape("mesh", H, filename=uri, scale=scale)
        if kind == "empty":
            return None
        if kind in _UNSUPPORTED_GEOMETRIES:
            self.note(GEOMETRIES, f"{label} ({kind})")
            return None
        self.note(OTHER, f"collision '{label}' <geometry><{kind}>")
        return None

    def joint_description(self, node: Node, parent: Node, child: Node) -> JointDescription:
        element, where, name = node.element, node.where, node.name
        kind = element.get("type", "")
        if kind in _REFUSED_JOINTS:
            raise ValueError(f"{where}: joint '{name}' has type '{kind}' ({_REFUSED_JOINTS[kind]}), which warpdyn does not support")
        if kind not in ("revolute", "continuous", "prismatic", "ball", "fixed"):
            raise ValueError(
                f"{where}: joint '{name}' has type '{kind}': expected revolute, continuous, prismatic, ball or fixed (universal, "
                "revolute2, screw and gearbox are refused)"
            )
        parent_name = "world" if parent is self.world else parent.name
        origin = self.transform(parent, child)
        joint = JointDescription(name=name, type=kind if kind in ("fixed", "prismatic", "ball") else "revolute",
                                 parent=parent_name, child=child.name, origin=origin)
        self.others(element, "joint", name, where, read=("pose", "parent", "child", "axis", "axis2"))
        if kind == "fixed":
            return joint
        if kind == "ball":  # about the joint frame's origin; an axis means nothing to it
            joint.pivot = np.array(self.transform(child, node)[:3, 3], dtype=np.float64)
            for tag in ("axis", "axis2"):
                if element.find(tag) is not None:
                    self.note(OTHER, f"joint '{name}' <{tag}> (a ball joint has no axis)")
            return joint
        axis = element.find("axis")
        C_H_J = self.transform(child, node)
        xyz_element = axis.find("xyz") if axis is not None else None
        xyz = vector(xyz_element, 3, f"joint '{name}' <axis><xyz>", where, (0.0, 0.0, 1.0))
        norm = np.linalg.norm(xyz)
        if norm < 1e-12:
            raise ValueError(f"{where}: joint '{name}' has the zero axis {xyz.tolist()}")
        version = node.version
        expressed = None  # the frame the axis is written in: the joint frame by default
        if version < (1, 5):
            expressed = node.scope.frame  # SDFormat 1.4: the (parent) model frame
        elif version < (1, 7):
            upmf = axis.find("use_parent_model_frame") if axis is not None else None
            if boolean(upmf, f"joint '{name}' <use_parent_model_frame>", where, False):
                expressed = node.scope.frame
        else:
            if axis is not None and axis.find("use_parent_model_frame") is not None:
                self.note(OTHER_VERSION, f"joint '{name}' <use_parent_model_frame> (SDFormat 1.5/1.6)")
        if version < (1, 7) and xyz_element is not None and xyz_element.get("expressed_in"):
            self.note(OTHER_VERSION, f"joint '{name}' <xyz expressed_in> (SDFormat 1.7+)")
        if version >= (1, 7):
            frame = xyz_element.get("expressed_in", "") if xyz_element is not None else ""
            if frame:
                expressed = self.lookup(node.scope, frame, f"joint '{name}' <xyz expressed_in>")
        C_R_E = C_H_J[:3, :3] if expressed is None else self.transform(child, expressed)[:3, :3]
        joint.axis = C_R_E @ (xyz / norm)
        joint.pivot = np.array(C_H_J[:3, 3], dtype=np.float64)
        if axis is not None:
            self.axis_details(axis, joint, kind, where)
        if element.find("axis2") is not None:
            self.note(OTHER, f"joint '{name}' <axis2> (a second axis of a single-axis joint)")
        return joint

    def axis_details(self, axis, joint: JointDescription, kind: str, where: str) -> None:
        name = joint.name
        limit = axis.find("limit")
        if limit is not None:
            lower = number(limit.find("lower"), f"joint '{name}' <limit><lower>", where, -np.inf, finite=False)
            upper = number(limit.find("upper"), f"joint '{name}' <limit><upper>", where, np.inf, finite=False)
            lower = -np.inf if lower <= -UNLIMITED else lower
            upper = np.inf if upper >= UNLIMITED else upper
            if kind != "continuous":
                if lower > upper:
                    self.note(INVERTED_LIMITS, f"{name} ({lower:g} > {upper:g})")
                    lower, upper = -np.inf, np.inf
                joint.lower, joint.upper = lower, upper
            for attribute, what in (("effort", "effort"), ("velocity", "velocity")):
                value = number(limit.find(attribute), f"joint '{name}' <limit><{attribute}>", where, np.inf, finite=False)
                setattr(joint, what, np.inf if value < 0.0 else value)  # negative: not enforced (the spec)
            if limit.find("stiffness") is not None or limit.find("dissipation") is not None:
                self.note(LIMIT_STOPS, name)
            for child in limit:
                if child.tag not in ("lower", "upper", "effort", "velocity", "stiffness", "dissipation"):
                    self.note(OTHER, f"joint '{name}' <limit><{child.tag}>")
        dynamics = axis.find("dynamics")
        if dynamics is not None:
            joint.damping = number(dynamics.find("damping"), f"joint '{name}' <dynamics><damping>", where, 0.0)
            joint.friction = number(dynamics.find("friction"), f"joint '{name}' <dynamics><friction>", where, 0.0)
            joint.stiffness = number(dynamics.find("spring_stiffness"), f"joint '{name}' <dynamics><spring_stiffness>", where, 0.0)
            joint.springref = number(dynamics.find("spring_reference"), f"joint '{name}' <dynamics><spring_reference>", where, 0.0)
            for child in dynamics:
                if child.tag not in ("damping", "friction", "spring_stiffness", "spring_reference"):
                    self.note(OTHER, f"joint '{name}' <dynamics><{child.tag}>")
        for child in axis:
            if child.tag == "mimic":
                self.note(MIMIC, name)
            elif child.tag == "initial_position":
                joint.initial_position = np.array([number(child, f"joint '{name}' <axis><initial_position>", where, 0.0)])
            elif child.tag not in ("xyz", "limit", "dynamics", "use_parent_model_frame"):
                self.note(OTHER, f"joint '{name}' <axis><{child.tag}>")

    # ------------------------------------------------------------------ the tree

    def description(self, top: Node, where: str) -> ModelDescription:
        nested_static = [m.name for m in self.models if m.static and not top.static]
        if nested_static:
            raise ValueError(
                f"{where}: the static models {nested_static} are welded to the world inside the floating model '{top.name}': "
                "several trees (not supported yet)"
            )
        for node in (*self.models, *self.links, *self.joints, *self.frames):
            self.transform(self.world, node)  # every pose resolves: unknown relative_to and cycles are refused, used or not
        links = [self.link_description(node) for node in self.links]
        if any(link.name == "world" for link in links):
            raise ValueError(f"{where}: a link is named 'world', which SDFormat reserves")
        joints, children = [], {}
        for node in self.joints:
            parent_name = text(node.element.find("parent"))
            parent_frame = self.lookup(node.scope, parent_name, f"{node.label()} <parent>")
            child_frame = self.lookup(node.scope, node.child, f"{node.label()} <child>")
            parent, child = self.body_of(parent_frame), self.body_of(child_frame)
            if child is self.world:
                raise ValueError(f"{node.where}: {node.label()} has child '{node.child}', which is fixed in the world")
            if parent is child:
                raise ValueError(f"{node.where}: {node.label()} connects link '{child.name}' to itself")
            joint = self.joint_description(node, parent, child)
            children.setdefault(child.name, []).append(joint.name)
            joints.append(joint)
            if top.static and joint.type != "fixed":
                self.note(STATIC_JOINTS, joint.name)
        loops = {link: names for link, names in children.items() if len(names) > 1}
        if loops:
            raise ValueError(
                f"{where}: links with several parent joints (a kinematic loop, which warpdyn's trees cannot hold): "
                + "; ".join(f"'{link}' is the child of {names}" for link, names in loops.items())
            )
        roots = [link.name for link in links if link.name not in children]
        world_jointed = any(j.parent == "world" for j in joints)
        if not roots and not world_jointed and links:
            raise ValueError(
                f"{where}: every link of model '{top.name}' is a joint's child: its joints {[j.name for j in joints]} close a "
                "kinematic loop (warpdyn's trees cannot hold one)"
            )
        node_of = {node.name: node for node in self.links}
        if top.static:
            for root in roots:
                joints.append(
                    JointDescription(name=f"__static_weld_{root}__", type="fixed", parent="world", child=root,
                                     origin=self.transform(self.world, node_of[root]))
                )
            world_jointed = True
        elif world_jointed:
            if roots:
                raise ValueError(
                    f"{where}: model '{top.name}' has links jointed to the world and also the floating roots {roots}: several "
                    "trees (not supported yet)"
                )
        elif len(roots) != 1:
            raise ValueError(
                f"{where}: model '{top.name}' has {len(roots)} kinematic roots {roots} (links that are no joint's child): "
                "warpdyn simulates one tree (several trees are not supported yet): join them with joints"
            )
        if world_jointed:
            links = [LinkDescription(name="world"), *links]
        description = finish_tree(top.name, links, joints, "sdf", where)
        if not description.fixed_base:
            description.initial_world_H_base = self.transform(self.world, node_of[description.base])
        description.frames = self.frame_descriptions(description, node_of)
        description.gravity = self.gravity
        description.time_step = self.time_step
        description.not_modelled = {kind: self.notes[kind] for kind in _KIND_ORDER if kind in self.notes}
        return description

    def frame_descriptions(self, description: ModelDescription, node_of: dict[str, Node]) -> list[FrameDescription]:
        frames = []
        has_world = any(link.name == "world" for link in description.links)
        for node in self.frames:
            body = self.body_of(node)
            if body is self.world:
                if has_world:
                    frames.append(FrameDescription(node.name, "world", self.transform(self.world, node)))
                elif description.fixed_base:
                    base = node_of[description.base]
                    frames.append(FrameDescription(node.name, description.base, self.transform(base, node)))
                else:
                    self.note(WORLD_FRAMES, node.name)
                continue
            frames.append(FrameDescription(node.name, body.name, self.transform(body, node)))
        links = {link.name for link in description.links}
        names = [f.name for f in frames]
        clashes = sorted({n for n in names if n in links or names.count(n) > 1})
        if clashes:
            raise ValueError(
                f"{self.top_where}: frames {clashes} have the names of links or of other frames (warpdyn's frame names must "
                "differ from every link's and from each other)"
            )
        return frames


def load_sdf(root: ET.Element, path: str | None, where: str) -> ModelDescription:
    """The ModelDescription of an SDFormat document (its root element `<sdf>`), read from `path` (None for an XML
    string: includes then resolve against the working directory and the resource paths)."""
    reader = _Reader(where, path)
    base_dir = pathlib.Path(path).resolve().parent if path is not None else pathlib.Path.cwd()
    top = reader.document(root, where, base_dir)
    return reader.description(top, where)
