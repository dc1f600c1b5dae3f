"""warpdyn.envs.CubeReorientEnv (issue 37: a dexterous hand): MuJoCo Playground's LeapCubeReorient on the shipped
LEAP hand scene, its resets (a bank of non-penetrating draws), actions, observations, rewards (recomputed with
NumPy and MuJoCo's actuator forces), goal updates and termination, and the example's training on the CPU. Few
environments, small reset banks, on the tests' device."""

import pathlib
import sys

import mujoco
import numpy as np
import pytest
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.envs.reorient import CubeReorientConfig

N = 4


def _env(**cfg) -> envs.CubeReorientEnv:
    return envs.CubeReorientEnv(N, CubeReorientConfig(reset_bank=32, **cfg), dtype=np.float64, seed=1)


def _quat_mul(p, q):
    w1, v1, w2, v2 = p[0], p[1:], q[0], q[1:]
    return np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def test_resets_draw_from_a_bank_of_states_that_do_not_interpenetrate():
    """reset(seed) gives (N, 57) float32 observations and (N, 116) critic observations, the same for the same seed;
    the reset states come from the bank, whose boxes penetrate by at most reset_depth, the targets at the hand's
    joints; the goals are unit quaternions."""
    env = _env()
    obs, info = env.reset(seed=3)
    assert obs.shape == (N, 57) and obs.dtype == torch.float32 and info["critic_obs"].shape == (N, 116) and torch.isfinite(info["critic_obs"]).all()
    again, _ = env.reset(seed=3)
    assert torch.equal(again, obs)
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    assert all(bool((env._bank == q[e]).all(dim=1).any()) for e in range(N))
    torch.testing.assert_close(env._ctrl, q[:, env._q])
    torch.testing.assert_close(env.goal.norm(dim=1), torch.ones(N, dtype=env.goal.dtype, device=env.device))
    data = wd.data.keyframe(env.model, "home", num_envs=env._bank.shape[0])
    wp.to_torch(data.joint_positions_state).copy_(env._bank)
    assert wd.contact.geom_contacts(env.model, data).distance.numpy().min() >= -env.cfg.reset_depth
    cube = env._bank[:, env._cube_q : env._cube_q + 3].cpu().numpy()
    assert np.all(np.abs(cube - np.array(env.cfg.cube_start)) <= env.cfg.cube_range + 1e-12)
    raw = wd.data.keyframe(env.model, "home", num_envs=256)  # why a bank: most of Playground's draws interpenetrate
    wp.to_torch(raw.joint_positions_state).copy_(env._draws(256))
    deepest = wd.contact.geom_contacts(env.model, raw).distance.numpy().min(axis=1)
    assert np.mean(deepest < -2e-3) > 0.6 and deepest.min() < -0.015  # measured: 0.79 deeper than 2 mm, down to 3 cm


def test_actions_add_to_the_targets_within_their_ranges():
    """A step adds 0.5 times the actions (clipped to [-1, 1], NaN as 0) to the 16 targets, clipped to the joints'
    ranges; actions of another shape are refused."""
    env = _env()
    env.reset(seed=0)
    before = env._ctrl.clone()
    actions = torch.zeros(N, 16, device=env.device)
    actions[:, 0], actions[:, 1], actions[:, 2] = 3.0, float("nan"), -0.25
    env.step(actions)
    expected = torch.minimum(torch.maximum(before + 0.5 * actions.nan_to_num(0.0).clamp(-1, 1).to(before.dtype), env._low), env._high)
    torch.testing.assert_close(env._ctrl, expected, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match=r"actions has shape \(4, 8\); expected \(4, 16\)"):
        env.step(torch.zeros(N, 8))


def test_rewards_equal_playgrounds_terms_recomputed():
    """After a step, each term recomputed from the state with NumPy as Playground writes it (the orientation error
    2 asin |vec(q goal^-1)|, dm_control's linear tolerance, the palm's grasp site from MuJoCo, the actuators' forces
    from MuJoCo's actuator_force at the same state and targets, as Playground reads them: not clamped by the joints'
    actuatorfrcrange), and the reward their scaled sum times policy_dt."""
    env = _env(noise={"joint_pos": 0.0, "cube_pos": 0.0, "cube_ori": 0.0})
    env.reset(seed=2)
    actions = torch.linspace(-1.0, 1.0, 16 * N, device=env.device).reshape(N, 16)
    env.step(actions)
    last = actions.clone()
    actions = actions.flip(1)
    _, reward, _, _, info = env.step(actions)
    m = mujoco.MjModel.from_xml_path(str(wd.assets.leap_hand_cube_mjcf()))
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    palm = d.site_xpos[m.site("grasp_site").id].copy()  # on the mount, fixed to the world
    q = wp.to_torch(env.stepper.data.joint_positions_state).cpu().numpy()
    u = wp.to_torch(env.stepper.data.joint_velocities_state).cpu().numpy()
    goal, ctrl = env.goal.cpu().numpy(), env._ctrl.cpu().numpy()
    hand_q, hand_v = env._q.cpu().numpy(), env._v.cpu().numpy()
    home = np.array(m.key("home").qpos[:16])
    a, a1 = actions.cpu().numpy(), last.cpu().numpy()
    scales, logged = env.cfg.rewards, {name: 0.0 for name in scales_names()}
    for e in range(N):
        cube, quat = q[e, env._cube_q : env._cube_q + 3], q[e, env._cube_q + 3 : env._cube_q + 7] / np.linalg.norm(q[e, env._cube_q + 3 : env._cube_q + 7])
        diff = _quat_mul(quat, goal[e] * [1, -1, -1, -1])
        angle = 2.0 * np.arcsin(min(1.0, np.linalg.norm(diff[1:] / np.linalg.norm(diff))))
        d.qpos[:16], d.qvel[:16], d.ctrl[:] = q[e, hand_q], u[e, hand_v], ctrl[e]
        d.qpos[16:19], d.qpos[19:23] = cube, quat
        mujoco.mj_forward(m, d)
        terms = {
            "orientation": max(0.0, 1.0 - 0.9 * max(0.0, angle - 0.2) / np.pi),
            "position": max(0.0, 1.0 - 0.9 * max(0.0, np.linalg.norm(palm - cube) - 0.02) / 0.05),
            "termination": float(cube[2] < -0.05),
            "hand_pose": float(np.sum((q[e, hand_q] - home) ** 2)),
            "action_rate": float(np.sum((a[e] - a1[e]) ** 2) + np.sum((a[e] - 2 * a1[e]) ** 2)),
            "joint_velocity": float(np.sum((u[e, hand_v] / 4.0) ** 2)),
            "energy": float(np.sum(np.abs(u[e, hand_v]) * np.abs(d.actuator_force))),  # Playground's: unclamped by actuatorfrcrange
        }
        for name, value in terms.items():
            logged[name] += value / N
        obs, critic = info["critic_obs"][e, :57].cpu().numpy(), info["critic_obs"][e, 57:].cpu().numpy()  # noise off: exact
        tips = np.concatenate([d.site_xpos[m.site(t).id] - palm for t in ("th_tip", "if_tip", "mf_tip", "rf_tip")])
        np.testing.assert_allclose(obs[:16], q[e, hand_q], atol=1e-6)
        np.testing.assert_allclose(obs[16:32], q[e, hand_q] - ctrl[e], atol=1e-6)
        np.testing.assert_allclose(obs[32:35], palm - cube, atol=1e-6)
        np.testing.assert_allclose(obs[41:], a[e], atol=1e-6)
        np.testing.assert_allclose(critic[32:44], tips, atol=1e-6)  # MuJoCo's fingertip sites from the grasp site
        expected = sum(scales[k] * v for k, v in terms.items()) * env.cfg.policy_dt + 100.0 * (angle < 0.1)
        assert float(reward[e]) == pytest.approx(expected, rel=1e-5, abs=1e-5), (e, terms)
    for name, value in logged.items():  # info["log"]: the terms' means
        assert float(info["log"][f"/reward/{name}"]) == pytest.approx(value, rel=1e-5, abs=1e-7), name


def scales_names() -> tuple:
    return tuple(CubeReorientConfig().rewards)


def test_a_success_pays_and_turns_the_goal():
    """Where the cube's orientation is within 0.1 rad of the goal the step pays success_reward, counts a success and
    the goal starts turning at 1 to 5 rad/s about each axis; the rate decays by 0.8 a step after."""
    env = _env()
    env.reset(seed=4)
    for _ in range(20):  # the cube settles in the palm
        env.step(torch.zeros(N, 16, device=env.device))
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    env.goal.copy_(q[:, env._cube_q + 3 : env._cube_q + 7])  # the goal is where the cube is
    _, reward, _, _, _ = env.step(torch.zeros(N, 16, device=env.device))
    assert bool((reward > 90.0).all()) and bool((env.successes == 1).all())
    rate = env._goal_rate.clone()
    assert bool(((rate >= 1.0) & (rate <= 5.0)).all())
    env.step(torch.zeros(N, 16, device=env.device))
    turned = env.successes == 1  # no second success: the goal moved away
    torch.testing.assert_close(env._goal_rate[turned], 0.8 * rate[turned])


def test_a_dropped_cube_ends_its_episode():
    """The cube below z = -0.05 m ends the episode (terminated, the termination term paid) and resets it."""
    env = _env()
    env.reset(seed=5)
    q = wp.to_torch(env.stepper.data.joint_positions_state)
    q[0, env._cube_q : env._cube_q + 3] = torch.tensor([0.3, 0.0, -0.2], dtype=q.dtype, device=q.device)
    _, reward, terminated, truncated, info = env.step(torch.zeros(N, 16, device=env.device))
    assert terminated.tolist() == [True, False, False, False] and not truncated.any()
    assert float(reward[0]) < -100.0 * env.cfg.policy_dt + 1.0 and bool(info["_final_obs"][0])
    assert float(wp.to_torch(env.stepper.data.joint_positions_state)[0, env._cube_q + 2]) > 0.0  # reset from the bank



def test_smooth_random_actions_at_2ms_keep_the_cube_in_hand():
    """32 hands at 2 ms, D = 2000, implicit contacts (the config's defaults), 2 s of smooth random actions: every
    environment healthy and the cube never faster than 3 m/s. Before a linearly implicit step's friction was
    backward-Euler (kernels/implicit_contacts.py), this ran away within 0.15 s: a corner hitting the palm took 4 m/s
    sideways from friction bounded by the impact's damper spike (92 m/s at the third policy step, 65 km/s later)."""
    N32 = 32
    env = envs.CubeReorientEnv(N32, CubeReorientConfig(time_step=0.002, contact_damping=2000.0, episode_seconds=1e3), seed=3)
    env.reset(seed=3)
    generator = torch.Generator().manual_seed(0)
    actions, fastest = torch.zeros(N32, 16), 0.0
    for _ in range(40):
        actions = 0.8 * actions + 0.2 * (2 * torch.rand(N32, 16, generator=generator) - 1)
        env.step(actions.to(env.device))
        fastest = max(fastest, float(env._state()[4][:, :3].norm(dim=1).max()))
    assert int(wp.to_torch(env.stepper.data.valid_state).sum()) == N32 and fastest < 3.0, fastest

def test_bad_settings_and_models_are_refused():
    """Each bad setting is a ValueError naming it; another scene is refused, naming what it lacks."""
    for kwargs, match in [
        (dict(time_step=0.0), "CubeReorientConfig.time_step must be a positive finite number"),
        (dict(policy_dt=0.0502), r"policy_dt \(0.0502 s\) must be a whole number of time_step"),
        (dict(reset_bank=0), "CubeReorientConfig.reset_bank must be a positive integer"),
        (dict(implicit_contacts=1), "CubeReorientConfig.implicit_contacts must be True or False"),
        (dict(noise={"joint_pos": 0.1}), "CubeReorientConfig.noise maps joint_pos, cube_pos and cube_ori"),
        (dict(rewards={"speed": 1.0}), r"CubeReorientConfig.rewards maps terms of \['orientation'"),
        (dict(cube_start=(0.1, 0.0)), "CubeReorientConfig.cube_start must be 3 finite numbers"),
    ]:
        with pytest.raises(ValueError, match=match):
            envs.CubeReorientEnv(1, CubeReorientConfig(**kwargs))
    with pytest.raises(ValueError, match=r"0 of 102400 drawn resets penetrate by at most reset_depth = 0.0 m; 32 are needed"):
        envs.CubeReorientEnv(1, CubeReorientConfig(reset_bank=32, reset_depth=0.0, cube_start=(0.1, 0.0, 0.0)))  # the cube in the palm
    with pytest.warns(wd.model.NotModelledWarning):
        panda = wd.model.Model.build_from_model_description(wd.assets.franka_panda_cube_mjcf())
    with pytest.raises(ValueError, match=r"CubeReorientEnv simulates wd.assets.leap_hand_cube_mjcf\(\)'s scene: 'panda cube' lacks \['cube'"):
        envs.CubeReorientEnv(1, model=panda)


@pytest.mark.skipif(not wp.get_device().is_cuda, reason="CUDA graphs: the tests' device is not a GPU")
def test_graph_replays_equal_eager_steps():
    """use_graph=True captures a whole step (actions, 100 simulation steps with the 325 pairs' contacts, the
    fingertips' kinematics, noise, rewards, goal updates, resets from the bank) and its replays give what eager steps
    give, bitwise, through a reset() between replays and episodes that end."""
    cfg = CubeReorientConfig(episode_seconds=0.2, reset_bank=32)
    graphed, eager = (envs.CubeReorientEnv(4, cfg, seed=3, use_graph=mode) for mode in (True, False))
    actions = torch.tensor(np.random.default_rng(0).uniform(-1, 1, (10, 4, 16)), dtype=torch.float32, device=graphed.device)
    for env in (graphed, eager):
        env.reset(seed=3)
    for k in range(10):
        if k == 6:
            assert torch.equal(graphed.reset(seed=5)[0], eager.reset(seed=5)[0])
        a, b = graphed.step(actions[k]), eager.step(actions[k])
        for x, y in zip(a[:4], b[:4]):
            assert torch.equal(x, y), k
        for name in ("final_obs", "critic_obs", "final_critic_obs"):
            assert torch.equal(a[4][name], b[4][name]), (k, name)
        assert torch.equal(graphed.goal, eager.goal) and all(torch.equal(a[4]["log"][n], b[4]["log"][n]) for n in a[4]["log"])
    assert graphed._program.captured >= 1 and not eager._program.captured


def test_the_example_trains_and_evaluates(tmp_path, capsys):
    """examples/rl_reorient.py: one short iteration and an evaluation run, on the tests' device."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_reorient

    device = str(wp.get_device())
    history = rl_reorient.main(["--device", device, "--num-envs", "4", "--iterations", "1", "--steps-per-env", "4", "--mini-batches", "1",
                                "--evaluate", "--evaluate-envs", "2", "--evaluate-seconds", "0.2", "--out", str(tmp_path)])  # fmt: skip
    out = capsys.readouterr().out
    assert len(history) == 1 and (tmp_path / "policy.pt").exists()
    assert "success 0." in out and "orientation_error" in out and "evaluation: 2 fresh environments, 0.2 s:" in out
    assert torch.load(tmp_path / "policy.pt", weights_only=False)["infos"]["action_distribution"] == "beta"  # the default policy


@pytest.mark.parametrize("flags, kept", [([], True), (["--schedule", "adaptive"], False)])
def test_the_examples_learning_rate_stays_fixed_by_default(tmp_path, flags, kept):
    """rl_reorient.py's default schedule is Playground's fixed rate: a rate of 0.05 (updates whose KL exceeds twice
    0.01) is kept through an iteration; rsl-rl's adaptive schedule (--schedule adaptive) divides it by 1.5 at each such update."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_reorient

    rl_reorient.main(["--device", str(wp.get_device()), "--num-envs", "4", "--iterations", "1", "--steps-per-env", "4", "--mini-batches", "1",
                      "--learning-rate", "0.05", "--out", str(tmp_path), *flags])  # fmt: skip
    rate = float(torch.load(tmp_path / "policy.pt", weights_only=False)["optimizer_state_dict"]["param_groups"][0]["lr"])
    assert (rate == pytest.approx(0.05, rel=1e-6)) == kept and rate <= 0.05 * (1 + 1e-6)


def test_the_example_steps_at_another_time_step(tmp_path, capsys, monkeypatch):
    """--time-step 0.005: the environments step at 5 ms, 10 simulation steps per policy step (the header says so),
    and --evaluate builds its environments with the training's config (recorded by a stand-in for `evaluate`)."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    import rl_reorient

    steps = []
    monkeypatch.setattr(rl_reorient, "evaluate", lambda *args, cfg=None, **kwargs: steps.append(cfg.time_step) or
                        {"environments": 2, "seconds": 0.1, "successes": 0.0, "dropped": 0.0})  # fmt: skip
    rl_reorient.main(["--device", str(wp.get_device()), "--num-envs", "4", "--iterations", "1", "--steps-per-env", "2", "--mini-batches", "1",
                      "--time-step", "0.005", "--evaluate", "--out", str(tmp_path)])  # fmt: skip
    assert "policy at 20 Hz over 10 steps" in capsys.readouterr().out and steps == [0.005]


def test_the_mujoco_comparison_runs_both_simulators_from_the_same_resets():
    """benchmarks/reorient_vs_mujoco.py (run as a script) on 2 hands for 0.25 s: both simulators' lines printed, their
    eight statistics finite, the dropped fraction and the fraction of joints past their ranges in [0, 1], the largest
    excess at least 0 and the cube's mean height within 0.3 m of the palm's."""
    import re
    import subprocess

    root = pathlib.Path(__file__).resolve().parents[1]
    run = subprocess.run([sys.executable, "benchmarks/reorient_vs_mujoco.py", "--envs", "2", "--seconds", "0.25", "--device", str(wp.get_device())],
                         cwd=root, capture_output=True, text=True, timeout=600)  # fmt: skip
    assert run.returncode == 0, run.stderr[-2000:]
    lines = [line for line in run.stdout.splitlines() if line.startswith(("warpdyn", "MuJoCo"))]
    assert len(lines) == 2, run.stdout
    for line in lines:
        numbers = [float(x) for x in re.findall(r"-?\d+\.\d+", line.split(":", 1)[1].replace("> 0.01 rad", ""))]
        assert len(numbers) == 8 and all(np.isfinite(numbers)), line
        assert 0.0 <= numbers[3] <= 1.0 and -0.3 < numbers[4] < 0.3, line  # dropped fraction, mean height [m]
        assert 0.0 <= numbers[6] <= 1.0 and numbers[7] >= 0.0, line  # joints past their ranges: fraction, largest [rad]
