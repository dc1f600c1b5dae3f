"""SDFormat's frame rules one by one, and what the SDF reader refuses or warns about.

Each rule has a small SDF whose expected kinematics are derived by hand from the numbers in the file (link and
frame poses at q = 0 and at a nonzero q, joint axes in the world), written here as compositions of elementary
rotations: `relative_to` a link, a joint, a frame, a nested model and `__model__`; frame chains and frames on
joints; `expressed_in` against the default; SDFormat 1.4's model-frame axis and 1.5/1.6's
`use_parent_model_frame`; degrees and quaternions; nested models; `placement_frame`, `canonical_link`, frames as
joint parents; a world's model pose (Data.build's default base pose) and gravity; static models; includes from
the model directory beside a file, through SDF_PATH, with overrides, and merged. The engine computes the poses
(Model.build_from_model_description, Data.build, forward_kinematics, frame.transform) in float64.

Tolerance: 1e-12 relative to max(1, |value|): the expected values compose a few transforms whose entries are
cos(pi/2) = 6e-17 rather than 0 and products of such, errors of a few 1e-16; any wrong rule is an O(1) error.
The refusals are checked for the element their message names (the file, the joint, link, frame or URI).
"""

from __future__ import annotations

import math
import os
import pathlib
import warnings

import numpy as np
import pytest

import warpdyn as wd
from robots import assert_close
from warpdyn.description import NotModelledWarning

MODELS = pathlib.Path(__file__).parent / "models" / "sdf"
PI2 = "1.5707963267948966"
INERTIAL = "<inertial><mass>1</mass><inertia><ixx>0.1</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial>"
TOL = 1e-12


def Rx(a):
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def Ry(a):
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def Rz(a):
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def T(p=(0.0, 0.0, 0.0), R=None) -> np.ndarray:
    H = np.eye(4)
    H[:3, 3] = p
    if R is not None:
        H[:3, :3] = R
    return H


def sdf(body: str, version: str = "1.9") -> str:
    return f'<sdf version="{version}">{body}</sdf>'


def build(source, **kwargs) -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        return wd.model.Model.build_from_model_description(source, dtype=np.float64, **kwargs)


class Posed:
    """A model at joint positions q (by name, 0 elsewhere) and Data.build's default base pose: link and frame
    poses in the world, joint axes in the world."""

    def __init__(self, model, q=None):
        q = q or {}
        self.model = model
        self.data = wd.data.Data.build(model, joint_positions=[q.get(n, 0.0) for n in model.joint_names()])
        self.H = wd.model.forward_kinematics(model, self.data).numpy()

    def link(self, name):
        return self.H[self.model.link_names().index(name)]

    def frame(self, name):
        index = wd.frame.name_to_idx(self.model, frame_name=name)
        return wd.frame.transform(self.model, self.data, frame_index=index).numpy()

    def axis(self, joint):
        i = self.model.joint_names().index(joint) + 1  # the joint's child link
        return self.H[i][:3, :3] @ self.model.tree.joint_axis[i]

    def frame_link(self, name):
        index = wd.frame.name_to_idx(self.model, frame_name=name)
        return self.model.link_names()[wd.frame.idx_of_parent_link(self.model, frame_index=index)]


def arm(body: str, version: str = "1.9", pose: str = "") -> wd.model.Model:
    """A floating model: link `base` (first) and whatever `body` adds."""
    return build(sdf(f'<model name="m">{pose}<link name="base">{INERTIAL}</link>{body}</model>', version))


# ------------------------------------------------------------------------------------ relative_to


@pytest.mark.parametrize("q", [0.0, 0.7])
def test_link_relative_to_a_link(q):
    """The model (so base) at (0, 0, 1); arm at (1, 0, 0) yawed 90 deg relative_to base; the joint at arm's origin
    (its default pose), axis x of the joint frame: the world axis is Rz(90) x = +y, and q rolls arm about it."""
    posed = Posed(arm(f"""<link name="arm"><pose relative_to="base">1 0 0 0 0 {PI2}</pose>{INERTIAL}</link>
        <joint name="j" type="revolute"><parent>base</parent><child>arm</child><axis><xyz>1 0 0</xyz></axis></joint>""",
                      pose="<pose>0 0 1 0 0 0</pose>"), {"j": q})
    assert_close(posed.link("base"), T((0, 0, 1)), TOL, "base")  # Data.build's default: the model's pose
    assert_close(posed.link("arm"), T((1, 0, 1), Rz(math.pi / 2) @ Rx(q)), TOL, "arm")
    assert_close(posed.axis("j"), [0, 1, 0], TOL, "axis")


@pytest.mark.parametrize("q", [0.0, math.pi / 2, -0.4])
def test_link_relative_to_its_joint_pivots_about_the_joint(q):
    """URDF style: the joint at (0, 0, 0.5) relative_to base, arm at (0, 0, -0.25) relative_to the joint: arm
    swings about y through the joint, 0.25 m from its origin (pivot (0, 0, 0.25) in arm)."""
    model = arm("""<joint name="j" type="revolute"><pose relative_to="base">0 0 0.5 0 0 0</pose><parent>base</parent>
        <child>arm</child><axis><xyz>0 1 0</xyz></axis></joint>
        <link name="arm"><pose relative_to="j">0 0 -0.25 0 0 0</pose>""" + INERTIAL + "</link>")
    posed = Posed(model, {"j": q})
    assert_close(posed.link("arm"), T(np.array([0, 0, 0.5]) + Ry(q) @ [0, 0, -0.25], Ry(q)), TOL, "arm")
    assert_close(model.tree.joint_pivot[1], [0, 0, 0.25], TOL, "pivot")


@pytest.mark.parametrize("q", [0.0, 0.9])
def test_frames_chains_and_frames_on_joints(q):
    """F1 on base at (0, 1, 0) yawed 90 deg; F2 on F1, 1 m along F1's x: (0, 2, 0); arm relative_to F2, 1 m up;
    F3 attached to F2 (so to base) but placed relative_to base at (3, 0, 0); `tip` attached to the joint, 0.5 m
    along the joint frame's z: it rides on arm. Each frame's link is where its attached_to chain ends."""
    posed = Posed(arm(f"""<frame name="F1" attached_to="base"><pose>0 1 0 0 0 {PI2}</pose></frame>
        <frame name="F2" attached_to="F1"><pose>1 0 0 0 0 0</pose></frame>
        <frame name="F3" attached_to="F2"><pose relative_to="base">3 0 0 0 0 0</pose></frame>
        <link name="arm"><pose relative_to="F2">0 0 1 0 0 0</pose>{INERTIAL}</link>
        <joint name="j" type="revolute"><parent>base</parent><child>arm</child><axis><xyz>1 0 0</xyz></axis></joint>
        <frame name="tip" attached_to="j"><pose>0 0 0.5 0 0 0</pose></frame>"""), {"j": q})
    W_arm = T((0, 2, 1), Rz(math.pi / 2) @ Rx(q))
    assert_close(posed.link("arm"), W_arm, TOL, "arm")
    assert_close(posed.axis("j"), [0, 1, 0], TOL, "axis")
    expected = {"F1": T((0, 1, 0), Rz(math.pi / 2)), "F2": T((0, 2, 0), Rz(math.pi / 2)), "F3": T((3, 0, 0)),
                "tip": W_arm @ T((0, 0, 0.5))}  # fmt: skip
    assert posed.model.frame_names() == ("F1", "F2", "F3", "tip")
    for name, H in expected.items():
        assert_close(posed.frame(name), H, TOL, name)
        assert posed.frame_link(name) == ("arm" if name == "tip" else "base")


@pytest.mark.parametrize("q", [(0.0, 0.0), (0.3, -1.1)])
def test_nested_models_scoped_names_and_relative_to_a_model(q):
    """robot > arm (at (1, 0, 0), yaw 90) > hand (at (0, 1, 0) in arm: the world origin, yaw 90); finger 1 m up
    relative_to the hand's __model__; the top model's `tool` relative_to the nested model `arm`, 2 m up: (1, 0, 2),
    welded to arm::hand::finger. Names are scoped (arm::upper, arm::hand::finger, arm::wrist); the shoulder turns
    arm::upper about z, the wrist turns the finger about the joint frame's x = world +y at q = 0."""
    model = build(sdf(f"""<model name="robot"><link name="base">{INERTIAL}</link>
        <model name="arm"><pose>1 0 0 0 0 {PI2}</pose><link name="upper">{INERTIAL}</link>
          <model name="hand"><pose>0 1 0 0 0 0</pose>
            <link name="finger"><pose relative_to="__model__">0 0 1 0 0 0</pose>{INERTIAL}</link></model>
          <joint name="wrist" type="revolute"><parent>upper</parent><child>hand::finger</child><axis><xyz>1 0 0</xyz></axis></joint>
        </model>
        <joint name="shoulder" type="revolute"><parent>base</parent><child>arm::upper</child><axis><xyz>0 0 1</xyz></axis></joint>
        <link name="tool"><pose relative_to="arm">0 0 2 0 0 0</pose>{INERTIAL}</link>
        <joint name="mount" type="fixed"><parent>arm::hand::finger</parent><child>tool</child></joint></model>"""))
    assert model.link_names() == ("base", "arm::upper", "arm::hand::finger")
    assert model.joint_names() == ("shoulder", "arm::wrist") and model.frame_names() == ("tool",)
    q1, q2 = q
    posed = Posed(model, {"shoulder": q1, "arm::wrist": q2})
    W_upper = T((1, 0, 0), Rz(math.pi / 2) @ Rz(q1))
    W_finger = W_upper @ T((0, 1, 1)) @ T(R=Rx(q2))  # finger in upper at q = 0: Rz(-90) ((0, 0, 1) - (1, 0, 0))
    assert_close(posed.link("arm::upper"), W_upper, TOL, "upper")
    assert_close(posed.link("arm::hand::finger"), W_finger, TOL, "finger")
    assert_close(posed.frame("tool"), W_finger @ T((0, -1, 1)), TOL, "tool")  # Rz(-90) ((1, 0, 2) - (0, 0, 1))
    if q == (0.0, 0.0):
        assert_close(posed.axis("arm::wrist"), [0, 1, 0], TOL, "wrist axis")


# ------------------------------------------------------------------------------------ joint axes


@pytest.mark.parametrize(
    "expressed_in, axis",
    [(None, [0, 0, 1]), ("__model__", [1, 0, 0]), ("m", [1, 0, 0]), ("tilted", [0, 0, -1]), ("arm", [1, 0, 0])],
)
@pytest.mark.parametrize("q", [0.0, 0.6])
def test_axis_expressed_in(expressed_in, axis, q):
    """arm at (0, 0, 1) rolled 90 deg (Rx); the joint frame yawed 90 deg in it (Rz): axis x in the joint frame is
    Rx(90) Rz(90) x = +z (the default), x of the model (`__model__` or its name) or of arm is +x, x of `tilted`
    (a frame pitched 90 deg) is -z. q turns arm about that world axis through the joint (arm's origin)."""
    attribute = f' expressed_in="{expressed_in}"' if expressed_in else ""
    posed = Posed(arm(f"""<frame name="tilted" attached_to="base"><pose>0 0 0 0 {PI2} 0</pose></frame>
        <link name="arm"><pose>0 0 1 {PI2} 0 0</pose>{INERTIAL}</link>
        <joint name="j" type="revolute"><pose>0 0 0 0 0 {PI2}</pose><parent>base</parent><child>arm</child>
        <axis><xyz{attribute}>1 0 0</xyz></axis></joint>""", version="1.7"), {"j": q})
    assert_close(posed.axis("j"), axis, TOL, "axis")
    w = np.asarray(axis, dtype=float)
    K = np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    R = np.eye(3) + math.sin(q) * K + (1 - math.cos(q)) * K @ K
    assert_close(posed.link("arm"), T((0, 0, 1), R @ Rx(math.pi / 2)), TOL, "arm")


@pytest.mark.parametrize(
    "version, axis_xml, axis",
    [
        ("1.4", "<xyz>0 1 0</xyz>", [-1, 0, 0]),  # 1.4: the model frame (yawed 90 deg)
        ("1.5", "<xyz>0 1 0</xyz>", [0, 0, 1]),  # 1.5/1.6: the joint frame = arm's (Rz(90) Rx(90))
        ("1.6", "<xyz>0 1 0</xyz><use_parent_model_frame>true</use_parent_model_frame>", [-1, 0, 0]),
        ("1.6", "<xyz>0 1 0</xyz><use_parent_model_frame>false</use_parent_model_frame>", [0, 0, 1]),
        ("1.7", "<xyz>0 1 0</xyz>", [0, 0, 1]),
        ("1.7", '<xyz expressed_in="__model__">0 1 0</xyz>', [-1, 0, 0]),
    ],
)
def test_axis_rules_of_each_version(version, axis_xml, axis):
    """The model yawed 90 deg in the world, arm rolled 90 deg in the model frame (links in the model frame, the
    joint at arm's origin: the legacy defaults, which 1.7+ keeps): axis (0, 1, 0) is Rz(90) y = -x in the model
    frame (1.4's rule, use_parent_model_frame, expressed_in="__model__"), Rz(90) Rx(90) y = +z in the joint frame.
    Data.build starts the floating base at the model's pose."""
    posed = Posed(arm(f"""<link name="arm"><pose>0 0 1 {PI2} 0 0</pose>{INERTIAL}</link>
        <joint name="j" type="revolute"><parent>base</parent><child>arm</child><axis>{axis_xml}</axis></joint>""",
                      version=version, pose=f"<pose>0 0 0 0 0 {PI2}</pose>"))
    assert_close(posed.axis("j"), axis, TOL, "axis")
    assert_close(posed.link("base"), T(R=Rz(math.pi / 2)), TOL, "base")
    assert_close(posed.link("arm"), T((0, 0, 1), Rz(math.pi / 2) @ Rx(math.pi / 2)), TOL, "arm")


@pytest.mark.parametrize(
    "pose",
    [f"1 0 0 0 0 {PI2}", '<pose degrees="true">1 0 0 0 0 90</pose>',
     '<pose rotation_format="quat_xyzw">1 0 0 0 0 0.70710678118654757 0.70710678118654757</pose>'],
    ids=["radians", "degrees", "quat_xyzw"],
)  # fmt: skip
def test_pose_formats(pose):
    """One pose written three ways (SDFormat 1.9): (1, 0, 0) yawed 90 deg; and a general one in degrees,
    (0.1, 0.2, 0.3) with roll 30, pitch 45, yaw 60: R = Rz(60) Ry(45) Rx(30), SDFormat's extrinsic X-Y-Z."""
    pose = pose if pose.startswith("<") else f"<pose>{pose}</pose>"
    posed = Posed(arm(f"""<link name="arm">{pose}{INERTIAL}</link><link name="tool">
        <pose degrees="true">0.1 0.2 0.3 30 45 60</pose>{INERTIAL}</link>
        <joint name="j" type="revolute"><parent>base</parent><child>arm</child></joint>
        <joint name="k" type="prismatic"><parent>base</parent><child>tool</child></joint>"""))
    assert_close(posed.link("arm"), T((1, 0, 0), Rz(math.pi / 2)), 1e-15, "arm")
    R = Rz(math.radians(60)) @ Ry(math.radians(45)) @ Rx(math.radians(30))
    assert_close(posed.link("tool"), T((0.1, 0.2, 0.3), R), 1e-15, "tool")


# ------------------------------------------------------------------------------------ models in the world


@pytest.mark.parametrize("q", [0.0, 1.2])
def test_relative_to_world_and_a_joint_from_the_world(q):
    """The model sits at (0, 0, 1); `post` is placed relative_to `world` at (2, 0, 0), whatever the model's pose;
    the revolute joint `turn` from `world` to `base` (at the model's origin, axis z) makes the world the fixed base
    and turns base, and post with it, about the world's z through (0, 0, 1)."""
    model = build(sdf(f"""<model name="m"><pose>0 0 1 0 0 0</pose><link name="base">{INERTIAL}</link>
        <link name="post"><pose relative_to="world">2 0 0 0 0 0</pose>{INERTIAL}</link>
        <joint name="turn" type="revolute"><parent>world</parent><child>base</child><axis><xyz>0 0 1</xyz></axis></joint>
        <joint name="bolt" type="fixed"><parent>base</parent><child>post</child></joint></model>"""))
    assert not model.floating_base() and model.base_link() == "world" and model.joint_names() == ("turn",)
    posed = Posed(model, {"turn": q})
    assert_close(posed.link("base"), T((0, 0, 1), Rz(q)), TOL, "base")
    assert_close(posed.frame("post"), T((0, 0, 1), Rz(q)) @ T((2, 0, -1)), TOL, "post")


def test_placement_frame_canonical_link_and_frames_as_joint_parents():
    """(1.8) The nested `table` places its link `leg` (at (1, 0, 0) in the table frame) at (2, 0, 0): the table
    frame lands at (1, 0, 0) and its `top` (1 m up in the table frame) at (1, 0, 1). canonical_link="top": the
    table's frame, so a frame attached to `table`, rides on top. A joint whose <child> is the frame `mount` (on
    `cup`, 0.5 m up) connects `cup` and has its default pose at the frame: pivot (0, 0, 0.5) in cup."""
    model = build(sdf(f"""<model name="room"><link name="floor">{INERTIAL}</link>
        <model name="table" placement_frame="leg" canonical_link="top"><pose>2 0 0 0 0 0</pose>
          <link name="leg"><pose>1 0 0 0 0 0</pose>{INERTIAL}</link><link name="top"><pose>0 0 1 0 0 0</pose>{INERTIAL}</link>
          <joint name="legs" type="fixed"><parent>top</parent><child>leg</child></joint></model>
        <frame name="on_table" attached_to="table"><pose relative_to="table::top">0 0 0.1 0 0 0</pose></frame>
        <link name="cup"><pose relative_to="on_table"/>{INERTIAL}</link>
        <frame name="mount" attached_to="cup"><pose>0 0 0.5 0 0 0</pose></frame>
        <joint name="fix" type="fixed"><parent>floor</parent><child>table</child></joint>
        <joint name="spin" type="revolute"><parent>table::top</parent><child>mount</child><axis><xyz>0 0 1</xyz></axis></joint>
        </model>""", "1.8"))
    assert model.link_names() == ("floor", "cup") and model.joint_names() == ("spin",)
    posed = Posed(model, {"spin": 0.4})
    assert_close(posed.frame("table::leg"), T((2, 0, 0)), TOL, "leg")
    assert_close(posed.frame("table::top"), T((1, 0, 1)), TOL, "top")
    assert posed.frame_link("on_table") == "floor" and posed.frame_link("mount") == "cup"
    assert_close(posed.link("cup"), T((1, 0, 1.1), Rz(0.4)), TOL, "cup")
    assert_close(model.tree.joint_pivot[1], [0, 0, 0.5], TOL, "pivot")


@pytest.mark.parametrize("welded", [False, True])
def test_world_places_the_model(welded):
    """A <world> places model r at (1, 2, 3) yawed 90 deg; its base 1 m up in it: Data.build's default base pose is
    (1, 2, 4), quaternion (cos 45, 0, 0, sin 45) deg, floating or welded by a fixed joint from `world`. The world's
    gravity (0, 0, -3.7) and <physics><max_step_size> become the model's; the <physics> engine is named in the
    warning."""
    weld = '<joint name="weld" type="fixed"><parent>world</parent><child>base</child></joint>' if welded else ""
    doc = sdf(f"""<world name="w"><gravity>0 0 -3.7</gravity><physics name="p" type="ode"><max_step_size>0.002</max_step_size>
        </physics><model name="r"><pose>1 2 3 0 0 {PI2}</pose><link name="base"><pose>0 0 1 0 0 0</pose>{INERTIAL}</link>
        <link name="arm">{INERTIAL}</link><joint name="j" type="revolute"><parent>base</parent><child>arm</child></joint>
        {weld}</model></world>""")
    with pytest.warns(NotModelledWarning, match=r"world settings .*<physics name='p' type='ode'>"):
        model = wd.model.Model.build_from_model_description(doc, dtype=np.float64)
    assert model.floating_base() != welded
    data = wd.data.Data.build(model)
    np.testing.assert_allclose(data.base_position.numpy(), [1, 2, 4], atol=1e-15)
    np.testing.assert_allclose(data.base_quaternion.numpy(), [math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)], atol=1e-15)
    assert model.description.gravity.tolist() == [0, 0, -3.7] and model.gravity == -3.7 and model.time_step == 0.002
    assert wd.description.load(sdf(f'<world name="w"><model name="r"><link name="l">{INERTIAL}</link></model></world>')).gravity.tolist() == [0, 0, -9.8]


def test_static_model_is_welded_and_keeps_its_joints():
    """<static>true</static>: the base is welded where the model's pose puts it; its revolute joint stays a joint
    of warpdyn's model (Gazebo would move nothing), which the warning says."""
    doc = sdf(f"""<model name="s"><static>true</static><pose>0 0 2 0 0 0</pose><link name="base">{INERTIAL}</link>
        <link name="door">{INERTIAL}</link><joint name="hinge" type="revolute"><parent>base</parent><child>door</child></joint>
        </model>""")
    with pytest.warns(NotModelledWarning, match=r"movable joints of a static model .*\['hinge'\]"):
        model = wd.model.Model.build_from_model_description(doc, dtype=np.float64)
    assert not model.floating_base() and model.joint_names() == ("hinge",)
    assert_close(model.description.world_H_base, T((0, 0, 2)), 0.0, "weld")


# ------------------------------------------------------------------------------------ includes


def test_include_from_the_model_directory_beside_the_file():
    """tests/models/sdf/arm_on_cart.sdf includes model://two_link_arm from the directory beside it (model.config
    lists 1.5 and 1.8 files: the 1.8 one is read), renamed `arm` and placed 0.1 m ahead and up relative_to the
    cart's body; the cart sits at (1, 0, 0.5) yawed 90 deg in the world. The shoulder's axis is x of the cart's
    model frame (+y in the world); the elbow turns about y of the upper arm, 0.5 m below it; the included frame
    `arm::hand` is 0.4 m below the elbow. Joint dynamics come from the included file."""
    model = build(MODELS / "arm_on_cart.sdf")
    assert model.link_names() == ("body", "arm::upper", "arm::lower") and model.frame_names() == ("arm::hand",)
    q1, q2 = 0.5, -0.8
    posed = Posed(model, {"shoulder": q1, "arm::elbow": q2})
    W_upper = T((1, 0.1, 0.6), Rz(math.pi / 2) @ Rx(q1))
    W_lower = W_upper @ T((0, 0, -0.5)) @ T(R=Ry(q2))
    assert_close(posed.link("body"), T((1, 0, 0.5), Rz(math.pi / 2)), TOL, "body")
    assert_close(posed.link("arm::upper"), W_upper, TOL, "upper")
    assert_close(posed.link("arm::lower"), W_lower, TOL, "lower")
    assert_close(posed.frame("arm::hand"), W_lower @ T((0, 0, -0.4)), TOL, "hand")
    elbow = model.joint_names().index("arm::elbow")
    tree = model.tree
    assert (tree.damping[elbow], tree.friction[elbow], tree.stiffness[elbow], tree.springref[elbow]) == (0.1, 0.05, 3.0, 0.2)
    np.testing.assert_array_equal(tree.position_limits[elbow], [-2, 2])
    assert model.description.gravity.tolist() == [0, 0, -9.81]


def test_include_through_sdf_path_with_overrides_and_merge(tmp_path, monkeypatch):
    """A model directory in a temporary folder found through SDF_PATH (the first of its two entries does not
    exist), then, SDF_PATH unset, not found from elsewhere but found beside the including file: included inside a
    model with <name>, <pose> and a frame of the includer as relative_to; with merge="true" (its elements keep their own
    names; its model frame becomes the frame `_merged__gripper__model__`); in a <world> with <static> true, the
    included model is a fixed base. A relative <uri> is read against the including file."""
    library = tmp_path / "library" / "gripper"
    library.mkdir(parents=True)
    (library / "model.config").write_text('<model><sdf version="1.9">gripper.sdf</sdf></model>')
    (library / "gripper.sdf").write_text(sdf(f'<model name="gripper"><pose>0 0 5 0 0 0</pose><link name="palm">{INERTIAL}'
                                             '</link><frame name="tcp" attached_to="palm"><pose>0 0 0.1 0 0 0</pose></frame></model>'))
    monkeypatch.setenv("SDF_PATH", os.pathsep.join([str(tmp_path / "nowhere"), str(tmp_path / "library")]))
    host = tmp_path / "host.sdf"
    host.write_text(sdf(f"""<model name="robot"><link name="base">{INERTIAL}</link>
        <frame name="flange" attached_to="base"><pose>0 0 1 0 0 0</pose></frame>
        <include><uri>model://gripper</uri><name>left</name><pose relative_to="flange">0 0.2 0 0 0 0</pose></include>
        <joint name="grip" type="prismatic"><parent>base</parent><child>left::palm</child></joint></model>"""))
    posed = Posed(build(host))
    assert posed.model.link_names() == ("base", "left::palm") and posed.model.frame_names() == ("flange", "left::tcp")
    monkeypatch.delenv("SDF_PATH")
    with pytest.raises(ValueError, match=r"<include> of 'model://gripper': no model 'gripper'") as raised:
        wd.description.load(host)
    assert str(raised.value).startswith(f"'{host}': ")  # the including file
    beside = tmp_path / "library" / "host.sdf"  # the model directory beside the including file
    beside.write_text(host.read_text())
    assert build(beside).link_names() == posed.model.link_names()
    assert_close(posed.link("left::palm"), T((0, 0.2, 1)), TOL, "palm")  # the include's pose replaces the file's
    assert_close(posed.frame("left::tcp"), T((0, 0.2, 1.1)), TOL, "tcp")
    merged = tmp_path / "merged.sdf"
    merged.write_text(sdf(f"""<model name="robot"><link name="base">{INERTIAL}</link>
        <include merge="true"><uri>library/gripper/gripper.sdf</uri><pose>0 0 2 0 0 0</pose></include>
        <joint name="grip" type="fixed"><parent>base</parent><child>palm</child></joint></model>"""))
    description = wd.description.load(merged)
    assert [f.name for f in description.frames] == ["_merged__gripper__model__", "tcp"]
    assert description.frames[1].link == "palm"
    world = tmp_path / "library" / "world.sdf"
    world.write_text(sdf('<world name="w"><include><uri>model://gripper</uri><static>true</static></include></world>'))
    welded = wd.description.load(world)
    assert welded.fixed_base and welded.base == "palm"
    assert_close(welded.world_H_base, T((0, 0, 5)), 0.0, "weld")


# ------------------------------------------------------------------------------------ refusals and warnings

LINK = f'<link name="a">{INERTIAL}</link><link name="b">{INERTIAL}</link>'
REFUSED = [
    (sdf(f'<model name="m">{LINK}<joint name="u" type="universal"><parent>a</parent><child>b</child></joint></model>'),
     r"joint 'u' has type 'universal'"),
    (sdf(f'<world name="w"><model name="one">{LINK}</model><model name="two">{LINK}</model></world>'),
     r"the world holds 2 models \['one', 'two'\]"),
    (sdf(f'<model name="m">{LINK}</model>'), r"model 'm' has 2 kinematic roots \['a', 'b'\]"),
    (sdf(f'<model name="m">{LINK}<joint name="j" type="fixed"><parent>a</parent><child>b</child>'
         '<pose relative_to="nowhere"/></joint></model>'), r"joint 'j' <pose relative_to> names frame 'nowhere'"),
    (sdf(f'<model name="m"><link name="a"><pose relative_to="F2"/></link><frame name="F1" attached_to="a">'
         '<pose relative_to="F2"/></frame><frame name="F2" attached_to="a"><pose relative_to="F1"/></frame></model>'),
     r"the poses of 'F\d' -> 'F\d' -> 'F\d' are expressed relative to each other in a cycle"),
    (sdf(f'<model name="m">{LINK}<joint name="j" type="fixed"><parent>a</parent><child>b</child></joint>'
         '<frame name="F1" attached_to="F2"><pose relative_to="a"/></frame><frame name="F2" attached_to="F1">'
         '<pose relative_to="a"/></frame></model>'),
     r"the attached_to chain 'F\d' -> 'F\d' -> 'F\d' is a cycle"),
    (sdf('<model name="m"><include><uri>model://no_such_model</uri></include></model>'),
     r"<include> of 'model://no_such_model': no model 'no_such_model' .*SDF_PATH.* \(looked in \["),
    (sdf('<model name="m"><link name="a"><inertial><mass>heavy</mass></inertial></link></model>'),
     r"link 'a' <inertial><mass> has 'heavy', which is not a number"),
    (sdf(f'<model name="m">{LINK}<joint name="j" type="fixed"><parent>a</parent></joint></model>'), r"joint 'j' has no <child>"),
    (sdf(f'<model name="m">{LINK}<frame name="a"/></model>'), r"frame 'a' has the name of link 'a'"),
    (sdf(f'<model name="m">{LINK}<joint name="j" type="fixed"><parent>a</parent><child>b</child></joint>'
         '<joint name="k" type="fixed"><parent>b</parent><child>a</child></joint></model>'), r"its joints \['j', 'k'\] close a kinematic loop"),
    (sdf(f'<model name="m">{LINK}</model>', "1.3"), r"SDFormat 1.3 is not read \(1.4 to 1.11 are\)"),
    (sdf(f'<model name="m">{LINK}</model>', "two"), r"<sdf version='two'> is not an SDFormat version"),
    (sdf(f'<model name="m"><link name="a"><pose>1 2 3</pose></link></model>'), r"link 'a' <pose> has 3 numbers"),
]


@pytest.mark.parametrize("doc, message", REFUSED, ids=range(len(REFUSED)))
def test_refusals_name_the_element(doc, message):
    """Each refusal is a ValueError naming the document and the offending joint, link, frame, models, URI,
    value or version."""
    with pytest.raises(ValueError, match=message) as raised:
        wd.description.load(doc)
    assert str(raised.value).startswith("the given XML document")


def test_kinematic_loop_message_names_both_joints():
    """Two joints with the same child: a loop warpdyn's trees cannot hold; the message names the link and joints."""
    with pytest.raises(ValueError, match=r"links with several parent joints"):
        wd.description.load(sdf(f'<model name="m">{LINK}<link name="c">{INERTIAL}</link>'
                                '<joint name="j" type="fixed"><parent>a</parent><child>b</child></joint>'
                                '<joint name="k" type="fixed"><parent>c</parent><child>b</child></joint></model>'))


def test_one_warning_lists_what_is_not_modelled(recwarn):
    """Sensors, plugins, joint <physics>, limit stiffness, inverted limits, mimic, contact surfaces, unsupported
    geometry, a link without gravity, self collision, lights and a link without <inertial> are listed by kind and
    name in ModelDescription.not_modelled and one NotModelledWarning; visuals are not (they are not physics).
    Reference: the document itself. A version newer than 1.11 is read with 1.11's rules and a warning."""
    doc = sdf(f"""<model name="m"><plugin name="ctrl" filename="libctrl.so"/><self_collide>true</self_collide>
        <link name="a">{INERTIAL}<gravity>false</gravity><sensor name="imu" type="imu"/><light name="lamp"/>
          <visual name="v"><geometry><box/></geometry></visual>
          <collision name="c"><geometry><cone><radius>1</radius><length>1</length></cone></geometry></collision>
          <collision name="d"><surface><friction/></surface><geometry><sphere><radius>0.1</radius></sphere></geometry></collision>
        </link><link name="b"/>
        <joint name="j" type="revolute"><parent>a</parent><child>b</child><physics><ode/></physics>
          <axis><limit><lower>1</lower><upper>-1</upper><stiffness>1e5</stiffness></limit><mimic joint="k"/></axis></joint>
        </model>""", "1.12")
    description = wd.description.load(doc)
    notes = description.not_modelled
    assert notes["sensors (their plugins included)"] == ["a/imu"] and notes["plugins"] == ["m/ctrl"]
    assert [k.split(" ")[0] for k in notes] == ["sensors", "plugins", "joint", "joint-limit", "joint", "mimic", "links",
                                                "collision", "collision", "links", "self", "lights"]
    assert list(notes.values())[2:] == [["j"], ["j"], ["j (1 > -1)"], ["j"], ["b (<inertial>)"], ["a/d"],
                                        ["a/c (cone)"], ["a"], ["m"], ["a/lamp"]]
    assert (description.joints[0].lower, description.joints[0].upper) == (-np.inf, np.inf)
    assert description.link("b").mass == 1.0 and np.array_equal(description.link("b").inertia, np.eye(3))
    kinds = [type(w.message) for w in recwarn]
    assert kinds.count(NotModelledWarning) == 1 and kinds.count(UserWarning) == 1  # the version
    assert "SDFormat 1.12 is newer than 1.11" in str(next(w.message for w in recwarn if type(w.message) is UserWarning))
