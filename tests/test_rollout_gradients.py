"""wp.Tape gradients through rollouts against central finite differences, for every kind of input (float64).

Inputs: the initial state (base position, base quaternion, joint positions, base velocity (stored Mixed),
joint velocities, tangential deformation m), per-step joint force references (T, N, n) and link forces
(T, N, nL, 6), and the model parameters marked by `wd.model.parameters_requiring_grad` (link masses,
CoMs, inertias, joint friction and limit gains, contact K, D, mu). They are Warp arrays that require
gradients: the state arrays are the Data's own (a Data built around them, so the rollout's first copy
carries the gradient back), the controls are passed as Warp arrays, the parameters are the model's.

Loss: a fixed random weighted sum (weights N(0, 1) divided by a per-quantity scale, `SCALES`) of every
recorded quantity over all steps: the state records at t = 0 ... T (base pose, joint positions and
velocities, base velocity in the data's representation, m) and the step records (applied joint torques,
and with contacts the link contact wrenches and point forces), summed by a Warp kernel (tests/gradcheck.py).

Method: directional derivatives. One taped rollout gives all gradients g; for each input a seeded random
direction d gives g . d, compared with the central difference of the same loss along d computed by
rollouts without a tape (a reused `Rollout`, so graph replays: the same kernels, which test_rollout.py
shows equal `step` bitwise). Directions are in each input's natural units: N(0, 1) for the state [m, rad,
m/s, rad/s] and controls [N, N m], 1e-3 N(0, 1) m for m, 0.05 N(0, 1) m for the CoMs, symmetric N(0, 1)
matrices times each link's largest entry for the inertias (an inertia stays symmetric), and N(0, 1)
times the value itself (relative) for masses, friction, limit gains and K, D, mu.

Step: Richardson-extrapolated central differences, (4 D(h/2) - D(h)) / 3 with h = H = 2e-5 (relative to
the directions' scales above), whose truncation error is O(h^4) (plain central differences: O(h^2)).
Why not plain central differences at h ~ 1e-6: the soft contacts (K = 1e6, force ~ delta^1.5 with
delta ~ 1 mm) give the loss large third derivatives, ~(h / delta)^2 relative: plain central differences
were off by 7e-6 at h = 1e-5 on the ergoCub, and at h = 1e-7 rounding (eps |L| / h, the stiff contact
amplifying the rounding of the state) was as large (1e-5 to 4e-5). Extrapolated at h = 2e-5 the
truncation is below 1e-9 and the rounding ~2e-6 in absolute terms on the ergoCub's loss (~1e-8 without
contacts), which is what limits the inputs along which the loss changes little (K while sticking: g . d
= 0.2; the torques: 0.2 to 1).

Tolerances (relative, |g . d - fd| <= rtol |fd|, every input separately): the issue's, 1e-6 without
contacts and 1e-4 with them. Measured worst over the inputs: pendulum 6.3e-8 (inertias), iCub 6.3e-8
(torques; state inputs <= 4.4e-9), ergoCub sticking 7.5e-6 (K, whose derivative is small) and 1.5e-6
otherwise, sliding 5.5e-6 (torques); state inputs with contacts <= 3.9e-8. Each test prints its table
(pytest -s).

The quaternion: the state stores 4 raw components and the kernels read them as given (the integrator
normalises before stepping, forward kinematics and ABA use them as they are), so the loss is a function
on R^4 and the tape's gradient is its gradient there. Two directions are checked: d tangent to the unit
sphere at Q with the perturbed quaternion renormalised, normalise(Q + t d), the physical derivative
(d/dt normalise(Q + t d) = d at t = 0, so g . d is what the differences estimate); and a raw direction
in R^4 without renormalisation, which also checks the radial part of g (the adjoint of the
normalisation, and of the first step's use of the non-unit quaternion).

Smoothness: each case asserts that its trajectory stays away from the switches a perturbation could
cross (a limit's kink, the Coulomb friction's sign, the torque-speed curve's clip, a point touching or
leaving the ground, stick against slip), with margins far above the perturbations (~1e-5).
"""

import functools

import numpy as np
import pytest
import warp as wp

import gradcheck as gc
import robots
import warpdyn as wd
from warpdyn import VelRepr

SIE, RK4 = wd.model.IntegratorType.SemiImplicitEuler, wd.model.IntegratorType.RungeKutta4
H = 2e-5
SCALES = {"joint_torques": 10.0, "link_contact_forces": 100.0, "collidable_point_forces": 100.0, "tangential_deformation": 1e-4}
STATE = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities", "tangential_deformation")
JOINT_PARAMETERS = ("friction_static", "friction_viscous", "joint_limit_spring", "joint_limit_damper")
MASS_PARAMETERS = ("link_mass", "link_com", "link_inertia")


# ------------------------------------------------------------------------------ a differentiable rollout


def _data_of(state: dict, repr_, num_envs, valid) -> wd.data.Data:
    """Data holding the Warp arrays `state` (by the names of STATE) and the valid flags `valid`."""
    return wd.data.Data(
        base_position_state=state["base_position"],
        base_quaternion_state=state["base_quaternion"],
        joint_positions_state=state["joint_positions"],
        base_velocity_state=state["base_velocity"],
        joint_velocities_state=state["joint_velocities"],
        velocity_representation=repr_,
        num_envs=num_envs,
        tangential_deformation_state=state["tangential_deformation"],
        valid_state=valid,
    )


class _Problem:
    """A rollout of `steps` steps of `model` from a state given as NumPy arrays (N, ...), the state, the
    controls (tau (T, N, n), forces (T, N, nL, 6); for num_envs=None (T, n), (T, nL, 6)) and the marked
    parameters held as Warp arrays requiring gradients, and the loss: weights (gc.record_weights, or
    given) times the records `loss_records`. `extra_records` are recorded for the regime checks only."""

    def __init__(self, model, state, steps, *, tau=None, forces=None, params=(), loss_records, extra_records=(),
                 repr_=VelRepr.Mixed, num_envs=-1, rng=None, env_mask=None, weights=None):
        s = model.scalar
        self.model, self.steps, self.repr = model, steps, repr_
        batch = state["joint_positions"].shape[0]
        self.num_envs = batch if num_envs == -1 else num_envs
        self.state = {k: wp.array(np.asarray(v, dtype=np.float64), dtype=s, requires_grad=True) for k, v in state.items()}
        self.valid = wp.ones(batch, dtype=wp.int32)
        self.controls = {
            k: wp.array(np.asarray(v, dtype=np.float64), dtype=s, requires_grad=True)
            for k, v in (("joint_force_references", tau), ("link_forces", forces))
            if v is not None
        }
        self.params = wd.model.parameters_requiring_grad(model, names=params) if params else {}
        self.loss_records = tuple(loss_records)
        self.record = self.loss_records + tuple(r for r in extra_records if r not in self.loss_records)
        self._roll = wd.simulation.Rollout(model, steps=steps, record=self.record)  # replays its graph
        self.reference = {k: v.numpy().copy() for k, v in self.records(taped=False).items()}
        if weights is None:
            weights = gc.record_weights(self.reference, self.loss_records, rng, SCALES, env_mask, s, model.device)
        self.weights = weights

    def data(self):
        return _data_of(self.state, self.repr, self.num_envs, self.valid)

    def records(self, taped: bool) -> dict:
        """Under a tape a fresh rollout (its own buffers, kept for the adjoint); else the reused one."""
        if taped:
            return wd.simulation.rollout(self.model, self.data(), steps=self.steps, record=self.record, **self.controls)[1]
        return self._roll.run(self.data(), **self.controls)[1]

    def loss(self, taped: bool) -> wp.array:
        rec = self.records(taped)
        return gc.weighted_sum([rec[k] for k in self.loss_records], [self.weights[k] for k in self.loss_records], self.model.scalar)

    def value(self) -> float:
        """The loss of the reused rollout, summed on the host in a fixed order (a GPU sums `loss` with atomics,
        whose order changes its last bits from call to call: noise in the finite differences)."""
        rec = self.records(taped=False)
        return float(sum(np.sum(self.weights[k].numpy() * rec[k].numpy()) for k in self.loss_records))

    def backward(self) -> wp.Tape:
        tape = wp.Tape()
        with tape:
            out = self.loss(True)
        tape.backward(out)
        return tape

    def inputs(self) -> dict:
        return {**self.state, **self.controls, **self.params}

    def gradients(self) -> dict:
        return {k: a.grad.numpy().copy() for k, a in self.inputs().items() if a.size}


def _checks(problem: _Problem, rng, skip=()) -> dict:
    """A gc.Check per input (the module docstring's directions); the quaternion twice (tangent and raw)."""
    checks = {}
    for name, array in problem.state.items():
        if name in skip or array.size == 0:
            continue
        if name == "base_quaternion":
            checks["base_quaternion (tangent)"] = gc.unit_quaternion_check(array, rng)
            checks["base_quaternion (raw R^4)"] = gc.Check(array, rng.normal(size=array.shape))
        else:
            checks[name] = gc.Check(array, (1e-3 if name == "tangential_deformation" else 1.0) * rng.normal(size=array.shape))
    for name, array in problem.controls.items():
        checks[name] = gc.Check(array, rng.normal(size=array.shape))
    for name, array in problem.params.items():
        x = array.numpy()
        if name == "link_inertia":
            d = gc.symmetric_direction(rng, x.shape) * np.abs(x).max(axis=(-2, -1), keepdims=True)
        elif name == "link_com":
            d = 0.05 * rng.normal(size=x.shape)
        else:
            d = np.abs(x) * rng.normal(size=x.shape)
        checks[name] = gc.Check(array, d)
    return checks


def _compare(problem: _Problem, checks: dict, rtol: float, zero=(), label="", h: float = H) -> dict:
    """Tape g . d against the extrapolated central differences of step h for every check; `zero`: inputs that
    must not matter (the tape's exactly 0; the differences within the loss's rounding, 64 u |L| / h: the loss
    of the finite differences is summed on the host in a fixed order, `_Problem.value`). Prints the table;
    asserts all within rtol at once. Returns the errors."""
    problem.backward()
    got = gc.tape_directional(checks)
    fd = gc.directional_derivatives(checks, problem.value, h, richardson=True)
    noise = 64.0 * np.finfo(np.float64).eps * abs(problem.value()) / h
    errors, failures = {}, []
    print(f"\n{label}: input, tape g.d, finite differences, relative error")
    for name in checks:
        if name in zero:
            print(f"  {name:28s} {got[name]: .12e} {fd[name]: .12e}  (must not matter)")
            if got[name] != 0.0 or abs(fd[name]) > noise:
                failures.append(f"{name}: tape {got[name]:.6e} (should be 0), differences {fd[name]:.6e} (beyond the rounding {noise:.1e})")
            continue
        errors[name] = abs(got[name] - fd[name]) / abs(fd[name]) if fd[name] != 0.0 else np.inf
        print(f"  {name:28s} {got[name]: .12e} {fd[name]: .12e}  {errors[name]:.2e}")
        if not errors[name] <= rtol:
            failures.append(f"{name}: tape {got[name]:.12e}, differences {fd[name]:.12e}, relative error {errors[name]:.2e} > {rtol:g}")
    assert not failures, f"{label}:\n" + "\n".join(failures)
    return errors


def _assert_joint_regime(problem: _Problem, limits=None, margin=1e-3):
    """No joint is at a switch of the actuation, which a step evaluates once, at its start (the recorded
    states t = 0 ... T - 1): every joint is farther than `margin` [rad] from its limits (the spring's kink)
    and |sdot| > margin (the Coulomb friction's sign), and the torques are inside the torque-speed curve's
    flat band (|sdot| < omega_th, |tau| < torque_max / 2: no clip). Perturbations are ~1e-5."""
    s, sd = problem.reference["joint_positions"][:-1], problem.reference["joint_velocities"][:-1]
    assert np.all(problem.reference["valid"] == 1)
    if limits is not None:
        assert np.minimum(np.abs(s - limits[:, 0]), np.abs(s - limits[:, 1])).min() > margin, "a joint is at its limit"
    assert np.abs(sd).min() > margin, "a joint velocity is at 0"
    a = problem.model.actuation_params
    assert np.abs(sd).max() < a.omega_th and np.abs(problem.reference["joint_torques"]).max() < a.torque_max / 2


# ------------------------------------------------------------------------------ models


@functools.cache
def _full(name: str):
    text = {"icub": robots.icub_urdf, "ergocub": robots.ergocub_urdf}[name]()
    return wd.model.Model.build_from_model_description(text, dtype=np.float64)


def _legs(name: str, dtype=np.float64):
    """A fresh model of the iCub's or ergoCub's legs (its own parameter arrays)."""
    if dtype == np.float64:
        full = _full(name)
    else:
        text = {"icub": robots.icub_urdf, "ergocub": robots.ergocub_urdf}[name]()
        full = wd.model.Model.build_from_model_description(text, dtype=dtype)
    pick = robots.icub_leg_joints if name == "icub" else robots.seed_joints
    return wd.model.reduce(full, pick(full.joint_names()))


def _numpy_state(data) -> dict:
    return {
        "base_position": data.base_position_state.numpy(),
        "base_quaternion": data.base_quaternion_state.numpy(),
        "joint_positions": data.joint_positions_state.numpy(),
        "base_velocity": data.base_velocity_state.numpy(),
        "joint_velocities": data.joint_velocities_state.numpy(),
        "tangential_deformation": data.tangential_deformation_state.numpy(),
    }


def _limited_joints(model, limits, friction_static, N: int, rng) -> np.ndarray:
    """Sets the position limits `limits`, random limit springs and dampers, static friction drawn in the range
    `friction_static` and viscous friction; returns random signs (N, n) for the initial joint state."""
    n = model.dofs()
    model.set_joint_parameters(
        position_limits=limits,
        limit_spring=rng.uniform(5.0, 15.0, n),
        limit_damper=rng.uniform(0.05, 0.2, n),
        friction_static=rng.uniform(*friction_static, n),
        friction_viscous=rng.uniform(0.1, 0.5, n),
    )
    return rng.choice([-1.0, 1.0], size=(N, n))


# ------------------------------------------------------------------------------ (a) pendulum chain


def test_pendulum_chain_gradients_for_every_input():
    """A 4-link pendulum chain (fixed base), 2 environments, 50 steps of 1 ms (semi-implicit Euler):
    d loss / d (initial joint positions and velocities, per-step torques (T, N, n), Mixed link forces
    (T, N, nL, 6), link masses, CoMs, inertias, static and viscous friction, limit spring and damper).
    Every joint starts 0.3-0.6 rad beyond a +-0.2 rad limit moving outwards at 3-5 rad/s, so the limit
    springs act throughout and no velocity reaches 0 (asserted with a 1e-3 margin: the limit's kink and
    the friction's sign are never crossed). Reference: extrapolated central differences (module
    docstring); rtol 1e-6, the issue's (measured worst 6.3e-8, link inertias). The base pose of a
    fixed-base model is not a state and is not perturbed."""
    n, N, T = 4, 2, 50
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
    rng = np.random.default_rng(5)
    limits = np.tile([-0.2, 0.2], (n, 1))
    sign = _limited_joints(model, limits, (0.1, 0.5), N, rng)
    state = _numpy_state(wd.data.Data.build(model, num_envs=N))
    state["joint_positions"] = sign * rng.uniform(0.5, 0.8, (N, n))
    state["joint_velocities"] = sign * rng.uniform(3.0, 5.0, (N, n))
    problem = _Problem(
        model, state, T,
        tau=0.5 * rng.normal(size=(T, N, n)),
        forces=rng.normal(size=(T, N, model.number_of_links(), 6)),
        params=MASS_PARAMETERS + JOINT_PARAMETERS,
        loss_records=("joint_positions", "joint_velocities", "joint_torques"),
        extra_records=("valid",),
        rng=rng,
    )
    _assert_joint_regime(problem, limits)
    checks = _checks(problem, rng, skip=("base_position", "base_quaternion", "base_velocity"))
    assert len(checks) == 11
    _compare(problem, checks, rtol=1e-6, label="pendulum")


# ------------------------------------------------------------------------------ (b) iCub legs in the air


def _icub_in_the_air(integrator, dtype=np.float64) -> tuple:
    """(problem, limits): the iCub's legs in the air (every collidable point disabled), 2 environments,
    50 steps, all inputs and the mass and joint parameters marked (see the test below)."""
    model = _legs("icub", dtype)
    nc = len(model.kin_dyn_parameters.contact_parameters.body)
    model = wd.contact.with_collidable_points(model, enabled=np.zeros(nc, dtype=bool))
    model.integrator = integrator
    n, nL, N, T = model.dofs(), model.number_of_links(), 2, 50
    rng = np.random.default_rng(7)
    beyond = np.arange(n) % 2 == 0
    limits = np.where(beyond[:, None], [-0.3, 0.3], [-3.0, 3.0])
    sign = _limited_joints(model, limits, (0.05, 0.2), N, rng)
    q = rng.normal(size=(N, 4))
    state = {
        "base_position": rng.normal(size=(N, 3)) + [0.0, 0.0, 1.0],
        "base_quaternion": q / np.linalg.norm(q, axis=1, keepdims=True),
        "joint_positions": np.where(beyond, sign * rng.uniform(0.4, 0.6, (N, n)), rng.uniform(-0.5, 0.5, (N, n))),
        "base_velocity": rng.normal(size=(N, 6)),
        "joint_velocities": sign * rng.uniform(3.0, 5.0, (N, n)),
        "tangential_deformation": 1e-3 * rng.normal(size=(N, nc, 3)),
    }
    problem = _Problem(
        model, state, T,
        tau=0.1 * rng.normal(size=(T, N, n)),
        forces=0.5 * rng.normal(size=(T, N, nL, 6)),
        params=MASS_PARAMETERS + JOINT_PARAMETERS,
        loss_records=STATE + ("joint_torques",),
        extra_records=("valid",),
        repr_=VelRepr.Mixed if integrator == SIE else VelRepr.Body,
        rng=rng,
    )
    return problem, limits


@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["euler", "rk4"])
def test_icub_legs_in_the_air_gradients_for_every_input(integrator):
    """The iCub's legs (12 joints, floating base) in the air with every collidable point disabled, 2
    environments from random poses and velocities, 50 steps of 1 ms; data in Mixed (semi-implicit Euler)
    or Body (RK4: link forces read in Body, the base velocity recorded through its conversion). Inputs: the
    whole initial state (base position, quaternion (tangent and raw), joint positions, base and joint
    velocities, m (held constant without enabled points: only its records depend on it)), per-step torques
    and link forces, masses, CoMs, inertias, both frictions and both limit gains. Even joints start
    0.1-0.3 rad beyond +-0.3 rad limits moving outwards, odd ones inside limits of +-3 rad; all move at
    3-5 rad/s (asserted at every step start: no joint within 1e-3 of a limit or of zero speed).
    Reference: extrapolated central differences; rtol 1e-6, the issue's (measured worst 6.3e-8, torques;
    state inputs <= 4.4e-9)."""
    problem, limits = _icub_in_the_air(integrator)
    _assert_joint_regime(problem, limits)
    checks = _checks(problem, np.random.default_rng(8))
    assert len(checks) == 16
    _compare(problem, checks, rtol=1e-6, label=f"iCub {integrator.name}")


@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["euler", "rk4"])
def test_float32_gradients_agree_with_float64_in_the_air(integrator):
    """The iCub case above in float32: every gradient array (all inputs, all parameters) against float64's,
    max |g32 - g64| <= 2e-5 max |g64| per input. Reference: the float64 tape (itself checked against finite
    differences above); float32's eps 6e-8 grown over 50 steps: measured worst 2.8e-6 (base position, Euler).
    (With the stiff contacts of the ergoCub, float32 gradients differ from float64's by up to 7e-4 of
    their largest entry, and 5e-2 for K, which sticking contacts barely feel: not asserted here.)"""
    g64 = _icub_in_the_air(integrator, np.float64)[0]
    g32 = _icub_in_the_air(integrator, np.float32)[0]
    g64.backward()
    g32.backward()
    a, b = g64.gradients(), g32.gradients()
    assert set(a) == set(b) and len(a) == 15
    errors = {k: np.abs(b[k].astype(np.float64) - a[k]).max() / np.abs(a[k]).max() for k in a}
    print(f"\nfloat32 vs float64, {integrator.name}: " + ", ".join(f"{k} {e:.1e}" for k, e in errors.items()))
    assert all(np.all(np.isfinite(g)) for g in b.values())
    assert max(errors.values()) <= 2e-5, errors


# ------------------------------------------------------------------------------ (c) ergoCub legs on the ground


def _holding_torques(model, data) -> np.ndarray:
    """Joint torques (N, n) that give zero joint accelerations at `data` with its contact forces (ABA is
    affine in the joint torques: its response to each unit torque, then one linear solve per environment)."""
    n = model.dofs()
    f_c = wd.contact.link_contact_forces(model, data, output_vel_repr=data.velocity_representation)[0]
    N = data.batch_size
    a0 = wd.model.forward_dynamics_aba(model, data, link_forces=f_c)[1].numpy().reshape(N, n)
    columns = []
    for e in np.eye(n):
        tau = np.broadcast_to(e, (N, n)) if data.num_envs is not None else e
        columns.append(wd.model.forward_dynamics_aba(model, data, joint_forces=tau, link_forces=f_c)[1].numpy().reshape(N, n) - a0)
    G = np.stack(columns, axis=-1)
    return np.linalg.solve(G, -a0[..., None])[..., 0]


def _standing_ergocub(integrator, mu, num_envs, base_linear_velocity=(0.0, 0.0, 0.0)):
    """The seed's ergoCub legs (12 joints; 32 points: 8 sole corners and 8 corners 6 mm or more above them
    per foot) on flat ground, at s = 0, upright, soles 1.06 mm deep (the sink under equal loads, (m g / 16 / K)^(2/3) with JaxSim's
    K = 1e6, D = 2000), with `mu` and the given base velocity; returns (model, data, holding torques)."""
    model = _legs("ergocub")
    model.integrator = integrator
    model.contact_params = wd.model.SoftContactsParams(K=1e6, D=2000.0, mu=mu)
    z = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2]
    sink = (wd.model.total_mass(model) * 9.81 / 16 / 1e6) ** (2.0 / 3.0)
    data = wd.data.Data.build(
        model,
        base_position=[0.0, 0.0, -z.min() - sink],
        base_linear_velocity=base_linear_velocity,
        num_envs=num_envs,
    )
    return model, data, _holding_torques(model, data)


def _data_at(problem: _Problem, t: int):
    """Data (Mixed) of the reference trajectory's state t, for the contact API."""
    assert problem.repr == VelRepr.Mixed
    arrays = {k: wp.array(problem.reference[k][t], dtype=problem.model.scalar) for k in STATE}
    N = problem.reference["joint_positions"].shape[1]
    return _data_of(arrays, problem.repr, N, wp.ones(N, dtype=wp.int32))


def _contact_regime(problem: _Problem, K, D, mu) -> dict:
    """The soft-contact switches at the step starts t = 0 ... T - 1, recomputed in NumPy from the reference
    trajectory (flat ground, all points enabled, p = q = 0.5, see kernels/soft_contacts.py): per point the
    depth delta, the normal force before its clip at 0, and the trial tangential force over mu fn (> 1:
    slipping). Returns arrays (T, N, nc)."""
    model = problem.model
    depth, fn, ratio = [], [], []
    for t in range(problem.steps):
        data = _data_at(problem, t)
        p = wd.contact.collidable_point_positions(model, data).numpy()
        v = wd.contact.collidable_point_velocities(model, data).numpy()
        m = problem.reference["tangential_deformation"][t]
        delta = np.maximum(0.0, -p[..., 2])
        delta_dot = np.where(delta > 0.0, -v[..., 2], 0.0)
        root = np.sqrt(delta + 2.220446049250313e-16)
        f_n = K * root * delta + D * root * delta_dot
        trial = -(K * root[..., None] * m[..., :2] + D * root[..., None] * v[..., :2])
        depth.append(-p[..., 2])
        fn.append(f_n)
        ratio.append(np.linalg.norm(trial, axis=-1) / np.maximum(mu * f_n, 1e-300))
    return {"depth": np.array(depth), "fn": np.array(fn), "ratio": np.array(ratio)}


def _assert_smooth_contacts(problem: _Problem, K, D, mu, slipping: bool):
    """Every point either touches at every step start (depth > 0.1 mm, normal force > 1 N before its clip,
    trial friction force < 0.9 mu fn when sticking, > 1.1 mu fn when slipping) or stays more than 1 mm
    above the ground: no perturbation of ~1e-5 crosses a switch. (RK4's stages lie within a step of these.)"""
    assert np.all(problem.reference["valid"] == 1)
    r = _contact_regime(problem, K, D, mu)
    touching = r["depth"][0] > 0.0
    assert touching.sum() >= 16 * touching.shape[0], "the soles are not on the ground"
    assert np.all(r["depth"][:, touching] > 1e-4) and np.all(r["fn"][:, touching] > 1.0), "a sole corner nearly left the ground"
    assert np.all(r["depth"][:, ~touching] < -1e-3), "a point off the ground nearly touched it"
    ratio = r["ratio"][:, touching]
    if slipping:
        assert ratio.min() > 1.1, f"a point nearly sticks: trial force / mu fn = {ratio.min():.3f}"
    else:
        assert ratio.max() < 0.9, f"a point nearly slips: trial force / mu fn = {ratio.max():.3f}"
    return r


CONTACT_RECORDS = STATE + ("joint_torques", "link_contact_forces", "collidable_point_forces")


@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["euler", "rk4"])
@pytest.mark.parametrize("regime", ["stick", "slip"])
def test_ergocub_legs_on_the_ground_gradients_for_every_input(regime, integrator):
    """The ergoCub's legs standing on flat ground (JaxSim's K = 1e6, D = 2000; soles 1.06 mm deep, 16 sole
    corners touching), joints held by the constant torques that cancel their initial accelerations plus
    per-step N(0, 0.5^2) N m, Mixed link forces N(0, 1), m0 ~ 1e-5 m, one environment, 50 steps of 1 ms.
    "stick": at rest, mu = 0.5, every touching corner sticking (trial force < 0.9 mu fn); mu then does not
    enter the loss, and both its tape gradient and its differences must be exactly 0. "slip": the base
    moving at 0.5 m/s along x with mu = 0.05, every touching corner slipping (trial force > 1.1 mu fn, the
    friction force mu fn along it); mu matters. Inputs: the whole initial state, torques, link forces,
    masses, CoMs, inertias, viscous friction (the URDF's 2 N m s/rad), K, D, mu. The regime is asserted
    (`_assert_smooth_contacts`). Reference: extrapolated central differences of step 1e-4 (module docstring);
    rtol 1e-4, the issue's: some inputs move this stiff loss little, so that the differences' rounding noise
    matters (measured worst 6.1e-6; with the points in the description's order, the slipping RK4 torques'
    g . d = 9.2e-3 met 2.2e-4 of rounding noise with steps of 2e-5)."""
    slipping = regime == "slip"
    mu = 0.05 if slipping else 0.5
    model, data, hold = _standing_ergocub(integrator, mu, 1, base_linear_velocity=(0.5 if slipping else 0.0, 0.0, 0.0))
    n, nL, nc, T = model.dofs(), model.number_of_links(), 32, 50
    rng = np.random.default_rng(11)
    state = _numpy_state(data)
    state["tangential_deformation"] = 1e-5 * rng.normal(size=(1, nc, 3))
    problem = _Problem(
        model, state, T,
        tau=hold + 0.5 * rng.normal(size=(T, 1, n)),
        forces=rng.normal(size=(T, 1, nL, 6)),
        params=MASS_PARAMETERS + ("friction_viscous", "K", "D", "mu"),
        loss_records=CONTACT_RECORDS,
        extra_records=("valid",),
        rng=rng,
    )
    _assert_smooth_contacts(problem, 1e6, 2000.0, mu, slipping)
    checks = _checks(problem, rng)
    assert len(checks) == 16
    _compare(problem, checks, rtol=1e-4, zero=() if slipping else ("mu",), label=f"ergoCub {regime} {integrator.name}", h=1e-4)


# ------------------------------------------------------------------------------ no leaks between environments


@pytest.mark.parametrize("layout", [None, True], ids=["device_layout", "env_fastest_layout"])
@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["euler", "rk4"])
def test_gradients_of_one_environment_do_not_leak(integrator, layout, monkeypatch):
    """3 environments of the ergoCub legs on the ground (different base velocities, m0, per-step torques
    and link forces, and per-environment K, D, mu), 10 steps, every input and every parameter marked; the
    loss sees environment 1 only (the weights of the others are 0). Reference: exactness. The gradients
    of environments 0 and 2 of every per-environment input (state, controls, K, D, mu) are exactly 0, and
    environment 1's, and the shared parameters', equal those of a single-environment rollout of
    environment 1 alone (same kernels on the same numbers: measured bitwise equal; asserted to rtol 1e-12,
    in case a sum over environments is reordered).
    Both physical layouts of per-environment arrays (env-major, the CPU's; env-fastest, the GPU's)."""
    monkeypatch.setattr(wd.config, "env_fastest", layout)
    N, T, env = 3, 10, 1
    K, D, mu = np.array([1.2e6, 1e6, 8e5]), np.array([1800.0, 2000.0, 2500.0]), np.array([0.5, 0.1, 0.05])
    model, data, hold = _standing_ergocub(integrator, 0.5, N, base_linear_velocity=np.array([[0.0, 0.0, 0.0], [0.5, 0.1, 0.0], [-0.3, 0.0, 0.0]]))
    model.contact_params = wd.model.SoftContactsParams(K=K, D=D, mu=mu)
    n, nL, nc = model.dofs(), model.number_of_links(), 32
    rng = np.random.default_rng(13)
    state = _numpy_state(data)
    state["joint_positions"] = state["joint_positions"] + 0.02 * rng.normal(size=(N, n))
    state["joint_velocities"] = 0.1 * rng.normal(size=(N, n))
    state["tangential_deformation"] = 1e-5 * rng.normal(size=(N, nc, 3))
    tau = hold + 0.5 * rng.normal(size=(T, N, n))
    forces = rng.normal(size=(T, N, nL, 6))
    params = MASS_PARAMETERS + JOINT_PARAMETERS + ("K", "D", "mu")
    mask = np.arange(N) == env
    batched = _Problem(model, state, T, tau=tau, forces=forces, params=params, loss_records=CONTACT_RECORDS, rng=rng, env_mask=mask)
    batched.backward()
    got = batched.gradients()

    single_model = _legs("ergocub")
    single_model.integrator = integrator
    single_model.contact_params = wd.model.SoftContactsParams(K=K[env], D=D[env], mu=mu[env])
    weights = {k: wp.array(w.numpy()[:, env], dtype=wp.float64) for k, w in batched.weights.items()}
    single = _Problem(
        single_model, {k: v[env : env + 1] for k, v in state.items()}, T, tau=tau[:, env], forces=forces[:, env],
        params=params, loss_records=CONTACT_RECORDS, num_envs=None, weights=weights,
    )
    single.backward()
    expected = single.gradients()

    env_axis = {**{k: 0 for k in STATE}, "joint_force_references": 1, "link_forces": 1, "K": 0, "D": 0, "mu": 0}
    for name, g in got.items():
        assert np.all(np.isfinite(g)), name
        if name in env_axis:
            others = np.delete(g, env, axis=env_axis[name])
            assert np.all(others == 0.0), f"{name}: the loss of environment {env} has a gradient in the others, up to {np.abs(others).max():.3e}"
            mine = np.take(g, env, axis=env_axis[name])
            np.testing.assert_allclose(mine, expected[name].reshape(mine.shape), rtol=1e-12, atol=0.0, err_msg=name)
            assert np.abs(mine).max() > 0.0, f"{name}: no gradient at all"
        else:  # shared parameters: the sum over the environments, here environment 1's alone
            np.testing.assert_allclose(g, expected[name], rtol=1e-12, atol=0.0, err_msg=name)
    assert all(np.abs(got[k]).max() > 0.0 for k in MASS_PARAMETERS + ("friction_viscous",))


# ------------------------------------------------------------------------------ finite gradients through switches


@pytest.mark.parametrize("integrator", [SIE, RK4], ids=["euler", "rk4"])
def test_gradients_stay_finite_through_clamps_contacts_and_flags(integrator, dtype):
    """Gradients of every input are finite (no NaN or inf) through a rollout that passes every switch the
    step has, in both dtypes: the ergoCub legs dropped from 2 mm above the ground at rest (points touching
    down; at t = 0 every point at rest with m = 0, so the trial friction force is exactly 0 (a length of a
    zero vector) and every joint velocity is 0 (Coulomb friction's sign(0))), joint references of +-200 N m
    against torque_max = 50 N m (the torque-speed clip) and joints above omega_th = 2 rad/s (its sloped
    part), both knees 0.1 rad beyond their upper limit with a limit spring, the base spinning at 2 rad/s
    (the quaternion renormalised at every step and stage), 30 steps; the odd joints' references N(0, 5^2)
    N m, inside the clip at times. Environment 1 spins at 1000 rad/s with quaternion_tolerance 1e-5 (RK4's
    quaternion step keeps its norm to O((dt omega / 2)^6), so it needs that speed): its first step is
    refused (valid = 0) and its state is kept from then on.
    Reference: np.isfinite, and that each switch was indeed reached (asserted on the records)."""
    N, T = 2, 30
    model = _legs("ergocub", dtype)
    model.integrator = integrator
    model.quaternion_tolerance = 1e-5
    model.actuation_params = wd.model.ActuationParams(torque_max=50.0, omega_th=2.0, omega_max=40.0)
    n, nL = model.dofs(), model.number_of_links()
    limits = model.tree.position_limits
    knees = [model.joint_names().index(k) for k in ("l_knee", "r_knee")]
    model.set_joint_parameters(limit_spring=np.full(n, 100.0), limit_damper=np.full(n, 0.1), friction_static=np.full(n, 0.5))
    s0 = np.zeros(n)
    s0[knees] = limits[knees, 1] + 0.1
    z = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, joint_positions=s0)).numpy()[:, 2]
    data = wd.data.Data.build(
        model,
        base_position=[0.0, 0.0, -float(z.min()) + 2e-3],
        joint_positions=s0,
        base_angular_velocity=np.array([[0.0, 0.0, 2.0], [1000.0, 0.0, 0.0]]),
        num_envs=N,
    )
    rng = np.random.default_rng(17)
    tau = np.where(np.arange(n) % 2 == 0, rng.choice([-200.0, 200.0], size=(T, N, n)), rng.normal(scale=5.0, size=(T, N, n)))
    forces = rng.normal(size=(T, N, nL, 6))
    problem = _Problem(
        model, _numpy_state(data), T, tau=tau, forces=forces, params=MASS_PARAMETERS + JOINT_PARAMETERS + ("K", "D", "mu"),
        loss_records=CONTACT_RECORDS, extra_records=("valid",), rng=rng,
    )
    ref = problem.reference
    valid = ref["valid"]
    assert np.all(valid[:, 0] == 1) and np.all(valid[1:, 1] == 0), "environment 0 flagged, or environment 1 not"
    fz = ref["collidable_point_forces"][:, 0, :, 2]
    assert np.all(fz[0] == 0.0) and np.any(fz[-1] > 0.0), "no point touched down"
    torques, speeds = np.abs(ref["joint_torques"][:, 0]), np.abs(ref["joint_velocities"][:-1, 0])
    bound = 50.0 * np.clip(1.0 - (speeds - 2.0) / 38.0, 0.0, 1.0)
    assert np.any(np.isclose(torques, 50.0, rtol=1e-5) & (speeds <= 2.0)), "the clip at torque_max never acted"
    assert np.any(np.isclose(torques, bound, rtol=1e-4) & (speeds > 2.0)), "the sloped clip never acted"
    assert np.all(ref["joint_positions"][:, 0, knees] > limits[knees, 1]), "the knees left their limit"
    problem.backward()
    grads = problem.gradients()
    bad = [k for k, g in grads.items() if not np.all(np.isfinite(g))]
    assert not bad, f"non-finite gradients: {bad}"
    for name in STATE + ("joint_force_references", "link_forces"):
        assert np.abs(np.take(grads[name], 0, axis=1 if name in ("joint_force_references", "link_forces") else 0)).max() > 0.0, name
    assert all(np.abs(grads[k]).max() > 0.0 for k in ("link_mass", "K", "D", "joint_limit_spring"))
