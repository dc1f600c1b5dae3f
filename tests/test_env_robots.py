"""warpdyn.envs.robots: `LeggedRobot` sets a legged robot up from its description and a few names; the presets
equal what examples/rl_locomotion.py built by hand before them (the same contact points, feet and settings); a robot
not among them is set up by docs/rl.md's "Your own robot" block, which this file runs as written, and stands."""

import pathlib
import re

import numpy as np
import pytest
import torch

import warpdyn as wd
import warpdyn.envs as envs

ROOT = pathlib.Path(__file__).resolve().parents[1]


@pytest.mark.filterwarnings("ignore::warpdyn.description.UnphysicalInertiaWarning")  # the Go1 URDF's massless base link
def test_the_presets_give_the_hand_built_models():
    """The Go1 preset's contacts are the lower halves of its foot spheres (20 points each), as the example chose them
    by the foot centre's height (wd.assets.GO1_FOOT_CENTRE); the ergoCub's are its foot boxes' corners, the default."""
    go1 = envs.robots.go1().model(device="cpu")
    hand = wd.model.Model.build_from_model_description(wd.assets.example_robot_data_urdf("go1"), device="cpu")
    hand = wd.contact.with_collidable_points(hand, options=wd.contact.CollidablePointsOptions(shapes=("sphere",), sphere_points=20))
    point = hand.kin_dyn_parameters.contact_parameters.point
    hand = wd.contact.with_collidable_points(hand, enabled=point[:, 2] < wd.assets.GO1_FOOT_CENTRE[2])
    assert go1.kin_dyn_parameters.contact_parameters.enabled == hand.kin_dyn_parameters.contact_parameters.enabled
    assert sum(go1.kin_dyn_parameters.contact_parameters.enabled) == 36
    legs = envs.robots.ergocub_legs()
    model = legs.model(device="cpu")
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), device="cpu")
    default = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    np.testing.assert_array_equal(np.asarray(model.kin_dyn_parameters.contact_parameters.point), np.asarray(default.kin_dyn_parameters.contact_parameters.point))
    assert all(model.kin_dyn_parameters.contact_parameters.enabled) and len(model.kin_dyn_parameters.contact_parameters.body) == 32
    cfg = envs.robots.go1().config(go1)
    assert cfg.kp == 20.0 and set(cfg.feet) == set(wd.assets.GO1_FEET) and cfg.feet == tuple(n for n in go1.link_names() if n in cfg.feet) and cfg.default_joint_positions == dict(wd.assets.GO1_STANDING_POSE)


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
    actions = torch.zeros(env.num_envs, env.single_action_space.shape[0], device=env.device)
    ended = torch.zeros(env.num_envs, dtype=torch.bool, device=env.device)
    for _ in range(int(1.0 / env.cfg.policy_dt)):
        _, _, terminated, _, _ = env.step(actions)
        ended |= terminated
    assert not ended.any()
    assert float(env.state.base_position[:, 2].min()) > 0.2


def test_bad_robots_are_refused_by_name():
    robot = envs.robots.ergocub_legs()
    with pytest.raises(ValueError, match=r"feet \['l_foot'\] are not links"):
        envs.LeggedRobot(description=robot.description, feet=("l_foot",), joints=robot.joints).model(device="cpu")
    with pytest.raises(ValueError, match=r"feet \['l_ankle_2'\] have no collision shape of the kinds \['sphere'\]"):
        envs.LeggedRobot(description=robot.description, feet=("l_ankle_2",), joints=robot.joints, contact_shapes=("sphere",)).model(device="cpu")
    with pytest.raises(ValueError, match="keyframe"):
        envs.LeggedRobot(description=robot.description, feet=robot.feet, joints=robot.joints, posture="stand").config()
