"""A finite divergence flags its environment (model.divergence_speed; kernels/integrators.py's and
kernels/fused_step.py's health checks): a huge but finite force drives environment BAD's velocity far past the
bound (2 here; inf, off, by default) in one step; the next step, reading that state, flags the environment and
keeps the state, and the other environments equal the same two steps without the fault, bitwise. With the bound at
inf the second step is not flagged (the state is finite, beyond 10 x the bound): what the check adds over the non-finite one. Every
integrator (the fused Euler step and the staged kernels), a floating base with revolute joints and a fixed arm
beside a free body (a free joint's translation and rotation), float64 and float32. The reference: before, a wedged
cube in the LEAP scene diverged to a finite 65 km/s, unflagged (docs/simulation.md)."""

import dataclasses

import numpy as np
import pytest
import warp as wp

import gradcheck
import mjcf_fixtures as mf
import robots
import warpdyn as wd
from warpdyn.engine import step as engine_step

N, BAD = 3, 1
BOUND = 2.0  # [m/s or rad/s]: the random states' velocities are below 1

ARM_AND_BOX = """
<mujoco model="arm_and_box">
  <worldbody>
    <body name="arm" pos="0 0 1">
      <joint name="hinge" axis="0 1 0"/>
      <inertial pos="0.1 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    </body>
    <body name="box" pos="1 0 0.5">
      <freejoint name="box_root"/>
      <inertial pos="0 0 0" mass="0.5" diaginertia="0.001 0.002 0.003"/>
    </body>
  </worldbody>
</mujoco>
"""

MODELS = {
    "floating chain": lambda dtype: wd.model.Model.build_from_model_description(robots.random_tree_urdf(7, num_links=4), dtype=dtype),
    "arm and free box": lambda dtype: wd.model.Model.build_from_model_description(ARM_AND_BOX, dtype=dtype),
}

# (model, where, how hard): a link force's linear or angular part [N or N m] on the floating chain's last link (its
# joints and base) or on the box (its free joint), 15 to 165 times the bound in one step (not past the quaternions'
# checks). Not a joint torque: the torque-speed curve and effort limits bound those.
FAULTS = [
    ("floating chain", 0, 2e5),
    ("floating chain", 3, 1e5),
    ("arm and free box", 0, 1e4),
    ("arm and free box", 3, 2e2),
]


def _inputs(model, component: int, dtype, push: float) -> tuple:
    """(clean, faulty) link forces (N, nL, 6), Warp arrays; the faulty one has `push` at `component` of the last link
    in environment BAD."""
    clean = np.random.default_rng(0).uniform(-0.5, 0.5, (N, model.number_of_links(), 6))
    faulty = clean.copy()
    faulty[BAD, -1, component] = push
    return wp.array(clean, dtype=dtype), wp.array(faulty, dtype=dtype)


FIELDS = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")


@pytest.mark.parametrize("fused", [True, False], ids=["fused", "staged"])
@pytest.mark.parametrize("integrator", list(wd.model.IntegratorType), ids=lambda i: i.name)
@pytest.mark.parametrize("label, component, push", FAULTS, ids=[f"{m}-{'linear' if c < 3 else 'angular'}" for m, c, _ in FAULTS])
@pytest.mark.parametrize("dtype", [np.float64, np.float32], ids=["float64", "float32"])
def test_a_finite_divergence_flags_its_environment(label, component, push, integrator, fused, dtype, monkeypatch):
    monkeypatch.setattr(wd.config, "fused_step", fused)
    model = MODELS[label](dtype).replace(integrator=integrator, divergence_speed=BOUND)
    if label == "arm and free box":
        assert model.link_names()[-1] == "box"
    data = wd.data.random_model_data(model, num_envs=N, key=2)
    clean, faulty = _inputs(model, component, wp.float64 if dtype == np.float64 else wp.float32, push)
    pushed = wd.model.step(model, data, link_forces=faulty)
    assert pushed.healthy.numpy().tolist() == [1, 1, 1]  # the check reads the state a step starts from
    reference = wd.model.step(model, wd.model.step(model, data, link_forces=clean), link_forces=clean)
    out = wd.model.step(model, pushed, link_forces=clean)
    assert out.healthy.numpy().tolist() == [1, 0, 1]
    for field in FIELDS:
        got, ref, before = (getattr(d, field).numpy() for d in (out, reference, pushed))
        for e in range(N):
            np.testing.assert_array_equal(got[e], before[e] if e == BAD else ref[e], err_msg=f"{field}, environment {e}")
    unbounded = model.replace(divergence_speed=float("inf"))
    free = wd.model.step(unbounded, wd.model.step(unbounded, data, link_forces=faulty), link_forces=clean)
    assert free.healthy.numpy().tolist() == [1, 1, 1]  # finite: the non-finite check alone lets it through
    nu = np.concatenate([free.base_velocity.numpy(), free.joint_velocities.numpy()], axis=1)
    assert np.all(np.isfinite(nu)) and np.abs(nu[BAD]).max() > 10 * BOUND


def _with_velocities(model, data, nu: np.ndarray):
    """`data` with the generalized velocities nu (N, 6 + n) for a floating base, (N, n) else (the base's Mixed)."""
    dtype = wp.float64 if model.scalar == wp.float64 else wp.float32
    base = {"base_velocity_state": wp.array(nu[:, :6], dtype=dtype, requires_grad=data.requires_grad)} if model.floating_base() else {}
    joints = wp.array(nu[:, 6:] if model.floating_base() else nu, dtype=dtype, requires_grad=data.requires_grad)
    return dataclasses.replace(data, joint_velocities_state=joints, **base)


SLOT_MODELS = {"floating chain": MODELS["floating chain"], "arm and free box": MODELS["arm and free box"], "ball": lambda dtype: wd.model.Model.build_from_model_description(mf.BALL, dtype=dtype)}


@pytest.mark.parametrize("fused", [True, False], ids=["fused", "staged"])
@pytest.mark.parametrize("integrator", list(wd.model.IntegratorType), ids=lambda i: i.name)
@pytest.mark.parametrize("label", list(SLOT_MODELS))
def test_each_velocity_component_alone_past_the_bound_flags(label, integrator, fused, monkeypatch):
    """From rest, one velocity component at a time set to 3 x the bound in environment 1 and 0.5 x in environment
    0: environment 1 is flagged and keeps its state, environment 0 steps: each of the base's six (the floating
    chain), a free joint's six, a ball joint's three and each hinge's, by every integrator; the fused kernel
    where it applies (the Euler steps of the chain and of the arm beside its free box)."""
    monkeypatch.setattr(wd.config, "fused_step", fused)
    model = SLOT_MODELS[label](np.float64).replace(integrator=integrator, divergence_speed=BOUND)
    data = wd.data.Data.build(model, num_envs=2)
    euler = integrator in (wd.model.IntegratorType.SemiImplicitEuler, wd.model.IntegratorType.SemiImplicitEulerSO3)
    assert (engine_step.prepare(model, data, health=True)[0].fused is not None) == (euler and label != "ball")
    size = 6 * model.floating_base() + model.dofs()
    for k in range(size):
        nu = np.zeros((2, size))
        nu[:, k] = (0.5 * BOUND, 3.0 * BOUND)
        start = _with_velocities(model, data, nu)
        out = wd.model.step(model, start)
        assert out.healthy.numpy().tolist() == [1, 0], k
        for field in FIELDS:
            np.testing.assert_array_equal(getattr(out, field).numpy()[1], getattr(start, field).numpy()[1], err_msg=f"{field}, component {k}")


def test_a_flagged_environment_has_finite_gradients():
    """Under a tape, the staged Euler step of the floating chain with environment 1 past the bound: the gradients of
    the next state's velocities with respect to the initial velocities are finite in both environments (the check
    adds no adjoint: a square root's, 0 x sqrt(1 - |v| / bound), made them NaN past the bound)."""
    model = MODELS["floating chain"](np.float64).replace(divergence_speed=BOUND)
    data = wd.data.random_model_data(model, num_envs=2, key=4, requires_grad=True)
    size = 6 + model.dofs()
    nu = np.full((2, size), 0.1)
    nu[1, 7] = 3.0 * BOUND
    start = _with_velocities(model, data, nu)
    tape = wp.Tape()
    with tape:
        out = wd.model.step(model, start)
        loss = gradcheck.weighted_sum([out.base_velocity_state, out.joint_velocities_state], [wp.ones((2, 6), dtype=wp.float64), wp.ones((2, model.dofs()), dtype=wp.float64)])
    assert out.healthy.numpy().tolist() == [1, 0]
    tape.backward(loss)
    grads = [start.base_velocity_state.grad.numpy(), start.joint_velocities_state.grad.numpy()]
    assert all(np.all(np.isfinite(g)) for g in grads)


def test_the_bound_is_off_by_default_and_acts_once_set():
    """The bound is off by default (inf): a hinge spinning at 5e3 and 1.5e4 rad/s steps; set on the model to 1e4 (a
    setting: its plan rebuilt) it acts at the next step, on the velocity's components a step reads: 0.5 x the bound
    steps, 1.5 x is flagged; at 1e3 both are; reduce carries it."""
    model = MODELS["arm and free box"](np.float64)
    assert model.divergence_speed == float("inf")  # the default
    data = wd.data.Data.build(model, num_envs=2)
    speeds = np.zeros((2, model.dofs()))
    speeds[:, wd.joint.velocity_slice(model, joint_index=wd.joint.name_to_idx(model, joint_name="hinge"))] = [[5e3], [1.5e4]]
    data = dataclasses.replace(data, joint_velocities_state=wp.array(speeds, dtype=wp.float64))
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1, 1]
    model.divergence_speed = 1e4
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1, 0]
    model.divergence_speed = 1e3
    assert wd.model.step(model, data).healthy.numpy().tolist() == [0, 0]
    assert wd.model.reduce(model, ["hinge"]).divergence_speed == 1e3



FALLING_BOX = """
<mujoco model="falling_box">
  <worldbody>
    <body name="box" pos="0 0 1">
      <freejoint name="box_root"/>
      <inertial pos="0 0 0" mass="0.5" diaginertia="0.001 0.002 0.003"/>
    </body>
  </worldbody>
</mujoco>
"""


@pytest.mark.parametrize("fused", [True, False], ids=["fused", "staged"])
@pytest.mark.parametrize("integrator", list(wd.model.IntegratorType), ids=lambda i: i.name)
def test_a_stepper_call_flags_the_state_it_ends_on(integrator, fused, monkeypatch):
    """A free box falling from rest at 9.81 dt per step passes the bound (9.5 steps' speed) in the last of a Stepper
    call's 10 steps: the steps' own check, reading the states they start from (all below the bound), does not flag
    it, as 10 calls of wd.model.step show; the call flags it at its end (warpdyn.engine.stepper), keeping the state.
    With the bound at inf it stays healthy. Every integrator (gravity alone: each integrates it exactly)."""
    monkeypatch.setattr(wd.config, "fused_step", fused)
    dt, substeps = 0.01, 10
    model = wd.model.Model.build_from_model_description(FALLING_BOX, dtype=np.float64).replace(time_step=dt, divergence_speed=9.81 * dt * 9.5, integrator=integrator)
    data = wd.data.random_model_data(model, num_envs=N, key=0, base_vel_lin_bounds=(0.0, 0.0), base_vel_ang_bounds=(0.0, 0.0))
    stepped = data
    for _ in range(substeps):
        stepped = wd.model.step(model, stepped)
    assert stepped.healthy.numpy().tolist() == [1] * N  # the steps flag it only at the next one
    stepper = wd.simulation.Stepper(model, data, substeps=substeps, use_graph=False)
    ended = stepper.step()
    assert ended.healthy.numpy().tolist() == [0] * N
    np.testing.assert_array_equal(ended.base_position.numpy(), stepped.base_position.numpy())  # the state kept
    assert np.all(np.abs(ended.base_velocity.numpy()[:, 2]) > model.divergence_speed)
    free = wd.simulation.Stepper(model.replace(divergence_speed=np.inf), data, substeps=substeps, use_graph=False)
    assert free.step().healthy.numpy().tolist() == [1] * N
