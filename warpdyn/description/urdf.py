"""URDF, read with yourdfpy into a `ModelDescription` (see warpdyn.description.model for the conventions).

URDF carries no armature, MuJoCo damper, spring, gravity compensation, actuators or options: those fields
keep their defaults (0, (-inf, inf), False; no actuators; gravity, time_step and integrator None).
`<dynamics damping>` is the viscous friction `damping`, `<dynamics friction>` the static `friction`.
"""

from __future__ import annotations

import io

import numpy as np

from .model import MOVABLE_JOINT_TYPES, CollisionShape, JointDescription, LinkDescription, ModelDescription, finish_tree

__all__ = ["load_urdf"]

MIMIC = "mimic joints (kept as independent joints: their <mimic> coupling is ignored)"


def _ignore_mesh_uri(fname, dir=None):
    """Meshes are not needed for dynamics: yourdfpy gets back the URI unchanged."""
    return fname


def load_urdf(document: bytes, where: str) -> ModelDescription:
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
            description.inertial_rotation = np.asarray(origin[:3, :3], dtype=np.float64)
        for visual in link.visuals:
            shape = _urdf_collision_shape(visual)
            if shape is not None:
                description.visuals.append(shape)
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
    description = finish_tree(robot.name, links, joints, "urdf", where)
    if mimic:
        description.not_modelled[MIMIC] = mimic
    return description


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


