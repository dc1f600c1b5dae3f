"""warpdyn against MuJoCo on the hand-written MJCF fixtures (tests/mjcf_fixtures.py): the armature in the
mass matrix and the kinetic energy, the passive forces (springs, dampers, gravity compensation), the
actuators' forces, the accelerations of the smooth dynamics, one step of MuJoCo's Euler (implicit joint
damping, or explicit with eulerdamp disabled) and of its RK4, float64 to 1e-10 of the largest value;
gradients with respect to armature, damping, stiffness, springref, gravity compensation, the actuators'
parameters and the controls against central finite differences; float32 near float64.

MuJoCo's generalized velocity differs from warpdyn's Mixed one only in the free joint's angular part (body
frame in MuJoCo, world frame in warpdyn) and in the order of the dofs: qvel = T nu with
T = blockdiag(I, R^T, P), so M = T^T M_mj T, forces f = T^T f_mj and, since d(R^T w)/dt = R^T dw/dt,
qacc = T nu_dot. MuJoCo's constraints (joint limits, frictionloss) are disabled in the references
(mjcf_models.reference_model): warpdyn models the smooth dynamics.
"""

import warnings

import mujoco
import numpy as np
import pytest
import warp as wp

import gradcheck
import mjcf_models as mm
import robots
import warpdyn as wd
from warpdyn.description import NotModelledWarning

Model = wd.model.Model

GRAVCOMP_ARM = mm.GRAVCOMP.replace(mm.GRAVCOMP[mm.GRAVCOMP.index('    <body name="balloon"') : mm.GRAVCOMP.index("  </worldbody>")], "")
"""GRAVCOMP without its free balloon (warpdyn simulates one robot): gravcomp 1 and 0.5 on two links, and
actuatorgravcomp on gj2 (whose compensation warpdyn applies as a passive force, MuJoCo as an actuator's)."""

FIXTURES = {name: xml for name, xml in mm.FIXTURES.items() if name not in ("BALL", "GRAVCOMP", "UNSUPPORTED")}
FIXTURES["GRAVCOMP_ARM"] = GRAVCOMP_ARM
ACTUATED = [name for name in FIXTURES if mm.load(FIXTURES[name]).nu > 0]


def build(xml: str, dtype=np.float64) -> Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        return Model.build_from_model_description(xml, dtype=dtype)


class Pair:
    """A fixture as a warpdyn model and a MuJoCo model, and random states of both."""

    def __init__(self, name: str, dtype=np.float64):
        self.name = name
        self.model = build(FIXTURES[name], dtype)
        self.mj = mm.load(FIXTURES[name])
        self.st = robots.MujocoState(self.mj, self.model.joint_names(), self.model.floating_base())
        self.rng = robots.rng_for("mjcf dynamics", name)

    def state(self):
        """(data, qpos, qvel, T): a random warpdyn state, MuJoCo's, and qvel = T nu (see the module docstring)."""
        data, state = robots.random_data(self.model, self.rng)
        self.st.set(*state)
        return data, self.st.d.qpos.copy(), self.st.d.qvel.copy(), self.T(state[1])

    def T(self, quaternion_wxyz) -> np.ndarray:
        n, nv = self.model.dofs(), self.mj.nv
        floating = self.model.floating_base()
        T = np.zeros((nv, n + (6 if floating else 0)))
        if floating:
            T[:3, :3] = np.eye(3)
            T[3:6, 3:6] = robots.rotation_wxyz(quaternion_wxyz).T
        for j, dof in enumerate(self.st.dof_adr):
            T[dof, j + (6 if floating else 0)] = 1.0
        return T

    def generalized(self, array) -> np.ndarray:
        """A warpdyn (6 + n) quantity as MuJoCo's coordinates see it: all of it for a floating base, the joints'
        part for a fixed one."""
        x = np.asarray(array.numpy() if isinstance(array, wp.array) else array, dtype=np.float64)
        return x if self.model.floating_base() else x[..., 6:]

    def ctrl(self):
        return mm.random_ctrl(self.mj, self.rng)


def close(actual, expected, tol=mm.TOL, what=""):
    robots.assert_close(actual, expected, tol, what)


@pytest.mark.parametrize("name", sorted(FIXTURES))
def test_mass_matrix_and_kinetic_energy_count_the_armature(name):
    """M (CRBA) = T^T M_mj T with MuJoCo's armature on the diagonal; K = 1/2 nu^T M nu; RNEA's joint forces
    M qdd + h (armature_j qdd_j included)."""
    pair = Pair(name)
    model = pair.model
    for _ in range(3):
        data, qpos, qvel, T = pair.state()
        M_mj = mm.full_mass_matrix(pair.mj, qpos)
        M = wd.model.free_floating_mass_matrix(model, data).numpy()
        M = M if model.floating_base() else M[6:, 6:]
        close(M, T.T @ M_mj @ T, what=f"{name}: M")
        K = float(wd.model.kinetic_energy(model, data).numpy().reshape(-1)[0])
        close(K, 0.5 * qvel @ M_mj @ qvel, what=f"{name}: kinetic energy")
        nu_dot = pair.rng.normal(size=M.shape[0])
        base, joints = (nu_dot[:6], nu_dot[6:]) if model.floating_base() else (None, nu_dot)
        f_B, tau = wd.model.inverse_dynamics(model, data, joint_accelerations=joints, base_acceleration=base)
        h = pair.generalized(wd.model.free_floating_bias_forces(model, data))
        Q = np.concatenate([f_B.numpy(), tau.numpy()]) if model.floating_base() else tau.numpy()
        close(Q, M @ nu_dot + h, what=f"{name}: RNEA")


@pytest.mark.parametrize("name", sorted(FIXTURES))
def test_passive_forces_match_mujoco(name):
    """free_floating_passive_forces = T^T (qfrc_spring + qfrc_damper + qfrc_gravcomp): MuJoCo's qfrc_passive,
    with the compensation of actuatorgravcomp joints (which MuJoCo counts in qfrc_actuator)."""
    pair = Pair(name)
    for _ in mm.SEEDS:
        data, qpos, qvel, T = pair.state()
        p = mm.passive_forces(pair.mj, qpos, qvel)
        expected = p.qfrc_spring + p.qfrc_damper + p.qfrc_gravcomp
        if not pair.mj.jnt_actgravcomp.any():
            close(expected, p.qfrc_passive, 1e-14, f"{name}: MuJoCo's parts")
        close(pair.generalized(wd.model.free_floating_passive_forces(pair.model, data)), T.T @ expected, what=name)


@pytest.mark.parametrize("name", ACTUATED)
def test_actuator_forces_match_mujoco(name):
    """actuator_forces = MuJoCo's qfrc_actuator (less the gravity compensation of actuatorgravcomp joints) for
    random controls, a third of them outside the control ranges; batched data gets one row per environment."""
    pair = Pair(name)
    model, mj = pair.model, pair.mj
    assert model.actuator_names() == tuple(mj.actuator(k).name for k in range(mj.nu))
    rows, expected_rows = [], []
    for _ in mm.SEEDS:
        data, qpos, qvel, T = pair.state()
        u = pair.ctrl()
        a = mm.actuator_forces(mj, qpos, qvel, u)
        expected = a.qfrc_actuator - mm.passive_forces(mj, qpos, qvel).qfrc_gravcomp * mj.jnt_actgravcomp[mj.dof_jntid]
        tau = wd.model.actuator_forces(model, data, ctrl=u).numpy()
        close(tau, expected[pair.st.dof_adr], what=name)
        rows.append((data, u))
        expected_rows.append(tau)
    batch = wd.data.Data.build(
        model,
        num_envs=len(rows),
        joint_positions=np.stack([d.joint_positions.numpy() for d, _ in rows]),
        joint_velocities=np.stack([d.joint_velocities.numpy() for d, _ in rows]),
        **({"base_quaternion": np.stack([d.base_quaternion.numpy() for d, _ in rows])} if model.floating_base() else {}),
    )
    np.testing.assert_array_equal(wd.model.actuator_forces(model, batch, ctrl=np.stack([u for _, u in rows])).numpy(), np.stack(expected_rows))


def _base_wrench(pair: Pair, data, rng):
    """(link_forces (nL, 6) Mixed with a wrench on the base, MuJoCo's xfrc_applied (nbody, 6)): a force and a
    torque applied to the base link, at MuJoCo's body CoM (xipos) in the world frame."""
    f, t = rng.normal(size=3), rng.normal(size=3)
    base = pair.mj.body(pair.model.base_link()).id
    xfrc = np.zeros((pair.mj.nbody, 6))
    xfrc[base] = np.concatenate([f, t])
    arm = pair.st.d.xipos[base] - pair.st.d.xpos[base]
    link_forces = np.zeros((pair.model.number_of_links(), 6))
    link_forces[0] = np.concatenate([f, t + np.cross(arm, f)])  # Mixed: about the base origin, world axes
    return link_forces, xfrc


@pytest.mark.parametrize("name", sorted(FIXTURES))
def test_accelerations_match_mujoco(name):
    """MuJoCo's qacc (constraints disabled) = T nu_dot, nu_dot by ABA and by CRBA from the actuators' and the
    passive forces (the base's passive wrench applied to the base link, whose Mixed Jacobian is [1 0]) and, for
    a floating base, a wrench on the base (MuJoCo's xfrc_applied)."""
    pair = Pair(name)
    model, mj = pair.model, pair.mj
    for _ in range(3):
        data, qpos, qvel, T = pair.state()
        u = pair.ctrl() if mj.nu else None
        passive = wd.model.free_floating_passive_forces(model, data).numpy()
        tau = wd.model.actuator_forces(model, data, ctrl=u).numpy() + passive[6:]
        link_forces, xfrc = _base_wrench(pair, data, pair.rng) if model.floating_base() else (None, None)
        if model.floating_base():
            link_forces[0] += passive[:6]
        qacc = mm.forward_acceleration(mj, qpos, qvel, ctrl=u, xfrc_applied=xfrc)
        for prefer_aba in (True, False):
            base, joints = wd.model.forward_dynamics(model, data, joint_forces=tau, link_forces=link_forces, prefer_aba=prefer_aba)
            nu_dot = np.concatenate([base.numpy(), joints.numpy()])
            close(T @ pair.generalized(nu_dot), qacc, what=f"{name} ({'ABA' if prefer_aba else 'CRBA'})")


def _compare_step(pair: Pair, new, reference, what: str, tol=mm.TOL):
    """warpdyn's Data after a step against MuJoCo's (qpos, qvel)."""
    qpos, qvel = reference
    st = pair.st
    close(new.joint_positions.numpy(), qpos[st.qpos_adr], tol, f"{what}: joint positions")
    close(new.joint_velocities.numpy(), qvel[st.dof_adr], tol, f"{what}: joint velocities")
    if pair.model.floating_base():
        close(new.base_position.numpy(), qpos[:3], tol, f"{what}: base position")
        q = new.base_quaternion.numpy()
        close(q * np.sign(q @ qpos[3:7]), qpos[3:7], tol, f"{what}: base quaternion")
        R = robots.rotation_wxyz(qpos[3:7])
        close(new.base_velocity.numpy(), np.concatenate([qvel[:3], R @ qvel[3:6]]), tol, f"{what}: base velocity")


@pytest.mark.parametrize("eulerdamp", [True, False])
@pytest.mark.parametrize("name", sorted(FIXTURES))
def test_euler_step_matches_mujoco(name, eulerdamp):
    """One step of MuJoCo's Euler, constraints disabled: with eulerdamp (the default) the joints' damping is
    implicit, (M + dt diag(damping)) qacc = f, as warpdyn's semi-implicit Euler with model.implicit_damping;
    without, explicit. Controls held for the step, a third outside their ranges."""
    pair = Pair(name)
    model, mj = pair.model, pair.mj
    assert model.integrator == wd.model.IntegratorType.SemiImplicitEulerSO3 and model.time_step == mj.opt.timestep
    assert model.implicit_damping
    model.implicit_damping = eulerdamp
    for _ in range(3):
        data, qpos, qvel, _ = pair.state()
        u = pair.ctrl() if mj.nu else None
        step = mm.euler_step(mj, qpos, qvel, ctrl=u, eulerdamp=eulerdamp)
        _compare_step(pair, wd.model.step(model, data, ctrl=u), (step.qpos, step.qvel), f"{name}, eulerdamp={eulerdamp}")


def _rk4_errors(pair: Pair, tol=None) -> float:
    """The largest difference of one RK4 step from MuJoCo's over three random states (compared to `tol` when given)."""
    model, mj = pair.model, pair.mj
    model.integrator = wd.model.IntegratorType.RungeKutta4
    reference = mm.reference_model(mj, integrator=mujoco.mjtIntegrator.mjINT_RK4)
    largest = 0.0
    for _ in range(3):
        data, qpos, qvel, _ = pair.state()
        u = pair.ctrl() if mj.nu else None
        d = mm.make_data(reference, qpos, qvel, u)
        mujoco.mj_step(reference, d)
        new = wd.model.step(model, data, ctrl=u)
        if tol is not None:
            _compare_step(pair, new, (d.qpos, d.qvel), f"{pair.name} RK4", tol)
        st = pair.st
        s_error = np.abs(new.joint_positions.numpy() - d.qpos[st.qpos_adr]).max(initial=0.0)
        largest = max(largest, s_error, np.abs(new.joint_velocities.numpy() - d.qvel[st.dof_adr]).max(initial=0.0))
    return largest


@pytest.mark.parametrize("name", ["DAMPING", "SPRINGS", "POSITION", "VELOCITY", "GRAVCOMP_ARM", "DRONE"])
def test_rk4_step_matches_mujoco(name):
    """One step of MuJoCo's RK4: the springs, dampers (explicit) and actuators evaluated at each stage's state
    and the gravity compensation at each stage's poses, as MuJoCo's (JaxSim's friction and limits stay held
    from the step's start, as JaxSim's)."""
    _rk4_errors(Pair(name), mm.TOL)


def test_rk4_of_a_floating_humanoid_converges_to_mujocos():
    """A floating base makes warpdyn's RK4 (Inertial base velocity, quaternion normalised per stage) and
    MuJoCo's (Mixed linear, body-frame angular velocity, exponential map) two 4th-order schemes in
    different coordinates: one step differs by O(dt^5). Measured on the actuated humanoid (stiff position
    servos): 7.5e-7 at 2 ms, 2.7e-8 at 1 ms, 8.8e-10 at 0.5 ms (ratios 28, 30; 2^5 = 32)."""
    errors = []
    for dt in (1e-3, 5e-4):
        FIXTURES["HUMANOID_DT"] = mm.FLOATING_HUMANOID.replace("<worldbody>", f'<option timestep="{dt}"/>\n  <worldbody>', 1)
        try:
            errors.append(_rk4_errors(Pair("HUMANOID_DT")))
        finally:
            del FIXTURES["HUMANOID_DT"]
    assert errors[1] < 3e-9 and errors[0] / errors[1] > 16, errors


def test_mujoco_options_and_disable_flags_are_followed():
    """<option>'s gravity, timestep and integrator become the model's; the spring, damper, gravity,
    actuation and clampctrl flags switch the same terms off as in MuJoCo (checked through the passive and
    actuator forces and an Euler step against MuJoCo on the same XML); eulerdamp makes damping explicit."""
    model = build(mm.OPTIONS)
    assert (model.gravity, model.time_step, model.implicit_damping) == (-3.0, 0.004, True)
    rk4 = build(mm.OPTIONS.replace('integrator="Euler"', 'integrator="RK4"'))
    assert rk4.integrator == wd.model.IntegratorType.RungeKutta4 and not rk4.implicit_damping
    flags = ['spring="disable"', 'damper="disable"', 'gravity="disable"', 'actuation="disable"', 'clampctrl="disable"', 'eulerdamp="disable"']
    for flag in flags:
        xml = mm.FLOATING_HUMANOID.replace("<worldbody>", f"<option><flag {flag}/></option>\n  <worldbody>", 1)
        xml = xml.replace('<body name="torso"', '<body name="torso" gravcomp="0.5"', 1)
        assert xml.count("gravcomp") == 1 and xml.count("<flag") == 1
        FIXTURES["FLAG"] = xml
        try:
            pair = Pair("FLAG")
        finally:
            del FIXTURES["FLAG"]
        assert pair.model.implicit_damping == (flag not in ('damper="disable"', 'eulerdamp="disable"'))
        data, qpos, qvel, T = pair.state()
        u = pair.ctrl()
        p = mm.passive_forces(pair.mj, qpos, qvel)
        close(wd.model.free_floating_passive_forces(pair.model, data).numpy(), T.T @ (p.qfrc_spring + p.qfrc_damper + p.qfrc_gravcomp), what=flag)
        close(wd.model.actuator_forces(pair.model, data, ctrl=u).numpy(), mm.actuator_forces(pair.mj, qpos, qvel, u).qfrc_actuator[pair.st.dof_adr], what=flag)
        reference = mm.reference_model(pair.mj)
        d = mm.make_data(reference, qpos, qvel, u)
        mujoco.mj_step(reference, d)
        _compare_step(pair, wd.model.step(pair.model, data, ctrl=u), (d.qpos, d.qvel), flag)


def test_rollout_with_controls_equals_steps():
    """A rollout's ctrl (T, N, na), one row per step and environment, gives the states of as many steps."""
    model = build(mm.FLOATING_HUMANOID)
    rng = np.random.default_rng(3)
    N, T, na = 3, 4, model.number_of_actuators()
    data = wd.data.Data.build(model, num_envs=N, joint_positions=rng.uniform(-0.5, 0.5, (N, model.dofs())))
    ctrl = rng.uniform(-1.5, 1.5, (T, N, na))
    final, records = wd.simulation.rollout(model, data, steps=T, ctrl=ctrl, record=("joint_velocities", "joint_torques"))
    stepped = data
    for t in range(T):
        torques = wd.model.actuator_forces(model, stepped, ctrl=ctrl[t]).numpy() + wd.model.free_floating_passive_forces(model, stepped).numpy()[:, 6:]
        np.testing.assert_allclose(records["joint_torques"].numpy()[t], torques, rtol=0, atol=1e-12)
        stepped = wd.model.step(model, stepped, ctrl=ctrl[t])
        np.testing.assert_allclose(records["joint_velocities"].numpy()[t + 1], stepped.joint_velocities.numpy(), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(final.joint_positions.numpy(), stepped.joint_positions.numpy())
    shared, _ = wd.simulation.rollout(model, data, steps=T, ctrl=ctrl[:, :1])  # (T, 1, na): the same for every environment
    per_env, _ = wd.simulation.rollout(model, data, steps=T, ctrl=np.repeat(ctrl[:, :1], N, axis=1))
    np.testing.assert_array_equal(shared.joint_positions.numpy(), per_env.joint_positions.numpy())


def test_actuator_parameters_per_environment():
    """set_actuator_parameters with a leading N: environment e's forces are those of a model given row e."""
    model = build(mm.FLOATING_HUMANOID)
    rng = np.random.default_rng(5)
    N, na, n = 3, model.number_of_actuators(), model.dofs()
    gains = model.actuator_gain.numpy()[None] * rng.uniform(0.5, 1.5, (N, na, 1))
    model.set_actuator_parameters(gain=gains)
    model.set_joint_parameters(armature=rng.uniform(0.0, 0.1, (N, n)))
    data = wd.data.Data.build(model, num_envs=N, joint_positions=rng.uniform(-0.5, 0.5, (N, n)))
    u = rng.uniform(-1, 1, (N, na))
    forces = wd.model.actuator_forces(model, data, ctrl=u).numpy()
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    for e in range(N):
        single = build(mm.FLOATING_HUMANOID)
        single.set_actuator_parameters(gain=gains[e])
        single.set_joint_parameters(armature=model.armature.numpy()[e])
        one = wd.data.Data.build(single, joint_positions=data.joint_positions.numpy()[e])
        np.testing.assert_allclose(forces[e], wd.model.actuator_forces(single, one, ctrl=u[e]).numpy(), rtol=1e-14, atol=1e-14)
        np.testing.assert_allclose(M[e], wd.model.free_floating_mass_matrix(single, one).numpy(), rtol=1e-14, atol=1e-14)


@pytest.mark.parametrize("integrator", ["SemiImplicitEuler", "RungeKutta4"])
def test_gradients_of_a_step_against_finite_differences(integrator):
    """d(sum w * state after 3 steps) / d(armature, damping, stiffness, springref, gravcomp, actuator gear,
    gain, bias, the controls, the joint positions) by the tape against central differences, float64, 1e-6
    relative (differences of step 1e-6 on O(1) losses). Every armature, damping and stiffness is positive, so
    that the differences stay inside the parameters' range (a negative one is flagged by the step's check,
    kernels/parameter_checks.py)."""
    model = build(GRAVCOMP_ARM.replace('<joint name="gj3" axis="1 0 1"/>', '<joint name="gj3" axis="1 0 1" damping="0.2" stiffness="3" springref="0.3" armature="0.05"/>'))
    positive = np.linspace(0.05, 0.1, model.dofs())
    model.set_joint_parameters(armature=positive, damping=2.0 * positive, stiffness=30.0 * positive)
    model.integrator = wd.model.IntegratorType[integrator]
    model.set_actuator_parameters(bias=[[0.1, -2.0, -0.3]])
    rng = np.random.default_rng(7)
    names = ("armature", "damping", "stiffness", "springref", "gravcomp_mass", "gravcomp_com", "actuator_gear", "actuator_gain", "actuator_bias")
    marked = model.mark_for_gradients(names)
    N, n = 2, model.dofs()
    data = wd.data.Data.build(
        model, num_envs=N, joint_positions=rng.uniform(-1, 1, (N, n)), joint_velocities=rng.uniform(-1, 1, (N, n)), requires_grad=True
    )
    ctrl = wp.array(rng.uniform(-1, 1, (N, model.number_of_actuators())), dtype=wp.float64, requires_grad=True)
    s = data.joint_positions_state
    weights = [wp.array(rng.normal(size=(N, n)), dtype=wp.float64) for _ in range(2)]

    def loss_of(d):
        for _ in range(3):
            d = wd.model.step(model, d, ctrl=ctrl)
        return gradcheck.weighted_sum([d.joint_positions_state, d.joint_velocities_state], weights)

    checks = {name: gradcheck.Check(array, rng.normal(size=array.numpy().shape)) for name, array in marked.items()}
    checks["ctrl"] = gradcheck.Check(ctrl, rng.normal(size=ctrl.shape))
    checks["joint_positions"] = gradcheck.Check(s, rng.normal(size=s.shape))
    tape = wp.Tape()
    with tape:
        loss = loss_of(data)
    tape.backward(loss)
    taped = gradcheck.tape_directional(checks)
    fd = gradcheck.directional_derivatives(checks, lambda: float(loss_of(data).numpy()[0]), 1e-6)
    for name, error in gradcheck.relative_errors(taped, fd, floor=1e-3).items():
        assert error < 1e-6, f"{name}: tape {taped[name]:.10g}, differences {fd[name]:.10g}"
        assert abs(fd[name]) > 1e-4, f"{name}: the loss does not depend on it (a check that cannot fail)"


def test_float32_steps_stay_near_float64():
    """100 Euler steps of the actuated humanoid (armature, damping, position servos) in float32 stay within
    1e-3 of float64."""
    rng = np.random.default_rng(9)
    states = []
    for dtype in (np.float64, np.float32):
        model = build(mm.FLOATING_HUMANOID, dtype)
        data = wd.data.Data.build(model, joint_positions=rng.uniform(-0.3, 0.3, model.dofs()) * 0 + 0.1)
        ctrl = np.full(model.number_of_actuators(), 0.3)
        final, _ = wd.simulation.rollout(model, data, steps=100, ctrl=ctrl)
        states.append(np.concatenate([final.joint_positions.numpy(), final.base_position.numpy()]))
    assert np.all(np.isfinite(states[1]))
    np.testing.assert_allclose(states[1], states[0], rtol=0, atol=1e-3)


def test_add_actuators_equals_the_same_actuators_in_the_xml():
    """wd.model.add_actuators on DAMPING (no actuators) gives the forces and the Euler step of MuJoCo on the
    XML with the same <position>, <velocity> and <motor> elements (gear, ranges); parameters set before are
    carried over, also per environment; bad arguments are named."""
    xml_actuators = """
  <actuator>
    <position name="slider_position" joint="slider" kp="40" kv="3" gear="2" ctrlrange="-0.5 0.5"/>
    <position name="hinge_position" joint="hinge" kp="15" kv="0.5" ctrlrange="-1 1" forcerange="-4 4"/>
    <velocity name="hinge2_velocity" joint="hinge2" kv="2"/>
    <motor name="hinge_motor" joint="hinge" gear="3"/>
  </actuator>
</mujoco>"""
    FIXTURES["DAMPING_ACTUATED"] = mm.DAMPING.replace("</mujoco>", xml_actuators)
    try:
        pair = Pair("DAMPING_ACTUATED")
    finally:
        del FIXTURES["DAMPING_ACTUATED"]
    model = build(mm.DAMPING)
    model.set_joint_parameters(armature=[0.01, 0.02, 0.0])
    model = wd.model.add_actuators(model, "position", joints=["slider", "hinge"], kp=[40, 15], kv=[3, 0.5], gear=[2, 1],
                                   ctrl_range=[[-0.5, 0.5], [-1, 1]], force_range=[[-np.inf, np.inf], [-4, 4]])  # fmt: skip
    model = wd.model.add_actuators(model, "velocity", joints=["hinge2"], kv=2)
    model = wd.model.add_actuators(model, "motor", joints=["hinge"], gear=3, names=["hinge_motor"])
    assert model.actuator_names() == pair.model.actuator_names() and model.actuators_per_joint == 2
    np.testing.assert_array_equal(model.armature.numpy(), [0.01, 0.02, 0.0])
    model.set_joint_parameters(armature=np.zeros(3))
    for _ in range(3):
        data, qpos, qvel, _ = pair.state()
        u = pair.ctrl()
        close(wd.model.actuator_forces(model, data, ctrl=u).numpy(), mm.actuator_forces(pair.mj, qpos, qvel, u).qfrc_actuator[pair.st.dof_adr], what="forces")
        step = mm.euler_step(pair.mj, qpos, qvel, ctrl=u)
        _compare_step(pair, wd.model.step(model, data, ctrl=u), (step.qpos, step.qvel), "step")
    per_env = build(mm.DAMPING)
    per_env.set_joint_parameters(armature=np.full((2, 3), 0.1))
    per_env = wd.model.add_actuators(per_env, "motor", joints=["hinge"])
    per_env.set_actuator_parameters(gear=[[1.0], [2.0]])
    per_env = wd.model.add_actuators(per_env, "motor", joints=["hinge2"])
    np.testing.assert_array_equal(per_env.actuator_gear.numpy(), [[1.0, 1.0], [2.0, 1.0]])
    with pytest.raises(ValueError, match="needs kp"):
        wd.model.add_actuators(model, "position", joints=["hinge"])
    with pytest.raises(ValueError, match="'elbow'"):
        wd.model.add_actuators(model, "motor", joints=["elbow"])
    with pytest.raises(ValueError, match="hinge_motor"):
        wd.model.add_actuators(model, "motor", joints=["hinge"], names=["hinge_motor"])
    with pytest.raises(ValueError, match="kp must be"):
        wd.model.add_actuators(model, "position", joints=["hinge"], kp=[1.0, 2.0], names=["p"])


def test_reduce_keeps_what_the_mjcf_says():
    """A reduced MJCF model still follows MuJoCo's integrator and flags (they come from the description);
    gravity and the time step are carried over."""
    xml = mm.FLOATING_HUMANOID.replace("<worldbody>", '<option timestep="0.003"><flag spring="disable"/></option>\n  <worldbody>', 1)
    model = build(xml)
    with pytest.warns(NotModelledWarning, match="actuators on joints that the reduction locks are dropped"):
        reduced = wd.model.reduce(model, model.joint_names()[:4])
    assert reduced.integrator == wd.model.IntegratorType.SemiImplicitEulerSO3 and reduced.implicit_damping
    assert reduced.time_step == 0.003 and not reduced.stiffness.numpy().any()
    mj = mm.load(xml)
    kept = [mj.actuator(k).name for k in range(mj.nu) if mj.joint(int(mj.actuator_trnid[k, 0])).name in reduced.joint_names()]
    assert reduced.actuator_names() == tuple(kept) and len(kept) > 0
