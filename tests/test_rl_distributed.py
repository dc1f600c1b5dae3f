"""examples/rl_locomotion.py data parallel (issue 14) on the CPU: `torchrun --standalone --nproc_per_node 2` with
the gloo backend: K GPUs' code path with NCCL but for the backend, the devices and GraphedPPO's CUDA graphs (eager
on the CPU).

- Two ranks x 8 environments x 2 iterations: the run exits 0; only rank 0 prints (one line per iteration);
  the env-steps printed are those of both ranks (all-reduced: 2 x 8 x 24 per iteration, 768 in all); the
  ranks end with identical actor and critic parameters and normaliser statistics (the example compares every
  rank's with rank 0's after training and fails otherwise: without the initial broadcast (each rank seeds
  torch with seed + rank) the parameters differ by ~0.3, without the PPO's gradient averaging by ~0.01;
  with gloo and two ranks the sums are exact, so the difference printed must be 0); rank 0 alone writes
  policy.pt in OnPolicyRunner.save's format, which --replay then reads; --evaluate runs on rank 0 inside the
  process group (one evaluation line).
- One process (plain python) still trains, counts 8 x 24 env-steps per iteration and stops at
  --target-return.
- examples/rl_manipulation.py under torchrun: two ranks train one policy, rank 0 alone prints, evaluates and saves;
  a two-rank run of 0 iterations resumes from that checkpoint and saves it back unchanged (every rank loads it, rank
  0's broadcast), and one of 1 iteration numbers it on. examples/rl_reorient.py: two ranks train one policy.
About 80 s warm on 2 cores (plus Warp's compilation of the ergoCub legs the first time, ~15 s).
"""

import os
import pathlib
import re
import subprocess
import sys

import pytest
import torch
import warp as wp

ROOT = pathlib.Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "rl_locomotion.py"
PICK = ROOT / "examples" / "rl_manipulation.py"
N, ITERATIONS, STEPS = 8, 2, 24  # STEPS: train_config's num_steps_per_env


def _run(args: list, timeout: float = 300) -> str:
    env = {k: v for k, v in os.environ.items() if k not in ("WORLD_SIZE", "RANK", "LOCAL_RANK", "MASTER_ADDR", "MASTER_PORT")}
    env["OMP_NUM_THREADS"] = "1"
    proc = subprocess.run([sys.executable, *args], cwd=ROOT, env=env, capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, f"exit {proc.returncode}\n{proc.stdout[-4000:]}\n{proc.stderr[-4000:]}"
    return proc.stdout


def _iterations(stdout: str) -> list[tuple[int, int]]:
    """[(iteration, env-steps so far)] of the printed iteration lines."""
    return [(int(i), int(s)) for i, s in re.findall(r"^iteration\s+(\d+)\s.*?\s(\d+) env-steps\s", stdout, re.M)]


def _total(stdout: str) -> tuple[int, int]:
    match = re.search(r"^total: (\d+) env-steps on (\d+) rank", stdout, re.M)
    assert match, stdout
    return int(match[1]), int(match[2])


CPU_BACKEND = pytest.mark.skipif(not wp.is_cpu_available(), reason="this Warp build has no CPU backend (LLVM): the gloo runs simulate on the CPU")


@CPU_BACKEND
def test_two_ranks_train_one_policy(tmp_path):
    out = tmp_path / "two"
    stdout = _run(["-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", str(EXAMPLE),
                   "--device", "cpu", "--num-envs", str(N), "--iterations", str(ITERATIONS), "--evaluate", "0.3", "--out", str(out)])  # fmt: skip
    assert f"2 ranks x {N} environments on CPU (gloo)" in stdout, stdout
    per_iteration = 2 * N * STEPS
    assert _iterations(stdout) == [(it, per_iteration * (it + 1)) for it in range(ITERATIONS)], stdout  # rank 0 only
    assert _total(stdout) == (per_iteration * ITERATIONS, 2)
    match = re.search(r"^policy identical on 2 ranks \(largest difference (\S+)\)", stdout, re.M)
    assert match and float(match[1]) == 0.0, stdout
    evaluations = re.findall(r"^evaluation: commanded 0.3 m/s straight ahead, 256 environments, 5 s: forward speed (\S+) m/s", stdout, re.M)
    assert len(evaluations) == 1, stdout  # rank 0 alone, inside the process group (no second one started)
    assert sorted(p.name for p in out.iterdir()) == ["policy.pt", "rewards.png"]
    checkpoint = torch.load(out / "policy.pt", weights_only=False)
    assert checkpoint["iter"] == ITERATIONS - 1
    assert {"actor_state_dict", "critic_state_dict", "optimizer_state_dict"} <= set(checkpoint)
    stdout = _run([str(EXAMPLE), "--device", "cpu", "--replay", str(out / "policy.pt"), "--out", str(out)])
    assert (out / "policy.rrd").stat().st_size > 0, stdout


@CPU_BACKEND
def test_one_process_still_trains(tmp_path):
    stdout = _run([str(EXAMPLE), "--device", "cpu", "--num-envs", str(N), "--iterations", "3",
                   "--target-return=-1e9", "--out", str(tmp_path)])  # fmt: skip
    assert f"stand: {N} environments on CPU" in stdout, stdout
    lines = _iterations(stdout)
    assert lines == [(it, N * STEPS * (it + 1)) for it in range(len(lines))], stdout
    assert _total(stdout) == (N * STEPS * len(lines), 1)
    # the first iteration in which an episode ends stops the run (its mean return is then > -1e9)
    reached = re.search(r"^reached mean return -1e\+09 at iteration (\d+)", stdout, re.M)
    assert (int(reached[1]) == len(lines) - 1) if reached else (len(lines) == 3 and "not reached" in stdout), stdout
    assert (tmp_path / "policy.pt").is_file()


@CPU_BACKEND
def test_two_ranks_train_and_resume_the_pick_task(tmp_path):
    args = ["-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", str(PICK), "--device", "cpu", "--num-envs", "4",
            "--steps-per-env", "4", "--mini-batches", "2"]  # fmt: skip
    stdout = _run([*args, "--iterations", "1", "--evaluate", "--evaluate-envs", "4", "--out", str(tmp_path / "a")])
    assert "pick cube: 2 ranks x 4 environments on CPU (gloo)" in stdout, stdout
    assert _iterations(stdout) == [(0, 2 * 4 * 4)], stdout  # both ranks' steps, printed once
    match = re.search(r"^policy identical on 2 ranks \(largest difference (\S+)\)", stdout, re.M)
    assert match and float(match[1]) == 0.0, stdout
    assert len(re.findall(r"^evaluation: 4 fresh environments, one episode: success", stdout, re.M)) == 1, stdout
    assert torch.load(tmp_path / "a" / "policy.pt", weights_only=False)["iter"] == 0
    saved = torch.load(tmp_path / "a" / "policy.pt", weights_only=False)
    stdout = _run([*args, "--iterations", "0", "--resume", str(tmp_path / "a" / "policy.pt"), "--out", str(tmp_path / "b")])
    match = re.search(r"^policy identical on 2 ranks \(largest difference (\S+)\)", stdout, re.M)
    assert match and float(match[1]) == 0.0, stdout
    resumed = torch.load(tmp_path / "b" / "policy.pt", weights_only=False)
    assert resumed["iter"] == 0  # no iteration: the checkpoint's number
    for name in ("actor_state_dict", "critic_state_dict"):  # loaded as saved (rank 1 too: identical to rank 0's)
        assert all(torch.equal(resumed[name][k], saved[name][k]) for k in saved[name]), name
    stdout = _run([*args, "--iterations", "1", "--resume", str(tmp_path / "a" / "policy.pt"), "--out", str(tmp_path / "c")])
    assert _iterations(stdout) == [(1, 2 * 4 * 4)], stdout  # numbered on


@CPU_BACKEND
def test_two_ranks_train_the_reorient_task(tmp_path):
    script = ROOT / "examples" / "rl_reorient.py"
    stdout = _run(["-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2", str(script), "--device", "cpu", "--num-envs", "4",
                   "--iterations", "1", "--steps-per-env", "4", "--mini-batches", "1", "--out", str(tmp_path)])  # fmt: skip
    assert "reorient cube: 2 ranks x 4 environments on CPU (gloo)" in stdout, stdout
    assert _iterations(stdout) == [(0, 2 * 4 * 4)], stdout
    match = re.search(r"^policy identical on 2 ranks \(largest difference (\S+)\)", stdout, re.M)
    assert match and float(match[1]) == 0.0, stdout
    assert torch.load(tmp_path / "policy.pt", weights_only=False)["iter"] == 0
