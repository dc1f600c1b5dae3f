"""The PyTorch bridge (warpdyn.torch): a rollout as a torch.autograd.Function, float64 on the CPU.

References and tolerances:
- torch.autograd.gradcheck (central differences of the bridge itself against its backward pass) on a
  pendulum chain with viscous friction, w.r.t. the initial joint positions and velocities, the per-step
  torques and two model parameters. eps = 1e-6: the truncation error of central differences is
  ~eps^2 |f'''| ~ 1e-12 and the rounding error ~1e-16 |f| / eps ~ 1e-10 for records of O(1),
  so atol = 1e-7 and rtol = 1e-6 are 1000 times above both and far below each input's largest Jacobian
  entry (observed: 0.06 for the torques and parameters, 1 for the initial state).
- The plain wp.Tape through wd.simulation.rollout on the same inputs (itself checked against central
  differences in tests/test_rollout.py and tests/test_parameter_gradients.py): the bridge runs the same
  kernels on the same numbers, and torch's output gradient of a weighted sum is the weights exactly, so
  the gradients must agree to rounding of the summation order: rtol 1e-12.
- The records against wd.simulation.rollout's: the same launches, bitwise.
"""

from __future__ import annotations

import functools
import subprocess
import sys
import weakref

import numpy as np
import pytest
import warp as wp

import torch  # the test extra installs it

import gradcheck
import robots
import warpdyn as wd
import warpdyn.torch as wdt
from warpdyn import VelRepr

F64 = torch.float64
torch.set_default_device(wp.device_to_torch(wp.get_device()))  # the tests' device (tests/conftest.py)


def _pendulum(n=3):
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
    model.set_joint_parameters(friction_viscous=np.full(n, 0.3))
    return model


@functools.cache
def _legs():
    """The seed's ergoCub legs, float64: 13 links, 12 joints, 32 collidable points (cached)."""
    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=np.float64)
    return wd.model.reduce(full, robots.seed_joints(full.joint_names()))


def _legs_model():
    """A copy of the cached legs (wd.contact.with_collidable_points: the same points, the cached device
    constants) with its own parameters, settings and plan, and its own link-mass array (the tests mark it for
    gradients: not the cached model's)."""
    legs = _legs()
    model = wd.contact.with_collidable_points(legs)
    model.set_link_parameters(mass=legs.link_mass.numpy())
    return model


def _t(x, grad=False):
    return torch.tensor(np.asarray(x, dtype=np.float64), dtype=F64, requires_grad=grad)


# ------------------------------------------------------------------------------ gradcheck


@pytest.mark.parametrize("batched", [False, True], ids=["single", "batched"])
def test_gradcheck_pendulum_state_torques_and_parameters(batched):
    """torch.autograd.gradcheck through 4 steps of a 3-link pendulum chain with viscous friction, w.r.t. the
    initial joint positions and velocities, the per-step torques, link_mass and friction_viscous (module
    docstring: eps 1e-6, atol 1e-7, rtol 1e-6). Single environment: torques (T, n); batched: 2 environments
    sharing per-step torques (T, 1, n), so their gradient sums both. validate=False: gradcheck perturbs the
    massless base's link_mass below 0, which validation would refuse."""
    model = _pendulum()
    n, T = model.dofs(), 4
    rng = np.random.default_rng(0)
    lead = () if not batched else (2,)
    s0 = _t(rng.uniform(-0.5, 0.5, (*lead, n)), True)
    v0 = _t(rng.uniform(-0.5, 0.5, (*lead, n)), True)
    tau = _t(rng.normal(size=(T, n) if not batched else (T, 1, n)), True)
    mass = _t(model.link_mass.numpy() * rng.uniform(0.8, 1.2, model.number_of_links()), True)
    viscous = _t(rng.uniform(0.2, 0.4, n), True)

    def f(s0, v0, tau, mass, viscous):
        rec = wdt.rollout(
            model,
            steps=T,
            joint_positions=s0,
            joint_velocities=v0,
            joint_force_references=tau,
            parameters={"link_mass": mass, "friction_viscous": viscous},
            record=("joint_positions", "joint_velocities"),
            validate=False,
        )
        return rec["joint_positions"], rec["joint_velocities"]

    inputs = (s0, v0, tau, mass, viscous)
    assert torch.autograd.gradcheck(f, inputs, eps=1e-6, atol=1e-7, rtol=1e-6)
    # the check is not vacuous: every input moves the final velocities
    s, v = f(*inputs)
    grads = torch.autograd.grad(v[-1].sum(), inputs)
    assert all(float(g.abs().max()) > 1e-3 for g in grads[:3] + grads[4:])
    assert float(grads[3][1:].abs().max()) > 1e-3  # the rods' masses (the base's is 0 and does not matter)


ARM_MJCF = """
<mujoco model="servo_arm">
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0" armature="0.02" damping="0.3" stiffness="2" springref="0.2"/>
      <inertial pos="0.15 0 0" mass="1.0" diaginertia="0.001 0.008 0.008"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" axis="0 1 0" armature="0.01" damping="0.1"/>
        <inertial pos="0.12 0 0" mass="0.6" diaginertia="0.0005 0.004 0.004"/>
      </body>
    </body>
  </worldbody>
  <actuator>
    <position name="shoulder_servo" joint="shoulder" kp="20" kv="1" ctrlrange="-2 2" gear="2"/>
    <motor name="elbow_motor" joint="elbow" forcerange="-3 3"/>
  </actuator>
</mujoco>"""


def test_gradcheck_controls_and_actuator_parameters():
    """gradcheck through 4 steps of a two-joint MJCF arm (armature, damping, a spring; a position servo with
    gear and a motor), w.r.t. the per-step controls (T, na) and the armature and the actuators' gains (module
    docstring: eps 1e-6, atol 1e-7, rtol 1e-6); controls inside their ranges (a clip's kink is not
    differentiable at the bound)."""
    model = wd.model.Model.build_from_model_description(ARM_MJCF, dtype=np.float64)
    assert model.actuator_names() == ("shoulder_servo", "elbow_motor")
    T = 4
    rng = np.random.default_rng(1)
    ctrl = _t(rng.uniform(-1, 1, (T, 2)), True)
    armature = _t(model.armature.numpy(), True)
    gain = _t(model.actuator_gain.numpy(), True)

    def f(ctrl, armature, gain):
        rec = wdt.rollout(
            model, steps=T, joint_velocities=_t([0.5, -0.3]), ctrl=ctrl, parameters={"armature": armature, "actuator_gain": gain},
            record=("joint_positions", "joint_velocities"), validate=False,
        )  # fmt: skip
        return rec["joint_positions"], rec["joint_velocities"]

    inputs = (ctrl, armature, gain)
    assert torch.autograd.gradcheck(f, inputs, eps=1e-6, atol=1e-7, rtol=1e-6)
    grads = torch.autograd.grad(f(*inputs)[1][-1].sum(), inputs)
    assert all(float(g.abs().max()) > 1e-3 for g in grads)


# ------------------------------------------------------------------------------ against the plain tape


RECORDS = (
    "base_position",
    "base_quaternion",
    "joint_positions",
    "base_velocity",
    "joint_velocities",
    "tangential_deformation",
    "joint_torques",
    "link_contact_forces",
)


@pytest.mark.parametrize("per_env", [False, True], ids=["shared", "per-environment"])
def test_floating_base_with_contacts_equals_the_plain_tape(per_env, monkeypatch):
    """The ergoCub legs standing on flat ground (feet 4 mm deep, joints moving, contact forces and tangential
    deformation in every step), 2 environments, 5 steps, Inertial representation (the base velocity's
    conversion to Mixed is on the tape): the records equal wd.simulation.rollout's bitwise, and the
    gradients of sum(w * records) w.r.t. the base pose and velocity, the joint state, the tangential
    deformation, the per-step torques and the parameters K and link_mass equal those of the plain wp.Tape
    through wd.simulation.rollout (module docstring: rtol 1e-12). The bridge leaves the .grad the model's
    parameter arrays hold (the plain tape's), also of D, marked but not given to it, and their values as
    they were. per_env: link masses given per environment ((2, nL) tensors and gradients) and the ground at
    a height per environment (terrain_height (2,)), in the GPUs' environment-fastest layout (per-environment
    arrays are transposed views there)."""
    monkeypatch.setattr(wd.config, "env_fastest", per_env)
    model = _legs_model()
    n, N, T = model.dofs(), 2, 5
    nc = len(model.kin_dyn_parameters.contact_parameters.body)
    rng = np.random.default_rng(1)
    low = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min()
    heights = np.zeros(N)
    names = ("K", "link_mass", "D")  # D: not given to the bridge
    if per_env:
        model.set_link_parameters(mass=model.link_mass.numpy() * rng.uniform(0.9, 1.1, (N, model.number_of_links())))
        heights = np.array([0.0, 0.002])
        model.terrain = wd.terrain.FlatTerrain(height=heights)
        names += ("terrain_height",)
    state = {
        "base_position": np.array([[0.0, 0.0, -low - 0.004], [0.01, -0.02, -low - 0.003]]) + np.outer(heights, [0, 0, 1]),
        "base_quaternion": np.array([[1.0, 0.0, 0.0, 0.0], [np.cos(0.05), 0.0, 0.0, np.sin(0.05)]]),
        "joint_positions": rng.uniform(-0.1, 0.1, (N, n)),
        "base_velocity": rng.uniform(-0.05, 0.05, (N, 6)),
        "joint_velocities": rng.uniform(-0.2, 0.2, (N, n)),
        "tangential_deformation": rng.uniform(-1e-4, 1e-4, (N, nc, 3)),
    }
    tau = rng.normal(size=(T, N, n))

    # the plain tape
    params = wd.model.parameters_requiring_grad(model, names=names)
    wp_state = {k: wp.array(v, dtype=wp.float64, requires_grad=True) for k, v in state.items()}
    wp_tau = wp.array(tau, dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        v = wp_state["base_velocity"]
        data = wd.data.Data.build(
            model,
            base_position=wp_state["base_position"],
            base_quaternion=wp_state["base_quaternion"],
            joint_positions=wp_state["joint_positions"],
            base_linear_velocity=v[:, :3],
            base_angular_velocity=v[:, 3:],
            joint_velocities=wp_state["joint_velocities"],
            velocity_representation=VelRepr.Inertial,
            num_envs=N,
            requires_grad=True,
        )
        data.tangential_deformation_state = wp_state["tangential_deformation"]
        _, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=wp_tau, record=RECORDS)
        weights = {k: rng.normal(size=rec[k].shape) for k in RECORDS}
        loss = gradcheck.weighted_sum([rec[k] for k in RECORDS], [wp.array(weights[k], dtype=wp.float64) for k in RECORDS])
    tape.backward(loss)
    expected = {k: a.grad.numpy().copy() for k, a in wp_state.items()}
    expected["tau"] = wp_tau.grad.numpy().copy()
    expected.update({k: a.grad.numpy().copy() for k, a in params.items()})
    values = {k: a.numpy().copy() for k, a in params.items()}
    assert np.abs(rec["tangential_deformation"].numpy()).max() > 1e-4, "the feet lost their contacts"
    assert np.abs(rec["link_contact_forces"].numpy()).max() > 10.0

    # the bridge
    inputs = {k: _t(v, True) for k, v in state.items()}
    tau_t = _t(tau, True)
    torch_params = {k: _t(values[k], True) for k in names if k != "D"}
    out = wdt.rollout(
        model,
        steps=T,
        **inputs,
        joint_force_references=tau_t,
        parameters=torch_params,
        record=RECORDS,
        velocity_representation=VelRepr.Inertial,
    )
    for k in RECORDS:
        np.testing.assert_array_equal(out[k].detach().cpu().numpy(), rec[k].numpy(), err_msg=k)
    total = sum((torch.from_numpy(weights[k]).to(out[k].device) * out[k]).sum() for k in RECORDS)
    total.backward()
    got = {k: t.grad.cpu().numpy() for k, t in inputs.items()}
    got["tau"] = tau_t.grad.cpu().numpy()
    got.update({k: t.grad.cpu().numpy() for k, t in torch_params.items()})
    for k, e in expected.items():
        if k == "D":
            continue
        np.testing.assert_allclose(got[k], e, rtol=1e-12, atol=1e-12 * np.abs(e).max(), err_msg=k)
        assert np.abs(e).max() > 1e-6, f"{k}: the loss does not depend on it"
    for k, a in params.items():  # the model's own values and .grad are untouched by the bridge
        np.testing.assert_array_equal(a.numpy(), values[k])
        np.testing.assert_array_equal(a.grad.numpy(), expected[k])


# ------------------------------------------------------------------------------ torch training


def test_adam_on_torques_reduces_the_loss_and_frees_each_tape():
    """torch.optim.Adam on per-step torques (20 steps of the pendulum chain, dt 1 ms) to bring the final
    joint velocities to a target: the loss falls at every iteration, to under a quarter of its start in 12
    (observed 0.19; Adam then oscillates on this ill-conditioned least-squares problem), and each
    iteration's tape is freed as its backward pass returns (no leak in a training loop, no wait for the
    garbage collector), though the records live on."""
    model = _pendulum()
    n, T = model.dofs(), 20
    s0, v0 = _t([0.3, -0.2, 0.1]), _t([0.0, 0.5, -0.5])
    target = _t([1.0, -1.0, 0.5])
    tau = torch.zeros(T, n, dtype=F64, requires_grad=True)
    optimiser = torch.optim.Adam([tau], lr=0.1)
    losses, freed = [], []
    for _ in range(12):
        optimiser.zero_grad()
        rec = wdt.rollout(model, steps=T, joint_positions=s0, joint_velocities=v0, joint_force_references=tau, record="joint_velocities")
        taped = weakref.ref(rec["joint_velocities"].grad_fn.saved_tensors[0]._warpdyn_rollout)
        loss = (rec["joint_velocities"][-1] - target).square().sum()
        loss.backward()
        optimiser.step()
        losses.append(loss.item())
        freed.append(taped() is None)  # by reference counting, without gc.collect(): no cycles hold it
    assert all(b < a for a, b in zip(losses, losses[1:])), losses
    assert losses[-1] < 0.25 * losses[0], losses
    assert all(freed)
    with pytest.raises(RuntimeError, match="second time"):
        rec["joint_velocities"].sum().backward()  # torch's own error: the graph was freed with the tape


def test_gradients_reach_a_network_producing_the_torques():
    """Torques from a torch.nn.Linear of the initial state (a non-leaf input): the layer's weight gradient is
    the chain rule's outer product of d loss / d tau (from a call with tau as a leaf) and the layer's input
    (reference: that product; the same numbers, rtol 1e-12)."""
    model = _pendulum()
    n, T = model.dofs(), 5
    torch.manual_seed(0)
    net = torch.nn.Linear(2 * n, T * n, dtype=F64)
    s0, v0 = _t([0.2, -0.1, 0.4]), _t([0.3, 0.0, -0.2])
    x = torch.cat([s0, v0])

    def loss_of(tau):
        rec = wdt.rollout(model, steps=T, joint_positions=s0, joint_velocities=v0, joint_force_references=tau, record="joint_positions")
        return rec["joint_positions"][-1].square().sum()

    loss_of(net(x).reshape(T, n)).backward()
    tau = net(x).detach().reshape(T, n).requires_grad_()
    loss_of(tau).backward()
    expected = torch.outer(tau.grad.reshape(-1), x)
    torch.testing.assert_close(net.weight.grad, expected, rtol=1e-12, atol=0)
    torch.testing.assert_close(net.bias.grad, tau.grad.reshape(-1), rtol=1e-12, atol=0)
    assert float(net.weight.grad.abs().max()) > 1e-5  # observed 1e-4: the torques move the final positions


def test_repeated_calls_and_retained_graphs_do_not_accumulate():
    """Two calls on the same inputs give the same gradients (the second is not the sum of both), and two
    backward passes through one retained graph give the same gradients each time (tape zeroed between)."""
    model = _pendulum()
    n, T = model.dofs(), 5
    s0 = _t([0.1, 0.2, 0.3], True)
    tau = _t(np.linspace(-1, 1, T * n).reshape(T, n), True)
    mass = _t(model.link_mass.numpy(), True)

    def grads(retain=False):
        rec = wdt.rollout(model, steps=T, joint_positions=s0, joint_force_references=tau, parameters={"link_mass": mass}, record="joint_positions")
        loss = rec["joint_positions"].square().sum()
        first = torch.autograd.grad(loss, (s0, tau, mass), retain_graph=retain)
        return first, (torch.autograd.grad(loss, (s0, tau, mass)) if retain else None)

    a, _ = grads()
    b, _ = grads()
    c, d = grads(retain=True)
    for x, y, z, w in zip(a, b, c, d):
        assert float(x.abs().max()) > 1e-4
        torch.testing.assert_close(x, y, rtol=0, atol=0)
        torch.testing.assert_close(x, z, rtol=0, atol=0)
        torch.testing.assert_close(x, w, rtol=0, atol=0)


def test_parameters_are_functional_and_no_grad_skips_the_tape():
    """parameters={"link_mass": m} gives the records of a model whose link_mass is m (reference: a model
    with those masses through wd.simulation.rollout, bitwise) and leaves the model's masses as they were;
    under torch.no_grad the records are the same and nothing requires a gradient."""
    model, heavier = _pendulum(), _pendulum()
    T = 6
    masses = model.link_mass.numpy() * np.array([1.0, 1.5, 0.7, 2.0])
    heavier.link_mass = wp.array(masses, dtype=wp.float64)
    s0 = [0.3, -0.4, 0.2]
    _, expected = wd.simulation.rollout(heavier, wd.data.Data.build(heavier, joint_positions=s0), steps=T, record="joint_positions")
    before = model.link_mass.numpy().copy()
    m = _t(masses, True)
    rec = wdt.rollout(model, steps=T, joint_positions=_t(s0), parameters={"link_mass": m}, record="joint_positions")
    assert rec["joint_positions"].requires_grad
    np.testing.assert_array_equal(rec["joint_positions"].detach().cpu().numpy(), expected["joint_positions"].numpy())
    np.testing.assert_array_equal(model.link_mass.numpy(), before)
    with torch.no_grad():
        quiet = wdt.rollout(model, steps=T, joint_positions=_t(s0), parameters={"link_mass": m}, record=("joint_positions", "valid"))
    assert not quiet["joint_positions"].requires_grad and quiet["valid"].dtype == torch.int32
    np.testing.assert_array_equal(quiet["joint_positions"].cpu().numpy(), expected["joint_positions"].numpy())
    assert quiet["valid"].shape == (T + 1,) and bool(quiet["valid"].all())


# ------------------------------------------------------------------------------ errors


def test_errors_name_the_tensor():
    """Wrong dtype (TypeError), device (ValueError), shape (ValueError), unknown parameter names and
    parameters of the wrong shape (ValueError), non-tensors (TypeError), a call inside a wp.Tape, and a
    backward pass after a record was changed in place (the tape reads the states the records show)."""
    model = _pendulum()
    T = 2
    s0 = torch.zeros(3, dtype=F64)
    with pytest.raises(TypeError, match=r"joint_positions \(dtype torch.float32.*torch.float64"):
        wdt.rollout(model, steps=T, joint_positions=s0.float())
    with pytest.raises(ValueError, match=rf"joint_velocities \(dtype torch.float64, device meta.*model is on '{model.device}'"):
        wdt.rollout(model, steps=T, joint_positions=s0, joint_velocities=torch.zeros(3, dtype=F64, device="meta"))
    with pytest.raises(ValueError, match=r"joint_positions has shape \(4,\)"):
        wdt.rollout(model, steps=T, joint_positions=torch.zeros(4, dtype=F64))
    with pytest.raises(ValueError, match="disagree on the number of environments"):
        wdt.rollout(model, steps=T, joint_positions=torch.zeros(2, 3, dtype=F64), joint_velocities=torch.zeros(3, 3, dtype=F64))
    with pytest.raises(ValueError, match="joint_force_references has shape"):
        wdt.rollout(model, steps=T, joint_positions=s0, joint_force_references=torch.zeros(T + 1, 3, dtype=F64))
    with pytest.raises(ValueError, match=r"unknown model parameters \['link_masses'\]"):
        wdt.rollout(model, steps=T, joint_positions=s0, parameters={"link_masses": torch.ones(4, dtype=F64)})
    with pytest.raises(ValueError, match=r"parameters\['link_mass'\] has shape \(3,\), the model's link_mass \(4,\)"):
        wdt.rollout(model, steps=T, joint_positions=s0, parameters={"link_mass": torch.ones(3, dtype=F64)})
    with pytest.raises(ValueError, match=r"parameters\['friction_viscous'\] must be non-negative"):
        wdt.rollout(model, steps=T, joint_positions=s0, parameters={"friction_viscous": -torch.ones(3, dtype=F64)})
    with pytest.raises(TypeError, match="must be a torch.Tensor"):
        wdt.rollout(model, steps=T, joint_positions=np.zeros(3))
    with pytest.raises(RuntimeError, match="outside a wp.Tape"):
        with wp.Tape():
            wdt.rollout(model, steps=T, joint_positions=s0)
    s = wdt.rollout(model, steps=T, joint_positions=s0.clone().requires_grad_(), record="joint_positions")["joint_positions"]
    loss = s.square().sum()
    s.detach().mul_(2.0)
    with pytest.raises(RuntimeError, match="modified by an inplace operation"):
        loss.backward()


def test_importing_warpdyn_does_not_import_torch(tmp_path):
    code = "import sys, warpdyn; assert 'torch' not in sys.modules, 'torch was imported'"
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)  # the installed warpdyn
    assert result.returncode == 0, result.stderr
