"""JaxSim's relaxed-rigid law on the contacts between bodies (model.geom_contacts with RelaxedRigidContacts): each geom
pair's contact slot joins the points' solve (kernels/relaxed_rigid.py's `relaxed_slot_rows`, kernels/rigid_contacts.py's
`slot_point` and `slot_wrenches`), checked against the law assembled in NumPy from the façade's Jacobians, mass
matrix and bias accelerations, by scenes of free objects coming to rest where MuJoCo's do, by momentum in free
flight, by a frictionless pair, and by a step's Jacobians against central differences. The rigid law refuses
geom contacts (its impact would need the contacts at the step's new state).
"""

import mujoco
import numpy as np
import pytest
from test_body_contacts import MIXED, PUSHER, REST_TOL, ROLLING, SCENES, TWO_SPHERES, _model, _positions

import warpdyn as wd


def _relaxed(xml, dtype=np.float64, **params):
    model = _model(xml, dtype)
    model.contact_model = wd.rbda.contacts.RelaxedRigidContacts()
    model.contact_params = wd.rbda.contacts.RelaxedRigidContactsParams(**params)
    return model


def _impedance(c, x):
    """JaxSim's relaxed-rigid impedance of |pos| = x [m] (MuJoCo's solimp sigmoid), written out again."""
    x = x / c.width
    if x >= 1.0:
        return c.d_max
    y = x**c.power / c.midpoint ** (c.power - 1) if x < c.midpoint else 1 - (1 - x) ** c.power / (1 - c.midpoint) ** (c.power - 1)
    return float(np.clip(c.d_min + y * (c.d_max - c.d_min), c.d_min, c.d_max))


def _reference_link_forces(model, data) -> np.ndarray:
    """(nL, 6) Inertial contact wrenches of the geom pairs' contacts under the relaxed-rigid law, assembled in NumPy:
    each penetrating slot's rows are the velocity of geom2's point relative to geom1's along (t1, t2, n), from the
    links' Inertial Jacobians and bias accelerations (its classical acceleration: J̇ν_lin + J̇ν_ang x p + w x v), the
    free accelerations from ABA, f = (J M^-1 J^T + diag R)^-1 (a_ref - J a_free - J̇ν) over the joints' DoFs (the
    scene's base is the world), a_ref and R JaxSim's per axis with n = (0, 0, 1), the pair's mu and reduced mass."""
    c = model.contact_params
    pairs = wd.contact.geom_pairs(model)
    contacts = wd.contact.geom_contacts(model, data)
    count, position, frame, dist = (a.numpy() for a in contacts)  # one environment: no N axis
    J_all = wd.model.generalized_free_floating_jacobian(model, data).numpy()  # (nL, 6, 6 + n), one environment
    J_L = J_all[:, :, 6:]
    bias = wd.model.link_bias_accelerations(model, data).numpy()
    v_L = J_all @ data.generalized_velocity.numpy().reshape(-1)
    M = wd.model.free_floating_mass_matrix(model, data).numpy()[6:, 6:]
    a_free = wd.model.forward_dynamics_aba(model, data)[1].numpy().reshape(-1)
    mass = np.asarray(model.kin_dyn_parameters.link_parameters.mass, dtype=float)
    rows, rhs, reg, slots = [], [], [], []
    for i in range(len(pairs.first)):
        for k in range(int(count[i])):
            s = pairs.first[i] + k
            if dist[s] >= 0:
                continue
            x, axes = position[s], frame[s][[1, 2, 0]]
            J = np.zeros((3, M.shape[0]))
            a = np.zeros(3)
            v = np.zeros(3)
            inverse_mass = 0.0
            for link, sign in ((pairs.link2[i], 1.0), (pairs.link1[i], -1.0)):
                if link < 0:
                    continue
                w, lin = v_L[link, 3:], v_L[link, :3] + np.cross(v_L[link, 3:], x)
                J += sign * axes @ (J_L[link, :3] - np.cross(x, J_L[link, 3:].T).T)
                a += sign * axes @ (bias[link, :3] + np.cross(bias[link, 3:], x) + np.cross(w, lin))
                v += sign * axes @ lin
                inverse_mass += 1.0 / mass[link]
            mu = pairs.friction[i, 0] if pairs.condim[i] > 1 else 0.0
            tau, zeta = c.time_constant, c.damping_coefficient
            stiffness, damping = 1.0 / (c.d_max * tau * zeta) ** 2, 2.0 / (c.d_max * tau)
            for r, n_r in enumerate((0.0, 0.0, 1.0)):
                pos = dist[s] * n_r  # -delta n_r
                xi = _impedance(c, abs(pos))
                rhs.append(-(damping * v[r] + stiffness * xi * pos) - a[r] - J[r] @ a_free)
                reg.append(2 * mu**2 * (1 - xi) / (xi + 1e-12) * (1 + mu**2) * inverse_mass)
            rows.append(J)
            slots.append((i, s))
    out = np.zeros((model.number_of_links(), 6))
    if not rows:
        return out
    J = np.concatenate(rows)
    f = np.linalg.solve(J @ np.linalg.solve(M, J.T) + np.diag(reg), np.array(rhs)).reshape(-1, 3)
    for (i, s), f_c in zip(slots, f):
        f_w = frame[s][[1, 2, 0]].T @ f_c
        wrench = np.concatenate([f_w, np.cross(position[s], f_w)])
        if pairs.link2[i] >= 0:
            out[pairs.link2[i]] += wrench
        if pairs.link1[i] >= 0:
            out[pairs.link1[i]] -= wrench
    return out


def test_the_slots_forces_are_the_law_assembled_in_numpy():
    """MIXED's bodies in the air, touching (sphere-box, capsule-box, capsule-capsule, sphere-cylinder, box-box) and
    moving: the links' contact wrenches equal the NumPy assembly (`_reference_link_forces`) to 1e-9 of the largest."""
    model = _relaxed(MIXED)
    rng = np.random.default_rng(3)
    data = wd.data.Data.build(model, joint_velocities=rng.normal(size=model.dofs()) * 0.3, velocity_representation=wd.VelRepr.Inertial)
    expected = _reference_link_forces(model, data)
    got = wd.contact.link_contact_forces(model, data)[0].numpy()
    assert np.abs(expected).max() > 1.0
    np.testing.assert_allclose(got, expected, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("dtype", [np.float64, np.float32], ids=["float64", "float32"])
@pytest.mark.parametrize("scene", SCENES)
def test_scenes_come_to_rest_where_mujocos_do(scene, dtype):
    """After 1.5 s (1 ms steps) under the relaxed-rigid law on the pairs' contacts and on the floor's points, each
    body's position is MuJoCo's within REST_TOL (0.8 mm at most measured, in float64 and float32) and it has stopped
    (ROLLING's bounds)."""
    xml = SCENES[scene]
    model = _relaxed(xml, dtype)
    data = wd.data.Data.build(model)
    for _ in range(1500):
        data = wd.model.step(model, data)
    assert float(np.abs(data.generalized_velocity.numpy()).max()) < ROLLING.get(scene, 1e-3)
    mj = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(mj)
    for _ in range(1500):
        mujoco.mj_step(mj, d)
    for name, position in _positions(model, data).items():
        np.testing.assert_allclose(position, d.xpos[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, name)], atol=REST_TOL, err_msg=name)


def test_momentum_is_conserved_in_free_flight():
    """Without gravity or terrain, two spinning spheres thrown at each other keep their total linear and angular
    momentum about the origin through the collision (1e-10 relative over 400 steps): the slot's force acts on both
    bodies, equal and opposite, at one point."""
    model = _relaxed(TWO_SPHERES)
    qpos = np.array([-0.3, 0, 1, 1, 0, 0, 0, 0.3, 0.04, 1.02, 1, 0, 0, 0], dtype=np.float64)
    velocity = np.array([1.0, 0, 0, 0, 2.0, 0, -1.5, 0, 0, 0, 0, 3.0])
    data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=velocity)
    before = wd.model.total_momentum(model, data).numpy()
    touched = False
    for _ in range(400):
        data = wd.model.step(model, data)
        touched = touched or bool(np.abs(wd.contact.link_contact_forces(model, data)[0].numpy()).max() > 0.0)
    assert touched
    np.testing.assert_allclose(wd.model.total_momentum(model, data).numpy(), before, rtol=1e-10, atol=1e-10)


def test_condim_1_is_frictionless():
    """A pair of condim 1 gets no tangential force under the relaxed-rigid law either (its tangential rows are
    zeros): the spheres' wrench, moving sideways against each other, lies along the normal; with condim 3 it does not."""
    qpos = np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0], dtype=np.float64)
    velocity = np.array([0.0, 0.5, 0, 0, 0, 0, 0, -0.5, 0, 0, 0, 0])
    for condim, frictionless in ((1, True), (3, False)):
        xml = TWO_SPHERES.replace('friction="0.7"', f'friction="0.7" condim="{condim}"').replace('friction="0.4"', f'friction="0.4" condim="{condim}"')
        model = _relaxed(xml)
        data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=velocity)
        f = wd.contact.link_contact_forces(model, data)[0].numpy()[model.link_names().index("b"), :3]
        n = wd.contact.geom_contacts(model, data).frame.numpy()[0, 0]
        tangential = np.linalg.norm(f - (f @ n) * n)
        assert np.linalg.norm(f) > 1.0
        assert (tangential < 1e-9 * np.linalg.norm(f)) == frictionless, (condim, tangential, np.linalg.norm(f))


def test_a_steps_jacobians_through_body_contacts_equal_central_differences():
    """wd.autodiff's reverse A and B (one taped step: the narrow phase, the slots' rows, the solve's hand-written
    adjoint, the wrenches) equal central differences (h = 1e-7) to 5e-7 of the largest entry (1.1e-7 measured; without
    the contacts A's entries differ by up to 36.5, its largest), on MIXED's touching bodies (the brick tilted: box-box faces exactly parallel
    are not differentiable, test_body_contacts says why)."""
    model = _relaxed(MIXED)
    data = wd.data.Data.build(model, joint_velocities=np.random.default_rng(0).normal(size=model.dofs()) * 0.3)
    reverse = wd.autodiff.transition_matrices(model, data, method="reverse")
    central = wd.autodiff.transition_matrices(model, data, method="central", h=1e-7)
    for name in ("A", "B"):
        r, c = reverse[name].numpy(), central[name].numpy()
        assert np.abs(r - c).max() < 5e-7 * np.abs(c).max(), (name, np.abs(r - c).max(), np.abs(c).max())


def test_the_rigid_law_refuses_geom_contacts():
    """RigidContacts with model.geom_contacts: a NotImplementedError naming the setting and the laws that take it."""
    model = _model(TWO_SPHERES)
    model.contact_model = wd.rbda.contacts.RigidContacts()
    model.contact_params = wd.rbda.contacts.RigidContactsParams()
    with pytest.raises(NotImplementedError, match=r"geom_contacts.*soft and relaxed-rigid laws"):
        wd.model.step(model, wd.data.Data.build(model))


def test_more_penetrating_contacts_than_max_active_contacts_flag_that_environment():
    """RelaxedRigidContacts(max_active_contacts=n) sizes the solve for n contacts: an environment where more penetrate
    (a stack of boxes at rest: its floor and box-box contacts) is flagged and frozen, one in the air goes on as
    without the limit (the same numbers), and a limit the scene stays within changes nothing (bit for bit)."""
    xml = SCENES["a stack of boxes"]
    model = _relaxed(xml)
    resting = wd.data.Data.build(model)
    for _ in range(300):
        resting = wd.model.step(model, resting)
    q = resting.joint_positions.numpy().reshape(1, -1)
    lifted = q.copy()
    lifted[0, 2::7] += np.array([1.0, 2.0, 3.0])  # each box's height, a metre apart from the next
    active = int((wd.contact.geom_contacts(model, resting).distance.numpy() < 0).sum())  # the box-box contacts alone
    assert active >= 4
    states = {}
    for limit in (None, 3, 200):
        limited = model.replace(contact_model=wd.rbda.contacts.RelaxedRigidContacts(max_active_contacts=limit))
        data = wd.data.Data.build(limited, joint_positions=np.concatenate([q, lifted]), num_envs=2)
        for _ in range(50):
            data = wd.model.step(limited, data)
        states[limit] = (data.healthy.numpy(), data.joint_positions.numpy())
    assert states[None][0].tolist() == [True, True] and states[200][0].tolist() == [True, True]
    assert states[3][0].tolist() == [False, True]
    np.testing.assert_array_equal(states[200][1], states[None][1])
    np.testing.assert_array_equal(states[3][1][1], states[None][1][1])
    with pytest.raises(ValueError, match=r"max_active_contacts must be an integer >= 1, got 0"):
        wd.rbda.contacts.RelaxedRigidContacts(max_active_contacts=0)
