"""warpdyn.envs.robots: `LeggedRobot` sets a legged robot up from its description and a few names; the presets
equal what examples/rl_locomotion.py built by hand before them (the same contact points, feet and settings); a robot
not among them is set up by docs/rl.md's "Your own robot" block, which this file runs as written, and stands. The
shipped ANYmal C (warpdyn/assets/anymal_c.xml, from MuJoCo Menagerie) loads with the warning its comment names, its
dynamics equal MuJoCo's (measured: M 6e-16, h 5e-16, qacc 4e-15 relative, tests/mjcf_compare.py), and its preset
stands on the lower halves of its foot spheres; so do the shipped Go2's (warpdyn/assets/go2.xml: M 6e-16, h 6e-16,
qacc 2e-15 relative)."""

import dataclasses
import pathlib
import re
import warnings

import mujoco
import numpy as np
import pytest
import torch

import mjcf_compare
import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.description.mjcf import BODY_CONTACTS, JOINT_LIMITS, TORSION

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.filterwarnings("ignore::warpdyn.description.UnphysicalInertiaWarning")  # the Go1 URDF's massless base link
def test_the_presets_give_the_hand_built_models():
    """The Go1 preset's contacts are the lower halves of its foot spheres (20 points each), as the example chose them
    by the foot centre's height (wd.assets.GO1_FOOT_CENTRE); the ergoCub's are its foot boxes' corners, the default."""
    go1 = envs.robots.go1().model()
    hand = wd.model.Model.build_from_model_description(wd.assets.example_robot_data_urdf("go1"))
    hand = wd.contact.with_collidable_points(hand, options=wd.contact.CollidablePointsOptions(shapes=("sphere",), sphere_points=20))
    point = hand.kin_dyn_parameters.contact_parameters.point
    hand = wd.contact.with_collidable_points(hand, enabled=point[:, 2] < wd.assets.GO1_FOOT_CENTRE[2])
    assert go1.kin_dyn_parameters.contact_parameters.enabled == hand.kin_dyn_parameters.contact_parameters.enabled
    assert sum(go1.kin_dyn_parameters.contact_parameters.enabled) == 36
    legs = envs.robots.ergocub_legs()
    model = legs.model()
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf())
    default = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    np.testing.assert_array_equal(np.asarray(model.kin_dyn_parameters.contact_parameters.point), np.asarray(default.kin_dyn_parameters.contact_parameters.point))
    assert all(model.kin_dyn_parameters.contact_parameters.enabled) and len(model.kin_dyn_parameters.contact_parameters.body) == 32
    cfg = envs.robots.go1().config(go1)
    assert cfg.kp == 20.0 and set(cfg.feet) == set(wd.assets.GO1_FEET) and cfg.feet == tuple(n for n in go1.link_names() if n in cfg.feet) and cfg.default_joint_positions == dict(wd.assets.GO1_STANDING_POSE)


def assert_stands(env, seconds: float = 1.0) -> None:
    """With zero actions for `seconds`, no episode of `env` ends and every base stays above half its standing height."""
    actions = torch.zeros(env.num_envs, env.single_action_space.shape[0], device=env.device)
    ended = torch.zeros(env.num_envs, dtype=torch.bool, device=env.device)
    for _ in range(int(seconds / env.cfg.policy_dt)):
        _, _, terminated, _, _ = env.step(actions)
        ended |= terminated
    assert not ended.any()
    assert float(env.state.base_position[:, 2].min()) > 0.5 * env.standing_height


def test_your_own_robot_block_of_the_docs_runs_and_stands():
    """docs/rl.md's block, run as written: the quadruped's feet carry its only contact points (the lower halves of its
    spheres), its posture is the keyframe's, and with zero actions it stays standing for 1 s (no episode ends)."""
    text = (ROOT / "docs" / "rl.md").read_text()
    block = re.search(r"<!-- your-own-robot -->\n```python\n(.*?)```", text, re.S).group(1)
    scope = {}
    exec(compile(block, "docs/rl.md", "exec"), scope)
    env, robot = scope["env"], scope["robot"]
    cp = env.model.kin_dyn_parameters.contact_parameters
    links = env.model.link_names()
    assert {links[b] for b, e in zip(cp.body, cp.enabled) if e} == set(robot.feet)
    lower = [links[b] in robot.feet and p[2] < -0.2 for b, p in zip(cp.body, np.asarray(cp.point))]  # below each sphere's centre
    assert list(cp.enabled) == lower and 0 < sum(lower) < sum(links[b] in robot.feet for b in cp.body)
    assert env.cfg.default_joint_positions["fl_knee"] == pytest.approx(-1.4) and set(env.cfg.feet) == set(robot.feet)
    assert_stands(env)
    assert float(env.state.base_position[:, 2].min()) > 0.2


def test_bad_robots_are_refused_by_name():
    robot = envs.robots.ergocub_legs()
    with pytest.raises(ValueError, match=r"feet \['l_foot'\] are not links"):
        envs.LeggedRobot(description=robot.description, feet=("l_foot",), joints=robot.joints).model()
    with pytest.raises(ValueError, match=r"feet \['l_ankle_2'\] have no collision shape of the kinds \['sphere'\]"):
        envs.LeggedRobot(description=robot.description, feet=("l_ankle_2",), joints=robot.joints, contact_shapes=("sphere",)).model()
    with pytest.raises(ValueError, match="keyframe"):
        envs.LeggedRobot(description=robot.description, feet=robot.feet, joints=robot.joints, posture="stand").config()


ANYMAL_C_JOINTS = tuple(f"{leg}_{joint}" for leg in ("LF", "RF", "LH", "RH") for joint in ("HAA", "HFE", "KFE"))  # MuJoCo's order


def _one_warning(path) -> tuple:
    """(the float64 model of `path`, what its one warning lists): loading it warns once, a NotModelledWarning."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = wd.model.Model.build_from_model_description(path, dtype=np.float64)
    assert [w.category for w in caught] == [wd.model.NotModelledWarning], [str(w.message) for w in caught]
    return model, str(caught[0].message).split(" holds elements that warpdyn does not model: ")[1]


def test_mujoco_compiles_the_shipped_anymal_c_alone_and_warpdyn_names_what_it_does_not_model():
    """No mesh, texture, material, light or actuator, no frictionloss; Menagerie's 44 collision primitives (29 cylinders,
    11 boxes, 4 foot spheres) and its keyframe "standing". warpdyn (float64) warns once: the 12 joints' limits,
    the contacts between bodies (592 pairs, off), the multiCCD contacts of the 414 pairs with a cylinder (GJK and EPA's
    one contact instead) and the feet pairs' torsional and rolling friction (condim 6), nothing else; 13 links (the base, 4 hips, thighs, shanks), the feet
    spheres on the shanks."""
    m = mujoco.MjModel.from_xml_path(str(wd.assets.anymal_c_mjcf()))
    assert (m.nq, m.nv, m.nu, m.nmesh, m.ntex, m.nmat, m.nlight) == (19, 18, 0, 0, 0, 0, 0)
    assert [m.joint(j).name for j in range(1, m.njnt)] == list(ANYMAL_C_JOINTS)
    kinds = [mujoco.mjtGeom(int(t)).name for t in m.geom_type]
    assert [kinds.count(k) for k in ("mjGEOM_SPHERE", "mjGEOM_CYLINDER", "mjGEOM_BOX")] == [4, 29, 11] and m.ngeom == 44
    np.testing.assert_array_equal(m.dof_frictionloss, 0.0)
    np.testing.assert_array_equal(m.dof_damping[6:], 1.0)
    assert m.key("standing").qpos[2] == 0.56 and m.body_subtreemass[1] == pytest.approx(44.96518)
    model, listed = _one_warning(wd.assets.anymal_c_mjcf())
    torsion = ["142 geom pairs (e.g. geom19/geom0, condim 6)"]  # the feet's condim 6
    assert listed == f"{JOINT_LIMITS}: {list(ANYMAL_C_JOINTS)}; {BODY_CONTACTS}: ['592 geom pairs']; {TORSION}: {torsion}"
    assert model.floating_base() and model.number_of_links() == 13 and set(model.joint_names()) == set(ANYMAL_C_JOINTS)
    spheres = {model.link_names()[link] for link, shapes in enumerate(model.tree.collisions) for s in shapes if s.kind == "sphere"}
    assert spheres == set(wd.assets.ANYMAL_C_FEET)


@pytest.mark.parametrize("asset", [wd.assets.anymal_c_mjcf, wd.assets.go2_mjcf], ids=["anymal_c", "go2"])
def test_the_shipped_quadrupeds_equal_mujoco(asset):
    """M, h (qfrc_bias), passive forces (damping) and qacc (armature in M) at qpos0 and 5 random states, float64,
    relative to 1e-10 (mjcf_compare.compare_model, MuJoCo's constraints disabled); warpdyn starts at MuJoCo's qpos0."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(asset(), dtype=np.float64)
    errors = mjcf_compare.compare_model(model, mujoco.MjModel.from_xml_path(str(asset())), random_states=5, seed=3)
    assert all(errors[name] < 1e-10 for name in ("M", "h", "forces", "qacc")), errors
    assert errors["start"] == 0.0


@pytest.mark.filterwarnings("ignore::warpdyn.model.NotModelledWarning")  # the joint limits and body contacts, tested above
def test_the_anymal_c_preset_stands_on_its_foot_spheres():
    """Its contacts are the lower halves of the four foot spheres (9 of each sphere's 20 points, below its centre
    in the shank frame) and nothing else; its posture is the keyframe's, its standing height the keyframe's base
    height less the feet's 1.2 mm clearance (to the lowest point's 0.5 mm); with zero actions it stays standing for 1 s."""
    robot = envs.robots.anymal_c()
    env = robot.env(num_envs=8)
    cp = env.model.kin_dyn_parameters.contact_parameters
    links = env.model.link_names()
    feet = [links[b] in robot.feet for b in cp.body]
    assert all(feet) and len(feet) == 4 * 20  # sphere points only, on the feet
    assert list(cp.enabled) == [p[2] < -0.31547 for p in np.asarray(cp.point)]
    assert [sum(e for b, e in zip(cp.body, cp.enabled) if links[b] == foot) for foot in robot.feet] == [9, 9, 9, 9]
    assert env.cfg.default_joint_positions["LF_HFE"] == pytest.approx(np.pi / 6) and env.cfg.default_joint_positions["RH_KFE"] == pytest.approx(np.pi / 4)
    assert (env.cfg.kp, env.cfg.kd, env.cfg.torque_limit) == (80.0, 2.0, 80.0)
    assert env.standing_height == pytest.approx(0.56 - 0.0012254, abs=1e-3) and env.cfg.base_height_target == env.standing_height
    assert_stands(env)


GO2_JOINTS = tuple(f"{leg}_{joint}_joint" for leg in ("FL", "FR", "RL", "RR") for joint in ("hip", "thigh", "calf"))  # MuJoCo's order


def test_mujoco_compiles_the_shipped_go2_alone_and_warpdyn_names_what_it_does_not_model():
    """No mesh, material, light or actuator, no frictionloss; Menagerie's 23 collision primitives (5 spheres: the
    base's and the feet's; 13 cylinders, 5 boxes), its damping and armature, and its keyframe "home". warpdyn
    (float64) warns once: the 12 joints' limits, the contacts between bodies (210 pairs, off), the multiCCD contacts of
    the 118 pairs with a cylinder and the feet pairs' torsional and rolling friction (condim 6), nothing else; 13 links,
    the foot spheres on the calves."""
    m = mujoco.MjModel.from_xml_path(str(wd.assets.go2_mjcf()))
    assert (m.nq, m.nv, m.nu, m.nmesh, m.ntex, m.nmat, m.nlight) == (19, 18, 0, 0, 0, 0, 0)
    assert [m.joint(j).name for j in range(1, m.njnt)] == list(GO2_JOINTS)
    kinds = [mujoco.mjtGeom(int(t)).name for t in m.geom_type]
    assert [kinds.count(k) for k in ("mjGEOM_SPHERE", "mjGEOM_CYLINDER", "mjGEOM_BOX")] == [5, 13, 5] and m.ngeom == 23
    np.testing.assert_array_equal(m.dof_frictionloss, 0.0)
    np.testing.assert_array_equal(m.dof_damping[6:], 2.0)
    np.testing.assert_array_equal(m.dof_armature[6:], 0.01)
    assert m.key("home").qpos[2] == 0.27 and m.body_subtreemass[1] == pytest.approx(15.206408)
    model, listed = _one_warning(wd.assets.go2_mjcf())
    torsion = ["70 geom pairs (e.g. FL/geom0, condim 6)"]  # the feet's condim 6
    assert listed == f"{JOINT_LIMITS}: {list(GO2_JOINTS)}; {BODY_CONTACTS}: ['210 geom pairs']; {TORSION}: {torsion}"
    assert model.floating_base() and model.number_of_links() == 13 and set(model.joint_names()) == set(GO2_JOINTS)
    spheres = {model.link_names()[link] for link, shapes in enumerate(model.tree.collisions) for s in shapes if s.kind == "sphere"}
    assert spheres == {"base", *wd.assets.GO2_FEET}


@pytest.mark.filterwarnings("ignore::warpdyn.model.NotModelledWarning")  # the joint limits, tested above
def test_the_go2_preset_stands_on_its_foot_spheres():
    """Its contacts are the lower halves of the four foot spheres (9 of each sphere's 20 points, below its centre
    in the calf frame) and nothing else (the base's sphere has points, all disabled); its posture and gains are
    unitree_rl_gym's; with zero actions it stays standing for 1 s."""
    robot = envs.robots.go2()
    env = robot.env(num_envs=8)
    cp = env.model.kin_dyn_parameters.contact_parameters
    links = env.model.link_names()
    on_feet = np.array([links[b] in robot.feet for b in cp.body])
    assert on_feet.sum() == 4 * 20 and len(on_feet) == 5 * 20  # sphere points only: the feet's and the base's
    assert list(cp.enabled) == list(on_feet & (np.asarray(cp.point)[:, 2] < -0.213))
    assert [sum(e for b, e in zip(cp.body, cp.enabled) if links[b] == foot) for foot in robot.feet] == [9, 9, 9, 9]
    assert env.cfg.default_joint_positions == pytest.approx(wd.assets.GO2_STANDING_POSE)
    assert (env.cfg.kp, env.cfg.kd, env.cfg.torque_limit) == (20.0, 0.5, wd.assets.GO2_TORQUE_LIMITS)
    servo_range = env.model.actuator_force_range.numpy()[:, 1]  # the servos LeggedEnv added, one per joint, in joint order
    np.testing.assert_allclose(servo_range, [wd.assets.GO2_TORQUE_LIMITS[j] for j in env.model.joint_names()], rtol=1e-6)
    assert sorted(set(np.round(servo_range, 2))) == [23.7, 45.43]
    assert env.standing_height == pytest.approx(0.3227, abs=1e-3) and env.cfg.base_height_target == env.standing_height
    assert_stands(env)


def test_per_joint_torque_limits_clip_each_joint():
    """torque_limit {joint: N m}: under "torque" actions the named joint's torque is clipped at its limit, the others
    not; an unknown joint and a non-positive limit are refused by name."""
    legs = envs.robots.ergocub_legs()
    names = legs.model().joint_names()
    env = legs.env(num_envs=2, actuator="torque", action_scale=20.0, torque_limit={names[3]: 5.0})
    env.reset(seed=0)
    env.step(torch.ones(2, len(names)))
    torques = env.joint_torques
    assert torch.all(torques[:, 3] == 5.0) and torch.all(torques[:, [0, 1, 2, 4]] == 20.0)
    with pytest.raises(ValueError, match=r"torque_limit names joints \['knee'\]"):
        legs.env(num_envs=2, torque_limit={"knee": 5.0})
    with pytest.raises(ValueError, match="torque_limit must be a positive finite number"):
        envs.LeggedEnvConfig(torque_limit={names[0]: -1.0})


@pytest.mark.filterwarnings("ignore::warpdyn.model.NotModelledWarning")  # the joint limits and body contacts, tested above
def test_other_links_touch_with_their_box_corners():
    """LeggedRobot.other_links: the ANYmal C with its thighs besides its feet keeps the preset's foot points (the
    same positions, lower halves of the foot spheres) and adds each thigh box's 8 corners (the box's pose and size
    from the description); a link that is not the model's, or has no shape of those kinds, is refused by name, and a
    single name where a tuple of names belongs by the field's."""
    thighs = ("LF_THIGH", "RF_THIGH", "LH_THIGH", "RH_THIGH")
    preset = envs.robots.anymal_c()
    model = dataclasses.replace(preset, other_links=thighs).model()
    alone = preset.model()

    def enabled(m):
        cp = m.kin_dyn_parameters.contact_parameters
        return [(m.link_names()[b], tuple(np.round(p, 9))) for b, p, on in zip(cp.body, np.asarray(cp.point, dtype=np.float64), cp.enabled) if on]

    feet, others = enabled(alone), [e for e in enabled(model) if e[0] in thighs]
    assert sorted(e for e in enabled(model) if e[0] not in thighs) == sorted(feet) and len(feet) == 36
    for thigh in thighs:
        (box,) = [s for s in model.tree.collisions[model.link_names().index(thigh)] if s.kind == "box"]
        corners = np.array(np.meshgrid(*[[-h, h] for h in np.asarray(box.size) / 2], indexing="ij")).reshape(3, -1).T
        expected = corners @ box.link_H_shape[:3, :3].T + box.link_H_shape[:3, 3]
        mine = np.array([p for name, p in others if name == thigh])
        assert len(mine) == 8 and np.abs(mine[:, None, :] - expected[None, :, :]).max(axis=2).min(axis=1).max() < 1e-6
    with pytest.raises(ValueError, match=r"other_links \['knee'\] are not links of"):
        dataclasses.replace(preset, other_links=("knee",)).model()
    with pytest.raises(ValueError, match=r"other_links \['LF_HIP'\] have no collision shape of the kinds \['sphere', 'box'\]"):
        dataclasses.replace(preset, other_links=("LF_HIP",)).model()
    for field in ("feet", "other_links"):  # a name where a tuple of names belongs
        with pytest.raises(TypeError, match=f"LeggedRobot.{field} must be a tuple of names, got 'LF_THIGH'"):
            dataclasses.replace(preset, **{field: "LF_THIGH"})
