"""Simulation without contacts: the drift of the mechanical energy of passive, frictionless systems
(ENERGY_DRIFT), and warpdyn's integrators against MuJoCo's on the iCub. The set-up is the one of
tests/test_simulation.py (tests/robots.py: `build`, `contact_free`, `rollout`, `mujoco_rk4`).

References, one per test (its docstring says which and why its tolerance is what it is):
- conservation of the mechanical energy of passive frictionless systems;
- MuJoCo 3 (C), RK4 integrator (mjINT_RK4) or semi-implicit Euler (mjINT_EULER), constraints, damping
  and springs off, same dt.

Bounds were measured on Warp's CPU device (a 2-core CPU): ENERGY_DRIFT below, and the docstrings.
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import RK4, SIE, build, contact_free, host, mujoco_rk4, mujoco_state, quat_distance, rollout


def with_world_weld(urdf_text: str, root="root_link", xyz=(0.0, 0.0, 1.0), rpy=(0.1, 0.2, 0.3)) -> str:
    """The URDF with its root link welded to the world (a fixed base)."""
    i = urdf_text.index("<link ")
    weld = (
        f'<link name="world"/><joint name="world_weld" type="fixed"><parent link="world"/><child link="{root}"/>'
        f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/></joint>'
    )
    return urdf_text[:i] + weld + urdf_text[i:]


@functools.cache
def _icub_text(floating: bool) -> str:
    text = robots.icub_urdf()
    return text if floating else with_world_weld(text)


# ------------------------------------------------------------------------------------------------
# Energy and MuJoCo's RK4, without contacts

# max |E(t) - E(0)| [J] over 0.1 s (E = wd.model.mechanical_energy, sampled every step), measured on
# the CPU: (case, integrator, dt, dtype) -> (measured, bound). Cases: "pendulum": 5 rods of 0.5 m and
# 1 kg from rest at 0.5..1.5 rad (E0 = -10.9 J); "icub": the iCub (32 joints, floating, contact-free,
# joint friction off) from a seeded random state 1 m above the origin (E0 = 307 J, kinetic 3.1 J).
# SIE's drift is first order in dt (x10 per decade) and independent of the base's distance from the
# origin; it is the scheme's, not a bug: MuJoCo's semi-implicit Euler (mjINT_EULER) has the same drift on
# the fixed-base iCub (test_icub_sie_equals_mujoco_euler). RK4's is O(dt^4) until rounding (float64
# ~1e-13 J; float32 ~1e-5 J on 11 J, ~2e-4 J on 307 J) takes over. Bounds: 2x measured (rounding-bound
# entries: 3x or more).
ENERGY_DRIFT = {
    # (case, integrator, dt, dtype): (measured [J], bound [J])
    ("pendulum", "SemiImplicitEuler", 0.01, "float64"): (0.173, 0.35),
    ("pendulum", "SemiImplicitEuler", 0.001, "float64"): (0.0173, 0.035),
    ("pendulum", "SemiImplicitEuler", 0.0001, "float64"): (0.00173, 0.0035),
    ("pendulum", "RungeKutta4", 0.01, "float64"): (6.34e-08, 1.3e-07),
    ("pendulum", "RungeKutta4", 0.001, "float64"): (6.68e-12, 1.4e-11),
    ("pendulum", "RungeKutta4", 0.0001, "float64"): (3.55e-14, 1e-13),
    ("pendulum", "SemiImplicitEuler", 0.01, "float32"): (0.173, 0.35),
    ("pendulum", "SemiImplicitEuler", 0.001, "float32"): (0.0173, 0.035),
    ("pendulum", "SemiImplicitEuler", 0.0001, "float32"): (0.00174, 0.0035),
    ("pendulum", "RungeKutta4", 0.01, "float32"): (8.58e-06, 5e-05),
    ("pendulum", "RungeKutta4", 0.001, "float32"): (1.05e-05, 5e-05),
    ("pendulum", "RungeKutta4", 0.0001, "float32"): (1.72e-05, 5e-05),
    ("icub", "SemiImplicitEuler", 0.01, "float64"): (1.59, 3.2),
    ("icub", "SemiImplicitEuler", 0.001, "float64"): (0.159, 0.32),
    ("icub", "SemiImplicitEuler", 0.0001, "float64"): (0.0159, 0.032),
    ("icub", "RungeKutta4", 0.01, "float64"): (2.15e-09, 4.3e-09),
    ("icub", "RungeKutta4", 0.001, "float64"): (3.98e-13, 2e-12),
    ("icub", "RungeKutta4", 0.0001, "float64"): (5.12e-13, 2e-12),
    ("icub", "SemiImplicitEuler", 0.01, "float32"): (1.59, 3.2),
    ("icub", "SemiImplicitEuler", 0.001, "float32"): (0.159, 0.32),
    ("icub", "SemiImplicitEuler", 0.0001, "float32"): (0.0159, 0.032),
    ("icub", "RungeKutta4", 0.01, "float32"): (0.000122, 0.0006),
    ("icub", "RungeKutta4", 0.001, "float32"): (0.000214, 0.0006),
    ("icub", "RungeKutta4", 0.0001, "float32"): (0.000153, 0.0006),
}


@pytest.mark.parametrize("case", ["pendulum", "icub"])
def test_energy_drift_without_contacts(case, dtype):
    """Passive, frictionless, contact-free: the mechanical energy is conserved by the dynamics, so its
    drift is the integrator's (and rounding's). Reference: ENERGY_DRIFT, measured here; each bound is the
    measured value times 2 (rounded up). SIE's drift must also be first order (ratio 7 to 13 per decade
    of dt), RK4's at least 2 decades smaller than SIE's at dt = 1 ms."""
    drifts = {}
    for integrator in (SIE, RK4):
        for dt in (1e-2, 1e-3, 1e-4):
            if case == "pendulum":
                model = contact_free(build(robots.pendulum_chain_urdf(5), dtype, integrator=integrator, time_step=dt))
                data = wd.data.Data.build(model, joint_positions=np.linspace(0.5, 1.5, 5))
            else:
                model = contact_free(build(_icub_text(True), dtype, integrator=integrator, time_step=dt))
                rng = np.random.default_rng(0)
                data = wd.data.Data.build(
                    model, base_position=[0.0, 0.0, 1.0], joint_positions=rng.uniform(-0.5, 0.5, model.dofs()),
                    joint_velocities=rng.uniform(-1, 1, model.dofs()), base_linear_velocity=[0.1, -0.2, 0.3],
                    base_angular_velocity=[0.5, -0.3, 0.2])
            E0 = host(wd.model.mechanical_energy(model, data))[0]
            data, energies = rollout(model, data, int(round(0.1 / dt)), record=lambda d: host(wd.model.mechanical_energy(model, d))[0])
            assert host(data.healthy)[0] == 1
            drifts[(integrator.name, dt)] = np.abs(np.array(energies) - E0).max()
    name = np.dtype(dtype).name
    print(case, name, {k: f"{v:.3g}" for k, v in drifts.items()})
    for (integrator, dt), drift in drifts.items():
        measured, bound = ENERGY_DRIFT[(case, integrator, dt, name)]
        assert drift <= bound, (case, integrator, dt, name, drift, measured)
    for dt in (1e-2, 1e-3):
        assert 7 < drifts[("SemiImplicitEuler", dt)] / drifts[("SemiImplicitEuler", dt / 10)] < 13
    assert drifts[("RungeKutta4", 1e-3)] < 1e-2 * drifts[("SemiImplicitEuler", 1e-3)]


@pytest.mark.parametrize("floating", [True, False], ids=["floating", "fixed"])
def test_icub_matches_mujoco_rk4(floating, dtype):
    """The whole iCub (32 joints), contact-free and frictionless, from a seeded random state (joint speeds
    up to 2 rad/s, base spinning at 1.3 rad/s), 0.1 s of RK4 in warpdyn and in MuJoCo (mjINT_RK4,
    constraints, damping and springs off), same dt; joints compared by name, the base in MuJoCo's
    coordinates (free joint: world position and linear velocity of the base origin, body-frame angular
    velocity; quaternion integrated with the exponential map).

    Reference and tolerance: both are 4th-order schemes of the same ODE in different coordinates
    (warpdyn: Inertial base velocity, quaternion by Euler and normalisation at each stage), so they differ
    by O(dt^4): floating, float64, measured 3.7e-12 at dt = 1 ms and 2.3e-13 at 0.5 ms (ratio 16.1 = 2^4;
    the joints drawn in warpdyn's order, JaxSim's since round 16), bound 1e-11 and a ratio of at least 8. A fixed base makes both the same RK4 in joint coordinates:
    measured 1.4e-14, bound 1e-12. float32 (rounding): measured 2e-6, bound 2e-5.
    """
    text = _icub_text(floating)
    errors = {}
    for dt in (1e-3, 5e-4) if (floating and dtype == np.float64) else (1e-3,):
        model = contact_free(build(text, dtype, integrator=RK4, time_step=dt))
        rng = np.random.default_rng(3)
        n = model.dofs()
        kwargs = dict(joint_positions=rng.uniform(-0.5, 0.5, n), joint_velocities=rng.uniform(-2, 2, n))
        if floating:
            q = rng.normal(size=4)
            kwargs.update(base_position=[0.1, 0.2, 1.0], base_quaternion=q / np.linalg.norm(q),
                          base_linear_velocity=[0.3, -0.2, 0.5], base_angular_velocity=[1.0, -0.5, 0.7])
        data = wd.data.Data.build(model, **kwargs)
        mj = mujoco_rk4(text, floating, dt)
        state = mujoco_state(model, mj, data)
        steps = int(round(0.1 / dt))
        data, _ = rollout(model, data, steps)
        for _ in range(steps):
            mujoco.mj_step(mj, state.d)
        assert host(data.healthy)[0] == 1
        d = state.d
        err = [np.abs(host(data.joint_positions) - d.qpos[state.qpos_adr]).max(),
               np.abs(host(data.joint_velocities) - d.qvel[state.dof_adr]).max()]
        if floating:
            V = host(data.base_velocity)
            R = robots.rotation_wxyz(d.qpos[3:7])
            err += [np.abs(host(data.base_position) - d.qpos[:3]).max(), quat_distance(host(data.base_quaternion), d.qpos[3:7]),
                    np.abs(V[:3] - d.qvel[:3]).max(), np.abs(V[3:] - R @ d.qvel[3:6]).max()]
        errors[dt] = max(err)
    tol = (1e-11 if floating else 1e-12) if dtype == np.float64 else 2e-5
    assert errors[1e-3] < tol, errors
    if len(errors) == 2:
        assert errors[1e-3] / errors[5e-4] > 8, errors


def test_icub_sie_equals_mujoco_euler(dtype):
    """The fixed-base iCub (32 joints), contact-free and frictionless, 100 steps of 1 ms of SIE against
    MuJoCo's semi-implicit Euler (mjINT_EULER: qvel += dt qacc, then qpos += dt qvel, damping off so that
    nothing is implicit): on a fixed base both are the same map in joint coordinates, so they agree to
    rounding, and so do their energies (both lose 4.19 mJ: SIE's drift is the scheme's).
    Tolerance: float64 measured 1e-14, bound 1e-12; float32 measured 2e-6, bound 2e-5; energies 1e-9 J
    (float64) and 1e-4 J (float32) apart.
    """
    text = _icub_text(False)
    model = contact_free(build(text, dtype))
    rng = np.random.default_rng(3)
    n = model.dofs()
    data = wd.data.Data.build(model, joint_positions=rng.uniform(-0.5, 0.5, n), joint_velocities=rng.uniform(-2, 2, n))
    mj = mujoco_rk4(text, False, 1e-3)
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_EULER
    mj.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    state = mujoco_state(model, mj, data)
    E0, E0_mj = host(wd.model.mechanical_energy(model, data))[0], state.d.energy.sum()
    data, _ = rollout(model, data, 100)
    for _ in range(100):
        mujoco.mj_step(mj, state.d)
    mujoco.mj_forward(mj, state.d)
    f64 = dtype == np.float64
    assert host(data.healthy)[0] == 1
    np.testing.assert_allclose(host(data.joint_positions), state.d.qpos[state.qpos_adr], rtol=0, atol=1e-12 if f64 else 2e-5)
    np.testing.assert_allclose(host(data.joint_velocities), state.d.qvel[state.dof_adr], rtol=0, atol=1e-12 if f64 else 2e-5)
    drift, drift_mj = host(wd.model.mechanical_energy(model, data))[0] - E0, state.d.energy.sum() - E0_mj
    assert abs(drift - drift_mj) < (1e-9 if f64 else 1e-4) and drift < -1e-3


