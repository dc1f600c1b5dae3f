"""The actuation model of `wd.model.step` (warpdyn.engine.evaluations.resultant_torques): Coulomb and viscous
joint friction, the joint-limit spring and its damper, the torque-speed clip, enable_friction. Reference:
JaxSim's `compute_resultant_torques` transcribed in NumPy (/tmp/jaxsim_sim.md section 3.2), as
robots.jaxsim_resultant_torques. The set-up is the one of tests/test_simulation.py (tests/robots.py).

Measured behaviour worth knowing:
- Coulomb friction uses wp.sign, which is 1 at 0: a joint at rest is pushed by -kc (failing test, bug
  report with a proposed fix).
"""

from __future__ import annotations

import numpy as np

import warpdyn as wd
import warpdyn.engine.evaluations as simulation
from robots import RK4, SIE, build, host, jaxsim_resultant_torques, rollout, wheels_urdf


# ------------------------------------------------------------------------------------------------
# Actuation


def test_actuation_matches_jaxsims_formulas(dtype):
    """Friction (Coulomb, viscous), the joint-limit spring with JaxSim's damping quirk (the damper
    multiplies the spring torque: tau_pl (1 - d sdot), zero inside the limits, and of either sign), and
    the torque-speed clip, for 6 wheels in 256 environments drawn so that every regime occurs
    (inside/below/above the limits; speeds from 1e-3 rad/s, below omega_th, exactly omega_th = 30,
    between, exactly omega_max = 100, beyond). Zero speed: test_coulomb_friction_vanishes_at_rest.

    Reference: jaxsim_resultant_torques. Two checks: the torque kernel (warpdyn.engine.step.
    resultant_torques; float64 measured 0 (same operations), bound 1e-12 relative; float32 bound 1e-5
    relative to max(1, |tau|) since the terms reach 1e4 N m), and one step of the wheels (M = diag(I),
    no bias forces: sdot+ = sdot + dt tau / I), tau recovered from the step: float64 bound 1e-9 relative
    (dt tau / I added to sdot of ~100 loses 1e-16 * 100 / (dt / I)), float32 bound 2e-2 relative (the
    same cancellation at eps 6e-8) . Then enable_friction = False drops the friction terms, as snapshot B
    of JaxSim.
    """
    rng = np.random.default_rng(5)
    n, N = 6, 256
    inertia = rng.uniform(0.5, 2.0, n)
    limits = np.sort(rng.uniform(-1.0, 1.0, (n, 2)), axis=1)
    model = build(wheels_urdf(inertia, limits), dtype)
    k, d = rng.uniform(0, 500, n), rng.uniform(0, 0.2, n)
    kc, kv = rng.uniform(0, 5, n), rng.uniform(0, 2, n)
    model.set_joint_parameters(limit_spring=k, limit_damper=d, friction_static=kc, friction_viscous=kv)
    model.actuation_params = wd.model.ActuationParams(torque_max=50.0)
    s = rng.uniform(-2.0, 2.0, (N, n))
    sdot = rng.choice([-1, 1], (N, n)) * rng.choice([1e-3, 10.0, 29.0, 30.0, 50.0, 99.0, 100.0, 120.0], (N, n)) * rng.uniform(0.9, 1.0, (N, n))
    sdot[:8] = rng.choice([30.0, -30.0, 100.0, -100.0], (8, n))
    tau_ref = rng.uniform(-100.0, 100.0, (N, n))
    data = wd.data.Data.build(model, joint_positions=s, joint_velocities=sdot, num_envs=N)
    s, sdot = host(data.joint_positions), host(data.joint_velocities)  # as stored (float32 rounding)
    a = model.actuation_params
    expected = jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, a)
    # every regime is exercised
    outside = (s < limits[:, 0]) | (s > limits[:, 1])
    assert outside.any() and (~outside).any() and (np.abs(sdot) == 30.0).any() and (np.abs(sdot) == 100.0).any()
    assert (np.abs(sdot) > 100).any() and ((np.abs(sdot) > 30) & (np.abs(sdot) < 100)).any()
    assert (np.abs(expected) == 50.0).any() and (outside & (np.abs(sdot) > 0) & (np.abs(expected) < 50.0)).any()
    f64 = dtype == np.float64
    # the terms reach |tau_ref| + |friction| + |spring| (1 + d |sdot|) ~ 2e4 N m before the clip
    scale = np.abs(tau_ref) + kc + kv * np.abs(sdot) + k * np.abs(s - np.clip(s, limits[:, 0], limits[:, 1])) * (1 + d * np.abs(sdot))
    tau = host(simulation.resultant_torques(model, data, tau_ref))
    np.testing.assert_allclose(tau, expected, rtol=0, atol=(1e-15 if f64 else 4e-7) * scale.max())
    stepped = wd.model.step(model, data, joint_force_references=tau_ref)
    recovered = (host(stepped.joint_velocities) - sdot) * inertia / model.time_step
    np.testing.assert_allclose(recovered, expected, rtol=0, atol=1e-9 if f64 else 5e-2)

    model.actuation_params = wd.model.ActuationParams(torque_max=50.0, enable_friction=False)
    expected = jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, model.actuation_params, friction=False)
    tau = host(simulation.resultant_torques(model, data, tau_ref))
    np.testing.assert_allclose(tau, expected, rtol=0, atol=(1e-15 if f64 else 4e-7) * scale.max())
    assert not np.allclose(tau, jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, model.actuation_params))


def test_coulomb_friction_vanishes_at_rest():
    """JaxSim's friction is -(kc sign(sdot) + kv sdot) with jnp.sign(0) = 0: a joint at rest with no
    torque stays at rest. Reference: that formula (/tmp/jaxsim_sim.md 3.2), exact.

    MEASURED (a bug report: this test fails): warpdyn's kernel uses wp.sign, which is 1 at 0 (and at
    -0.0), so a wheel (I = 1 kg m^2, kc = 1 N m) at rest gets tau = -1 N m: after one step
    sdot = -1e-3 rad/s (SIE and RK4), and it chatters between -1e-3 and 0 rad/s, creeping -5e-5 rad in 0.1 s.
    Proposed fix (kernels/actuation.py): replace wp.sign(sd) by a sign that is 0 at 0, e.g.
    `wp.where(sd > scalar(0.0), scalar(1.0), wp.where(sd < scalar(0.0), scalar(-1.0), scalar(0.0)))`.
    """
    for integrator in (SIE, RK4):
        model = build(wheels_urdf([1.0, 1.0]), np.float64, integrator=integrator)
        model.set_joint_parameters(friction_static=[1.0, 1.0], friction_viscous=[0.5, 0.5])
        data = wd.data.Data.build(model, joint_velocities=[0.0, -0.0], num_envs=1)
        np.testing.assert_array_equal(host(simulation.resultant_torques(model, data, [0.0, 0.0])), [[0.0, 0.0]])
        np.testing.assert_array_equal(host(simulation.resultant_torques(model, data, [0.3, -0.2])), [[0.3, -0.2]])
        data, _ = rollout(model, data, 10)
        np.testing.assert_array_equal(host(data.joint_velocities), [[0.0, 0.0]])
        np.testing.assert_array_equal(host(data.joint_positions), [[0.0, 0.0]])
