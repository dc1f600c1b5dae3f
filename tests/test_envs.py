"""warpdyn.envs: the batched legged environment (Gymnasium's vector API, torch tensors) and rsl-rl's PPO on it,
on the tests' device. The ergoCub legs, few environments: shapes and spaces, decimation against wd.model.step
(bitwise), seeding, automatic resets on a fall, a time limit and the health flag, domain randomisation, and a
few PPO iterations that must raise the return of standing."""

import math
import pathlib
import sys

import gymnasium as gym
import numpy as np
import pytest
import torch
import warp as wp
from gymnasium.vector.utils import batch_space

import warpdyn as wd
import warpdyn.envs as envs


def _legs():
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf())
    return wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)


def _env(N=4, seed=0, **cfg):
    return envs.LeggedEnv(_legs(), num_envs=N, cfg=envs.LeggedEnvConfig(**cfg), seed=seed)


def test_spaces_shapes_and_the_vector_api():
    env = _env(N=3)
    obs, info = env.reset(seed=0)
    na = env.model.number_of_actuators()
    assert na == 12 and env.decimation == 10 and env.metadata["autoreset_mode"] == gym.vector.AutoresetMode.SAME_STEP
    assert env.single_observation_space.shape == (49,) and env.single_action_space.shape == (12,)
    assert env.observation_space == batch_space(env.single_observation_space, 3)
    assert env.action_space == batch_space(env.single_action_space, 3)
    assert obs.shape == (3, 49) and obs.dtype == torch.float32 and obs.device == env.device and isinstance(info, dict)
    assert env.observation_space.contains(obs.cpu().numpy())
    obs, reward, terminated, truncated, info = env.step(torch.zeros(3, na, device=env.device))
    assert obs.shape == (3, 49) and reward.shape == (3,) and reward.dtype == torch.float32
    assert terminated.dtype == torch.bool and truncated.dtype == torch.bool and terminated.shape == (3,)
    assert set(info) >= {"final_obs", "_final_obs", "invalid", "log"}
    assert bool(torch.isfinite(obs).all()) and bool(torch.isfinite(reward).all())
    with pytest.raises(ValueError, match=r"actions has shape \(2, 12\)"):
        env.step(torch.zeros(2, na))
    with pytest.raises(ValueError, match="whole number of time steps"):
        _env(policy_dt=0.005, time_step=0.002)
    fixed = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), fixed_base=True)
    with pytest.raises(ValueError, match="floating-base"):
        envs.LeggedEnv(fixed, num_envs=2)


def test_a_step_is_decimation_simulation_steps():
    """One env.step = `decimation` wd.model.step calls with ctrl = default + scale * clip(action), bitwise."""
    env = _env(N=2, joint_noise=0.0)
    env.reset(seed=3)
    start = wd.data.Data.build(env.model, num_envs=2, base_position=env.stepper.data.base_position.numpy(),
                               base_quaternion=env.stepper.data.base_quaternion.numpy(), joint_positions=env.stepper.data.joint_positions.numpy())  # fmt: skip
    actions = torch.tensor(np.random.default_rng(0).uniform(-8, 8, (2, 12)), dtype=torch.float32, device=env.device)
    env.step(actions)
    ctrl = (env.cfg.action_scale * actions.clamp(-5, 5)).cpu().numpy().astype(np.float64)
    expected = start
    for _ in range(env.decimation):
        expected = wd.model.step(env.model, expected, ctrl=ctrl.astype(env.model.dtype))
    np.testing.assert_array_equal(env.stepper.data.joint_positions.numpy(), expected.joint_positions.numpy())
    np.testing.assert_array_equal(env.stepper.data.base_position.numpy(), expected.base_position.numpy())


def test_seeding_reproduces_and_distinguishes():
    def run(seed):
        env = _env(N=4, push_velocity=0.5, push_seconds=0.04, mass_scale=(0.8, 1.2), friction=(0.4, 1.0))
        obs, _ = env.reset(seed=seed)
        out = [obs.clone()]
        for k in range(4):
            obs, *_ = env.step(torch.full((4, 12), 0.1 * k, device=env.device))
            out.append(obs.clone())
        return torch.stack(out)

    a, b, c = run(1), run(1), run(2)
    assert torch.equal(a, b)
    assert not torch.allclose(a, c)


def test_a_fall_and_a_time_limit_reset_the_environment():
    """termination_height above the standing height: every environment 'falls' at once; the observation
    returned is the reset one, the last one in final_obs; episodes of 2 policy steps truncate after 2."""
    env = _env(N=3, termination_height=1.5)
    env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(torch.zeros(3, 12, device=env.device))
    assert terminated.all() and not truncated.any() and info["_final_obs"].all()
    assert not torch.equal(obs, info["final_obs"]) and (env.episode_length_buf == 0).all()
    assert env.episode_statistics()["episodes"] == 3
    env = _env(N=2, episode_seconds=0.04)
    env.reset(seed=0)
    flags = [env.step(torch.zeros(2, 12, device=env.device))[3].tolist() for _ in range(4)]
    assert flags == [[False, False], [True, True], [False, False], [True, True]]


def test_a_diverging_environment_is_reset_and_reported():
    """A non-finite joint velocity in environment 1 (as a diverging simulation would give): it is flagged by
    the step, reported in info["invalid"], terminated with reward 0 and reset; the others step on, and
    nothing returned is NaN."""
    env = _env(N=3)
    env.reset(seed=0)
    velocities = wp.to_torch(env.stepper.data.joint_velocities_state)
    velocities[1, 4] = float("nan")
    obs, reward, terminated, _, info = env.step(torch.zeros(3, 12, device=env.device))
    assert info["invalid"].tolist() == [False, True, False]
    assert bool(terminated[1]) and float(reward[1]) == 0.0 and not terminated[[0, 2]].any()
    assert bool(torch.isfinite(obs).all()) and bool(torch.isfinite(info["final_obs"]).all())
    assert env.stepper.data.healthy.numpy().tolist() == [1, 1, 1]


def test_resets_randomise_masses_and_friction():
    env = _env(N=6, mass_scale=(0.5, 1.5), friction=(0.3, 0.9))
    env.reset(seed=5)
    masses = env.model.link_mass.numpy()
    nominal = env.model.tree.link_mass
    ratio = masses[:, nominal > 0] / nominal[nominal > 0]
    assert ratio.min() >= 0.5 and ratio.max() <= 1.5 and ratio.std() > 0.05
    mu = env.model.contact_params.mu.numpy()
    assert mu.shape == (6,) and mu.min() >= 0.3 and mu.max() <= 0.9 and len(set(mu.tolist())) == 6


def test_link_lengths_per_environment():
    """A model with joint origins per environment (wd.model.with_joint_origins: link lengths randomised up to 8 %)
    runs in LeggedEnv: each environment's feet stand where its legs put them, the resets place the tallest clear of
    the ground (the standing height is the tallest environment's), and the steps stay healthy."""
    model = _legs()
    positions = wd.model.joint_origins(model)[0]
    scale = np.random.default_rng(3).uniform(0.92, 1.08, (4, model.number_of_joints(), 1))
    env = envs.LeggedEnv(wd.model.with_joint_origins(model, positions=positions * scale), num_envs=4, cfg=envs.LeggedEnvConfig(), seed=0)
    assert env.model.per_environment_parameters()["joint_origins"] == 4
    env.reset(seed=0)
    upright = wd.data.Data.build(env.model, num_envs=4, joint_positions=env.default_joint_positions.cpu().numpy())
    lowest = wd.contact.collidable_point_positions(env.model, upright).numpy()[..., 2].min(axis=1)
    assert np.ptp(lowest) > 0.01 and env.standing_height == pytest.approx(-lowest.min())
    for _ in range(10):
        env.step(torch.zeros((4, env.single_action_space.shape[0]), device=env.device, dtype=env.torch_dtype))
    assert bool(env.stepper.data.healthy.numpy().all())


def test_ppo_learns_to_stand(tmp_path):
    """rsl-rl's PPO (examples/rl_locomotion.py's configuration), 96 environments, 16 iterations: the mean
    return of the last 4 iterations is higher than that of the first 4 by 0.1 (measured on the CPU: -0.68 ->
    -0.39; seeded, so a run repeats)."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    try:
        import rl_locomotion
    finally:
        sys.path.pop(0)
    torch.manual_seed(0)
    env = rl_locomotion.make_env("stand", 96, wp.get_device(), seed=0)
    history = rl_locomotion.train(env, 16, tmp_path, str(env.device))
    returns = [h[1] for h in history if not math.isnan(h[1])]
    assert len(returns) >= 12
    assert np.mean(returns[-4:]) > np.mean(returns[:4]) + 0.1, returns


def test_the_default_posture_and_its_checks():
    """Targets and resets centre on default_joint_positions; the standing height is that posture's; a joint
    that the model lacks, or a non-finite angle, is refused by name."""
    knees = {"l_knee": -0.4, "r_knee": -0.4}
    env = _env(N=2, joint_noise=0.0, default_joint_positions=knees)
    names = env.model.joint_names()
    expected = np.zeros(12)
    expected[[names.index("l_knee"), names.index("r_knee")]] = -0.4
    expected = expected.astype(env.model.dtype)
    np.testing.assert_array_equal(env.default_joint_positions.cpu().numpy(), expected)
    env.reset(seed=0)
    np.testing.assert_array_equal(env.stepper.data.joint_positions.numpy(), np.tile(expected, (2, 1)))
    posture = wd.data.Data.build(env.model, joint_positions=expected)
    lowest = wd.contact.collidable_point_positions(env.model, posture).numpy()[..., 2].min()
    assert env.standing_height == -lowest and abs(env.standing_height - _env(N=1).standing_height) > 1e-3
    env.step(torch.ones(2, 12, device=env.device))
    np.testing.assert_array_equal(wp.to_torch(env.stepper.ctrl).cpu().numpy(), np.tile(expected + np.float32(0.25), (2, 1)))
    with pytest.raises(ValueError, match="names joint 'l_elbow'"):
        _env(default_joint_positions={"l_elbow": 0.3})
    with pytest.raises(ValueError, match=r"default_joint_positions\['l_knee'\] is nan"):
        _env(default_joint_positions={"l_knee": float("nan")})


def test_feet_contact_and_air_time():
    """The ergoCub's feet are the two links with collidable points. Standing (policy steps 30 to 50, after
    landing and before zero actions let it topple), both touch the ground and carry the robot's weight on
    average; dropped from 0.3 m above its stance, no foot touches, the air time grows by policy_dt per step,
    and the step a foot lands its first contact is flagged."""
    rewards = dict(envs.DEFAULT_REWARDS, feet_air_time=(envs.terms.feet_air_time, 1.0))
    env = _env(N=2, joint_noise=0.0, lin_vel_x=(0.5, 0.5), air_time_target=0.1, rewards=rewards)
    assert env.feet == ("l_ankle_2", "r_ankle_2")
    env.reset(seed=0)
    normal = []
    for k in range(50):
        env.step(torch.zeros(2, 12, device=env.device))
        if k >= 30:
            assert env.feet_contact.all(), k
            normal.append(wp.to_torch(env.stepper.contact_wrenches)[:, :, 2].sum(dim=1).cpu().numpy())
    weight = env.model.link_mass.numpy().sum(axis=1) * 9.81
    np.testing.assert_allclose(np.mean(normal, axis=0), weight, rtol=0.1)
    high = wd.data.Data.build(env.model, num_envs=2, base_position=(0.0, 0.0, env.standing_height + 0.3))
    env.stepper.set_state(high)
    env.feet_air_time.zero_()
    env._previous_contact.zero_()
    dt, landed = env.cfg.policy_dt, None
    for k in range(20):
        info = env.step(torch.zeros(2, 12, device=env.device))[4]
        if env.feet_first_contact.any():
            landed = k
            break
        assert not env.feet_contact.any()
        np.testing.assert_allclose(env.feet_air_time.cpu().numpy(), (k + 1) * dt, rtol=1e-6)
    assert landed is not None and landed >= 8, landed  # a 0.3 m fall takes ~0.25 s = 12 policy steps
    first = env.feet_first_contact.cpu().numpy()
    paid = ((landed + 1) * dt - 0.1) * first.sum(axis=1) * dt  # (air time - target) per landing foot, x policy_dt
    np.testing.assert_allclose(float(info["log"]["/reward/feet_air_time"]), paid.mean(), rtol=1e-5)
    assert (env.feet_air_time.cpu().numpy()[env.feet_contact.cpu().numpy()] == 0).all()  # landed feet start anew


def test_pushes_follow_each_episodes_clock():
    """push_seconds = 2 policy steps: an environment's base gets a horizontal kick at its episode steps 2, 4, ...
    (its own clock: rsl-rl spreads the clocks), the others do not."""
    env = _env(N=4, push_velocity=0.5, push_seconds=0.04, joint_noise=0.0)
    env.reset(seed=0)
    env.episode_length_buf.copy_(torch.tensor([0, 1, 2, 3], device=env.device))
    twin = _env(N=4, push_velocity=0.0, joint_noise=0.0)
    twin.reset(seed=0)
    twin.episode_length_buf.copy_(env.episode_length_buf)
    env.step(torch.zeros(4, 12, device=env.device))
    twin.step(torch.zeros(4, 12, device=env.device))
    moved = (env.state.base_linear_velocity - twin.state.base_linear_velocity)[:, :2].abs().amax(dim=1) > 1e-3
    assert moved.tolist() == [False, False, True, False]


def test_a_torque_limit_clips_the_servos():
    """torque_limit becomes the servos' force range; env.joint_torques is what servos and dampers apply:
    clip(kp (target - s), +-limit) - kd sdot. A model with actuators of its own is refused a torque_limit."""
    env = _env(N=2, torque_limit=20.0)
    env.reset(seed=0)
    env.step(torch.full((2, 12), 5.0, device=env.device))
    np.testing.assert_array_equal(env.model.actuator_force_range.numpy(), np.tile([-20.0, 20.0], (12, 1)))
    s = env.state
    targets = env.default_joint_positions + 0.25 * env.actions.to(env.torch_dtype)
    servo = (300.0 * (targets - s.joint_positions)).clamp(-20.0, 20.0)
    assert float(servo.abs().max()) == 20.0  # saturated
    torch.testing.assert_close(env.joint_torques, servo - 5.0 * s.joint_velocities, rtol=0, atol=0)
    actuated = wd.model.add_actuators(_legs(), "position", kp=100.0)
    with pytest.raises(ValueError, match="has actuators of its own"):
        envs.LeggedEnv(actuated, num_envs=2, cfg=envs.LeggedEnvConfig(torque_limit=20.0))
    with pytest.raises(TypeError, match="feet must be a tuple of link names"):
        _env(feet="l_ankle_2")


def test_a_setter_or_a_new_configuration_is_taken_up():
    """After a setter gives the model new parameter arrays, resets randomise those (not the old ones); a
    changed cfg (what a curriculum does) reaches the next step, graphs or not."""
    env = _env(N=3, mass_scale=(0.5, 1.5))
    env.reset(seed=0)
    env.step(torch.zeros(3, 12, device=env.device))
    env.model.set_link_parameters(mass=np.tile(env.model.tree.link_mass, (3, 1)))  # new arrays
    env.reset(seed=1)
    ratio = env.model.link_mass.numpy() / env.model.tree.link_mass
    assert np.nanstd(ratio[:, env.model.tree.link_mass > 0]) > 0.05  # the new arrays were randomised
    env.cfg.rewards = {"alive": (envs.terms.alive, 2.0)}
    for _ in range(3):
        reward = env.step(torch.zeros(3, 12, device=env.device))[1]
    torch.testing.assert_close(reward, torch.full((3,), 2.0 * env.cfg.policy_dt, device=env.device))


def test_a_generated_terrain_places_environments_on_their_tiles():
    """With cfg.terrain the model walks on the generated heightfield and each environment starts on its tile's
    platform, standing at its height above the tile's centre (a raised pyramid platform included); base heights are
    observed above the origin; an episode that ended promotes an environment that walked past half a tile, demotes
    one that walked less than half its command, and moves its origin to its new tile; reset() moves none."""
    from warpdyn.envs.terrain_generator import TerrainConfig

    terrain = TerrainConfig(levels=3, kinds=("flat", "pyramid_slope_up"), tile_size=4.0, platform=1.0)
    env = _env(N=4, terrain=terrain, lin_vel_x=(1.0, 1.0), episode_seconds=0.04)
    assert isinstance(env.model.terrain, wd.terrain.HeightfieldTerrain)
    env.reset(seed=0)
    np.testing.assert_array_equal(env.terrain_columns.cpu().numpy(), [0, 1, 0, 1])
    np.testing.assert_array_equal(env.terrain_levels.cpu().numpy(), 0)  # a fifth of 3 levels: level 0 only
    origins = env.env_origins.cpu().numpy()
    np.testing.assert_allclose(origins[:, :2], [[2.0, 2.0], [2.0, 6.0], [2.0, 2.0], [2.0, 6.0]])
    np.testing.assert_array_equal(origins[:, 2], 0.0)  # level 0: d = 0, flat
    base = env.state.base_position.cpu().numpy()
    np.testing.assert_allclose(base[:, :2], origins[:, :2], atol=1e-6)
    np.testing.assert_allclose(base[:, 2], origins[:, 2] + env.standing_height + 0.02, atol=1e-6)
    # environment 0 "walked" 3 m, environment 1 stayed: their episodes end at the next step (2 policy steps)
    env.step(torch.zeros(4, 12, device=env.device))
    views = env._state_views[id(env.stepper.data)]
    views["base_position"][0, 0] += 3.0
    env.step(torch.zeros(4, 12, device=env.device))
    levels = env.terrain_levels.cpu().numpy()
    assert levels[0] == 1 and levels[1] == 0  # up past half a tile (2 m); down from 0 stays at 0
    np.testing.assert_allclose(env.env_origins.cpu().numpy()[0], env.terrain_generator.tile_centre(1, 0))
    raised = env.terrain_generator.tile_centre(2, 1)
    assert raised[2] > 0.3  # a level-2 pyramid's platform is raised: an environment there starts above it
    env.terrain_levels[1], env.env_origins[1] = 2, torch.tensor(raised, dtype=env.env_origins.dtype)
    env._reset(torch.tensor([False, True, False, False], device=env.device), curriculum=False)
    np.testing.assert_allclose(env._reset_views["base_position"][1].cpu().numpy(), raised + [0.0, 0.0, env.standing_height + 0.02], atol=1e-6)
    with pytest.raises(TypeError, match="LeggedEnvConfig.terrain must be a TerrainConfig"):
        envs.LeggedEnvConfig(terrain="rough")


def test_the_height_scan_reads_the_terrain_around_each_base():
    """cfg.height_scan: after reset and after each step env.height_scan holds the terrain's heights on the grid
    around each base in its yaw frame (the host terrain's heights at those points), terms.height_scan the base's
    height above them, less 0.5 m, clipped to [-1, 1]; without the option the term says what to set."""
    from warpdyn.envs.terrain_generator import TerrainConfig

    terrain = TerrainConfig(levels=2, kinds=("random_rough", "pyramid_slope_down"), tile_size=4.0, platform=1.0)
    observations = (*envs.DEFAULT_OBSERVATIONS, (envs.terms.height_scan, 1.0))
    env = _env(N=3, terrain=terrain, height_scan=((0.6, 0.4), 0.2), observations=observations)
    obs, _ = env.reset(seed=1)
    assert env.height_scan.shape == (3, 12) and obs.shape[1] == env.single_observation_space.shape[0]
    for _ in range(2):
        s = env.state
        base = s.base_position.cpu().numpy()
        q = s.base_quaternion.cpu().numpy()
        yaw = np.arctan2(2 * (q[:, 0] * q[:, 3] + q[:, 1] * q[:, 2]), 1 - 2 * (q[:, 2] ** 2 + q[:, 3] ** 2))
        pattern = wd.terrain.grid_pattern((0.6, 0.4), 0.2)
        for e in range(3):
            R = np.array([[np.cos(yaw[e]), -np.sin(yaw[e])], [np.sin(yaw[e]), np.cos(yaw[e])]])
            points = base[e, :2] + pattern @ R.T
            np.testing.assert_allclose(env.height_scan[e].cpu().numpy(), env.model.terrain.height(points[:, 0], points[:, 1]), atol=1e-5)
        above = (s.base_position[:, 2:3] - env.height_scan - 0.5).clamp(-1.0, 1.0)
        assert torch.equal(envs.terms.height_scan(env), above)
        env.step(torch.zeros(3, 12, device=env.device))
    flat = _env(N=2)
    flat.reset(seed=0)
    with pytest.raises(ValueError, match="set LeggedEnvConfig.height_scan"):
        envs.terms.height_scan(flat)
    with pytest.raises(TypeError, match="height_scan must be"):
        envs.LeggedEnvConfig(height_scan=0.1)


def test_undesired_contacts_flag_and_count_their_links():
    """cfg.undesired_contacts: the named links' contact with the terrain (normal force above the threshold) in
    env.undesired_contact, counted by terms.undesired_contacts; standing, both feet touch; lifted into the air,
    neither. A link without collidable points, or one the model lacks, is refused by name."""
    env = _env(N=2, undesired_contacts=("r_ankle_2", "l_ankle_2"))
    env.reset(seed=0)
    for _ in range(10):  # the reset drops the legs from 2 cm
        env.step(torch.zeros(2, 12, device=env.device))
    assert env.undesired_contact.shape == (2, 2) and env.undesired_contact.all()
    assert torch.equal(envs.terms.undesired_contacts(env), torch.full((2,), 2.0, device=env.device))
    views = env._state_views[id(env.stepper.data)]
    views["base_position"][:, 2] += 1.0  # in the air: no contact after the next step
    env.step(torch.zeros(2, 12, device=env.device))
    assert not env.undesired_contact.any() and (envs.terms.undesired_contacts(env) == 0).all()
    with pytest.raises(ValueError, match="undesired_contacts: link 'l_upper_leg' has no enabled collidable points"):
        _env(N=1, undesired_contacts=("l_upper_leg",))
    with pytest.raises(ValueError, match="undesired_contacts names link 'tail'"):
        _env(N=1, undesired_contacts=("tail",))


def test_observation_noise_and_action_delay():
    """An observation entry (term, scale, noise) adds uniform noise of +-noise to its scaled values (here on zero
    commands: the noise alone, bounded, spread); action_delay k sets the targets from the action given k policy
    steps before (zero actions first), while env.actions is the newest; a reset empties the history."""
    observations = ((envs.terms.commands, 1.0, 0.1),)
    env = _env(N=64, observations=observations, action_delay=2)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (64, 3) and obs.abs().max() <= 0.1 and obs.abs().mean() > 0.03
    default = env.default_joint_positions
    given = [torch.full((64, 12), value, device=env.device) for value in (0.4, -0.2, 0.8)]
    applied = []
    for action in given:
        env.step(action)
        applied.append(((wp.to_torch(env.stepper.ctrl) - default) / env.cfg.action_scale).to(torch.float32))
        assert torch.equal(env.actions, action)
    assert torch.allclose(applied[0], torch.zeros_like(applied[0])) and torch.allclose(applied[1], torch.zeros_like(applied[1]))
    assert torch.allclose(applied[2], given[0], atol=1e-5)  # two steps late
    env.reset(seed=0)
    env.step(given[2])
    assert torch.allclose(((wp.to_torch(env.stepper.ctrl) - default) / env.cfg.action_scale).to(torch.float32), torch.zeros(64, 12, device=env.device))
    with pytest.raises(ValueError, match="action_delay must be an integer >= 0"):
        envs.LeggedEnvConfig(action_delay=-1)
    with pytest.raises(ValueError, match=r"observations\[0\] noise must be a finite number >= 0"):
        envs.LeggedEnvConfig(observations=((envs.terms.commands, 1.0, -0.1),))


def test_use_graph_true_is_refused_on_the_cpu():
    """Torch ops cannot be captured on the CPU: use_graph=True says so (and "auto" steps eagerly there)."""
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), device="cpu")
    legs = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    with pytest.raises(ValueError, match="use_graph=True captures torch ops"):
        envs.LeggedEnv(legs, num_envs=2, use_graph=True)


@pytest.mark.skipif(not wp.get_device().is_cuda, reason="CUDA graphs: the tests' device is not a GPU")
@pytest.mark.parametrize(
    "policy_dt, terrain, sensors", [(0.02, False, None), (0.01, False, None), (0.02, True, None), (0.02, True, "root_link"), (0.01, False, "l_lower_leg")]
)  # 10 and 5 simulation steps: an odd count ends on the other buffer
def test_graph_replays_equal_eager_steps(policy_dt, terrain, sensors):
    """use_graph=True captures a whole step (actions, simulation, rewards, resets, randomisation, the terrain
    curriculum and the height scan; with `sensors` the IMU's noise and biases on that link (the base's path, or a
    shank's kinematics at both state buffers), an ActuatorNet's torch network at each
    simulation step on two Steppers, stumbling and the height above the terrain) and its replays give what eager steps
    give, bitwise, through pushes, time-limit resets and a reset() between replays, in tensors that the next step does
    not overwrite."""
    from warpdyn.envs.actuators import ActuatorNet
    from warpdyn.envs.sensors import ImuConfig
    from warpdyn.envs.terrain_generator import TerrainConfig

    settings = dict(policy_dt=policy_dt, push_velocity=0.5, push_seconds=0.06, episode_seconds=0.1, mass_scale=(0.8, 1.2), friction=(0.4, 1.0), lin_vel_x=(-0.5, 0.5))
    if terrain:
        settings["terrain"] = TerrainConfig(levels=3, kinds=("flat", "pyramid_slope_up", "random_rough"), tile_size=4.0, platform=1.0)
        settings["height_scan"] = ((0.6, 0.4), 0.2)
        settings["observations"] = (*envs.DEFAULT_OBSERVATIONS, (envs.terms.height_scan, 1.0))
    if sensors:
        torch.manual_seed(0)
        net = torch.nn.Sequential(torch.nn.Linear(6, 16), torch.nn.Softsign(), torch.nn.Linear(16, 1)).to(wp.device_to_torch(wp.get_device()))
        settings["imu"] = ImuConfig(offset=(0.05, 0.0, 0.1), accelerometer_noise=0.1, gyroscope_noise=0.01, accelerometer_bias=0.2, gyroscope_bias=0.05, link=sensors)
        settings["actuator"] = ActuatorNet(net, history=3)
        terms = envs.terms
        settings["observations"] = (*settings.get("observations", envs.DEFAULT_OBSERVATIONS), (terms.imu_linear_acceleration, 0.1),
                                    (terms.imu_angular_velocity, 0.25), (terms.height_above_terrain, 1.0))  # fmt: skip
        settings["rewards"] = {**envs.DEFAULT_REWARDS, "stumbling": (terms.stumbling, -1.0), "base_height": (terms.height_above_terrain_error, -10.0)}
    graphed = envs.LeggedEnv(_legs(), num_envs=8, cfg=envs.LeggedEnvConfig(**settings), seed=3, use_graph=True)
    eager = envs.LeggedEnv(_legs(), num_envs=8, cfg=envs.LeggedEnvConfig(**settings), seed=3, use_graph=False)
    actions = torch.tensor(np.random.default_rng(0).uniform(-1, 1, (12, 8, 12)), dtype=torch.float32, device=graphed.device)
    for env in (graphed, eager):
        env.reset(seed=3)
    kept = None
    for k in range(12):
        if k == 7:  # a reset between replays
            assert torch.equal(graphed.reset(seed=5)[0], eager.reset(seed=5)[0])
        a = graphed.step(actions[k])
        b = eager.step(actions[k])
        for x, y in zip(a[:4], b[:4]):
            assert torch.equal(x, y), k
        assert torch.equal(a[4]["final_obs"], b[4]["final_obs"])
        if kept is not None:  # the previous step's observation is its own tensor (rsl-rl stores it after the step)
            assert torch.equal(kept[0], kept[1]), k
        kept = (a[0], a[0].clone())
    assert graphed._program.captured == (1 if graphed.stepper.substeps % 2 == 0 else 2) and not eager._program.captured


@pytest.mark.filterwarnings("ignore:.*link 'base'. principal moments:warpdyn.model.UnphysicalInertiaWarning")  # tests/test_go1.py checks it
def test_the_go1_walk_task_steps_and_its_feet_touch_down():
    """examples/rl_locomotion.py's Go1 (example-robot-data): its walk task builds, its feet are the four calves
    with 9 points each, observations and rewards are finite, and landing in its default posture (at step 3 of
    the policy, from 2 cm) the four feet touch the ground together."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    try:
        import rl_locomotion
    finally:
        sys.path.pop(0)
    env = rl_locomotion.make_env("walk", 4, wp.get_device(), seed=0, robot="go1", joint_noise=0.0)
    in_link_order = tuple(sorted(wd.assets.GO1_FEET, key=env.model.link_names().index))  # the default: links with points
    assert env.feet == in_link_order and [len(p) for p in env._foot_points] == [9, 9, 9, 9]
    assert env.decimation == 10 and env.single_action_space.shape == (12,)
    obs, _ = env.reset(seed=0)
    for k in range(8):
        obs, reward, terminated, truncated, info = env.step(torch.zeros(4, 12, device=env.device))
        assert bool(torch.isfinite(obs).all()) and bool(torch.isfinite(reward).all()) and not info["invalid"].any()
        assert not terminated.any() and bool(env.feet_contact.all()) == (k >= 3), k


@pytest.mark.filterwarnings("ignore::warpdyn.model.NotModelledWarning")  # the ANYmal C's, tests/test_env_robots.py checks them
def test_the_anymal_c_rough_task_builds_on_its_curriculum(tmp_path):
    """examples/rl_locomotion.py's rough task: the ANYmal C on the generated terrain (10 levels), the 187-point
    height scan observed instead of the base's height above its origin (235 observations), its thighs' box corners
    touching the terrain besides the feet (8 each) and watched as undesired contacts, each step's reward clipped at 0;
    two PPO iterations record the mean terrain level (the last one the environments' now). A robot without a rough task is refused by name."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    try:
        import rl_locomotion
    finally:
        sys.path.pop(0)
    env = rl_locomotion.make_env("rough", 4, wp.get_device(), seed=0, robot="anymal_c")
    assert env.single_observation_space.shape == (235,) and env.terrain_generator.levels == 10
    assert env.cfg.only_positive_rewards and env.undesired_contact.shape == (4, 4)
    cp, links = env.model.kin_dyn_parameters.contact_parameters, env.model.link_names()
    touching = [links[b] for b, on in zip(cp.body, cp.enabled) if on]
    assert {name: touching.count(name) for name in set(touching)} == {**dict.fromkeys(wd.assets.ANYMAL_C_FEET, 9), **dict.fromkeys(rl_locomotion.ROUGH_LINKS["anymal_c"], 8)}
    history = rl_locomotion.train(env, 2, tmp_path, str(env.device))
    levels = [h[4] for h in history]  # each iteration's mean of 4 levels, the last one the environments' now
    assert len(levels) == 2 and all(0 <= level <= 9 and (4 * level).is_integer() for level in levels)
    assert levels[-1] == pytest.approx(float(env.terrain_levels.float().mean()), abs=1e-6)
    with pytest.raises(ValueError, match="go2 has no task 'rough' .its tasks: stand, walk"):
        rl_locomotion.make_env("rough", 4, wp.get_device(), seed=0, robot="go2")


def test_only_positive_rewards_clip_each_steps_total_at_zero():
    """LeggedEnvConfig.only_positive_rewards (legged_gym's): a step whose terms sum to -policy_dt reports 0 with it
    and -policy_dt without; a non-bool is refused by name."""
    for clip in (False, True):
        env = _env(N=2, joint_noise=0.0, rewards={"penalty": (envs.terms.alive, -1.0)}, only_positive_rewards=clip)
        env.reset(seed=0)
        _, reward, terminated, _, _ = env.step(torch.zeros(2, 12, device=env.device))
        assert not terminated.any() and reward.tolist() == ([0.0, 0.0] if clip else [pytest.approx(-env.cfg.policy_dt)] * 2)
    with pytest.raises(TypeError, match="LeggedEnvConfig.only_positive_rewards must be True or False, got 1"):
        envs.LeggedEnvConfig(only_positive_rewards=1)


def test_heading_commands_steer_the_yaw_rate():
    """LeggedEnvConfig.heading_command (legged_gym's): each environment draws a heading in [-pi, pi] with its
    commands, and every observation commands the yaw rate 0.5 x the heading's error from the base's yaw, wrapped to
    [-pi, pi) and clipped to yaw_rate's range (headings 0.4, -0.4 - 2 pi, 3 and -3 rad from the yaw command 0.2,
    -0.2, 1 and -1 rad/s); without it the heading stays 0 and the drawn yaw rate stands; a single yaw rate (nothing
    to steer with) is refused."""
    env = _env(N=4, joint_noise=0.0, heading_command=True, yaw_rate=(-1.0, 1.0))
    env.reset(seed=0)

    def yaw():
        w, x, y, z = env.state.base_quaternion.double().T
        return torch.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))

    def expected():
        error = torch.remainder(env.heading.double() - yaw() + math.pi, 2 * math.pi) - math.pi
        return (0.5 * error).clamp(-1.0, 1.0)

    heading = env.heading.clone()
    assert bool((heading.abs() <= math.pi).all()) and len(set(heading.tolist())) == 4
    np.testing.assert_allclose(env.commands[:, 2].double().cpu(), expected().cpu(), atol=1e-6)
    env.heading.copy_((yaw() + torch.tensor([0.4, -0.4 - 2 * math.pi, 3.0, -3.0], dtype=torch.float64, device=env.device)).float())
    env.step(torch.zeros(4, 12, device=env.device))
    np.testing.assert_allclose(env.commands[:, 2].double().cpu(), expected().cpu(), atol=1e-6)
    np.testing.assert_allclose(env.commands[:, 2].cpu(), [0.2, -0.2, 1.0, -1.0], atol=0.02)
    plain = _env(N=4, joint_noise=0.0, yaw_rate=(-1.0, 1.0))
    plain.reset(seed=0)
    plain.step(torch.zeros(4, 12, device=plain.device))
    assert plain.heading.tolist() == [0.0] * 4 and len(set(plain.commands[:, 2].tolist())) == 4
    with pytest.raises(TypeError, match="LeggedEnvConfig.heading_command must be True or False"):
        envs.LeggedEnvConfig(heading_command="yes")
    with pytest.raises(ValueError, match="heading_command clips its yaw rate to yaw_rate's range, which is the single value 0.0"):
        envs.LeggedEnvConfig(heading_command=True)


def test_the_ppo_settings_reach_the_trainer(tmp_path, capsys):
    """examples/rl_locomotion.py's --steps-per-env, --epochs, --mini-batches, --learning-rate, --gamma and --entropy-coef (PPO_DEFAULTS) reach
    rsl-rl's configuration and the collection (2 iterations of 8 steps: every environment 16 steps into its episode);
    a non-positive value is refused by the parser, naming the flag."""
    sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "examples"))
    try:
        import rl_locomotion
    finally:
        sys.path.pop(0)
    cfg = rl_locomotion.train_config(3, steps_per_env=8, epochs=1, mini_batches=2, learning_rate=5e-4, gamma=0.97, entropy_coef=0.02)
    algorithm = cfg["algorithm"]
    assert (cfg["num_steps_per_env"], algorithm["num_learning_epochs"], algorithm["num_mini_batches"], algorithm["learning_rate"]) == (8, 1, 2, 5e-4)
    assert (algorithm["gamma"], algorithm["entropy_coef"], algorithm["use_clipped_value_loss"]) == (0.97, 0.02, True)
    assert rl_locomotion.train_config(3, clipped_value_loss=False)["algorithm"]["use_clipped_value_loss"] is False
    env = rl_locomotion.make_env("stand", 8, wp.get_device(), seed=0, joint_noise=0.0)
    history = rl_locomotion.train(env, 2, tmp_path, str(env.device), ppo=dict(steps_per_env=8, epochs=1, mini_batches=2))
    assert len(history) == 2 and env.episode_length_buf.tolist() == [16] * 8
    with pytest.raises(SystemExit):
        rl_locomotion.main(["--epochs", "0", "--device", "cpu"])
    assert "--epochs must be positive, got 0" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        rl_locomotion.main(["--gamma", "-0.5", "--device", "cpu"])
    assert "--gamma must be positive, got -0.5" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        rl_locomotion.main(["--clipped-value-loss", "no", "--device", "cpu"])
    assert "--clipped-value-loss: on or off, got 'no'" in capsys.readouterr().err
