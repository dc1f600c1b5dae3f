"""SDFormat input against URDF twins: the shipped ergoCub (Gazebo's conversion of the URDF warpdyn ships) and
small robots of tests/robots.py written out as SDF by `urdf_to_sdf` below, in every pose style the versions
allow (URDF-like `relative_to` chains, model-frame poses with the axis in the joint frame or the model frame,
SDFormat 1.4's model-frame axes, degrees, quaternions). Also the collision shapes' collidable points, the
NotModelledWarning of the ergoCub, and the base options (fixed_base, the model's pose as Data.build's default).

Reference: the same robot read from its URDF by warpdyn's URDF reader (yourdfpy), which the rest of the suite
checks against MuJoCo (tests/test_model.py, test_dynamics.py). Tolerance: 1e-12 relative to max(1, |value|)
in float64: the two files hold the same numbers (the ergoCub's SDF prints 16 significant digits where the
URDF prints 17, a relative difference of 1e-16), composed in different orders (model-frame poses, rpy and
quaternions round-tripped), which leaves errors of a few 1e-16 per transform, 1e-14 after the deepest
chains; 1e-12 is far below any modelling difference (a wrong axis or frame is an O(1) error).

Frame rules one by one, includes, worlds and refusals: tests/test_sdf_frames.py.
"""

from __future__ import annotations

import functools
import math
import warnings
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import assert_close, rng_for
from warpdyn.description import NotModelledWarning

F64 = np.float64


# ------------------------------------------------------------------------------------ URDF -> SDF


def _urdf_origin(element) -> np.ndarray:
    origin = element.find("origin") if element is not None else None
    xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()]
    rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()]
    H = np.eye(4)
    H[:3, :3] = _rpy(*rpy)
    H[:3, 3] = xyz
    return H


def _rpy(r, p, y) -> np.ndarray:
    """R = Rz(y) Ry(p) Rx(r): URDF's and SDFormat's roll-pitch-yaw."""
    Rx = np.array([[1, 0, 0], [0, math.cos(r), -math.sin(r)], [0, math.sin(r), math.cos(r)]])
    Ry = np.array([[math.cos(p), 0, math.sin(p)], [0, 1, 0], [-math.sin(p), 0, math.cos(p)]])
    Rz = np.array([[math.cos(y), -math.sin(y), 0], [math.sin(y), math.cos(y), 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


def _matrix_rpy(R) -> tuple[float, float, float]:
    return math.atan2(R[2, 1], R[2, 2]), math.asin(max(-1.0, min(1.0, -R[2, 0]))), math.atan2(R[1, 0], R[0, 0])


def _matrix_xyzw(R) -> np.ndarray:
    w = math.sqrt(max(0.0, 1.0 + R[0, 0] + R[1, 1] + R[2, 2])) / 2
    x = math.copysign(math.sqrt(max(0.0, 1.0 + R[0, 0] - R[1, 1] - R[2, 2])) / 2, R[2, 1] - R[1, 2])
    y = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] + R[1, 1] - R[2, 2])) / 2, R[0, 2] - R[2, 0])
    z = math.copysign(math.sqrt(max(0.0, 1.0 - R[0, 0] - R[1, 1] + R[2, 2])) / 2, R[1, 0] - R[0, 1])
    return np.array([x, y, z, w])


def _g(values) -> str:
    return " ".join(f"{float(v):.17g}" for v in values)


def _pose(H, rotation: str, relative_to: str | None = None) -> str:
    """<pose> of H: rotation "rpy", "degrees" or "quat"."""
    attributes = f' relative_to="{relative_to}"' if relative_to else ""
    if rotation == "quat":
        return f'<pose{attributes} rotation_format="quat_xyzw">{_g(H[:3, 3])} {_g(_matrix_xyzw(H[:3, :3]))}</pose>'
    angles = np.array(_matrix_rpy(H[:3, :3]))
    if rotation == "degrees":
        return f'<pose{attributes} degrees="true">{_g(H[:3, 3])} {_g(np.degrees(angles))}</pose>'
    return f"<pose{attributes}>{_g(H[:3, 3])} {_g(angles)}</pose>"


def urdf_to_sdf(urdf: str, version: str = "1.9", style: str = "urdf", axis: str = "joint", rotation: str = "rpy") -> str:
    """The URDF's robot as an SDF document.

    style "urdf" (1.7+): each link relative_to its parent joint, each joint relative_to its parent link (the
    poses of Gazebo's converter). style "model": every link's pose in the model frame (composed from the
    URDF's origins at q = 0), joints at their child link's origin (the default pose), as SDFormat <= 1.6 had
    to write them. axis "joint": the URDF's axis, in the joint frame; "model": the axis rotated into the model
    frame, flagged as 1.4 (implicitly), 1.5/1.6 (use_parent_model_frame) or 1.7+ (expressed_in="__model__")
    require. A root welded to a `world` link becomes the model's <pose> and a fixed joint from `world`.
    """
    root = ET.fromstring(urdf)
    joints = root.findall("joint")
    child_joint = {j.find("child").get("link"): j for j in joints}
    model_H = {}

    def placed(link):  # model_H_link at q = 0
        if link not in model_H:
            joint = child_joint.get(link)
            parent = joint.find("parent").get("link") if joint is not None else None
            model_H[link] = np.eye(4) if joint is None or parent == "world" else placed(parent) @ _urdf_origin(joint)
        return model_H[link]

    parts = [f'<sdf version="{version}"><model name="{root.get("name")}">']
    for joint in joints:
        if joint.find("parent").get("link") == "world":
            parts.append(_pose(_urdf_origin(joint), rotation))  # the model's pose: where the world weld puts the root
    for link in root.findall("link"):
        name = link.get("name")
        if name == "world":
            continue
        joint = child_joint.get(name)
        if joint is not None and joint.find("parent").get("link") != "world":
            parts.append(f'<link name="{name}">')
            parts.append(f'<pose relative_to="{joint.get("name")}"/>' if style == "urdf" else _pose(placed(name), rotation))
        else:
            parts.append(f'<link name="{name}">')
        inertial = link.find("inertial")
        if inertial is None:
            parts.append("<inertial><mass>0</mass><inertia>" + "".join(f"<{k}>0</{k}>" for k in ("ixx", "iyy", "izz")) + "</inertia></inertial>")
        else:
            i = inertial.find("inertia").attrib
            parts.append(
                f"<inertial>{_pose(_urdf_origin(inertial), rotation)}<mass>{inertial.find('mass').get('value')}</mass><inertia>"
                + "".join(f"<{k}>{i[k]}</{k}>" for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"))
                + "</inertia></inertial>"
            )
        for k, collision in enumerate(link.findall("collision")):
            geometry = collision.find("geometry")[0]
            size = {"box": f"<size>{geometry.get('size')}</size>", "sphere": f"<radius>{geometry.get('radius')}</radius>",
                    "cylinder": f"<radius>{geometry.get('radius')}</radius><length>{geometry.get('length')}</length>"}[geometry.tag]
            parts.append(f'<collision name="c{k}">{_pose(_urdf_origin(collision), rotation)}<geometry><{geometry.tag}>{size}'
                         f"</{geometry.tag}></geometry></collision>")
        parts.append("</link>")
    for joint in joints:
        kind, parent, child = joint.get("type"), joint.find("parent").get("link"), joint.find("child").get("link")
        parts.append(f'<joint name="{joint.get("name")}" type="{kind}"><parent>{parent}</parent><child>{child}</child>')
        if style == "urdf" and parent != "world":
            parts.append(_pose(_urdf_origin(joint), rotation, relative_to=parent))
        if kind != "fixed":
            xyz = np.array([float(v) for v in joint.find("axis").get("xyz").split()])
            legacy = tuple(int(v) for v in version.split(".")) < (1, 7)
            if axis == "model":
                xyz = placed(child)[:3, :3] @ xyz
            flag = ' expressed_in="__model__"' if axis == "model" and not legacy else ""
            parts.append(f"<axis><xyz{flag}>{_g(xyz)}</xyz>")
            if axis == "model" and version in ("1.5", "1.6"):
                parts.append("<use_parent_model_frame>true</use_parent_model_frame>")
            limit = joint.find("limit")
            if limit is not None and kind != "continuous":
                parts.append(f"<limit><lower>{limit.get('lower')}</lower><upper>{limit.get('upper')}</upper>"
                             f"<effort>{limit.get('effort')}</effort><velocity>{limit.get('velocity')}</velocity></limit>")
            dynamics = joint.find("dynamics")
            if dynamics is not None:
                parts.append(f"<dynamics><damping>{dynamics.get('damping', 0)}</damping><friction>{dynamics.get('friction', 0)}"
                             "</friction></dynamics>")
            parts.append("</axis>")
        parts.append("</joint>")
    parts.append("</model></sdf>")
    return "\n".join(parts)


# ------------------------------------------------------------------------------------ comparison


def build(source, **kwargs) -> wd.model.Model:
    """A float64 model, its NotModelledWarning (if any) swallowed."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotModelledWarning)
        return wd.model.Model.build_from_model_description(source, dtype=F64, **kwargs)


def assert_same_robot(sdf, urdf, rng, *, frames_subset=False, num_envs=3, tol=1e-12):
    """The same names (joints, links; frames, or a subset of the URDF's), constants, limit and friction rows, M, h, ABA, link and frame
    poses at random states, joints mapped by name."""
    assert sorted(sdf.link_names()) == sorted(urdf.link_names())
    assert sorted(sdf.joint_names()) == sorted(urdf.joint_names())
    assert sdf.floating_base() == urdf.floating_base() and sdf.base_link() == urdf.base_link()
    if frames_subset:
        assert set(sdf.frame_names()) <= set(urdf.frame_names())
    else:
        assert sorted(sdf.frame_names()) == sorted(urdf.frame_names())
    links = np.array([urdf.link_names().index(n) for n in sdf.link_names()])
    joints = np.array([urdf.joint_names().index(n) for n in sdf.joint_names()])
    ts, tu = sdf.tree, urdf.tree
    assert_close(sdf.description.world_H_base, urdf.description.world_H_base, tol, "world_H_base")
    for name in ("position_limits", "effort_limits", "velocity_limits", "damping", "friction", "stiffness"):
        np.testing.assert_allclose(getattr(ts, name), getattr(tu, name)[joints], rtol=tol, atol=tol, err_msg=name)
    for rows in ("limits", "friction_rows"):  # MuJoCo's limit and friction rows, their invweights the trees' M^-1 diagonals
        in_sdf, in_urdf = ({row.name: row for row in getattr(t, rows)} for t in (ts, tu))
        assert sorted(in_sdf) == sorted(in_urdf), rows
        for name, row in in_sdf.items():
            np.testing.assert_allclose(row.invweight, in_urdf[name].invweight, rtol=tol, atol=0, err_msg=f"{rows}: {name}")
    kw = robots.random_state_kwargs(urdf, rng, num_envs=num_envs)
    data_u = wd.data.Data.build(urdf, num_envs=num_envs, **kw)
    data_s = wd.data.Data.build(sdf, num_envs=num_envs, **{**kw, "joint_positions": kw["joint_positions"][:, joints],
                                        "joint_velocities": kw["joint_velocities"][:, joints]})
    M_u = wd.model.free_floating_mass_matrix(urdf, data_u).numpy()
    base = M_u.shape[-1] - urdf.dofs()
    dofs = np.concatenate([np.arange(base), base + joints])
    assert_close(wd.model.free_floating_mass_matrix(sdf, data_s).numpy(), M_u[:, dofs][:, :, dofs], tol, "M")
    h_u = wd.model.free_floating_bias_forces(urdf, data_u).numpy()
    assert_close(wd.model.free_floating_bias_forces(sdf, data_s).numpy(), h_u[:, dofs], tol, "h")
    (a_s, s_s), (a_u, s_u) = wd.model.forward_dynamics_aba(sdf, data_s), wd.model.forward_dynamics_aba(urdf, data_u)
    assert_close(a_s.numpy(), a_u.numpy(), tol, "ABA base acceleration")
    assert_close(s_s.numpy(), s_u.numpy()[:, joints], tol, "ABA joint accelerations")
    H_u = wd.model.forward_kinematics(urdf, data_u).numpy()
    assert_close(wd.model.forward_kinematics(sdf, data_s).numpy(), H_u[:, links], tol, "link poses")
    nL_s, nL_u = sdf.number_of_links(), urdf.number_of_links()
    for k, name in enumerate(sdf.frame_names()):
        expected = wd.frame.transform(urdf, data_u, frame_index=nL_u + urdf.frame_names().index(name)).numpy()
        assert_close(wd.frame.transform(sdf, data_s, frame_index=nL_s + k).numpy(), expected, tol, f"frame '{name}'")


# ------------------------------------------------------------------------------------ the ergoCub

ERGOCUB_SDF_FRAMES = ("l_foot_front", "l_foot_rear", "l_hip_3", "l_shoulder_3", "r_foot_front", "r_foot_rear", "r_hip_3",
                      "r_shoulder_3")  # fmt: skip  # sorted by name, as JaxSim (warpdyn/description/tree.py)


@functools.cache
def ergocub(kind: str, legs: bool) -> wd.model.Model:
    path = wd.assets.ergocub_sdf() if kind == "sdf" else wd.assets.ergocub_urdf()
    return build(path, considered_joints=list(wd.assets.ERGOCUB_LEG_JOINTS) if legs else None)


@pytest.mark.parametrize("legs", [False, True], ids=["full", "legs"])
def test_ergocub_sdf_equals_urdf(legs):
    """The shipped SDF ergoCub is the URDF ergoCub: names, limits and friction, M, h, ABA, link and frame poses at
    3 random floating-base states (float64, 1e-12: the module docstring says why). Gazebo's converter kept the 8
    force-torque sensors' fixed joints (their child links become the SDF model's only frames, all frames of the
    URDF model) and lumped the URDF's other fixed links away without writing <frame>s: 138 URDF frames (skin,
    soles, IMUs, cameras) have no SDF counterpart."""
    sdf, urdf = ergocub("sdf", legs), ergocub("urdf", legs)
    if not legs:
        assert sdf.frame_names() == ERGOCUB_SDF_FRAMES and urdf.number_of_frames() == 146
    assert set(ERGOCUB_SDF_FRAMES) <= set(sdf.frame_names())  # legs: the locked links' frames besides
    assert_same_robot(sdf, urdf, rng_for("ergocub sdf", legs), frames_subset=True)
    if legs:
        assert sdf.joint_names() == urdf.joint_names()


def test_ergocub_sdf_collidable_points_and_placement():
    """The SDF's 4 foot boxes give the URDF's 32 collidable points (exactly the same numbers, 1e-15: one rpy
    conversion each), each file's in its own order (JaxSim's: the description's order of the shapes; Gazebo's
    converter orders the links otherwise), its 62 meshes are meshes (model:// URIs, scale 1e-3), and Data.build
    puts the floating base at the model's <pose> 0 0 0.8 (the URDF's at the origin)."""
    sdf, urdf = ergocub("sdf", False), ergocub("urdf", False)
    ps, pu = sdf.kin_dyn_parameters.contact_parameters, urdf.kin_dyn_parameters.contact_parameters

    def rows(params):  # (link, point) sorted: the same set of points
        table = np.column_stack([np.asarray(params.body, dtype=np.float64), params.point])
        return table[np.lexsort(table.T[::-1])]

    np.testing.assert_allclose(rows(ps), rows(pu), atol=1e-15)
    meshes = [s for shapes in sdf.tree.collisions for s in shapes if s.kind == "mesh"]
    assert len(meshes) == 62 and all(s.filename.startswith("model://ergoCub/meshes/") for s in meshes)
    np.testing.assert_array_equal(meshes[0].scale, [1e-3, 1e-3, 1e-3])
    data = wd.data.Data.build(sdf)
    np.testing.assert_array_equal(data.base_position.numpy(), [0.0, 0.0, 0.8])
    np.testing.assert_array_equal(data.base_quaternion.numpy(), [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(wd.data.Data.build(urdf).base_position.numpy(), [0.0, 0.0, 0.0])


def test_ergocub_sdf_warns_once_naming_what_it_does_not_model():
    """One NotModelledWarning at load, naming the 18 sensors, the 10 Gazebo plugins, the 40 joints with ODE settings
    and the 7 collisions with contact surfaces (reference: the file, counted with ElementTree)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        description = wd.description.load(wd.assets.ergocub_sdf())
    warned = [w for w in caught if issubclass(w.category, NotModelledWarning)]
    assert len(warned) == 1 and warned[0].filename == __file__
    root = ET.parse(wd.assets.ergocub_sdf()).getroot()
    counts = {kind: len(names) for kind, names in description.not_modelled.items()}
    assert list(counts.values()) == [
        len(root.findall(".//sensor")), len(root.findall("model/plugin")), len(root.findall(".//joint/physics")),
        len([c for c in root.iter("collision") if c.find("surface") is not None or c.find("max_contacts") is not None]),
    ]  # fmt: skip
    assert counts[next(iter(counts))] == 18 and "l_leg_ft_sensor/l_leg_ft" in description.not_modelled[next(iter(counts))]
    message = str(warned[0].message)
    for name in ("head/lasersensor_head", "ergoCub/controlboard_torso", "l_foot_front/l_foot_front_collision", "'l_knee'"):
        assert name in message


# ------------------------------------------------------------------------------------ small robots

TWINS = [
    # (case, version, style, axis, rotation)
    ("pendulum-4", "1.9", "urdf", "joint", "rpy"),
    ("random-3", "1.9", "urdf", "joint", "quat"),
    ("random-15", "1.10", "urdf", "joint", "degrees"),
    ("randomfixed-101", "1.7", "model", "model", "rpy"),
    ("random-0", "1.7", "model", "joint", "quat"),
    ("random-4", "1.6", "model", "model", "rpy"),
    ("randomfixed-100", "1.5", "model", "joint", "rpy"),
    ("random-5", "1.4", "model", "model", "rpy"),
]


@pytest.mark.parametrize("case,version,style,axis,rotation", TWINS, ids=["-".join(t) for t in TWINS])
def test_twin_of_a_urdf(case, version, style, axis, rotation):
    """tests/robots.py's robot written as SDF (urdf_to_sdf) is the URDF's robot: names, constants, M, h, ABA, link
    and frame poses at 3 random states, float64, 1e-12 (the module docstring says why). SDFormat 1.4 writes the
    axis in the model frame (no flag), 1.5/1.6 with use_parent_model_frame, 1.7+ with expressed_in."""
    urdf_text = robots.text_of(case)
    sdf_text = urdf_to_sdf(urdf_text, version, style, axis, rotation)
    assert_same_robot(build(sdf_text), build(urdf_text), rng_for("twin", case, version, style))


def test_collision_shapes_give_the_urdf_points():
    """Boxes, spheres and cylinders at rotated origins on two links give the URDF twin's collidable points
    (bodies equal, points to 1e-14: an rpy round trip per shape); an SDF capsule gives
    collidable.capsule_points placed at its pose, an SDF ellipsoid collidable.ellipsoid_points (their reference: the
    shapes' definitions, 1e-15)."""
    urdf = """<robot name="shapes"><link name="a"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0"
      ixz="0" iyz="0"/></inertial>
      <collision><origin xyz="0.1 0 0.2" rpy="0.3 0 0.5"/><geometry><box size="0.1 0.2 0.3"/></geometry></collision>
      <collision><origin xyz="0 0.3 0"/><geometry><sphere radius="0.05"/></geometry></collision></link>
      <link name="b"><inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial>
      <collision><origin xyz="0 0 -0.2" rpy="1.5707963267948966 0 0"/><geometry><cylinder radius="0.04" length="0.3"/>
      </geometry></collision></link>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 1" rpy="0 0.2 0"/>
      <axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"""
    sdf, reference = build(urdf_to_sdf(urdf)), build(urdf)
    ps, pu = sdf.kin_dyn_parameters.contact_parameters, reference.kin_dyn_parameters.contact_parameters
    np.testing.assert_array_equal(ps.body, pu.body)
    np.testing.assert_allclose(ps.point, pu.point, atol=1e-14)
    capsule = build("""<sdf version="1.9"><model name="c"><link name="l"><collision name="k"><pose>0 0 0.5 0 0 0</pose>
      <geometry><capsule><radius>0.1</radius><length>0.4</length></capsule></geometry></collision></link></model></sdf>""")
    options = wd.contact.CollidablePointsOptions()
    expected = wd.description.collidable.capsule_points(0.1, 0.4, options.circle_points, options.capsule_cap_rings) + [0, 0, 0.5]
    np.testing.assert_allclose(capsule.kin_dyn_parameters.contact_parameters.point, expected, atol=1e-15)
    egg = build("""<sdf version="1.9"><model name="e"><link name="l"><collision name="k"><pose>0 0 0.5 0 0 0</pose>
      <geometry><ellipsoid><radii>0.1 0.2 0.3</radii></ellipsoid></geometry></collision></link></model></sdf>""")
    (shape,) = egg.description.links[0].collisions
    assert shape.kind == "ellipsoid" and np.array_equal(shape.size, [0.1, 0.2, 0.3])
    expected = wd.description.collidable.ellipsoid_points([0.1, 0.2, 0.3], options.sphere_points) + [0, 0, 0.5]
    np.testing.assert_allclose(egg.kin_dyn_parameters.contact_parameters.point, expected, atol=1e-15)


# ------------------------------------------------------------------------------------ the base


def test_fixed_base_options_on_sdf_models():
    """fixed_base=True welds a floating SDF model where its <pose> places it (the description's placement, as a
    URDF's world weld); fixed_base=False frees a static model, which then starts where it was welded. Reference:
    the pose in the file, exactly."""
    doc = """<sdf version="1.9"><model name="m"><static>{static}</static><pose>1 2 3 0 0 0</pose>
      <link name="l"><inertial><mass>1</mass><inertia><ixx>1</ixx><iyy>1</iyy><izz>1</izz></inertia></inertial></link>
      </model></sdf>"""
    welded = build(doc.format(static="false"), fixed_base=True)
    assert not welded.floating_base()
    np.testing.assert_array_equal(welded.description.world_H_base[:3, 3], [1.0, 2.0, 3.0])
    assert build(doc.format(static="true")).description.initial_world_H_base is None
    freed = build(doc.format(static="true"), fixed_base=False)
    assert freed.floating_base()
    np.testing.assert_array_equal(wd.data.Data.build(freed).base_position.numpy(), [1.0, 2.0, 3.0])
    assert wd.description.load(doc.format(static="false"), is_urdf=False).source == "sdf"
    with pytest.raises(ValueError, match=r"<robot> \(URDF\), <mujoco> \(MJCF\) or <sdf> \(SDFormat\)"):
        wd.description.load("<gazebo/>")
