"""warpdyn.envs.PickCubeEnv (issue 37: a manipulation task): MuJoCo Playground's PandaPickCube on the shipped scene,
its resets, actions, rewards (recomputed from the JaxSim-style API), terminations, a scripted grasp through its
actions, and the Stepper's contact rows it reads. Few environments, on the tests' device."""

import argparse
import pathlib
import re
import sys

import mujoco
import numpy as np
import pytest
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.envs.manipulation import PickCubeConfig

N = 4


def _env(**cfg) -> envs.PickCubeEnv:
    return envs.PickCubeEnv(N, PickCubeConfig(**cfg), seed=1)


def _cube_and_target(env):
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    return q[:, env._cube : env._cube + 3], env.target


def test_resets_draw_cubes_and_targets_in_their_ranges():
    """reset(seed) gives (N, 66) float32 observations, the same for the same seed and others for another; each cube
    lies on the floor within 0.2 m (x, y) of the keyframe's, its target 0.2 to 0.4 m above the floor around it; the
    controls are the keyframe's."""
    env = _env()
    obs, _ = env.reset(seed=3)
    assert obs.shape == (N, 66) and obs.dtype == torch.float32 and torch.isfinite(obs).all()
    assert torch.equal(env.reset(seed=3)[0], obs) and not torch.equal(env.reset(seed=4)[0], obs)
    cube, target = _cube_and_target(env)
    home = env._home_cube
    assert bool(((cube[:, :2] - home[:2]).abs() <= 0.2).all()) and torch.allclose(cube[:, 2], home[2].expand(N))
    offset = target - home
    assert bool(((offset[:, :2].abs() <= 0.2).all(dim=1) & (offset[:, 2] >= 0.2) & (offset[:, 2] <= 0.4)).all())
    key = next(k for k in env.model.description.keyframes if k.name == "home")
    np.testing.assert_allclose(wp.to_torch(env.stepper.ctrl).cpu().numpy(), np.tile(key.ctrl, (N, 1)), atol=1e-6)


def test_actions_add_to_the_controls_within_their_ranges():
    """A step adds 0.04 times the actions (clipped to [-1, 1]) to the 8 controls, clipped to their ranges (the
    gripper's 0 to 0.04 m); actions of another shape are refused."""
    env = _env()
    env.reset(seed=0)
    before = wp.to_torch(env.stepper.ctrl).clone()
    actions = torch.tensor([[0.5, -2.0, 0.0, 1.0, -0.25, 0.0, 3.0, 1.0]] * N, device=env.device)
    env.step(actions)
    expected = torch.minimum(torch.maximum(before + 0.04 * actions.clamp(-1, 1).to(before.dtype), env._low), env._high)
    torch.testing.assert_close(wp.to_torch(env.stepper.ctrl), expected, rtol=0, atol=1e-6)
    assert float(wp.to_torch(env.stepper.ctrl)[0, 7]) == pytest.approx(0.04)  # the gripper at its range's top
    with pytest.raises(ValueError, match=r"actions has shape \(4, 7\); expected \(4, 8\)"):
        env.step(torch.zeros(N, 7))


def test_rewards_equal_playgrounds_terms_recomputed():
    """After random steps, each reward is Playground's sum of scaled terms, recomputed here from wd.frame.transform
    (the gripper site where MuJoCo's file puts it on the hand), wd.link.transform (the cube, turned 0.7 rad about the vertical
    so that its rotation error counts) and the joint positions (float32: 1e-4); the cube-to-target term counts where
    `reached` is set (here by hand in two environments)."""
    env = _env()
    env.reset(seed=0)
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    q[:, env._cube + 3 : env._cube + 7] = torch.tensor([np.cos(0.35), 0.0, 0.0, np.sin(0.35)], dtype=q.dtype, device=q.device)
    env.reached[:2] = True
    mj = mujoco.MjModel.from_xml_path(str(wd.assets.franka_panda_cube_mjcf()))
    assert mj.body(mj.site("gripper").bodyid[0]).name == "hand"
    site = torch.tensor(mj.site("gripper").pos, dtype=q.dtype, device=q.device)  # MuJoCo's gripper site in the hand's frame
    rng = np.random.default_rng(0)
    for _ in range(3):
        target = env.target.clone()
        reached = env.reached.clone()
        _, reward, terminated, _, info = env.step(torch.tensor(rng.uniform(-1, 1, (N, 8)), dtype=torch.float32))
        assert not terminated.any()
        data = env.stepper.data
        H_hand = wp.to_torch(wd.frame.transform(env.model, data, frame_index=wd.frame.name_to_idx(env.model, frame_name="hand")))
        gripper = H_hand[:, :3, 3] + H_hand[:, :3, :3] @ site
        H_cube = wp.to_torch(wd.link.transform(env.model, data, link_index=env.model.link_names().index("box")))
        cube, R = H_cube[:, :3, 3], H_cube[:, :3, :3]
        reach = (cube - gripper).norm(dim=1)
        reached = reached | (reach < 0.012)
        rotation = (torch.eye(3, dtype=R.dtype, device=R.device).reshape(9)[:6] - R.reshape(-1, 9)[:, :6]).norm(dim=1)
        q = wp.to_torch(data.joint_positions_state)
        arm = (q[:, env._arm] - env._home[env._arm]).norm(dim=1)
        expected = (4.0 * (1 - torch.tanh(5 * reach)) + 8.0 * (1 - torch.tanh(5 * (0.9 * (target - cube).norm(dim=1) + 0.1 * rotation))) * reached
                    + 0.25 * 1.0 + 0.3 * (1 - torch.tanh(arm)))  # fmt: skip (the hand stays off the floor here)
        torch.testing.assert_close(reward, expected.to(torch.float32), rtol=0, atol=1e-4)
        assert float(info["log"]["/reached"]) == float(reached.float().mean()) and float(reached.float().mean()) >= 0.5
        assert float(info["log"]["/success"]) == float(((target - cube).norm(dim=1) < 0.05).float().mean())


def test_a_scripted_grasp_through_the_actions_lifts_the_cube():
    """From the keyframe "pickup1" (the fingers around the cube), the cube where the keyframe has it: one action
    closes the gripper, 15 wait, then 10 raise joint 2's target by 0.4 rad and 8 lower joint 4's by 0.3 rad: the cube
    rises with the hand (above 0.2 m), held between the pads, and no episode ends."""
    env = _env(keyframe="pickup1", cube_range=0.0)
    env.reset(seed=0)
    plan = [(7, -1.0)] + [(None, 0.0)] * 15 + [(1, -1.0)] * 10 + [(3, 1.0)] * 8 + [(None, 0.0)] * 15
    for joint, value in plan:
        actions = torch.zeros(N, 8)
        if joint is not None:
            actions[:, joint] = value
        _, _, terminated, truncated, _ = env.step(actions)
        assert not (terminated | truncated).any()
    cube, _ = _cube_and_target(env)
    assert bool((cube[:, 2] > 0.2).all()), cube


def test_a_cube_out_of_bounds_ends_its_episode():
    """A cube moved 1.5 m away ends its environment's episode (terminated; the observation returned is the reset's,
    info['final_obs'] the last one); the others go on."""
    env = _env()
    env.reset(seed=0)
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    q[1, env._cube] = 1.5
    obs, _, terminated, truncated, info = env.step(torch.zeros(N, 8))
    assert terminated.tolist() == [False, True, False, False] and not truncated.any()
    assert bool(info["_final_obs"][1]) and not torch.equal(info["final_obs"][1], obs[1])
    cube, _ = _cube_and_target(env)
    assert float(cube[1].abs().max()) < 1.0  # reset


def test_bad_settings_and_models_are_refused():
    """Each bad setting names its field; a model of another scene is refused, naming what it lacks."""
    for kwargs, match in [
        (dict(time_step=-1.0), "PickCubeConfig.time_step must be a positive finite number"),
        (dict(implicit_contacts="yes"), "PickCubeConfig.implicit_contacts must be True or False"),
        (dict(policy_dt=0.02025), r"policy_dt \(0.02025 s\) must be a whole number of time_step"),
        (dict(rewards={"lift": 1.0}), "PickCubeConfig.rewards maps terms of"),
        (dict(target_low=(0, 0, 1), target_high=(0, 0, 0.5)), "target_low and target_high"),
    ]:
        with pytest.raises(ValueError, match=match):
            PickCubeConfig(**kwargs).validate()
    with pytest.warns(wd.model.NotModelledWarning, match="joint limits"):
        arm = wd.model.Model.build_from_model_description(wd.assets.franka_panda_mjcf())
    with pytest.raises(ValueError, match=r"PickCubeEnv simulates wd.assets.franka_panda_cube_mjcf\(\)'s scene: 'panda nohand' lacks \['box'"):
        envs.PickCubeEnv(2, model=arm)


def test_the_steppers_contact_rows_are_sorted_by_link():
    """Stepper.contact_wrenches' rows hold the enabled points by link (contact_point_links), which for the cube scene
    is not the description's order (model.kin_dyn_parameters.enabled_link: the cube, link 1, is described last):
    the env's hand rows are the points of link7 and the fingers, and the cube resting on the floor pushes on its
    own rows only."""
    env = _env()
    env.reset(seed=0)
    env.step(torch.zeros(N, 8))
    described = env.model.kin_dyn_structure().enabled_link.numpy()
    links = env.stepper.contact_point_links
    np.testing.assert_array_equal(links, np.sort(described, kind="stable"))
    assert not np.array_equal(links, described)
    names = env.model.link_names()
    assert {names[i] for i in links[env._hand_points.cpu().numpy()]} == {"link7", "left_finger", "right_finger"}
    pushing = np.flatnonzero(wp.to_torch(env.stepper.contact_wrenches)[0, :, 2].cpu().numpy() > 0.0)
    assert pushing.size and {names[i] for i in links[pushing]} == {"box"}


def test_the_example_trains_and_evaluates(tmp_path, capsys):
    """examples/rl_manipulation.py on 8 environments: 2 PPO iterations (each line printing the reached and success
    fractions), its policy saved and evaluated in 8 fresh environments (the success rate a fraction)."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_manipulation

    device = str(wp.get_device())
    history = rl_manipulation.main(["--device", device, "--num-envs", "8", "--iterations", "2", "--evaluate", "--evaluate-envs", "8", "--out", str(tmp_path)])
    assert len(history) == 2 and (tmp_path / "policy.pt").is_file()
    lines = [line for line in capsys.readouterr().out.splitlines() if line.startswith("iteration")]
    assert len(lines) == 2 and all(re.search(r"reached \d\.\d{3}  success \d\.\d{3}  reward/box_target \d\.\d{3}$", line) for line in lines), lines
    result = rl_manipulation.evaluate(tmp_path / "policy.pt", wp.get_device(), seed=5, num_envs=8)
    assert result["environments"] == 8 and 0.0 <= result["success"] <= 1.0 and np.isfinite(result["distance"])


def test_a_beta_policy_acts_within_the_range_and_reloads(tmp_path):
    """The example's default policy, a Beta (rsl-rl's, rescaled to [-1, 1]: a Gaussian's mean drifted to +13 to +18 on
    the gripper in a 3-minute H200 run, past the environment's clip, and never closed it): one PPO iteration; the
    checkpoint names its distribution, which `load_policy` reads back, and the deterministic policy's actions lie
    within [-1, 1] (a Beta's samples do by construction); an unknown distribution is refused."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_locomotion
    import rl_manipulation

    rl_manipulation.main(["--device", str(wp.get_device()), "--num-envs", "4", "--iterations", "1", "--out", str(tmp_path)])
    assert torch.load(tmp_path / "policy.pt", weights_only=False)["infos"] == {"action_distribution": "beta", "hidden_dims": [256, 128, 64], "schedule": "adaptive"}
    vec, policy = rl_locomotion.load_policy(envs.PickCubeEnv(4, seed=2), tmp_path / "policy.pt")
    obs = vec.get_observations()
    with torch.no_grad():
        assert float(policy(obs).abs().max()) <= 1.0
    with pytest.raises(ValueError, match="action distribution is one of"):
        rl_locomotion.train_config(1, "tanh")
    assert [rl_locomotion.train_config(1, schedule=s)["algorithm"]["schedule"] for s in ("adaptive", "fixed")] == ["adaptive", "fixed"]
    with pytest.raises(ValueError, match=r"learning-rate schedule is one of \['adaptive', 'fixed'\], got 'cosine'"):
        rl_locomotion.train_config(1, "beta", schedule="cosine")


def test_a_run_resumes_from_its_checkpoint(tmp_path, capsys):
    """--resume (a long run split over several processes): the second run's iterations are numbered on from the
    checkpoint's, and so is its own checkpoint; `train` for 0 iterations from a checkpoint saves it back unchanged
    (models, normalisers, optimizer state, learning rate); a checkpoint of another action distribution is refused."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_locomotion
    import rl_manipulation

    device = str(wp.get_device())
    rl_manipulation.main(["--device", device, "--num-envs", "4", "--iterations", "1", "--out", str(tmp_path / "a")])
    capsys.readouterr()
    rl_manipulation.main(["--device", device, "--num-envs", "4", "--iterations", "2", "--resume", str(tmp_path / "a" / "policy.pt"), "--out", str(tmp_path / "b")])
    assert re.findall(r"^iteration\s+(\d+)", capsys.readouterr().out, re.M) == ["1", "2"]
    first, second = (torch.load(tmp_path / x / "policy.pt", weights_only=False) for x in ("a", "b"))
    assert (first["iter"], second["iter"]) == (0, 2)
    env = envs.PickCubeEnv(4, seed=3)
    assert rl_locomotion.train(env, 0, tmp_path / "c", str(env.device), distribution="beta", resume=tmp_path / "b" / "policy.pt") == []
    again = torch.load(tmp_path / "c" / "policy.pt", weights_only=False)
    assert again["iter"] == 2
    for key in ("actor_state_dict", "critic_state_dict"):
        for name, value in second[key].items():
            torch.testing.assert_close(again[key][name], value, rtol=0, atol=0)
    assert again["optimizer_state_dict"]["param_groups"][0]["lr"] == second["optimizer_state_dict"]["param_groups"][0]["lr"]
    for k, state in second["optimizer_state_dict"]["state"].items():
        torch.testing.assert_close(again["optimizer_state_dict"]["state"][k]["exp_avg"], state["exp_avg"], rtol=0, atol=0)
    with pytest.raises(ValueError, match=r"its policy is beta, not the --action-distribution gaussian asked for"):
        rl_locomotion.train(env, 1, tmp_path / "d", str(env.device), resume=tmp_path / "b" / "policy.pt")
    with pytest.raises(ValueError, match=r"its networks' layers are \(256, 128, 64\), not the --hidden-dims \(64, 32\) asked for"):
        rl_locomotion.train(env, 1, tmp_path / "d", str(env.device), distribution="beta", resume=tmp_path / "b" / "policy.pt", hidden_dims=(64, 32))


def test_other_networks_are_saved_and_reloaded(tmp_path):
    """--hidden-dims: the actor's layers as asked, named in the checkpoint's infos, from which `load_policy` builds
    the same networks (a checkpoint of other layers would not load into the default ones) and a --resume without
    --hidden-dims takes them; bad widths are refused."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_locomotion
    import rl_manipulation

    rl_manipulation.main(["--device", str(wp.get_device()), "--num-envs", "4", "--iterations", "1", "--hidden-dims", "32,16", "--out", str(tmp_path)])
    saved = torch.load(tmp_path / "policy.pt", weights_only=False)
    assert saved["infos"]["hidden_dims"] == [32, 16] and tuple(saved["actor_state_dict"]["mlp.0.weight"].shape)[0] == 32
    vec, policy = rl_locomotion.load_policy(envs.PickCubeEnv(4, seed=2), tmp_path / "policy.pt")
    with torch.no_grad():
        assert policy(vec.get_observations()).shape == (4, 8)
    rl_manipulation.main(["--device", str(wp.get_device()), "--num-envs", "4", "--iterations", "1", "--resume", str(tmp_path / "policy.pt"), "--out", str(tmp_path / "b")])
    assert torch.load(tmp_path / "b" / "policy.pt", weights_only=False)["infos"]["hidden_dims"] == [32, 16]
    for bad in ("0", "32,x", "", "32,-1"):
        with pytest.raises(argparse.ArgumentTypeError, match="comma-separated positive layer widths"):
            rl_locomotion.layer_widths(bad)
    for bad in ((32, 0), (32.5,), (True,), ()):
        with pytest.raises(ValueError, match="hidden_dims must be positive integer layer widths"):
            rl_locomotion.train_config(1, hidden_dims=bad)


@pytest.mark.parametrize("schedule", ["adaptive", "fixed"])
def test_a_resume_with_a_fixed_schedule_takes_the_rate_asked_for(tmp_path, schedule):
    """A checkpoint whose adaptive schedule cut its rate (0.05 with KLs beyond 0.02): resumed for 0 iterations with
    --schedule fixed, the saved rate is the one asked for; with adaptive, the checkpoint's (as rsl-rl resumes)."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_manipulation

    device = str(wp.get_device())
    rl_manipulation.main(["--device", device, "--num-envs", "4", "--iterations", "1", "--learning-rate", "0.05", "--out", str(tmp_path / "a")])
    cut = float(torch.load(tmp_path / "a" / "policy.pt", weights_only=False)["optimizer_state_dict"]["param_groups"][0]["lr"])
    assert cut < 0.05 * (1 - 1e-6)
    rl_manipulation.main(["--device", device, "--num-envs", "4", "--iterations", "0", "--learning-rate", "0.05", "--schedule", schedule,
                          "--resume", str(tmp_path / "a" / "policy.pt"), "--out", str(tmp_path / "b")])  # fmt: skip
    saved = torch.load(tmp_path / "b" / "policy.pt", weights_only=False)
    rate = float(saved["optimizer_state_dict"]["param_groups"][0]["lr"])
    assert rate == pytest.approx(0.05 if schedule == "fixed" else cut, rel=1e-6) and saved["infos"]["schedule"] == schedule


def test_the_command_line_reaches_train(monkeypatch, tmp_path):
    """rl_reorient.py's flags reach `train` (recorded by a stand-in): --schedule, --hidden-dims,
    --random-episode-start, and the defaults Beta, fixed, the checkpoint's or HIDDEN_DIMS (None), no random start."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_locomotion
    import rl_reorient

    calls = []
    monkeypatch.setattr(rl_locomotion, "train", lambda *args, **kwargs: calls.append(kwargs) or [])
    common = ["--device", str(wp.get_device()), "--num-envs", "2", "--iterations", "0", "--out", str(tmp_path)]
    rl_reorient.main(common)
    rl_reorient.main([*common, "--schedule", "adaptive", "--hidden-dims", "64,32", "--random-episode-start", "--action-distribution", "gaussian"])
    picked = [{k: c[k] for k in ("distribution", "schedule", "hidden_dims", "random_episode_start")} for c in calls]
    assert picked == [dict(distribution="beta", schedule="fixed", hidden_dims=None, random_episode_start=False),
                      dict(distribution="gaussian", schedule="adaptive", hidden_dims=(64, 32), random_episode_start=True)]  # fmt: skip


@pytest.mark.parametrize("random_start", [False, True])
def test_episodes_can_start_at_random_points(tmp_path, random_start):
    """`train`'s random_episode_start (--random-episode-start; rsl-rl's init_at_random_ep_len): the episode counters
    start uniformly in [0, max_episode_length), so episodes end apart (on a resume too: a run in parts restarted its
    episodes together at each part); without it every counter moves in step."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_locomotion

    env = envs.PickCubeEnv(16, seed=4)
    ppo = {"steps_per_env": 2, "epochs": 1, "mini_batches": 1}
    rl_locomotion.train(env, 1, tmp_path, str(env.device), ppo=ppo, distribution="beta")
    resumed = envs.PickCubeEnv(16, seed=5)
    rl_locomotion.train(resumed, 1, tmp_path / "b", str(env.device), ppo=ppo, distribution="beta", resume=tmp_path / "policy.pt", random_episode_start=random_start)
    counters = resumed.episode_length_buf.cpu()
    assert int(counters.max()) < resumed.max_episode_length
    if random_start:
        assert len(set(counters.tolist())) > 8
    else:
        assert counters.tolist() == [2] * 16


@pytest.mark.skipif(not wp.get_device().is_cuda, reason="CUDA graphs: the tests' device is not a GPU")
def test_graph_replays_equal_eager_steps():
    """use_graph=True captures a whole step (actions, 20 simulation steps, the gripper's kinematics, rewards, resets)
    and its replays give what eager steps give, bitwise, through a reset() between replays and episodes that end."""
    cfg = PickCubeConfig(episode_seconds=0.1)
    graphed, eager = (envs.PickCubeEnv(8, cfg, seed=3, use_graph=mode) for mode in (True, False))
    actions = torch.tensor(np.random.default_rng(0).uniform(-1, 1, (12, 8, 8)), dtype=torch.float32, device=graphed.device)
    for env in (graphed, eager):
        env.reset(seed=3)
    for k in range(12):
        if k == 7:
            assert torch.equal(graphed.reset(seed=5)[0], eager.reset(seed=5)[0])
        a, b = graphed.step(actions[k]), eager.step(actions[k])
        for x, y in zip(a[:4], b[:4]):
            assert torch.equal(x, y), k
        assert torch.equal(a[4]["final_obs"], b[4]["final_obs"]) and torch.equal(graphed.cube_position, eager.cube_position)
        assert all(torch.equal(a[4]["log"][name], b[4]["log"][name]) for name in a[4]["log"])
    assert graphed._program.captured == (1 if graphed.stepper.substeps % 2 == 0 else 2) and not eager._program.captured


def _press_on_the_edge(m, d) -> tuple[np.ndarray, list]:
    """(the cube's position (3,) [m], the controls (8,) of each policy step): from the keyframe "home", the cube on the
    floor half under the left fingertip pad and the hand lowered 0.30 m, its orientation kept (MuJoCo's site Jacobian,
    damped least squares), controls stepping at most 0.03 rad per policy step then held for 10 steps: the pad lands on
    the cube's top edge and presses on it."""
    mujoco.mj_resetDataKeyframe(m, d, m.key("home").id)
    mujoco.mj_forward(m, d)
    site = m.site("gripper").id
    cube = d.geom_xpos[m.geom("left_finger_pad").id] + np.array([0.0, 0.02, 0.0])
    cube[2] = 0.03
    goal_p, goal_R = d.site_xpos[site] - np.array([0.0, 0.0, 0.30]), d.site_xmat[site].reshape(3, 3).copy()
    k = mujoco.MjData(m)
    k.qpos[:] = d.qpos
    for _ in range(100):
        mujoco.mj_kinematics(m, k)
        mujoco.mj_comPos(m, k)
        jp, jr = np.zeros((3, m.nv)), np.zeros((3, m.nv))
        mujoco.mj_jacSite(m, k, jp, jr, site)
        R = k.site_xmat[site].reshape(3, 3)
        error = np.concatenate([goal_p - k.site_xpos[site], 0.5 * sum(np.cross(R[:, i], goal_R[:, i]) for i in range(3))])
        J = np.vstack([jp, jr])[:, :7]
        k.qpos[:7] += J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(6), error)
    target = d.ctrl.copy()
    target[:7] = k.qpos[:7]
    steps = int(np.ceil(np.abs(target - d.ctrl).max() / 0.03))
    return cube, [d.ctrl + (target - d.ctrl) * min(1.0, (t + 1) / steps) for t in range(steps + 10)]


def test_a_pad_pressing_on_the_cubes_edge_leaves_it_near_mujocos():
    """A fingertip pad lands on the cube's top edge and presses on it (`_press_on_the_edge`, 0.62 s), as a policy's
    approaches do, beside MuJoCo (the file's 1 ms, implicit contacts): MuJoCo's cube moves 1.3 mm and turns at 2.3
    rad/s at most. With PickCubeConfig's 2 ms steps, D = 2000 and implicit contacts warpdyn's moves 1.4 mm and turns at
    up to 2.2 rad/s (measured; 1.5 mm and 6.4 rad/s at 1 ms, D = 500); explicit, at 0.5 ms it moved 11 mm with a 62 rad/s burst (near the explicit step's stable
    rate of the light cube's off-centre contacts), at 1 ms it spun at 860 rad/s and was thrown 0.23 m, unflagged (the
    damper check counts translations only). Bounds: MuJoCo's (5 mm moved, 5 rad/s), 3 mm moved for warpdyn's."""
    m = mujoco.MjModel.from_xml_path(str(wd.assets.franka_panda_cube_mjcf()))
    d = mujoco.MjData(m)
    cube, ctrls = _press_on_the_edge(m, d)
    d.qpos[9:12] = cube
    mujoco.mj_forward(m, d)
    mj_spin = 0.0
    for c in ctrls:
        d.ctrl[:] = c
        for _ in range(20):
            mujoco.mj_step(m, d)
        mj_spin = max(mj_spin, float(np.linalg.norm(d.qvel[12:15])))
    mj_moved = float(np.linalg.norm(d.qpos[9:12] - cube))
    env = envs.PickCubeEnv(1, PickCubeConfig(), dtype=np.float64, seed=0)
    env.reset(seed=0)
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    q[0, env._cube : env._cube + 3] = torch.tensor(cube, dtype=q.dtype, device=q.device)
    spin = 0.0
    for c in ctrls:
        env.step(((torch.tensor(c, device=env.device) - env._ctrl[0]) / 0.04).clamp(-1.0, 1.0)[None])
        spin = max(spin, float(wp.to_torch(env.stepper.data.joint_velocities_state)[0, 3:6].norm()))
    state = env._state_views[id(env.stepper.data)]
    moved = float((state["joint_positions"][0, env._cube : env._cube + 3].cpu() - torch.tensor(cube)).norm())
    assert mj_moved < 5e-3 and mj_spin < 5.0  # the reference: MuJoCo's cube nudged
    assert int(state["valid"][0]) == 1 and moved < 3e-3 and spin < 5.0, (moved, spin)



_BAD_SIZES = [
    (["--num-envs", "0"], "--num-envs must be a positive number"),
    (["--iterations", "-1"], "--iterations must be >= 0"),
    (["--max-minutes", "0"], "--max-minutes must be a positive number"),
    (["--max-minutes", "nan"], "--max-minutes must be a positive number"),
    (["--resume", "no/such/policy.pt"], "--resume no/such/policy.pt: no such file"),
]
BAD_RUN_ARGUMENTS = (
    [(example, argv, message) for example in ("rl_manipulation", "rl_reorient", "rl_locomotion") for argv, message in _BAD_SIZES]
    + [(example, ["--evaluate-envs", "0"], "--evaluate-envs must be a positive number") for example in ("rl_manipulation", "rl_reorient")]
    + [("rl_reorient", ["--evaluate-seconds", "-5"], "--evaluate-seconds must be a positive")]
    + [("rl_reorient", ["--time-step", "0.003"], "must be a whole number of time_step"), ("rl_reorient", ["--time-step", "0"], "time_step must be a positive")]
    + [("rl_locomotion", ["--replay", "no/such/policy.pt"], "--replay no/such/policy.pt: no such file")]
)
"""(example, its flags, the error's words): rl_locomotion.py has no --evaluate-envs, only rl_reorient.py --evaluate-seconds
and only rl_locomotion.py --replay."""


@pytest.mark.parametrize("example, argv, message", BAD_RUN_ARGUMENTS)
def test_the_examples_refuse_a_bad_run_argument(example, argv, message, capsys, tmp_path):
    """A run's sizes are refused naming the flag, before anything is built: --num-envs 0 once meant the default
    (silently), --iterations -1 saved an untrained policy, --max-minutes 0 stopped after one iteration."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    module = __import__(example)
    with pytest.raises(SystemExit) as raised:
        module.main([*argv, "--device", str(wp.get_device()), "--out", str(tmp_path)])
    assert raised.value.code == 2 and message in capsys.readouterr().err
