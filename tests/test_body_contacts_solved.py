"""JaxSim's relaxed-rigid and rigid laws on the contacts between bodies (model.geom_contacts with RelaxedRigidContacts
or RigidContacts): each geom pair's contact slot joins the points' solve (kernels/relaxed_rigid.py's
`relaxed_slot_rows`, kernels/contact_slots.py's `rigid_slot_rows`, `slot_point` and `slot_wrenches`) and, under the
rigid law, the impact after each step (kernels/rigid_impact.py, at the contacts of the step's new state). Checked
against each law assembled in NumPy from the façade's Jacobians, mass matrix and bias accelerations (the rigid QP
solved at its active set), by scenes of free objects coming to rest where MuJoCo's do, by momentum in free flight,
by a frictionless pair, by the impact stopping each penetrating contact, and by a step's Jacobians against central
differences.
"""

import dataclasses

import mujoco
import numpy as np
import pytest
import warp as wp
from test_body_contacts import MIXED, REST_TOL, ROLLING, SCENES, TWO_SPHERES, _model, _positions

import warpdyn as wd

LAWS = ("RelaxedRigidContacts", "RigidContacts")


def _solved(xml, law="RelaxedRigidContacts", dtype=np.float64, **params):
    model = _model(xml, dtype)
    model.contact_model = getattr(wd.rbda.contacts, law)()
    model.contact_params = getattr(wd.rbda.contacts, law + "Params")(**params)
    return model


def _impedance(c, x):
    """JaxSim's relaxed-rigid impedance of |pos| = x [m] (MuJoCo's solimp sigmoid), written out again."""
    x = x / c.width
    if x >= 1.0:
        return c.d_max
    y = x**c.power / c.midpoint ** (c.power - 1) if x < c.midpoint else 1 - (1 - x) ** c.power / (1 - c.midpoint) ** (c.power - 1)
    return float(np.clip(c.d_min + y * (c.d_max - c.d_min), c.d_min, c.d_max))


def _penetrating_slots(model, data) -> tuple:
    """The penetrating contact slots of the geom pairs, assembled in NumPy (the scene's base is the world: its joints'
    DoFs alone): (slots, M, a_free), slots a list of dicts: pair i, slot s, depth, the rows J (3, n) of geom2's point's
    velocity relative to geom1's along (t1, t2, n) from the links' Inertial Jacobians, their bias a (3,) (the classical
    acceleration J̇ν_lin + J̇ν_ang x p + w x v), the relative velocity v (3,), the bodies' inverse mass sum and the
    pair's mu (0 for condim 1, whose rows are then J's normal row alone)."""
    pairs = wd.contact.geom_pairs(model)
    count, position, frame, dist = (a.numpy() for a in wd.contact.geom_contacts(model, data))  # one environment: no N axis
    J_all = wd.model.generalized_free_floating_jacobian(model, data).numpy()  # (nL, 6, 6 + n), one environment
    J_L = J_all[:, :, 6:]
    bias = wd.model.link_bias_accelerations(model, data).numpy()
    v_L = J_all @ data.generalized_velocity.numpy().reshape(-1)
    M = wd.model.free_floating_mass_matrix(model, data).numpy()[6:, 6:]
    a_free = wd.model.forward_dynamics_aba(model, data)[1].numpy().reshape(-1)
    mass = np.asarray(model.kin_dyn_parameters.link_parameters.mass, dtype=float)
    slots = []
    for i in range(len(pairs.first)):
        for k in range(int(count[i])):
            s = pairs.first[i] + k
            if dist[s] >= 0:
                continue
            x, axes = position[s], frame[s][[1, 2, 0]]
            slot = dict(i=i, s=s, depth=-dist[s], J=np.zeros((3, M.shape[0])), a=np.zeros(3), v=np.zeros(3), inverse_mass=0.0)
            for link, sign in ((pairs.link2[i], 1.0), (pairs.link1[i], -1.0)):
                if link < 0:
                    continue
                w, lin = v_L[link, 3:], v_L[link, :3] + np.cross(v_L[link, 3:], x)
                slot["J"] += sign * axes @ (J_L[link, :3] - np.cross(x, J_L[link, 3:].T).T)
                slot["a"] += sign * axes @ (bias[link, :3] + np.cross(bias[link, 3:], x) + np.cross(w, lin))
                slot["v"] += sign * axes @ lin
                slot["inverse_mass"] += 1.0 / mass[link]
            slot["mu"] = pairs.friction[i, 0] if pairs.condim[i] > 1 else 0.0
            if slot["mu"] == 0.0:
                slot["J"][:2] = 0.0
                slot["a"][:2] = 0.0
            slots.append(slot)
    return slots, M, a_free


def _link_wrenches(model, data, slots, forces) -> np.ndarray:
    """(nL, 6) Inertial wrenches of the slots' forces (k, 3) in their contact axes: [f; x x f] on geom2's link, its
    opposite on geom1's."""
    pairs = wd.contact.geom_pairs(model)
    _, position, frame, _ = (a.numpy() for a in wd.contact.geom_contacts(model, data))
    out = np.zeros((model.number_of_links(), 6))
    for slot, f_c in zip(slots, forces):
        i, s = slot["i"], slot["s"]
        f_w = frame[s][[1, 2, 0]].T @ f_c
        wrench = np.concatenate([f_w, np.cross(position[s], f_w)])
        if pairs.link2[i] >= 0:
            out[pairs.link2[i]] += wrench
        if pairs.link1[i] >= 0:
            out[pairs.link1[i]] -= wrench
    return out


def _relaxed_link_forces(model, data) -> np.ndarray:
    """(nL, 6) the relaxed-rigid law's wrenches: f = (J M^-1 J^T + diag R)^-1 (a_ref - J a_free - J̇ν) over the
    penetrating slots, a_ref and R JaxSim's per axis with n = (0, 0, 1), the pair's mu and reduced mass."""
    c = model.contact_params
    slots, M, a_free = _penetrating_slots(model, data)
    if not slots:
        return np.zeros((model.number_of_links(), 6))
    tau, zeta = c.time_constant, c.damping_coefficient
    stiffness, damping = 1.0 / (c.d_max * tau * zeta) ** 2, 2.0 / (c.d_max * tau)
    rhs, reg = [], []
    for slot in slots:
        for r, n_r in enumerate((0.0, 0.0, 1.0)):
            pos = -slot["depth"] * n_r
            xi = _impedance(c, abs(pos))
            frictionless_tangent = slot["mu"] == 0.0 and r < 2
            rhs.append(0.0 if frictionless_tangent else -(damping * slot["v"][r] + stiffness * xi * pos) - slot["a"][r] - slot["J"][r] @ a_free)
            reg.append(1.0 if frictionless_tangent else 2 * slot["mu"] ** 2 * (1 - xi) / (xi + 1e-12) * (1 + slot["mu"] ** 2) * slot["inverse_mass"])
    J = np.concatenate([slot["J"] for slot in slots])
    f = np.linalg.solve(J @ np.linalg.solve(M, J.T) + np.diag(reg), np.array(rhs)).reshape(-1, 3)
    return _link_wrenches(model, data, slots, f)


def _pyramids(slots) -> np.ndarray:
    """G (5 k, 3 k): each slot's friction pyramid f_t1 - mu f_n, f_t2 - mu f_n, -f_t1 - mu f_n, -f_t2 - mu f_n, -f_n <= 0."""
    G = np.zeros((5 * len(slots), 3 * len(slots)))
    for k, slot in enumerate(slots):
        mu = slot["mu"]
        G[5 * k : 5 * k + 5, 3 * k : 3 * k + 3] = [[1, 0, -mu], [0, 1, -mu], [-1, 0, -mu], [0, -1, -mu], [0, 0, -1]]
    return G


def _rigid_link_forces(model, data) -> np.ndarray:
    """(nL, 6) the rigid law's wrenches: f minimises 1/2 f^T Q f + q^T f over the slots' friction pyramids G f <= 0,
    Q = J M^-1 J^T + eps I, q = J a_free + J̇ν - beta, beta = (0, 0, K depth - D v_n) in the contact's axes. Solved
    exactly (but for rounding, which Q's condition amplifies) in its dual, max over z >= 0 of -1/2 (q + G^T z)^T Q^-1 (q + G^T z): with Q = L L^T a
    non-negative least-squares problem min |L^-1 G^T z + L^-1 q| (Lawson and Hanson's finite active-set method), then
    f = -Q^-1 (q + G^T z). The NNLS optimality conditions are the QP's: G f <= 0, and G f = 0 where z > 0; both are
    checked (to 1e-8 of max |f|, Q's condition ~3e7 times float64's rounding)."""
    from scipy.linalg import solve_triangular
    from scipy.optimize import nnls

    c, eps = model.contact_params, model.contact_model.regularization_delassus
    slots, M, a_free = _penetrating_slots(model, data)
    if not slots:
        return np.zeros((model.number_of_links(), 6))
    J = np.concatenate([slot["J"] for slot in slots])
    Q = J @ np.linalg.solve(M, J.T) + eps * np.eye(J.shape[0])
    beta = np.concatenate([[0.0, 0.0, c.K * slot["depth"] - c.D * slot["v"][2]] for slot in slots])
    q = J @ a_free + np.concatenate([slot["a"] for slot in slots]) - beta
    G = _pyramids(slots)
    L = np.linalg.cholesky(Q)
    z, _ = nnls(solve_triangular(L, G.T, lower=True), -solve_triangular(L, q, lower=True), maxiter=50 * len(G))
    f = -np.linalg.solve(Q, q + G.T @ z)
    slack, tol = G @ f, 1e-8 * np.abs(f).max()
    assert (slack <= tol).all() and (np.abs(slack[z > 0]) <= tol).all(), (slack.max(), np.abs(slack[z > 0]).max())
    return _link_wrenches(model, data, slots, f.reshape(-1, 3))


# |warpdyn - NumPy| / max |NumPy| of the links' contact wrenches at MIXED's states of seeds 3 to 14 (CPU, float64):
# relaxed-rigid <= 1.5e-15 (one linear solve); rigid <= 9.1e-8 (seed 6): the interior-point solve stops at residuals
# of 1e-10 of 1 + max |q| (JaxSim's tolerance) and Q's condition is ~3e7.
FORCE_TOL = {"RelaxedRigidContacts": 1e-12, "RigidContacts": 2e-7}


@pytest.mark.parametrize("law", LAWS)
def test_the_slots_forces_are_the_law_assembled_in_numpy(law):
    """MIXED's bodies in the air, touching (sphere-box, capsule-box, capsule-capsule, sphere-cylinder, box-box) and
    moving at six random velocities: the links' contact wrenches equal each law assembled in NumPy
    (`_relaxed_link_forces`, `_rigid_link_forces` with Baumgarte's K = 1e4, D = 100) to FORCE_TOL of the largest."""
    params = {"K": 1e4, "D": 100.0} if law == "RigidContacts" else {}
    model = _solved(MIXED, law, **params)
    for seed in range(3, 9):
        rng = np.random.default_rng(seed)
        data = wd.data.Data.build(model, joint_velocities=rng.normal(size=model.dofs()) * 0.3, velocity_representation=wd.VelRepr.Inertial)
        expected = (_rigid_link_forces if law == "RigidContacts" else _relaxed_link_forces)(model, data)
        got = wd.contact.link_contact_forces(model, data)[0].numpy()
        assert np.abs(expected).max() > 1.0
        np.testing.assert_allclose(got, expected, rtol=0, atol=FORCE_TOL[law] * np.abs(expected).max(), err_msg=f"seed {seed}")


CASES = [("RelaxedRigidContacts", np.float64), ("RelaxedRigidContacts", np.float32), ("RigidContacts", np.float64)]


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("law, dtype", CASES, ids=["relaxed-float64", "relaxed-float32", "rigid-float64"])
@pytest.mark.parametrize("scene", SCENES)
def test_scenes_come_to_rest_where_mujocos_do(scene, law, dtype):
    """After 1.5 s (1 ms steps) under the relaxed-rigid or rigid law (JaxSim's defaults: the rigid law without
    Baumgarte's terms) on the pairs' contacts and on the floor's points, each body's position is MuJoCo's within
    REST_TOL (measured at most 0.81 mm for each, the crossed cylinders) and it has stopped (ROLLING's
    bounds). The rigid law in float32 warns (tests/test_contact_models.py) and is not held to MuJoCo's rest."""
    xml = SCENES[scene]
    model = _solved(xml, law, dtype)
    data = wd.data.Data.build(model)
    for _ in range(1500):
        data = wd.model.step(model, data)
    assert bool(data.healthy.numpy().all())
    assert float(np.abs(data.generalized_velocity.numpy()).max()) < ROLLING.get(scene, 1e-3)
    mj = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(mj)
    for _ in range(1500):
        mujoco.mj_step(mj, d)
    for name, position in _positions(model, data).items():
        np.testing.assert_allclose(position, d.xpos[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, name)], atol=REST_TOL, err_msg=name)


def _thrown_spheres(law):
    """TWO_SPHERES without gravity, spinning and thrown at each other: (model, data), Inertial velocities."""
    model = _solved(TWO_SPHERES, law)
    qpos = np.array([-0.3, 0, 1, 1, 0, 0, 0, 0.3, 0.04, 1.02, 1, 0, 0, 0], dtype=np.float64)
    velocity = np.array([1.0, 0, 0, 0, 2.0, 0, -1.5, 0, 0, 0, 0, 3.0])
    return model, wd.data.Data.build(model, joint_positions=qpos, joint_velocities=velocity, velocity_representation=wd.VelRepr.Inertial)


@pytest.mark.parametrize("law", LAWS)
def test_momentum_is_conserved_in_free_flight(law):
    """Without gravity or terrain, two spinning spheres thrown at each other keep their total linear and angular
    momentum about the origin through the collision (1e-10 relative over 400 steps): the slot's force, and the rigid
    law's impact, act on both bodies, equal and opposite, at one point."""
    model, data = _thrown_spheres(law)
    before = wd.model.total_momentum(model, data).numpy()
    touched = False
    for _ in range(400):
        data = wd.model.step(model, data)
        touched = touched or bool((wd.contact.geom_contacts(model, data).distance.numpy() < 0).any())
    assert touched
    np.testing.assert_allclose(wd.model.total_momentum(model, data).numpy(), before, rtol=1e-10, atol=1e-10)


def test_the_rigid_impact_stops_each_penetrating_contact():
    """Under the rigid law, after each step the velocity of geom2's point relative to geom1's at each contact that
    penetrates at the step's new state is 0 in all three axes (JaxSim's impact on the slots' rows; 1e-12 m/s), the
    spheres having met at 2.5 m/s; they go on moving together."""
    model, data = _thrown_spheres("RigidContacts")
    impacts = 0
    for _ in range(400):
        data = wd.model.step(model, data)
        slots, _, _ = _penetrating_slots(model, data)
        for slot in slots:
            np.testing.assert_allclose(slot["v"], 0.0, atol=1e-12)
        impacts += bool(slots)
    assert impacts > 0
    assert np.abs(data.generalized_velocity.numpy()).max() > 0.1


@pytest.mark.parametrize("law", LAWS)
def test_condim_1_is_frictionless(law):
    """A pair of condim 1 gets no tangential force under the relaxed-rigid or rigid law either (its tangential rows are
    zeros, the rigid pyramid's mu 0): the spheres' wrench, moving sideways against each other and b pushed sideways
    into a by a link force (the rigid law's friction holds the tangential acceleration, not the velocity), lies along
    the normal; with condim 3 it does not."""
    qpos = np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0], dtype=np.float64)
    velocity = np.array([0.0, 0.5, 0, 0, 0, 0, 0, -0.5, 0, 0, 0, 0])
    for condim, frictionless in ((1, True), (3, False)):
        xml = TWO_SPHERES.replace('friction="0.7"', f'friction="0.7" condim="{condim}"').replace('friction="0.4"', f'friction="0.4" condim="{condim}"')
        model = _solved(xml, law, **({"K": 1e4, "D": 100.0} if law == "RigidContacts" else {}))
        data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=velocity)
        push = np.zeros((model.number_of_links(), 6))
        push[model.link_names().index("b"), :3] = (-10.0, 30.0, 0.0)
        f = wd.contact.link_contact_forces(model, data, link_forces=push)[0].numpy()[model.link_names().index("b"), :3]
        n = wd.contact.geom_contacts(model, data).frame.numpy()[0, 0]
        tangential = np.linalg.norm(f - (f @ n) * n)
        assert np.linalg.norm(f) > 1.0
        assert (tangential < 1e-9 * np.linalg.norm(f)) == frictionless, (condim, tangential, np.linalg.norm(f))


@pytest.mark.parametrize("law", LAWS)
def test_link_contact_forces_are_the_contacts_alone(law):
    """JaxSim's link_contact_forces with link_forces: those act on the solve's free accelerations, and the result is the
    contacts' wrenches alone: zero for the spheres apart (where wd.ode.system_acceleration accelerates b by the push);
    touching, with b pushed into a, a force on each, equal and opposite (their sum 0, where the push's 31.6 N would
    show)."""
    qpos = np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0], dtype=np.float64)
    model = _solved(TWO_SPHERES, law, **({"K": 1e4, "D": 100.0} if law == "RigidContacts" else {}))
    push = np.zeros((model.number_of_links(), 6))
    push[model.link_names().index("b"), :3] = (-10.0, 30.0, 0.0)
    apart = qpos.copy()
    apart[7] += 1.0
    for q, touching in ((apart, False), (qpos, True)):
        data = wd.data.Data.build(model, joint_positions=q, velocity_representation=wd.VelRepr.Inertial)
        f = wd.contact.link_contact_forces(model, data, link_forces=push)[0].numpy()[:, :3]
        assert (np.abs(f).max() > 1.0) == touching, f
        np.testing.assert_allclose(f.sum(axis=0), 0.0, atol=1e-9 * max(1.0, np.abs(f).max()))
        if not touching:  # and the dynamics read the push: b (0.5 kg, its base the world) accelerates at push / m
            accelerations = wd.ode.system_acceleration(model, data, link_forces=push)[1].numpy().reshape(-1)
            np.testing.assert_allclose(accelerations[6:9], (-20.0, 60.0, 0.0), atol=1e-9)


def _mixed(law):
    """MIXED's touching bodies, moving (the brick tilted: box-box faces exactly parallel are not differentiable,
    test_body_contacts says why): (model, data)."""
    model = _solved(MIXED, law, **({"K": 1e4, "D": 100.0} if law == "RigidContacts" else {}))
    return model, wd.data.Data.build(model, joint_velocities=np.random.default_rng(0).normal(size=model.dofs()) * 0.3)


PARAMETER_CASES = {"RelaxedRigidContacts": ("link_mass", 1e-6), "RigidContacts": ("K", 1e-4)}
"""law: (the parameter varied, the bound relative to the central difference at h = 1e-4 of it). Measured on MIXED
(CPU): the relaxed law's ball mass 1.5e-9, the rigid law's K 2.9e-6 (the QP's tolerance over h)."""


@pytest.mark.parametrize("law", LAWS)
def test_link_contact_forces_differentiate_in_the_models_parameters(law):
    """With only a model parameter requiring gradients (the data not), link_contact_forces' wrenches carry the tape's
    gradients, also with link_forces given and in Body representation (before, their arrays were made with the data's
    requires_grad: no gradient flowed): d(w . f)/d(p) equals central differences (PARAMETER_CASES)."""
    name, bound = PARAMETER_CASES[law]
    model, data = _mixed(law)
    data = wd.data.Data.build(model, joint_positions=data.joint_positions.numpy(), joint_velocities=data.joint_velocities.numpy())
    push = np.full((model.number_of_links(), 6), 0.3)
    weights = np.random.default_rng(5).normal(size=(model.number_of_links(), 6))
    link = model.link_names().index("ball")

    def loss(varied) -> float:
        return float(np.sum(weights * wd.contact.link_contact_forces(varied, data, link_forces=push, output_vel_repr=wd.VelRepr.Body)[0].numpy()))

    def with_value(dv):
        varied = model.copy()
        if name == "K":
            varied.contact_params = dataclasses.replace(varied.contact_params, K=value + dv)
        else:
            varied.set_link_parameters(mass=masses + dv * (np.arange(masses.size) == link))
        return varied

    masses = model.link_mass.numpy().copy()
    value = float(model.contact_params.K) if name == "K" else masses[link]
    h = 1e-4 * value
    central = (loss(with_value(h)) - loss(with_value(-h))) / (2.0 * h)
    marked = wd.model.parameters_requiring_grad(model, names=(name,))
    tape = wp.Tape()
    with tape:
        f = wd.contact.link_contact_forces(model, data, link_forces=push, output_vel_repr=wd.VelRepr.Body)[0]
    f.grad.assign(wp.array(weights, dtype=model.scalar, device=model.device))
    tape.backward()
    taped = marked[name].grad.numpy().reshape(-1)[0 if name == "K" else link]
    assert abs(central) > 1e-3 and abs(taped - central) <= bound * abs(central), (taped, central)


JACOBIAN_CASES = {"relaxed": ("RelaxedRigidContacts", 1e-7, 5e-7), "rigid": ("RigidContacts", 1e-5, 2e-7)}
"""law: (h, bound relative to the largest entry). Measured on MIXED: the relaxed law 1.1e-7 at h = 1e-7 (its solve is
exact); the rigid law 4.6e-8 at h = 1e-5 (truncation at 1e-4, 6e-6; the QP's tolerance over h below 1e-6). The rigid
impact at the new state's contacts solves its singular Delassus matrix regularised (kernels/rigid_contacts.py's
IMPACT_REGULARISATION): dropping its dependent rows instead had left 3e-8 of noise in the velocities of the two
boxes, and differences that grew as 1 / h from 6e-6."""


@pytest.mark.parametrize("case", JACOBIAN_CASES)
def test_a_steps_jacobians_through_body_contacts_equal_central_differences(case):
    """wd.autodiff's reverse A and B (one taped step: the narrow phase, the slots' rows, the solve's hand-written
    adjoint, the wrenches, and the rigid impact's at the new state's contacts) equal central differences to
    JACOBIAN_CASES' bound of the largest entry (without the contacts MIXED's A's entries differ by up to 36.5, its
    largest)."""
    law, h, bound = JACOBIAN_CASES[case]
    model, data = _mixed(law)
    assert np.abs(wd.contact.link_contact_forces(model, data)[0].numpy()).max() > 1.0
    reverse = wd.autodiff.transition_matrices(model, data, method="reverse")
    central = wd.autodiff.transition_matrices(model, data, method="central", h=h)
    for name in ("A", "B"):
        r, c = reverse[name].numpy(), central[name].numpy()
        assert np.abs(r - c).max() < bound * np.abs(c).max(), (name, np.abs(r - c).max(), np.abs(c).max())


@pytest.mark.parametrize("law", LAWS)
def test_more_penetrating_contacts_than_max_active_contacts_flag_that_environment(law):
    """RelaxedRigidContacts(max_active_contacts=n) and RigidContacts(max_active_contacts=n) size the solve for n contacts:
    an environment where more penetrate (a stack of boxes at rest: its floor and box-box contacts) is flagged and
    frozen, one in the air goes on as without the limit (the same numbers), and a limit the scene stays within changes
    nothing (bit for bit)."""
    xml = SCENES["a stack of boxes"]
    model = _solved(xml, law)
    resting = wd.data.Data.build(model)
    for _ in range(300):
        resting = wd.model.step(model, resting)
    q = resting.joint_positions.numpy().reshape(1, -1)
    lifted = q.copy()
    lifted[0, 2::7] += np.array([1.0, 2.0, 3.0])  # each box's height, a metre apart from the next
    active = int((wd.contact.geom_contacts(model, resting).distance.numpy() < 0).sum())  # the box-box contacts alone
    assert active >= 4
    kind = getattr(wd.rbda.contacts, law)
    states = {}
    for limit in (None, 3, 200):
        limited = model.replace(contact_model=kind(max_active_contacts=limit))
        data = wd.data.Data.build(limited, joint_positions=np.concatenate([q, lifted]), num_envs=2)
        for _ in range(50):
            data = wd.model.step(limited, data)
        states[limit] = (data.healthy.numpy(), data.joint_positions.numpy())
    assert states[None][0].tolist() == [True, True] and states[200][0].tolist() == [True, True]
    assert states[3][0].tolist() == [False, True]
    np.testing.assert_array_equal(states[200][1], states[None][1])
    np.testing.assert_array_equal(states[3][1][1], states[None][1][1])
    with pytest.raises(ValueError, match=rf"{law}.max_active_contacts must be an integer >= 1, got 0"):
        kind(max_active_contacts=0)


def test_an_impact_beyond_max_active_contacts_on_data_without_health_flags_says_so():
    """RigidContacts.update_velocity_after_impact on data without health flags (valid_state None) where more contacts
    penetrate than max_active_contacts: no write out of bounds (the flag has nowhere to go), the velocities made NaN;
    with the flags, the environment flagged and its velocities left as they were."""
    import dataclasses

    model = _solved(SCENES["a stack of boxes"], "RigidContacts")
    resting = wd.data.Data.build(model)
    for _ in range(50):
        resting = wd.model.step(model, resting)
    limited = model.replace(contact_model=wd.rbda.contacts.RigidContacts(max_active_contacts=2))
    flagged = limited.contact_model.update_velocity_after_impact(limited, resting)
    assert not bool(flagged.healthy.numpy().all())
    np.testing.assert_array_equal(flagged.generalized_velocity.numpy(), resting.generalized_velocity.numpy())
    unflagged = limited.contact_model.update_velocity_after_impact(limited, dataclasses.replace(resting, valid_state=None))
    assert np.isnan(unflagged.generalized_velocity.numpy()).all()
