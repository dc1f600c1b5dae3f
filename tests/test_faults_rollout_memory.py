"""A long rollout's captured graph does not grow with its length, `memory_bytes` counts the graph, and a
rollout too large for the machine is a MemoryError naming its size, before anything is allocated.

References:
- Chunked graphs (warpdyn/engine/rollout.py, ping-pong storage): the same rollout run eagerly
  (use_graph=False), launch by launch: records and final states bitwise equal (the same launches on the same
  numbers; the stage copies are exact). GRAPH_CHUNK is made 4 here so that T = 11 has chunks of 4, 4 and 3
  steps, starting on both parities, and callbacks split it further.
- Graph memory: the number of captured graphs and the steps they hold, for T from 10 to 1000 (at most a
  full chunk and a remainder per parity: bounded); `memory_bytes()["graph"]` is GRAPH_BYTES_PER_LAUNCH
  (measured, warpdyn/engine/rollout_memory.py) times the launches the graphs hold, and stays the same
  for every T beyond a chunk.
- MemoryError: a trajectory of 10^9 steps of 4 environments (~0.6 TB) on this machine.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

import mjcf_fixtures as mf
import robots
import warpdyn as wd
from warpdyn.engine import launch, rollout_memory

ALL_RECORDS = (*wd.simulation.STATE_RECORDS, *wd.simulation.STEP_RECORDS)


@pytest.fixture
def small_chunks(monkeypatch):
    monkeypatch.setattr(rollout_memory, "GRAPH_CHUNK", 4)
    return 4


def _box():
    return wd.model.Model.build_from_model_description(robots.BOX_URDF, dtype=np.float64)


def _run(model, data, use_graph, callback_every=None, **controls):
    seen = []

    def callback(t, state):
        seen.append((t, state.joint_positions.numpy().copy() if model.dofs() else state.base_position.numpy().copy()))

    roll = wd.simulation.Rollout(model, steps=11, record=ALL_RECORDS, use_graph=use_graph)
    final, records = roll.run(data, callback=callback if callback_every else None, callback_every=callback_every or 1, **controls)
    out = {name: array.numpy().copy() for name, array in records.items()}
    out["final"] = final.base_position.numpy().copy()
    return out, seen, roll


@pytest.mark.parametrize("callback_every", [None, 3, 5], ids=["no callback", "every 3", "every 5"])
def test_chunked_graphs_equal_the_eager_rollout(small_chunks, callback_every):
    """The box on the ground (contacts: every record is written) with per-step link forces, and MJCF motors
    with per-step shared controls and constant joint references: graph replays equal eager launches."""
    T, N = 11, 3
    rng = np.random.default_rng(0)
    box = _box()
    box_data = wd.data.Data.build(box, num_envs=N, base_position=np.array([0.0, 0.0, 0.098]) + rng.uniform(-0.002, 0.002, (N, 3)))
    forces = rng.uniform(-1.0, 1.0, (T, N, box.number_of_links(), 6))
    motor = wd.model.Model.build_from_model_description(mf.MOTOR, dtype=np.float64)
    motor_data = wd.data.random_model_data(motor, num_envs=N, key=1)
    ctrl = wp.array(rng.uniform(-1.0, 1.0, (T, 1, motor.number_of_actuators())), dtype=wp.float64)
    tau = rng.uniform(-0.1, 0.1, (N, motor.dofs()))
    for model, data, controls in ((box, box_data, {"link_forces": forces}), (motor, motor_data, {"ctrl": ctrl, "joint_force_references": tau})):
        graph, graph_seen, roll = _run(model, data, True, callback_every, **controls)
        eager, eager_seen, _ = _run(model, data, False, callback_every, **controls)
        for name in eager:
            np.testing.assert_array_equal(graph[name], eager[name], err_msg=name)
        assert [t for t, _ in graph_seen] == [t for t, _ in eager_seen]
        for (_, a), (_, b) in zip(graph_seen, eager_seen):
            np.testing.assert_array_equal(a, b)
        lengths = {key[1] for key in roll._config.graphs}
        assert max(lengths) <= small_chunks and all(key[0] == "chunk" for key in roll._config.graphs)
        again, _, _ = _run(model, data, True, callback_every, **controls)  # a second Rollout: same numbers
        np.testing.assert_array_equal(again["joint_positions"], eager["joint_positions"])


def test_graphs_hold_a_bounded_number_of_steps(small_chunks):
    """However long the rollout, its graphs hold at most a chunk and a remainder per parity; memory_bytes'
    graph entry counts a chunk and the remainder (T = 10: 4 + 2 steps, 101: 4 + 1, 1000: 4)."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=2)
    estimates = []
    for T in (10, 101, 1000):
        roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions", "valid"))
        roll.run(data)
        held = sum(key[1] for key in roll._config.graphs)
        assert len(roll._config.graphs) <= 4 and held <= 4 * small_chunks, roll._config.graphs.keys()
        estimate = roll.memory_bytes(2, grad=False)
        assert estimate["total"] == roll.nbytes  # the stage buffers included
        estimates.append(estimate["graph"])
    per_step = rollout_memory.launches_per_step(wd.engine.step.plan(model), int(wd.VelRepr.Mixed), ("joint_positions", "valid"), False, False)
    assert estimates == [steps * per_step * rollout_memory.GRAPH_BYTES_PER_LAUNCH for steps in (6, 5, 4)]


def test_a_graph_that_cannot_be_allocated_is_a_memory_error_and_is_captured_again_next_run(monkeypatch):
    """A capture whose allocation fails (Warp's "Failed to allocate") is a MemoryError naming the launches and
    their estimated bytes; the rollout keeps no half-made graph, and a later run captures it and equals an
    eager run."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=2, joint_positions=[[0.3, -0.2]] * 2)
    roll = wd.simulation.Rollout(model, steps=5, record=("joint_positions",), use_graph=True)
    capture_graph = launch.capture_graph

    def failing(launches, device):
        raise RuntimeError("Failed to allocate 1048576 bytes on device 'cpu'")

    monkeypatch.setattr(launch, "capture_graph", failing)
    with pytest.raises(MemoryError, match=r"capturing a graph of \d+ launches needs about .* Failed to allocate"):
        roll.run(data)
    assert not roll._config.graphs
    monkeypatch.setattr(launch, "capture_graph", capture_graph)
    _, records = roll.run(data)
    assert roll._config.graphs and all(p.replay is not None for p in roll._config.graphs.values())
    _, eager = wd.simulation.Rollout(model, steps=5, record=("joint_positions",), use_graph=False).run(data)
    np.testing.assert_array_equal(records["joint_positions"].numpy(), eager["joint_positions"].numpy())


def test_memory_bytes_counts_the_graph_of_unchunked_storages():
    """A graph of "trajectory" storage outside a tape holds every step: its estimate grows with T; under a
    tape the steps are recorded, not captured: 0."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2), dtype=np.float64)
    per_step = rollout_memory.launches_per_step(wd.engine.step.plan(model), int(wd.VelRepr.Mixed), ("joint_positions",), False, False)
    for T in (10, 20):
        roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions",), storage="trajectory")
        assert roll.memory_bytes(2, grad=False)["graph"] == T * per_step * rollout_memory.GRAPH_BYTES_PER_LAUNCH
        assert roll.memory_bytes(2, grad=True)["graph"] == 0
    eager = wd.simulation.Rollout(model, steps=10, use_graph=False)
    assert eager.memory_bytes(2, grad=False)["graph"] == 0 and eager.memory_bytes(2, grad=False)["staging"] == 0


def test_a_rollout_larger_than_the_machine_is_a_memory_error():
    """10^9 steps of 4 environments kept as a trajectory (~0.6 TB): a MemoryError naming the rollout and its
    size, raised before any buffer is allocated (the host would otherwise overcommit and be killed)."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(3), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=4)
    roll = wd.simulation.Rollout(model, steps=10**9, record=(), storage="trajectory", use_graph=False)
    with pytest.raises(MemoryError, match=r"a rollout of 1000000000 steps of 4 environments \(trajectory storage\) needs about \d+ GiB \(\d+ bytes\)"):
        roll.run(data)
    assert roll.nbytes == 0
