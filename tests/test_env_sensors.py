"""warpdyn.envs's rough-terrain sensing and actuation (issue 39): the IMU (warpdyn.envs.sensors) at rest, in free fall,
at an offset, its noise and bias; the stumbling and height-above-terrain terms; the "torque" and ActuatorNet actuators
(warpdyn.envs.actuators). A box robot on four corners settles to rest (the IMU tests); the ergoCub legs walk into
stairs and terrain. Few environments, few steps, on the tests' device."""

import math
import warnings

import numpy as np
import pytest
import torch
from scipy.spatial.transform import Rotation
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.envs.actuators import ActuatorNet
from warpdyn.envs.sensors import ImuConfig
from warpdyn.envs.terrain_generator import TerrainConfig

BOX = """<robot name="box">
  <link name="base">
    <inertial><mass value="4.0"/><inertia ixx="0.033" ixy="0" ixz="0" iyy="0.057" iyz="0" izz="0.083"/></inertial>
    <collision><geometry><box size="0.4 0.3 0.1"/></geometry></collision>
  </link>
  <link name="tail">
    <inertial><origin xyz="0.05 0 0"/><mass value="0.2"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
  </link>
  <joint name="tail_joint" type="revolute"><parent link="base"/><child link="tail"/><origin xyz="0.2 0 0.05"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="10"/></joint>
</robot>"""
"""A 4 kg box (its 8 corners its collidable points) with a servoed tail: it rests still on four corners."""

BOX_SETTINGS = dict(joint_noise=0.0, kp=5.0, kd=0.5, contact_damping=5000.0, friction=(1.0, 1.0))
"""Contact damping that settles the box within 0.4 s; friction that holds it on a 0.2 slope."""


def _box(N, terrain=None, seed=0, **cfg):
    model = wd.model.Model.build_from_model_description(BOX)
    if terrain is not None:
        model.terrain = terrain
    return envs.LeggedEnv(model, num_envs=N, cfg=envs.LeggedEnvConfig(**{**BOX_SETTINGS, **cfg}), seed=seed)


def _legs(dtype=np.float32):
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=dtype)
    return wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)


def _rotate_inverse(q, v):
    """R(q)^T v, q (N, 4) (w, x, y, z) or (4,), v (N, 3): torch."""
    q = torch.as_tensor(q, dtype=v.dtype, device=v.device).expand(v.shape[0], 4)
    return envs.terms.quat_rotate_inverse(q, v)


def _zero(env):
    return torch.zeros(env.num_envs, env.single_action_space.shape[0], device=env.device)


def test_the_imu_reads_minus_gravity_at_rest_on_a_slope():
    """At rest on a 0.2 slope (tilted, at a random yaw), an IMU mounted rolled by 0.6 rad reads R_BI^T R_WB^T (0, 0, +g)
    [m/s^2] to 1e-3 and no rotation; its noise-free and noisy readings agree without noise or bias; the terms read it."""
    x = np.arange(41) * 0.1 - 2.0
    slope = wd.terrain.HeightfieldTerrain(np.tile(0.2 * x[:, None], (1, 41)), origin=(-2.0, -2.0), spacing=(0.1, 0.1))
    mount = (math.cos(0.3), math.sin(0.3), 0.0, 0.0)
    env = _box(3, slope, imu=ImuConfig(rotation=mount))
    env.reset(seed=0)
    for _ in range(30):
        env.step(_zero(env))
    s = env.state
    assert float(s.projected_gravity[:, :2].norm(dim=1).min()) > 0.15  # tilted by the slope
    up = torch.tensor([[0.0, 0.0, 9.81]], dtype=env.torch_dtype, device=env.device).expand(3, 3)
    expected = _rotate_inverse(mount, _rotate_inverse(s.base_quaternion, up))
    torch.testing.assert_close(env.imu.linear_acceleration, expected, atol=1e-3, rtol=0)
    torch.testing.assert_close(env.imu.angular_velocity, torch.zeros_like(expected), atol=1e-3, rtol=0)
    assert torch.equal(env.imu.linear_acceleration, env.imu.true_linear_acceleration)
    assert torch.equal(envs.terms.imu_linear_acceleration(env), env.imu.linear_acceleration)
    assert torch.equal(envs.terms.imu_angular_velocity(env), env.imu.angular_velocity)


def test_the_imu_reads_zero_in_free_fall_under_the_models_gravity():
    """Dropped from 1 m, the accelerometer reads 0 under the model's world_gravity, whatever it is (here one per
    environment, one tilted); the gyroscope reads the base's angular velocity in its axes. Reset, before any step,
    the sensor is at rest: -g in its axes."""
    env = _box(3, imu=ImuConfig())
    gravity = np.array([[0.0, 0.0, -9.81], [1.0, -2.0, -8.0], [0.0, 0.0, -3.0]])
    env.model.set_gravity(gravity)
    env.reset(seed=0)
    g = torch.tensor(gravity, dtype=env.torch_dtype, device=env.device)
    torch.testing.assert_close(env.imu.linear_acceleration, _rotate_inverse(env.state.base_quaternion, -g), atol=1e-5, rtol=0)
    views = env._state_views[id(env.stepper.data)]
    views["base_position"][:, 2] += 1.0
    env.step(_zero(env))
    assert float(env.state.base_linear_velocity.norm(dim=1).min()) > 0.05  # falling
    torch.testing.assert_close(env.imu.linear_acceleration, torch.zeros_like(g), atol=1e-3, rtol=0)
    views["base_velocity"][:, 3:] = torch.tensor([0.5, -1.0, 2.0], device=env.device)
    env.step(_zero(env))
    torch.testing.assert_close(env.imu.angular_velocity, env.state.base_angular_velocity, atol=1e-6, rtol=0)
    assert float(env.imu.angular_velocity.norm(dim=1).min()) > 1.0


def test_an_offset_imu_reads_its_own_points_acceleration():
    """An IMU 0.15 m off the base origin on a box spinning in free fall reads its point's acceleration less gravity:
    the finite difference of that point's velocity over the last simulation step, v_I = pdot_B + omega x R r (the
    two state buffers), to O(dt omega^3 r); the centripetal part alone is omega^2 r = 1.35 m/s^2."""
    offset = (0.1, -0.1, 0.05)
    env = _box(2, imu=ImuConfig(offset=offset))
    env.reset(seed=0)
    views = env._state_views[id(env.stepper.data)]
    views["base_position"][:, 2] += 1.0
    views["base_velocity"][:, 3:] = torch.tensor([0.0, 0.0, 3.0], device=env.device)
    env.step(_zero(env))
    now, before = (env._state_views[id(env.stepper.data)], next(env._state_views[id(d)] for d in env.stepper.buffers if d is not env.stepper.data))
    r = torch.tensor([offset], dtype=env.torch_dtype, device=env.device).expand(2, 3)

    def point_velocity(v):
        q = v["base_quaternion"] / v["base_quaternion"].norm(dim=1, keepdim=True)
        return v["base_velocity"][:, :3] + torch.cross(v["base_velocity"][:, 3:], envs.terms.quat_rotate(q, r), dim=1)

    acceleration = (point_velocity(now) - point_velocity(before)) / env.cfg.time_step
    g = torch.tensor([[0.0, 0.0, -9.81]], dtype=env.torch_dtype, device=env.device)
    expected = _rotate_inverse(env.state.base_quaternion, acceleration - g)
    assert float(expected.norm(dim=1).min()) > 1.0  # not free fall's zero
    torch.testing.assert_close(env.imu.linear_acceleration, expected, atol=0.03, rtol=0)


def test_an_imu_on_a_link_reads_that_links_frame():
    """An IMU on the tail (ImuConfig.link, offset and turned on it): at a reset it reads -g in its own axes (the tail's
    pose composed with the mount); on the box spinning in free fall, with the tail servoed, the accelerometer reads the
    finite difference of the IMU point's velocity over the last simulation step less gravity and the gyroscope the
    tail's angular velocity, both in the IMU's axes, as wd.link.transform and wd.link.velocity give them at the two
    state buffers (1e-4 m/s^2, float32); an unknown link is refused, naming the model's links."""
    offset, mount = (0.04, 0.01, -0.02), (np.cos(0.4), 0.0, 0.0, np.sin(0.4))
    env = _box(2, imu=ImuConfig(link="tail", offset=offset, rotation=mount))
    env.reset(seed=0)
    tail = env.model.link_names().index("tail")
    R_LI = torch.tensor(Rotation.from_quat([*mount[1:], mount[0]]).as_matrix(), dtype=env.torch_dtype, device=env.device)
    r = torch.tensor(offset, dtype=env.torch_dtype, device=env.device)

    def imu_frame(data):
        W_H_L = wp.to_torch(wd.link.transform(env.model, data, link_index=tail))
        v = wp.to_torch(wd.link.velocity(env.model, data, link_index=tail, output_vel_repr=wd.VelRepr.Mixed))
        R = W_H_L[:, :3, :3]
        return R @ R_LI, v[:, :3] + torch.cross(v[:, 3:], R @ r, dim=1), v[:, 3:]

    g = torch.tensor([[0.0, 0.0, -9.81]], dtype=env.torch_dtype, device=env.device)
    R, _, _ = imu_frame(env.stepper.data)
    torch.testing.assert_close(env.imu.linear_acceleration, torch.einsum("nji,nj->ni", R, -g.expand(2, 3)), atol=1e-5, rtol=0)
    views = env._state_views[id(env.stepper.data)]
    views["base_position"][:, 2] += 1.0
    views["base_velocity"][:, 3:] = torch.tensor([0.5, -1.0, 3.0], device=env.device)
    env.step(_zero(env) + 0.5)
    before = next(d for d in env.stepper.buffers if d is not env.stepper.data)
    (R, v_now, omega), (_, v_before, _) = imu_frame(env.stepper.data), imu_frame(before)
    expected = torch.einsum("nji,nj->ni", R, (v_now - v_before) / env.cfg.time_step - g)
    assert float(expected.norm(dim=1).min()) > 1.0  # not free fall's zero: the tail turns about the spinning box
    torch.testing.assert_close(env.imu.linear_acceleration, expected, atol=1e-4, rtol=0)
    torch.testing.assert_close(env.imu.angular_velocity, torch.einsum("nji,nj->ni", R, omega), atol=1e-5, rtol=0)
    with pytest.raises(ValueError, match=r"ImuConfig.link 'fin' is not a link of model 'box'; its links: \['base', 'tail'\]"):
        _box(1, imu=ImuConfig(link="fin"))
    with pytest.raises(TypeError, match="ImuConfig.link must be a link's name or None"):
        ImuConfig(link=3)


def test_frame_motion_is_the_links_pose_and_velocity_composed_with_the_frame():
    """wd.link.FrameMotion (ANYmal C's left front shank, a frame offset and turned on it, 3 random states, float64)
    equals wd.link.transform times the frame's pose, and the Mixed velocity of wd.link.velocity moved to the frame's
    origin, to 1e-15; the same arrays at every call; bad frames and another N are refused."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(wd.assets.anymal_c_mjcf(), dtype=np.float64)
    rng = np.random.default_rng(0)
    data = wd.data.Data.build(model, num_envs=3, joint_positions=rng.normal(size=(3, model.dofs())) * 0.3,
                              joint_velocities=rng.normal(size=(3, model.dofs())), base_linear_velocity=rng.normal(size=(3, 3)),
                              base_angular_velocity=rng.normal(size=(3, 3)), velocity_representation=wd.VelRepr.Mixed)  # fmt: skip
    link, p, q = model.link_names().index("LF_SHANK"), np.array([0.02, -0.03, 0.05]), np.array([np.cos(0.3), 0.0, np.sin(0.3), 0.0])
    motion = wd.link.FrameMotion(model, link_index=link, position=p, quaternion=q, num_envs=3)
    W_H_F, W_v_WF = motion(data)
    W_H_L = wd.link.transform(model, data, link_index=link).numpy()
    v_L = wd.link.velocity(model, data, link_index=link, output_vel_repr=wd.VelRepr.Mixed).numpy()
    L_H_F = np.eye(4)
    L_H_F[:3, :3], L_H_F[:3, 3] = Rotation.from_quat([*q[1:], q[0]]).as_matrix(), p
    np.testing.assert_allclose(W_H_F.numpy(), W_H_L @ L_H_F, rtol=0, atol=1e-15)
    r = np.einsum("nij,j->ni", W_H_L[:, :3, :3], p)
    np.testing.assert_allclose(W_v_WF.numpy(), np.concatenate([v_L[:, :3] + np.cross(v_L[:, 3:], r), v_L[:, 3:]], axis=1), rtol=0, atol=1e-15)
    again = motion(data)
    assert again[0].ptr == W_H_F.ptr and again[1].ptr == W_v_WF.ptr
    with pytest.raises(ValueError, match="unit quaternion"):
        wd.link.FrameMotion(model, link_index=link, quaternion=(1.0, 1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="made for 2 environments, the data holds 3"):
        wd.link.FrameMotion(model, link_index=link, num_envs=2)(data)


def test_imu_noise_and_bias_statistics():
    """White noise N(0, sigma^2) per reading and a bias per environment drawn at each reset (Gaussian here, uniform
    below): their sample means and standard deviations over environments, axes and steps (resets) match the
    configuration within 5 standard errors; the bias holds over an episode and is redrawn at a reset, for the
    environments reset alone; a seed repeats everything, another seed differs."""
    imu = ImuConfig(accelerometer_noise=0.2, gyroscope_noise=0.05, accelerometer_bias=0.3, gyroscope_bias=0.1)
    N, steps = 64, 6
    env = _box(N, imu=imu, episode_seconds=1.0)
    biases, noise = [], []
    for seed in range(4):
        env.reset(seed=seed)
        biases.append((env.imu.accelerometer_bias.clone(), env.imu.gyroscope_bias.clone()))
    for _ in range(steps):
        env.step(_zero(env))
        noise.append((env.imu.linear_acceleration - env.imu.true_linear_acceleration - env.imu.accelerometer_bias,
                      env.imu.angular_velocity - env.imu.true_angular_velocity - env.imu.gyroscope_bias))  # fmt: skip
    for k, (sigma_noise, sigma_bias) in enumerate(((0.2, 0.3), (0.05, 0.1))):
        for samples, sigma in ((torch.cat([n[k] for n in noise]), sigma_noise), (torch.cat([b[k] for b in biases]), sigma_bias)):
            n = samples.numel()
            assert abs(float(samples.mean())) < 5 * sigma / math.sqrt(n), (k, float(samples.mean()))
            assert abs(float(samples.std()) / sigma - 1.0) < 5 / math.sqrt(2 * n), (k, float(samples.std()))
    held = env.imu.gyroscope_bias.clone()
    assert torch.equal(held, biases[-1][1])  # the same over the episode's steps
    env.episode_length_buf[:2] = env.max_episode_length - 1  # environments 0 and 1 end at the next step
    env.step(_zero(env))
    assert not torch.equal(env.imu.gyroscope_bias[:2], held[:2]) and torch.equal(env.imu.gyroscope_bias[2:], held[2:])
    uniform = _box(N, imu=ImuConfig(accelerometer_bias=0.3, bias_distribution="uniform"))
    uniform.reset(seed=0)
    b = uniform.imu.accelerometer_bias
    assert float(b.abs().max()) <= 0.3 and abs(float(b.std()) / (0.3 / math.sqrt(3)) - 1.0) < 5 / math.sqrt(2 * b.numel())

    def readings(seed):
        e = _box(4, imu=imu, seed=seed)
        e.reset(seed=seed)
        out = []
        for _ in range(3):
            e.step(_zero(e))
            out.append(e.imu.linear_acceleration.clone())
        return torch.stack(out)

    assert torch.equal(readings(1), readings(1)) and not torch.allclose(readings(1), readings(2))
    with pytest.raises(ValueError, match="ImuConfig.gyroscope_noise must be a finite number >= 0"):
        ImuConfig(gyroscope_noise=-1.0)
    with pytest.raises(ValueError, match="bias_distribution must be one of"):
        ImuConfig(bias_distribution="laplace")
    with pytest.raises(ValueError, match="set LeggedEnvConfig.imu"):
        envs.terms.imu_angular_velocity(_box(1))


def test_stumbling_fires_for_a_foot_pushed_into_a_stair():
    """The ergoCub legs hovering 1 cm above a generated staircase (0.23 m steps sampled every 0.02 m: a riser is a
    slope of 11.5), pushed at 1 m/s so that their toes hit a riser: the feet's horizontal contact force exceeds 5 times
    their vertical one and terms.stumbling reads 1; the environment landing and standing on its platform reads 0 at every step.
    Friction on a riser (mostly vertical on a steep face) bounds that ratio by about 1 / mu: the pushed environment's
    friction is 0.05."""
    terrain = TerrainConfig(levels=2, kinds=("stairs_up",), tile_size=4.0, platform=1.0, resolution=0.02)
    env = envs.LeggedEnv(_legs(), num_envs=2, cfg=envs.LeggedEnvConfig(terrain=terrain, joint_noise=0.0), seed=0)
    env.reset(seed=0)
    n = env.terrain_generator.samples
    row = env.terrain_generator.heights[n : 2 * n + 1, n // 2]  # level 1 (d = 1: 0.23 m steps), along x at the tile's centre line
    riser = 4.0 + 0.02 * np.flatnonzero(np.diff(row) > 0.2)[0]  # where the first step up begins
    views = env._state_views[id(env.stepper.data)]
    toe = float(wd.contact.collidable_point_positions(env.model, wd.data.Data.build(env.model)).numpy()[:, 0].max())  # the feet's front edge, ahead of the base
    views["base_position"][0] = torch.tensor([riser - 0.005 - toe, 2.0, env.standing_height + 0.01], device=env.device)
    views["base_quaternion"][0] = torch.tensor([1.0, 0.0, 0.0, 0.0], device=env.device)
    views["base_velocity"][0] = torch.tensor([1.0, 0.0, 0.0, 0.0, 0.0, 0.0], device=env.device)
    mu = wp.to_torch(env.model.contact_params.mu)
    mu[0], mu[1] = 0.05, 0.8
    env.step(_zero(env))
    force = env.feet_contact_forces[0]
    assert bool((force[:, :2].norm(dim=1) > 5.0 * force[:, 2]).all()) and float(force[:, 0].max()) < -100.0  # pushed back
    assert envs.terms.stumbling(env).tolist() == [1.0, 0.0]
    landed = 0
    for _ in range(10):
        env.step(_zero(env))
        assert float(envs.terms.stumbling(env)[1]) == 0.0
        landed += int(env.feet_contact[1].all())
    assert landed >= 3  # the feet carried the robot (it lands from 2 cm and bounces)


def test_the_height_above_the_terrain_under_the_base():
    """On a heightfield of a slope and a 0.3 m step, terms.height_above_terrain is the base's z less the terrain's
    height right under its origin, h(x, y) (analytic), wherever the base is, and height_above_terrain_error is
    (that - base_height_target)^2; terms.base_height stays the height above the environment's origin."""
    x, y = np.arange(61) * 0.1 - 3.0, np.arange(61) * 0.1 - 3.0
    X, Y = np.meshgrid(x, y, indexing="ij")

    def h(px, py):
        return 0.1 * px - 0.05 * py + 0.3 * (py > 1.05)

    terrain = wd.terrain.HeightfieldTerrain(h(X, Y), origin=(-3.0, -3.0), spacing=(0.1, 0.1))
    model = _legs()
    model.terrain = terrain
    env = envs.LeggedEnv(model, num_envs=4, cfg=envs.LeggedEnvConfig(joint_noise=0.0, base_height_target=0.7), seed=0)
    env.reset(seed=0)
    places = np.array([[0.3, 0.4], [1.2, 1.5], [-0.7, 2.0], [0.55, -0.8]])
    views = env._state_views[id(env.stepper.data)]
    views["base_position"].copy_(torch.tensor(np.c_[places, h(*places.T) + env.standing_height + 0.05], device=env.device))
    env.step(_zero(env))
    base = env.state.base_position.cpu().numpy()
    above = base[:, 2] - h(base[:, 0], base[:, 1])
    np.testing.assert_allclose(envs.terms.height_above_terrain(env)[:, 0].cpu().numpy(), above, atol=1e-5)
    np.testing.assert_allclose(envs.terms.height_above_terrain_error(env).cpu().numpy(), (above - 0.7) ** 2, atol=1e-5)
    np.testing.assert_allclose(envs.terms.base_height(env)[:, 0].cpu().numpy(), base[:, 2], atol=1e-6)
    assert np.ptp(base[:, 2]) > 0.3  # the bases stand at different heights, above different ground


def test_a_fall_is_judged_above_the_terrain_under_the_base():
    """On a heightfield 1 m down for x < 0 and 1 m up for x > 0, with termination_height 1 (the standing height
    above the terrain under the base), over one 0.1 ms step (the bases move by micrometres): a base 5 cm above
    its standing height over the lower ground is not fallen though it is 0.95 m below its environment's origin,
    and one 5 cm below it over the upper ground is, though it is 0.95 m above its origin."""
    x = y = np.arange(41) * 0.1 - 2.0
    X, _ = np.meshgrid(x, y, indexing="ij")
    model = _legs()
    model.terrain = wd.terrain.HeightfieldTerrain(np.where(X < -0.05, -1.0, 1.0), origin=(-2.0, -2.0), spacing=(0.1, 0.1))
    cfg = envs.LeggedEnvConfig(joint_noise=0.0, termination_height=1.0, time_step=1e-4, policy_dt=1e-4)
    env = envs.LeggedEnv(model, num_envs=2, cfg=cfg, seed=0)
    env.reset(seed=0)
    views = env._state_views[id(env.stepper.data)]
    s = env.standing_height
    views["base_position"].copy_(torch.tensor([[-1.0, 0.0, -1.0 + s + 0.05], [1.0, 0.0, 1.0 + s - 0.05]], device=env.device))
    _, _, terminated, _, _ = env.step(_zero(env))
    assert terminated.tolist() == [False, True]
    assert float(envs.terms.base_height(env)[0, 0]) == pytest.approx(-1.0 + s + 0.05, abs=1e-3)  # (the fallen one was reset)


class PD(torch.nn.Module):
    """kp * error - kd * velocity from an ActuatorNet's input (N, n, 2 history): the newest of each."""

    def __init__(self, kp, kd, history=1):
        super().__init__()
        self.kp, self.kd, self.history, self.inputs = kp, kd, history, []

    def forward(self, x):
        self.inputs.append(x.clone())
        return self.kp * x[..., 0] - self.kd * x[..., self.history]


def test_an_actuator_net_of_the_pd_law_follows_the_built_in_servo():
    """An ActuatorNet computing kp (target - s) - kd sdot at every simulation step gives the built-in servo's trajectory
    to rounding (float64, 8 policy steps of random actions from a perturbed posture). The built-in servo's damper is
    implicit (model.implicit_damping), the network's torque explicit: the reference takes its damper explicit too,
    with a kd that the explicit step keeps stable. Eager (use_graph=False) here and below: the network records its
    inputs in Python, which a replayed CUDA graph does not run (tests/test_envs.py's graph test covers the network
    inside the graph)."""
    kp, kd, N = 100.0, 1.0, 3
    servo = envs.LeggedEnv(_legs(np.float64), num_envs=N, cfg=envs.LeggedEnvConfig(kp=kp, kd=kd), seed=1, use_graph=False)
    servo.model.implicit_damping = False
    net = PD(kp, kd)
    actuated = envs.LeggedEnv(_legs(np.float64), num_envs=N, cfg=envs.LeggedEnvConfig(actuator=ActuatorNet(net)), seed=1, use_graph=False)
    assert actuated.stepper.substeps == 1 and actuated.single_action_space.shape == (12,)
    servo.reset(seed=1)
    actuated.reset(seed=1)
    actions = torch.tensor(np.random.default_rng(0).uniform(-1, 1, (8, N, 12)), dtype=torch.float32)
    for a in actions:
        servo.step(a)
        actuated.step(a)
    assert len(net.inputs) == 8 * actuated.decimation
    for name in ("joint_positions", "joint_velocities", "base_position", "base_linear_velocity"):
        torch.testing.assert_close(getattr(actuated.state, name), getattr(servo.state, name), atol=1e-10, rtol=0)
    assert float(servo.state.joint_velocities.abs().max()) > 0.5  # it moved


def test_the_actuator_history_shifts_each_simulation_step_and_resets_per_environment():
    """history 4, 3 simulation steps per action: each call's input holds the position errors and velocities of the
    steps before it, newest first (zeros before the episode's first step); the newest is target - s and sdot at the
    state that step starts from; a reset empties an environment's history alone; torque_limit clips the torques."""
    H = 4
    net = PD(50.0, 0.5, history=H)
    env = envs.LeggedEnv(_legs(), num_envs=2, cfg=envs.LeggedEnvConfig(actuator=ActuatorNet(net, history=H), policy_dt=0.006, torque_limit=10.0), seed=0,
                         use_graph=False)
    env.reset(seed=0)
    action = torch.full((2, 12), 0.8, device=env.device)
    for _ in range(2):
        env.step(action)
    x = net.inputs
    assert len(x) == 6 and x[0].shape == (2, 12, 2 * H)
    for k in range(6):
        for j in range(H):
            older = x[k - j][..., [0, H]] if k >= j else torch.zeros(2, 12, 2, device=env.device)
            assert torch.equal(x[k][..., [j, H + j]], older), (k, j)
    previous = next(env._state_views[id(d)] for d in env.stepper.buffers if d is not env.stepper.data)  # where the last step began
    targets = env.default_joint_positions + 0.25 * action
    torch.testing.assert_close(x[-1][..., 0], targets - previous["joint_positions"], atol=1e-6, rtol=0)
    torch.testing.assert_close(x[-1][..., H], previous["joint_velocities"], atol=0, rtol=0)
    assert float(env.joint_torques.abs().max()) == 10.0 and torch.equal(env.joint_torques, env.actuation.torques)
    env.episode_length_buf[0] = env.max_episode_length - 1  # environment 0's episode ends at the next step
    env.step(action)
    assert not env.actuation.position_errors[0].any() and not env.actuation.velocities[0].any() and env.actuation.velocities[1].any()
    env.step(action)
    first = x[-3]  # environment 0's first step of its new episode
    assert not first[0][:, [1, 2, 3, H + 1, H + 2, H + 3]].any() and first[1][:, [1, 2, 3]].any()


def test_a_bad_actuator_network_or_configuration_is_refused_by_name():
    """A network whose output is not (N, n) or (N, n, 1) torques raises a ValueError naming it and the shapes; a
    history below 1, an unknown actuator, and a model with actuators of its own are refused."""

    class Wide(torch.nn.Module):
        def forward(self, x):
            return x

    env = envs.LeggedEnv(_legs(), num_envs=2, cfg=envs.LeggedEnvConfig(actuator=ActuatorNet(Wide(), history=2)), seed=0)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"network Wide returned shape \(2, 12, 4\) from its input \(2, 12, 4\).*\(2, 12\) or \(2, 12, 1\)"):
        env.step(_zero(env))

    def scalar_torque(x):
        return 1.0

    env = envs.LeggedEnv(_legs(), num_envs=2, cfg=envs.LeggedEnvConfig(actuator=ActuatorNet(scalar_torque)), seed=0)
    with pytest.raises(ValueError, match="network .*scalar_torque returned float"):
        env.step(_zero(env))
    with pytest.raises(ValueError, match="ActuatorNet.history must be an integer >= 1"):
        ActuatorNet(Wide(), history=0)
    with pytest.raises(TypeError, match="ActuatorNet.network must be a torch callable"):
        ActuatorNet("mlp.pt")
    with pytest.raises(ValueError, match="actuator must be 'pd', 'torque' or an ActuatorNet"):
        envs.LeggedEnvConfig(actuator="servo")
    actuated = wd.model.add_actuators(_legs(), "position", kp=100.0)
    with pytest.raises(ValueError, match="has actuators of its own"):
        envs.LeggedEnv(actuated, num_envs=2, cfg=envs.LeggedEnvConfig(actuator="torque"))


def test_torque_actions_are_held_over_the_policy_step():
    """actuator="torque": one env.step is `decimation` wd.model.step calls with joint torques action_scale * clip(action)
    clipped at torque_limit (bitwise), on joints without damping; env.joint_torques holds them."""
    env = envs.LeggedEnv(_legs(), num_envs=2, cfg=envs.LeggedEnvConfig(actuator="torque", action_scale=10.0, torque_limit=30.0), seed=0)
    env.reset(seed=3)
    assert env.model.number_of_actuators() == 0 and not env.model.damping.numpy().any()
    start = wd.data.Data.build(env.model, num_envs=2, base_position=env.stepper.data.base_position.numpy(),
                               base_quaternion=env.stepper.data.base_quaternion.numpy(), joint_positions=env.stepper.data.joint_positions.numpy())  # fmt: skip
    actions = torch.tensor(np.random.default_rng(0).uniform(-6, 6, (2, 12)), dtype=torch.float32)
    env.step(actions)
    torques = (10.0 * actions.clamp(-5, 5)).clamp(-30.0, 30.0).numpy().astype(np.float32)
    expected = start
    for _ in range(env.decimation):
        expected = wd.model.step(env.model, expected, joint_force_references=torques)
    np.testing.assert_array_equal(env.stepper.data.joint_positions.numpy(), expected.joint_positions.numpy())
    np.testing.assert_array_equal(env.stepper.data.base_position.numpy(), expected.base_position.numpy())
    np.testing.assert_array_equal(env.joint_torques.cpu().numpy(), torques)
