"""Data that does not hold together is refused before a kernel reads it; non-finite controls given as Warp
arrays flag their environment and leave the others intact; argument mistakes are named.

References:
- Data consistency (warpdyn.types.model.check_data / check_state): a Data assembled with
  dataclasses.replace from pieces of different batch sizes, dtypes, shapes or types, or without a health
  flag, raises a ValueError or TypeError naming the field (before: kernels read past the shorter arrays,
  and a step without a health flag crashed the process).
- Non-finite inputs (kernels/actuation.py, kernels/integrators.py): the reference is the same step or
  rollout with finite inputs. The faulty environment is flagged (valid 0) and keeps the state it had when
  the fault reached it; every other environment is bitwise equal to the reference (the same launches on the
  same numbers). NumPy inputs are checked on the host instead (a ValueError naming the array and the index).
- Arguments: num_envs, envs of reset/replace: named ValueError / TypeError instead of NumPy's.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import warp as wp

import mjcf_fixtures as mf
import robots
import warpdyn as wd

N = 3
BAD = 1  # the environment that gets the fault


@pytest.fixture(scope="module")
def chain():
    return wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(3), dtype=np.float64)


# ------------------------------------------------------------------------------------ data consistency


CALLS = {
    "step": lambda m, d: wd.model.step(m, d),
    "rollout": lambda m, d: wd.simulation.rollout(m, d, steps=2),
    "forward_kinematics": lambda m, d: wd.model.forward_kinematics(m, d),
    "mass_matrix": lambda m, d: wd.model.free_floating_mass_matrix(m, d),
    "base_velocity": lambda m, d: d.base_velocity,
}


@pytest.mark.parametrize("call", CALLS)
@pytest.mark.parametrize(
    "field", ["base_position_state", "base_quaternion_state", "joint_positions_state", "joint_velocities_state", "valid_state"]
)
def test_fields_of_different_batch_sizes_are_refused_before_launch(chain, field, call):
    data = wd.data.Data.build(chain, num_envs=N)
    other = wd.data.Data.build(chain, num_envs=N + 2)
    mixed = dataclasses.replace(data, **{field: getattr(other, field)})
    with pytest.raises(ValueError, match=r"data\.\w+_state has shape \(\d+,?( \d+)?\), expected .*N = \d environments"):
        CALLS[call](chain, mixed)


@pytest.mark.parametrize("call", ["step", "rollout"])
def test_a_step_without_a_health_flag_is_refused(chain, call):
    """dataclasses.replace(data, valid_state=None) then a step crashed the process (the integrator read the
    empty flag); now a ValueError says what is missing. Functions that do not step accept it."""
    data = dataclasses.replace(wd.data.Data.build(chain, num_envs=N), valid_state=None)
    with pytest.raises(ValueError, match=r"data.valid_state is None, but a step reads and writes each environment's health flag"):
        CALLS[call](chain, data)
    assert wd.model.free_floating_mass_matrix(chain, data).shape[0] == N


MALFORMED = [
    ("joint_positions_state", None, TypeError, r"data.joint_positions_state must be a Warp array \(N, k\), got None"),
    ("base_velocity_state", np.zeros((N, 6)), TypeError, r"data.base_velocity_state must be a Warp array \(N, k\), got a ndarray"),
    ("joint_velocities_state", wp.zeros((N, 3), dtype=wp.float32), TypeError, r"data.joint_velocities_state has dtype float32, expected float64"),
    ("joint_velocities_state", wp.zeros((N, 4), dtype=wp.float64), ValueError, r"data.joint_velocities_state has shape \(3, 4\), expected \(3, 3\)"),
    ("base_position_state", wp.zeros((N, 4), dtype=wp.float64), ValueError, r"data.base_position_state has shape \(3, 4\), expected \(3, 3\)"),
    ("valid_state", wp.ones(N, dtype=wp.float64), TypeError, r"data.valid_state has dtype float64, expected int32"),
    ("valid_state", wp.ones((N, 1), dtype=wp.int32), ValueError, r"data.valid_state has shape \(3, 1\), expected \(3,\)"),
    ("tangential_deformation_state", wp.zeros((N, 0), dtype=wp.float64), TypeError, r"tangential_deformation_state must be a Warp array \(N, nc, 3\) or None"),
    ("num_envs", 5, ValueError, r"data.num_envs is 5, but its arrays hold 3 environments"),
]


@pytest.mark.parametrize("field, value, error, message", MALFORMED)
def test_each_malformed_field_is_named(chain, field, value, error, message):
    data = dataclasses.replace(wd.data.Data.build(chain, num_envs=N), **{field: value})
    with pytest.raises(error, match=message):
        wd.model.step(chain, data)


@pytest.mark.parametrize("source", ["built", "stepped"])
@pytest.mark.parametrize("field, value, error, message", MALFORMED)
def test_a_checked_data_is_checked_again_after_a_field_is_set(chain, field, value, error, message, source):
    """check_data remembers a data that passed (warpdyn.types.data_checks) and a step's result inherits that;
    setting a field of the same Data object afterwards makes the next call check it again and name the field
    (reference: the same message as for a new malformed Data)."""
    data = wd.data.Data.build(chain, num_envs=N)
    wd.model.step(chain, data)
    wd.model.free_floating_mass_matrix(chain, data)
    if source == "stepped":
        data = wd.model.step(chain, data)
        wd.model.free_floating_mass_matrix(chain, data)
    setattr(data, field, value)
    with pytest.raises(error, match=message):
        wd.model.step(chain, data)
    with pytest.raises(error, match=message):
        wd.model.free_floating_mass_matrix(chain, data)


def test_a_checked_data_is_checked_again_after_the_model_changes(chain):
    """Link parameters given per environment for another N (a new model version) after the data passed: the
    next call says so (reference: the message for data built after the change)."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(3), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=N)
    stepped = wd.model.step(model, data)
    wd.model.free_floating_mass_matrix(model, stepped)
    model.set_link_parameters(mass=np.ones((N + 1, model.number_of_links())))
    for d in (data, stepped):
        with pytest.raises(ValueError, match=rf"per environment, but the data has {N} environments"):
            wd.model.free_floating_mass_matrix(model, d)
    other = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(4), dtype=np.float64)
    with pytest.raises(ValueError, match=rf"data.joint_positions_state has shape \({N}, 3\), expected \({N}, 4\)"):
        wd.model.free_floating_mass_matrix(other, stepped)


def test_single_environment_data_with_several_rows_is_refused(chain):
    data = dataclasses.replace(wd.data.Data.build(chain, num_envs=2), num_envs=None)
    with pytest.raises(ValueError, match=r"data.num_envs is None, but its arrays hold 2 environments \(None means 1\)"):
        wd.model.forward_kinematics(chain, data)


# ---------------------------------------------------------------------------------- non-finite inputs


def _flagged_and_others_intact(out, reference, start, bad_envs=(BAD,)):
    """out's bad environments are flagged and hold `start`'s state; the others equal `reference` bitwise."""
    valid = out.healthy.numpy()
    assert valid.tolist() == [0 if e in bad_envs else 1 for e in range(len(valid))]
    for name in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities"):
        got, ref, before = (getattr(d, name).numpy() for d in (out, reference, start))
        for e in range(len(valid)):
            np.testing.assert_array_equal(got[e], before[e] if e in bad_envs else ref[e], err_msg=f"{name}, environment {e}")


def _models():
    """(label, model): a floating URDF chain with joint friction and the torque-speed curve, and MJCF motors
    (a control-limited one first) and servos (force-limited)."""
    urdf = wd.model.Model.build_from_model_description(robots.random_tree_urdf(7, num_links=4), dtype=np.float64)
    urdf.set_joint_parameters(friction_static=np.full(urdf.dofs(), 0.5), friction_viscous=np.full(urdf.dofs(), 0.1))
    urdf.actuation_params = wd.model.ActuationParams(torque_max=2.0)  # the reference is clipped: a bound in play
    motor = wd.model.Model.build_from_model_description(mf.MOTOR, dtype=np.float64)
    servo = wd.model.Model.build_from_model_description(mf.POSITION, dtype=np.float64)
    return [("urdf", urdf), ("motor", motor), ("servo", servo)]


MODELS = dict(_models())


# Where the fault goes: the first joint and actuator (MOTOR's mot1 and POSITION's pos1 are control- and
# force-limited: the clips that used to turn an infinite control into their bound) and the last link (a
# force on a welded base is absorbed by the weld, NaN or not: nothing to flag there).


def _inputs(model, bad_value):
    """{name: (clean, faulty)} Warp arrays (N, ...) of the step's inputs; the faulty one has bad_value in
    environment BAD."""
    rng = np.random.default_rng(0)
    shapes = {"joint_force_references": (model.dofs(),), "link_forces": (model.number_of_links(), 6)}
    if model.number_of_actuators():
        shapes["ctrl"] = (model.number_of_actuators(),)
    out = {}
    for name, shape in shapes.items():
        clean = rng.uniform(-0.5, 0.5, (N, *shape))
        faulty = clean.copy()
        faulty[(BAD, -1 if name == "link_forces" else 0) + (0,) * (len(shape) - 1)] = bad_value  # see above
        out[name] = (wp.array(clean, dtype=wp.float64), wp.array(faulty, dtype=wp.float64))
    return out


@pytest.mark.parametrize("bad_value", [np.nan, np.inf, -np.inf], ids=["nan", "inf", "-inf"])
@pytest.mark.parametrize("repr", [wd.VelRepr.Mixed, wd.VelRepr.Body, wd.VelRepr.Inertial], ids=lambda r: r.name)
@pytest.mark.parametrize("label", list(MODELS))
def test_a_non_finite_warp_input_flags_its_environment_in_a_step(label, repr, bad_value):
    """A NaN or infinite joint force reference, link force or control (Warp arrays are not read back on the
    host) flags its environment; an infinite reference used to be clamped to the torque-speed bound or the
    control range and applied silently."""
    model = MODELS[label]
    data = wd.data.random_model_data(model, num_envs=N, key=1, velocity_representation=repr)
    for name, (clean, faulty) in _inputs(model, bad_value).items():
        reference = wd.model.step(model, data, **{name: clean})
        _flagged_and_others_intact(wd.model.step(model, data, **{name: faulty}), reference, data)


def test_the_torque_speed_clip_does_not_hide_a_nan_beyond_omega_max():
    """Beyond omega_max the torque-speed bound is 0 and clips every finite reference to 0; a NaN still flags."""
    model = MODELS["urdf"]
    data = wd.data.random_model_data(model, num_envs=N, key=2, joint_vel_bounds=(150.0, 160.0))
    clean, faulty = _inputs(model, np.nan)["joint_force_references"]
    _flagged_and_others_intact(wd.model.step(model, data, joint_force_references=faulty), wd.model.step(model, data, joint_force_references=clean), data)


@pytest.mark.parametrize("use_graph", [True, False], ids=["graph", "eager"])
@pytest.mark.parametrize("label", ["urdf", "motor"])
def test_a_non_finite_warp_control_flags_its_environment_in_a_rollout(label, use_graph):
    """Per-step controls (T, N, ...) with a NaN at step t = 2 in environment BAD: the rollout records that
    environment valid up to t = 2, flagged from t = 3 on, its state frozen at the state 2; the other
    environments' records equal the clean rollout's bitwise."""
    model, T, t_bad = MODELS[label], 5, 2
    data = wd.data.random_model_data(model, num_envs=N, key=3)
    rng = np.random.default_rng(4)
    shapes = {"joint_force_references": (model.dofs(),), "link_forces": (model.number_of_links(), 6)}
    if model.number_of_actuators():
        shapes["ctrl"] = (model.number_of_actuators(),)
    record = ("joint_positions", "base_position", "valid")
    for name, shape in shapes.items():
        clean = rng.uniform(-0.5, 0.5, (T, N, *shape))
        faulty = clean.copy()
        faulty[(t_bad, BAD, -1 if name == "link_forces" else 0) + (0,) * (len(shape) - 1)] = np.nan  # where: as in _inputs
        runs = [
            wd.simulation.rollout(model, data, steps=T, record=record, use_graph=use_graph, **{name: wp.array(c, dtype=wp.float64)})[1]
            for c in (clean, faulty)
        ]
        ref, got = ({k: v.numpy() for k, v in r.items()} for r in runs)
        assert got["valid"][:, BAD].tolist() == [1] * (t_bad + 1) + [0] * (T - t_bad), name
        for k in ("joint_positions", "base_position"):
            np.testing.assert_array_equal(np.delete(got[k], BAD, axis=1), np.delete(ref[k], BAD, axis=1), err_msg=f"{name}: {k}")
            np.testing.assert_array_equal(got[k][: t_bad + 1, BAD], ref[k][: t_bad + 1, BAD], err_msg=f"{name}: {k}")
            assert np.all(got[k][t_bad + 1 :, BAD] == got[k][t_bad, BAD]), f"{name}: {k} moved after the flag"


@pytest.mark.parametrize("bad_value", [np.nan, np.inf])
def test_numpy_inputs_are_checked_on_the_host(bad_value):
    model = MODELS["motor"]
    data = wd.data.Data.build(model, num_envs=N)
    for name, shape in (("joint_force_references", (N, model.dofs())), ("ctrl", (N, model.number_of_actuators())), ("link_forces", (N, model.number_of_links(), 6))):
        value = np.zeros(shape)
        value[(BAD,) + (0,) * (len(shape) - 1)] = bad_value
        with pytest.raises(ValueError, match=rf"{name} has non-finite values, first at index \({BAD}, 0"):
            wd.model.step(model, data, **{name: value})
        with pytest.raises(ValueError, match=rf"{name} has non-finite values, first at index \(0, {BAD}, 0"):
            wd.simulation.rollout(model, data, steps=2, **{name: np.broadcast_to(value, (2, *shape))})


# ------------------------------------------------------------------------------------------- arguments


@pytest.mark.parametrize("make", ["build", "zero", "random"])
def test_num_envs_that_is_not_a_count_is_named(chain, make):
    f = {"build": wd.data.Data.build, "zero": wd.data.Data.zero, "random": wd.data.random_model_data}[make]
    with pytest.raises(ValueError, match=r"num_envs must be a positive integer or None, got 2.5"):
        f(chain, num_envs=2.5)


@pytest.mark.parametrize(
    "envs, error, message",
    [
        ([7], ValueError, r"envs holds environment 7, but there are 3 \(indices 0 to 2\)"),
        ([-4], ValueError, r"envs holds environment -4, but there are 3"),
        ([True, False], ValueError, r"envs as a boolean mask must have shape \(3,\), one entry per environment, got shape \(2,\)"),
        ([1.5], TypeError, r"envs must be environment indices \(integers\) or a boolean mask of length 3, got \[1.5\]"),
    ],
)
def test_envs_out_of_range_are_named(chain, envs, error, message):
    data = wd.data.Data.build(chain, num_envs=N)
    with pytest.raises(error, match=message):
        data.reset(chain, envs)
    with pytest.raises(error, match=message):
        data.replace(chain, joint_positions=np.ones(3), envs=envs)


def test_envs_as_indices_negative_indices_and_masks_select_the_same(chain):
    data = wd.data.Data.build(chain, num_envs=N, joint_positions=np.ones(3))
    for envs in ([2], -1, np.array([False, False, True])):
        out = data.reset(chain, envs).joint_positions.numpy()
        np.testing.assert_array_equal(out, [[1, 1, 1], [1, 1, 1], [0, 0, 0]])
    np.testing.assert_array_equal(data.reset(chain, []).joint_positions.numpy(), np.ones((N, 3)))
