"""Reverse-mode gradients (wp.Tape, float64) of the kinematics façade against central finite differences.

Each test runs a façade call inside `wp.Tape`, reduces its output to a scalar with a weighted sum (fixed
random weights, a Warp kernel of this file), calls `tape.backward` and compares the gradients of every
state array with central finite differences of the same scalar. The finite differences perturb one
component of the raw state at a time (the quaternion's raw (w, x, y, z) components too, with
validate=False, the kernels evaluating the non-unit quaternion exactly as the tape differentiates it);
all perturbed states run as the environments of one batched launch.

Tolerance, unless a test says otherwise: 1e-6 relative to the largest gradient (at least 1). Central
differences with step h = 1e-6 in float64 carry a truncation error ~h^2·|f'''| ~1e-12 and a rounding
error ~1e-16·|f|/h ~1e-9 for losses of size ~10 (observed ≤ 1e-8).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
import warp as wp

import gradcheck
import robots
import warpdyn as wd
from warpdyn import VelRepr

STEP = 1e-6
RTOL = 1e-6
FIELDS = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")


def _weighted_sum(x: wp.array, weights: np.ndarray) -> wp.array:
    """loss (1,) = sum(x * weights), launched (so recorded by an active tape)."""
    assert tuple(x.shape) == weights.shape, (x.shape, weights.shape)
    return gradcheck.weighted_sum([x], [wp.array(weights, dtype=wp.float64, device=x.device)])


@functools.cache
def _model(name: str) -> wd.model.Model:
    if name == "tree0":
        return wd.model.Model.build_from_model_description(robots.random_tree_urdf(0), dtype=np.float64)
    if name == "fixed2":
        return wd.model.Model.build_from_model_description(robots.random_tree_urdf(2, fixed_base=True), dtype=np.float64)
    if name == "icub_legs":
        urdf = robots.icub_urdf()
        full = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        return wd.model.Model.build_from_model_description(
            urdf, considered_joints=robots.icub_leg_joints(full.joint_names()), dtype=np.float64
        )
    raise KeyError(name)


def _random_state(model, rng, N: int) -> dict:
    """Host state (N environments): base pose, joints, base velocity in Mixed, joint velocities."""
    n = model.dofs()
    if model.floating_base():
        p = rng.uniform(-1.0, 1.0, size=(N, 3))
        q = rng.normal(size=(N, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        v = rng.uniform(-1.0, 1.0, size=(N, 6))
    else:
        H = model.description.world_H_base
        p, q = np.tile(H[:3, 3], (N, 1)), np.tile(wd.data._quaternion_wxyz(H[:3, :3]), (N, 1))
        v = np.zeros((N, 6))
    return {
        "base_position": p,
        "base_quaternion": q,
        "joint_positions": rng.uniform(-1.5, 1.5, size=(N, n)),
        "base_velocity": v,
        "joint_velocities": rng.uniform(-1.0, 1.0, size=(N, n)),
    }


def _build(model, state: dict, num_envs, requires_grad=False) -> wd.data.Data:
    """Data of a host state whose base velocity is the Mixed state (so the stored state is `state`).

    state: arrays with a leading environment axis (of length 1 for num_envs=None).
    """
    if num_envs is None:
        state = {f: v[0] for f, v in state.items()}
    return wd.data.Data.build(
        model,
        base_position=state["base_position"],
        base_quaternion=state["base_quaternion"],
        joint_positions=state["joint_positions"],
        base_linear_velocity=state["base_velocity"][..., :3],
        base_angular_velocity=state["base_velocity"][..., 3:],
        joint_velocities=state["joint_velocities"],
        velocity_representation=VelRepr.Mixed,
        num_envs=num_envs,
        requires_grad=requires_grad,
        validate=False,
    )


def _fields(model) -> tuple[str, ...]:
    """The state arrays to differentiate: a fixed-base model's base velocity must stay zero, so not it."""
    return FIELDS if model.floating_base() else tuple(f for f in FIELDS if f != "base_velocity")


def _finite_differences(model, state1: dict, function, weights: np.ndarray, repr_) -> dict:
    """Central differences of sum(function(model, data) * weights) w.r.t. every state component.

    state1: a one-environment state (leading axis 1); the data reads velocities in repr_. All 2·K
    perturbations run batched.
    """
    fields = _fields(model)
    columns = [(f, k) for f in fields for k in range(state1[f].shape[1])]
    K = len(columns)
    batch = {f: np.repeat(v, 2 * K, axis=0) for f, v in state1.items()}
    for c, (f, k) in enumerate(columns):
        batch[f][2 * c, k] += STEP
        batch[f][2 * c + 1, k] -= STEP
    data = _build(model, batch, 2 * K)
    with data.switch_velocity_representation(repr_):
        out = function(model, data).numpy().reshape(2 * K, *weights.shape)
    losses = (out * weights).reshape(2 * K, -1).sum(axis=1)
    fd = (losses[0::2] - losses[1::2]) / (2.0 * STEP)
    grads = {f: np.zeros(state1[f].shape[1]) for f in fields}
    for c, (f, k) in enumerate(columns):
        grads[f][k] = fd[c]
    return grads


def _tape_gradients(model, state1: dict, function, weights: np.ndarray, repr_) -> dict:
    data = _build(model, state1, None, requires_grad=True)
    data.velocity_representation = repr_
    with wp.Tape() as tape:
        out = function(model, data)
        loss = _weighted_sum(out, weights)
    tape.backward(loss)
    return {f: getattr(data, f"{f}_state").grad.numpy()[0] for f in _fields(model)}


def _check(model, function, repr_, rng, what: str):
    state1 = _random_state(model, rng, 1)
    probe = _build(model, state1, None)
    probe.velocity_representation = repr_
    weights = rng.normal(size=tuple(function(model, probe).shape))
    fd = _finite_differences(model, state1, function, weights, repr_)
    tape = _tape_gradients(model, state1, function, weights, repr_)
    scale = max(1.0, max(float(np.abs(g).max()) for g in fd.values()))
    for f in _fields(model):
        np.testing.assert_allclose(tape[f], fd[f], rtol=0, atol=RTOL * scale, err_msg=f"{what}: d loss / d {f}_state")
    return fd


# ---------------------------------------------------------------------------------------- functions

def _fk(model, data):
    return wd.model.forward_kinematics(model, data)


def _relative_link_transforms(model, data):
    return wd.model.relative_link_transforms(model, data)


def _jacobian(out_repr):
    def f(model, data):
        return wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=out_repr)

    return f


def _link_velocity(out_repr):
    def f(model, data):
        return wd.link.velocity(model, data, link_index=model.number_of_links() - 1, output_vel_repr=out_repr)

    return f


def _link_jacobian(model, data):
    return wd.link.jacobian(model, data, link_index=model.number_of_links() - 1)


def _deep_frame(model) -> int:
    """The index of a frame on the deepest link that carries one (so that it moves with joints)."""
    k = int(np.argmax(model.tree.frame_parent))
    return model.number_of_links() + k


def _frame_velocity(model, data):
    return wd.frame.velocity(model, data, frame_index=_deep_frame(model))


def _frame_jacobian(model, data):
    return wd.frame.jacobian(model, data, frame_index=_deep_frame(model), output_vel_repr=VelRepr.Body)


def _frame_transform(model, data):
    return wd.frame.transform(model, data, frame_index=_deep_frame(model))


def _generalized_velocity(model, data):
    return data.generalized_velocity


CASES = {
    "forward_kinematics": (_fk, VelRepr.Mixed),
    "relative_link_transforms": (_relative_link_transforms, VelRepr.Mixed),
    "jacobian_mixed_mixed": (_jacobian(VelRepr.Mixed), VelRepr.Mixed),
    "jacobian_body_inertial": (_jacobian(VelRepr.Inertial), VelRepr.Body),
    "jacobian_inertial_body": (_jacobian(VelRepr.Body), VelRepr.Inertial),
    "link_jacobian_body": (_link_jacobian, VelRepr.Body),
    "link_velocity_mixed_body": (_link_velocity(VelRepr.Body), VelRepr.Mixed),
    "link_velocity_inertial": (_link_velocity(VelRepr.Inertial), VelRepr.Body),
    "frame_velocity_body": (_frame_velocity, VelRepr.Body),
    "frame_jacobian_body_output": (_frame_jacobian, VelRepr.Inertial),
    "frame_transform": (_frame_transform, VelRepr.Mixed),
    "generalized_velocity_body": (_generalized_velocity, VelRepr.Body),
}


@pytest.mark.parametrize("name", ("tree0", "fixed2", "icub_legs"))
@pytest.mark.parametrize("case", list(CASES))
def test_tape_gradient_equals_finite_differences(name, case, layout):
    """d(sum(w · output))/d state by wp.Tape equals central finite differences, for every state array.

    Reference: central differences (h = 1e-6, float64) of the same façade call on the perturbed raw state
    (joint positions and velocities, base position, raw quaternion components, the stored Mixed base
    velocity); state arrays an output does not depend on must get a zero gradient (FD gives 0 too).
    Tolerance 1e-6 relative to the largest gradient: see the module docstring.
    """
    model = _model(name)
    function, repr_ = CASES[case]
    rng = np.random.default_rng(100 + 7 * list(CASES).index(case) + ("tree0", "fixed2", "icub_legs").index(name))
    fd = _check(model, function, repr_, rng, f"{case} on {name}")
    # The test must be able to fail: the loss depends on the configuration at all.
    assert np.abs(fd["joint_positions"]).max() > 1e-3 or case == "generalized_velocity_body"


@pytest.mark.parametrize(
    "prop, repr_",
    [("base_transform", VelRepr.Mixed), ("base_orientation", VelRepr.Mixed), ("base_velocity", VelRepr.Body),
     ("base_velocity", VelRepr.Inertial)],
)
def test_tape_gradient_of_data_properties(prop, repr_):
    """Gradients flow through Data's derived properties (base_transform, base_orientation, base_velocity).

    Reference: central finite differences (h = 1e-6, float64) of the property on perturbed raw states
    (the quaternion's raw components: base_orientation normalises them, base_transform rotates by them).
    A property whose output array is created without requires_grad silently returns zero gradients,
    which this test catches. Tolerance 1e-6 relative: see the module docstring.
    """
    model = _model("tree0")
    rng = np.random.default_rng(300 + len(prop) + int(repr_))
    fd = _check(model, lambda m, d: getattr(d, prop), repr_, rng, prop)
    assert max(np.abs(fd["base_quaternion"]).max(), np.abs(fd["base_position"]).max()) > 1e-3  # depends on the pose


# ------------------------------------------------------------------------ gradients into user arrays


def _user_array_case(model, rng, fields, N):
    """Tape gradients into user wp.arrays passed to Data.build, and the FD of the same map.

    Returns (tape grads, fd grads) per field. The base velocity is given in the Body representation, so
    its gradient also runs through the conversion to the stored Mixed velocity.
    """
    n = model.dofs()
    base = _random_state(model, rng, 1)
    host = {
        "base_position": base["base_position"][0],
        "base_quaternion": base["base_quaternion"][0],
        "joint_positions": rng.uniform(-1.5, 1.5, size=(N, n)),  # per environment
        "base_linear_velocity": rng.uniform(-1, 1, size=3),
        "base_angular_velocity": rng.uniform(-1, 1, size=3),
        "joint_velocities": rng.uniform(-1, 1, size=n),  # shared by all environments
    }
    last = model.number_of_links() - 1

    def evaluate(values, num_envs):
        data = wd.data.Data.build(model, **values, velocity_representation=VelRepr.Body, num_envs=num_envs,
                                  requires_grad=True, validate=False)
        return wd.link.velocity(model, data, link_index=last, output_vel_repr=VelRepr.Inertial)

    weights = rng.normal(size=(N, 6))
    user = {k: wp.array(v, dtype=wp.float64, requires_grad=True) if k in fields else v for k, v in host.items()}
    with wp.Tape() as tape:
        loss = _weighted_sum(evaluate(user, N), weights)
    tape.backward(loss)
    tape_grads = {k: user[k].grad.numpy() for k in fields}

    fd_grads = {}
    for k in fields:
        g = np.zeros(host[k].shape)
        for idx in np.ndindex(host[k].shape):
            losses = []
            for sign in (1.0, -1.0):
                values = dict(host)
                values[k] = host[k].copy()
                values[k][idx] += sign * STEP
                losses.append(float(np.sum(evaluate(values, N).numpy() * weights)))
            g[idx] = (losses[0] - losses[1]) / (2.0 * STEP)
        fd_grads[k] = g
    return tape_grads, fd_grads


@pytest.mark.parametrize(
    "field",
    ["joint_positions", "joint_velocities", "base_position", "base_quaternion", "base_linear_velocity",
     "base_angular_velocity"],
)
def test_gradient_flows_into_user_arrays_passed_to_build(field, layout):
    """A wp.array(requires_grad=True) given to Data.build inside the tape receives d loss / d input.

    The copy into the state is a kernel, so the tape should carry the gradient to the user's array: a
    per-environment (N, n) array (joint_positions), a shared (n,) array broadcast to N = 3 environments
    (joint_velocities: its gradient is the sum over environments), the base pose, and base velocities
    given in the Body representation (through the conversion to the stored Mixed state). Reference:
    central finite differences (h = 1e-6) of the whole map input -> Data.build -> link velocity -> loss.
    Tolerance 1e-6 relative: see the module docstring.
    """
    model = _model("tree0")
    rng = np.random.default_rng(400 + len(field))
    tape_grads, fd_grads = _user_array_case(model, rng, [field], 3)
    scale = max(1.0, float(np.abs(fd_grads[field]).max()))
    assert np.abs(fd_grads[field]).max() > 1e-3  # the loss depends on this input
    np.testing.assert_allclose(tape_grads[field], fd_grads[field], rtol=0, atol=RTOL * scale, err_msg=field)


# --------------------------------------------------------------------------- no leak between envs


@pytest.mark.parametrize("case", ["forward_kinematics", "jacobian_body_inertial", "link_velocity_inertial",
                                  "generalized_velocity_body"])
def test_gradients_do_not_leak_between_environments(case, layout):
    """With N = 3 and a loss on environment 1 only, environments 0 and 2 get exactly zero gradients, and
    environment 1 gets what single-environment data of the same state gets.

    Reference: exact zeros (no arithmetic reaches them), and the tape gradient of the single-environment
    data (same kernels, same state: equal to 1e-12 relative, the reduction order of the weighted sum
    being the only difference).
    """
    model = _model("icub_legs")
    function, repr_ = CASES[case]
    rng = np.random.default_rng(500 + len(case))
    N = 3
    state = _random_state(model, rng, N)
    data = _build(model, state, N, requires_grad=True)
    data.velocity_representation = repr_
    probe = function(model, data)
    weights = np.zeros(tuple(probe.shape))
    weights[1] = rng.normal(size=weights.shape[1:])
    with wp.Tape() as tape:
        loss = _weighted_sum(function(model, data), weights)
    tape.backward(loss)
    single = _tape_gradients(model, {f: v[1:2] for f, v in state.items()}, function, weights[1], repr_)
    nonzero = False
    for f in _fields(model):
        g = getattr(data, f"{f}_state").grad.numpy()
        np.testing.assert_array_equal(g[[0, 2]], 0.0, err_msg=f"{case}: {f} gradient leaked into envs 0 and 2")
        np.testing.assert_allclose(g[1], single[f], rtol=0, atol=1e-12 * max(1.0, np.abs(single[f]).max()),
                                   err_msg=f"{case}: {f}, env 1 vs single env")
        nonzero |= bool(np.abs(g[1]).max() > 1e-3)
    assert nonzero
