"""Simulation (`wd.model.step`): free bodies, soft contacts on terrains and a standing humanoid. The other
simulation tests share this set-up (tests/robots.py: the free body, the box, `build`, `rollout`): energy
and MuJoCo's integrators in tests/test_simulation_energy.py, the extremes and per-environment health in
tests/test_simulation_extremes.py, the actuation model in tests/test_actuation.py.

References, one per test (its docstring says which and why its tolerance is what it is):
- closed forms: the parabola of free fall, the rotation about a principal axis, the penetration a
  Hunt/Crossley spring predicts under a resting box, Coulomb sliding on an incline;
- the exact discrete solutions of the integrators where one exists (semi-implicit Euler's, transcribed
  in NumPy from JaxSim's `integrators.py`, /tmp/jaxsim_sim.md section 3.5);
- conservation laws (energy and angular momentum of a free body).

Everything runs on Warp's CPU device; the four files take about 30 s together on a 2-core CPU once
Warp's kernel cache is warm (steps cost 0.3-1.5 ms here). Bounds measured on that CPU are given with the
test that uses them (in the docstrings).

Measured behaviour worth knowing:
- semi-implicit Euler (SIE) integrates the inertial-fixed base velocity v = pdot - omega x p and then
  p+ = p + dt (v+ + omega+ x p): for a body away from the origin that spins, this is first order in dt
  even for a free fall (a free body dropped 1 m from the origin spinning at 10 rad/s is 1.85 cm off the
  parabola after 0.5 s at dt = 1 ms), as in JaxSim; RK4 is exact on parabolas.
- JaxSim's estimated contact parameters (D = 1e4) make the ergoCub's light feet diverge at dt = 1 ms.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import (
    BODY_INERTIA, BODY_URDF, BOX_HALF, BOX_MASS, BOX_URDF, G, RK4, SIE, build, host, qmul, quat_distance, rollout,
)  # fmt: skip

ROUND = {np.float64: 1e-12, np.float32: 1e-5}


def quat_from_rotvec(r) -> np.ndarray:
    r = np.asarray(r, dtype=np.float64)
    angle = np.linalg.norm(r)
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * r / angle]


# ------------------------------------------------------------------------------------------------
# Free bodies


@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["sie", "rk4"])
def test_free_fall_matches_the_analytic_solution(dtype, integrator):
    """A floating body thrown from p0 with v0 (no rotation, no contact) for 500 steps of 1 ms.

    Reference: SIE's exact discrete solution v_k = v0 + k dt g, p_k = p0 + k dt v0 + dt^2 k (k + 1)/2 g
    (velocities first, then positions with the new velocities: /tmp/jaxsim_sim.md 3.5); RK4 integrates a
    quadratic exactly, so p_k = p0 + v0 t + g t^2 / 2. Tolerance: rounding only; float64 measured 6e-15,
    bound 1e-12; float32 measured 1.1e-5 (500 sums of O(1) numbers at eps 6e-8), bound 5e-5.
    """
    model = build(BODY_URDF, dtype, integrator=integrator)
    p0, v0, g = np.array([0.3, -0.2, 1.0]), np.array([1.0, 0.5, 2.0]), np.array([0.0, 0.0, -G])
    data = wd.data.Data.build(model, base_position=p0, base_linear_velocity=v0)
    K, dt = 500, model.time_step
    data, _ = rollout(model, data, K)
    if integrator == SIE:
        expected_p = p0 + K * dt * v0 + g * dt * dt * K * (K + 1) / 2
    else:
        expected_p = p0 + v0 * K * dt + 0.5 * g * (K * dt) ** 2
    expected_v = np.r_[v0 + g * K * dt, 0.0, 0.0, 0.0]
    tol = 1e-12 if dtype == np.float64 else 5e-5
    assert host(data.healthy)[0] == 1
    np.testing.assert_allclose(host(data.base_position), expected_p, rtol=0, atol=tol)
    np.testing.assert_allclose(host(data.base_velocity), expected_v, rtol=0, atol=tol)
    np.testing.assert_allclose(host(data.base_quaternion), [1.0, 0.0, 0.0, 0.0], rtol=0, atol=1e-7)


def _sie_free_body(p, Q, pdot, omega, dt, steps):
    """JaxSim's semi-implicit Euler for a free rigid body with CoM at the base origin, in NumPy
    (/tmp/jaxsim_sim.md 3.5): the Inertial base acceleration of the torque-free body under gravity is
    [g - omegadot x p - omega x pdot; omegadot], omegadot = -I_W^-1 (omega x I_W omega)."""
    g = np.array([0.0, 0.0, -G])
    for _ in range(steps):
        R = robots.rotation_wxyz(Q)
        I_W = R @ BODY_INERTIA @ R.T
        omegadot = np.linalg.solve(I_W, -np.cross(omega, I_W @ omega))
        v = pdot - np.cross(omega, p)
        v = v + dt * (g - np.cross(omegadot, p) - np.cross(omega, pdot))
        omega = omega + dt * omegadot
        p = p + dt * (v + np.cross(omega, p))
        Q = Q + dt * 0.5 * qmul(np.r_[0.0, omega], Q)
        Q = Q / np.linalg.norm(Q)
        pdot = v + np.cross(omega, p)
    return p, Q, pdot, omega


@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["sie", "rk4"])
def test_free_spin(dtype, integrator):
    """A floating body thrown while spinning, 500 steps of 1 ms, two environments: env 0 spins at
    10 rad/s about its principal z axis (tilted in the world), env 1 about a non-principal axis.

    References:
    - env 0: omega stays constant and the orientation turns about omega. SIE: each step turns by exactly
      2 atan(|omega| dt / 2) (normalise(Q + dt/2 (0, omega) Q) = normalise((1, omega dt/2) Q)); RK4: by
      |omega| dt up to O(dt^4) (measured 5e-12). The CoM (the base origin) follows the parabola under
      RK4 (measured 1e-14); SIE's inertial-fixed velocity makes it O(dt) off (measured 1.85 cm, bounded
      by 2.5 cm, and matched below by the transcription of JaxSim's scheme).
    - env 1 under SIE: the NumPy transcription of JaxSim's scheme (_sie_free_body), float64 measured
      5e-14, bound 1e-11; float32 measured 1.6e-5, bound 1e-4 (500 steps of eps 6e-8 on O(10) values).
    - env 1 under RK4: the world angular momentum R I R^T omega and the kinetic energy are conserved,
      float64 measured 2e-11 and 2e-12 relative, bound 1e-9; float32 measured 9e-7 and 2e-6, bound 2e-5.
      Under SIE they drift (explicit Euler on Euler's equations): measured 7.4e-4 and 1.8e-4, bound 2e-3.
    """
    model = build(BODY_URDF, dtype, integrator=integrator)
    Q0 = quat_from_rotvec([0.3, -0.5, 0.8])
    R0 = robots.rotation_wxyz(Q0)
    p0, v0 = np.array([0.3, -0.2, 1.0]), np.array([1.0, 0.5, 2.0])
    omega0 = np.stack([R0 @ [0.0, 0.0, 10.0], R0 @ [0.2, 6.0, 0.3]])
    data = wd.data.Data.build(model, base_position=p0, base_quaternion=Q0, base_linear_velocity=v0,
                              base_angular_velocity=omega0, num_envs=2)
    K, dt = 500, model.time_step
    data, _ = rollout(model, data, K)
    assert host(data.healthy).tolist() == [1, 1]
    p, Q, V = host(data.base_position), host(data.base_quaternion), host(data.base_velocity)
    f64 = dtype == np.float64

    # env 0: spin about a principal axis
    w = np.linalg.norm(omega0[0])
    angle = 2 * K * np.arctan(w * dt / 2) if integrator == SIE else w * K * dt
    expected_Q = qmul(quat_from_rotvec(omega0[0] / w * angle), Q0)
    assert quat_distance(Q[0], expected_Q) < (1e-11 if f64 else 2e-5)
    np.testing.assert_allclose(V[0, 3:], omega0[0], rtol=0, atol=1e-12 if f64 else 2e-5)
    t = K * dt
    parabola = p0 + v0 * t + 0.5 * np.array([0.0, 0.0, -G]) * t * t
    if integrator == RK4:
        np.testing.assert_allclose(p[0], parabola, rtol=0, atol=1e-11 if f64 else 5e-5)
    else:
        assert np.abs(p[0] - parabola).max() < 2.5e-2
        ref = _sie_free_body(p0, Q0, v0, omega0[0], dt, K)
        np.testing.assert_allclose(p[0], ref[0], rtol=0, atol=1e-11 if f64 else 1e-4)

    # env 1: a non-principal spin
    R = robots.rotation_wxyz(Q[1])
    L0, L = R0 @ BODY_INERTIA @ R0.T @ omega0[1], R @ BODY_INERTIA @ R.T @ V[1, 3:]
    E0, E = 0.5 * omega0[1] @ L0, 0.5 * V[1, 3:] @ L
    L_drift, E_drift = np.linalg.norm(L - L0) / np.linalg.norm(L0), abs(E - E0) / E0
    if integrator == SIE:
        p_ref, Q_ref, pdot_ref, omega_ref = _sie_free_body(p0, Q0, v0, omega0[1], dt, K)
        tol = 1e-11 if f64 else 1e-4
        np.testing.assert_allclose(p[1], p_ref, rtol=0, atol=tol)
        assert quat_distance(Q[1], Q_ref) < tol
        np.testing.assert_allclose(V[1], np.r_[pdot_ref, omega_ref], rtol=0, atol=tol)
        assert L_drift < 2e-3 and E_drift < 2e-3
    else:
        bound = 1e-9 if f64 else 2e-5
        assert L_drift < bound and E_drift < bound


# ------------------------------------------------------------------------------------------------
# Soft contacts on terrains


def _slope_quaternion(theta):
    """The rotation about y by theta: the body's z axis becomes the normal (sin theta, 0, cos theta) of
    a plane that descends along +x; the body's +x axis points down the slope."""
    return np.array([np.cos(theta / 2), 0.0, np.sin(theta / 2), 0.0])


def _box_on(terrain, dtype, theta=0.0, mu=0.5, K=1e6, D=2000.0):
    """The box resting (zero velocity) with its bottom face on the terrain through the origin with slope
    theta, its corners just touching (delta = 0)."""
    model = build(BOX_URDF, dtype)
    model.terrain = terrain
    model.contact_params = wd.model.SoftContactsParams(K=K, D=D, mu=mu)
    n = np.array([np.sin(theta), 0.0, np.cos(theta)])
    data = wd.data.Data.build(model, base_position=BOX_HALF * n, base_quaternion=_slope_quaternion(theta))
    return model, data, n


def _penetrations(model, data, n) -> np.ndarray:
    """delta of the 4 bottom corners (JaxSim orders a box's bottom corners first) on the plane through
    the origin with normal n: -(p_C . n)."""
    return -(host(wd.contact.collidable_point_positions(model, data))[:4] @ n)


def test_box_rests_on_flat_terrain_at_the_predicted_penetration(dtype):
    """The box released at rest touching flat ground settles in 0.6 s (damping ratio ~0.15, time constant
    30 ms) where each of its 4 bottom corners carries m g / 4:
    delta = (m g / 4 / K)^(1/(1+p)) = 0.289 mm (K = 1e6, p = 0.5), and it does not move sideways.

    Reference: the static balance of JaxSim's spring K (delta + eps)^p delta (eps = 2.2e-16 is far below
    delta). Tolerance: float64 measured 2e-10 relative after 0.6 s (the transient's tail), bound 1e-8;
    float32 measured 5e-6 (the base height 0.1 m carries an ulp of 7e-9 m, 2.6e-5 of delta), bound 1e-4.
    Speeds: measured 4e-11 / 1e-6 m/s, bounds 1e-6 / 1e-4.
    """
    model, data, n = _box_on(wd.terrain.FlatTerrain(), dtype)
    data, _ = rollout(model, data, 600)
    expected = (BOX_MASS * G / 4 / 1e6) ** (1 / 1.5)
    tol = 1e-8 if dtype == np.float64 else 1e-4
    assert host(data.healthy)[0] == 1
    np.testing.assert_allclose(_penetrations(model, data, n), expected, rtol=tol)
    np.testing.assert_allclose(host(data.base_position), [0.0, 0.0, BOX_HALF - expected], rtol=0, atol=tol * expected)
    np.testing.assert_allclose(host(data.base_velocity), 0.0, rtol=0, atol=1e-6 if dtype == np.float64 else 1e-4)


def test_box_sticks_below_the_friction_angle(dtype):
    """The box released at rest on a 15 degree PlaneTerrain with mu = 0.5 (tan 15 = 0.27 < mu) for 1 s.

    References:
    - normal balance: the 4 corner forces K delta_i^1.5 sum to m g cos(theta), i.e. the mean of
      delta_i^1.5 is (m g cos(theta) / 4 / K), the brief's formula delta = (m g cos / 4 / K)^(2/3) for
      equal loads. float64 measured 8e-8 relative, bound 1e-6; float32 measured 1.1e-5, bound 1e-4
      (delta = 0.28 mm next to coordinates of 0.1 m: ulp/delta = 3e-5).
    - moment balance: friction m g sin(theta) acts at the contact plane, 0.1 m below the CoM, so the
      downhill corners carry m g (cos + sin) / 4 and the uphill ones m g (cos - sin) / 4 (measured within
      0.055 %, bound 0.5 %: the lever arms change by delta and by the tilt, O(delta / 0.1 m) = 0.3 %); the
      centre therefore sinks 0.8 % less than the equal-load delta.
    - sticking: once the transient has decayed (it e-folds in ~0.1 s), the box no longer moves. Creep
      bound: displacement along the slope between 0.5 s and 1 s below 1e-6 m (measured 1.6e-7 m, both
      dtypes: the tail of the transient; a sticking contact has v_t = 0 and mdot_t = v_t = 0 exactly) and
      speed at 1 s below 1e-5 m/s (measured 8e-8 / 2.5e-6). Total displacement below 0.5 mm (measured 0.18 mm: the elastic
      tangential deflection tan(theta) delta = 0.08 mm plus a slip while the normal force builds up).
    """
    theta, mu = np.deg2rad(15.0), 0.5
    model, data, n = _box_on(wd.terrain.PlaneTerrain(normal=(np.sin(theta), 0.0, np.cos(theta))), dtype, theta, mu)
    down = np.array([np.cos(theta), 0.0, -np.sin(theta)])
    data, track = rollout(model, data, 1000, record=lambda d: host(d.base_position) @ down)
    assert host(data.healthy)[0] == 1
    delta = _penetrations(model, data, n)
    f64 = dtype == np.float64
    np.testing.assert_allclose(np.mean(delta**1.5), BOX_MASS * G * np.cos(theta) / 4 / 1e6, rtol=1e-6 if f64 else 1e-4)
    x_corner = host(wd.contact.collidable_point_positions(model, data))[:4] @ down
    downhill = x_corner > np.mean(x_corner)
    assert downhill.sum() == 2
    load = np.where(downhill, np.cos(theta) + np.sin(theta), np.cos(theta) - np.sin(theta))
    np.testing.assert_allclose(delta, (BOX_MASS * G * load / 4 / 1e6) ** (1 / 1.5), rtol=5e-3)
    track = np.array(track) - BOX_HALF * (n @ down)
    assert abs(track[-1] - track[499]) < 1e-6
    assert abs(track[-1]) < 5e-4
    assert np.abs(host(data.base_velocity)[:3]).max() < 1e-5


def _slide(terrain, dtype, theta, mu, steps=600):
    model, data, _ = _box_on(terrain, dtype, theta, mu)
    down = np.array([np.cos(theta), 0.0, -np.sin(theta)])
    return rollout(model, data, steps, record=lambda d: np.r_[host(d.base_position), host(d.base_velocity)[:3] @ down])


def test_box_slides_above_the_friction_angle_and_a_heightfield_plane_equals_the_plane(dtype):
    """The box released at rest on a 20 degree PlaneTerrain with mu = 0.2 (tan 20 = 0.36 > mu) slides.

    References:
    - Coulomb: acceleration along the slope g (sin(theta) - mu cos(theta)) = 1.512 m/s^2, measured from
      the velocity between 0.2 s and 0.6 s (the normal transient has decayed by then): measured 2e-5
      relative (both dtypes), bound 1e-3. The box does not tip (the slope is below 45 degrees): its
      orientation stays within 1e-3 of the slope's (measured 1.8e-4: the moment of friction).
    - a HeightfieldTerrain sampling the same plane on a 0.25 m grid (bilinear interpolation and its
      gradient are exact on a plane; the box crosses cells) gives the same trajectory: float64 measured
      4e-15, bound 1e-12; float32 measured 2.4e-6 (interpolation rounds differently), bound 2e-5.
    """
    theta, mu = np.deg2rad(20.0), 0.2
    plane = wd.terrain.PlaneTerrain(normal=(np.sin(theta), 0.0, np.cos(theta)))
    data, track = _slide(plane, dtype, theta, mu)
    track = np.array(track)
    assert host(data.healthy)[0] == 1
    a = (track[-1, 3] - track[199, 3]) / (400 * 1e-3)
    expected = G * (np.sin(theta) - mu * np.cos(theta))
    assert abs(a / expected - 1) < 1e-3
    assert track[-1, 3] > 0.5 and track[-1, 0] > 0.15
    assert quat_distance(host(data.base_quaternion), _slope_quaternion(theta)) < 1e-3

    xs, ys = np.arange(-2.0, 2.01, 0.25), np.arange(-1.0, 1.01, 0.25)
    heights = plane.height(xs[:, None], ys[None, :])
    heightfield = wd.terrain.HeightfieldTerrain(heights, origin=(xs[0], ys[0]), spacing=(0.25, 0.25))
    data_hf, track_hf = _slide(heightfield, dtype, theta, mu)
    assert host(data_hf.healthy)[0] == 1
    np.testing.assert_allclose(np.array(track_hf), track, rtol=0, atol=1e-12 if dtype == np.float64 else 2e-5)


# ------------------------------------------------------------------------------------------------
# A standing humanoid


@functools.cache
def _ergocub(dtype) -> wd.model.Model:
    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=dtype)
    return wd.model.reduce(full, robots.seed_joints(full.joint_names()))


def _standing_ergocub(dtype, time_step=1e-3, contact_params=None):
    """The seed's ergoCub (12 leg joints; 2 boxes per foot, 8 bottom corners per foot) at s0 = 0, base
    upright with the soles on the ground (lowest collidable point at z = 0), at rest."""
    model = _ergocub(dtype)
    model = wd.model.reduce(model, model.joint_names())  # a fresh copy: the tests change its parameters
    model.time_step = time_step
    if contact_params is not None:
        model.contact_params = contact_params
    data = wd.data.Data.build(model)
    z0 = -host(wd.contact.collidable_point_positions(model, data))[:, 2].min()
    return model, data.replace(model, base_position=[0.0, 0.0, z0]), z0


def _pd_rollout(model, data, steps, Kp=3000.0, Kd=5.0):
    """Joint PD to s0 = 0 (tau = -Kp s - Kd sdot, computed at each step's start); the URDF's joint damping
    (2 N m s/rad, JaxSim's viscous friction) adds to Kd."""
    out = []
    for _ in range(steps):
        s, sdot = host(data.joint_positions), host(data.joint_velocities)
        data = wd.model.step(model, data, joint_force_references=-Kp * s - Kd * sdot)
        R = robots.rotation_wxyz(host(data.base_quaternion))
        tilt = np.degrees(np.arccos(min(1.0, R[2, 2])))
        yaw = np.degrees(np.arctan2(R[1, 0], R[0, 0]))
        out.append(np.r_[host(data.base_position), tilt, yaw, np.abs(s).max(), np.abs(sdot).max()])
    return data, np.array(out)


def test_ergocub_stands_for_one_second_with_joint_pd(dtype):
    """The ergoCub standing on flat ground with JaxSim's default contacts (K = 1e6, D = 2000, mu = 0.5)
    and joint PD (Kp = 3000 N m/rad, Kd = 5 N m s/rad), 1000 steps of 1 ms.

    Reference: statics. The 16 sole corners carry the robot's 56.6 kg: equal loads would sink them by
    (m g / 16 / K)^(2/3) = 1.06 mm; the CoM is 3.4 cm behind the soles' centre, so the heels carry more.
    The soft contact's rocking mode (~8 rad/s) is lightly damped (damping ratio < 0.01), so the robot
    rocks by a fraction of a degree for seconds: that is physics, not drift. Measured (both dtypes):
    base height -1.82 mm to 0 (mean over the last 0.5 s -1.21 mm), base x drift 8.9 mm, y 2e-5 m, tilt
    0.83 degree, yaw 2e-4 degree, joints within 3.6e-3 rad of s0. Bounds: height in [-3 mm, +0.5 mm] and
    its late mean within 0.5 mm of -1.06 mm, |x|, |y| < 2 cm, tilt < 2 degrees, yaw < 0.05 degree,
    joints within 0.02 rad.
    (With Kp = 500 the robot sags 0.034 rad at the joints and leans 4.7 degrees in 1 s, identical at
    dt = 0.25 ms, i.e. a physical lean, not a numerical one.)
    """
    model, data, z0 = _standing_ergocub(dtype)
    data, track = _pd_rollout(model, data, 1000)
    assert host(data.healthy)[0] == 1
    dz = track[:, 2] - z0
    assert -3e-3 < dz.min() and dz.max() < 5e-4
    sink = (wd.model.total_mass(model) * G / 16 / 1e6) ** (2 / 3)
    assert abs(dz[500:].mean() + sink) < 5e-4
    assert np.abs(track[:, :2]).max() < 2e-2
    assert track[:, 3].max() < 2.0
    assert np.abs(track[:, 4]).max() < 5e-2
    assert track[:, 5].max() < 2e-2


def test_ergocub_with_jaxsims_estimated_contact_parameters_needs_a_smaller_time_step():
    """JaxSim's estimate_good_contact_parameters for the ergoCub gives K = 9.1e5 and D = 1e4 (clipped).
    Explicit contact damping D delta^q on the feet, whose ankle joints have inertias of 0.013-0.015 kg m^2,
    is unstable at dt = 1 ms: the simulation diverges (joint speeds over 1e3 rad/s) and is flagged
    (valid = 0) within 30 steps (measured: step 26, both dtypes, after joint speeds of 7e3 rad/s: the
    flag comes late, the state it freezes is already meaningless). At dt = 0.25 ms the same robot stands
    (measured over 0.1 s: joint speeds up to 0.096 rad/s, bound 0.5; base height within 1.5 mm, bound
    3 mm). Reference: the outcome itself, documented. Float64 only (float32 measured the same).
    """
    params = wd.contact.estimate_good_contact_parameters(_ergocub(np.float64))
    assert params.K == pytest.approx(913369.47, rel=1e-6) and params.D == 1e4
    model, data, _ = _standing_ergocub(np.float64, 1e-3, params)
    data, track = _pd_rollout(model, data, 40)
    assert host(data.healthy)[0] == 0
    model, data, z0 = _standing_ergocub(np.float64, 2.5e-4, params)
    data, track = _pd_rollout(model, data, 400)
    assert host(data.healthy)[0] == 1
    assert track[:, 6].max() < 0.5
    assert np.abs(track[:, 2] - z0).max() < 3e-3

