"""Model parameters given per environment (domain randomisation) and the terrain's height as a parameter.

References: a model whose parameters are shared and equal to one environment's row computes, for that
environment, exactly what the per-environment model computes (the kernels read row min(env, P - 1) of the
same values: bitwise the same arithmetic, so rtol 1e-13); gradients are checked against central finite
differences as in tests/test_parameter_gradients.py (float64, relative steps 1e-6, rtol 1e-6).
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from gradcheck import weighted_sum
from test_parameter_gradients import BOX_URDF, _assert_gradients, _contact_rollout_gradients, _finite_differences

N = 3


def _random_rows(model, rng, N: int) -> dict:
    """Per-environment masses (x 0.5 .. 1.5), CoMs (+- 5 cm) and inertias (rotated, rescaled) around the
    description's values: {set_link_parameters argument: (N, nL, ...) array}."""
    tree = model.tree
    nL = tree.number_of_links
    mass = tree.link_mass[None] * rng.uniform(0.5, 1.5, (N, nL))
    com = tree.link_com[None] + rng.uniform(-0.05, 0.05, (N, nL, 3))
    inertia = np.empty((N, nL, 3, 3))
    for k in range(N):
        for i in range(nL):
            Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
            inertia[k, i] = rng.uniform(0.5, 1.5) * Q @ tree.link_inertia[i] @ Q.T
    return {"mass": mass, "com": com, "inertia": inertia}


def _joint_rows(model, rng, N: int) -> dict:
    n = model.dofs()
    return {
        "limit_spring": rng.uniform(5.0, 15.0, (N, n)),
        "limit_damper": rng.uniform(0.05, 0.2, (N, n)),
        "friction_static": rng.uniform(0.1, 0.5, (N, n)),
        "friction_viscous": rng.uniform(0.1, 0.5, (N, n)),
    }


def _outputs(model, data) -> dict:
    """Every function that reads the mass parameters, and a step that reads the joint parameters."""
    base, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=np.linspace(-1.0, 1.0, model.dofs()))
    f_B, tau = wd.model.inverse_dynamics(model, data, joint_accelerations=np.ones(model.dofs()))
    nxt = wd.model.step(model, data, joint_force_references=np.linspace(-2.0, 2.0, model.dofs()))
    return {
        "aba base": base,
        "aba joints": joints,
        "crb joints": wd.model.forward_dynamics_crb(model, data)[1],
        "rnea base": f_B,
        "rnea joints": tau,
        "M": wd.model.free_floating_mass_matrix(model, data),
        "h": wd.model.free_floating_bias_forces(model, data),
        "C": wd.model.free_floating_coriolis_matrix(model, data),
        "com": wd.com.com_position(model, data),
        "com bias": wd.com.bias_acceleration(model, data),
        "h_G": wd.com.centroidal_momentum(model, data),
        "J_G": wd.com.centroidal_momentum_jacobian(model, data),
        "locked": wd.model.locked_spatial_inertia(model, data),
        "energy": wd.model.mechanical_energy(model, data),
        "link com": wd.link.com_position(model, data, link_index=model.number_of_links() - 1, in_link_frame=False),
        "step s": nxt.joint_positions_state,
        "step v": nxt.joint_velocities_state,
        "step base": nxt.base_velocity_state,
    }


def test_per_environment_parameters_equal_shared_models_row_by_row():
    """N = 3 environments of a random 6-link floating tree, each with its own masses, CoMs, inertias, joint
    friction and limit gains: every dynamics, centroidal and energy function and a step give, in
    environment k, what a model sharing row k gives (reference: that model, same data; rtol 1e-13). Also
    link_spatial_inertia_matrices (N, nL, 6, 6), wd.link.spatial_inertia (N, 6, 6), total_mass and
    wd.link.mass (N,)."""
    rng = np.random.default_rng(0)
    urdf = robots.random_tree_urdf(4, num_links=6)
    model = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
    model.set_joint_parameters(position_limits=np.tile([-0.2, 0.2], (model.dofs(), 1)))
    links, joints = _random_rows(model, rng, N), _joint_rows(model, rng, N)
    model.set_link_parameters(**links)
    model.set_joint_parameters(**joints)
    assert model.link_mass.shape == (N, model.number_of_links()) and model.friction_static.shape == (N, model.dofs())
    assert model.per_environment_parameters() == dict.fromkeys(
        ("link_mass", "link_com", "link_inertia", "joint_limit_spring", "joint_limit_damper", "friction_static", "friction_viscous"), N
    )
    data = wd.data.random_model_data(model, key=1, num_envs=N)
    got = {k: v.numpy() for k, v in _outputs(model, data).items()}
    M_links = wd.model.link_spatial_inertia_matrices(model).numpy()
    assert M_links.shape == (N, model.number_of_links(), 6, 6)
    assert wd.link.spatial_inertia(model, link_index=2).shape == (N, 6, 6)
    np.testing.assert_allclose(wd.model.total_mass(model), links["mass"].sum(axis=1), rtol=1e-15)
    np.testing.assert_allclose(wd.link.mass(model, link_index=1), links["mass"][:, 1], rtol=1e-15)
    for k in range(N):
        shared = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        shared.set_joint_parameters(position_limits=np.tile([-0.2, 0.2], (model.dofs(), 1)))
        shared.set_link_parameters(**{name: value[k] for name, value in links.items()})
        shared.set_joint_parameters(**{name: value[k] for name, value in joints.items()})
        expected = _outputs(shared, data)
        for name, value in expected.items():
            np.testing.assert_allclose(got[name][k], value.numpy()[k], rtol=1e-13, atol=1e-13, err_msg=f"{name}, env {k}")
        np.testing.assert_allclose(M_links[k], wd.model.link_spatial_inertia_matrices(shared).numpy(), rtol=1e-15)
    assert not np.allclose(got["M"][0], got["M"][1]), "the rows do not differ"


@pytest.mark.parametrize("env_fastest", [False, True], ids=["env-major", "env-fastest"])
def test_per_environment_gradients_through_a_rollout(env_fastest, monkeypatch):
    """d loss / d (link_mass, link_com, link_inertia, friction_viscous, joint_limit_spring), each given per
    environment (N = 2), through 10 steps of a 3-link pendulum chain beyond its limits: the gradients come
    back per environment, (N, nL), (N, nL) vec3, (N, nL) mat33, (N, n), and match central differences
    (module docstring; rtol 1e-6). The loss weighs environment 0 and 1 differently, so a gradient summed
    over environments (the shared case) would fail. Both layouts: the CPU's and the GPUs' (environment
    fastest: the per-environment parameter arrays are then transposed views)."""
    monkeypatch.setattr(wd.config, "env_fastest", env_fastest)
    n, T, envs = 3, 10, 2
    rng = np.random.default_rng(2)
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(n), dtype=np.float64)
    model.set_joint_parameters(position_limits=np.tile([-0.1, 0.1], (n, 1)))
    model.set_link_parameters(**_random_rows(model, rng, envs))
    joints = _joint_rows(model, rng, envs)
    model.set_joint_parameters(friction_viscous=joints["friction_viscous"], limit_spring=joints["limit_spring"])
    names = ("link_mass", "link_com", "link_inertia", "friction_viscous", "joint_limit_spring")
    params = wd.model.parameters_requiring_grad(model, names=names)
    s0 = rng.choice([-1.0, 1.0], size=(envs, n)) * rng.uniform(0.3, 0.6, size=(envs, n))
    v0 = rng.uniform(-2.0, 2.0, size=(envs, n))
    tau = rng.normal(size=(T, envs, n))
    w = wp.array(rng.normal(size=(envs, n)), dtype=wp.float64)

    def loss():
        data = wd.data.Data.build(model, joint_positions=s0, joint_velocities=v0, num_envs=envs)
        final, _ = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau, record=())
        out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        weighted_sum([final.joint_positions_state, final.joint_velocities_state], [w, w], out=out)
        return out

    tape = wp.Tape()
    with tape:
        out = loss()
    tape.backward(out)
    assert params["link_com"].grad.shape == (envs, model.number_of_links())
    assert params["link_mass"].is_contiguous != env_fastest
    _assert_gradients(params, _finite_differences(params, lambda: float(loss().numpy()[0])))


def test_per_environment_terrain_heights():
    """FlatTerrain with one height per environment: a box resting 1 mm deep on ground at 0 and at 5 cm steps
    as a shared-height model does in each environment (reference: that model; rtol 1e-13), and the gradient
    of a loss over 15 steps of the box sliding with respect to the heights ((N,) per environment, and (1,)
    shared) matches central differences (module docstring; rtol 1e-6)."""
    heights = np.array([0.0, 0.05])
    model = wd.model.Model.build_from_model_description(BOX_URDF, dtype=np.float64)
    model.contact_params = wd.model.SoftContactsParams(K=1e5, D=1e3, mu=0.4)
    model.terrain = wd.terrain.FlatTerrain(height=heights)
    z = 0.099 + heights
    data = wd.data.Data.build(
        model, base_position=np.stack([np.zeros(2), np.zeros(2), z], axis=1), base_linear_velocity=[1.0, 0.2, 0.0], num_envs=2
    )
    got = wd.model.step(model, data).base_velocity_state.numpy()
    for k, h in enumerate(heights):
        shared = wd.model.Model.build_from_model_description(BOX_URDF, dtype=np.float64)
        shared.contact_params = model.contact_params
        shared.terrain = wd.terrain.FlatTerrain(height=h)
        np.testing.assert_allclose(got[k], wd.model.step(shared, data).base_velocity_state.numpy()[k], rtol=1e-13, atol=1e-15)
    assert np.all(got[:, 2] > -0.9 * 9.81 * model.time_step), "the ground does not push (free fall after one step)"
    params, rec, fd = _contact_rollout_gradients(model, data, 15, ("terrain_height",))
    assert params["terrain_height"].shape == (2,) and model.terrain.elevation is params["terrain_height"]
    assert np.all(rec["base_position"].numpy()[..., 2] < z + 0.001), "a corner left the ground"
    _assert_gradients(params, fd)

    model.terrain = wd.terrain.FlatTerrain(height=0.0)
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, 0.099], base_linear_velocity=[1.0, 0.2, 0.0], num_envs=2)
    params, _, fd = _contact_rollout_gradients(model, data, 15, ("terrain_height",))
    assert params["terrain_height"].shape == (1,)
    _assert_gradients(params, fd)


def test_heightfield_heights_gradient():
    """d loss / d heights (4 x 4 grid, 0.5 m cells, a gentle slope) of a box sliding 15 steps across it:
    tape vs central differences (module docstring; rtol 1e-6); the cells under the box get non-zero
    gradients, the far ones exactly 0."""
    rng = np.random.default_rng(3)
    grid = 0.02 * rng.uniform(-1.0, 1.0, (4, 4))
    model = wd.model.Model.build_from_model_description(BOX_URDF, dtype=np.float64)
    model.contact_params = wd.model.SoftContactsParams(K=1e5, D=1e3, mu=0.4)
    model.terrain = wd.terrain.HeightfieldTerrain(grid, origin=(-0.6, -0.6), spacing=(0.5, 0.5))
    points = wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()
    lift = np.max(model.terrain.height(points[:, 0], points[:, 1]) - points[:, 2])
    data = wd.data.Data.build(model, base_position=[0.0, 0.0, lift - 0.001], base_linear_velocity=[0.5, 0.1, 0.0])
    params, _, fd = _contact_rollout_gradients(model, data, 15, ("terrain_height",))
    assert params["terrain_height"].shape == (4, 4)
    _assert_gradients(params, fd)
    assert np.all(params["terrain_height"].grad.numpy()[3, :] == 0.0), "a cell the box never reaches has a gradient"


def test_bad_per_environment_parameters_are_refused():
    """Each bad value raises and names what is wrong: wrong shapes, negative masses, non-symmetric or
    indefinite inertias, two numbers of environments, data of another batch size, a plane's height."""
    model = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(3), dtype=np.float64)
    nL, n = model.number_of_links(), model.dofs()
    with pytest.raises(ValueError, match=r"link_mass has shape \(2, 5\)"):
        model.set_link_parameters(mass=np.ones((2, nL + 1)))
    with pytest.raises(ValueError, match="link_mass must be non-negative"):
        model.set_link_parameters(mass=-np.ones(nL))
    bad = np.tile(np.eye(3), (nL, 1, 1))
    bad[1, 0, 1] = 0.5
    with pytest.raises(ValueError, match="link_inertia must hold symmetric"):
        model.set_link_parameters(inertia=bad)
    with pytest.raises(ValueError, match="positive semi-definite"):
        model.set_link_parameters(inertia=np.tile(np.diag([1.0, 1.0, -1.0]), (nL, 1, 1)))
    with pytest.raises(ValueError, match="friction_viscous must be non-negative"):
        model.set_joint_parameters(friction_viscous=-np.ones((2, n)))
    model.set_link_parameters(mass=np.ones((2, nL)))
    with pytest.raises(ValueError, match="one N per model"):
        model.set_joint_parameters(friction_static=np.ones((3, n)))
    with pytest.raises(ValueError, match=r"per environment, but the data has 3 environments"):
        wd.model.free_floating_mass_matrix(model, wd.data.Data.build(model, num_envs=3))
    assert wd.model.free_floating_mass_matrix(model, wd.data.Data.build(model, num_envs=2)).shape == (2, 6 + n, 6 + n)
    model.set_link_parameters(mass=np.ones(nL))
    assert model.per_environment_parameters() == {}
    model.terrain = wd.terrain.PlaneTerrain(normal=(0.1, 0.0, 1.0))
    with pytest.raises(ValueError, match="PlaneTerrain has no height parameter"):
        wd.model.parameters_requiring_grad(model, names=("terrain_height",))
    with pytest.raises(ValueError, match="FlatTerrain.height"):
        wd.terrain.FlatTerrain(height=np.ones((2, 2)))
    model.terrain = wd.terrain.FlatTerrain(height=np.zeros(4))
    with pytest.raises(ValueError, match=r"terrain's height has shape \(4,\)"):
        wd.model.step(model, wd.data.Data.build(model, num_envs=2))


def test_parameters_edited_in_place_are_read_by_replayed_graphs():
    """A Rollout captured as a graph (Warp's CPU graph here, a CUDA graph on GPUs) reads the parameter arrays
    when it replays: after model.link_mass.assign(...) and model.friction_viscous.assign(...) the next run
    equals a fresh model built with those values (reference: that model; bitwise, the same launches), and
    total_mass reads the edited array."""
    n, T = 3, 20
    urdf = robots.pendulum_chain_urdf(n)
    model = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
    model.set_joint_parameters(friction_viscous=np.full(n, 0.1))
    data = wd.data.Data.build(model, joint_positions=[0.3, -0.2, 0.1], joint_velocities=[1.0, 0.0, -1.0])
    roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions",), use_graph=True)
    before = roll.run(data)[1]["joint_positions"].numpy().copy()
    masses = model.link_mass.numpy() * np.linspace(0.5, 1.5, model.number_of_links())
    model.link_mass.assign(masses)
    model.friction_viscous.assign(np.full(n, 0.4))
    after = roll.run(data)[1]["joint_positions"].numpy()
    fresh = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
    fresh.set_link_parameters(mass=masses)
    fresh.set_joint_parameters(friction_viscous=np.full(n, 0.4))
    expected = wd.simulation.rollout(fresh, data, steps=T, record=("joint_positions",), use_graph=False)[1]["joint_positions"].numpy()
    np.testing.assert_array_equal(after, expected)
    assert np.abs(after - before).max() > 1e-3
    assert wd.model.total_mass(model) == pytest.approx(masses.sum(), rel=1e-15)


def test_a_diverging_environment_leaves_the_others_gradients_intact():
    """Environment 1 of 2 diverges in the first step (a joint speed of 1e200 rad/s overflows: it is flagged
    and frozen); the loss reads environment 0 only. Environment 0's gradients (its initial joint velocities
    and, with masses given per environment, its row of d loss / d link_mass) equal those of a run where
    environment 1 stays finite (reference: that run; rtol 1e-12). Environment 1's own gradients are NaN, and
    a mass shared by both environments gets NaN (its gradient sums over environments, docs/differentiation.md, 'Where the
    derivative is not defined'): this is the documented behaviour, asserted so that a change is noticed."""
    n, T = 3, 5
    urdf = robots.pendulum_chain_urdf(n)
    w = np.zeros((2, n))
    w[0] = [1.0, -0.5, 2.0]

    def gradients(v1: float, per_env: bool):
        model = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        if per_env:
            model.set_link_parameters(mass=np.tile(model.tree.link_mass, (2, 1)))
        params = wd.model.parameters_requiring_grad(model, names=("link_mass",))
        v = np.array([[1.0, 0.0, -1.0], [v1, 0.0, 0.0]])
        data = wd.data.Data.build(model, joint_velocities=v, num_envs=2, requires_grad=True)
        tape = wp.Tape()
        with tape:
            final, rec = wd.simulation.rollout(model, data, steps=T, record=("valid",))
            out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
            weighted_sum([final.joint_positions_state], [wp.array(w, dtype=wp.float64)], out=out)
        tape.backward(out)
        return rec["valid"].numpy(), data.joint_velocities_state.grad.numpy(), params["link_mass"].grad.numpy()

    valid, dv, dm = gradients(1e200, per_env=True)
    assert valid[1:, 1].max() == 0 and valid[:, 0].min() == 1
    _, dv_ref, dm_ref = gradients(0.5, per_env=True)
    np.testing.assert_allclose(dv[0], dv_ref[0], rtol=1e-12)
    np.testing.assert_allclose(dm[0], dm_ref[0], rtol=1e-12, atol=1e-300)
    assert np.abs(dm[0]).max() > 0.0 and np.isnan(dv[1]).all()
    _, dv_shared, dm_shared = gradients(1e200, per_env=False)
    np.testing.assert_allclose(dv_shared[0], dv_ref[0], rtol=1e-12)
    assert np.isnan(dm_shared[1:]).all()


def test_functions_that_do_not_read_the_parameters_take_any_batch_size():
    """With masses given for 3 environments, kinematics, collidable points and contact forces (which read no
    link or joint parameter) accept other batch sizes (the visualiser runs F frames as F environments);
    link.com_position gives gradients of link_com (tape vs the analytic sum of W_R_L over environments); the contact estimate gives
    one K and D per environment, each what a shared model with that row gives (reference: those models;
    rtol 1e-12); FlatTerrain.for_env picks one environment's height."""
    full = wd.model.Model.build_from_model_description(robots.ergocub_urdf(), dtype=np.float64)
    model = wd.model.reduce(full, robots.seed_joints(full.joint_names()))
    masses = model.tree.link_mass[None] * np.array([[1.0], [1.2], [0.8]])
    model.set_link_parameters(mass=masses)
    single = wd.data.Data.build(model)
    assert wd.model.forward_kinematics(model, single).shape == (model.number_of_links(), 4, 4)
    assert wd.contact.collidable_point_positions(model, wd.data.Data.build(model, num_envs=5)).shape[0] == 5
    assert wd.contact.collidable_point_forces(model, single).shape[-1] == 6
    with pytest.raises(ValueError, match="per environment"):
        wd.model.free_floating_mass_matrix(model, single)
    estimate = wd.contact.estimate_good_contact_parameters(model)
    assert np.shape(estimate.K) == (3,) and np.shape(estimate.D) == (3,)
    for k in range(3):
        shared = wd.model.reduce(full, robots.seed_joints(full.joint_names()))
        shared.set_link_parameters(mass=masses[k])
        e = wd.contact.estimate_good_contact_parameters(shared)
        np.testing.assert_allclose([estimate.K[k], estimate.D[k]], [e.K, e.D], rtol=1e-12)
    params = wd.model.parameters_requiring_grad(model, names=("link_com",))
    data = wd.data.random_model_data(model, key=3, num_envs=3)
    tape = wp.Tape()
    with tape:
        p = wd.link.com_position(model, data, link_index=4, in_link_frame=False)
        out = wp.zeros(1, dtype=wp.float64, requires_grad=True)
        weighted_sum([p], [wp.array(np.ones((3, 3)), dtype=wp.float64)], out=out)
    tape.backward(out)
    R = wd.link.transform(model, data, link_index=4).numpy()[:, :3, :3]
    grad = params["link_com"].grad.numpy()
    np.testing.assert_allclose(grad[4], R.sum(axis=(0, 1)), rtol=1e-12)  # link_com is shared: summed over envs
    assert np.all(np.delete(grad, 4, axis=0) == 0.0)
    terrain = wd.terrain.FlatTerrain(height=np.array([0.0, 0.1, 0.2]))
    assert terrain.for_env(2).elevation == 0.2 and terrain.for_env(2).height(1.0, 2.0) == 0.2
