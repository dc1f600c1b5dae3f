"""Run-to-run reproducibility, on any device (written for GPUs, where threads race): the same rollout gives
the same states bit for bit, and its gradients, from a fresh forward and backward, are bit-identical with
respect to the state, the controls and parameters given per environment (one thread per environment reads
its own row and sums its adjoints in program order). A parameter shared by the environments gets the sum of
their adjoints, which a GPU adds up with atomics in an order that varies from run to run (the last bits;
within 1e-12 of its largest entry here); its gradient equals the sum of the per-environment rows. With
parameters_requiring_grad(..., deterministic=True) it is that sum, taken in environment order: bit-identical
run to run on any device."""

import contextlib
import os
import subprocess
import sys

import numpy as np
import pytest
import warp as wp

import gradcheck
import robots
import warpdyn as wd
from warpdyn import VelRepr
from warpdyn.engine import contact_stage, determinism

N, T = 8, 6
PARAMETERS = ("link_mass", "friction_viscous", "K", "terrain_height")
RECORD = ("joint_positions", "base_velocity", "tangential_deformation", "joint_torques", "link_contact_forces")


def _legs(per_environment: bool):
    """The seed's legs on flat ground, float64; per_environment: every marked parameter given per
    environment (the shared values tiled, so the physics is the same)."""
    model = robots.ergocub_seed_with_points(np.float64)
    model = wd.model.reduce(model, model.joint_names())
    model.contact_params = wd.model.SoftContactsParams(K=1e6, D=2e3, mu=0.5)
    model.terrain = wd.terrain.FlatTerrain(height=0.0)
    model.set_joint_parameters(friction_viscous=np.full(model.dofs(), 0.3))
    if per_environment:
        model.set_link_parameters(mass=np.tile(model.link_mass.numpy(), (N, 1)))
        model.set_joint_parameters(friction_viscous=np.tile(model.friction_viscous.numpy(), (N, 1)))
        model.contact_params = wd.model.SoftContactsParams(K=np.full(N, 1e6), D=np.full(N, 2e3), mu=np.full(N, 0.5))
        model.terrain = wd.terrain.FlatTerrain(height=np.zeros(N))
    return model


def _data(model, requires_grad=False):
    return wd.data.random_model_data(
        model, key=4, num_envs=N, velocity_representation=VelRepr.Body, requires_grad=requires_grad,
        base_pos_bounds=((-0.1, -0.1, 0.56), (0.1, 0.1, 0.58)), base_rpy_bounds=(-0.2, 0.2), joint_pos_bounds=(-0.3, 0.3),
    )  # fmt: skip


def _controls(model, rng):
    tau = wp.array(5.0 * rng.normal(size=(T, N, model.dofs())), dtype=wp.float64, requires_grad=True)
    f = wp.array(rng.normal(size=(T, N, model.number_of_links(), 6)), dtype=wp.float64, requires_grad=True)
    return {"joint_force_references": tau, "link_forces": f}


def _run(per_environment: bool, storage: str = "trajectory", deterministic: bool = False):
    """A fresh model, data and controls, a rollout under a tape and one backward pass: (records, gradients)
    as host copies (the gradients of the initial state, the controls and the marked parameters)."""
    model = _legs(per_environment)
    params = wd.model.parameters_requiring_grad(model, names=PARAMETERS, deterministic=deterministic)
    data = _data(model, requires_grad=True)
    controls = _controls(model, np.random.default_rng(2))
    tape = wp.Tape()
    with tape:
        final, rec = wd.simulation.Rollout(model, steps=T, record=RECORD, storage=storage).run(data, **controls)
        arrays = [rec[name] for name in RECORD] + [final.joint_positions_state]
        rng = np.random.default_rng(3)
        loss = gradcheck.weighted_sum(arrays, [wp.array(rng.normal(size=x.shape), dtype=wp.float64) for x in arrays])
    tape.backward(loss)
    state = {"p": data.base_position_state, "Q": data.base_quaternion_state, "s": data.joint_positions_state,
             "v": data.base_velocity_state, "sdot": data.joint_velocities_state, "m": data.tangential_deformation_state}  # fmt: skip
    grads = {k: a.grad.numpy().copy() for k, a in {**state, **controls, **params}.items()}
    return {k: rec[k].numpy().copy() for k in RECORD}, grads


def test_forward_rollouts_are_bitwise_reproducible():
    """Two rollouts of 40 steps with contacts from fresh objects (and a third on the same Rollout) agree bit for bit."""
    runs = []
    for _ in range(2):
        model = _legs(False)
        rollout = wd.simulation.Rollout(model, steps=40, record=RECORD)
        tau = np.random.default_rng(1).normal(0.0, 5.0, (N, model.dofs()))
        for _ in range(2 if not runs else 1):
            final, rec = rollout.run(_data(model), joint_force_references=tau)
            runs.append([final.base_position_state.numpy(), *(rec[k].numpy() for k in RECORD)])
    assert np.abs(runs[0][3]).max() > 0, "no contact"
    for other in runs[1:]:
        for a, b in zip(runs[0], other):
            np.testing.assert_array_equal(a, b)


def test_contacts_with_gradients_match_contacts_without(monkeypatch):
    """With gradients the step's contact forces run a thread per environment (its points and links in a
    loop: deterministic adjoints), without them (on a GPU; here on any device) a thread per point and per
    link: the same records, bit for bit on the CPU (the same operations per point), to rounding on a GPU
    (another compilation of them)."""
    monkeypatch.setattr(contact_stage, "contacts_per_environment", lambda device, grad: grad)
    monkeypatch.setattr(wd.config, "fused_step", False)  # without gradients too: the launch list's contact kernels
    model = _legs(True)
    tau = np.random.default_rng(1).normal(0.0, 5.0, (N, model.dofs()))
    runs = []
    for grad in (False, True):
        with wp.Tape() if grad else contextlib.nullcontext():
            final, rec = wd.simulation.Rollout(model, steps=T, record=RECORD).run(_data(model, requires_grad=grad), joint_force_references=tau)
        runs.append([final.base_velocity_state.numpy(), *(rec[k].numpy() for k in RECORD)])
    assert np.abs(runs[0][5]).max() > 10.0, "no contact"
    for a, b in zip(*runs):
        robots.assert_same_compilation_results(a, b)


@pytest.mark.parametrize("storage", ["trajectory", "checkpointed"])
def test_gradients_with_per_environment_parameters_are_bitwise_reproducible(storage):
    """Twice a fresh forward and backward: every gradient (state, controls, per-environment parameters) and
    every record agree bit for bit."""
    (rec_a, grad_a), (rec_b, grad_b) = _run(True, storage), _run(True, storage)
    for k in rec_a:
        np.testing.assert_array_equal(rec_a[k], rec_b[k], err_msg=k)
    for k in grad_a:
        assert np.abs(grad_a[k]).max() > 0, f"no gradient reaches {k}"
        np.testing.assert_array_equal(grad_a[k], grad_b[k], err_msg=k)
    assert grad_a["link_mass"].shape == (N, 13) and grad_a["K"].shape == (N,)


def test_shared_parameter_gradients_are_the_sums_of_the_per_environment_rows():
    """The same physics with shared parameters: the same records and state/control gradients (to rounding),
    and each shared parameter's gradient equals the sum of the per-environment rows; run to run it agrees
    bit for bit on the CPU and within 1e-12 of its largest entry on a GPU (atomics)."""
    rec_env, grad_env = _run(True)
    rec_a, grad_a = _run(False)
    _, grad_b = _run(False)
    for k in rec_env:
        np.testing.assert_allclose(rec_a[k], rec_env[k], rtol=1e-12, atol=1e-12 * max(1.0, np.abs(rec_env[k]).max()), err_msg=k)
    for k in grad_a:
        summed = grad_env[k].sum(axis=0) if k in PARAMETERS else grad_env[k]
        scale = max(1.0, np.abs(summed).max())
        np.testing.assert_allclose(grad_a[k], summed, rtol=0, atol=1e-10 * scale, err_msg=k)
        if robots.TEST_DEVICE == "cpu":
            np.testing.assert_array_equal(grad_a[k], grad_b[k], err_msg=k)
        else:
            np.testing.assert_allclose(grad_a[k], grad_b[k], rtol=0, atol=1e-12 * scale, err_msg=k)


@pytest.mark.parametrize("storage", ["trajectory", "checkpointed"])
def test_deterministic_shared_parameter_gradients_are_bitwise_reproducible(storage):
    """deterministic=True: twice a fresh forward and backward give bit-identical gradients of the shared
    parameters (and of everything else), equal to the per-environment rows summed in environment order:
    bit for bit where one backward pass sums them ("trajectory"), to rounding where each recomputed segment
    adds its sum ("checkpointed")."""
    _, grad_env = _run(True, storage)
    (rec_a, grad_a), (rec_b, grad_b) = _run(False, storage, True), _run(False, storage, True)
    for k in rec_a:
        np.testing.assert_array_equal(rec_a[k], rec_b[k], err_msg=k)
    for k in grad_a:
        np.testing.assert_array_equal(grad_a[k], grad_b[k], err_msg=k)
    for k in PARAMETERS:
        rows = grad_env[k]
        summed = rows[0].copy()
        for row in rows[1:]:
            summed += row
        summed = summed.reshape(grad_a[k].shape)  # K and the terrain's height: (1,) shared, (N,) per environment
        assert np.abs(summed).max() > 0, k
        if storage == "trajectory":
            np.testing.assert_array_equal(grad_a[k], summed, err_msg=k)
        else:
            np.testing.assert_allclose(grad_a[k], summed, rtol=0, atol=1e-12 * np.abs(summed).max(), err_msg=k)


def test_deterministic_gradients_refuse_heightfield_heights():
    model = _legs(False)
    model.terrain = wd.terrain.HeightfieldTerrain(heights=np.zeros((4, 4)), spacing=(1.0, 1.0), origin=(-2.0, -2.0))
    with pytest.raises(ValueError, match="terrain_height with deterministic=True: a HeightfieldTerrain"):
        wd.model.parameters_requiring_grad(model, names=("link_mass", "terrain_height"), deterministic=True)


@wp.kernel
def _sum_squares(x: wp.array2d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    i, j = wp.tid()
    wp.atomic_add(loss, 0, x[i, j] * x[i, j])


def _step_gradients(deterministic: bool):
    """Two steps and ABA under a tape: d loss / d every kind of shared parameter (scalar, vec3 and mat33 per
    link, per joint, contact, terrain), after one backward pass and after tape.zero() and a second."""
    names = ("link_mass", "link_com", "link_inertia", "friction_viscous", "K", "D", "mu", "terrain_height")
    model = _legs(False)
    params = wd.model.parameters_requiring_grad(model, names=names, deterministic=deterministic)
    data = _data(model)
    tau = wp.array(np.random.default_rng(5).normal(0.0, 5.0, (N, model.dofs())), dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        stepped = wd.model.step(model, data, joint_force_references=tau)
        stepped = wd.model.step(model, stepped, joint_force_references=tau)
        _, acc = wd.model.forward_dynamics_aba(model, stepped, joint_forces=tau)
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        wp.launch(_sum_squares, dim=acc.shape, inputs=[acc], outputs=[loss])
    passes = []
    for _ in range(2):
        tape.backward(loss)
        passes.append({k: a.grad.numpy().copy() for k, a in {**params, "tau": tau}.items()})
        tape.zero()
    return passes


def test_deterministic_gradients_of_every_kind_of_parameter_equal_the_default_ones():
    """deterministic=True changes the order of the sums only: the gradients of scalar, vec3 and mat33
    parameters of links, joints, contacts and the terrain through steps and ABA equal the default ones to
    rounding, and a second backward pass after tape.zero() repeats the first."""
    default, deterministic = _step_gradients(False), _step_gradients(True)
    for k, expected in default[0].items():
        scale = np.abs(expected).max()
        assert scale > 0, f"no gradient reaches {k}"
        np.testing.assert_allclose(deterministic[0][k], expected, rtol=0, atol=1e-12 * scale, err_msg=k)
        np.testing.assert_allclose(deterministic[1][k], deterministic[0][k], rtol=0, atol=1e-12 * scale, err_msg=f"{k}, second pass")


NO_CONTRACTION = """
import sys
import numpy as np
import warp as wp
sys.path.insert(0, sys.argv[1])
import robots
import warpdyn as wd
wd.config.fuse_fp = False
wp.set_device(sys.argv[2])

@wp.kernel
def sum_squares(x: wp.array2d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    i, j = wp.tid()
    wp.atomic_add(loss, 0, x[i, j] * x[i, j])

model = robots.ergocub_seed_with_points(np.float64)
model = wd.model.reduce(model, model.joint_names())
data = wd.data.random_model_data(model, key=4, num_envs=8, requires_grad=True)
tau = wp.array(np.random.default_rng(5).normal(0.0, 5.0, (8, model.dofs())), dtype=wp.float64, requires_grad=True)
tape = wp.Tape()
with tape:
    _, acc = wd.model.forward_dynamics_aba(model, data, joint_forces=tau)
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    wp.launch(sum_squares, dim=acc.shape, inputs=[acc], outputs=[loss])
arrays = [tau, data.joint_positions_state, data.base_quaternion_state, data.base_velocity_state, data.joint_velocities_state]
passes = []
for _ in range(3):
    tape.backward(loss)
    passes.append([a.grad.numpy().copy() for a in arrays])
    tape.zero()
assert all(np.abs(g).max() > 0 for g in passes[0])
for other in passes[1:]:
    for a, b in zip(passes[0], other):
        assert np.array_equal(a, b), np.abs(a - b).max()
print("identical", len(passes))
"""


def test_repeated_backward_passes_agree_bitwise_without_contraction(tmp_path):
    """warpdyn.config.fuse_fp = False (set before the first launch, in a fresh interpreter): three backward
    passes of one tape through ABA give bit-identical gradients (on a GPU too, where contracted kernels
    replay their forward with other roundings)."""
    tests = os.path.dirname(os.path.abspath(__file__))
    script = tmp_path / "no_contraction.py"  # a file: Warp reads its kernels' source
    script.write_text(NO_CONTRACTION)
    proc = subprocess.run(
        [sys.executable, str(script), tests, robots.TEST_DEVICE],
        capture_output=True, text=True, env=dict(os.environ, WARPDYN_VERBOSE="0"), timeout=600,
    )  # fmt: skip
    assert proc.returncode == 0 and "identical 3" in proc.stdout, proc.stdout + proc.stderr


def test_fuse_fp_changed_after_kernels_loaded_is_refused():
    """Recorded launches and graphs hold compiled kernels: once kernels are loaded, assigning the other value
    of warpdyn.config.fuse_fp raises (and leaves it), the same value is accepted, a non-bool is refused."""
    model = _legs(False)
    data = _data(model)
    expected = wd.model.forward_dynamics_aba(model, data)[1].numpy()
    before = wd.config.fuse_fp
    with pytest.raises(RuntimeError, match=f"warpdyn.config.fuse_fp = {not before}: kernels are loaded with {before}"):
        wd.config.fuse_fp = not before
    with pytest.raises(TypeError, match="fuse_fp must be True or False, got 0"):
        wd.config.fuse_fp = 0
    wd.config.fuse_fp = before
    assert wd.config.fuse_fp is before
    np.testing.assert_array_equal(wd.model.forward_dynamics_aba(model, data)[1].numpy(), expected)


def _aba_loss_and_gradient(model, data, mass, tape):
    """sum of squared joint accelerations of ABA recorded on `tape`, and d/d link_mass after its backward."""
    with tape:
        _, acc = wd.model.forward_dynamics_aba(model, data)
        loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        wp.launch(_sum_squares, dim=acc.shape, inputs=[acc], outputs=[loss])
    tape.backward(loss)
    return float(loss.numpy()[0]), mass.grad.numpy().copy()


def test_deterministic_marks_are_kept_and_a_reset_tape_records_anew():
    """A call without `deterministic` keeps a parameter's marking (the torch bridge marks its parameters so);
    a tape reset after an optimiser step records a new copy of the parameter: the loss and gradient of the
    new masses, as without determinism; np.int64 launch dimensions are accepted."""
    model = _legs(False)
    mass = wd.model.parameters_requiring_grad(model, names=("link_mass",), deterministic=True)["link_mass"]
    wd.model.parameters_requiring_grad(model, names=("link_mass",))
    assert determinism.is_marked(mass)
    data = _data(model)
    tape = wp.Tape()
    _aba_loss_and_gradient(model, data, mass, tape)
    mass.assign(mass.numpy() * 1.1)
    tape.reset()
    got = _aba_loss_and_gradient(model, data, mass, tape)
    wd.model.parameters_requiring_grad(model, names=("link_mass",), deterministic=False)
    assert not determinism.is_marked(mass)
    mass.grad.zero_()
    expected = _aba_loss_and_gradient(model, data, mass, wp.Tape())
    np.testing.assert_allclose(got[0], expected[0], rtol=1e-13)
    np.testing.assert_allclose(got[1], expected[1], rtol=0, atol=1e-12 * np.abs(expected[1]).max())
    wd.model.parameters_requiring_grad(model, names=("link_mass",), deterministic=True)
    with wp.Tape():
        rows = determinism.rows_per_environment([mass.reshape((1, -1))], np.int64(N), mass.device)
    assert rows[0].shape == (N, mass.shape[0])
