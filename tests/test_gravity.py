"""The world's gravity as a vector parameter (`model.world_gravity`, issue 38): any direction, shared or per
environment, differentiable; JaxSim's `model.gravity` (its z component) as before.

References: MuJoCo (M, qfrc_bias, the passive forces with gravcomp, qacc with constraints disabled, and one
Euler step: tests/mjcf_compare.py maps the states) on MJCF fixtures whose gravity is tilted, float64, 1e-10
relative (both compute the same arithmetic; measured ~1e-14); the staged step for the fused one (1e-12, as
tests/test_fused_step.py); a model built with one environment's gravity for each environment of a model given
gravity per environment (1e-12); central finite differences for tape gradients (float64, step 1e-6 of
max(|g|, 1): rtol 1e-6, as tests/test_parameter_gradients.py); the pendulum's equation of motion by hand for
an SDF world's gravity; -m p_CoM for d U / d g.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch  # the test extra installs it
import warp as wp

import mjcf_compare
import mjcf_models as mm
import warpdyn as wd
from gradcheck import weighted_sum
import warpdyn.torch as wdt
from warpdyn.engine import step as engine_step

TILTED = (1.5, -2.0, -9.0)

# A floating torso with an arm (two hinges) and a leg (a slide), gravity compensation on the torso and the arm.
FLOATING = """
<mujoco model="tilted floating">
  <compiler angle="radian"/>
  <option gravity="1.5 -2 -9" timestep="0.002"/>
  <worldbody>
    <body name="torso" pos="0.1 -0.2 1" euler="0.2 -0.1 0.4" gravcomp="0.3">
      <freejoint name="root"/>
      <inertial pos="0.02 -0.01 0.03" mass="3" diaginertia="0.04 0.05 0.06"/>
      <body name="arm" pos="0.2 0 0" gravcomp="0.7">
        <joint name="shoulder" axis="0 1 0" damping="0.1"/>
        <inertial pos="0.1 0 -0.02" mass="0.8" diaginertia="0.002 0.006 0.006"/>
        <body name="hand" pos="0.25 0 0">
          <joint name="wrist" axis="1 0 1"/>
          <inertial pos="0.05 0.02 0" mass="0.4" diaginertia="0.0005 0.001 0.001"/>
        </body>
      </body>
      <body name="leg" pos="0 0 -0.1">
        <joint name="hip" type="slide" axis="0 0 1"/>
        <inertial pos="0 0 -0.1" mass="0.5" diaginertia="0.003 0.003 0.001"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

# tests/mjcf_fixtures.py's GRAVCOMP with tilted gravity: a fixed-base arm (gravcomp 1 and 0.5) beside a free
# balloon (gravcomp 1) hanging from the world by its free joint.
SCENE = mm.GRAVCOMP.replace('<compiler angle="radian"/>', '<compiler angle="radian"/>\n  <option gravity="1.5 -2 -9"/>')
# The scene's arm alone: a fixed base with one-DoF joints.
ARM = SCENE[: SCENE.index('    <body name="balloon"')] + SCENE[SCENE.index("  </worldbody>") :]
CASES = {"floating": FLOATING, "scene": SCENE, "arm": ARM}


def _load(xml: str, dtype=np.float64) -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)  # the arm's actuatorgravcomp
        return wd.model.Model.build_from_model_description(xml, dtype=dtype)


def _states(model, mj, N: int, seed: int) -> dict:
    """Data.build's keyword arguments of N random MuJoCo states (mm.random_state), (N, ...) each."""
    rng = np.random.default_rng(seed)
    states = [mjcf_compare.mujoco_to_warpdyn_state(model, mj, *mm.random_state(mj, rng)).data_kwargs for _ in range(N)]
    return {name: np.stack([s[name] for s in states]) for name in states[0]}


def _assert_states_close(actual, expected, tolerance: float, label: str = "") -> None:
    np.testing.assert_array_equal(actual.valid_state.numpy(), expected.valid_state.numpy(), err_msg=f"{label} health flags")
    for name in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities"):
        a, b = getattr(actual, name).numpy(), getattr(expected, name).numpy()
        np.testing.assert_allclose(a, b, rtol=0.0, atol=tolerance * max(1.0, float(np.abs(b).max())), err_msg=f"{label} {name}")


# ------------------------------------------------------------------------------ MuJoCo


@pytest.mark.parametrize("case", list(CASES))
def test_dynamics_under_tilted_gravity_equal_mujocos(case):
    """M, h (qfrc_bias: gravity's generalized force), the passive forces (gravcomp: -gravcomp m g at the CoM)
    and ABA's accelerations equal MuJoCo's at qpos0 and three random states, the gravity (1.5, -2, -9) read
    from <option> (1e-10 relative, float64)."""
    model, mj = _load(CASES[case]), mm.load(CASES[case])
    np.testing.assert_array_equal(model.world_gravity.numpy().reshape(3), mj.opt.gravity)
    assert np.abs(model.gravcomp_mass.numpy()).max() > 0.0
    errors = mjcf_compare.compare_model(model, mj)
    assert all(errors[name] <= 1e-10 for name in mjcf_compare.QUANTITIES), errors


@pytest.mark.parametrize("case", ["floating", "scene"])
def test_an_euler_step_under_tilted_gravity_equals_mujocos(case):
    """One step of MuJoCo's Euler (SemiImplicitEulerSO3, damping implicit) equals mj_step's with constraints
    disabled, the gravity compensation applied in the step (1e-10 absolute)."""
    model, mj = _load(CASES[case]), mm.load(CASES[case])
    for seed in (0, 1):
        qpos, qvel = mm.random_state(mj, np.random.default_rng(seed))
        stepped = wd.model.step(model, wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs))
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, *mm.euler_step(mj, qpos, qvel)[:2]).data_kwargs
        np.testing.assert_allclose(stepped.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-10)
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-10)
        if model.floating_base():
            np.testing.assert_allclose(stepped.base_position.numpy(), expected["base_position"], rtol=0, atol=1e-10)
            v = np.concatenate([expected["base_linear_velocity"], expected["base_angular_velocity"]])
            np.testing.assert_allclose(stepped.base_velocity.numpy(), v, rtol=0, atol=1e-10)


@pytest.mark.parametrize("case", list(CASES))
def test_the_fused_step_under_gravity_per_environment_equals_the_staged_step(monkeypatch, case):
    """Four environments, each its own gravity (tilted, zero, upward, along x) and gravity compensation: the fused
    step (kernels/fused_step.py: the base's bias force, a free joint's acceleration below the world, the
    accelerations) equals the staged kernels' to rounding (1e-12), over two steps."""
    model, mj = _load(CASES[case]), mm.load(CASES[case])
    G = np.array([TILTED, (0.0, 0.0, 0.0), (0.3, 0.2, 4.0), (-9.81, 0.0, 0.0)])
    model.set_gravity(G)
    data = wd.data.Data.build(model, num_envs=4, **_states(model, mj, 4, seed=2))
    monkeypatch.setattr(wd.config, "fused_step", True)
    plan, _ = engine_step.prepare(model, data, health=True)
    assert plan.fused is not None and plan.gravcomp
    tau = np.random.default_rng(3).normal(0.0, 1.0, (4, model.dofs()))
    out = {}
    for fused in (True, False):
        monkeypatch.setattr(wd.config, "fused_step", fused)
        first = engine_step.step(model, data, joint_force_references=tau)
        out[fused] = (first, engine_step.step(model, first, joint_force_references=tau))
    for k, label in enumerate(("first step", "second step")):
        _assert_states_close(out[True][k], out[False][k], 1e-12, f"{case}, {label}")
    assert out[False][1].valid_state.numpy().all()


# ------------------------------------------------------------------------------ per environment


@pytest.mark.parametrize("case", ["floating", "scene"])
def test_each_environment_has_the_dynamics_of_its_gravity(case):
    """A model given N = 4 gravities (set_gravity (N, 3)) gives environment k what a model with the shared
    gravity G[k] gives: ABA's accelerations, the gravity and passive (gravcomp) forces, the potential energy and
    a step (1e-12 of each quantity's size)."""
    model, mj = _load(CASES[case]), mm.load(CASES[case])
    G = np.array([TILTED, (0.0, 0.0, -9.81), (0.0, 0.0, 0.0), (2.0, 1.0, 3.0)])
    model.set_gravity(G)
    assert model.per_environment_parameters() == {"world_gravity": 4} and model.world_gravity.shape == (4, 1)
    states = _states(model, mj, 4, seed=5)

    def quantities(m, data):
        base, joints = wd.model.forward_dynamics_aba(m, data)
        stepped = wd.model.step(m, data)
        return {
            "base acceleration": base.numpy(), "joint accelerations": joints.numpy(),
            "gravity forces": wd.model.free_floating_gravity_forces(m, data).numpy(),
            "passive forces": wd.model.free_floating_passive_forces(m, data).numpy(),
            "potential energy": wd.model.potential_energy(m, data).numpy(),
            "stepped joint velocities": stepped.joint_velocities.numpy(), "stepped base velocity": stepped.base_velocity.numpy(),
        }  # fmt: skip

    data = wd.data.Data.build(model, num_envs=4, **states)
    batched = quantities(model, data)
    for k in range(4):
        single = model.copy()
        single.set_gravity(G[k])
        expected = quantities(single, wd.data.Data.build(single, num_envs=1, **{name: v[k : k + 1] for name, v in states.items()}))
        for name, value in expected.items():
            np.testing.assert_allclose(batched[name][k], value[0], rtol=0.0, atol=1e-12 * max(1.0, np.abs(value).max()), err_msg=f"{case}: {name}, environment {k}")
    shared = model.copy()
    shared.set_gravity(G[0])
    first = quantities(shared, data)
    change = [np.abs(first[name] - batched[name]).max(axis=1) for name in ("base acceleration", "joint accelerations")]
    assert np.maximum(*change)[1:].min() > 0.1, "each environment's gravity matters"


# ------------------------------------------------------------------------------ gradients

STEP, RTOL, ATOL = 1e-6, 1e-6, 1e-9
RECORD = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")


def _rollout_loss(model, states: dict, weights: dict, size: list | None = None):
    """sum w x over the records of 4 steps from `states`; appends sum |w x| (the loss's size) to `size`."""
    data = wd.data.Data.build(model, num_envs=states["joint_positions"].shape[0], **states)
    _, rec = wd.simulation.rollout(model, data, steps=4, record=RECORD)
    if size is not None:
        size.append(sum(float(np.abs(rec[name].numpy() * weights[name].numpy()).sum()) for name in RECORD))
    return weighted_sum([rec[name] for name in RECORD], [weights[name] for name in RECORD])


def _central_differences(array: wp.array, loss) -> np.ndarray:
    """d loss / d array by central differences, each entry stepped by STEP max(|x|, 1) in place."""
    x0 = array.numpy().copy()
    fd = np.zeros_like(x0)
    for i in np.ndindex(x0.shape):
        h = STEP * max(abs(float(x0[i])), 1.0)
        values = []
        for sign in (1.0, -1.0):
            x = x0.copy()
            x[i] += sign * h
            array.assign(x)
            values.append(float(loss().numpy()[0]))
        fd[i] = (values[0] - values[1]) / (2.0 * h)
    array.assign(x0)
    return fd


@pytest.mark.parametrize("per_environment", [False, True], ids=["shared", "per environment"])
def test_rollout_gradients_with_respect_to_gravity_equal_finite_differences(per_environment):
    """d loss / d world_gravity through 4 steps (MuJoCo's Euler, 2 ms) of the floating model with gravity
    compensation, 3 environments, loss a random weighting of the records: the tape's gradient equals central
    differences (rtol 1e-6; atol 1e-9, or the differences' rounding 1e-16 / 1e-6 of the loss's size sum |w x|
    when larger, times max(|g|, 1)). Shared: the gradient summed over the environments,
    equal to the rows' sum of the same gravity given per environment (1e-12) and to the deterministic
    gradient's (warpdyn.engine.determinism; 1e-12)."""
    model, mj = _load(FLOATING), mm.load(FLOATING)
    N = 3
    G = np.array([TILTED, (0.5, 1.0, -9.81), (-1.0, 0.0, -4.0)]) if per_environment else np.array(TILTED)
    model.set_gravity(G)
    states = _states(model, mj, N, seed=7)
    rng = np.random.default_rng(8)
    shapes = {"base_position": (3,), "base_quaternion": (4,), "joint_positions": (3,), "base_velocity": (6,), "joint_velocities": (3,)}
    weights = {name: wp.array(rng.normal(size=(5, N, *shape)), dtype=wp.float64) for name, shape in shapes.items()}

    def gradient(m, **kwargs):
        g = wd.model.parameters_requiring_grad(m, names=("world_gravity",), **kwargs)["world_gravity"]
        g.grad.zero_()
        tape = wp.Tape()
        with tape:
            loss = _rollout_loss(m, states, weights)
        tape.backward(loss)
        return g, g.grad.numpy().reshape(-1, 3).copy()

    g, grad = gradient(model)
    fd = _central_differences(g, lambda: _rollout_loss(model, states, weights)).reshape(-1, 3)
    size = []
    _rollout_loss(model, states, weights, size)
    scale = np.maximum(np.abs(g.numpy().reshape(-1, 3)), 1.0)
    np.testing.assert_allclose(grad * scale, fd * scale, rtol=RTOL, atol=max(ATOL, 1e-16 / STEP * size[0]))
    assert grad.shape == (N if per_environment else 1, 3) and np.abs(fd).min() > 1e-4, "every component matters"
    if not per_environment:
        rows = model.copy()
        rows.set_gravity(np.tile(G, (N, 1)))
        np.testing.assert_allclose(gradient(rows)[1].sum(axis=0), grad[0], rtol=1e-12, atol=1e-14)
        deterministic = model.copy()
        np.testing.assert_allclose(gradient(deterministic, deterministic=True)[1], grad, rtol=1e-12, atol=1e-14)


def test_potential_energy_gradient_is_minus_mass_times_com():
    """U = -m g . p_CoM: d U / d world_gravity = -m p_CoM per environment (1e-12), and U itself at the tilted
    gravity (reference: the total mass and wd.com.com_position)."""
    model, mj = _load(FLOATING), mm.load(FLOATING)
    G = np.array([TILTED, (0.0, 0.0, -9.81)])
    model.set_gravity(G)
    data = wd.data.Data.build(model, num_envs=2, **_states(model, mj, 2, seed=4))
    g = wd.model.parameters_requiring_grad(model, names="world_gravity")["world_gravity"]
    tape = wp.Tape()
    with tape:
        U = wd.model.potential_energy(model, data)
        loss = weighted_sum([U], [wp.ones(2, dtype=wp.float64)])
    tape.backward(loss)
    m, p = wd.model.total_mass(model), wd.com.com_position(model, data).numpy()
    np.testing.assert_allclose(g.grad.numpy().reshape(2, 3), -m * p, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(U.numpy(), -m * np.einsum("ki,ki->k", G, p), rtol=1e-12)


def test_torch_bridge_takes_world_gravity():
    """warpdyn.torch.rollout's parameters={"world_gravity": (1, 3) tensor}: its gradient is the tape's (1e-12)."""
    model, mj = _load(FLOATING), mm.load(FLOATING)
    state = _states(model, mj, 1, seed=9)
    on = dict(dtype=torch.float64, device=wdt.torch_device(model))  # the model's device: a GPU where there is one
    g = torch.tensor([TILTED], **on, requires_grad=True)
    q0 = torch.tensor(state["joint_positions"][0], **on)
    rec = wdt.rollout(model, steps=3, joint_positions=q0, parameters={"world_gravity": g}, record=("base_velocity",))
    w = torch.tensor(np.random.default_rng(1).normal(size=tuple(rec["base_velocity"].shape)), **on)
    (rec["base_velocity"] * w).sum().backward()
    reference = model.copy()
    array = wd.model.parameters_requiring_grad(reference, names="world_gravity")["world_gravity"]
    array.grad.zero_()
    tape = wp.Tape()
    with tape:
        _, out = wd.simulation.rollout(reference, wd.data.Data.build(reference, joint_positions=state["joint_positions"][0]), steps=3, record=("base_velocity",))
        loss = weighted_sum([out["base_velocity"]], [wp.array(w.cpu().numpy().reshape(out["base_velocity"].shape), dtype=wp.float64, device=model.device)])
    tape.backward(loss)
    np.testing.assert_allclose(g.grad.cpu().numpy(), array.grad.numpy().reshape(1, 3), rtol=1e-12, atol=1e-14)
    assert np.abs(g.grad.cpu().numpy()).max() > 1e-3


# ------------------------------------------------------------------------------ JaxSim's model.gravity


def test_jaxsims_gravity_setting_reads_and_writes_the_z_component():
    """model.gravity = g sets world_gravity (0, 0, g) shared (a new array, the model's version bumped) and reads g
    back as set (not rounded to float32); replace(gravity=...) changes the copy alone; equality and hashing
    ignore gravity (JaxSim's: name, time step, structure); build's gravity=9.81 is a magnitude and overrides
    the description's tilted gravity; a failing block of mutable_context puts the gravity back."""
    model = _load(FLOATING, np.float32)
    model.set_gravity((1.0, 2.0, 3.0))
    version = model.version
    model.gravity = -3.7
    assert model.gravity == -3.7 and model.version > version and "world_gravity" not in model.per_environment_parameters()
    np.testing.assert_array_equal(model.world_gravity.numpy(), np.array([[0.0, 0.0, -3.7]], dtype=np.float32))
    other = model.replace(gravity=-1.0)
    assert (other.gravity, model.gravity) == (-1.0, -3.7) and other == model and hash(other) == hash(model)
    with pytest.raises(RuntimeError), model.mutable_context():
        model.gravity = 5.0
        raise RuntimeError
    assert model.gravity == -3.7
    model.world_gravity.assign(np.array([[0.0, 0.0, -2.0]], dtype=np.float32))  # in place, then announced
    model.notify_model_changed()
    assert model.gravity == -2.0
    built = wd.model.Model.build_from_model_description(FLOATING, gravity=9.81, dtype=np.float64)
    assert built.gravity == -9.81 and built.world_gravity.numpy().tolist() == [[0.0, 0.0, -9.81]]
    assert _load(FLOATING.replace('gravity="1.5 -2 -9"', 'gravity="0 0 -3"')).gravity == -3.0


def test_reading_gravity_that_is_not_one_z_component_names_world_gravity():
    """model.gravity of a tilted gravity, or of gravity per environment: ValueError saying to read world_gravity."""
    model = _load(FLOATING)
    with pytest.raises(ValueError, match=r"does not point along z; read model.world_gravity"):
        model.gravity
    model.set_gravity(np.tile([0.0, 0.0, -9.81], (2, 1)))
    with pytest.raises(ValueError, match=r"given per environment .*read model.world_gravity"):
        model.gravity


def test_reduce_carries_the_gravity():
    """wd.model.reduce keeps the model's gravity: tilted and shared, or per environment."""
    model = _load(FLOATING)
    reduced = wd.model.reduce(model, ["shoulder", "hip"])
    np.testing.assert_array_equal(reduced.world_gravity.numpy(), [TILTED])
    G = np.array([TILTED, (0.0, 1.0, -2.0)])
    model.set_gravity(G)
    reduced = wd.model.reduce(model, ["shoulder"])
    assert reduced.per_environment_parameters() == {"world_gravity": 2}
    np.testing.assert_array_equal(reduced.world_gravity.numpy().reshape(2, 3), G)


# ------------------------------------------------------------------------------ SDF


def test_an_sdf_worlds_tilted_gravity_drives_its_pendulum():
    """An SDF <world><gravity>1.5 -2 -9</gravity> becomes the model's world_gravity; the pendulum (a link hinged
    to the world about y at its origin, CoM r = (0.3, 0.1, -0.2), mass 2) accelerates as its equation of motion
    says at rest at q = 0.7: qdd = a . (R r x m g) / (Iyy + m (rx^2 + rz^2)) (1e-12)."""
    sdf = """<sdf version="1.9"><world name="w"><gravity>1.5 -2 -9</gravity><model name="p"><link name="bob">
      <pose>0 0 1 0 0 0</pose><inertial><pose>0.3 0.1 -0.2 0 0 0</pose><mass>2</mass><inertia><ixx>0.01</ixx><iyy>0.02</iyy>
      <izz>0.03</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial></link><joint name="hinge" type="revolute">
      <parent>world</parent><child>bob</child><axis><xyz>0 1 0</xyz></axis></joint></model></world></sdf>"""
    model = wd.model.Model.build_from_model_description(sdf, dtype=np.float64)
    np.testing.assert_array_equal(model.description.gravity, TILTED)
    np.testing.assert_array_equal(model.world_gravity.numpy(), [TILTED])
    q, m, r, a = 0.7, 2.0, np.array([0.3, 0.1, -0.2]), np.array([0.0, 1.0, 0.0])
    R = np.array([[np.cos(q), 0.0, np.sin(q)], [0.0, 1.0, 0.0], [-np.sin(q), 0.0, np.cos(q)]])
    expected = a @ np.cross(R @ r, m * np.array(TILTED)) / (0.02 + m * (r[0] ** 2 + r[2] ** 2))
    _, qdd = wd.model.forward_dynamics_aba(model, wd.data.Data.build(model, joint_positions=[q]))
    np.testing.assert_allclose(qdd.numpy(), [expected], rtol=1e-12)


# ------------------------------------------------------------------------------ bad input


@pytest.mark.parametrize(
    "value, message",
    [
        ((np.nan, 0.0, -9.81), r"world_gravity has non-finite values"),
        ([[0.0, np.inf, -9.81]], r"world_gravity has non-finite values"),
        ((0.0, -9.81), r"world_gravity has shape \(2,\), expected \(3,\) \(shared\) or \(N, 3\) \(per environment\)"),
        (np.zeros((2, 4)), r"world_gravity has shape \(2, 4\)"),
        (np.zeros((1, 1, 3)), r"world_gravity has shape \(1, 1, 3\)"),
        (np.zeros((0, 3)), r"world_gravity has shape \(0, 3\)"),
    ],
)
def test_bad_gravity_is_refused_naming_world_gravity(value, message):
    model = _load(FLOATING)
    before, version = model.world_gravity, model.version
    with pytest.raises(ValueError, match=message):
        model.set_gravity(value)
    assert model.world_gravity is before and model.version == version


def test_gravity_edited_in_place_is_checked_and_flags_nothing_silently():
    """A NaN written into world_gravity in place (after a step built the model's plan): a step flags that
    environment (its state non-finite) and keeps the other's; validate_parameters names it and the environment."""
    model = _load(FLOATING)
    model.set_gravity(np.tile(TILTED, (2, 1)))
    data = wd.data.Data.build(model, num_envs=2)
    wd.model.step(model, data)
    model.world_gravity.assign(np.array([[TILTED], [(0.0, np.nan, -9.81)]]))
    stepped = wd.model.step(model, data)
    assert stepped.healthy.numpy().tolist() == [True, False]
    np.testing.assert_array_equal(stepped.joint_positions.numpy()[1], data.joint_positions.numpy()[1])
    with pytest.raises(ValueError, match=r"world_gravity of the world in environment 1 is \[0.0, nan, -9.81\] \[m/s\^2, world frame\]: must be finite"):
        model.validate_parameters()
    with pytest.raises(TypeError, match=r"world_gravity must be real numbers"):
        model.set_gravity(["a", "b", "c"])
