"""JaxSim's rigid and relaxed-rigid contact models (kernels/rigid_contacts.py) against JaxSim 0.9.0
(tests/jaxsim/contact_models.npz, from tests/jaxsim/generate_contact_models.py: a box, a hopper and the seed's
ergoCub legs in contact), and their parameters' checks.

Tolerances, float64:
- the relaxed-rigid law is a linear solve, which warpdyn factorises and JaxSim minimises by L-BFGS (asked here for
  tol 1e-12, 1000 iterations). On the box JaxSim's iterate is converged: forces equal to 1e-10 of their scale, the
  300 steps' states to 1e-10 (measured 8.7e-12). The hopper's system is ill-conditioned (its feet's many points give a Delassus matrix
  of low rank, regularised by R ~ 1e-6 / m): JaxSim's iterate is not converged (its residual |A f + b| is checked
  larger than warpdyn's), the forces differ in G's near-null space (internal forces that cancel in J^T f), so the
  states differ by rounding that grows over the rollout (measured 1.8e-6 after 300 steps; bound 1e-5).
- the rigid law is a QP that both solve by an interior point (JaxSim's qpax at solver_tol 1e-10, warpdyn's at its
  default 1e-10): forces within 1e-8 of their scale (measured 3.5e-11), the states of 300 steps within 1e-8
  (measured: 1.7e-9 after the hopper's first step and its impact, 1e-10 later; the box 6e-11; the legs 4.1e-9). JaxSim's own
  rollout is not the reference there: its impact leaves stale link velocities in its data
  (tests/jaxsim/generate_contact_models.py), so the reference steps from data rebuilt at each state.
"""

from __future__ import annotations

import dataclasses
import pathlib
import sys
import warnings

import numpy as np
import pytest
import warp as wp

import warpdyn as wd
from warpdyn.rbda import contacts

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests" / "jaxsim"))

import cases  # noqa: E402
from generate_contact_models import CONTACT_CASES, EVERY, STEPS  # noqa: E402

REFERENCE = np.load(ROOT / "tests" / "jaxsim" / "contact_models.npz")


def _model(name: str, dtype=wp.float64, **options):
    case = CONTACT_CASES[name]
    spec = cases.MODELS[case["model"]]
    with warnings.catch_warnings():  # the ergoCub SDF's sensors and plugins, named in a NotModelledWarning
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.JaxSimModel.build_from_model_description(ROOT / spec["path"], considered_joints=spec["considered_joints"], dtype=dtype)
    kind = getattr(contacts, case["contact_model"])
    return model.replace(contact_model=kind.build(**options), contact_params=kind.parameters_class(**case["params"]))


def _data(name: str, model):
    """The case's state: the parity cases' (tests/jaxsim/cases.py), the legs lowered into contact as the reference
    stored them."""
    kwargs = cases.state(CONTACT_CASES[name]["model"], model.joint_names(), model.floating_base())
    if f"{name}/base_position" in REFERENCE:
        kwargs["base_position"] = REFERENCE[f"{name}/base_position"]
    return wd.data.JaxSimModelData.build(model=model, velocity_representation=wd.VelRepr.Inertial, **kwargs)


def _state(data) -> np.ndarray:
    values = (data.base_position, data.base_orientation, data.joint_positions, data.base_velocity, data.joint_velocities)
    return np.concatenate([np.asarray(v.numpy()).ravel() for v in values])


def _rollout_states(model, data) -> list:
    """The states of STEPS steps (zero joint forces) at the reference's samples: every EVERY-th and the first step."""
    states = []
    for k in range(STEPS + 1):
        if k % EVERY == 0 or k == 1:
            states.append(_state(data))
        if k < STEPS:
            data = wd.model.step(model, data, joint_force_references=np.zeros(model.dofs()))
    return states


def _forces(name: str, model, data) -> np.ndarray:
    x = cases.inputs(CONTACT_CASES[name]["model"], model.dofs(), model.number_of_links())
    forces, aux = model.contact_model.compute_contact_forces(model, data, joint_force_references=x["tau"])
    assert aux == {}
    return forces.numpy()


@pytest.mark.parametrize("name", ["relaxed_box", "rigid_box", "rigid_hopper", "rigid_legs"])
def test_forces_and_rollout_equal_jaxsim(name):
    model = _model(name)
    data = _data(name, model)
    expected = REFERENCE[f"{name}/forces"]
    forces = _forces(name, model, data)
    tolerance = 1e-10 if name.startswith("relaxed") else 1e-8
    np.testing.assert_allclose(forces, expected, rtol=0, atol=tolerance * np.abs(expected).max())
    states = _rollout_states(model, data)
    reference = REFERENCE[f"{name}/states"]
    np.testing.assert_allclose(states, reference, rtol=0, atol=1e-10 if name.startswith("relaxed") else 1e-8)


def _relaxed_rigid_system(model, data, tau) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(A, b, active) of JaxSim's relaxed-rigid law at the data's state on a flat terrain at 0, from warpdyn's public
    quantities in the Mixed representation (JaxSim's computation, written here in NumPy): its forces minimise
    |A f + b| over the active points' rows."""
    c = model.contact_params
    with data.switch_velocity_representation(wd.VelRepr.Mixed):
        return _relaxed_rigid_rows(model, data, tau, c)


def _relaxed_rigid_rows(model, mixed, tau, c) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    M = wd.model.free_floating_mass_matrix(model, mixed).numpy()
    a_free = np.concatenate([a.numpy() for a in wd.model.forward_dynamics_aba(model, mixed, joint_forces=tau)])
    J = wd.contact.jacobian(model, mixed).numpy()[:, :3]
    Jdot = wd.contact.jacobian_derivative(model, mixed).numpy()[:, :3]
    nu = mixed.generalized_velocity.numpy()
    p, v = (a.numpy() for a in wd.contact.collidable_point_kinematics(model, mixed))
    active = p[:, 2] < 0.0
    pos = np.zeros_like(p)
    pos[:, 2] = p[:, 2]  # -delta n
    x = np.abs(pos) / c.width
    y = np.where(x < c.midpoint, x**c.power / c.midpoint ** (c.power - 1), 1 - (1 - x) ** c.power / (1 - c.midpoint) ** (c.power - 1))
    xi = np.where(x > 1, c.d_max, np.clip(c.d_min + y * (c.d_max - c.d_min), c.d_min, c.d_max))
    K, D = 1 / (c.d_max * c.time_constant * c.damping_coefficient) ** 2, 2 / (c.d_max * c.time_constant)
    a_ref = -(D * v + K * xi * pos)
    links = np.asarray(model.kin_dyn_parameters.contact_parameters.body)[model.kin_dyn_parameters.contact_parameters.indices_of_enabled_collidable_points]
    mass = model.link_mass.numpy().reshape(-1)[links][:, None]
    R = 2 * c.mu**2 * (1 - xi) / (xi + 1e-12) * (1 + c.mu**2) / mass
    Ja = J[active].reshape(-1, M.shape[0])
    A = Ja @ np.linalg.solve(M, Ja.T) + np.diag(R[active].ravel())
    b = (np.einsum("cak,k->ca", J, a_free) + np.einsum("cak,k->ca", Jdot, nu) - a_ref)[active].ravel()
    return A, b, active


def test_relaxed_rigid_solves_what_jaxsim_approximates():
    """The hopper (module docstring): warpdyn's forces minimise JaxSim's objective |A f + b| (its system rebuilt in
    NumPy from warpdyn's public quantities) to rounding (residual 1e-10 of |b|, measured); JaxSim's L-BFGS iterate
    leaves 1e-5 of |b| (measured), so the states differ by more than the box's."""
    name = "relaxed_hopper"
    model = _model(name)
    data = _data(name, model)
    tau = cases.inputs("hopper", model.dofs(), model.number_of_links())["tau"]
    A, b, active = _relaxed_rigid_system(model, data, tau)
    ours, theirs = _forces(name, model, data)[active][:, :3].ravel(), REFERENCE[f"{name}/forces"][active][:, :3].ravel()
    exact = -np.linalg.solve(A, b)
    np.testing.assert_allclose(ours, exact, rtol=0, atol=1e-8 * np.abs(exact).max())
    assert np.abs(A @ ours + b).max() < 1e-8 * np.abs(b).max()
    assert np.abs(A @ theirs + b).max() > 1e-6 * np.abs(b).max()
    states = _rollout_states(model, data)
    np.testing.assert_allclose(states, REFERENCE[f"{name}/states"], rtol=0, atol=1e-5)


def test_relaxed_rigid_legs_equal_jaxsim_until_its_iterate_stops_short():
    """The ergoCub legs, 3 mm into the ground (32 points): the forces equal JaxSim's to 1e-10 of their size and the
    first 100 steps to 1e-9 (measured 6e-14, 9e-11). Later the feet's contacts make the system ill-conditioned
    (cond 8.4e6 at step 180, 12 points) and JaxSim's L-BFGS stops short of the minimiser, as on the hopper: at
    warpdyn's state of step 180 JaxSim's forces (tol 1e-12, 1000 iterations, the reference's options) differ from
    warpdyn's by 5e-5 of their size, by 2.4e-6 with 10000 iterations (measured with JaxSim 0.9.0), while warpdyn's
    residual is 1e-12. So the 300 steps are held to 1e-4 (measured 5e-5)."""
    name = "relaxed_legs"
    model = _model(name)
    data = _data(name, model)
    expected = REFERENCE[f"{name}/forces"]
    np.testing.assert_allclose(_forces(name, model, data), expected, rtol=0, atol=1e-10 * np.abs(expected).max())
    states, reference = _rollout_states(model, data), REFERENCE[f"{name}/states"]
    np.testing.assert_allclose(states[:4], reference[:4], rtol=0, atol=1e-9)
    np.testing.assert_allclose(states, reference, rtol=0, atol=1e-4)


def test_default_relaxed_solver_options_change_jaxsim_not_warpdyn():
    """JaxSim's default L-BFGS (50 iterations, tol 1e-6) stops far from the minimiser on the box; warpdyn's exact
    solve takes the options and ignores them: its forces do not change."""
    name = "relaxed_box"
    data = _data(name, _model(name))
    exact = _forces(name, _model(name), data)
    loose = _forces(name, _model(name, solver_options={"tol": 1e-6, "maxiter": 50}), data)
    np.testing.assert_array_equal(exact, loose)
    assert np.abs(REFERENCE[f"{name}/forces_default"] - REFERENCE[f"{name}/forces"]).max() > 1e-3


def test_rigid_impact_stops_the_penetrating_points():
    """After each step, the points below the terrain are still (JaxSim's impact); the others move."""
    name = "rigid_box"
    model = _model(name)
    data = wd.model.step(model, _data(name, model), joint_force_references=np.zeros(model.dofs()))
    p, v = (a.numpy() for a in wd.contact.collidable_point_kinematics(model, data))
    below = p[:, 2] < 0.0
    assert below.any() and not below.all()
    np.testing.assert_allclose(v[below], 0.0, atol=1e-12)
    assert np.abs(v[~below]).max() > 1e-3


def test_per_environment_friction_equals_separate_runs():
    name = "rigid_box"
    mus = np.array([0.2, 0.9])
    base = _model(name)
    batched = base.replace(contact_params=contacts.RigidContactsParams(mu=mus, K=1e4, D=100.0))
    kwargs = cases.state("box", base.joint_names(), True)
    data = wd.data.JaxSimModelData.build(model=batched, num_envs=2, velocity_representation=wd.VelRepr.Inertial, **kwargs)
    for _ in range(5):
        data = wd.model.step(batched, data)
    for env, mu in enumerate(mus):
        single = base.replace(contact_params=contacts.RigidContactsParams(mu=mu, K=1e4, D=100.0))
        one = wd.data.JaxSimModelData.build(model=single, velocity_representation=wd.VelRepr.Inertial, **kwargs)
        for _ in range(5):
            one = wd.model.step(single, one)
        np.testing.assert_allclose(data.base_velocity.numpy()[env], one.base_velocity.numpy(), rtol=0, atol=1e-12)


@pytest.mark.parametrize("kind", ["RigidContacts", "RelaxedRigidContacts"])
def test_float32_box_comes_to_rest(kind):
    """A box dropped on the ground in float32 comes to rest on it: finite, no drift, its lowest corner at the
    ground within the law's sink (relaxed rigid: a few millimetres; rigid: Baumgarte's)."""
    model = wd.model.JaxSimModel.build_from_model_description(ROOT / "tests" / "jaxsim" / "box.sdf", dtype=wp.float32)
    model = model.replace(contact_model=getattr(contacts, kind).build())
    if kind == "RigidContacts":
        model = model.replace(contact_params=contacts.RigidContactsParams(K=1e4, D=200.0))
    data = wd.data.JaxSimModelData.build(model=model, base_position=np.array([0.0, 0.0, 0.12]))
    if kind == "RigidContacts":  # the float32 rigid law's warning (warpdyn.engine.contact_stage), once per model version
        with pytest.warns(UserWarning, match=r"model 'box': RigidContacts in float32 .* dtype=np.float64"):
            data = wd.model.step(model, data)
    for _ in range(1500):
        data = wd.model.step(model, data)
    assert bool(data.healthy.numpy().all())
    p = wd.contact.collidable_point_positions(model, data).numpy()
    assert abs(p[:, 2].min()) < 5e-3
    assert np.abs(data.base_velocity.numpy()).max() < 1e-2


def _tangent(data, reference) -> np.ndarray:
    """data's state in the tangent at `reference`'s: positions, 2 Im(Q Q_ref^*) (the rotation [rad], world axes),
    joints, velocities (the layout of wd.autodiff's x)."""
    x, x0 = ([a.numpy() for a in (d.base_position, d.base_quaternion, d.joint_positions, d.base_velocity, d.joint_velocities)] for d in (data, reference))
    (w, v), (w0, v0) = (x[1][0], x[1][1:]), (x0[1][0], -x0[1][1:])
    return np.concatenate([x[0], 2.0 * (w * v0 + w0 * v + np.cross(v, v0)), x[2], x[3], x[4]])


GRADIENT_CASES = {  # name: (bound on A and B, the contact parameters checked: {name: relative step})
    "relaxed_box": (2e-7, {"mu": 1e-2}),
    "relaxed_legs": (1e-8, {"mu": 1e-2}),
    "rigid_box": (1e-7, {"mu": 1e-4, "K": 1e-4, "D": 1e-4}),
    "rigid_legs": (1e-7, {"mu": 1e-4, "K": 1e-4, "D": 1e-4}),
}


@pytest.mark.parametrize("name", list(GRADIENT_CASES))
def test_solved_contact_gradients_equal_central_differences(name):
    """The relaxed-rigid and rigid steps differentiate: Warp's adjoints of the rows and the wrenches, the solves'
    written by hand (the relaxed law's linear solve by the implicit function theorem; the rigid QP by OptNet's
    differentiation of its KKT conditions at its active set; the rigid impact as the projection it is, at the kept
    rows), each at the forward pass's penetrating points. In contact, A and B of one step and of 20 steps
    (wd.autodiff's reverse pass through the tape) equal central differences at h = 1e-5, and ∂x'/∂(the contact
    parameters) and ∂x'/∂(link masses) equal central differences of the step with the parameter varied.

    Tolerances, relative to the largest entry: the relaxed box's 4 corners give 12 rows of rank 6 regularised by
    R ~ 1e-6 / m, so the differences' rounding, eps cond(A) |x| / h, dominates: measured 2.4e-8 (one step) and 4.5e-9
    (20 steps) at h = 1e-5, 2e-7 at 1e-6; the relaxed legs 6e-11 and 5.8e-9; the rigid box 6.6e-9 and 4.6e-10, the
    rigid legs 1.1e-8 (B) and 1.2e-8, where the QP's own tolerance (1e-10) adds its noise / h. mu moves the relaxed
    state through R alone, by ~1e-6 of the forces: its differences need h = 1e-2 mu (measured 1.7e-5 on the box,
    truncation; 2e-4 at h = 1e-5, rounding); the rigid model's mu, K and D at h = 1e-4 of each (measured 3e-6 at
    most), the masses at 1e-4 of each (measured 6e-9 at most)."""
    bound, contact_parameters = GRADIENT_CASES[name]
    model = _model(name)
    data = _data(name, model)
    assert np.abs(_forces(name, model, data)).max() > 1.0  # in contact
    for steps in (1, 20):
        reverse = wd.autodiff.transition_matrices(model, data, steps=steps, parameters=(*contact_parameters, "link_mass") if steps == 1 else ())
        central = wd.autodiff.transition_matrices(model, data, steps=steps, method="central", h=1e-5)
        for key in ("A", "B") if model.dofs() else ("A",):
            exact, fd = reverse[key].numpy(), central[key].numpy()
            assert np.abs(exact - fd).max() <= bound * np.abs(exact).max(), (key, steps)
        if steps == 1:
            parameters = reverse
    stepped = wd.model.step(model, data)

    def central_difference(vary, h: float) -> np.ndarray:
        plus, minus = (_tangent(wd.model.step(vary(sign * h), data), stepped) for sign in (1.0, -1.0))
        return (plus - minus) / (2.0 * h)

    for parameter, relative in contact_parameters.items():
        value = float(getattr(model.contact_params, parameter))

        def with_parameter(dv, parameter=parameter, value=value):
            varied = model.copy()
            varied.contact_params = dataclasses.replace(model.contact_params, **{parameter: value + dv})
            return varied

        fd = central_difference(with_parameter, relative * value)
        exact = parameters[parameter].numpy()[:, 0]
        assert np.abs(fd).max() > 0.0 and np.abs(exact - fd).max() <= 1e-4 * np.abs(fd).max(), parameter
    masses = model.link_mass.numpy()
    for link in range(min(3, masses.size)):

        def with_mass(dm, link=link):
            varied = model.copy()
            varied.set_link_parameters(mass=masses + dm * (np.arange(masses.size) == link))
            return varied

        fd = central_difference(with_mass, 1e-4 * masses[link])
        exact = parameters["link_mass"].numpy()[:, link]
        assert np.abs(fd).max() > 0.0 and np.abs(exact - fd).max() <= 1e-6 * np.abs(fd).max(), link


@pytest.mark.parametrize("name, integrator", [("rigid_legs", "RungeKutta4"), ("relaxed_legs", "RungeKutta4Fast")])
def test_solved_contact_gradients_through_rk4(name, integrator):
    """Through RK4's four evaluations (each with its own contact buffers; the rigid impact after the step with its own)
    and RK4Fast's held contact forces, A and B of 5 steps equal central differences at h = 1e-5 (measured 2.5e-9 and
    6.5e-9 of the largest entry; bound 1e-7)."""
    model = _model(name).replace(integrator=getattr(wd.model.IntegratorType, integrator))
    data = _data(name, model)
    reverse = wd.autodiff.transition_matrices(model, data, steps=5)
    central = wd.autodiff.transition_matrices(model, data, steps=5, method="central", h=1e-5)
    for key in ("A", "B"):
        exact, fd = reverse[key].numpy(), central[key].numpy()
        assert np.abs(exact - fd).max() <= 1e-7 * np.abs(exact).max(), key


STEP_ROUNDING = 1e-9  # [m, rad, m/s, rad/s] a taped step's state against an untaped one's (CPU: equal bit for bit)
GRADIENT_ROUNDING = 1e-9  # of the largest gradient: two backward passes' (CPU: equal bit for bit)


@pytest.mark.parametrize("integrator", ["SemiImplicitEuler", "RungeKutta4"])
def test_a_taped_rigid_steps_state_survives_its_backward_pass(integrator):
    """The rigid impact replaces the step's velocities in place after the integrator, and Warp's adjoint of the
    integrator replays its forward, writing velocities from before the impact back (warpdyn.engine.step's
    `kept_after_step` copies the impact's back after it). Two taped steps of the legs landing: after each of two
    backward passes (tape.zero between; the second replays the second step from the first's state) the stepped
    data hold what the forward pass left (bit for bit), which is an untaped step's (to STEP_ROUNDING: on a GPU the
    two paths' kernels may round differently), and the passes' gradients agree (to GRADIENT_ROUNDING: a GPU adds
    adjoints with atomics, in no fixed order); as do a checkpointed Rollout's, which recomputes its segments under
    a tape of its own. Without the copy the stepped velocities moved by 1.0 rad/s, the second pass's gradients by
    1.2e-3 of their largest, a Rollout's final state by 0.39 rad/s."""
    model = _model("rigid_legs").replace(integrator=getattr(wd.model.IntegratorType, integrator))
    kwargs = cases.state(CONTACT_CASES["rigid_legs"]["model"], model.joint_names(), model.floating_base())
    kwargs["base_position"] = REFERENCE["rigid_legs/base_position"]
    names = ("base_velocity", "joint_velocities", "joint_positions")

    def build(requires_grad: bool):
        return wd.data.Data.build(model, velocity_representation=wd.VelRepr.Inertial, requires_grad=requires_grad, **kwargs)

    def state(data) -> list:
        return [getattr(data, name).numpy().copy() for name in names]

    def backward_twice(tape, seeds, x):
        """Two backward passes from `seeds` (gradients 1); yields the list of x's gradients after each."""
        passes = []
        for _ in range(2):
            tape.zero()
            for a in seeds:
                a.grad.fill_(1.0)
            tape.backward()
            passes.append(np.concatenate([a.grad.numpy().ravel() for a in (x.base_position, x.joint_positions, x.base_velocity, x.joint_velocities)]))
            yield passes

    plain = [build(False)]
    for _ in range(2):
        plain.append(wd.model.step(model, plain[-1]))
    x = build(True)
    tape = wp.Tape()
    with tape:
        taped = [x, wd.model.step(model, x)]
        taped.append(wd.model.step(model, taped[1]))
    forward = [state(taped[t]) for t in (1, 2)]
    for t in (1, 2):
        assert (wd.contact.collidable_point_positions(model, plain[t]).numpy()[..., 2] < 0.0).any()  # a point penetrates: the impact acts
        for got, expected in zip(forward[t - 1], state(plain[t])):
            np.testing.assert_allclose(got, expected, rtol=0, atol=STEP_ROUNDING)
    for passes in backward_twice(tape, (taped[2].joint_velocities, taped[2].base_velocity), x):
        for t in (1, 2):
            for name, got, kept in zip(names, state(taped[t]), forward[t - 1]):
                np.testing.assert_array_equal(got, kept, err_msg=f"step {t} {name}")
    assert np.abs(passes[0]).max() > 0.0
    np.testing.assert_allclose(passes[1], passes[0], rtol=0, atol=GRADIENT_ROUNDING * np.abs(passes[0]).max())
    plain_final, _ = wd.simulation.Rollout(model, steps=4, record=(), storage="checkpointed", checkpoint_every=2).run(build(False))
    x = build(True)
    tape = wp.Tape()
    with tape:
        final, _ = wd.simulation.Rollout(model, steps=4, record=(), storage="checkpointed", checkpoint_every=2).run(x)
    for passes in backward_twice(tape, (final.joint_velocities,), x):
        for got, expected in zip(state(final), state(plain_final)):
            np.testing.assert_allclose(got, expected, rtol=0, atol=STEP_ROUNDING)
    assert np.abs(passes[0]).max() > 0.0
    np.testing.assert_allclose(passes[1], passes[0], rtol=0, atol=GRADIENT_ROUNDING * np.abs(passes[0]).max())


def test_solved_models_with_moving_points_refuse_gradients():
    """A solved model whose collidable points a taped update_hw_parameters computed is refused, naming the law: its
    points' Jacobians are built from the model's points once, so a gradient would miss them."""
    leg = wd.model.Model.build_from_model_description((ROOT / "tests" / "jaxsim" / "hw_leg.sdf").read_text(), dtype=np.float64)
    nL = leg.number_of_links()
    for kind in (contacts.RelaxedRigidContacts, contacts.RigidContacts):
        model = leg.replace(contact_model=kind.build())
        dims = wp.array(np.ones((nL, 3)), dtype=wp.float64, requires_grad=True)
        with pytest.raises(NotImplementedError, match=f"{kind.__name__} with collidable points that require gradients"):
            with wp.Tape():
                updated = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=np.ones(nL)))
                wd.model.step(updated, wd.data.Data.build(updated, base_position=(0.0, 0.0, 0.5)))


def test_parameters_are_checked_and_named():
    with pytest.raises(ValueError, match=r"RelaxedRigidContactsParams.mu .*vanishes at mu = 0"):
        contacts.RelaxedRigidContactsParams(mu=0.0)
    with pytest.raises(ValueError, match=r"RelaxedRigidContactsParams.d_max"):
        contacts.RelaxedRigidContactsParams(d_max=1.0)
    with pytest.raises(ValueError, match=r"d_min <= d_max"):
        contacts.RelaxedRigidContactsParams(d_min=0.95, d_max=0.9)
    with pytest.raises(ValueError, match=r"RigidContactsParams.K .*got -1.0"):
        contacts.RigidContactsParams(K=-1.0)
    with pytest.raises(ValueError, match=r"environment 1"):
        contacts.RigidContactsParams(mu=np.array([0.5, np.nan]))
    with pytest.warns(UserWarning, match=r"RelaxedRigidContactsParams.K is not read"):
        contacts.RelaxedRigidContactsParams.build(K=1e5)
    with pytest.raises(TypeError, match=r"solver_options are .*got \['tolerance'\]"):
        contacts.RigidContacts.build(solver_options={"tolerance": 1e-3})
    assert contacts.RigidContactsParams().valid() and contacts.RelaxedRigidContactsParams().valid()


def test_a_model_and_parameters_of_another_model_are_refused():
    model = _model("rigid_box")
    model.contact_params = contacts.SoftContactsParams()
    with pytest.raises(ValueError, match=r"contact_params is a SoftContactsParams, but model.contact_model \(RigidContacts\) takes RigidContactsParams"):
        wd.model.step(model, _data("rigid_box", model))


def test_replacing_the_model_sets_its_default_parameters():
    model = wd.model.JaxSimModel.build_from_model_description(ROOT / "tests" / "jaxsim" / "box.sdf")
    relaxed = model.replace(contact_model=contacts.RelaxedRigidContacts.build())
    assert relaxed.contact_params == contacts.RelaxedRigidContactsParams()
    assert contacts.RigidContacts.build(regularization_delassus=1e-5) != contacts.RigidContacts.build()


def test_update_velocity_after_impact_is_the_steps_impact():
    """JaxSim's RigidContacts.update_velocity_after_impact on a state equals the impact that ends a step there:
    the points below the terrain are still, the positions unchanged, the data given untouched."""
    name = "rigid_box"
    model = _model(name)
    data = _data(name, model)
    after = model.contact_model.update_velocity_after_impact(model, data)
    np.testing.assert_array_equal(after.base_position.numpy(), data.base_position.numpy())
    p, v = (a.numpy() for a in wd.contact.collidable_point_kinematics(model, after))
    np.testing.assert_allclose(v[p[:, 2] < 0.0], 0.0, atol=1e-12)
    assert np.abs(wd.contact.collidable_point_velocities(model, data).numpy()[p[:, 2] < 0.0]).max() > 1e-2


@wp.kernel
def _weighted_velocity(v: wp.array2d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    env, i = wp.tid()
    wp.atomic_add(loss, 0, wp.float64(float(i + 1)) * v[env, i])


def test_update_velocity_after_impact_differentiates():
    """Under a wp.Tape, update_velocity_after_impact registers the impact's adjoint: the gradient of a weighted sum of
    the base's velocity after it with respect to the state's base velocity (Mixed) and position equals central
    differences (h = 1e-6; measured 1e-10 of the largest entry, bound 1e-7)."""
    name = "rigid_box"
    model = _model(name)
    start = _data(name, model)

    def build(position, velocity, grad=False):
        return wd.data.JaxSimModelData.build(
            model=model, velocity_representation=wd.VelRepr.Mixed, requires_grad=grad, base_position=position,
            base_quaternion=start.base_quaternion.numpy(), base_linear_velocity=velocity[:3], base_angular_velocity=velocity[3:],
        )

    position = start.base_position.numpy()
    velocity = np.array([0.3, -0.2, -0.4, 0.5, -0.3, 0.2])
    data = build(position, velocity, grad=True)
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        after = model.contact_model.update_velocity_after_impact(model, data)
        wp.launch(_weighted_velocity, dim=(1, 6), inputs=[after.base_velocity_state], outputs=[loss])
    tape.backward(loss)
    exact = np.concatenate([data.base_position_state.grad.numpy().ravel(), data.base_velocity_state.grad.numpy().ravel()])

    def value(x):
        after = model.contact_model.update_velocity_after_impact(model, build(x[:3], x[3:]))
        return float(after.base_velocity.numpy() @ np.arange(1.0, 7.0))

    x0, h = np.concatenate([position, velocity]), 1e-6
    fd = np.array([(value(x0 + h * e) - value(x0 - h * e)) / (2 * h) for e in np.eye(9)])
    assert np.abs(fd[3:] - np.arange(1.0, 7.0)).max() > 0.1  # the impact changes the velocity
    np.testing.assert_allclose(exact, fd, rtol=0, atol=1e-7 * np.abs(fd).max())
    # with the box's mass alone requiring gradients (the data not: the impact's copy gets them), its gradient equals
    # central differences too (the impact reads the mass matrix)
    masses = model.link_mass.numpy().copy()
    marked = wd.model.parameters_requiring_grad(model, names=("link_mass",))
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        after = model.contact_model.update_velocity_after_impact(model, build(position, velocity))
        wp.launch(_weighted_velocity, dim=(1, 6), inputs=[after.base_velocity_state], outputs=[loss])
    tape.backward(loss)
    link = int(np.argmax(masses))

    def with_mass(dm):
        varied = model.copy()
        varied.set_link_parameters(mass=masses + dm * (np.arange(masses.size) == link))
        return float(varied.contact_model.update_velocity_after_impact(varied, build(position, velocity)).base_velocity.numpy() @ np.arange(1.0, 7.0))

    h = 1e-6 * masses[link]
    central = (with_mass(h) - with_mass(-h)) / (2 * h)
    assert abs(central) > 1e-3
    np.testing.assert_allclose(marked["link_mass"].grad.numpy()[link], central, rtol=1e-6)


def test_relaxed_rigid_gradients_stay_finite_with_a_power_below_one():
    """The relaxed-rigid impedance's solimp power below 1 (pow's derivative infinite at 0, where a flat terrain's
    tangential axes sit): the step's A stays finite and equals central differences (bound 1e-6)."""
    model = _model("relaxed_box")
    model = model.replace(contact_params=dataclasses.replace(model.contact_params, power=0.5))
    data = _data("relaxed_box", model)
    exact = wd.autodiff.transition_matrices(model, data)["A"].numpy()
    central = wd.autodiff.transition_matrices(model, data, method="central", h=1e-5)["A"].numpy()
    assert np.isfinite(exact).all() and np.abs(exact - central).max() <= 1e-6 * np.abs(exact).max()


def test_compute_impact_velocity_is_the_kernels():
    """JaxSim's host formula (a least-squares KKT solve) gives the step's impact velocity: the kernels' solve of the
    Delassus matrix regularised by 1e-14 of its largest diagonal entry gives the same velocity to 1e-12 (the box's four
    corners on the ground: 12 rows of rank 6, a singular system)."""
    name = "rigid_box"
    model = _model(name)
    data = wd.data.JaxSimModelData.build(
        model=model, velocity_representation=wd.VelRepr.Mixed, base_position=np.array([0.0, 0.0, 0.099]),
        base_linear_velocity=np.array([0.3, -0.2, -0.5]), base_angular_velocity=np.array([0.1, 0.4, -0.3]),
    )
    p = wd.contact.collidable_point_positions(model, data).numpy()
    assert (p[:, 2] < 0.0).sum() == 4
    expected = contacts.RigidContacts.compute_impact_velocity(
        p[:, 2] >= 0.0, wd.model.free_floating_mass_matrix(model, data), wd.contact.jacobian(model, data), data.generalized_velocity
    )
    after = model.contact_model.update_velocity_after_impact(model, data)
    np.testing.assert_allclose(after.generalized_velocity.numpy(), expected, rtol=0, atol=1e-12)
    assert model.contact_model.update_contact_state({"m_dot": 1}) == {}


def test_unstable_reference_accelerations_are_refused_with_the_stable_step():
    """The solved models' reference accelerations (relaxed rigid: a_ref; rigid: Baumgarte's K and D) are an
    oscillator per penetrating point, integrated explicitly: a step beyond its stable dt is refused with that dt in
    the message; one just below it runs (and stays healthy on the box at rest on the ground)."""
    box = wd.model.JaxSimModel.build_from_model_description(ROOT / "tests" / "jaxsim" / "box.sdf", dtype=wp.float64)
    relaxed = box.replace(contact_model=contacts.RelaxedRigidContacts.build(), time_step=0.02)
    data = wd.data.JaxSimModelData.build(model=relaxed, base_position=np.array([0.0, 0.0, 0.0999]))
    with pytest.raises(ValueError, match=r"time_constant = 0.02 s.*take time_step < 0.0159 s, or a larger time_constant"):
        wd.model.step(relaxed, data)
    relaxed.time_step = 0.015
    for _ in range(50):
        data = wd.model.step(relaxed, data)
    assert bool(data.healthy.numpy().all())
    rigid = box.replace(contact_model=contacts.RigidContacts.build(), contact_params=contacts.RigidContactsParams(K=1e6, D=0.0), time_step=3e-3)
    with pytest.raises(ValueError, match=r"RigidContactsParams K = 1e\+06, D = 0.*take time_step < 0.002 s"):
        wd.model.step(rigid, wd.data.JaxSimModelData.build(model=rigid))
    rigid.time_step = 2.5e-3
    rigid.integrator = wd.model.IntegratorType.RungeKutta4
    wd.model.step(rigid, wd.data.JaxSimModelData.build(model=rigid))  # RK4's region reaches further (2.83 / sqrt(K))


def _warned_once(model):
    """The model after its float32 rigid warning (its step's plan built once, the warning checked)."""
    with pytest.warns(UserWarning, match="RigidContacts in float32"):
        wd.engine.step.plan(model)
    return model


@pytest.mark.parametrize("kind", ["RigidContacts", "RelaxedRigidContacts"])
def test_legs_land_and_stand(kind):
    """The ergoCub legs (32 collidable points, a joint PD as joint-limit springs) dropped from 5 cm, four drops tilted
    by up to 3 degrees with their joints offset (benchmarks/speed_accuracy.py's scene), 0.4 s: in float64 they stay
    healthy and stand (base tilt under 30 degrees: leaning, measured up to 12, not fallen); so do the relaxed-rigid
    ones in float32: the two that rest upright at float64's height within 0.5 mm (measured 4 um), the two that lean
    within 1 cm (how far they lean is float32's rounding's: 3.8 and 9.2 degrees on the CPU against float64's 4.5 and
    11.6, 2.9 mm of height; 5.3 mm on an H200). Rigid contacts in float32 stay healthy but may tip (one drop
    leant 28 degrees on an H200, 7 on the CPU: `step` warns), so only their health is asserted. (With the impact
    keeping its Delassus matrix's dependent rows, a float32 rigid landing is flagged.)"""
    runs = {}
    for dtype in (wp.float64, wp.float32):
        full = wd.model.JaxSimModel.build_from_model_description(wd.assets.ergocub_urdf(), dtype=dtype)
        model = wd.model.reduce(full, considered_joints=wd.assets.ERGOCUB_LEG_JOINTS)
        n = model.dofs()
        model.set_joint_parameters(
            position_limits=np.zeros((n, 2)), limit_spring=np.full(n, 3000.0), limit_damper=np.zeros(n),
            friction_static=np.zeros(n), friction_viscous=np.full(n, 7.0),
        )
        model = model.replace(contact_model=getattr(contacts, kind).build())
        if dtype == wp.float32 and kind == "RigidContacts":
            model = _warned_once(model)
        if dtype == wp.float64:
            joints = np.random.default_rng(0).uniform(-0.05, 0.05, (4, n))
            angles = np.radians(np.random.default_rng(1).uniform(-3.0, 3.0, (4, 2))) / 2
            tilts = np.array([[np.cos(a) * np.cos(b), np.sin(a) * np.cos(b), np.cos(a) * np.sin(b), np.sin(a) * np.sin(b)] for a, b in angles])
            heights = []
            for k in range(4):
                one = wd.data.JaxSimModelData.build(model=model, base_quaternion=tilts[k], joint_positions=joints[k])
                heights.append(0.05 - float(wd.contact.collidable_point_positions(model, one).numpy()[:, 2].min()))
            bases = np.column_stack([np.zeros((4, 2)), heights])
        data = wd.data.JaxSimModelData.build(model=model, num_envs=4, base_position=bases, base_quaternion=tilts, joint_positions=joints)
        for _ in range(400):
            data = wd.model.step(model, data)
        assert bool(data.healthy.numpy().all())
        Q = data.base_orientation.numpy()
        runs[dtype] = (data.base_position.numpy()[:, 2], np.degrees(2.0 * np.arccos(np.clip(np.abs(Q[:, 0]), 0.0, 1.0))))
    np.testing.assert_array_less(runs[wp.float64][1], 30.0)
    if kind == "RelaxedRigidContacts":
        np.testing.assert_array_less(runs[wp.float32][1], 30.0)
        upright = runs[wp.float64][1] < 3.0  # two drops come to rest upright (1.9 degrees), two lean (4.5 and 11.6)
        assert upright.sum() == 2, runs[wp.float64][1]
        np.testing.assert_allclose(runs[wp.float32][0][upright], runs[wp.float64][0][upright], atol=5e-4)
        np.testing.assert_allclose(runs[wp.float32][0], runs[wp.float64][0], atol=1e-2)
