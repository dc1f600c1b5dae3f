"""MJCF, compiled by MuJoCo and read from its MjModel into a `ModelDescription` (see
warpdyn.description.model for the conventions)."""

from __future__ import annotations

import pathlib
import xml.etree.ElementTree as ET

import numpy as np

from .model import (
    CollisionShape,
    JointDescription,
    LinkDescription,
    ModelDescription,
    finish_tree,
    homogeneous,
    joint_motion,
    quaternion_wxyz_to_matrix,
)

__all__ = ["load_mjcf"]


def load_mjcf(root: ET.Element, path: str | None, where: str) -> ModelDescription:
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
        origin = homogeneous(quaternion_wxyz_to_matrix(m.body_quat[b]), m.body_pos[b])
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
    return finish_tree(name, [world_link, *links], joints, "mjcf", where)


def _mjcf_collisions(m, b: int, link: LinkDescription, mujoco) -> None:
    for g in range(int(m.body_geomadr[b]), int(m.body_geomadr[b]) + int(m.body_geomnum[b])):
        if m.geom_contype[g] == 0 and m.geom_conaffinity[g] == 0:
            continue
        H = homogeneous(quaternion_wxyz_to_matrix(m.geom_quat[g]), m.geom_pos[g])
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


