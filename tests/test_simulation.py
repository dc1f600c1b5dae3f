"""Simulation (`wd.model.step`): free bodies, soft contacts on terrains, a standing humanoid, energy,
MuJoCo's RK4, the extremes, per-environment health, and the actuation model.

References, one per test (its docstring says which and why its tolerance is what it is):
- closed forms: the parabola of free fall, the rotation about a principal axis, the penetration a
  Hunt/Crossley spring predicts under a resting box, Coulomb sliding on an incline;
- the exact discrete solutions of the integrators where one exists (semi-implicit Euler's, transcribed
  in NumPy from JaxSim's `integrators.py`, /tmp/jaxsim_sim.md section 3.5);
- conservation laws (energy of passive frictionless systems, angular momentum of a free body);
- MuJoCo 3 (C), RK4 integrator (mjINT_RK4), constraints, damping and springs off, same dt;
- JaxSim's `compute_resultant_torques` transcribed in NumPy (/tmp/jaxsim_sim.md section 3.2).

Everything runs on Warp's CPU device; the whole file takes about 30 s on a 2-core CPU once Warp's
kernel cache is warm (steps cost 0.3-1.5 ms here). Bounds measured on that CPU are given with the test
that uses them (ENERGY_DRIFT below, and the docstrings).

Measured behaviour worth knowing (see the extremes tests):
- semi-implicit Euler (SIE) integrates the inertial-fixed base velocity v = pdot - omega x p and then
  p+ = p + dt (v+ + omega+ x p): for a body away from the origin that spins, this is first order in dt
  even for a free fall (a free body dropped 1 m from the origin spinning at 10 rad/s is 1.85 cm off the
  parabola after 0.5 s at dt = 1 ms), as in JaxSim; RK4 is exact on parabolas.
- SIE's explicit Euler on the rigid-body rotation gains energy: a free asymmetric top gains 16-18 % of
  its kinetic energy and its angular momentum drifts 4-8 % in 10 s at dt = 1 ms (RK4: 1e-11, 5e-10).
- the tangential deformation m relaxes as mdot = -(K/D) m, integrated explicitly: unstable when
  dt K / D > 2 (dt > 4 ms at JaxSim's defaults K = 1e6, D = 2000; dt > 40 us at K = 1e8), and such
  divergence is NOT flagged while it stays finite (failing test, bug report with a proposed fix);
- m is updated with the velocity at the step's start (m+ = m + dt v_t): explicit Euler on the
  tangential spring, which leaves a torsional stick-slip chatter of a resting box at dt = 3 ms (SIE);
- JaxSim's estimated contact parameters (D = 1e4) make the ergoCub's light feet diverge at dt = 1 ms;
- Coulomb friction uses wp.sign, which is 1 at 0: a joint at rest is pushed by -kc (failing test, bug
  report with a proposed fix).
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
import warpdyn.engine.step as simulation

SIE = wd.model.IntegratorType.SemiImplicitEuler
RK4 = wd.model.IntegratorType.RungeKutta4
G = 9.81
ROUND = {np.float64: 1e-12, np.float32: 1e-5}

# A free body: principal axes along the link's axes, CoM at the link origin, no collision shape.
BODY_INERTIA = np.diag([0.02, 0.05, 0.08])
BODY_URDF = """<robot name="body"><link name="body"><inertial><mass value="2"/>
<inertia ixx="0.02" iyy="0.05" izz="0.08" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>"""

# A 2 kg cube of side 0.2 m: 8 collidable points at its corners (JaxSim's box points).
BOX_MASS, BOX_HALF = 2.0, 0.1
BOX_URDF = """<robot name="box"><link name="box"><inertial><mass value="2"/>
<inertia ixx="0.013333333333333334" iyy="0.013333333333333334" izz="0.013333333333333334" ixy="0" ixz="0" iyz="0"/>
</inertial><collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link></robot>"""


def chain_urdf(masses, length=0.5, offsets=None) -> str:
    """A chain of rods hanging from a world-fixed base, hinges about y; rod i has mass masses[i] (CoM at
    mid-length, rod inertia about x and y, 1e-4 m^2 times its mass about z); joint i sits at
    offsets[i] along z of its parent (default 0 for the first, -length for the others)."""
    parts = ['<robot name="chain">', '<link name="world"/>', '<link name="base"/>',
             '<joint name="world_to_base" type="fixed"><parent link="world"/><child link="base"/></joint>']
    parent = "base"
    for i, mass in enumerate(masses):
        I = mass * length**2 / 12.0
        z = (0.0 if i == 0 else -length) if offsets is None else offsets[i]
        parts.append(
            f'<link name="rod{i}"><inertial><origin xyz="0 0 {-length / 2}"/><mass value="{mass:.17g}"/>'
            f'<inertia ixx="{I:.17g}" iyy="{I:.17g}" izz="{mass * 1e-4:.17g}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        parts.append(
            f'<joint name="hinge{i}" type="continuous"><parent link="{parent}"/><child link="rod{i}"/>'
            f'<origin xyz="0 0 {z}"/><axis xyz="0 1 0"/></joint>'
        )
        parent = f"rod{i}"
    parts.append("</robot>")
    return "\n".join(parts)


def wheels_urdf(inertias, limits=None) -> str:
    """Wheels on a world-fixed base, each a joint about the world z axis through its CoM: gravity and
    Coriolis forces vanish and the mass matrix is diag(inertias), so sddot_i = tau_i / inertias[i]."""
    parts = ['<robot name="wheels">', '<link name="world"/>', '<link name="base"/>',
             '<joint name="world_to_base" type="fixed"><parent link="world"/><child link="base"/></joint>']
    for i, I in enumerate(inertias):
        kind, limit = "continuous", ""
        if limits is not None:
            kind, limit = "revolute", f'<limit lower="{limits[i][0]:.17g}" upper="{limits[i][1]:.17g}" effort="1" velocity="1"/>'
        parts.append(
            f'<link name="wheel{i}"><inertial><mass value="1"/>'
            f'<inertia ixx="0.1" iyy="0.1" izz="{I:.17g}" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        parts.append(
            f'<joint name="axle{i}" type="{kind}"><parent link="base"/><child link="wheel{i}"/>'
            f'<origin xyz="{0.5 * i} 0 0"/><axis xyz="0 0 1"/>{limit}</joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


def with_world_weld(urdf_text: str, root="root_link", xyz=(0.0, 0.0, 1.0), rpy=(0.1, 0.2, 0.3)) -> str:
    """The URDF with its root link welded to the world (a fixed base)."""
    i = urdf_text.index("<link ")
    weld = (
        f'<link name="world"/><joint name="world_weld" type="fixed"><parent link="world"/><child link="{root}"/>'
        f'<origin xyz="{xyz[0]} {xyz[1]} {xyz[2]}" rpy="{rpy[0]} {rpy[1]} {rpy[2]}"/></joint>'
    )
    return urdf_text[:i] + weld + urdf_text[i:]


def build(text, dtype, *, integrator=SIE, time_step=1e-3, **kwargs) -> wd.model.Model:
    model = wd.model.Model.build_from_model_description(text, dtype=dtype, **kwargs)
    model.integrator = integrator
    model.time_step = time_step
    return model


def contact_free(model) -> wd.model.Model:
    """The model with joint friction off and every collidable point disabled (limit springs are off by
    default): a passive, conservative system."""
    n = model.dofs()
    model.set_joint_parameters(friction_static=np.zeros(n), friction_viscous=np.zeros(n))
    nc = len(model.kin_dyn_parameters.contact_parameters.body)
    return wd.contact.with_collidable_points(model, enabled=[False] * nc) if nc else model


@functools.cache
def _icub_text(floating: bool) -> str:
    text = robots.icub_urdf()
    return text if floating else with_world_weld(text)


def rollout(model, data, steps, record=None, **step_kwargs):
    """`steps` steps; returns (data, [record(data) after each step])."""
    out = []
    for _ in range(steps):
        data = wd.model.step(model, data, **step_kwargs)
        if record is not None:
            out.append(record(data))
    return data, out


def qmul(a, b) -> np.ndarray:
    """Hamilton product of (w, x, y, z) quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])


def quat_from_rotvec(r) -> np.ndarray:
    r = np.asarray(r, dtype=np.float64)
    angle = np.linalg.norm(r)
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.r_[np.cos(angle / 2), np.sin(angle / 2) * r / angle]


def quat_distance(a, b) -> float:
    """max |a - b| up to the sign of the quaternion."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    return min(np.abs(a - b).max(), np.abs(a + b).max())


def host(array) -> np.ndarray:
    return np.asarray(array.numpy(), dtype=np.float64)


def mujoco_rk4(text, floating, dt, considered_joints=None):
    """MuJoCo's model of `text` with RK4 at dt, constraints, damping and springs off."""
    mj = robots.mujoco_model(text, considered_joints, floating=floating)
    off = mujoco.mjtDisableBit
    mj.opt.disableflags |= off.mjDSBL_CONSTRAINT | off.mjDSBL_DAMPER | off.mjDSBL_SPRING
    mj.opt.integrator = mujoco.mjtIntegrator.mjINT_RK4
    mj.opt.timestep = dt
    return mj


def mujoco_state(model, mj, data) -> robots.MujocoState:
    state = robots.MujocoState(mj, model.joint_names(), model.floating_base())
    state.set(host(data.base_position), host(data.base_quaternion), host(data.joint_positions),
              host(data.base_velocity), host(data.joint_velocities))
    return state


def chain_vs_mujoco(text, dtype, s0, sdot0, T, dt=1e-3, integrator=RK4):
    """Rolls a fixed-base chain out in warpdyn and in MuJoCo (RK4); returns the final data, MuJoCo's
    state, the max |s - s_mj|, |sdot - sdot_mj| and |E - E0| (warpdyn's mechanical energy, every step)."""
    model = contact_free(build(text, dtype, integrator=integrator, time_step=dt))
    data = wd.data.Data.build(model, joint_positions=s0, joint_velocities=sdot0)
    mj = mujoco_rk4(text, False, dt)
    state = mujoco_state(model, mj, data)
    E0 = host(wd.model.mechanical_energy(model, data))[0]
    steps = int(round(T / dt))
    data, energies = rollout(model, data, steps, record=lambda d: host(wd.model.mechanical_energy(model, d))[0])
    for _ in range(steps):
        mujoco.mj_step(mj, state.d)
    s_err = np.abs(host(data.joint_positions) - state.d.qpos[state.qpos_adr]).max()
    sdot_err = np.abs(host(data.joint_velocities) - state.d.qvel[state.dof_adr]).max()
    return data, state, s_err, sdot_err, np.abs(np.array(energies) - E0).max()


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
    assert host(data.valid)[0] == 1
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
    assert host(data.valid).tolist() == [1, 1]
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
    assert host(data.valid)[0] == 1
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
    assert host(data.valid)[0] == 1
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
    assert host(data.valid)[0] == 1
    a = (track[-1, 3] - track[199, 3]) / (400 * 1e-3)
    expected = G * (np.sin(theta) - mu * np.cos(theta))
    assert abs(a / expected - 1) < 1e-3
    assert track[-1, 3] > 0.5 and track[-1, 0] > 0.15
    assert quat_distance(host(data.base_quaternion), _slope_quaternion(theta)) < 1e-3

    xs, ys = np.arange(-2.0, 2.01, 0.25), np.arange(-1.0, 1.01, 0.25)
    heights = plane.height_at(xs[:, None], ys[None, :])
    heightfield = wd.terrain.HeightfieldTerrain(heights, origin=(xs[0], ys[0]), spacing=(0.25, 0.25))
    data_hf, track_hf = _slide(heightfield, dtype, theta, mu)
    assert host(data_hf.valid)[0] == 1
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
    assert host(data.valid)[0] == 1
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
    assert host(data.valid)[0] == 0
    model, data, z0 = _standing_ergocub(np.float64, 2.5e-4, params)
    data, track = _pd_rollout(model, data, 400)
    assert host(data.valid)[0] == 1
    assert track[:, 6].max() < 0.5
    assert np.abs(track[:, 2] - z0).max() < 3e-3


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
            assert host(data.valid)[0] == 1
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
    by O(dt^4): floating, float64, measured 3.1e-13 at dt = 1 ms and 1.9e-14 at 0.5 ms (ratio 16.8 = 2^4),
    bound 3e-12 and a ratio of at least 8. A fixed base makes both the same RK4 in joint coordinates:
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
        assert host(data.valid)[0] == 1
        d = state.d
        err = [np.abs(host(data.joint_positions) - d.qpos[state.qpos_adr]).max(),
               np.abs(host(data.joint_velocities) - d.qvel[state.dof_adr]).max()]
        if floating:
            V = host(data.base_velocity)
            R = robots.rotation_wxyz(d.qpos[3:7])
            err += [np.abs(host(data.base_position) - d.qpos[:3]).max(), quat_distance(host(data.base_quaternion), d.qpos[3:7]),
                    np.abs(V[:3] - d.qvel[:3]).max(), np.abs(V[3:] - R @ d.qvel[3:6]).max()]
        errors[dt] = max(err)
    tol = (3e-12 if floating else 1e-12) if dtype == np.float64 else 2e-5
    assert errors[1e-3] < tol, errors
    if len(errors) == 2:
        assert errors[1e-3] / errors[5e-4] > 8, errors


def test_icub_sie_equals_mujoco_euler(dtype):
    """The fixed-base iCub (32 joints), contact-free and frictionless, 100 steps of 1 ms of SIE against
    MuJoCo's semi-implicit Euler (mjINT_EULER: qvel += dt qacc, then qpos += dt qvel, damping off so that
    nothing is implicit): on a fixed base both are the same map in joint coordinates, so they agree to
    rounding, and so do their energies (both lose 0.0282 J: SIE's drift is the scheme's).
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
    assert host(data.valid)[0] == 1
    np.testing.assert_allclose(host(data.joint_positions), state.d.qpos[state.qpos_adr], rtol=0, atol=1e-12 if f64 else 2e-5)
    np.testing.assert_allclose(host(data.joint_velocities), state.d.qvel[state.dof_adr], rtol=0, atol=1e-12 if f64 else 2e-5)
    drift, drift_mj = host(wd.model.mechanical_energy(model, data))[0] - E0, state.d.energy.sum() - E0_mj
    assert abs(drift - drift_mj) < (1e-9 if f64 else 1e-4) and drift < -0.02


# ------------------------------------------------------------------------------------------------
# Extremes


def test_contact_stiffness_extremes(dtype):
    """The box on flat ground at the two ends of the stiffness range.

    - K = 1e3, D = 50, dt = 1 ms: stable; settles in 1 s (damping ratio 0.38, 0.12 s time constant) at
      the predicted delta = (m g / 4 / K)^(2/3) = 28.9 mm (measured 3.7e-5 relative after 1 s, both
      dtypes: the transient's tail; bound 2e-4).
    - K = 1e8, D = 2000, dt = 1 ms: refused with a clear error. The tangential deformation relaxes with
      rate K/D = 5e4 /s, integrated explicitly with dt K/D = 50 > 2: a sliding landing grows it
      geometrically (it was measured overflowing only after 185 steps in float64, finite meanwhile), so
      `step` refuses dt K/D beyond the integrator's stability limit instead.
    - K = 1e8 at dt = 20 us (dt K/D = 0.4): the sliding landing is stable for 0.02 s (valid, the box
      bounces 5.2 mm (bound 1 cm: little damping at this stiffness), |m| relaxed to 0 (bound 1 mm)).
    """
    model = build(BOX_URDF, dtype)
    model.contact_params = wd.model.SoftContactsParams(K=np.array([1e3, 1e8]), D=np.array([50.0, 2000.0]))
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, BOX_HALF], num_envs=2)
    with pytest.raises(ValueError, match=r"dt K/D = 50.*stability limit 2\.0 of SemiImplicitEuler"):
        wd.model.step(model, data)
    model.contact_params = wd.model.SoftContactsParams(K=1e3, D=50.0)
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, BOX_HALF])
    data, _ = rollout(model, data, 1000)
    assert host(data.valid)[0] == 1
    delta = (BOX_MASS * G / 4 / 1e3) ** (2 / 3)
    np.testing.assert_allclose(BOX_HALF - host(data.base_position)[2], delta, rtol=2e-4)

    model = build(BOX_URDF, dtype, time_step=2e-5)
    model.contact_params = wd.model.SoftContactsParams(K=1e8, D=2000.0)
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, BOX_HALF], base_linear_velocity=[0.5, 0.0, -0.3])
    data, track = rollout(model, data, 1000, record=lambda d: host(d.base_position)[2])
    assert host(data.valid)[0] == 1
    assert max(track) < BOX_HALF + 1e-2
    assert np.abs(host(data.tangential_deformation_state)).max() < 1e-3


def _landing(dtype, dt, integrator=SIE, T=0.5):
    """The box landing at 0.3 m/s while sliding at 0.5 m/s on flat ground, JaxSim's default contacts
    (K = 1e6, D = 2000), for T seconds: (final data, track of [base position, base velocity])."""
    model = build(BOX_URDF, dtype, integrator=integrator, time_step=dt)
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, BOX_HALF], base_linear_velocity=[0.5, 0.0, -0.3])
    data, track = rollout(model, data, int(round(T / dt)), record=lambda d: np.r_[host(d.base_position), host(d.base_velocity)])
    return data, np.array(track)


@functools.cache
def _reference_landing(dtype):
    data, track = _landing(dtype, 1e-4)
    assert host(data.valid)[0] == 1
    return track[-1, :3]


@pytest.mark.parametrize(
    "integrator, dt",
    [(SIE, 1e-3), (SIE, 2e-3), (RK4, 1e-3), (RK4, 3e-3), (RK4, 5e-3)],
    ids=["sie-1ms", "sie-2ms", "rk4-1ms", "rk4-3ms", "rk4-5ms"],
)
def test_time_steps_where_contacts_are_stable(integrator, dt, dtype):
    """The sliding landing (0.5 s) with JaxSim's default contacts at dt from 1 to 5 ms: SIE up to 2 ms,
    RK4 up to 5 ms (dt K/D = 2.5 < 2.78, RK4's stability limit on the real axis) come to rest where SIE
    at dt = 0.1 ms does (the reference, run once per dtype).

    Measured (both dtypes): final height equal within 1.1e-7 m (the settled delta is 0.29 mm); final x
    off by 0.17 mm (SIE, 1 ms), 0.82 mm (SIE, 2 ms: first order), 0.02 mm (RK4 1 and 3 ms) and 1.0 mm
    (RK4 5 ms: the landing is not smooth); highest bounce 2.6 mm above the start (SIE 2 ms); angular
    speed over the last 0.1 s at most 0.022 rad/s (SIE 2 ms, a decaying rocking). Bounds: height 1e-6 m,
    x 1.5 mm, bounce 5 mm, angular speed 0.05 rad/s (no torsional chatter: see the 3 ms test).
    """
    reference = _reference_landing(dtype)
    data, track = _landing(dtype, dt, integrator)
    assert host(data.valid)[0] == 1
    assert abs(track[-1, 2] - reference[2]) < 1e-6
    assert abs(track[-1, 0] - reference[0]) < 1.5e-3
    assert track[:, 2].max() < BOX_HALF + 5e-3
    assert np.abs(track[-len(track) // 5:, 6:]).max() < 5e-2


def test_time_step_3ms_with_sie_leaves_a_torsional_chatter(dtype):
    """At dt = 3 ms SIE (dt K/D = 1.5: the deformation relaxation itself is stable) the landed box rests
    in place but keeps oscillating about the vertical axis: the tangential deformation is integrated
    with the velocity at the start of the step (m+ = m + dt v_t, JaxSim's scheme), explicit Euler on the
    torsional spring (4 corners: K delta^p r^2 = 1.4e3 N m/rad on I_zz = 0.013 kg m^2, omega = 320 rad/s,
    damping ratio 0.32), which is unstable once omega dt > 2 x damping ratio, dt > 2 ms; the slip at the
    friction cone bounds the amplitude. Valid stays 1 (finite, bounded: not a divergence).
    Measured (both dtypes, last 0.5 s of 1 s): yaw rate up to 0.43 rad/s, other speeds below 0.016, the
    base within 0.22 mm of its place. Documented bounds: yaw-rate amplitude between 0.1 and 1 rad/s, base
    moving less than 1 mm. RK4 at 3 ms has no chatter (yaw rate below 1e-8 rad/s).
    """
    data, track = _landing(dtype, 3e-3, SIE, T=1.0)
    late = track[len(track) // 2:]
    assert host(data.valid)[0] == 1
    assert 0.1 < np.abs(late[:, 8]).max() < 1.0
    assert np.ptp(late[:, 0]) < 1e-3 and np.ptp(late[:, 1]) < 1e-3
    data, track = _landing(dtype, 3e-3, RK4, T=1.0)
    assert np.abs(track[len(track) // 2:, 8]).max() < 1e-8


@pytest.mark.parametrize("integrator, dt", [(SIE, 5e-3), (SIE, 1e-2), (RK4, 1e-2)], ids=["sie-5ms", "sie-10ms", "rk4-10ms"])
def test_time_steps_beyond_the_deformation_stability_limit_are_flagged_or_refused(integrator, dt, dtype):
    """The sliding landing at dt K/D = 2.5 and 5 (K = 1e6, D = 2000): out of contact the deformation
    is updated as m+ = (1 - dt K/D) m (SIE; RK4's factor is the 4th-order Taylor polynomial, unstable
    beyond dt K/D = 2.78): it diverges, for both integrators, as in JaxSim. The issue asks for each
    extreme to be stable, flagged (valid = 0) or refused with a clear error. Expected: `step` raises a
    ValueError naming the time step, or the environment is flagged within 0.5 s.

    MEASURED (a bug report: this test fails): neither, except float32 RK4 at 10 ms (flagged at step 35,
    by overflow). The box is launched (SIE: to 0.57 m at 5 ms, 5 m at 10 ms; RK4 0.28 m), |m| reaches
    1e14-1e53 m, and valid stays 1: the health check only catches non-finite values and quaternion
    steps > 0.1. Proposed fix: in `step`, raise a ValueError when model.time_step * max(K / D) >= 2
    (SIE; 2.78 for RK4); and/or flag an environment whose new |m| exceeds a physical bound (e.g. 1 m).
    """
    model = build(BOX_URDF, dtype, integrator=integrator, time_step=dt)
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, BOX_HALF], base_linear_velocity=[0.5, 0.0, -0.3])
    try:
        data, heights = rollout(model, data, int(round(0.5 / dt)), record=lambda d: host(d.base_position)[2])
    except ValueError as error:
        assert "time_step" in str(error) or "time step" in str(error)
        return
    assert host(data.valid)[0] == 0, (
        f"dt = {dt}: diverged without being flagged: max height {max(heights):.3g} m, "
        f"|m| = {np.abs(host(data.tangential_deformation_state)).max():.3g} m"
    )


def test_joint_speeds_up_to_100_rad_s():
    """Two references at joint speeds up to 100 rad/s (float64; float32 is covered by the actuation test):
    - the torque-speed curve: a wheel (I = 1 kg m^2, viscous friction 0.5 N m s/rad, Coulomb 1 N m) driven
      by tau_ref = 5000 N m (above torque_max = 3000) spins up to, and never beyond, omega_max = 100 rad/s;
      its speed follows the NumPy recursion of JaxSim's actuation (tau clipped to tau_max (1 - (|sdot| -
      30) / 70) above 30 rad/s) and SIE step by step (measured 0, bound 1e-10), and for RK4 the same
      speeds (tau is computed once per step at its start, so RK4's velocity update equals Euler's) and
      positions s+ = s + dt sdot + dt^2/2 tau/I;
    - the passive 3-rod chain thrown at 100 rad/s per joint, RK4 at 0.1 ms for 0.1 s, against MuJoCo's RK4:
      measured 8e-15 rad and 3e-12 rad/s, bound 1e-10 and 1e-9; energy drift (max over the steps) 2.3e-5 J
      of 4.5e3 J, bound 5e-5 J.
    """
    dt, I, steps = 1e-3, 1.0, 400
    expected = np.zeros((steps + 1, 2))
    a = wd.model.ActuationParams()
    for k in range(steps):
        s, w = expected[k]
        tau = _jaxsim_resultant_torques(5000.0, 0.0, w, np.array([[-np.inf, np.inf]]), 0.0, 0.0, 1.0, 0.5, a)[0]
        expected[k + 1] = [s, w + dt * tau / I]
        expected[k + 1, 0] = s + dt * expected[k + 1, 1]
    for integrator in (SIE, RK4):
        model = build(wheels_urdf([I]), np.float64, integrator=integrator, time_step=dt)
        model.set_joint_parameters(friction_static=[1.0], friction_viscous=[0.5])
        data = wd.data.Data.build(model)
        data, track = rollout(model, data, steps, record=lambda d: np.r_[host(d.joint_positions), host(d.joint_velocities)],
                              joint_force_references=[5000.0])
        track = np.array(track)
        np.testing.assert_allclose(track[:, 1], expected[1:, 1], rtol=1e-10, atol=0)
        if integrator == SIE:
            np.testing.assert_allclose(track[:, 0], expected[1:, 0], rtol=1e-10)
        else:
            tau = (expected[1:, 1] - expected[:-1, 1]) * I / dt
            rk4_s = np.cumsum(dt * expected[:-1, 1] + 0.5 * dt * dt * tau / I)
            np.testing.assert_allclose(track[:, 0], rk4_s, rtol=1e-10)
        assert track[:, 1].max() <= 100.0 and track[-1, 1] > 99.9

    s0, sdot0 = np.array([1.0, -0.5, 0.3]), np.array([100.0, -100.0, 100.0])
    _, _, s_err, sdot_err, drift = chain_vs_mujoco(chain_urdf([1.0, 1.0, 1.0]), np.float64, s0, sdot0, 0.1, dt=1e-4)
    assert s_err < 1e-10 and sdot_err < 1e-9 and drift < 5e-5


def test_link_mass_extremes(dtype):
    """Link masses from 1e-6 kg to 1e3 kg and mass ratios of 1e6, 3-rod chains, RK4 at 1 ms for 0.3 s:
    - uniform scaling (all rods 1e-6 kg or 1e3 kg, inertias scaled alike) leaves the motion unchanged:
      same trajectory as 1 kg rods (float64 measured 6e-15, bound 1e-12; float32 measured 4.8e-6, bound 5e-5);
    - ratios 1e6 ([1e3, 1e-3, 1e-3] and [1e-3, 1e3, 1e-3]) against MuJoCo's RK4: float64 measured 3e-15,
      bound 1e-11; float32 measured 2.7e-6, bound 5e-5;
    - a 1e3 kg rod at the tip of two 1e-3 kg rods passes near a configuration where the light rods align
      and the heavy rod can barely move radially (mass matrix condition 2e2 at the start, 8e7 with the
      light rods aligned): at dt = 1 ms the motion
      diverges, in MuJoCo too ("Nan, Inf or huge value in QPOS" at t = 0.094 s), and warpdyn flags it
      (valid = 0, finite frozen state).
    """
    s0 = np.array([1.0, -0.5, 0.3])
    f64 = dtype == np.float64

    def run(masses):
        model = contact_free(build(chain_urdf(masses), dtype, integrator=RK4))
        data, _ = rollout(model, wd.data.Data.build(model, joint_positions=s0), 300)
        assert host(data.valid)[0] == 1
        return np.r_[host(data.joint_positions), host(data.joint_velocities)]

    unit = run([1.0, 1.0, 1.0])
    for scale in (1e-6, 1e3):
        np.testing.assert_allclose(run([scale] * 3), unit, rtol=0, atol=1e-12 if f64 else 5e-5)
    for masses in ([1e3, 1e-3, 1e-3], [1e-3, 1e3, 1e-3]):
        data, _, s_err, sdot_err, _ = chain_vs_mujoco(chain_urdf(masses), dtype, s0, np.zeros(3), 0.3)
        assert host(data.valid)[0] == 1
        assert max(s_err, sdot_err) < (1e-11 if f64 else 5e-5)
    model = contact_free(build(chain_urdf([1e-3, 1e-3, 1e3]), dtype, integrator=RK4))
    data, _ = rollout(model, wd.data.Data.build(model, joint_positions=s0), 300)
    assert host(data.valid)[0] == 0
    assert np.all(np.isfinite(host(data.joint_positions))) and np.all(np.isfinite(host(data.joint_velocities)))


def test_chain_of_100_links_stretched(dtype):
    """A chain of 100 rods (5 cm, 0.1 kg each) held out straight and horizontal (a fully stretched,
    kinematically singular configuration; 100 parallel axes), released: RK4 at 1 ms for 0.05 s against
    MuJoCo's RK4. Tolerance: float64 measured 2.5e-11 rad and 2e-9 rad/s (rounding through 100 levels
    of recursion, speeds of 4 rad/s), bound 1e-9 and 1e-7; float32 measured 2.5e-7 and 1.0e-5, bound 1e-5
    and 2e-4."""
    n = 100
    s0 = np.zeros(n)
    s0[0] = np.pi / 2
    data, _, s_err, sdot_err, _ = chain_vs_mujoco(robots.pendulum_chain_urdf(n, length=0.05, mass=0.1), dtype, s0, np.zeros(n), 0.05)
    assert host(data.valid)[0] == 1
    f64 = dtype == np.float64
    assert s_err < (1e-9 if f64 else 1e-5) and sdot_err < (1e-7 if f64 else 2e-4)


def test_near_singular_coaxial_joints(dtype):
    """Two joints on the same axis at the same point, the link between them 1e-6 kg (2e-8 kg m^2 about
    the axis), then two 1 kg rods: the mass matrix is nearly singular (condition 3.3e7). RK4 at 1 ms for
    0.3 s against MuJoCo's RK4: float64 measured 3.2e-10, bound 1e-8; float32 measured 3.1e-3 (eps 6e-8
    times the condition number), bound 2e-2; both stay valid, energy drift below 1e-10 J (float64,
    measured 1e-11) and 2e-5 J (float32, measured 4.8e-6)."""
    text = chain_urdf([1e-6, 1.0, 1.0], offsets=[0.0, 0.0, -0.5])
    data, _, s_err, sdot_err, drift = chain_vs_mujoco(text, dtype, np.array([0.3, 0.4, -0.2]), np.array([0.0, 1.0, 0.0]), 0.3)
    assert host(data.valid)[0] == 1
    f64 = dtype == np.float64
    assert max(s_err, sdot_err) < (1e-8 if f64 else 2e-2)
    assert drift < (1e-10 if f64 else 2e-5)


def test_long_run_spinning_body(dtype):
    """A free body (no gravity) spinning for 1e4 SIE steps of 1 ms (10 s), two environments: env 0 about
    its principal z axis at 20 rad/s, env 1 about (0.3, 0.2, 20) rad/s (near the major axis).
    Reference: the quaternion stays unit (normalised each step: measured 1e-16 / 5e-8, bound 1e-6); env 0
    turns by exactly 2 atan(20 dt / 2) per step (measured 1.3e-14 / 4e-6 after 1e4 steps, bound 1e-10 /
    5e-5); env 1: SIE's explicit Euler on Euler's equations gains energy and tilts the angular momentum
    (measured 17.6 % and 4.4 %: documented bounds 25 % and 6 %, and at least 10 % and 3 %, so that a
    change of scheme shows here); RK4 for 2000 steps: both below 1e-9 (float64, measured 1e-11) / 2e-5
    (float32, measured 4e-6).
    """
    f64 = dtype == np.float64
    omega0 = np.array([[0.0, 0.0, 20.0], [0.3, 0.2, 20.0]])
    for integrator, steps in ((SIE, 10000), (RK4, 2000)):
        model = build(BODY_URDF, dtype, integrator=integrator, gravity=0.0)
        data = wd.data.Data.build(model, base_angular_velocity=omega0, num_envs=2)
        data, _ = rollout(model, data, steps)
        assert host(data.valid).tolist() == [1, 1]
        Q, V = host(data.base_quaternion), host(data.base_velocity)
        assert np.abs(np.linalg.norm(Q, axis=1) - 1).max() < 1e-6
        angle = 2 * steps * np.arctan(20 * 1e-3 / 2) if integrator == SIE else 20 * steps * 1e-3
        tol = (1e-10 if integrator == SIE else 1e-8) if f64 else 5e-5
        assert quat_distance(Q[0], [np.cos(angle / 2), 0, 0, np.sin(angle / 2)]) < tol
        R = robots.rotation_wxyz(Q[1])
        L0, L = BODY_INERTIA @ omega0[1], R @ BODY_INERTIA @ R.T @ V[1, 3:]
        E_drift = (0.5 * V[1, 3:] @ L) / (0.5 * omega0[1] @ L0) - 1
        L_drift = np.linalg.norm(L - L0) / np.linalg.norm(L0)
        if integrator == SIE:
            assert 0.10 < E_drift < 0.25 and 0.03 < L_drift < 0.06
        else:
            bound = 1e-9 if f64 else 2e-5
            assert abs(E_drift) < bound and L_drift < bound


def test_invalid_simulation_parameters_raise_at_build_time():
    """The extremes that are refused outright, each with a ValueError naming the culprit (reference: the
    documented checks of SoftContactsParams, ActuationParams, set_joint_parameters, the terrains, Model
    and step)."""
    with pytest.raises(ValueError, match="K"):
        wd.model.SoftContactsParams(K=-1.0)
    with pytest.raises(ValueError, match="D"):
        wd.model.SoftContactsParams(D=0.0)
    with pytest.raises(ValueError, match="mu"):
        wd.model.SoftContactsParams(mu=np.nan)
    with pytest.raises(ValueError, match="omega"):
        wd.model.ActuationParams(omega_th=200.0)
    with pytest.raises(ValueError, match="time_step"):
        wd.model.Model.build_from_model_description(BOX_URDF, time_step=0.0)
    with pytest.raises(ValueError, match="point up"):
        wd.terrain.PlaneTerrain(normal=(1.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="heights"):
        wd.terrain.HeightfieldTerrain(np.zeros((1, 5)))
    model = build(wheels_urdf([1.0, 1.0]), np.float64)
    with pytest.raises(ValueError, match="friction_static"):
        model.set_joint_parameters(friction_static=[-1.0, 0.0])
    with pytest.raises(ValueError, match="position_limits"):
        model.set_joint_parameters(position_limits=[[1.0, -1.0], [0.0, 1.0]])
    box = build(BOX_URDF, np.float64)
    box.contact_params = wd.model.SoftContactsParams(K=np.array([1e6, 1e6, 1e6]))
    with pytest.raises(ValueError, match="K"):
        wd.model.step(box, wd.data.Data.build(box, num_envs=2))


# ------------------------------------------------------------------------------------------------
# Health of a batch


@pytest.fixture(params=[None, True], ids=["device_layout", "env_fastest_layout"])
def layout(request, monkeypatch):
    """Both physical layouts of per-environment arrays (warpdyn.arrays): the CPU's env-major one and the
    GPU's env-fastest one, so that a CPU run covers the batched indexing of both."""
    monkeypatch.setattr(wd.config, "env_fastest", request.param)
    return request.param


def test_a_diverging_environment_is_flagged_frozen_and_reset(dtype, layout):
    """4 boxes dropped on flat ground from seeded random poses and velocities; env 2 gets a 1e6 N m torque
    in the first 5 steps (a 7.5e4 rad/s spin after one step: its quaternion step is far beyond the
    tolerance 0.1). Reference: a batch of the 3 others, simulated alone.
    - env 2 is flagged at the first step (valid = 0) and frozen at its initial state for the 200 steps;
    - the 3 others' trajectories equal the batch without env 2 bitwise (each environment is one
      thread's independent computation; measured: identical);
    - data.reset(model, envs=[2]) makes it valid with the zero state (base at the origin, identity
      quaternion, zero velocity and deformation) and leaves the others untouched; it then steps validly
      (it starts inside the ground, so it is pushed out hard: still finite, valid).
    Both memory layouts (env-major, the CPU's; env-fastest, the GPU's).
    """
    model = build(BOX_URDF, dtype)
    rng = np.random.default_rng(0)
    N, bad, keep = 4, 2, [0, 1, 3]
    position = np.c_[rng.uniform(-1, 1, (N, 2)), rng.uniform(0.1, 0.15, N)]
    linear, angular = rng.uniform(-0.5, 0.5, (N, 3)), rng.uniform(-1, 1, (N, 3))
    torque = np.zeros((N, 1, 6))
    torque[bad, 0, 4] = 1e6
    data = wd.data.Data.build(model, base_position=position, base_linear_velocity=linear, base_angular_velocity=angular, num_envs=N)
    initial = {name: host(getattr(data, f"{name}_state")) for name in ("base_position", "base_quaternion", "base_velocity")}
    alone = wd.data.Data.build(model, base_position=position[keep], base_linear_velocity=linear[keep],
                               base_angular_velocity=angular[keep], num_envs=3)
    for k in range(200):
        data = wd.model.step(model, data, link_forces=torque if k < 5 else None)
        alone = wd.model.step(model, alone)
        if k == 0:
            assert host(data.valid).tolist() == [1, 1, 0, 1]
    assert host(data.valid).tolist() == [1, 1, 0, 1]
    for name in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities", "tangential_deformation"):
        mine, theirs = getattr(data, f"{name}_state").numpy(), getattr(alone, f"{name}_state").numpy()
        assert np.array_equal(mine[keep], theirs), name
        if name in initial:
            assert np.array_equal(host(getattr(data, f"{name}_state"))[bad], initial[name][bad]), name
    assert np.abs(host(alone.base_velocity_state)).max() > 0.0  # the others did move

    reset = data.reset(model, envs=[bad])
    assert host(reset.valid).tolist() == [1, 1, 1, 1]
    np.testing.assert_array_equal(host(reset.base_position)[bad], [0.0, 0.0, 0.0])
    np.testing.assert_array_equal(host(reset.base_quaternion)[bad], [1.0, 0.0, 0.0, 0.0])
    np.testing.assert_array_equal(host(reset.base_velocity)[bad], np.zeros(6))
    np.testing.assert_array_equal(host(reset.tangential_deformation_state)[bad], np.zeros((8, 3)))
    for name in ("base_position", "base_quaternion", "base_velocity"):
        assert np.array_equal(getattr(reset, f"{name}_state").numpy()[keep], getattr(data, f"{name}_state").numpy()[keep])
    stepped = wd.model.step(model, reset)
    assert host(stepped.valid).tolist() == [1, 1, 1, 1]
    assert np.all(np.isfinite(host(stepped.base_position)))


# ------------------------------------------------------------------------------------------------
# Actuation


def _jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, a, friction=True):
    """JaxSim's compute_resultant_torques (/tmp/jaxsim_sim.md 3.2) in NumPy, elementwise."""
    tau_pl = -k * (np.minimum(s - limits[:, 0], 0.0) + np.maximum(s - limits[:, 1], 0.0))
    tau_pl = tau_pl - tau_pl * d * sdot  # jnp.positive is the identity: damping times the spring torque
    tau_fr = -(kc * np.sign(sdot) + kv * sdot) if friction else 0.0
    total = tau_ref + tau_fr + tau_pl
    speed = np.abs(sdot)
    limit = np.where(speed <= a.omega_th, a.torque_max,
                     np.where(speed <= a.omega_max, a.torque_max * (1 - (speed - a.omega_th) / (a.omega_max - a.omega_th)), 0.0))
    return np.clip(total, -limit, limit)


def test_actuation_matches_jaxsims_formulas(dtype):
    """Friction (Coulomb, viscous), the joint-limit spring with JaxSim's damping quirk (the damper
    multiplies the spring torque: tau_pl (1 - d sdot), zero inside the limits, and of either sign), and
    the torque-speed clip, for 6 wheels in 256 environments drawn so that every regime occurs
    (inside/below/above the limits; speeds from 1e-3 rad/s, below omega_th, exactly omega_th = 30,
    between, exactly omega_max = 100, beyond). Zero speed: test_coulomb_friction_vanishes_at_rest.

    Reference: _jaxsim_resultant_torques. Two checks: the torque kernel (warpdyn.engine.step.
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
    expected = _jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, a)
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
    expected = _jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, model.actuation_params, friction=False)
    tau = host(simulation.resultant_torques(model, data, tau_ref))
    np.testing.assert_allclose(tau, expected, rtol=0, atol=(1e-15 if f64 else 4e-7) * scale.max())
    assert not np.allclose(tau, _jaxsim_resultant_torques(tau_ref, s, sdot, limits, k, d, kc, kv, model.actuation_params))


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
