"""wd.simulation.Stepper: in-place steps, the fast path. Reference: wd.model.step in a loop on the same
inputs, which runs the same kernels on the same numbers, so every state must be equal bit for bit."""

import numpy as np
import pytest
import warp as wp

import mjcf_models as mm
import robots
import warpdyn as wd
from warpdyn import VelRepr


def _legs(integrator=robots.SIE):
    model = robots.ergocub_seed_with_points(np.float64)
    model = wd.model.reduce(model, model.joint_names())  # its own plan and settings
    model.integrator = integrator
    return model


def _standing(model, N, repr_=VelRepr.Mixed, seed=0):
    return wd.data.random_model_data(
        model, key=seed, num_envs=N, velocity_representation=repr_,
        base_pos_bounds=((-0.1, -0.1, 0.56), (0.1, 0.1, 0.6)), base_rpy_bounds=(-0.3, 0.3), joint_pos_bounds=(-0.3, 0.3),
    )  # fmt: skip


def _assert_same_state(a, b, label):
    for name in ("base_position", "base_quaternion", "joint_positions", "joint_velocities", "base_velocity", "healthy"):
        np.testing.assert_array_equal(getattr(a, name).numpy(), getattr(b, name).numpy(), err_msg=f"{label}: {name}")
    np.testing.assert_array_equal(a.tangential_deformation_state.numpy(), b.tangential_deformation_state.numpy(), err_msg=label)


@pytest.mark.parametrize("use_graph", [True, False], ids=["graph", "recorded"])
@pytest.mark.parametrize("integrator", [robots.SIE, robots.RK4], ids=["euler", "rk4"])
def test_steps_equal_model_step_bitwise(integrator, use_graph):
    """The legs in contact, 3 environments in Body, per-call torques and Body link forces written into the
    Stepper's arrays, substeps 3 (odd: the buffers swap) over 4 calls: every state equals wd.model.step's."""
    model = _legs(integrator)
    N, n, nL = 3, model.dofs(), model.number_of_links()
    data = _standing(model, N, VelRepr.Body)
    stepper = wd.simulation.Stepper(model, data, substeps=3, link_forces=True, use_graph=use_graph)
    _assert_same_state(stepper.data, data, "initial")
    rng = np.random.default_rng(1)
    expected = data
    for call in range(4):
        tau, f = rng.normal(0, 5, (N, n)), rng.normal(0, 2, (N, nL, 6))
        stepper.joint_force_references.assign(tau)
        stepper.link_forces.assign(f)
        got = stepper.step()
        for _ in range(3):
            expected = wd.model.step(model, expected, joint_force_references=tau, link_forces=f)
        _assert_same_state(got, expected, f"call {call}")
    assert np.abs(stepper.data.tangential_deformation_state.numpy()).max() > 0, "no contact"


def test_actuators_and_a_model_change():
    """An MJCF humanoid with position servos driven by `ctrl`; then a setter changes the gains: the next call
    rebuilds its launches and follows the new values, as wd.model.step does."""
    model = wd.model.Model.build_from_model_description(mm.FLOATING_HUMANOID, dtype=np.float64)
    N, na = 2, model.number_of_actuators()
    data = wd.data.Data.build(model, num_envs=N, joint_positions=np.random.default_rng(0).uniform(-0.3, 0.3, (N, model.dofs())))
    stepper = wd.simulation.Stepper(model, data, substeps=2)
    u = np.random.default_rng(2).uniform(-1, 1, (N, na))
    stepper.ctrl.assign(u)
    expected = data
    for _ in range(2):
        got = stepper.step()
        for _ in range(2):
            expected = wd.model.step(model, expected, ctrl=u)
        _assert_same_state(got, expected, "servos")
    model.set_actuator_parameters(gain=model.actuator_gain.numpy() * 2.0)
    got = stepper.step()
    for _ in range(2):
        expected = wd.model.step(model, expected, ctrl=u)
    _assert_same_state(got, expected, "after the setter")


def test_masked_reset_and_health():
    """A pendulum chain, 3 environments; environment 1 diverges (1e200 rad/s) and is flagged, the others
    step on as alone; set_state with a mask (1 only) restores it, valid again, and leaves 0 and 2 as they were."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(3), dtype=np.float64)
    v = np.array([[0.5, 0.0, 0.0], [1e200, 0.0, 0.0], [0.0, -0.5, 0.0]])
    data = wd.data.Data.build(model, num_envs=3, joint_velocities=v)
    stepper = wd.simulation.Stepper(model, data)
    stepper.step()
    assert stepper.data.healthy.numpy().tolist() == [1, 0, 1]
    alone = wd.model.step(model, wd.data.Data.build(model, num_envs=3, joint_velocities=np.where(np.abs(v) > 1e100, 0.0, v)))
    np.testing.assert_array_equal(stepper.data.joint_positions.numpy()[[0, 2]], alone.joint_positions.numpy()[[0, 2]])
    before = stepper.data.joint_positions.numpy().copy()
    fresh = wd.data.Data.build(model, num_envs=3, joint_positions=np.full((3, 3), 0.25))
    stepper.set_state(fresh, envs=wp.array([0, 1, 0], dtype=wp.int32))
    after = stepper.data
    assert after.healthy.numpy().tolist() == [1, 1, 1]
    np.testing.assert_array_equal(after.joint_positions.numpy()[1], [0.25] * 3)
    np.testing.assert_array_equal(after.joint_velocities.numpy()[1], [0.0] * 3)
    np.testing.assert_array_equal(after.joint_positions.numpy()[[0, 2]], before[[0, 2]])
    stepper.step()
    assert stepper.data.healthy.numpy().all()


def test_errors_are_named():
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=2)
    with pytest.raises(ValueError, match="substeps must be a positive integer"):
        wd.simulation.Stepper(model, data, substeps=0)
    with pytest.raises(ValueError, match="use_graph must be"):
        wd.simulation.Stepper(model, data, use_graph="yes")
    stepper = wd.simulation.Stepper(model, data)
    with pytest.raises(ValueError, match="data has 3 environments in Mixed; this Stepper steps 2"):
        stepper.set_state(wd.data.Data.build(model, num_envs=3))
    with pytest.raises(ValueError, match=r"envs has shape \(3,\)"):
        stepper.set_state(data, envs=wp.zeros(3, dtype=wp.int32))
    with pytest.raises(TypeError, match="envs must be a Warp int32 array"):
        stepper.set_state(data, envs=wp.zeros(2, dtype=wp.float64))
    with pytest.raises(TypeError, match="got list"):
        stepper.set_state(data, envs=[1, 0])
    with pytest.raises(RuntimeError, match="overwrites its states"):
        with wp.Tape():
            stepper.step()


@wp.kernel
def _count(counter: wp.array(dtype=wp.int32)):
    counter[wp.tid()] += 1


def _warp_graph(body):
    """A caller's capture for a step program: `body` in Warp's graph of the current device (not run); its replay
    launches the graph and returns what `body` returned."""
    with wp.ScopedCapture(force_module_load=False) as capture:
        outputs = body()

    def replay():
        wp.capture_launch(capture.graph)
        return outputs

    return replay


@pytest.mark.parametrize("substeps", [2, 3], ids=["even", "odd"])
def test_a_step_program_captures_a_callers_step(substeps):
    """A caller's step (a launch of its own, then `step()`) as a step program: eager at the first run, then a
    graph per buffer its steps start from (one for even substeps, two for odd), whose capture runs nothing and
    whose replays run the whole step once; the states equal a plain Stepper's bit for bit and `data` is the
    state a run wrote. A setter drops the graphs: the next run is eager, the one after captures again."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(3), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=2, joint_positions=[[0.3, -0.2, 0.1], [-0.4, 0.2, 0.5]])
    stepper = wd.simulation.Stepper(model, data, substeps=substeps, use_graph=False)
    plain = wd.simulation.Stepper(model, data, substeps=substeps)
    counter = wp.zeros(1, dtype=wp.int32)

    def body():
        wp.launch(_count, dim=1, inputs=[counter])
        stepper.step()
        return counter

    program = stepper.step_program(body, _warp_graph)
    captured = []
    for run in range(7):
        if run == 4:
            model.set_joint_parameters(damping=np.full(model.dofs(), 0.5))
        assert program.run() is counter
        plain.step()
        _assert_same_state(stepper.data, plain.data, f"run {run}")
        assert counter.numpy()[0] == run + 1, run
        captured.append(program.captured)
    assert captured == ([0, 1, 1, 1, 0, 1, 1] if substeps % 2 == 0 else [0, 1, 2, 2, 0, 1, 2])


def test_step_program_errors_are_named():
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2), dtype=np.float64)
    data = wd.data.Data.build(model, num_envs=2)
    stepper = wd.simulation.Stepper(model, data, use_graph=False)
    with pytest.raises(ValueError, match="use_graph must be"):
        stepper.step_program(stepper.step, _warp_graph, use_graph="yes")
    with pytest.raises(TypeError, match="a callable body and a callable capture"):
        stepper.step_program(stepper.step, None)
    with pytest.raises(ValueError, match="build the Stepper with use_graph=False"):
        wd.simulation.Stepper(model, data).step_program(stepper.step, _warp_graph, what="an env")
    idle = stepper.step_program(lambda: None, _warp_graph, what="an env")
    with pytest.raises(RuntimeError, match=r"the body of an env must call its Stepper's step\(\) once; it called it 0 times"):
        idle.run()
    eager = stepper.step_program(stepper.step, _warp_graph, use_graph=False)
    for _ in range(3):
        assert eager.run() is stepper.data
    assert eager.captured == 0
