"""Joint origins as kinematic parameters (issue 38, item 1): `wd.model.with_joint_origins` and `joint_origins`.

- The device's joint terms from the model's own origins equal those the model was built with (the host's
  warpdyn.types.model_constants.joint_motion_terms), for revolute, prismatic, ball and free joints, with pivots.
- A model given another description's joint origins moves, weighs and steps as that description's model: random
  trees whose movable joints' URDF origins are moved and turned.
- Gradients of a rollout's loss (the legs landing on soft ground) with respect to the origins' positions and
  rotations equal central differences (float64).
- Bad input raises naming the argument and the joint.
"""

import xml.etree.ElementTree as ET

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from mjcf_fixtures import BALL, DAMPING
from test_fused_step import FREE_TREES

TERMS = ("joint_Q0", "joint_Q1", "joint_t0", "joint_t1", "joint_t2")


def legs(dtype=np.float64):
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=dtype)
    return wd.model.reduce(full, considered_joints=wd.assets.ERGOCUB_LEG_JOINTS)


@pytest.mark.parametrize("source", ["legs", "ball", "slide", "free trees", "random tree"])
def test_the_devices_joint_terms_equal_the_hosts(source, dtype):
    """with_joint_origins(model, *joint_origins(model)) computes on the device the terms the model holds (the
    host's formulas): to rounding of the rotation's normalisation (1e-15 in float64, 1e-6 in float32)."""
    if source == "legs":
        model = legs(dtype)
    elif source == "random tree":
        model = wd.model.Model.build_from_model_description(robots.random_tree_urdf(4, 12), dtype=dtype)
    else:
        model = wd.model.Model.build_from_model_description({"ball": BALL, "slide": DAMPING, "free trees": FREE_TREES}[source], dtype=dtype)
    positions, rotations = wd.model.joint_origins(model)
    assert positions.shape == (model.number_of_joints(), 3) and rotations.shape == (model.number_of_joints(), 4)
    same = wd.model.with_joint_origins(model, positions=positions, rotations=rotations)
    tolerance = 1e-14 if dtype == np.float64 else 2e-6
    for name in TERMS:
        np.testing.assert_allclose(getattr(same, name).numpy(), getattr(model, name).numpy(), rtol=0, atol=tolerance, err_msg=name)
    np.testing.assert_allclose(wd.model.joint_origins(same)[0], positions, rtol=0, atol=1e-15)


def moved_urdf(text: str, seed: int) -> str:
    """The URDF with its movable joints' origins moved (up to 0.1 m) and turned (up to 0.3 rad per angle)."""
    rng = np.random.default_rng(seed)
    root = ET.fromstring(text)
    for joint in root.findall("joint"):
        if joint.get("type") == "fixed":
            continue
        origin = joint.find("origin")
        xyz = np.array([float(v) for v in origin.get("xyz").split()]) + rng.uniform(-0.1, 0.1, 3)
        rpy = np.array([float(v) for v in origin.get("rpy").split()]) + rng.uniform(-0.3, 0.3, 3)
        origin.set("xyz", " ".join(f"{v:.17g}" for v in xyz))
        origin.set("rpy", " ".join(f"{v:.17g}" for v in rpy))
    return ET.tostring(root, encoding="unicode")


@pytest.mark.parametrize("seed", [1, 2])
def test_moved_origins_equal_the_moved_description(seed):
    """A random tree (revolute, prismatic, fixed and continuous joints, floating base) given the joint origins of
    the same tree with its movable joints moved and turned in the URDF: link poses, mass matrix and a step equal
    those of the moved URDF's model (float64, 1e-12)."""
    text = robots.random_tree_urdf(seed, 10)
    model = wd.model.Model.build_from_model_description(text, dtype=np.float64)
    moved = wd.model.Model.build_from_model_description(moved_urdf(text, seed), dtype=np.float64)
    assert np.abs(wd.model.joint_origins(moved)[0] - wd.model.joint_origins(model)[0]).max() > 0.01
    given = wd.model.with_joint_origins(model, positions=wd.model.joint_origins(moved)[0], rotations=wd.model.joint_origins(moved)[1])
    data = wd.data.random_model_data(moved, key=seed, num_envs=3)
    np.testing.assert_allclose(wd.model.forward_kinematics(given, data).numpy(), wd.model.forward_kinematics(moved, data).numpy(), rtol=0, atol=1e-12)
    np.testing.assert_allclose(wd.model.free_floating_mass_matrix(given, data).numpy(), wd.model.free_floating_mass_matrix(moved, data).numpy(),
                               rtol=0, atol=1e-12 * np.abs(wd.model.free_floating_mass_matrix(moved, data).numpy()).max())
    after_given, after_moved = wd.model.step(given, data), wd.model.step(moved, data)
    for name in ("joint_velocities", "base_velocity", "joint_positions"):
        np.testing.assert_allclose(getattr(after_given, name).numpy(), getattr(after_moved, name).numpy(), rtol=0, atol=1e-9, err_msg=name)
    np.testing.assert_allclose(wd.model.joint_origins(given)[1], wd.model.joint_origins(moved)[1], rtol=0, atol=1e-15)


@wp.kernel
def final_height(p: wp.array3d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    """loss += the base height after the last step, summed over the environments."""
    env = wp.tid()
    wp.atomic_add(loss, 0, p[p.shape[0] - 1, env, 2])


def test_gradients_reach_the_origins_through_a_rollout():
    """The legs dropped 2 cm onto soft ground, 30 steps: the gradient of the final base heights with respect to the
    knee's and ankle's origins (positions and rotation quaternions) equals central differences (h = 1e-6: 1e-6
    relative)."""
    model = legs()
    positions, rotations = wd.model.joint_origins(model)
    zero = wd.data.Data.build(model, num_envs=2)
    lowest = wd.contact.collidable_point_positions(model, zero).numpy()[..., 2].min()
    rng = np.random.default_rng(3)
    data = wd.data.Data.build(model, num_envs=2, base_position=(0.0, 0.0, -lowest + 0.02), joint_positions=rng.uniform(-0.1, 0.1, (2, model.dofs())))
    P = wp.array(positions, dtype=wp.float64, requires_grad=True)
    R = wp.array(rotations, dtype=wp.float64, requires_grad=True)
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        moved = wd.model.with_joint_origins(model, positions=P, rotations=R)
        _, rec = wd.simulation.rollout(moved, data, steps=30, record=("base_position",))
        wp.launch(final_height, dim=2, inputs=[rec["base_position"]], outputs=[loss])
    tape.backward(loss)

    def height(p, r):
        _, out = wd.simulation.rollout(wd.model.with_joint_origins(model, positions=p, rotations=r), data, steps=30, record=("base_position",))
        return out["base_position"].numpy()[-1, :, 2].sum()

    knee = model.joint_names().index("l_knee")
    ankle = model.joint_names().index("r_ankle_pitch")
    h = 1e-6
    for grad, value, index in ((P, positions, (knee, 2)), (P, positions, (ankle, 0)), (R, rotations, (knee, 1)), (R, rotations, (ankle, 3))):
        plus, minus = value.copy(), value.copy()
        plus[index] += h
        minus[index] -= h
        args = (lambda v: (v, rotations)) if grad is P else (lambda v: (positions, v))
        fd = (height(*args(plus)) - height(*args(minus))) / (2 * h)
        assert abs(grad.grad.numpy()[index] - fd) <= 1e-6 * abs(fd) + 1e-9, (index, grad.grad.numpy()[index], fd)
        assert abs(fd) > 1e-6  # the origin moves the result: a zero gradient would pass the first check


def test_bad_origins_raise_naming_the_joint():
    model = legs()
    positions, rotations = wd.model.joint_origins(model)
    with pytest.raises(ValueError, match=r"positions has shape \(11, 3\), expected \(12, 3\)"):
        wd.model.with_joint_origins(model, positions=positions[:-1])
    bad = rotations.copy()
    bad[4] = 0.0
    with pytest.raises(ValueError, match=f"rotations of joint '{model.joint_names()[4]}' is \\[0.0, 0.0, 0.0, 0.0\\]"):
        wd.model.with_joint_origins(model, rotations=bad)
    bad = positions.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match=f"positions of joint '{model.joint_names()[2]}'"):
        wd.model.with_joint_origins(model, positions=bad)
    with pytest.raises(TypeError):
        wd.model.with_joint_origins(model, positions=wp.array(positions, dtype=wp.float32))
