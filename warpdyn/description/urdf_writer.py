"""A lumped tree written as URDF (host NumPy): what `Model.export_updated_model` returns, JaxSim's export of a model
with its current parameters. Loading the text back gives the same model: the same links (each with its current
mass, centre of mass and inertia about it, in link axes), joints (origins, axes, limits, friction), collision
shapes and frames (massless links on fixed joints); a welded base hangs from a `world` link.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np

from .model import CollisionShape
from .tree import JOINT_PRISMATIC, JOINT_REVOLUTE, KinematicTree

__all__ = ["write_urdf", "rpy_of"]


def rpy_of(R: np.ndarray) -> np.ndarray:
    """URDF's roll, pitch, yaw [rad] of a rotation R = Rz(yaw) Ry(pitch) Rx(roll)."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:  # pitch = +-90 degrees: yaw absorbed into roll
        return np.array([math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0])
    return np.array([math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])])


def numbers(values) -> str:
    """Numbers as XML writes them: each to 17 significant digits (a float64 read back exactly), spaces between."""
    return " ".join(f"{float(v):.17g}" for v in np.ravel(values))


def _origin(parent: ET.Element, H: np.ndarray) -> None:
    rpy = rpy_of(H[:3, :3])
    ET.SubElement(parent, "origin", xyz=numbers(H[:3, 3]), rpy=numbers(rpy))


def _collision(link: ET.Element, shape: CollisionShape) -> None:
    collision = ET.SubElement(link, "collision")
    _origin(collision, shape.link_H_shape)
    geometry = ET.SubElement(collision, "geometry")
    if shape.kind == "box":
        ET.SubElement(geometry, "box", size=numbers(shape.size))
    elif shape.kind == "sphere":
        ET.SubElement(geometry, "sphere", radius=f"{shape.radius:.17g}")
    elif shape.kind == "cylinder":
        ET.SubElement(geometry, "cylinder", radius=f"{shape.radius:.17g}", length=f"{shape.length:.17g}")
    else:
        scale = np.ones(3) if shape.scale is None else shape.scale
        ET.SubElement(geometry, "mesh", filename=str(shape.filename), scale=numbers(scale))


def write_urdf(name: str, tree: KinematicTree, shapes: list, mass: np.ndarray, com: np.ndarray, inertia: np.ndarray,
               position_limits: np.ndarray, friction_static: np.ndarray, friction_viscous: np.ndarray, world_H_base: np.ndarray | None) -> str:
    """The URDF text of `tree` with the link parameters mass (nL,) [kg], com (nL, 3) [m, link frame], inertia
    (nL, 3, 3) [kg m^2, about the CoM, link axes] and the joint parameters position_limits (nj, 2), friction_static
    and friction_viscous (nj,); world_H_base (4, 4) welds the base to a `world` link, None leaves it floating.
    shapes: the description's (link name, its collision shapes in its own frame), in the description's order, each
    link a link of the tree or a frame (a lumped link): the links are written in that order, each with its own
    shapes, so that the collidable points come back in their order. A
    ValueError names what URDF cannot hold: a ball or free joint, a joint whose axis does not pass through the child
    link's origin (MJCF's joint `pos`), a capsule or a mesh without a file."""
    robot = ET.Element("robot", name=name)
    if world_H_base is not None:
        ET.SubElement(robot, "link", name="world")
        joint = ET.SubElement(robot, "joint", name="world_to_" + tree.link_names[0], type="fixed")
        ET.SubElement(joint, "parent", link="world")
        ET.SubElement(joint, "child", link=tree.link_names[0])
        _origin(joint, world_H_base)
    links = {link_name: i for i, link_name in enumerate(tree.link_names)}
    frames = set(tree.frame_names)
    written = [link_name for link_name, _ in shapes if link_name in links or link_name in frames]
    written += [link_name for link_name in (*tree.link_names, *tree.frame_names) if link_name not in set(written)]
    own = dict(shapes)
    for link_name in written:
        link = ET.SubElement(robot, "link", name=link_name)
        i = links.get(link_name)
        if i is not None:
            inertial = ET.SubElement(link, "inertial")
            _origin(inertial, np.block([[np.eye(3), com[i][:, None]], [np.zeros((1, 3)), np.ones((1, 1))]]))
            ET.SubElement(inertial, "mass", value=f"{mass[i]:.17g}")
            I = inertia[i]
            ET.SubElement(inertial, "inertia", ixx=f"{I[0, 0]:.17g}", ixy=f"{I[0, 1]:.17g}", ixz=f"{I[0, 2]:.17g}",
                          iyy=f"{I[1, 1]:.17g}", iyz=f"{I[1, 2]:.17g}", izz=f"{I[2, 2]:.17g}")
        for shape in own.get(link_name, ()):
            if shape.kind in ("capsule", "ellipsoid") or (shape.kind == "mesh" and not shape.filename):
                raise ValueError(f"link '{link_name}' has a collision URDF cannot hold ({shape.kind}: URDF has no capsule or ellipsoid, and a mesh needs a file)")
            _collision(link, shape)
    lost = [link_name for link_name, own_shapes in shapes if own_shapes and link_name not in links and link_name not in frames]
    if lost:
        raise ValueError(f"links {lost} carry collision shapes but are neither links nor frames of the model")
    for i in range(1, tree.number_of_links):
        j, kind, joint_name = i - 1, int(tree.joint_type[i]), tree.joint_names[i - 1]
        if kind not in (JOINT_REVOLUTE, JOINT_PRISMATIC):
            raise ValueError(f"joint '{joint_name}' is a ball or free joint: URDF has neither")
        if np.linalg.norm(np.cross(tree.joint_axis[i], np.cross(tree.joint_pivot[i], tree.joint_axis[i]))) > 1e-12:
            raise ValueError(f"joint '{joint_name}''s axis does not pass through link '{tree.link_names[i]}''s origin (an MJCF joint pos): URDF cannot say it")
        lower, upper = position_limits[j]
        unlimited = not (np.isfinite(lower) or np.isfinite(upper))
        type_name = "continuous" if kind == JOINT_REVOLUTE and unlimited else "revolute" if kind == JOINT_REVOLUTE else "prismatic"
        joint = ET.SubElement(robot, "joint", name=joint_name, type=type_name)
        ET.SubElement(joint, "parent", link=tree.link_names[int(tree.parent[i])])
        ET.SubElement(joint, "child", link=tree.link_names[i])
        _origin(joint, tree.parent_H_joint[i])
        ET.SubElement(joint, "axis", xyz=numbers(tree.joint_axis[i]))
        if not unlimited:
            ET.SubElement(joint, "limit", lower=f"{lower:.17g}", upper=f"{upper:.17g}", effort=f"{tree.effort_limits[j]:.17g}",
                          velocity=f"{tree.velocity_limits[j]:.17g}")
        ET.SubElement(joint, "dynamics", damping=f"{friction_viscous[j]:.17g}", friction=f"{friction_static[j]:.17g}")
    for k, frame_name in enumerate(tree.frame_names):
        joint = ET.SubElement(robot, "joint", name=f"{frame_name}_fixed_joint", type="fixed")
        ET.SubElement(joint, "parent", link=tree.link_names[int(tree.frame_parent[k])])
        ET.SubElement(joint, "child", link=frame_name)
        _origin(joint, tree.link_H_frame[k])
    ET.indent(robot)
    return ET.tostring(robot, encoding="unicode")
