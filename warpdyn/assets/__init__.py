"""Robot descriptions: shipped with warpdyn, or found in an installed pip package.

- `ergocub_urdf()`: the ergoCub humanoid, serial SN001 (the robot of JaxSim's notebook "JaxSim as a
  multibody dynamics library" that warpdyn's tour and tests use), from the ergocub-software repository of
  iCub Tech (https://github.com/icub-tech-iit/ergocub-software), BSD-3-Clause: its licence text is
  `LICENSE.ergoCub` beside the file. Meshes are not included: its collision boxes and spheres give the
  collidable points; its mesh URIs (`package://ergoCub/...`) stay unresolved.
- `ergocub_sdf()`: the same robot as Gazebo's URDF-to-SDF converter writes it (SDFormat 1.9, same licence,
  `LICENSE.ergoCub`): the same links, joints and dynamics as the URDF (tests/test_sdf.py checks M, h, ABA and
  poses to 1e-12), with 8 fixed joints kept (the force-torque sensors': their child links become frames) and
  the URDF's other fixed links lumped away by the converter, without `<frame>`s: its model has 8 frames where
  the URDF's has 146. The model's `<pose>` (0, 0, 0.8) is the default base pose of `Data.build`. Its sensors,
  Gazebo plugins, ODE joint settings and contact surfaces are not modelled (one NotModelledWarning at load).
- `franka_panda_mjcf()`: the Franka Emika Panda arm without its hand (fixed base, 7 revolute joints, 16.1 kg
  moving), MuJoCo Menagerie's `franka_emika_panda/panda_nohand.xml` without meshes, geoms and actuators (the
  file's comment says what was changed and why; Apache-2.0: `LICENSE.panda` beside the file). MuJoCo compiles
  it alone; warpdyn's M, h, accelerations and step equal MuJoCo's on it (tests/test_panda.py). Its controls are
  joint torques (`joint_force_references`), within FRANKA_PANDA_TORQUE_LIMITS; the flange is the frame
  FRANKA_PANDA_FLANGE; the keyframe "home" (`wd.data.keyframe(model, "home")`) is Menagerie's. Loading it
  warns once, a NotModelledWarning for the joint limits (MuJoCo's limit constraints).
- `franka_panda_cube_mjcf()`: the Panda with its hand and a 0.1 kg cube on the floor, MuJoCo Playground's
  PandaPickCube scene (Menagerie's `franka_emika_panda/mjx_single_cube.xml` with its mjx_panda.xml and
  mjx_scene.xml in one file, without meshes and the mocap target, at 1 ms; the file's comment says what was
  changed; Apache-2.0: `LICENSE.panda`): its fingertip pads collide with the cube (their two geom pairs act
  where model.geom_contacts is set; the hand's capsule meets the floor through its collidable points), the fingers are coupled by a joint equality, the 7 joints'
  position servos and the gripper's are its 8 controls, and its keyframes "home", "pickup" and "pickup1" are
  Menagerie's. A scripted grasp from "pickup1" lifts the cube 39 cm and holds it, the arm moving as MuJoCo's
  (tests/test_panda.py; soft law K = 5e5, D = 500 for the 0.1 kg cube at 1 ms).
- `leap_hand_cube_mjcf()`: the LEAP hand (right, its mount fixed to the world; 16 revolute joints, LEAP_HAND_JOINTS,
  each with a position servo of kp 3 and a force range of 0.22 N m) and a 0.108 kg cube of 7 cm in its palm,
  MuJoCo Playground's LeapCubeReorient scene (its leap_rh_mjx.xml, reorientation_cube.xml and scene_mjx_cube.xml in
  one file, without meshes, sensors and the mocap goal, at 1 ms; the file's comment says what was changed;
  Apache-2.0: `LICENSE.leap_hand`). Every collision geom is a box: the cube's, the palm's, the fingers' and the
  fingertips', 325 geom pairs as MuJoCo pairs them (its contact excludes and filters; they act where
  model.geom_contacts is set); the floor (z = -0.25 m; the mount at the origin) is the model's terrain; the keyframe "home" holds
  the cube in the palm. Loading it warns once, a NotModelledWarning for the joint limits and the frictionloss
  (applied as JaxSim's static friction).
- `anymal_c_mjcf()`: ANYbotics' ANYmal C quadruped (floating base, 12 revolute joints, 44.97 kg), MuJoCo
  Menagerie's `anybotics_anymal_c/anymal_c.xml` without meshes, textures, materials, visual geoms, actuators
  and frictionloss, with the keyframe "standing" of Menagerie's anymal_c_mjx.xml (the file's comment says what
  was changed and why; BSD-3-Clause, ANYbotics AG: `LICENSE.anymal_c` beside the file). MuJoCo compiles it
  alone; warpdyn's M and accelerations equal MuJoCo's on it (tests/test_env_robots.py). Its collision
  primitives are kept: the four 0.03 m foot spheres (ANYMAL_C_FEET's, the contacts of `envs.robots.anymal_c()`)
  and the boxes and cylinders of the base and legs. Loading it warns once, a NotModelledWarning for the joint
  limits, the contacts between bodies (off unless model.geom_contacts) and the pairs of cylinders warpdyn does not
  collide.
- `go2_mjcf()`: Unitree's Go2 quadruped (floating base, 12 revolute joints, 15.21 kg), MuJoCo Menagerie's
  `unitree_go2/go2.xml` without meshes, materials, visual geoms, motors and frictionloss, with Menagerie's
  keyframe "home" (the file's comment says what was changed and why; BSD-3-Clause, Unitree Robotics:
  `LICENSE.go2` beside the file). MuJoCo compiles it alone; warpdyn's M and accelerations equal MuJoCo's on it
  (tests/test_env_robots.py). Its collision primitives are kept: the four 0.022 m foot spheres (GO2_FEET's, the
  contacts of `envs.robots.go2()`) and the boxes, cylinders and sphere of the base and legs. Loading it warns
  once, a NotModelledWarning for the joint limits that MuJoCo has.
- `example_robot_data_urdf(robot)`: a URDF of the pip package example-robot-data (Gepetto, LAAS-CNRS;
  BSD-3-Clause; `pip install example-robot-data`, a cmeel wheel that puts the files under
  `<site-packages>/cmeel.prefix/share/example-robot-data/robots/`). Not shipped with warpdyn: found in the
  installed package. Its meshes (`package://example-robot-data/...`) resolve from the file's own ancestors.
  Each robot keeps its upstream licence beside it (go1_description/README.md: from unitreerobotics/unitree_ros,
  MPL-2.0).

The Unitree Go1 quadruped, `example_robot_data_urdf("go1")` (tests/test_go1.py checks it against MuJoCo):
floating base `base` (a 1e-6 kg placeholder, fixed to the 5.2 kg `trunk`), 13.1 kg in all, 12 revolute joints
(GO1_JOINTS), 13 links after warpdyn lumps the fixed joints (the trunk, IMU, cameras, sensors and the motors'
rotors into their parents, each `<leg>_foot` into `<leg>_calf`: frames, GO1_FOOT_FRAMES). Loading it warns
once, an UnphysicalInertiaWarning for the placeholder `base`, whose URDF inertia (every entry 1e-6: rank 1) no
rigid body has; harmless once lumped into the trunk (MuJoCo refuses that inertia: it does not compile the file
as it is). The URDF's `<dynamics damping="0.01" friction="0.2">` become the joints' viscous and static
friction, as JaxSim reads them; its transmissions (one motor per joint, reduction 1) and visual meshes are not
read. The rotors are rigid bodies fixed to the links, not geared: no reflected inertia (armature). Effort and
velocity limits (`model.tree.effort_limits`, `velocity_limits`): 23.7 N m and 30.1 rad/s for the hips and
thighs, 35.55 N m and 20.06 rad/s for the calves; warpdyn stores them but does not enforce them (clip the
servos with `wd.model.add_actuators(..., force_range=...)`).

Its 38 collision shapes (boxes, cylinders, and one sphere of radius 0.02 m per foot) all give collidable points
by default: 888 points. For legged locomotion keep the four foot spheres, the Go1's only collision spheres,
with a few points each: 20 Fibonacci points per sphere, of which the 9 below the sphere's centre (the lower
hemisphere in the calf frame, whose -z runs along the shank):

    go1 = wd.model.Model.build_from_model_description(wd.assets.example_robot_data_urdf("go1"))
    go1 = wd.contact.with_collidable_points(
        go1, options=wd.contact.CollidablePointsOptions(shapes=("sphere",), sphere_points=20))
    point = go1.kin_dyn_parameters.contact_parameters.point          # L_p_C of every point, calf frames
    go1 = wd.contact.with_collidable_points(go1, enabled=point[:, 2] < wd.assets.GO1_FOOT_CENTRE[2])

36 enabled points, 9 on each link of GO1_FEET, all on the sphere; in the standing pose the lowest is within a
tenth of the radius of the sphere's bottom (tests/test_go1.py). More points per sphere (`sphere_points`) follow
the sphere more closely, at the cost of more contact points per step.
"""

from __future__ import annotations

import importlib.metadata
import pathlib

__all__ = [
    "ergocub_urdf",
    "ergocub_sdf",
    "ERGOCUB_LEG_JOINTS",
    "franka_panda_mjcf",
    "franka_panda_cube_mjcf",
    "FRANKA_PANDA_FLANGE",
    "FRANKA_PANDA_TORQUE_LIMITS",
    "leap_hand_cube_mjcf",
    "LEAP_HAND_JOINTS",
    "anymal_c_mjcf",
    "ANYMAL_C_FEET",
    "ANYMAL_C_TORQUE_LIMIT",
    "go2_mjcf",
    "GO2_FEET",
    "GO2_TORQUE_LIMITS",
    "GO2_STANDING_POSE",
    "example_robot_data_urdf",
    "GO1_JOINTS",
    "GO1_FEET",
    "GO1_FOOT_FRAMES",
    "GO1_FOOT_CENTRE",
    "GO1_FOOT_RADIUS",
    "GO1_STANDING_POSE",
]

_HERE = pathlib.Path(__file__).resolve().parent

ERGOCUB_LEG_JOINTS = (
    "l_hip_pitch",
    "l_hip_roll",
    "l_hip_yaw",
    "l_knee",
    "l_ankle_pitch",
    "l_ankle_roll",
    "r_hip_pitch",
    "r_hip_roll",
    "r_hip_yaw",
    "r_knee",
    "r_ankle_pitch",
    "r_ankle_roll",
)
"""The twelve leg joints of the ergoCub, the ones JaxSim's notebook keeps."""


def ergocub_urdf() -> pathlib.Path:
    """The path of the shipped ergoCubSN001 URDF (a file inside the installed package)."""
    return _HERE / "ergoCubSN001.urdf"


def ergocub_sdf() -> pathlib.Path:
    """The path of the shipped ergoCubSN001 SDF (SDFormat 1.9, Gazebo's conversion of the URDF; a file inside
    the installed package)."""
    return _HERE / "ergoCubSN001.sdf"


# ------------------------------------------------------------------------------------ the Franka Emika Panda


def franka_panda_mjcf() -> pathlib.Path:
    """The path of the shipped Franka Emika Panda arm, an MJCF file without meshes (a file inside the installed
    package)."""
    return _HERE / "franka_panda.xml"


def franka_panda_cube_mjcf() -> pathlib.Path:
    """The path of the shipped Panda with its hand and a cube on the floor (Playground's PandaPickCube scene), an
    MJCF file without meshes (a file inside the installed package)."""
    return _HERE / "franka_panda_cube.xml"


FRANKA_PANDA_FLANGE = "attachment"
"""The Panda's flange: Menagerie's massless body `attachment`, 0.107 m along link7's z and turned 3 pi / 4 about
it, a frame of link7 in warpdyn's model (at the joints' zero: (0.088, 0, 0.926) m, its z axis down)."""

FRANKA_PANDA_TORQUE_LIMITS = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
"""The largest joint torque of joints 1 to 7 [N m] (Menagerie's actuator forcerange, Franka's limits)."""


def leap_hand_cube_mjcf() -> pathlib.Path:
    """The path of the shipped LEAP hand with a cube in its palm (Playground's LeapCubeReorient scene), an MJCF file
    without meshes (a file inside the installed package)."""
    return _HERE / "leap_hand_cube.xml"


LEAP_HAND_JOINTS = tuple(f"{finger}_{joint}" for finger in ("if", "mf", "rf") for joint in ("mcp", "rot", "pip", "dip")) + ("th_cmc", "th_axl", "th_mcp", "th_ipl")
"""The LEAP hand's 16 joints, in its actuators' order (index, middle, ring finger, then the thumb): Playground's."""


# ------------------------------------------------------------------------------------ ANYbotics' ANYmal C


def anymal_c_mjcf() -> pathlib.Path:
    """The path of the shipped ANYmal C, an MJCF file without meshes or actuators (a file inside the installed
    package)."""
    return _HERE / "anymal_c.xml"


ANYMAL_C_FEET = ("LF_SHANK", "RF_SHANK", "LH_SHANK", "RH_SHANK")
"""The links that carry the foot spheres: the shanks, Menagerie's last bodies (each sphere, radius 0.03 m, is
centred at (0.01305, +-0.08795, -0.31547) m in its shank's frame, whose -z runs down the shank)."""

ANYMAL_C_TORQUE_LIMIT = 80.0
"""The largest joint torque [N m] of every joint: Menagerie's actuator forcerange (its README: roughly the
ANYdrive's specification)."""


# ------------------------------------------------------------------------------------ Unitree's Go2


def go2_mjcf() -> pathlib.Path:
    """The path of the shipped Go2, an MJCF file without meshes or motors (a file inside the installed package)."""
    return _HERE / "go2.xml"


GO2_FEET = ("FL_calf", "FR_calf", "RL_calf", "RR_calf")
"""The links that carry the foot spheres: the calves, Menagerie's last bodies (each sphere, radius 0.022 m, is
centred at (-0.002, 0, -0.213) m in its calf's frame, whose -z runs down the calf)."""

GO2_TORQUE_LIMITS = {f"{leg}_{joint}_joint": (45.43 if joint == "calf" else 23.7) for leg in ("FL", "FR", "RL", "RR") for joint in ("hip", "thigh", "calf")}
"""Each joint's largest torque [N m]: Menagerie's motor ctrlrange (torques, gear 1), +-23.7 N m on the hip and thigh
joints and +-45.43 N m on the knees (the calf joints); LeggedEnvConfig.torque_limit takes the dict."""

GO2_STANDING_POSE = {
    **{f"{leg}_hip_joint": 0.1 if leg[1] == "L" else -0.1 for leg in ("FL", "FR", "RL", "RR")},
    **{f"{leg}_thigh_joint": 0.8 if leg[0] == "F" else 1.0 for leg in ("FL", "FR", "RL", "RR")},
    **{f"{leg}_calf_joint": -1.5 for leg in ("FL", "FR", "RL", "RR")},
}
"""A standing posture [rad]: unitree_rl_gym's Go2 default joint angles (GO2RoughCfg.init_state in
legged_gym/envs/go2/go2_config.py of github.com/unitreerobotics/unitree_rl_gym), the posture its gains (kp 20,
kd 0.5) hold. Menagerie's keyframe "home" (thighs 0.9, knees -1.8) bends the knees further: with those gains the
Go2 sinks on them by 0.5 rad and falls within 0.5 s."""


# ------------------------------------------------------------------------------------ example-robot-data

_ERD = "example-robot-data"
_ERD_ROBOTS = "share/example-robot-data/robots/"  # under the cmeel prefix, `cmeel.prefix/` in site-packages
_ERD_INSTALL = "pip install example-robot-data"


def _example_robot_data_urdfs() -> list[pathlib.Path]:
    """Every URDF of the installed example-robot-data (the files its distribution records, or, when it records
    none, those under its cmeel prefix); ImportError when it is not installed."""
    try:
        dist = importlib.metadata.distribution(_ERD)
    except importlib.metadata.PackageNotFoundError:
        raise ImportError(
            f"the robot descriptions of the pip package {_ERD} are needed, and it is not installed: {_ERD_INSTALL}"
        ) from None
    if dist.files is not None:
        found = [pathlib.Path(dist.locate_file(f)) for f in dist.files if f.suffix == ".urdf" and _ERD_ROBOTS in f.as_posix()]
    else:
        found = sorted(pathlib.Path(dist.locate_file("cmeel.prefix/" + _ERD_ROBOTS)).rglob("*.urdf"))
    return sorted(path for path in found if path.is_file())


def example_robot_data_urdf(robot: str) -> pathlib.Path:
    """The path of a URDF of the installed pip package example-robot-data (`pip install example-robot-data`).

    robot: the URDF's file name without `.urdf` ("go1", "solo12", "panda", "talos_reduced", ...), or the end of
        its path under `robots/` where a name is in several descriptions ("anymal_c_simple_description/urdf/anymal").
    Raises ImportError (naming the pip command) when the package is not installed, FileNotFoundError (listing
    the names it has) when no URDF is called `robot`, ValueError (listing them) when several are.
    """
    if not isinstance(robot, str) or not robot:
        raise TypeError(f"robot must be a URDF's name (e.g. 'go1'), got {robot!r}")
    name = robot.removesuffix(".urdf")
    urdfs = _example_robot_data_urdfs()
    matches = [path for path in urdfs if (path.stem == name if "/" not in name else path.with_suffix("").as_posix().endswith("/" + name))]
    if not matches:
        available = ", ".join(sorted({path.stem for path in urdfs}))
        raise FileNotFoundError(
            f"the installed {_ERD} ({importlib.metadata.version(_ERD)}) has no URDF called '{robot}' "
            f"(its URDFs: {available}); '{_ERD_INSTALL} --upgrade' for a newer one"
        )
    if len(matches) > 1:
        listed = ", ".join(path.with_suffix("").as_posix().split("/robots/", 1)[-1] for path in matches)
        raise ValueError(f"several URDFs of {_ERD} are called '{robot}': {listed}; give the end of one's path")
    return matches[0]


# ------------------------------------------------------------------------------------ the Unitree Go1

GO1_JOINTS = (
    "FR_hip_joint",
    "FR_thigh_joint",
    "FR_calf_joint",
    "FL_hip_joint",
    "FL_thigh_joint",
    "FL_calf_joint",
    "RR_hip_joint",
    "RR_thigh_joint",
    "RR_calf_joint",
    "RL_hip_joint",
    "RL_thigh_joint",
    "RL_calf_joint",
)
"""The Go1's 12 revolute joints in the URDF's order (leg by leg: front right, front left, rear right, rear
left; hip about x, thigh and calf about y), Unitree's order. warpdyn's model orders them breadth-first,
siblings by name as JaxSim (`model.joint_names()`: the four hips, the four thighs, the four calves, each FL,
FR, RL, RR), the order of its state and of its actuators; map by name."""

GO1_FEET = ("FR_calf", "FL_calf", "RR_calf", "RL_calf")
"""The links that carry the foot spheres: warpdyn lumps each fixed `<leg>_foot_fixed` joint, so the foot's
sphere (and its 0.06 kg) belong to the calf, and the foot is the frame `GO1_FOOT_FRAMES` of that calf."""

GO1_FOOT_FRAMES = ("FR_foot", "FL_foot", "RR_foot", "RL_foot")
"""The frames at the centres of the foot spheres (the lumped `<leg>_foot` links), in GO1_FEET's order."""

GO1_FOOT_CENTRE = (0.0, 0.0, -0.213)
"""The centre of each foot sphere in its calf's frame [m] (the `<leg>_foot_fixed` joint's origin)."""

GO1_FOOT_RADIUS = 0.02
"""The radius of the foot spheres [m]."""

GO1_STANDING_POSE = {
    **{f"{leg}_hip_joint": 0.0 for leg in ("FR", "FL", "RR", "RL")},
    **{f"{leg}_thigh_joint": 0.8 for leg in ("FR", "FL", "RR", "RL")},
    **{f"{leg}_calf_joint": -1.5 for leg in ("FR", "FL", "RR", "RL")},
}
"""joint -> angle [rad] of the usual standing posture: hips 0 (limits +-0.863), thighs 0.8 (limits -0.686 to
4.501; positive moves the knee backwards), calves -1.5 (limits -2.818 to -0.888: the knee bends one way, the
foot swinging forwards under it; all four knees point backwards). Each foot's centre then lies 1.6 cm behind
its thigh joint and 0.311 m below it: the base touches the ground at a height of 0.330 m and settles at
0.320 m on kp = 100 N m/rad servos and K = 1e5 soft contacts (tests/test_go1.py)."""
