"""benchmarks/training_curves.py reads the examples' iteration lines: a shipped log's counts, rates and logged values."""

import pathlib
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))
import training_curves  # noqa: E402


def test_a_logs_iterations_rates_and_logged_values():
    log = ROOT / "benchmarks" / "results" / "rl_pick_h200_2ms_graphed_30s.log"
    lines = [line for line in log.read_text().splitlines() if line.startswith("iteration ")]
    seconds, reached, rates = training_curves.read(log, "reached")
    assert len(rates) == len(lines) == len(seconds) == 231
    assert seconds[0] < seconds[-1] == pytest.approx(30.0, abs=0.5)
    assert sorted(rates)[len(rates) // 2] == pytest.approx(353.6)
    assert max(reached) == pytest.approx(0.725) and reached[-1] == pytest.approx(0.422)
    returns = training_curves.read(log, "return")[1]
    assert 0 < len(returns) < 231  # iterations that completed no episode print nan and are skipped
    with pytest.raises(SystemExit, match="not 'speed'"):
        training_curves.read(log, "speed")
