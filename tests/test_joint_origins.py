"""Joint origins as kinematic parameters (issue 38, item 1): `wd.model.with_joint_origins` and `joint_origins`.

- The device's joint terms from the model's own origins equal those the model was built with (the host's
  warpdyn.types.model_constants.joint_motion_terms), for revolute, prismatic, ball and free joints, with pivots.
- A model given another description's joint origins moves, weighs and steps as that description's model: random
  trees whose movable joints' URDF origins are moved and turned.
- Gradients of a rollout's loss (the legs landing on soft ground) with respect to the origins' positions and
  rotations equal central differences (float64).
- Kinematic queries carry the origins' gradients when the data requires none.
- Bad input raises naming the argument and the joint.
"""

import contextlib
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


def dropped_legs(model, drop: float, joint_positions=None):
    """Two environments of the legs with their lowest collidable point `drop` [m] above the ground."""
    lowest = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, num_envs=2)).numpy()[..., 2].min()
    return wd.data.Data.build(model, num_envs=2, base_position=(0.0, 0.0, -lowest + drop), joint_positions=joint_positions)


def landing(model, data, positions, rotations) -> np.ndarray:
    """The base heights (31, 2) of a 30-step rollout with the given joint origins; where they are Warp arrays that
    require gradients, those of the final heights' sum are taken (tape.backward)."""
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        moved = wd.model.with_joint_origins(model, positions=positions, rotations=rotations)
        _, rec = wd.simulation.rollout(moved, data, steps=30, record=("base_position",))
        wp.launch(final_height, dim=2, inputs=[rec["base_position"]], outputs=[loss])
    tape.backward(loss)
    return rec["base_position"].numpy()[:, :, 2]


def test_gradients_reach_the_origins_through_a_rollout():
    """The legs dropped 2 cm onto soft ground, 30 steps: the gradient of the final base heights with respect to the
    knee's and ankle's origins (positions and rotation quaternions) equals central differences (h = 1e-6: 1e-6
    relative)."""
    model = legs()
    positions, rotations = wd.model.joint_origins(model)
    data = dropped_legs(model, 0.02, np.random.default_rng(3).uniform(-0.1, 0.1, (2, model.dofs())))
    P = wp.array(positions, dtype=wp.float64, requires_grad=True)
    R = wp.array(rotations, dtype=wp.float64, requires_grad=True)
    landing(model, data, P, R)

    def height(p, r):
        return landing(model, data, p, r)[-1].sum()

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


QUERIES = {
    "forward_kinematics": lambda model, data: wd.model.forward_kinematics(model, data),
    "generalized_free_floating_jacobian": lambda model, data: wd.model.generalized_free_floating_jacobian(model, data),
    "collidable_point_positions": lambda model, data: wd.contact.collidable_point_positions(model, data),
}


@pytest.mark.parametrize("query", QUERIES)
def test_queries_carry_the_origins_gradients_when_the_data_does_not(query):
    """With the origins alone requiring gradients (the data not), a kinematic query's output carries them: the
    gradient of a weighted sum of it with respect to the knee's origin equals central differences (h = 1e-6:
    1e-7 relative). Before, the output was made with the data's requires_grad and no gradient flowed."""
    model = legs()
    positions, _ = wd.model.joint_origins(model)
    data = wd.data.Data.build(model, joint_positions=np.random.default_rng(4).uniform(-0.5, 0.5, model.dofs()))
    P = wp.array(positions, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        out = QUERIES[query](wd.model.with_joint_origins(model, positions=P), data)
    weights = np.random.default_rng(5).normal(size=out.shape)
    out.grad.assign(wp.array(weights, dtype=wp.float64))
    tape.backward()
    knee, h = (model.joint_names().index("l_knee"), 2), 1e-6

    def loss(shift: float) -> float:
        moved = positions.copy()
        moved[knee] += shift
        return float(np.sum(weights * QUERIES[query](wd.model.with_joint_origins(model, positions=moved), data).numpy()))

    fd = (loss(h) - loss(-h)) / (2 * h)
    assert abs(fd) > 1e-3 and abs(P.grad.numpy()[knee] - fd) <= 1e-7 * abs(fd), (P.grad.numpy()[knee], fd)


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


def moved_origins(model, seed: int, N: int) -> tuple[np.ndarray, np.ndarray]:
    """(N, nj, 3) and (N, nj, 4): the model's joint origins moved by up to 3 cm and turned by up to 0.1 rad per
    environment (a free joint's kept: its origin is one for all environments)."""
    positions, rotations = wd.model.joint_origins(model)
    rng = np.random.default_rng(seed)
    P = positions + rng.uniform(-0.03, 0.03, (N, *positions.shape))
    R = rotations + rng.uniform(-0.05, 0.05, (N, *rotations.shape))
    free = np.asarray(model.tree.joint_type)[1:] == wd.description.tree.JOINT_FREE
    P[:, free], R[:, free] = positions[free], rotations[free]
    return P, R / np.linalg.norm(R, axis=2, keepdims=True)


@pytest.mark.parametrize("source", ["random tree", "ball", "free trees"])
def test_origins_per_environment_equal_one_shared_model_each(source):
    """Origins given for 3 environments: every environment's link poses, mass matrix, forward dynamics, inverse
    dynamics and step equal those of the model whose shared origins are that environment's (float64, 1e-12 of
    each quantity's largest entry; revolute, prismatic, ball and free joints, a floating base)."""
    if source == "random tree":
        model = wd.model.Model.build_from_model_description(robots.random_tree_urdf(5, 10), dtype=np.float64)
    else:
        with pytest.warns(wd.description.NotModelledWarning) if source == "free trees" else contextlib.nullcontext():
            model = wd.model.Model.build_from_model_description({"ball": BALL, "free trees": FREE_TREES}[source], dtype=np.float64)
    P, R = moved_origins(model, 7, 3)
    per_env = wd.model.with_joint_origins(model, positions=P, rotations=R)
    assert per_env.per_environment_parameters() == {"joint_origins": 3}
    np.testing.assert_array_equal(wd.model.joint_origins(per_env)[0], P)
    data = wd.data.random_model_data(model, key=3, num_envs=3)
    tau = wp.array(np.random.default_rng(4).normal(size=(3, model.dofs())), dtype=wp.float64)
    quantities = {
        "link poses": lambda m: wd.model.forward_kinematics(m, data),
        "mass matrix": lambda m: wd.model.free_floating_mass_matrix(m, data),
        "forward dynamics": lambda m: wd.model.forward_dynamics_aba(m, data, joint_forces=tau)[1],
        "inverse dynamics": lambda m: wd.model.inverse_dynamics(m, data)[1],
        "step": lambda m: wd.model.step(m, data, joint_force_references=tau).joint_velocities,
    }
    for name, compute in quantities.items():
        batched = compute(per_env).numpy()
        for env in range(3):
            shared = compute(wd.model.with_joint_origins(model, positions=P[env], rotations=R[env])).numpy()[env]
            np.testing.assert_allclose(batched[env], shared, rtol=0, atol=1e-12 * max(np.abs(shared).max(), 1.0), err_msg=f"{name}, environment {env}")
        assert np.abs(batched[1] - batched[0]).max() > 1e-6 or name == "step" and model.dofs() == 0, name  # the origins matter


def test_origins_per_environment_in_the_fused_step_and_gradients():
    """The legs dropped onto soft ground with their knees' and ankles' origins per environment (2 environments):
    a 30-step rollout (the fused step) equals each environment's shared-origin rollout to 1e-12, and the gradient of
    the final base heights with respect to the per-environment origins equals central differences (h = 1e-7: the
    feet's contacts begin within the rollout, and h = 1e-6 is 1.7e-5 off for the ankle, as for shared origins) within
    1e-6 of the derivative plus the differences' rounding, 100 eps |sum of heights| / h (about 2e-8: on a GPU the
    sums round otherwise than on the CPU, and the knee's derivative, 3.6e-3, was 5e-9 from its differences)."""
    model = legs()
    P, R = moved_origins(model, 11, 2)
    data = dropped_legs(model, 0.03)
    positions = wp.array(P, dtype=wp.float64, requires_grad=True)
    heights = landing(model, data, positions, R)
    for env in range(2):
        alone = landing(model, data, P[env], R[env])
        np.testing.assert_allclose(heights[:, env], alone[:, env], rtol=0, atol=1e-12)
    assert abs(heights[-1, 1] - heights[-1, 0]) > 1e-5

    knee, ankle = model.joint_names().index("l_knee"), model.joint_names().index("r_ankle_pitch")
    for index in ((0, knee, 2), (1, knee, 2), (1, ankle, 0)):
        plus, minus = P.copy(), P.copy()
        plus[index] += 1e-7
        minus[index] -= 1e-7
        high, low = landing(model, data, plus, R)[-1].sum(), landing(model, data, minus, R)[-1].sum()
        fd = (high - low) / 2e-7
        rounding = 100 * np.finfo(np.float64).eps * abs(high) / 1e-7
        assert abs(positions.grad.numpy()[index] - fd) <= 1e-6 * abs(fd) + rounding and abs(fd) > 1e-6, (index, positions.grad.numpy()[index], fd)


def test_origins_per_environment_refusals():
    """Per-environment origins name what does not fit: another N than the other per-environment parameters, a
    free joint whose origin differs between environments, data of another N, export and the hardware
    parametrisation (which set one model's origins)."""
    model = legs()
    P, R = moved_origins(model, 2, 3)
    with pytest.raises(ValueError, match=r"positions are given for 3 environments, rotations for 2"):
        wd.model.with_joint_origins(model, positions=P, rotations=R[:2])
    with pytest.raises(ValueError, match=r"expected \(12, 3\) \(one row per joint, shared by the environments\) or \(N, 12, 3\)"):
        wd.model.with_joint_origins(model, positions=P[:, :-1])
    bad = P.copy()
    bad[2, 5, 0] = np.inf
    with pytest.raises(ValueError, match=f"positions of joint '{model.joint_names()[5]}' in environment 2 is"):
        wd.model.with_joint_origins(model, positions=bad)
    heavy = model.copy()
    heavy.set_link_parameters(mass=np.tile(heavy.link_mass.numpy(), (2, 1)))
    with pytest.raises(ValueError, match=r"joint origins are given for 3 environments but \{'link_mass': 2\}"):
        wd.model.with_joint_origins(heavy, positions=P)
    per_env = wd.model.with_joint_origins(model, positions=P)
    np.testing.assert_array_equal(wd.model.joint_origins(per_env)[1], np.broadcast_to(wd.model.joint_origins(model)[1], (3, 12, 4)))
    with pytest.raises(ValueError, match=r"parameters \{'joint_origins': 3\} are given per environment, but the data has 2 environments"):
        wd.model.step(per_env, wd.data.Data.build(model, num_envs=2))
    with pytest.raises(ValueError, match=r"\{'joint_origins': 3\} are given per environment, but the data has 1 environments"):
        wd.model.forward_kinematics(per_env, wd.data.Data.build(model))
    with pytest.raises(ValueError, match=r"export_updated_model: \['joint_origins'\] are given per environment"):
        per_env.export_updated_model()
    with pytest.warns(wd.description.NotModelledWarning):
        trees = wd.model.Model.build_from_model_description(FREE_TREES, dtype=np.float64)
    Pf, Rf = moved_origins(trees, 3, 2)
    crate = trees.joint_names().index("crate_free")
    Pf[1, crate, 0] += 0.1
    with pytest.raises(ValueError, match="the free joint 'crate_free' has other origins in other environments"):
        wd.model.with_joint_origins(trees, positions=Pf, rotations=Rf)


def test_origins_survive_actuators_and_a_model_without_joints():
    """add_actuators keeps the joints where with_joint_origins put them (its host tree, which export writes, too); a
    model without joints takes (0, 3) and (0, 4) origins."""
    model = legs()
    P, R = moved_origins(model, 4, 1)
    moved = wd.model.with_joint_origins(model, positions=P[0], rotations=R[0])
    acted = wd.model.add_actuators(moved, "motor")
    np.testing.assert_allclose(wd.model.joint_origins(acted)[0], P[0], rtol=0, atol=1e-15)
    data = wd.data.random_model_data(model, key=1, num_envs=2)
    np.testing.assert_allclose(wd.model.forward_kinematics(acted, data).numpy(), wd.model.forward_kinematics(moved, data).numpy(), rtol=0, atol=1e-14)
    single = wd.model.Model.build_from_model_description("""<robot name="one"><link name="only"><inertial><mass value="1"/>
        <inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>""", dtype=np.float64)
    same = wd.model.with_joint_origins(single, positions=np.zeros((0, 3)), rotations=np.zeros((0, 4)))
    assert same.number_of_joints() == 0 and same.per_environment_parameters() == {}


def test_the_contact_reach_counts_every_environments_origins():
    """A fixed-base leg whose sole is 5 mm above the ground in environment 0 but reaches it with a longer shank in
    environment 1: the soft law's deformation check (dt K / D) applies, as it would for a model with environment 1's
    origins alone."""
    W_H_B = np.eye(4)
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), fixed_base=True, base_pose=W_H_B, dtype=np.float64)
    model = wd.model.reduce(full, considered_joints=["r_hip_pitch", "r_knee", "r_ankle_pitch"])
    positions = wd.model.joint_origins(model)[0]
    reach = wd.engine.stability.contact_reach(model).reach
    lift = np.eye(4)
    lift[2, 3] = reach + 0.005
    model = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), fixed_base=True, base_pose=lift, dtype=np.float64)
    model = wd.model.reduce(model, considered_joints=["r_hip_pitch", "r_knee", "r_ankle_pitch"])
    assert not wd.engine.stability.contact_reach(model).may_touch
    longer = positions.copy()
    longer[model.joint_names().index("r_knee")] *= 1.2
    per_env = wd.model.with_joint_origins(model, positions=np.stack([positions, longer]))
    assert wd.engine.stability.contact_reach(per_env).may_touch
