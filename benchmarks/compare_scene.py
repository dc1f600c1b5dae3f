"""The scene of benchmarks/compare.py, described for each library from the one URDF warpdyn ships.

- `strip_urdf`: the ergoCub URDF without visuals, mesh collisions, <gazebo> and <transmission>; the four
  foot boxes are its only collision shapes (each library makes its contacts from them); joints outside
  the kept set become fixed (locked at 0, so MuJoCo and JaxSim lump their links as warpdyn does).
- `mujoco_spec`: an MjSpec of the legs built by MuJoCo's own URDF compiler from that text, with a free
  joint, the boxes as colliding box geoms (robot-robot pairs filtered out), a ground plane, 1 ms, Euler.
- `urdf_to_sdf`: the same text as SDF. JaxSim 0.9 (through rod 0.5) converts a URDF by calling Gazebo's
  `gz sdf` executable, which neither this machine nor the GPU machine has; an SDF string is parsed by rod
  in Python. Links are posed in the model frame at the zero configuration and every joint frame is its
  child link's frame, as in URDF, so JaxSim builds the same tree.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np


def strip_urdf(text: str, keep_joints=None) -> str:
    """The URDF with boxes as the only collision shapes; movable joints outside keep_joints made fixed."""
    root = ET.fromstring(text)
    for link in root.findall("link"):
        for visual in link.findall("visual"):
            link.remove(visual)
        for collision in link.findall("collision"):
            if collision.find("geometry/box") is None:
                link.remove(collision)
    if keep_joints is not None:
        keep = set(keep_joints)
        for joint in root.findall("joint"):
            if joint.get("type") not in ("fixed", "floating") and joint.get("name") not in keep:
                joint.set("type", "fixed")
    for element in root.findall("gazebo") + root.findall("transmission") + root.findall("material"):
        root.remove(element)
    return ET.tostring(root, encoding="unicode")


def count_boxes(text: str) -> int:
    return len(ET.fromstring(text).findall("link/collision/geometry/box"))


# ---------------------------------------------------------------------------------------------- MuJoCo


def mujoco_spec(urdf_text: str, *, time_step: float, mu: float):
    """MjSpec of the stripped URDF (fixed joints fused), floating base, boxes against a plane at z = 0."""
    import mujoco

    spec = mujoco.MjSpec.from_string(urdf_text)
    spec.compiler.fusestatic = True  # links on fixed joints merge into their parents, as in warpdyn
    spec.worldbody.first_body().add_freejoint()
    spec.option.timestep = time_step
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    friction = [mu, 0.005, 0.0001]  # MuJoCo's defaults for torsional and rolling friction (condim 3 uses mu only)
    for geom in spec.geoms:  # the URDF's collisions: the foot boxes
        # contype 1 & conaffinity 0: a box touches whatever has conaffinity 1 (the plane), never another box
        geom.contype, geom.conaffinity, geom.friction = 1, 0, friction
    spec.worldbody.add_geom(
        name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], contype=0, conaffinity=1, friction=friction
    )
    return spec


def mujoco_lowest_corner(mjm) -> float:
    """The lowest z of any box corner at the model's reference pose (qpos0, base at the origin)."""
    import mujoco

    mjd = mujoco.MjData(mjm)
    mujoco.mj_kinematics(mjm, mjd)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    lowest = np.inf
    for g in range(mjm.ngeom):
        if mjm.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
            corners = mjd.geom_xpos[g] + (signs * mjm.geom_size[g]) @ mjd.geom_xmat[g].reshape(3, 3).T
            lowest = min(lowest, float(corners[:, 2].min()))
    return lowest


# ------------------------------------------------------------------------------------------------- SDF


def _rotation(rpy) -> np.ndarray:
    """URDF's and SDF's roll-pitch-yaw: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _rpy(R: np.ndarray) -> np.ndarray:
    """The inverse of _rotation (pitch in [-pi/2, pi/2])."""
    pitch = np.arctan2(-R[2, 0], np.hypot(R[0, 0], R[1, 0]))
    if np.hypot(R[0, 0], R[1, 0]) < 1e-9:  # gimbal lock: put everything in yaw
        return np.array([0.0, pitch, np.arctan2(-R[0, 1], R[1, 1])])
    return np.array([np.arctan2(R[2, 1], R[2, 2]), pitch, np.arctan2(R[1, 0], R[0, 0])])


def _origin(element) -> np.ndarray:
    """4x4 transform of an element's <origin> (identity when absent)."""
    T = np.eye(4)
    origin = None if element is None else element.find("origin")
    if origin is not None:
        T[:3, :3] = _rotation([float(v) for v in origin.get("rpy", "0 0 0").split()])
        T[:3, 3] = [float(v) for v in origin.get("xyz", "0 0 0").split()]
    return T


def _pose(T: np.ndarray) -> str:
    return " ".join(f"{v:.17g}" for v in (*T[:3, 3], *_rpy(T[:3, :3])))


def link_poses(root) -> dict:
    """{link: 4x4 pose in the base link's frame} of a parsed URDF at the zero joint configuration."""
    joints = root.findall("joint")
    children = {j.find("child").get("link") for j in joints}
    base = next(link.get("name") for link in root.findall("link") if link.get("name") not in children)
    pose = {base: np.eye(4)}
    pending = list(joints)
    while pending:
        ready = [j for j in pending if j.find("parent").get("link") in pose]
        if not ready:
            raise ValueError("the URDF's joints do not form a tree rooted at " + base)
        for joint in ready:
            pose[joint.find("child").get("link")] = pose[joint.find("parent").get("link")] @ _origin(joint)
            pending.remove(joint)
    return pose


def lowest_box_corner(urdf_text: str) -> float:
    """The lowest z of any collision box corner at the zero configuration, base at the origin (NumPy only)."""
    root = ET.fromstring(urdf_text)
    pose = link_poses(root)
    signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=float)
    lowest = np.inf
    for link in root.findall("link"):
        for collision in link.findall("collision"):
            box = collision.find("geometry/box")
            if box is not None:
                T = pose[link.get("name")] @ _origin(collision)
                corners = T[:3, 3] + (signs * 0.5 * np.array([float(v) for v in box.get("size").split()])) @ T[:3, :3].T
                lowest = min(lowest, float(corners[:, 2].min()))
    return lowest


def urdf_to_sdf(urdf_text: str) -> str:
    """SDF 1.7 text of a URDF tree (links, inertials, box/sphere/cylinder collisions, joints, limits, dynamics)."""
    root = ET.fromstring(urdf_text)
    links = {link.get("name"): link for link in root.findall("link")}
    joints = root.findall("joint")
    children = {j.find("child").get("link") for j in joints}
    parents = {j.find("parent").get("link") for j in joints}
    base = next(name for name in links if name not in children)
    pose = link_poses(root)  # link frames in the model frame at the zero configuration
    # links without <inertial> (sensor frames, soles) are leaves on fixed joints: plain frames, left out,
    # since rod wants an inertial in every link (Gazebo's converter lumps them away as well)
    frames = {n for n, link in links.items() if link.find("inertial") is None and not link.findall("collision")}
    if frames & parents:
        raise ValueError(f"links without inertial that have children: {sorted(frames & parents)}")
    links = {base: links[base]} | {n: link for n, link in links.items() if n not in frames}  # the base first: SDF's canonical link
    joints = [j for j in joints if j.find("child").get("link") not in frames]

    out = [f'<sdf version="1.7"><model name="{root.get("name")}">']
    for name, link in links.items():
        out.append(f'<link name="{name}"><pose>{_pose(pose[name])}</pose>')
        inertial = link.find("inertial")
        if inertial is not None:
            inertia = inertial.find("inertia")
            terms = "".join(f"<{k}>{float(inertia.get(k, 0.0)):.17g}</{k}>" for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
            out.append(
                f"<inertial><pose>{_pose(_origin(inertial))}</pose><mass>{float(inertial.find('mass').get('value')):.17g}</mass>"
                f"<inertia>{terms}</inertia></inertial>"
            )
        for i, collision in enumerate(link.findall("collision")):
            shape = collision.find("geometry")[0]
            if shape.tag == "box":
                geometry = f"<box><size>{shape.get('size')}</size></box>"
            elif shape.tag == "sphere":
                geometry = f"<sphere><radius>{shape.get('radius')}</radius></sphere>"
            elif shape.tag == "cylinder":
                geometry = f"<cylinder><radius>{shape.get('radius')}</radius><length>{shape.get('length')}</length></cylinder>"
            else:
                continue
            out.append(f'<collision name="{name}_collision_{i}"><pose>{_pose(_origin(collision))}</pose><geometry>{geometry}</geometry></collision>')
        out.append("</link>")
    kinds = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed"}
    for joint in joints:
        kind = joint.get("type")
        if kind not in kinds:
            raise ValueError(f"joint {joint.get('name')}: type {kind!r} has no SDF counterpart here")
        text = [f'<joint name="{joint.get("name")}" type="{kinds[kind]}">']
        text.append(f"<parent>{joint.find('parent').get('link')}</parent><child>{joint.find('child').get('link')}</child>")
        if kind != "fixed":  # the joint frame is the child's frame (SDF's default): the axis is in it, as in URDF
            axis = joint.find("axis")
            text.append(f"<axis><xyz>{'1 0 0' if axis is None else axis.get('xyz')}</xyz>")
            limit = joint.find("limit")
            if limit is not None and kind != "continuous":
                text.append(
                    f"<limit><lower>{limit.get('lower', '0')}</lower><upper>{limit.get('upper', '0')}</upper>"
                    f"<effort>{limit.get('effort', '-1')}</effort><velocity>{limit.get('velocity', '-1')}</velocity></limit>"
                )
            dynamics = joint.find("dynamics")
            if dynamics is not None:
                text.append(  # rod requires the spring terms (none here)
                    "<dynamics><spring_reference>0</spring_reference><spring_stiffness>0</spring_stiffness>"
                    f"<damping>{dynamics.get('damping', '0')}</damping><friction>{dynamics.get('friction', '0')}</friction></dynamics>"
                )
            text.append("</axis>")
        else:  # JaxSim hashes every joint's axis, fixed ones included (it lumps them away)
            text.append("<axis><xyz>0 0 1</xyz></axis>")
        text.append("</joint>")
        out.append("".join(text))
    out.append("</model></sdf>")
    return "\n".join(out)
