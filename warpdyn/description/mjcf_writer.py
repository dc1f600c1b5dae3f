"""A lumped tree written as MJCF (host NumPy): `Model.export_updated_model(format="mjcf")`, the model with its current
parameters for MuJoCo (or warpdyn) to load.

Each link is a body at its joint's frame in its parent (`pos`, `quat`), with an `inertial` (its current mass, centre
of mass and full inertia about it, link axes: `inertiafromgeom="false"`, so geoms add nothing) and its joint: a hinge
or slide through the joint's pivot along its axis, with its position limits (`range`; its MuJoCo limit row's
`margin`, `solreflimit`, `solimplimit`, and a ball's range its angle), static friction (`frictionloss`; its friction
row's `solreffriction`, `solimpfriction`), the clamp of its actuators' force (`actuatorfrcrange`), armature, MuJoCo's damper plus the description's viscous friction (`damping`: the same torque
-b qdot, which warpdyn reads back as MuJoCo's damper), spring (`stiffness`, `springref`), its start `ref` (qpos0; the body
written where the joint is at it); a ball joint at its pivot;
a floating base's free joint (its armature, damper, spring). The terrain's plane (a flat terrain's, a tilted plane's) is a plane geom, the static
geoms (the world body's and bodies welded to it) are the worldbody's, and the description's explicit `<pair>`s and
`<exclude>`s are written back (a body welded to the world is the world). Actuators are MuJoCo's `general` ones with their current affine gain and bias, gear,
control and force ranges (warpdyn's actuator law is that affine subset). Equality constraints are MJCF's: connects and
welds between sites at their anchors, joint couplings, fixed-tendon couplings between fixed tendons; the integrator
and MuJoCo's disable flags are written too. Frames (lumped links and explicit frames) are massless bodies welded where they are;
collision shapes are geoms in the body of the link (or frame) that carries them, with their collision filter and
contact parameters; the base hangs from the world at world_H_base when welded, and starts at the initial pose when
floating; a mesh is an asset with its vertices inline (an MJCF's) or its file as the description names it (a URDF's
package:// needs resolving before MuJoCo reads it). A free joint's body is a top-level body at its initial pose (MuJoCo's
free joints measure the world pose). What MJCF cannot say here raises a ValueError naming it: a free joint below
another body or off the world's frame, a ball or free joint whose DoFs have different frictions, armatures or
dampers, a mesh with neither vertices nor a file. Massless moving links (MuJoCo refuses them; an MJCF body of several
joints is several links here) get MuJoCo's boundmass and boundinertia, named in a warning.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET

import numpy as np

from .model import CollisionShape, ModelDescription, NotModelledWarning, homogeneous, joint_motion, matrix_to_quaternion_wxyz, quaternion_wxyz_to_matrix
from .tree import JOINT_BALL, JOINT_FREE, JOINT_REVOLUTE, KinematicTree
from .urdf_writer import numbers

__all__ = ["write_mjcf", "BOUND_MASS", "BOUND_INERTIA"]

BOUND_MASS, BOUND_INERTIA = 1e-9, 1e-12
"""The lower bounds [kg, kg m^2] the MJCF gives massless moving links (MuJoCo's compiler boundmass and boundinertia)."""


def _pose(element: ET.Element, H: np.ndarray) -> None:
    element.set("pos", numbers(H[:3, 3]))
    element.set("quat", numbers(matrix_to_quaternion_wxyz(H[:3, :3])))


def _mesh_asset(asset: ET.Element, shape: CollisionShape, name: str) -> None:
    """A mesh asset: its vertices inline where the description holds them (an MJCF's, which MuJoCo loaded), else its
    file as the description names it."""
    mesh = ET.SubElement(asset, "mesh", name=name)
    if shape.vertices is not None:
        mesh.set("vertex", numbers(np.asarray(shape.vertices, dtype=np.float64)))
    else:
        mesh.set("file", str(shape.filename))
    if shape.scale is not None:
        mesh.set("scale", numbers(shape.scale))


def _geom(body: ET.Element, shape: CollisionShape, owner: str, asset: ET.Element) -> None:
    geom = ET.SubElement(body, "geom")
    if shape.name:
        geom.set("name", shape.name)
    _pose(geom, np.asarray(shape.link_H_shape, dtype=np.float64))
    if shape.kind == "box":
        geom.set("type", "box")
        geom.set("size", numbers(0.5 * np.asarray(shape.size, dtype=np.float64)))
    elif shape.kind == "sphere":
        geom.set("type", "sphere")
        geom.set("size", numbers([shape.radius]))
    elif shape.kind == "ellipsoid":
        geom.set("type", "ellipsoid")
        geom.set("size", numbers(np.asarray(shape.size, dtype=np.float64)))
    elif shape.kind in ("cylinder", "capsule"):
        geom.set("type", shape.kind)
        geom.set("size", numbers([shape.radius, 0.5 * shape.length]))
    elif shape.kind == "mesh" and (shape.filename or shape.vertices is not None):
        name = f"{owner}_mesh{len(asset)}"
        _mesh_asset(asset, shape, name)
        geom.set("type", "mesh")
        geom.set("mesh", name)
    else:
        raise ValueError(f"link '{owner}' has a {shape.kind} collision with neither vertices nor a file: MJCF cannot hold it")
    geom.set("contype", str(shape.contype))
    geom.set("conaffinity", str(shape.conaffinity))
    geom.set("condim", str(shape.condim))
    geom.set("friction", numbers(shape.friction))
    if shape.margin or shape.gap:
        geom.set("margin", numbers([shape.margin]))
        geom.set("gap", numbers([shape.gap]))
    if shape.priority:
        geom.set("priority", str(shape.priority))


def write_mjcf(tree: KinematicTree, description: ModelDescription, parameters: dict, world_H_base: np.ndarray | None,
               time_step: float, gravity: np.ndarray, floor: np.ndarray | None, integrator: str = "Euler", disabled: frozenset = frozenset()) -> str:  # fmt: skip
    """The MJCF text of `tree` with its current parameters (the module docstring). parameters: host float64 arrays
    link_mass (nL,) [kg], link_com (nL, 3) [m, link frame], link_inertia (nL, 3, 3) [kg m^2, about the CoM, link
    axes], position_limits (nj, 2), friction_static, friction_viscous, armature, damping (nv,), stiffness,
    springref (nj,), joint_actuator_force_range (nj, 2), base_armature, base_damping, base_stiffness (1,), actuator_gear, actuator_gain (na, 3), actuator_bias (na, 3), actuator_ctrl_range (na, 2),
    actuator_force_range (na, 2) (infinite: unlimited); description: the model's (its links' collision shapes, each
    link a link of the tree or a frame, its static geoms, explicit pairs and excludes, the floating base's initial
    pose); world_H_base (4, 4) welds the base, None leaves it floating; time_step [s], gravity (3,) [m/s^2], MuJoCo's
    integrator name and disable flags go to `option`; floor: the pose (4, 4) of the terrain's plane (z up in it), None
    for none."""
    mujoco = ET.Element("mujoco", model=description.name)
    compiler = ET.SubElement(mujoco, "compiler", angle="radian", inertiafromgeom="false", autolimits="true")
    massless = [link_name for i, link_name in enumerate(tree.link_names) if i > 0 and float(parameters["link_mass"][i]) <= 0.0]
    if massless:  # MuJoCo refuses massless moving bodies (an MJCF body of several joints is several links here)
        compiler.set("boundmass", f"{BOUND_MASS:g}")
        compiler.set("boundinertia", f"{BOUND_INERTIA:g}")
        warnings.warn(f"export_updated_model: the massless moving links {massless} get MuJoCo's boundmass {BOUND_MASS:g} kg and boundinertia "
                      f"{BOUND_INERTIA:g} kg m^2 in the MJCF (MuJoCo refuses massless moving bodies)", NotModelledWarning, stacklevel=4)
    option = ET.SubElement(mujoco, "option", timestep=f"{time_step:.17g}", gravity=numbers(gravity), integrator=integrator)
    for flag in sorted(disabled):  # MuJoCo's disable flags (the description's; eulerdamp as the model's implicit damping)
        ET.SubElement(option, "flag", **{flag: "disable"})
    asset = ET.SubElement(mujoco, "asset")
    world = ET.SubElement(mujoco, "worldbody")
    bodies: dict[str, ET.Element] = {}
    v_start, kinds = np.asarray(tree.v_start), np.asarray(tree.joint_type)
    limits, friction_rows = {row.name: row for row in tree.limits}, {row.name: row for row in tree.friction_rows}
    for i, link_name in enumerate(tree.link_names):
        kind = int(kinds[i])
        if i == 0 and link_name == "world" and world_H_base is not None:  # an MJCF's world: its children are the worldbody's
            if np.any(np.asarray(world_H_base) != np.eye(4)):  # (its mass, scenery welded to it, moves nothing)
                raise ValueError("the base is called 'world' but is not MuJoCo's world (it is moved): MJCF reserves the name")
            bodies[link_name] = world
            continue
        if i == 0:
            body = ET.SubElement(world, "body", name=link_name)
            base = world_H_base if world_H_base is not None else description.initial_world_H_base
            _pose(body, np.eye(4) if base is None else np.asarray(base, dtype=np.float64))
            if world_H_base is None:  # the floating base's free joint with its armature, damper and spring
                ET.SubElement(body, "joint", name=f"{link_name}_free", type="free", armature=f"{float(parameters['base_armature'][0]):.17g}",
                              damping=f"{float(parameters['base_damping'][0]):.17g}", stiffness=f"{float(parameters['base_stiffness'][0]):.17g}")
        else:
            parent = bodies[tree.link_names[int(tree.parent[i])]]
            H = np.asarray(tree.parent_H_joint[i], dtype=np.float64)
            if kind == JOINT_FREE:  # MuJoCo's free joints measure the world pose: a top-level body's, at its initial pose
                if parent is not world or np.abs(H - np.eye(4)).max() > 1e-12:
                    raise ValueError(f"joint '{tree.joint_names[i - 1]}' is a free joint below another body or moved from the world's "
                                     "frame: MuJoCo's free joints are the world's bodies'")
                q0 = np.asarray(tree.qpos0, dtype=np.float64)[int(tree.q_start[i]) : int(tree.q_start[i]) + 7]
                H = homogeneous(quaternion_wxyz_to_matrix(q0[3:]), q0[:3])
            if kind not in (JOINT_BALL, JOINT_FREE) and tree.qpos0[int(tree.q_start[i])] != 0.0:  # MuJoCo's ref: the body at q = qpos0
                H = H @ joint_motion("revolute" if kind == JOINT_REVOLUTE else "prismatic", tree.joint_axis[i], tree.joint_pivot[i], tree.qpos0[int(tree.q_start[i])])
            body = ET.SubElement(parent, "body", name=link_name)
            _pose(body, H)
        bodies[link_name] = body
        mass = float(parameters["link_mass"][i])
        if mass > 0.0:
            I = parameters["link_inertia"][i]
            ET.SubElement(body, "inertial", pos=numbers(parameters["link_com"][i]), mass=f"{mass:.17g}",
                          fullinertia=numbers([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        if i == 0:
            continue
        j, d = i - 1, int(v_start[i])
        for name in ("friction_static", "armature", "damping", "friction_viscous"):  # MJCF gives a joint one value for its DoFs
            values = parameters[name][d : int(v_start[i + 1])]
            if np.ptp(values) > 0.0:
                raise ValueError(f"joint '{tree.joint_names[j]}' has {name} {values.tolist()} on its DoFs: MJCF gives a joint one value")
        joint = ET.SubElement(body, "joint", name=tree.joint_names[j], pos=numbers(tree.joint_pivot[i]))
        if kind in (JOINT_BALL, JOINT_FREE):
            joint.set("type", "ball" if kind == JOINT_BALL else "free")
            if kind == JOINT_FREE:
                del joint.attrib["pos"]
        else:
            joint.set("type", "hinge" if kind == JOINT_REVOLUTE else "slide")  # the one-DoF kinds: revolute, prismatic
            joint.set("axis", numbers(tree.joint_axis[i]))
            lower, upper = parameters["position_limits"][j]
            if np.isfinite(lower) or np.isfinite(upper):
                joint.set("range", numbers([lower, upper]))
            joint.set("springref", f"{float(parameters['springref'][j]):.17g}")
            q0 = float(tree.qpos0[int(tree.q_start[i])])
            if q0 != 0.0:
                joint.set("ref", f"{q0:.17g}")
        limit = limits.get(tree.joint_names[j])
        if limit is not None:  # MuJoCo's limit row's parameters (a URDF's: MuJoCo's defaults); a ball's range is its angle
            if kind == JOINT_BALL:
                joint.set("range", numbers([0.0, limit.angle]))
            joint.set("margin", f"{limit.margin:.17g}")
            joint.set("solreflimit", numbers(limit.solref))
            joint.set("solimplimit", numbers(limit.solimp))
        friction = friction_rows.get(tree.joint_names[j])
        if friction is not None:  # its friction row's (the frictionloss is friction_static's, below)
            joint.set("solreffriction", numbers(friction.solref))
            joint.set("solimpfriction", numbers(friction.solimp))
        joint.set("stiffness", f"{float(parameters['stiffness'][j]):.17g}")
        if kind != JOINT_FREE:  # (MuJoCo's free joints may have it; warpdyn's loader does not read it on them)
            joint.set("frictionloss", f"{float(parameters['friction_static'][d]):.17g}")
        joint.set("armature", f"{float(parameters['armature'][d]):.17g}")
        joint.set("damping", f"{float(parameters['damping'][d] + parameters['friction_viscous'][d]):.17g}")
        if np.all(np.isfinite(parameters["joint_actuator_force_range"][j])):
            joint.set("actuatorfrcrange", numbers(parameters["joint_actuator_force_range"][j]))
    for k, frame_name in enumerate(tree.frame_names):
        body = ET.SubElement(bodies[tree.link_names[int(tree.frame_parent[k])]], "body", name=frame_name)
        _pose(body, np.asarray(tree.link_H_frame[k], dtype=np.float64))
        bodies[frame_name] = body
    shapes = [(link.name, link.collisions) for link in description.links]
    lost = [link_name for link_name, own in shapes if own and link_name not in bodies]
    if lost:
        raise ValueError(f"links {lost} carry collision shapes but are neither links nor frames of the model")
    if floor is not None:
        plane = ET.SubElement(world, "geom", name="floor", type="plane", size="0 0 1")
        _pose(plane, floor)
    on_links = {shape.geom for _, own in shapes for shape in own if shape.geom >= 0}
    for shape in description.world_geoms:  # those of bodies welded to the world are their frames' already
        if shape.geom < 0 or shape.geom not in on_links:
            _geom(world, shape, "world", asset)
    for link_name, own in shapes:
        for shape in own:
            _geom(bodies[link_name], shape, link_name, asset)
    names = {shape.geom: shape.name for shape in (*description.world_geoms, *(s for _, own in shapes for s in own)) if shape.geom >= 0}
    explicit = [pair for pair in description.geom_pairs if pair.explicit]
    if explicit or description.excludes:
        contact = ET.SubElement(mujoco, "contact")
        for pair in explicit:
            ET.SubElement(contact, "pair", geom1=names[pair.geom1], geom2=names[pair.geom2], margin=f"{pair.margin:.17g}", gap=f"{pair.gap:.17g}",
                          friction=numbers(pair.friction), condim=str(pair.condim))
        for body1, body2 in description.excludes:  # a body welded to the world is written as the world's geoms
            ET.SubElement(contact, "exclude", body1=body1 if body1 in bodies else "world", body2=body2 if body2 in bodies else "world")
    if not len(asset):
        mujoco.remove(asset)
    if tree.actuators:
        actuators = ET.SubElement(mujoco, "actuator")
        for k, act in enumerate(tree.actuators):
            ctrl, force = parameters["actuator_ctrl_range"][k], parameters["actuator_force_range"][k]
            general = ET.SubElement(actuators, "general", name=act.name, joint=act.joint_name, gear=f"{float(parameters['actuator_gear'][k]):.17g}",
                                    gaintype="affine", gainprm=numbers(parameters["actuator_gain"][k]),
                                    biastype="affine", biasprm=numbers(parameters["actuator_bias"][k]))
            if np.all(np.isfinite(ctrl)):
                general.set("ctrlrange", numbers(ctrl))
            if np.all(np.isfinite(force)):
                general.set("forcerange", numbers(force))
    if tree.equalities:
        _equalities(mujoco, tree, description, bodies, world)
    ET.indent(mujoco)
    return ET.tostring(mujoco, encoding="unicode")


def _equalities(mujoco: ET.Element, tree: KinematicTree, description: ModelDescription, bodies: dict, world: ET.Element) -> None:
    """The tree's equality constraints as MJCF: a connect or weld between two sites at its anchors (and, for a weld, its
    frames), MuJoCo's site semantics, each site on the description's body where that body is written (a link or a
    lumped frame), else on its link's body (the world's for link -1); a joint coupling between its joints; a
    fixed-tendon coupling between fixed tendons of its terms; each with its solref and solimp. MuJoCo computes the
    invweights from the written bodies: a constraint on a link that holds lumped bodies with mass gets others than
    the description's (its regularisation with them), named in a NotModelledWarning. Names are the constraints'
    (a repeated one suffixed), the sites' and tendons' made from them."""
    equality = ET.SubElement(mujoco, "equality")
    tendons = None
    masses = {link.name: float(link.mass) for link in description.links}
    heavy = {int(tree.frame_parent[k]) for k, frame in enumerate(tree.frame_names) if masses.get(frame, 0.0) > 0.0}  # links with lumped mass
    reweighted, used = [], set()
    for e in tree.equalities:
        name = e.name if e.name not in used else next(f"{e.name}_{k}" for k in range(1, len(used) + 2) if f"{e.name}_{k}" not in used)
        used.add(name)
        common = dict(name=name, solref=numbers(e.solref), solimp=numbers(e.solimp))
        if e.kind in ("connect", "weld"):
            sites, d = [], description.equalities[e.source] if e.source >= 0 else None
            if {e.link1, e.link2} & heavy:
                reweighted.append(e.name)
            for side, (link, p, Q) in enumerate(((e.link1, e.p1, e.Q1), (e.link2, e.p2, e.Q2)), 1):
                body = getattr(d, f"body{side}", None)
                if body in bodies and link >= 0:  # the description's own body, its anchor and frame in that body
                    parent, p, Q = bodies[body], getattr(d, f"anchor{side}"), getattr(d, f"rot{side}")
                else:
                    parent = world if link < 0 else bodies[tree.link_names[link]]
                site = ET.SubElement(parent, "site", name=f"{name}_anchor{side}")
                _pose(site, homogeneous(quaternion_wxyz_to_matrix(np.asarray(Q, dtype=np.float64)), np.asarray(p, dtype=np.float64)))
                sites.append(site.get("name"))
            element = ET.SubElement(equality, e.kind, site1=sites[0], site2=sites[1], **common)
            if e.kind == "weld":
                element.set("torquescale", f"{float(e.torquescale):.17g}")
        elif e.kind == "joint":
            element = ET.SubElement(equality, "joint", joint1=tree.joint_names[e.terms1[0][0]], polycoef=numbers(e.polycoef), **common)
            if e.terms2:
                element.set("joint2", tree.joint_names[e.terms2[0][0]])
        else:  # fixed tendons of the coupling's terms
            tendons = tendons if tendons is not None else ET.SubElement(mujoco, "tendon")
            names = []
            for side, terms in enumerate((e.terms1, e.terms2), 1):
                if not terms:
                    continue
                fixed = ET.SubElement(tendons, "fixed", name=f"{name}_tendon{side}")
                for j, coef in terms:
                    ET.SubElement(fixed, "joint", joint=tree.joint_names[j], coef=f"{float(coef):.17g}")
                names.append(fixed.get("name"))
            element = ET.SubElement(equality, "tendon", tendon1=names[0], polycoef=numbers(e.polycoef), **common)
            if len(names) == 2:
                element.set("tendon2", names[1])
    if reweighted:
        warnings.warn(f"export_updated_model: the constraints {reweighted} are on links that hold lumped bodies with mass; MuJoCo computes their "
                      "invweights (their soft constraints' regularisation) from the written, lumped links, which differ from the description's",
                      NotModelledWarning, stacklevel=4)
