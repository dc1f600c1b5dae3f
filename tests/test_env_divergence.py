"""The environments' divergence bound (`divergence_speed` in LeggedEnvConfig, PickCubeConfig and CubeReorientConfig,
model.divergence_speed; vector_env.DIVERGENCE_SPEED by default), on the tests' device: a joint pushed past it flags its
environment alone (info["invalid"]), which is reset; with the bound off (inf, changed in the config in place) the same
push is not flagged; a bound set on env.model directly stays until the config's changes; the user's model keeps its
own bound; bad values are refused naming the field."""

import math
import pathlib
import subprocess
import sys

import numpy as np
import pytest
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.envs.manipulation import PickCubeConfig
from warpdyn.envs.reorient import CubeReorientConfig
from warpdyn.envs.vector_env import DIVERGENCE_SPEED

N = 3
ROOT = pathlib.Path(__file__).resolve().parents[1]


def _legged(**cfg):
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf())
    model = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    return envs.LeggedEnv(model, num_envs=N, cfg=envs.LeggedEnvConfig(**cfg), seed=0), model


def _pick(**cfg):
    return envs.PickCubeEnv(N, PickCubeConfig(**cfg), seed=1), None


def _reorient(**cfg):
    return envs.CubeReorientEnv(N, CubeReorientConfig(reset_bank=32, **cfg), dtype=np.float64, seed=1), None


BUILDERS = {"LeggedEnvConfig": _legged, "PickCubeConfig": _pick, "CubeReorientConfig": _reorient}


def _push_and_step(env, speed: float):
    """Set the last joint's velocity of environment 0 to `speed` [rad/s or m/s], step with zero actions; info["invalid"]."""
    u = wp.to_torch(env.stepper.data.joint_velocities_state)
    u[0, -1] = speed
    return env.step(torch.zeros(env.action_space.shape, device=env.device))[-1]["invalid"]


@pytest.mark.parametrize("config", sorted(BUILDERS))
def test_a_joint_past_the_bound_flags_its_environment_alone(config):
    env, model = BUILDERS[config]()
    assert env.cfg.divergence_speed == env.model.divergence_speed == DIVERGENCE_SPEED == 100.0
    if model is not None:
        assert model.divergence_speed == math.inf  # the user's model keeps its own
    env.reset(seed=0)
    invalid = _push_and_step(env, 1.5 * DIVERGENCE_SPEED)
    assert invalid.tolist() == [True] + [False] * (N - 1)
    velocities = wp.to_torch(env.stepper.data.joint_velocities_state)
    assert velocities[0].abs().max() < DIVERGENCE_SPEED  # reset
    env.reset(seed=0)
    assert not _push_and_step(env, 0.5 * DIVERGENCE_SPEED).any()  # below the bound
    env.cfg.divergence_speed = math.inf  # changed in place: reaches the model at the next step
    env.reset(seed=0)
    assert not _push_and_step(env, 1.5 * DIVERGENCE_SPEED).any()
    assert env.model.divergence_speed == math.inf
    env.model.divergence_speed = 10.0 * DIVERGENCE_SPEED  # set on the model directly: stays until the config's changes
    env.reset(seed=0)
    assert not _push_and_step(env, 5.0 * DIVERGENCE_SPEED).any() and _push_and_step(env, 15.0 * DIVERGENCE_SPEED)[0]
    assert env.model.divergence_speed == 10.0 * DIVERGENCE_SPEED


@pytest.mark.parametrize("config", sorted(BUILDERS))
@pytest.mark.parametrize("bad", [0.0, -1.0, float("nan"), "fast", True])
def test_bad_bounds_are_refused_naming_the_field(config, bad):
    config_type = {"LeggedEnvConfig": envs.LeggedEnvConfig, "PickCubeConfig": PickCubeConfig, "CubeReorientConfig": CubeReorientConfig}[config]
    with pytest.raises(ValueError, match=rf"{config}\.divergence_speed must be a positive number \[m/s or rad/s\] or inf"):
        config_type(divergence_speed=bad).validate()


def test_a_bad_bound_set_in_place_is_refused_at_the_next_step():
    env, _ = _legged()
    env.reset(seed=0)
    env.cfg.divergence_speed = float("nan")
    with pytest.raises(ValueError, match=r"LeggedEnvConfig\.divergence_speed"):
        env.step(torch.zeros(env.action_space.shape, device=env.device))


def test_the_speed_bound_benchmark_finds_the_smallest_bound_that_flags_none():
    """benchmarks/env_speed_bounds.py (its own process: benchmarks/ is not on the tests' path) on two PickCubeEnv
    environments for 0.1 s: a bound of 1 mm/s flags the moving arm, 1000 none, and the table says so."""
    script = ROOT / "benchmarks" / "env_speed_bounds.py"
    args = [sys.executable, str(script), "--device", str(wp.get_device()), "--envs", "pick", "--bounds", "0.001,1000", "--num-envs", "2", "--seconds", "0.1"]
    stdout = subprocess.run(args, cwd=ROOT, capture_output=True, text=True, timeout=600, check=True).stdout
    row = next(line for line in stdout.splitlines() if line.startswith("| pick |"))
    cells = [c.strip() for c in row.strip("|").split("|")]
    assert cells[1] == "5" and int(cells[2]) > 0 and cells[3] == "0" and cells[4] == "1000", stdout  # 5 policy steps of 20 ms


def test_the_speed_bound_benchmark_runs_a_trained_policy(tmp_path):
    """env_speed_bounds.py --policy: the deterministic actions of a checkpoint (examples/rl_manipulation.py's, one
    iteration: a Beta policy near its mode, far from random actions' mean absolute value of 0.5) step the environment,
    its flags counted the same way; --policy with two environments, a missing file and another environment's
    checkpoint are refused, each naming what is wrong."""
    subprocess.run([sys.executable, str(ROOT / "examples" / "rl_manipulation.py"), "--device", str(wp.get_device()), "--num-envs", "2",
                    "--iterations", "1", "--steps-per-env", "2", "--out", str(tmp_path)], cwd=ROOT, capture_output=True, timeout=600, check=True)  # fmt: skip
    script = ROOT / "benchmarks" / "env_speed_bounds.py"
    args = [sys.executable, str(script), "--device", str(wp.get_device()), "--bounds", "0.001,1000", "--num-envs", "2", "--seconds", "0.1"]

    def row(*flags):
        stdout = subprocess.run([*args, *flags], cwd=ROOT, capture_output=True, text=True, timeout=600, check=True).stdout
        return stdout, [c.strip() for c in next(line for line in stdout.splitlines() if line.startswith("| pick |")).strip("|").split("|")]

    stdout, policy = row("--envs", "pick", "--policy", str(tmp_path / "policy.pt"))
    _, random = row("--envs", "pick")
    assert f"the deterministic actions of {tmp_path / 'policy.pt'}" in stdout
    assert policy[1] == "5" and int(policy[2]) > 0 and policy[3] == "0" and policy[4] == "1000", stdout
    assert abs(float(random[5]) - 0.5) < 0.1 and abs(float(policy[5]) - 0.5) > 0.2, (policy, random)
    for flags, message in [(["--envs", "pick,go1", "--policy", str(tmp_path / "policy.pt")], "--policy needs one environment in --envs (got 2)"),
                           (["--envs", "pick", "--policy", str(tmp_path / "none.pt")], "none.pt: no such file"),
                           (["--envs", "reorient", "--policy", str(tmp_path / "policy.pt")], "not a policy of this environment (size mismatch")]:  # fmt: skip
        refused = subprocess.run([*args, *flags], cwd=ROOT, capture_output=True, text=True, timeout=600)
        assert refused.returncode != 0 and message in refused.stderr, refused.stderr
