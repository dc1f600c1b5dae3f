"""References (link and frame forces, joint force references) and the data's contact state.

Reference: the power a wrench delivers does not depend on the representation it is written in, so for a
link (or frame) force f and the velocity v of the same body frame, f . v is the same in Body, Mixed and
Inertial; a frame force moved to its parent link delivers the same power there. float64 sums of a few
products of O(10) numbers: 1e-12.
"""

import numpy as np
import pytest

import robots
import warpdyn as wd
from warpdyn import VelRepr


@pytest.fixture(scope="module")
def ergocub():
    text = robots.ergocub_urdf()
    full = wd.model.Model.build_from_model_description(text, dtype=np.float64)
    return wd.model.reduce(full, robots.seed_joints(full.joint_names()))


def _link_velocities(model, data, repr):
    return np.array(
        [wd.link.velocity(model, data, link_index=i, output_vel_repr=repr).numpy() for i in range(model.number_of_links())]
    )


@pytest.mark.parametrize("repr", list(VelRepr))
def test_link_forces_round_trip_and_power(ergocub, repr):
    """Link forces given in `repr` read back unchanged in `repr`, and deliver the same power in every
    representation (f . v with v in the same representation)."""
    model = ergocub
    data = wd.data.random_model_data(model, key=1)
    f = np.random.default_rng(2).uniform(-10, 10, (model.number_of_links(), 6))
    references = wd.references.References.build(model, data=data, link_forces=f, velocity_representation=repr)
    np.testing.assert_allclose(references.link_forces(model, data).numpy(), f, atol=1e-12)
    power = np.einsum("lk,lk->l", f, _link_velocities(model, data, repr))
    for other in VelRepr:
        with references.switch_velocity_representation(other):
            f_other = references.link_forces(model, data).numpy()
        np.testing.assert_allclose(np.einsum("lk,lk->l", f_other, _link_velocities(model, data, other)), power, atol=1e-12)


@pytest.mark.parametrize("repr", list(VelRepr))
def test_frame_forces_move_to_the_parent_link(ergocub, repr):
    """apply_frame_forces: each frame force is moved to its parent link, where it delivers the frame's
    power (f_F . v_F); without `additive` it replaces that link's force, with it adds to it; the other
    links keep theirs."""
    model = ergocub
    data = wd.data.random_model_data(model, key=3)
    rng = np.random.default_rng(4)
    f_L = rng.uniform(-10, 10, (model.number_of_links(), 6))
    names = ("l_foot_front", "l_foot_rear", "r_foot_front")
    f_F = rng.uniform(-10, 10, (len(names), 6))
    base = wd.references.References.build(model, data=data, link_forces=f_L, velocity_representation=repr)
    parents = [wd.frame.idx_of_parent_link(model, frame_index=wd.frame.name_to_idx(model, frame_name=n)) for n in names]
    v_F = np.array(
        [
            wd.frame.velocity(model, data, frame_index=wd.frame.name_to_idx(model, frame_name=n), output_vel_repr=repr).numpy()
            for n in names
        ]
    )
    v_L = _link_velocities(model, data, repr)
    for additive in (False, True):
        moved = base.apply_frame_forces(f_F, model, data, frame_names=names, additive=additive).link_forces(model, data).numpy()
        for link in range(model.number_of_links()):
            mine = [k for k, p in enumerate(parents) if p == link]
            expected = (f_L[link] @ v_L[link] if additive or not mine else 0.0) + sum(f_F[k] @ v_F[k] for k in mine)
            np.testing.assert_allclose(moved[link] @ v_L[link], expected, atol=1e-12)
            if not mine:
                np.testing.assert_allclose(moved[link], f_L[link], atol=1e-12)


def test_joint_force_references_named_and_all(ergocub):
    """set_joint_force_references replaces all forces, or only the named joints' (the others kept)."""
    model = ergocub
    tau = np.arange(model.dofs(), dtype=np.float64)
    references = wd.references.References.build(model, joint_force_references=tau)
    np.testing.assert_array_equal(references.joint_force_references(model).numpy(), tau)
    changed = references.set_joint_force_references(np.array([-1.0, -2.0]), model, joint_names=("l_knee", "r_knee"))
    expected = tau.copy()
    expected[list(wd.joint.names_to_idxs(model, joint_names=("l_knee", "r_knee")))] = [-1.0, -2.0]
    np.testing.assert_array_equal(changed.joint_force_references(model).numpy(), expected)
    np.testing.assert_array_equal(changed.joint_force_references(model, joint_names=("r_knee",)).numpy(), [-2.0])


def test_contact_state_shapes_and_reset(ergocub):
    """data.contact_state holds the tangential deformation of every collidable point (32 for the seed),
    zero at build, JaxSim's shapes for one environment and a leading N when batched; a step in contact
    changes it and reset() zeroes the chosen environment's."""
    model = ergocub
    single = wd.data.Data.zero(model)
    assert tuple(single.contact_state["tangential_deformation"].shape) == (32, 3)
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, 0.5], num_envs=2)
    m = data.contact_state["tangential_deformation"].numpy()
    assert m.shape == (2, 32, 3) and not m.any()
    points = wd.contact.collidable_point_positions(model, data).numpy()
    sliding = wd.data.Data.build(
        model,
        base_position=[0.0, 0.0, 0.5 - points[0, :, 2].min() - 1e-3],
        base_linear_velocity=[0.3, 0.0, 0.0],
        num_envs=2,
    )
    after = wd.model.step(model, sliding)
    assert np.abs(after.contact_state["tangential_deformation"].numpy()).max() > 0.0
    reset = after.reset(model, envs=[1])
    m = reset.contact_state["tangential_deformation"].numpy()
    assert not m[1].any() and np.array_equal(m[0], after.contact_state["tangential_deformation"].numpy()[0])


@pytest.mark.parametrize("additive", [False, True], ids=["replace", "additive"])
def test_frame_and_link_force_gradients(additive):
    """Frame forces moved to their links are differentiable: the gradient of sum(w * accelerations) of ABA
    under references built by apply_link_forces then apply_frame_forces (Body representation, two frames
    of the same link and one of another), w.r.t. the frame forces and the joint positions (through the
    frames' poses), equals central differences (h = 1e-6, rtol 1e-6: float64, truncation ~1e-12)."""
    import warp as wp

    from gradcheck import weighted_sum

    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=np.float64)
    model = wd.model.reduce(full, robots.seed_joints(full.joint_names()))
    frames = [name for name in model.frame_names() if "sole" in name or "foot" in name][:2] + [model.frame_names()[0]]
    rng = np.random.default_rng(4)
    f0 = rng.normal(size=(len(frames), 6))
    s0 = rng.uniform(-0.3, 0.3, model.dofs())
    link_f = rng.normal(size=(model.number_of_links(), 6))
    w = [wp.array(rng.normal(size=(1, 6)), dtype=wp.float64), wp.array(rng.normal(size=(1, model.dofs())), dtype=wp.float64)]

    def loss(f, s):
        data = wd.data.Data.build(model, joint_positions=s, velocity_representation=VelRepr.Body, requires_grad=True)
        refs = wd.references.References.build(model, data=data, velocity_representation=VelRepr.Body)
        refs = refs.apply_link_forces(link_f, model, data)
        refs = refs.apply_frame_forces(f, model, data, frame_names=frames, additive=additive)
        base, joints = wd.model.forward_dynamics_aba(model, data, link_forces=refs.link_forces(model, data))
        return weighted_sum([base.reshape((1, 6)), joints.reshape((1, -1))], w)

    f = wp.array(f0, dtype=wp.float64, requires_grad=True)
    s = wp.array(s0, dtype=wp.float64, requires_grad=True)
    tape = wp.Tape()
    with tape:
        out = loss(f, s)
    tape.backward(out)
    for array, x0 in ((f, f0), (s, s0)):
        fd = np.zeros_like(x0)
        for i in np.ndindex(x0.shape):
            x = x0.copy()
            x[i] += 1e-6
            up = float(loss(wp.array(x, dtype=wp.float64) if array is f else f0, x if array is s else s0).numpy()[0])
            x[i] -= 2e-6
            down = float(loss(wp.array(x, dtype=wp.float64) if array is f else f0, x if array is s else s0).numpy()[0])
            fd[i] = (up - down) / 2e-6
        np.testing.assert_allclose(array.grad.numpy(), fd, rtol=1e-6, atol=1e-8 * np.abs(fd).max())
        assert np.abs(fd).max() > 1e-3
