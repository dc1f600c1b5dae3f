"""Bad input that warpdyn used to accept without a word (issue 34, item 4, found by fault injection).

Each case now gets an exception that names the offending thing (the array, its shape or dtype, the field and
its value), or a documented and tested behaviour (an environment flagged invalid by the step, its state
kept). Reference: the façade's documented contract (warpdyn.simulation.Stepper, warpdyn.arrays,
warpdyn.types.settings, warpdyn.types.parameters, warpdyn.envs.LeggedEnvConfig, warpdyn.engine.step's
stability check). No tolerances: exact messages matched by regular expressions, states compared bit for bit
(the same kernels on the same numbers).
"""

from __future__ import annotations

import functools
import re

import numpy as np
import pytest
import warp as wp

import warpdyn as wd
from warpdyn.engine import step as engine_step
from warpdyn.types import parameters as registry

SoftContactsParams = wd.model.SoftContactsParams


def _pendulum_urdf(height: float, hinge: str = "continuous") -> str:
    """Two 0.5 m rods hanging from a base welded `height` m above the world's origin, each with a 0.1 m
    collision box at its end (8 collidable points each); the second joint is `hinge` (continuous or a
    prismatic slide with limits)."""
    limit = '<limit lower="-0.1" upper="0.1" effort="10" velocity="1"/>' if hinge == "prismatic" else ""
    parts = ['<robot name="pendulum">', '<link name="world"/>', '<link name="base"/>',
             f'<joint name="weld" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 {height}"/></joint>']
    for i in range(2):
        parts.append(
            f'<link name="rod{i}"><inertial><origin xyz="0 0 -0.25"/><mass value="1"/>'
            '<inertia ixx="0.02" iyy="0.02" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>'
            '<collision><origin xyz="0 0 -0.5"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision></link>'
        )
        kind = hinge if i == 1 else "continuous"
        axis = "0 0 1" if kind == "prismatic" else "0 1 0"
        parts.append(
            f'<joint name="hinge{i}" type="{kind}"><parent link="{"base" if i == 0 else "rod0"}"/><child link="rod{i}"/>'
            f'<origin xyz="0 0 {0.0 if i == 0 else -0.5}"/><axis xyz="{axis}"/>{limit}</joint>'
        )
    parts.append("</robot>")
    return "\n".join(parts)


def _pendulum(height: float, hinge: str = "continuous", time_step: float = 0.001) -> wd.model.Model:
    model = wd.model.Model.build_from_model_description(_pendulum_urdf(height, hinge), dtype=np.float64)
    model.time_step = time_step
    return model


@functools.cache
def _legs_model():
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=np.float64)
    return wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)


def _legs() -> wd.model.Model:
    """The ergoCub legs (floating base, 32 enabled collidable points), a copy the test may change."""
    return _legs_model().copy()


def _state(data) -> list[np.ndarray]:
    return [a.numpy().copy() for a in wd.engine.kinematics.state_arrays(data)]


def _assert_same(a, b, label: str) -> None:
    for x, y in zip(_state(a), _state(b)):
        np.testing.assert_array_equal(x, y, err_msg=label)


def _actuated_pendulum(N: int = 3):
    """The pendulum high above the ground with a position servo per joint, N environments swinging, and a
    Stepper (2 substeps) on it."""
    model = wd.model.add_actuators(_pendulum(3.0), "position", kp=20.0, kv=1.0)
    data = wd.data.Data.build(model, num_envs=N, joint_positions=np.tile([0.3, -0.2], (N, 1)))
    return model, data, wd.simulation.Stepper(model, data, substeps=2)


# ------------------------------------------------------------------------ 1. the Stepper's inputs


def test_stepper_ctrl_assign_one_environment_short_is_refused():
    """The documented way (README, docs/simulation.md) of writing a Stepper's controls, `stepper.ctrl.assign(...)`, with an array one environment
    short: ValueError naming Stepper.ctrl, the shape given and the shapes accepted; the controls unchanged
    (Warp's own assign copies by byte count: the last environment kept its old control)."""
    model, data, stepper = _actuated_pendulum(3)
    na = model.number_of_actuators()
    stepper.ctrl.assign(np.full((3, na), 0.5))
    with pytest.raises(ValueError, match=re.escape(f"Stepper.ctrl has shape (2, {na}), expected one of [({na},), (3, {na})]")):
        stepper.ctrl.assign(np.zeros((2, na)))
    with pytest.raises(ValueError, match=re.escape(f"Stepper.ctrl has shape (2, {na})")):
        stepper.ctrl.assign(wp.zeros((2, na), dtype=wp.float64))
    np.testing.assert_array_equal(stepper.ctrl.numpy(), np.full((3, na), 0.5))


@pytest.mark.parametrize(
    "name, value, error, message",
    [
        ("joint_force_references", np.zeros((3, 3)), ValueError, r"Stepper.joint_force_references has shape \(3, 3\), expected one of \[\(2,\), \(3, 2\)\]"),
        ("joint_force_references", np.zeros((2, 3)), ValueError, r"Stepper.joint_force_references has shape \(2, 3\)"),
        ("joint_force_references", np.array([[0.0, np.nan]] * 3), ValueError, r"Stepper.joint_force_references has non-finite values, first at index \(0, 1\): nan"),
        ("ctrl", np.array([0.1 + 1j, 0.2]), TypeError, r"Stepper.ctrl must be real numbers, got an array of complex128"),
        ("ctrl", np.array([True, False]), TypeError, r"Stepper.ctrl must be real numbers, got an array of bool"),
        ("ctrl", wp.zeros((3, 2), dtype=wp.float32), TypeError, r"Stepper.ctrl has dtype float32, but the model computes in float64"),
        ("link_forces", np.zeros((3, 3, 5)), ValueError, r"Stepper.link_forces has shape \(3, 3, 5\), expected one of \[\(3, 6\), \(3, 3, 6\)\]"),
    ],
)
def test_stepper_inputs_are_checked_when_assigned(name, value, error, message):
    """Every writable input of a Stepper (joint_force_references, ctrl, link_forces) checks what `.assign` is
    given: the shape (the per-environment one, shared, or one row per environment), the dtype of a Warp
    array, real finite numbers from the host; an error names the array."""
    model = wd.model.add_actuators(_pendulum(3.0), "position", kp=20.0, kv=1.0)
    data = wd.data.Data.build(model, num_envs=3)
    stepper = wd.simulation.Stepper(model, data, link_forces=True)
    target = getattr(stepper, name)
    before = target.numpy().copy()
    with pytest.raises(error, match=message):
        target.assign(value)
    np.testing.assert_array_equal(target.numpy(), before)


def test_stepper_assign_broadcasts_a_shared_value_and_steps_as_model_step():
    """`.assign` of one environment's value (na,) writes it to every environment (documented: controls shared
    by the environments, as `step` takes them; Warp's own assign wrote environment 0 only); of (N, na), one row
    per environment. The Stepper then steps as wd.model.step with that ctrl, bit for bit."""
    model, data, stepper = _actuated_pendulum(3)
    stepper.ctrl.assign([0.4, -0.1])
    np.testing.assert_array_equal(stepper.ctrl.numpy(), np.tile([0.4, -0.1], (3, 1)))
    u = np.array([[0.1, 0.2], [0.3, 0.4], [0.5, 0.6]])
    stepper.ctrl.assign(u)
    got = stepper.step()
    expected = wd.model.step(model, wd.model.step(model, data, ctrl=u), ctrl=u)
    _assert_same(got, expected, "ctrl (N, na)")


def test_stepper_inputs_stay_zero_copy_warp_arrays():
    """The checked inputs are Warp arrays over the Stepper's own memory: kernels read them as before,
    wp.to_torch shares them (writes through such a view are the user's, unchecked: documented), and a
    Warp array of the right shape and dtype is copied in on the device."""
    torch = pytest.importorskip("torch")
    model, data, stepper = _actuated_pendulum(2)
    assert isinstance(stepper.ctrl, wp.array) and isinstance(stepper.joint_force_references, wp.array)
    view = wp.to_torch(stepper.ctrl)
    view[:] = torch.tensor([[0.1, 0.2], [0.3, 0.4]], dtype=view.dtype)
    np.testing.assert_array_equal(stepper.ctrl.numpy(), [[0.1, 0.2], [0.3, 0.4]])
    stepper.ctrl.assign(wp.array([[1.0, 2.0], [3.0, 4.0]], dtype=wp.float64))
    np.testing.assert_array_equal(view.cpu().numpy(), [[1.0, 2.0], [3.0, 4.0]])


# ------------------------------------------------------- 2. complex, bool, object and str arrays


_NOT_REAL = [
    (np.array([1 + 2j, 3j]), "complex128"),
    (np.array([True, False]), "bool"),
    (np.array([1.0, None], dtype=object), "object"),
    (np.array(["1", "2"]), "<U1"),
]


@pytest.mark.parametrize("value, dtype", _NOT_REAL, ids=["complex", "bool", "object", "str"])
def test_state_from_arrays_that_are_not_real_numbers(value, dtype):
    """Data.build(joint_positions=[1 + 2j, 3j]) kept the real parts (NumPy's cast drops the imaginary part
    with a warning); bool arrays became 0/1. Now: TypeError naming the argument and the dtype."""
    model = _pendulum(3.0)
    with pytest.raises(TypeError, match=re.escape(f"joint_positions must be real numbers, got an array of {dtype}")):
        wd.data.Data.build(model, joint_positions=value)


@pytest.mark.parametrize("value, dtype", _NOT_REAL, ids=["complex", "bool", "object", "str"])
def test_controls_that_are_not_real_numbers(value, dtype):
    """The control and force arguments of step and of the dynamics functions go through the same conversion:
    TypeError naming the argument and the dtype."""
    model = wd.model.add_actuators(_pendulum(3.0), "motor")
    data = wd.data.Data.build(model)
    for name in ("joint_force_references", "ctrl"):
        with pytest.raises(TypeError, match=re.escape(f"{name} must be real numbers, got an array of {dtype}")):
            wd.model.step(model, data, **{name: value})
    with pytest.raises(TypeError, match=re.escape(f"joint_forces must be real numbers, got an array of {dtype}")):
        wd.model.forward_dynamics_aba(model, data, joint_forces=value)
    forces = np.broadcast_to(value[:1], (model.number_of_links(), 6))
    with pytest.raises(TypeError, match=re.escape(f"link_forces must be real numbers, got an array of {dtype}")):
        wd.model.step(model, data, link_forces=forces)


# ------------------------------------------------- 3. a parameter edited in place to an impossible value


def test_negative_mass_written_in_place_flags_the_next_step():
    """`model.link_mass.assign(...)` with a negative mass after the model has stepped (its plan built): the
    next step flags every environment invalid (data.healthy 0, the state kept, as for a non-finite state) on the
    device, without a host synchronisation; a mass made physical again steps as before."""
    model = _pendulum(3.0)
    data = wd.data.Data.build(model, num_envs=2, joint_positions=[0.3, -0.2])
    good = wd.model.step(model, data)
    assert good.healthy.numpy().tolist() == [1, 1]
    masses = model.link_mass.numpy().copy()
    bad = masses.copy()
    bad[2] = -1.0
    model.link_mass.assign(bad)
    flagged = wd.model.step(model, data)
    assert flagged.healthy.numpy().tolist() == [0, 0]
    for name, (x, y) in zip(("p", "Q", "s", "v", "sdot", "m"), zip(_state(data)[:6], _state(flagged)[:6])):
        np.testing.assert_array_equal(x, y, err_msg=f"{name}: a flagged environment keeps its state")
    model.link_mass.assign(masses)
    _assert_same(wd.model.step(model, data), good, "the mass restored")


def test_negative_mass_of_one_environment_flags_that_environment():
    """Per-environment masses (domain randomisation) edited in place, one environment's negative: that one is
    flagged, the others step as before (the Stepper and wd.model.step alike)."""
    model = _pendulum(3.0)
    N = 3
    model.set_link_parameters(mass=np.tile(model.link_mass.numpy(), (N, 1)))
    data = wd.data.Data.build(model, num_envs=N, joint_positions=[0.3, -0.2])
    stepper = wd.simulation.Stepper(model, data)
    expected = wd.model.step(model, data)
    masses = model.link_mass.numpy().copy()
    masses[1, 1] = -0.5
    model.link_mass.assign(masses)
    for got in (wd.model.step(model, data), stepper.step()):
        assert got.healthy.numpy().tolist() == [1, 0, 1]
        np.testing.assert_array_equal(got.joint_positions.numpy()[[0, 2]], expected.joint_positions.numpy()[[0, 2]])
        np.testing.assert_array_equal(got.joint_positions.numpy()[1], data.joint_positions.numpy()[1])


@pytest.mark.parametrize(
    "name, index, value",
    [("link_mass", (1,), -2.0), ("link_inertia", (2, 1, 1), -0.5), ("armature", (0,), -0.1),
     ("friction_viscous", (1,), -1.0), ("position_limits", (0,), (1.0, -1.0)), ("joint_limit_spring", (1,), np.nan)],
)
def test_parameters_edited_in_place_flag_the_step(name, index, value):
    """Each kind of device-side check (non-negative, inertia diagonal, limits ordered, NaN): a parameter edited
    in place to an impossible value flags the next step's environments."""
    model = _pendulum(3.0)
    data = wd.data.Data.build(model, num_envs=2)
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1, 1]
    array = getattr(model, name)
    host = array.numpy().copy()
    host[index] = value
    array.assign(host)
    assert wd.model.step(model, data).healthy.numpy().tolist() == [0, 0]


def test_a_fixed_base_own_mass_is_not_checked():
    """A fixed base's own mass and inertia enter no dynamics (the base does not move): neither the device check
    nor the host's reads them, so a finite-difference probe around a massless fixed base
    (tests/test_domain_randomisation, test_torch_bridge's gradcheck) steps as before."""
    model = _pendulum(3.0)
    data = wd.data.Data.build(model, num_envs=2)
    expected = wd.model.step(model, data)
    masses = model.link_mass.numpy().copy()
    masses[0] = -1e-6
    model.link_mass.assign(masses)
    _assert_same(wd.model.step(model, data), expected, "a fixed base's mass, device check")
    model.notify_model_changed()
    registry.validate_parameters(model)
    _assert_same(wd.model.step(model, data), expected, "a fixed base's mass, host check")


def test_contact_parameters_edited_in_place_flag_the_step():
    """Warp arrays of the contact parameters (per environment, as LeggedEnv randomises mu) edited in place to
    K = 0, a negative mu or an unstable dt K / D: the affected environments are flagged."""
    model = _pendulum(0.8, time_step=0.001)
    N = 3
    K = wp.array(np.full(N, 1e6), dtype=wp.float64)
    D = wp.array(np.full(N, 2000.0), dtype=wp.float64)
    mu = wp.array(np.full(N, 0.5), dtype=wp.float64)
    model.contact_params = SoftContactsParams(K=K, D=D, mu=mu)
    data = wd.data.Data.build(model, num_envs=N, joint_positions=[np.pi / 2, 0.0])  # horizontal: in reach, not touching
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1, 1, 1]
    K.assign([1e6, 0.0, 1e6])
    mu.assign([0.5, 0.5, -0.1])
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1, 0, 0]
    K.assign([1e6, 1e6, 1e6])
    mu.assign([0.5, 0.5, 0.5])
    D.assign([2000.0, 2000.0, 400.0])  # dt K / D = 2.5: unstable deformation, and this pendulum reaches the ground
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1, 1, 0]


def test_negative_mass_before_the_first_step_is_refused_naming_link_and_value():
    """An in-place edit before the model's step plan is built (or after `notify_model_changed()`): the plan's
    host check refuses it, naming the parameter, the link and the value."""
    model = _pendulum(3.0)
    data = wd.data.Data.build(model)
    masses = model.link_mass.numpy().copy()
    masses[2] = -1.0
    model.link_mass.assign(masses)
    with pytest.raises(ValueError, match=r"link_mass of link 'rod1' is -1 \[kg\]: must be non-negative"):
        wd.model.step(model, data)
    masses[2] = 1.0
    model.link_mass.assign(masses)
    wd.model.step(model, data)
    inertia = model.link_inertia.numpy().copy()
    inertia[1, 0, 0] = -0.3
    model.link_inertia.assign(inertia)
    model.notify_model_changed()
    with pytest.raises(ValueError, match=r"link_inertia of link 'rod0' is .*: must be symmetric positive semi-definite"):
        wd.model.step(model, data)


def test_validate_parameters_names_parameter_element_environment_and_value():
    """registry.validate_parameters(model), the host check (one copy to the host per parameter): per-
    environment values name the environment; joint values the joint; contact values the field."""
    model = _pendulum(3.0)
    registry.validate_parameters(model)
    model.set_joint_parameters(friction_static=np.zeros((4, 2)))
    values = model.friction_static.numpy().copy()
    values[3, 1] = -0.25
    model.friction_static.assign(values)
    with pytest.raises(ValueError, match=r"friction_static of joint 'hinge1' in environment 3 is -0.25 \[N m or N\]: must be non-negative"):
        registry.validate_parameters(model)
    model.friction_static.assign(np.zeros((4, 2)))
    limits = model.position_limits.numpy().copy()
    limits[0] = (1.0, -1.0)
    model.position_limits.assign(limits)
    with pytest.raises(ValueError, match=r"position_limits of joint 'hinge0' is \[1.0, -1.0\] \[rad or m\]: must be \(lower, upper\)"):
        registry.validate_parameters(model)
    model.position_limits.assign(np.tile([-np.inf, np.inf], (2, 1)))
    K = wp.array([1e6], dtype=wp.float64)
    model.contact_params = SoftContactsParams(K=K)
    K.assign([-1.0])
    with pytest.raises(ValueError, match=r"SoftContactsParams.K must be .*, got -1.0 \(environment 0\)"):
        registry.validate_parameters(model)


def test_the_device_check_covers_every_parameter_with_a_physical_range():
    """Every model array whose registry check is more than finiteness (non-negative, limits, inertia) is read
    by the device-side check (a NaN or inf elsewhere makes the state non-finite, which the step flags)."""
    from warpdyn.kernels import parameter_checks

    ranged = {p.name for p in registry.REGISTRY.values() if p.name in registry.MODEL_ARRAYS and p.check is not registry.check_finite}
    assert ranged == set(parameter_checks.CHECKED)
    assert parameter_checks.INERTIA_ATOL == wd.description.physical.INERTIA_ATOL


# --------------------------------------------------------------------------- 4. SoftContactsParams


@pytest.mark.parametrize(
    "field, value, shown",
    [("K", 0.0, "0.0"), ("K", -1.0, "-1.0"), ("K", np.nan, "nan"), ("K", np.inf, "inf"), ("K", np.array([1e6, 0.0]), r"0.0 \(environment 1\)"),
     ("D", 0.0, "0.0"), ("D", np.inf, "inf"), ("mu", -0.1, "-0.1"), ("mu", np.nan, "nan"), ("mu", np.inf, "inf"),
     ("p", -0.5, "-0.5"), ("p", np.nan, "nan"), ("q", np.inf, "inf")],
)
def test_soft_contact_parameters_out_of_range(field, value, shown):
    """K = 0 is no ground at all (the legs fell through the floor with valid = 1): K and D must be positive
    and finite, mu, p and q finite and non-negative (JaxSim 0.9.0's SoftContactsParams.valid() asks K, D, mu,
    p, q >= 0; K = 0 and D = 0 are refused here as physics demands). ValueError naming the field and value."""
    with pytest.raises(ValueError, match=rf"SoftContactsParams.{field} must be .*, got {shown}"):
        SoftContactsParams(**{field: value})


@pytest.mark.parametrize("value", [True, "1e6", np.array([1e6 + 1j]), np.array([True])], ids=["bool", "str", "complex", "bool array"])
def test_soft_contact_parameters_that_are_not_numbers(value):
    """A bool, a string, complex or bool arrays: TypeError naming the field."""
    with pytest.raises(TypeError, match=r"SoftContactsParams.K must be"):
        SoftContactsParams(K=value)


# --------------------------------------------------------------------------------- 5. LeggedEnvConfig


@pytest.mark.parametrize(
    "field, value, message",
    [
        ("time_step", float("nan"), r"LeggedEnvConfig.time_step must be a positive finite number \[s\], got nan"),
        ("time_step", -0.002, r"LeggedEnvConfig.time_step must be a positive finite number \[s\], got -0.002"),
        ("time_step", 0.0, r"LeggedEnvConfig.time_step must be a positive finite number \[s\], got 0.0"),
        ("policy_dt", float("inf"), r"LeggedEnvConfig.policy_dt must be a positive finite number \[s\], got inf"),
        ("contact_stiffness", 0.0, r"LeggedEnvConfig.contact_stiffness must be a positive finite number"),
        ("contact_damping", -1.0, r"LeggedEnvConfig.contact_damping must be a positive finite number .* or None, got -1.0"),
        ("kp", -1.0, r"LeggedEnvConfig.kp must be a finite number >= 0"),
        ("action_clip", 0.0, r"LeggedEnvConfig.action_clip must be a positive finite number"),
        ("episode_seconds", float("nan"), r"LeggedEnvConfig.episode_seconds must be a positive finite number \[s\], got nan"),
        ("joint_noise", -0.1, r"LeggedEnvConfig.joint_noise must be a finite number >= 0"),
        ("torque_limit", 0.0, r"LeggedEnvConfig.torque_limit must be a positive finite number \[N m\], \{joint name: N m\} or None, got 0.0"),
        ("mass_scale", (-1.0, 1.0), r"LeggedEnvConfig.mass_scale must be a range \(low, high\) of finite numbers with 0 < low <= high, got \(-1.0, 1.0\)"),
        ("mass_scale", (1.2, 0.8), r"LeggedEnvConfig.mass_scale must be a range"),
        ("friction", (-0.1, 0.5), r"LeggedEnvConfig.friction must be a range \(low, high\) of finite numbers with 0 <= low <= high"),
        ("lin_vel_x", (1.0, -1.0), r"LeggedEnvConfig.lin_vel_x must be a range \(low, high\) of finite numbers with low <= high \[m/s\], got \(1.0, -1.0\)"),
        ("yaw_rate", (0.0,), r"LeggedEnvConfig.yaw_rate must be a range \(low, high\)"),
        ("time_step", True, r"LeggedEnvConfig.time_step must be a number, got True"),
        ("kd", "5", r"LeggedEnvConfig.kd must be a number, got '5'"),
    ],
)
def test_legged_env_config_values(field, value, message):
    """LeggedEnvConfig(time_step=nan) failed with "cannot convert float NaN to integer", a negative time step
    with a message about whole numbers of steps: every numeric field is checked in __post_init__ (finite,
    positive or non-negative, ranges ordered, no bools or strings), naming the field and the value."""
    envs = pytest.importorskip("warpdyn.envs")
    with pytest.raises((ValueError, TypeError), match=message):
        envs.LeggedEnvConfig(**{field: value})


def test_legged_env_config_whole_number_of_steps():
    """policy_dt that is not a whole number of time steps is refused by the config itself, naming both."""
    envs = pytest.importorskip("warpdyn.envs")
    with pytest.raises(ValueError, match=r"LeggedEnvConfig.policy_dt 0.005 s must be a whole number of time steps of 0.002 s"):
        envs.LeggedEnvConfig(policy_dt=0.005, time_step=0.002)
    envs.LeggedEnvConfig(policy_dt=0.02, time_step=0.002)


# ------------------------------------------------------ 6. the stability check follows the scene


def test_fixed_pendulum_that_cannot_reach_the_ground_steps_at_a_large_time_step():
    """JaxSim's K = 1e6, D = 2000 at dt = 0.005 (dt K / D = 2.5, beyond the explicit Euler's 2) was refused
    for a fixed-base pendulum welded 3 m up, whose points reach at most 0.5 + 0.5 + |(0.05, 0.05, 0.55)| m
    from the base: no point can touch the ground, so the deformation never acts. It steps now, valid, and
    equals the same pendulum without collidable points, bit for bit: no contact force."""
    model = _pendulum(3.0, time_step=0.005)
    data = wd.data.Data.build(model, num_envs=2, joint_positions=np.array([[1.0, -0.5], [2.5, 1.0]]))
    free = wd.contact.with_collidable_points(model, enabled=np.zeros(16, dtype=bool))
    a, b = data, data
    for _ in range(20):
        a, b = wd.model.step(model, a), wd.model.step(free, b)
    assert a.healthy.numpy().tolist() == [1, 1]
    _assert_same(a, b, "no contact force")
    assert np.abs(a.tangential_deformation_state.numpy()).max() == 0.0


def test_fixed_pendulum_near_the_ground_is_still_refused():
    """The same pendulum welded 0.8 m up can reach the ground: refused, with the stable setting named."""
    model = _pendulum(0.8, time_step=0.005)
    with pytest.raises(ValueError, match=r"dt K/D = 2.5, beyond the stability limit 2.0 .* take time_step < 0.004 s"):
        wd.model.step(model, wd.data.Data.build(model))


def test_floating_legs_are_still_refused():
    """A floating base can always reach the ground: the ergoCub legs at dt = 0.005 are refused as before."""
    legs = _legs()
    legs.time_step = 0.005
    with pytest.raises(ValueError, match=r"beyond the stability limit 2.0 of SemiImplicitEuler"):
        wd.model.step(legs, wd.data.Data.build(legs, base_position=(0.0, 0.0, 0.8)))


def test_prismatic_joint_in_the_chain_is_assumed_to_reach():
    """A prismatic joint's position is not bounded by its limits (JaxSim's limits are a spring, 0 by
    default): a chain with one may reach the ground from any height, and is refused."""
    model = _pendulum(50.0, hinge="prismatic", time_step=0.005)
    with pytest.raises(ValueError, match=r"beyond the stability limit"):
        wd.model.step(model, wd.data.Data.build(model))


def test_terrains_of_the_reach_check():
    """A PlaneTerrain far below the welded base: steps; a plane through the base: refused; a heightfield is
    assumed reachable (its heights may change in place): refused."""
    model = _pendulum(3.0, time_step=0.005)
    data = wd.data.Data.build(model)
    model.terrain = wd.terrain.PlaneTerrain(normal=(0.1, 0.0, 1.0), point=(0.0, 0.0, 0.0))
    assert wd.model.step(model, data).healthy.numpy().tolist() == [1]
    model.terrain = wd.terrain.PlaneTerrain(normal=(0.1, 0.0, 1.0), point=(0.0, 0.0, 2.5))
    with pytest.raises(ValueError, match=r"beyond the stability limit"):
        wd.model.step(model, data)
    model.terrain = wd.terrain.HeightfieldTerrain(heights=np.zeros((4, 4)), origin=(-1.0, -1.0), spacing=(1.0, 1.0))
    with pytest.raises(ValueError, match=r"beyond the stability limit"):
        wd.model.step(model, data)


def test_fixed_base_data_placed_where_points_reach_is_flagged():
    """The check on the host assumes the base where the description welds it. Data that puts a fixed base
    elsewhere (Data.build's base_position) within reach of the ground, at an unstable dt K / D, is flagged by
    the step on the device (valid 0, state kept); the environment out of reach steps."""
    model = _pendulum(3.0, time_step=0.005)
    data = wd.data.Data.build(model, num_envs=2, base_position=np.array([[0.0, 0.0, 0.5], [0.0, 0.0, 3.0]]))
    out = wd.model.step(model, data)
    assert out.healthy.numpy().tolist() == [0, 1]


def test_the_reach_is_cached_per_model_version():
    """The reach of the collidable points is computed once per model version (model.cached)."""
    model = _pendulum(3.0)
    first = engine_step.contact_reach(model)
    assert engine_step.contact_reach(model) is first
    model.terrain = wd.terrain.FlatTerrain(height=2.5)
    assert engine_step.contact_reach(model) is not first
