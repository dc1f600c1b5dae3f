"""benchmarks/training_curves.py reads the examples' iteration lines: a shipped log's counts, rates and logged values."""

import importlib.util
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _module():
    spec = importlib.util.spec_from_file_location("training_curves", ROOT / "benchmarks" / "training_curves.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_a_logs_iterations_rates_and_logged_values():
    log = ROOT / "benchmarks" / "results" / "rl_pick_h200_2ms_graphed_30s.log"
    lines = [line for line in log.read_text().splitlines() if line.startswith("iteration ")]
    seconds, reached, rates = _module().read(log, "reached")
    assert len(rates) == len(lines) == len(seconds) == 231
    assert seconds[0] < seconds[-1] == pytest.approx(30.0, abs=0.5)
    assert sorted(rates)[len(rates) // 2] == pytest.approx(353.6)
    assert max(reached) == pytest.approx(0.725) and reached[-1] == pytest.approx(0.422)
    returns = _module().read(log, "return")[1]
    assert 0 < len(returns) < 231  # iterations that completed no episode print nan and are skipped
    with pytest.raises(SystemExit, match="not 'speed'"):
        _module().read(log, "speed")
