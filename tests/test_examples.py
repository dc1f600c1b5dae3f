"""The examples run end to end on small settings (float64, the tests' device). The differentiable-simulation ones'
losses fall by the factors below only if the tape's gradients (with respect to per-step torques, model parameters and
initial states) point the right way, and each writes its plot.

- examples/trajectory_optimisation.py: 60 steps of 5 ms, 30 Adam iterations. Measured: the loss falls to 2 %
  of its start (1.69 -> 0.034), the final pose error to 9 % (1.30 -> 0.12 rad); the bounds (5 %, 15 %) leave
  a factor 2 of margin. A gradient of the wrong sign or of the wrong entries makes the loss grow or stall.
- examples/system_identification.py: 0.5 s of measurements, windows of 10 steps, 60 iterations (the short
  trajectory leaves the hip masses unidentifiable: the example leaves them out, which is checked). Measured:
  the loss falls to 5e-4 of its start, the largest friction error from 99 % to 3.5 %, the fitted masses' rms
  error from 15 % to 5 %; bounds 1e-2, 10 %, half. Then with noisy measurements (1 s, windows of 20
  steps), which also fits the windows' initial states (gradients with respect to the initial data).
- examples/mpc.py: iLQR model-predictive control of the shipped Panda on full Jacobians (wd.autodiff), 40 control
  steps of 10 ms, a horizon of 20 steps, the plant's masses 10 % off. Measured: the flange's tracking error falls
  from 120 mm to 1.5 mm at most over the last 10 steps (bound 3 %, 3.6 mm); the first step's iterations lower the
  plan's cost from 3024 to 787 (bound: below half). A flange Jacobian of the wrong sign leaves 145 mm, A = I 27 mm.
- examples/codesign.py: the ergoCub's right leg reaches for a point beyond its stretched sole, 20 iterations of each
  run, 60 steps. Measured: the torques alone end 80.5 mm from the target, co-design (the thigh and shank lengthened
  through wd.model.with_joint_origins) 37.5 mm with both bones 1.10x; bounds: co-design below 60 % of the torques'
  distance, its bones longer than 1.03x (without a gradient reaching the scales they stay at 1).
- examples/body_contacts.py: boxes stacked on a table, a ball and a capsule, 4 environments for 1 s under each of JaxSim's
  contact laws: the first rests where MuJoCo's does (0.16 to 1.02 mm), the others at the same heights.
About 18 s warm for the six runs (plus Warp's compilation the first time).
"""

import importlib.util
import pathlib
import sys

import numpy as np
import pytest
import warpdyn as wd
from robots import TEST_DEVICE

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"
sys.path.insert(0, str(EXAMPLES))  # the examples import examples/common.py, as when they run as scripts


def _example(name: str):
    """The example module, imported from its file (examples/ is not a package)."""
    spec = importlib.util.spec_from_file_location(f"warpdyn_example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _plot_argument(tmp_path, name: str) -> tuple[list[str], pathlib.Path]:
    """The example's --plot argument (matplotlib and icub-models are in the test extra: no test skips)."""
    path = tmp_path / "plots" / f"{name}.png"
    return ["--plot", str(path)], path


def _check_plot(path) -> None:
    assert path.is_file() and path.stat().st_size > 10_000, path
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_trajectory_optimisation_reaches_the_target(tmp_path):
    """Adam on per-step torques through a taped rollout of the iCub's fixed-base left leg: the loss falls
    below 5 % and the final pose error below 15 % of their starting values in 30 iterations (module docstring)."""
    example = _example("trajectory_optimisation")
    plot, path = _plot_argument(tmp_path, "trajectory_optimisation")
    settings = ["--steps", "60", "--time-step", "0.005", "--hold-steps", "5", "--iterations", "30"]
    result = example.main([*settings, "--device", TEST_DEVICE, "--dtype", "float64", "--print-every", "30", *plot])
    loss, pose_error = result["loss"], result["pose_error"]
    assert len(loss) == 31 and np.all(np.isfinite(loss))
    assert loss[-1] < 0.05 * loss[0], loss
    assert pose_error[-1] < 0.15 * pose_error[0], pose_error
    assert result["after"].shape == (61, 6) and result["torques"].shape == (60, 6)
    _check_plot(path)


def test_system_identification_recovers_friction_and_masses(tmp_path):
    """Adam on log link masses and log viscous frictions through a taped batched rollout (multiple shooting) of
    the iCub's fixed-base legs: the loss falls below 1e-2 of its start, the largest friction error below 10 %
    of its start, the fitted masses' rms error below half of its start (module docstring); the hip_1 masses
    (CoM on the axis that moves them) are found unidentifiable and left out."""
    example = _example("system_identification")
    plot, path = _plot_argument(tmp_path, "system_identification")
    settings = ["--duration", "0.5", "--horizon", "10", "--iterations", "60"]
    result = example.main([*settings, "--device", TEST_DEVICE, "--dtype", "float64", "--print-every", "60", *plot])
    loss, error = result["loss"], np.abs(result["error"])
    fitted, is_mass = result["fitted"], result["is_mass"]
    assert np.all(np.isfinite(loss))
    assert loss[-1] < 1e-2 * loss[0], loss
    friction = error[:, ~is_mass]
    assert fitted[~is_mass].all() and friction[-1].max() < 0.1 * friction[0].max(), friction[[0, -1]]
    masses = error[:, fitted & is_mass]
    assert masses.shape[1] >= 4
    rms = np.sqrt(np.mean(masses**2, axis=1))
    assert rms[-1] < 0.5 * rms[0], rms[[0, -1]]
    not_fitted = [name for name, f in zip(result["names"], fitted) if not f]
    assert "mass r_hip_1 [kg]" in not_fitted and "mass l_hip_1 [kg]" in not_fitted
    np.testing.assert_array_equal(result["estimate"][~fitted], result["initial"][~fitted])
    _check_plot(path)


def test_system_identification_with_noise_fits_initial_states():
    """With noisy measurements (1 mrad, 1e-2 rad/s) the windows' initial states are decision variables too
    (their gradients come from the tape through Data built from Warp arrays). 1 s, windows of 20 steps, 60
    iterations. Measured: the loss falls to 0.6 % of its start (401 -> 2.3, the noise floor is ~2), the largest
    friction error from 85 % to 6 %, the fitted masses' rms error from 17 % to 3 %; bounds 2 %, a quarter, half."""
    example = _example("system_identification")
    settings = ["--duration", "1.0", "--horizon", "20", "--iterations", "60", "--noise", "1"]
    result = example.main([*settings, "--device", TEST_DEVICE, "--dtype", "float64", "--print-every", "60", "--plot", ""])
    loss, error = result["loss"], np.abs(result["error"])
    assert loss[-1] < 0.02 * loss[0], loss
    friction = error[:, ~result["is_mass"]]
    assert friction[-1].max() < 0.25 * friction[0].max(), friction[[0, -1]]
    masses = error[:, result["fitted"] & result["is_mass"]]
    rms = np.sqrt(np.mean(masses**2, axis=1))
    assert rms[-1] < 0.5 * rms[0], rms[[0, -1]]


def test_mpc_tracks_the_moving_target(tmp_path):
    """iLQR on the Panda, its dynamics linearised along the plan by one wd.autodiff.transition_matrices call and the
    flange's Jacobians by one wd.autodiff.jacobian call per iteration, tracks the target round its circle in closed
    loop on a plant with 10 % mass errors: the error over the last 10 of 40 control steps is below 3 % of the 120 mm
    it starts at, and the first step's iterations halve the plan's cost at least (module docstring)."""
    example = _example("mpc")
    plot, path = _plot_argument(tmp_path, "mpc")
    result = example.main(["--steps", "40", "--horizon", "20", "--transient", "0.3", "--device", TEST_DEVICE, "--print-every", "40", *plot])
    error = result["error"]
    assert error.shape == (40,) and np.all(np.isfinite(error))
    assert abs(error[0] - 0.12) < 1e-9  # the arm starts at rest at the circle's centre
    assert error[-10:].max() < 0.03 * error[0], error
    assert result["cost"][0] < 0.5 * result["start_cost"][0] and result["iterations"][0] >= 2, result["cost"][:3]
    assert result["torque"].shape == (40, 7) and np.all(np.abs(result["torque"]) <= np.array(wd.assets.FRANKA_PANDA_TORQUE_LIMITS))
    _check_plot(path)


def test_codesign_lengthens_the_bones_to_reach():
    """Co-design of the torques and the thigh's and shank's lengths (joint origins scaled, gradients through
    wd.model.with_joint_origins) ends nearer the out-of-reach target than the torques alone, with longer bones
    (module docstring)."""
    example = _example("codesign")
    runs = example.main(["--iterations", "20", "--steps", "60", "--device", TEST_DEVICE, "--print-every", "20", "--plot", ""])
    torques, codesign = runs["torques"], runs["co-design"]
    assert np.all(torques["scales"] == 1.0)
    assert codesign["distance"][-1] < 0.6 * torques["distance"][-1], (codesign["distance"][-1], torques["distance"][-1])
    assert np.all(codesign["scales"][-1] > 1.03), codesign["scales"][-1]
    assert codesign["loss"][-1] < codesign["loss"][0]


@pytest.mark.parametrize("contact_model", ["soft", "relaxed", "rigid"])
def test_body_contacts_rest_on_the_table_as_in_mujoco(contact_model):
    """examples/body_contacts.py, 4 environments for 1 s in float64, under each of JaxSim's laws (--contact-model):
    every environment healthy; in the first (the file's placement) each object rests within 1.5 mm of MuJoCo's
    (measured 0.16 mm with the soft law, 1.02 with the relaxed-rigid, 0.33 with the rigid); in the others (objects
    moved by up to 1 cm and turned) at the same heights within 1 mm."""
    example = _example("body_contacts")
    result = example.run(4, np.float64, TEST_DEVICE, seconds=1.0, contact_model=contact_model)
    assert result["healthy"].all()
    theirs = example.mujoco_rest(1.0)
    for name, positions in result["positions"].items():
        np.testing.assert_allclose(positions[0], theirs[name], atol=1.5e-3, err_msg=name)
        np.testing.assert_allclose(positions[1:, 2], positions[0, 2], atol=1e-3, err_msg=name)
        assert np.abs(positions[1:, :2] - positions[0, :2]).max() > 1e-3  # the others started elsewhere
