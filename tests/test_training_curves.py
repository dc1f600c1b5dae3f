"""benchmarks/training_curves.py reads the examples' iteration lines (a shipped log's counts, rates and logged values; a
run in parts); benchmarks/checkpoint_summary.py reads their checkpoints."""

import pathlib
import runpy
import subprocess
import sys

import pytest
import warp as wp

ROOT = pathlib.Path(__file__).resolve().parents[1]
_script = runpy.run_path(str(ROOT / "benchmarks" / "training_curves.py"))  # (not imported: examples/ has a common.py too)
read, first_exceeding = _script["read"], _script["first_exceeding"]


def test_a_logs_iterations_rates_and_logged_values():
    log = ROOT / "benchmarks" / "results" / "rl_pick_h200_2ms_graphed_30s.log"
    lines = [line for line in log.read_text().splitlines() if line.startswith("iteration ")]
    seconds, reached, rates, end = read(log, "reached")
    assert len(rates) == len(lines) == len(seconds) == 231
    assert seconds[0] < seconds[-1] == end == pytest.approx(30.0, abs=0.5)
    assert sorted(rates)[len(rates) // 2] == pytest.approx(353.6)
    assert max(reached) == pytest.approx(0.725) and reached[-1] == pytest.approx(0.422)
    seconds, returns, _, end = read(log, "return")
    assert 0 < len(returns) < 231 and seconds[-1] < end  # iterations that completed no episode print nan and are skipped
    rough = read(ROOT / "benchmarks" / "results" / "rl_anymal_c_rough_h200.log", "level")  # "terrain level 2.38 (...)"
    assert len(rough[0]) == len(rough[2]) and rough[1][-1] == pytest.approx(2.38)
    with pytest.raises(SystemExit, match="not 'speed'"):
        read(log, "speed")


def test_when_a_quantity_first_exceeded_a_value():
    logs = ROOT / "benchmarks" / "results"
    seconds, success, _, _ = read(logs / "rl_pick_h200_2ms_graphed_3min_seed1.log", "success")
    assert first_exceeding(seconds, success, 0.9) == pytest.approx(121.7)  # the line printed "... 121.7 s ... success 0.9xx"
    earlier = [v for t, v in zip(seconds, success) if t < 121.7]
    assert max(earlier) <= 0.9 < success[seconds.index(121.7)]
    seconds, success, _, _ = read(logs / "rl_pick_h200_2ms_graphed_3min_seed0.log", "success")
    assert max(success) < 0.9 and first_exceeding(seconds, success, 0.9) is None
    assert first_exceeding([1.0, 2.0], [0.5, 0.5], 0.5) is None  # strictly above


def test_a_run_in_parts_counts_its_wall_time_on():
    logs = ROOT / "benchmarks" / "results"
    names = ["rl_reorient_h200_8min_graphed_part1.log", "rl_reorient_h200x2_8min_graphed_part2.log"]
    parts = [read(logs / name, "orientation_error") for name in names]
    seconds, values, rates, end = read(logs / "+".join(names), "orientation_error")
    assert parts[0][3] == pytest.approx(512.1) and parts[1][3] == pytest.approx(510.6)  # each part's last line
    assert end == pytest.approx(512.1 + 510.6)
    assert seconds == parts[0][0] + [512.1 + t for t in parts[1][0]]
    assert values == parts[0][1] + parts[1][1] and rates == parts[0][2] + parts[1][2]
    assert len(rates) == 237 + 231 and values[-1] == pytest.approx(1.436)


def test_a_checkpoints_summary_names_its_trainers_state(tmp_path):
    """benchmarks/checkpoint_summary.py (its own process) on a one-iteration Gaussian checkpoint of
    examples/rl_manipulation.py: its iteration, distribution, layers, schedule, learning rate and the Gaussian's
    deviations (rsl-rl starts them at 1); a missing file is refused naming it."""
    subprocess.run([sys.executable, str(ROOT / "examples" / "rl_manipulation.py"), "--device", str(wp.get_device()), "--num-envs", "2", "--iterations", "1",
                    "--steps-per-env", "2", "--action-distribution", "gaussian", "--out", str(tmp_path)], cwd=ROOT, capture_output=True, timeout=600, check=True)  # fmt: skip
    script = [sys.executable, str(ROOT / "benchmarks" / "checkpoint_summary.py")]
    out = subprocess.run([*script, str(tmp_path / "policy.pt")], capture_output=True, text=True, timeout=600, check=True).stdout
    assert "iteration 0, gaussian policy, layers [256, 128, 64], schedule adaptive, learning rate" in out
    low, high = (float(x) for x in out.split("Gaussian standard deviations ")[1].split(" (")[0].split(" to "))
    assert 0.8 < low <= high < 1.2 and "over 8 actions" in out
    refused = subprocess.run([*script, str(tmp_path / "none.pt")], capture_output=True, text=True, timeout=600)
    assert refused.returncode == 2 and "no such checkpoint:" in refused.stderr
