"""Linearly implicit soft contacts in a semi-implicit Euler step (model.implicit_contacts, kernels/implicit_contacts.py):
one step of free bodies against a NumPy solve of the linearised contact forces, the stability that they buy (a pad on
the 0.1 kg cube's edge at 1 ms, beside MuJoCo), that resting contacts rest where explicit ones do, the refusals, and
a step's Jacobian against central differences."""

import contextlib
import warnings

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from warpdyn.engine import contact_stage

EPS = 2.220446049250313e-16
K, D, P, Q = 1e6, 2000.0, 0.5, 0.5  # SoftContactsParams' defaults
H = 1e-3

SCENE = """<mujoco><option timestep="0.001"/><worldbody>
  <geom name="table" type="box" size=".5 .5 .05" pos="3 0 0.95" friction="{mu}"/>
  <body name="ball" pos="3 0 1.049"><freejoint/><geom type="sphere" size=".05" mass="0.3" friction="{mu}"/></body>
  <body name="cube" pos="0 0 0.049"><freejoint/><geom type="box" size=".05 .05 .05" mass="0.1"/></body>
</worldbody></mujoco>"""
"""A ball 1 mm into a table (a geom of the world: a geom pair's contact), a 0.1 kg cube 1 mm into the terrain (its four
lower corners: the collidable points' contacts), far apart, both unrotated (body axes = world axes)."""


def _model(mu: float, implicit: bool = True):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(SCENE.format(mu=mu), dtype=np.float64)
    model.geom_contacts = True
    model.implicit_contacts = implicit
    return model


def _law(depth, v, n, mu):
    """(f, alpha, beta, g, sticks): the soft law's force at a zero deformation in a linearly implicit step (its Coulomb
    limit mu min(fn, K delta^(1+p))) and its implicit terms (the module docstring of kernels/implicit_contacts.py),
    written out."""
    power = (depth + EPS) ** P
    fn = max(0.0, K * power * depth - D * power * (v @ n))
    limit = mu * min(fn, K * power * depth)
    v_t = v - (v @ n) * n
    f_t = -D * power * v_t
    sticks = np.linalg.norm(f_t) < limit
    if not sticks and np.linalg.norm(f_t) > 0:
        f_t = f_t * limit / np.linalg.norm(f_t)
    k_n, k_t, c = (1 + P) * K * power, K * power, D * power
    speed = np.linalg.norm(v_t)
    alpha = H * c + H * H * k_n
    beta = 0.0 if not sticks and limit <= 0 else H * (c + H * k_t) if sticks or speed * (c + H * k_t) <= limit else H * limit / speed
    g = -min(H * k_n * (v @ n), fn) * n - (H * k_t * v_t if sticks else 0.0)
    return fn * n + f_t, alpha, beta, g, sticks


def _expected_velocity(mass, inertia, centre, v, w, contacts, mu):
    """The body's velocity after one step: (M + sum J^T (alpha n n^T + beta (1 - n n^T)) J) a = sum J^T (f + g) - v x* M v
    + [m g; 0] in body coordinates (J = [1, -r^], r from the body's centre), a its spatial acceleration; the free joint's
    linear velocity changes by a_lin + w x v (the origin's classical acceleration); and whether each contact sticks."""
    Mb = np.diag([mass] * 3 + list(inertia))
    A, rhs, sticking = Mb.copy(), np.zeros(6), []
    for p, n, depth in contacts:
        r = p - centre
        f, alpha, beta, g, sticks = _law(depth, v + np.cross(w, r), n, mu)
        sticking.append(sticks)
        rx = np.array([[0, -r[2], r[1]], [r[2], 0, -r[0]], [-r[1], r[0], 0]])
        J = np.hstack([np.eye(3), -rx])
        A += J.T @ (beta * np.eye(3) + (alpha - beta) * np.outer(n, n)) @ J
        rhs += J.T @ (f + g)
    rhs -= np.concatenate([mass * np.cross(w, v), np.cross(w, np.asarray(inertia) * w)])
    rhs[2] -= mass * 9.81
    a = np.linalg.solve(A, rhs)
    return np.concatenate([v + H * (a[:3] + np.cross(w, v)), w + H * a[3:]]), sticking


@pytest.mark.parametrize("mu", [1.0, 0.05])
def test_one_step_is_the_linearised_solve(mu):
    """The ball on the table (a geom pair's contact) and the cube on the terrain (four corners), moving into their
    contacts and sideways, spinning: after one step each body's velocity is the NumPy solve of its linearised
    contact forces (float64, to 1e-12 relative); mu 1 (the geoms' and the terrain's) keeps the ball's contact and the
    cube's corners sticking; at 0.05 the ball and three corners slide (Coulomb's force as a damper)."""
    model = _model(mu)
    model.contact_params = wd.model.SoftContactsParams(mu=mu)
    v_ball, w_ball, v_cube, w_cube = np.array([0.01, -0.005, -0.05]), np.array([0.5, -1.0, 2.0]), np.array([0.02, -0.01, -0.03]), np.array([0.3, -0.2, 0.5])
    qpos = np.array([3, 0, 1.049, 1, 0, 0, 0, 0, 0, 0.049, 1, 0, 0, 0], dtype=np.float64)
    data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=np.concatenate([v_ball, w_ball, v_cube, w_cube]))
    after = wd.model.step(model, data).joint_velocities.numpy()
    contact = wd.contact.geom_contacts(model, data)
    count = contact.count.numpy()
    assert sorted(count) == [0, 0, 1]  # ball-table touch; cube-table, ball-cube do not
    slot = wd.contact.geom_pairs(model).first[int(np.argmax(count))]
    p, n = contact.position.numpy()[slot], contact.frame.numpy()[slot, 0]
    n = n if n @ (qpos[:3] - p) > 0 else -n  # the normal from geom1 to geom2: here towards the ball
    ball_contacts = [(p, n, -float(contact.distance.numpy()[slot]))]
    corners = wd.contact.collidable_point_positions(model, data).numpy()
    cube_contacts = [(p, np.array([0.0, 0.0, 1.0]), -p[2]) for p in corners if p[2] < 0.0 and p[0] < 1.0]
    assert len(cube_contacts) == 4
    ball, ball_sticks = _expected_velocity(0.3, [0.4 * 0.3 * 0.05**2] * 3, qpos[:3], v_ball, w_ball, ball_contacts, mu)
    cube, cube_sticks = _expected_velocity(0.1, [0.1 * 0.02 / 12] * 3, qpos[7:10], v_cube, w_cube, cube_contacts, mu)
    # at mu 0.05 the ball slides, and three corners slide while the slowest sticks: both branches in one step
    assert all(ball_sticks + cube_sticks) if mu == 1.0 else not any(ball_sticks) and sum(cube_sticks) == 1
    np.testing.assert_allclose(after[:6], ball, rtol=1e-12, atol=1e-13)
    np.testing.assert_allclose(after[6:], cube, rtol=1e-12, atol=1e-13)


CHIP = """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
  <body name="chip" pos="0 0 0.0052"><freejoint/><geom type="box" size=".01 .01 .005" mass="0.002"/></body>
</worldbody></mujoco>"""


def test_a_light_chip_rests_on_the_terrain_at_1ms():
    """A 2 g chip dropped 0.2 mm onto the terrain (its four lower corners, no geom pairs: the staged step, not the
    fused kernel): its corners' dampers act at 7 times the explicit step's stable rate, and explicit contacts threw it
    25 m up (measured); implicit, it rests after 1 s at the law's sink ((m g / 4 / K)^(2/3) = 0.03 mm), still."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(CHIP, dtype=np.float64)
    model.implicit_contacts = True
    data = wd.data.Data.build(model)
    heights = []
    for _ in range(1000):
        data = wd.model.step(model, data)
        heights.append(float(data.base_position.numpy()[2]))
    sink = (0.002 * 9.81 / 4 / K) ** (2 / 3)
    assert bool(data.healthy.numpy().all())
    assert abs(heights[-1] - (0.005 - sink)) < 1e-6 and max(heights) < 0.0053
    assert np.abs(data.generalized_velocity.numpy()).max() < 1e-9


@pytest.mark.parametrize("setting", ["RK4", "rigid"])
def test_implicit_contacts_outside_the_soft_euler_step_are_refused(setting):
    """The linearisation is the soft law's in a semi-implicit Euler step: with RK4 or RigidContacts a step refuses it,
    naming the setting."""
    model = _model(1.0)
    if setting == "RK4":
        model.integrator = wd.integrators.IntegratorType.RungeKutta4
    else:
        model.geom_contacts = False
        model.contact_model = wd.rbda.contacts.RigidContacts()
        model.contact_params = wd.rbda.contacts.RigidContactsParams()
    with pytest.raises(ValueError, match="implicit_contacts"):
        wd.model.step(model, wd.data.Data.build(model))


def test_the_setting_is_checked_and_carried():
    """model.implicit_contacts takes a bool only (naming itself otherwise), is off by default, and is carried by
    copy, replace and reduce, as the other settings."""
    model = _model(1.0, implicit=False)
    assert model.implicit_contacts is False
    with pytest.raises((TypeError, ValueError), match="implicit_contacts"):
        model.implicit_contacts = 1
    model.implicit_contacts = True
    assert model.copy().implicit_contacts and model.replace(time_step=5e-4).implicit_contacts
    assert wd.model.reduce(model, considered_joints=model.joint_names()).implicit_contacts


def test_a_batch_steps_as_its_environments_alone_in_both_layouts(layout):
    """Three environments of the scene, each with its own velocities, stepped 20 times together (the narrow phase, the
    wrenches, the implicit terms and the contact state's step each a thread per environment and item, ordered by the
    layout) equal each stepped alone, in the device's layout and environment-fastest, bitwise."""
    model = _model(1.0)
    rng = np.random.default_rng(3)
    qpos = np.array([3, 0, 1.049, 1, 0, 0, 0, 0, 0, 0.049, 1, 0, 0, 0], dtype=np.float64)
    velocities = rng.normal(scale=0.05, size=(3, 12))
    batch = wd.data.Data.build(model, joint_positions=np.tile(qpos, (3, 1)), joint_velocities=velocities, num_envs=3)
    alone = [wd.data.Data.build(model, joint_positions=qpos, joint_velocities=v) for v in velocities]
    for _ in range(20):
        batch = wd.model.step(model, batch)
        alone = [wd.model.step(model, d) for d in alone]
    for e, d in enumerate(alone):
        np.testing.assert_array_equal(batch.joint_velocities.numpy()[e], d.joint_velocities.numpy())
        np.testing.assert_array_equal(batch.tangential_deformation_state.numpy()[e], d.tangential_deformation_state.numpy()[0])


def test_the_kernels_per_item_equal_their_loops_per_environment(monkeypatch, layout):
    """Without gradients on a GPU the geom pairs' rates, their wrenches and the implicit terms run a thread per slot or
    link; with gradients (and on the CPU) a thread per environment walks them in order (deterministic adjoints). Here
    both on this device (warpdyn.engine.contact_stage's `contacts_per_environment` made to answer by gradients alone),
    in the device's layout and environment-fastest (the GPU's thread order): 50 steps of the scene, 3 environments,
    records bitwise equal on the CPU, to rounding on a GPU."""
    monkeypatch.setattr(contact_stage, "contacts_per_environment", lambda device, grad: grad)
    model = _model(1.0)
    qpos = np.array([3, 0, 1.049, 1, 0, 0, 0, 0, 0, 0.049, 1, 0, 0, 0], dtype=np.float64)
    velocities = np.random.default_rng(4).normal(scale=0.1, size=(3, 12))
    runs = []
    for grad in (False, True):
        data = wd.data.Data.build(model, joint_positions=np.tile(qpos, (3, 1)), joint_velocities=velocities, num_envs=3, requires_grad=grad)
        with wp.Tape() if grad else contextlib.nullcontext():
            final, records = wd.simulation.Rollout(model, steps=50, record=("joint_velocities", "tangential_deformation")).run(data)
        runs.append([final.joint_velocities_state.numpy(), *(records[k].numpy() for k in ("joint_velocities", "tangential_deformation"))])
    assert np.abs(runs[0][2]).max() > 0.0, "no contact deformed"
    for a, b in zip(*runs):
        robots.assert_same_compilation_results(a, b)
