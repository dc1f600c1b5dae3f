"""Settings assigned after construction are checked when assigned, and terrain heights written later into
a Warp array (which no host check sees) flag the environments they reach.

Reference: the documented checks of Model's settings (warpdyn/types/model.py `_setting`), ActuationParams
and SoftContactsParams (warpdyn/types/settings.py) and the terrains (warpdyn/types/terrain.py): each bad
value raises a TypeError (not a number) or ValueError (not a valid number) naming the setting and the
value, and leaves the model as it was. For heights written in place, the reference is the same step with
finite heights: the environments whose collidable points stand on a NaN cell are flagged (Data.healthy 0) and
keep their state, the others are bitwise equal.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd

NAN, INF = float("nan"), float("inf")


@pytest.fixture(scope="module")
def model():
    return wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2), dtype=np.float64)


@pytest.mark.parametrize(
    "name, value, error, message",
    [
        ("time_step", 0, ValueError, r"time_step must be positive and finite, got 0.0"),
        ("time_step", -1e-3, ValueError, r"time_step must be positive and finite, got -0.001"),
        ("time_step", NAN, ValueError, r"time_step must be positive and finite, got nan"),
        ("time_step", True, TypeError, r"time_step must be a number, got True"),
        ("time_step", None, TypeError, r"time_step must be a number, got None"),
        ("gravity", NAN, ValueError, r"gravity must be finite, got nan"),
        ("gravity", INF, ValueError, r"gravity must be finite, got inf"),
        ("quaternion_tolerance", 0.0, ValueError, r"quaternion_tolerance must be positive and finite, got 0.0"),
        ("quaternion_tolerance", NAN, ValueError, r"quaternion_tolerance must be positive and finite, got nan"),
        ("quaternion_tolerance", INF, ValueError, r"quaternion_tolerance must be positive and finite, got inf"),
        ("divergence_speed", 0.0, ValueError, r"divergence_speed must be positive \(inf for no bound\), got 0.0"),
        ("divergence_speed", -1e4, ValueError, r"divergence_speed must be positive \(inf for no bound\), got -10000.0"),
        ("divergence_speed", NAN, ValueError, r"divergence_speed must be positive \(inf for no bound\), got nan"),
        ("divergence_speed", True, TypeError, r"divergence_speed must be a number, got True"),
        ("integrator", 7, ValueError, r"integrator must be one of \['IntegratorType.SemiImplicitEuler'.*got 7"),
        ("terrain", "flat", TypeError, r"terrain must be a FlatTerrain or PlaneTerrain or HeightfieldTerrain, got str"),
        ("actuation_params", {"torque_max": 1.0}, TypeError, r"actuation_params must be a ActuationParams, got dict"),
    ],
)
def test_a_bad_setting_is_named_and_leaves_the_model_as_it_was(model, name, value, error, message):
    before, version = getattr(model, name), model.version
    with pytest.raises(error, match=message):
        setattr(model, name, value)
    assert getattr(model, name) is before and model.version == version


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"torque_max": NAN}, ValueError, r"ActuationParams.torque_max must be finite \[N m\], got nan"),
        ({"torque_max": INF}, ValueError, r"ActuationParams.torque_max must be finite \[N m\], got inf"),
        ({"torque_max": -1.0}, ValueError, r"ActuationParams.torque_max must be non-negative \[N m\], got -1.0"),
        ({"torque_max": "x"}, TypeError, r"ActuationParams.torque_max must be a number or an array of numbers, got 'x'"),
        ({"torque_max": None}, TypeError, r"ActuationParams.torque_max must be a number or an array of numbers, got None"),
        ({"torque_max": [1.0, 2.0]}, TypeError, r"ActuationParams.torque_max must be a number \[N m\], got \[1.0, 2.0\]"),
        ({"omega_th": NAN}, ValueError, r"ActuationParams.omega_th must be finite \[rad/s\], got nan"),
        ({"omega_th": 200.0}, ValueError, r"0 < omega_th < omega_max \[rad/s\], got omega_th 200.0, omega_max 100.0"),
        ({"enable_friction": "no"}, TypeError, r"ActuationParams.enable_friction must be True or False, got 'no'"),
    ],
)
def test_actuation_params_name_the_field(kwargs, error, message):
    with pytest.raises(error, match=message):
        wd.model.ActuationParams(**kwargs)


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"K": NAN}, ValueError, r"SoftContactsParams.K must be finite and non-negative \(a number or \(N,\)\), got nan"),
        ({"mu": np.array([0.5, NAN])}, ValueError, r"SoftContactsParams.mu must be finite and non-negative"),
        ({"p": "x"}, TypeError, r"SoftContactsParams.p must be a number or an array of numbers, got 'x'"),
        ({"q": [0.5, 0.5]}, ValueError, r"SoftContactsParams.q must be finite and non-negative \(a number\)"),
    ],
)
def test_soft_contact_params_name_the_field(kwargs, error, message):
    with pytest.raises(error, match=message):
        wd.model.SoftContactsParams(**kwargs)


@pytest.mark.parametrize(
    "kwargs, error, message",
    [
        ({"spacing": (NAN, 0.1)}, ValueError, r"HeightfieldTerrain.spacing must be two finite numbers \[m\], got \(nan, 0.1\)"),
        ({"spacing": (INF, 0.1)}, ValueError, r"HeightfieldTerrain.spacing must be two finite numbers \[m\], got \(inf, 0.1\)"),
        ({"spacing": (0.0, 0.1)}, ValueError, r"HeightfieldTerrain.spacing must be two finite positive numbers"),
        ({"spacing": 0.1}, ValueError, r"HeightfieldTerrain.spacing must be two numbers \(x, y\) \[m\], got 0.1"),
        ({"origin": (0.0, NAN)}, ValueError, r"HeightfieldTerrain.origin must be two finite numbers \[m\], got \(0.0, nan\)"),
        ({"origin": "corner"}, TypeError, r"HeightfieldTerrain.origin must be a number or an array of numbers, got 'corner'"),
        ({"heights": np.array([[0.0, 0.0], [INF, 0.0]])}, ValueError, r"HeightfieldTerrain.heights has non-finite values, first at \(1, 0\): inf"),
        ({"heights": wp.array(np.array([[0.0, NAN], [0.0, 0.0]]), dtype=wp.float64)}, ValueError, r"heights has non-finite values, first at \(0, 1\): nan"),
    ],
)
def test_heightfield_values_are_named(kwargs, error, message):
    args = {"heights": np.zeros((3, 3)), **kwargs}
    with pytest.raises(error, match=message):
        wd.terrain.HeightfieldTerrain(**args)


def _box_on(terrain, positions):
    model = wd.model.Model.build_from_model_description(robots.BOX_URDF, dtype=np.float64)
    model.terrain = terrain
    data = wd.data.Data.build(model, num_envs=len(positions), base_position=np.asarray(positions, dtype=np.float64))
    return model, data


@pytest.mark.parametrize("integrator", [robots.SIE, robots.RK4], ids=["SIE", "RK4"])
def test_nan_heights_written_in_place_flag_the_environments_standing_on_them(integrator):
    """A heightfield's Warp heights assigned NaN after the terrain was made (no host check): the box whose
    corners stand on the NaN cell is flagged and keeps its state (a NaN height used to read as 'no contact':
    wp.max(0, NaN) = 0), the box far away steps as with finite heights."""
    heights = wp.zeros((6, 6), dtype=wp.float64)
    terrain = wd.terrain.HeightfieldTerrain(heights, origin=(-0.5, -0.5), spacing=(0.2, 0.2))
    model, data = _box_on(terrain, [[0.0, 0.0, 0.095], [5.0, 5.0, 0.095]])
    model.integrator = integrator
    reference = wd.model.step(model, data)
    host = np.zeros((6, 6))
    host[2:4, 2:4] = np.nan
    heights.assign(host)
    out = wd.model.step(model, data)
    assert out.healthy.numpy().tolist() == [0, 1]
    np.testing.assert_array_equal(out.base_position.numpy()[0], data.base_position.numpy()[0])
    for name in ("base_position", "base_quaternion", "base_velocity"):
        np.testing.assert_array_equal(getattr(out, name).numpy()[1], getattr(reference, name).numpy()[1], err_msg=name)


def test_a_nan_flat_height_written_in_place_flags_its_environment():
    height = wp.zeros(2, dtype=wp.float64)
    model, data = _box_on(wd.terrain.FlatTerrain(height=height), [[0.0, 0.0, 0.095]] * 2)
    reference = wd.model.step(model, data)
    height.assign(np.array([0.0, NAN]))
    out = wd.model.step(model, data)
    assert out.healthy.numpy().tolist() == [1, 0]
    np.testing.assert_array_equal(out.base_position.numpy()[1], data.base_position.numpy()[1])
    np.testing.assert_array_equal(out.base_position.numpy()[0], reference.base_position.numpy()[0])
