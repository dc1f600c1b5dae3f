"""Contacts between bodies in a step (model.geom_contacts): the soft law at each contact of the geom pairs
(kernels/collisions.py's `geom_contact_wrenches` and `geom_contact_rates`), checked by hand on one contact, by the conservation of momentum
in free flight, by scenes of free objects coming to rest where MuJoCo's do and a pusher moving a box as MuJoCo's does,
and by a step's Jacobians against central differences.

MuJoCo's contacts are soft constraints (solref 0.02 s, solimp 0.9-0.95), warpdyn's the soft law (K = 1e6 N/m^1.5,
D = 2000, p = q = 0.5: a resting body of m kg on n contacts sinks about (m g / n / K)^(2/3), 0.1 mm for 1 kg on 4),
and the floor is warpdyn's terrain under the geoms' collidable points (MuJoCo: a plane geom). Resting positions are
held to REST_TOL: the two laws' sinks and the collidable points' (a box's 8 corners, a sphere's points on its surface)
against MuJoCo's plane contacts differ by fractions of a millimetre.
"""

import warnings

import mujoco
import numpy as np
import pytest

import warpdyn as wd

REST_TOL = 1.5e-3  # m

_RACK = """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
      <body name="rack" pos="0 0 0.022"><freejoint/>
        <geom type="box" size=".2 .2 .02" mass="2"/>
        <geom type="{rail}" size=".03 .2" pos="0 -0.1 0.05" euler="0 90 0" mass="0.5"/>
        <geom type="{rail}" size=".03 .2" pos="0 0.1 0.05" euler="0 90 0" mass="0.5"/>
      </body>{logs}
    </worldbody></mujoco>"""
"""A free rack (a slab with two rails of type `rail` along x) on the floor, and `logs` (free bodies) across it."""

SCENES = {
    "a stack of boxes": """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
      <body name="bottom" pos="0 0 0.102"><freejoint/><geom type="box" size=".1 .1 .1" mass="2"/></body>
      <body name="middle" pos="0.03 0.02 0.256" euler="0 0 20"><freejoint/><geom type="box" size=".06 .05 .05" mass="1"/></body>
      <body name="top" pos="0.02 0.03 0.340" euler="0 0 -35"><freejoint/><geom type="box" size=".03 .04 .03" mass="0.5"/></body>
    </worldbody></mujoco>""",
    "a table and a shelf": """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
      <geom name="table" type="box" size=".3 .3 .02" pos="0 0 0.4" euler="0 0 15"/>
      <body name="shelf" pos="0.8 0 0.3" euler="0 0 -20"><geom type="box" size=".2 .15 .02"/></body>
      <body name="cube" pos="0.05 -0.03 0.4705" euler="0 0 30"><freejoint/><geom type="box" size=".05 .05 .05" mass="1"/></body>
      <body name="can" pos="0.82 0.02 0.3525" euler="0 0 10"><freejoint/><geom type="capsule" size=".03 .1" euler="0 90 0" mass="0.5"/></body>
    </worldbody></mujoco>""",
    "a free ball on static scenery": """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
      <body name="step" pos="0 0 0.1"><geom type="box" size=".3 .3 .1"/></body>
      <body name="ball" pos="0.05 0.02 0.2505"><freejoint/><geom type="sphere" size=".05" mass="1"/></body>
    </worldbody></mujoco>""",
    "a ball on a box": """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
      <body name="box" pos="0 0 0.052"><freejoint/><geom type="box" size=".2 .2 .05" mass="2"/></body>
      <body name="ball" pos="0 0 0.156"><freejoint/><geom type="sphere" size=".05" mass="0.5"/></body>
    </worldbody></mujoco>""",
    "crossed capsules": _RACK.format(rail="capsule", logs="""
      <body name="log" pos="0 0 0.134" euler="90 0 0"><freejoint/><geom type="capsule" size=".03 .15" mass="0.5"/></body>"""),
    "crossed cylinders": _RACK.format(rail="cylinder", logs="""
      <body name="log" pos="0.08 0 0.134" euler="90 0 0"><freejoint/><geom type="cylinder" size=".03 .15" mass="0.5"/></body>
      <body name="pin" pos="-0.08 0 0.134" euler="90 0 0"><freejoint/><geom type="capsule" size=".03 .15" mass="0.5"/></body>"""),
    "an egg on a box": """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1"/>
      <body name="box" pos="0 0 0.052"><freejoint/><geom type="box" size=".2 .2 .05" mass="2"/></body>
      <body name="egg" pos="0.02 0.01 0.1335" euler="0 0 20"><freejoint/><geom type="ellipsoid" size=".06 .04 .03" mass="0.3"/></body>
    </worldbody></mujoco>""",
    "a can and a mesh cube on a box": """<mujoco><option timestep="0.001"/>
      <asset><mesh name="cube" vertex="-.04 -.04 -.04 .04 -.04 -.04 -.04 .04 -.04 .04 .04 -.04 -.04 -.04 .04 .04 -.04 .04 -.04 .04 .04 .04 .04 .04"/></asset>
      <worldbody><geom type="plane" size="5 5 .1"/>
        <body name="box" pos="0 0 0.052"><freejoint/><geom type="box" size=".25 .25 .05" mass="2"/></body>
        <body name="can" pos="-0.1 0.05 0.1555" euler="0 0 20"><freejoint/><geom type="cylinder" size=".04 .05" mass="0.4"/></body>
        <body name="cube" pos="0.1 -0.05 0.1455" euler="0 0 35"><freejoint/><geom type="mesh" mesh="cube" mass="0.4"/></body>
      </worldbody></mujoco>""",
    "a ball between a mesh ramp and a wall": """<mujoco><option timestep="0.001"/>
      <asset><mesh name="ramp" vertex="0 -.2 0  .4 -.2 0  0 -.2 .2  0 .2 0  .4 .2 0  0 .2 .2"/></asset>
      <worldbody><geom type="plane" size="5 5 .1"/>
        <geom type="mesh" mesh="ramp"/>
        <geom type="box" size=".02 .2 .15" pos="0.3 0 0.15"/>
        <body name="ball" pos="0.2282 0 0.1412"><freejoint/><geom type="sphere" size=".05" mass="0.3"/></body>
      </worldbody></mujoco>""",
}
"""Free objects placed a few millimetres above where they come to rest: boxes on boxes, turned about the vertical; a
cube on a table (a box of the world body) and a capsule on a shelf (a body welded to the world); a lone free ball (a
floating base) on a step of static scenery (dropped as a body, its box the world's); a ball on a box; a
capsule across the two capsule rails of a rack; a cylinder and a capsule across two cylinder rails (GJK and EPA, one
contact at each crossing, as MuJoCo's multiCCD too gives where two round sides cross); an ellipsoid lying on a box
(GJK and EPA, its witness its support point); a can standing and a mesh cube on a box (MuJoCo's multiCCD: 4 contacts
each, kernels/collision_polygons.py); a ball rolled down a mesh ramp
(a world geom: sphere-mesh, GJK and EPA, one contact as in MuJoCo) against a wall. (Dropped from higher, light bodies on several contacts need a smaller
time step: the soft law's damping is explicit, D (delta + eps)^q per contact on the body's mass.)"""


ROLLING = {"crossed cylinders": 2e-3, "an egg on a box": 8e-2}
"""A log across two rails rolls in neutral equilibrium: EPA's witnesses, placed to ~5e-8 m on the round sides, give
it a torque about its axis (8e-4 rad/s after 1.5 s here; MuJoCo's own log rolls at 0.035 rad/s by then). The egg
rocks on its one contact, rolling without slip, which the soft law's sticking spring does not dissipate: the drop
leaves it rocking, its angular velocity peaking at about 0.06 rad/s with the explicit contacts and 0.007 implicit,
undamped over 8 s (MuJoCo's soft constraints damp it: 1.7e-4 rad/s at 1.5 s); its position is MuJoCo's within 0.1 mm.
These bounds hold for the largest velocity over the last 0.1 s."""


def _model(xml, dtype=np.float64):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(xml, dtype=dtype)
    model.geom_contacts = True
    return model


def _positions(model, data) -> dict:
    W_H_L = wd.model.forward_kinematics(model, data).numpy()
    return {name: W_H_L[k, :3, 3] for k, name in enumerate(model.link_names()) if name != "world"}


@pytest.mark.parametrize("implicit", [False, True], ids=["explicit", "implicit"])
@pytest.mark.parametrize("scene", SCENES)
def test_scenes_come_to_rest_where_mujocos_do(scene, implicit):
    """After 1.5 s (1 ms steps), each body's position is MuJoCo's within REST_TOL, and it has stopped (every velocity
    below 1e-3 m/s or rad/s; ROLLING's scenes below their bound over the last 0.1 s): with the explicit contacts and
    the linearly implicit ones (model.implicit_contacts)."""
    xml = SCENES[scene]
    model = _model(xml)
    model.implicit_contacts = implicit
    data = wd.data.Data.build(model)
    window = []
    for k in range(1500):
        data = wd.model.step(model, data)
        if k >= 1400 and scene in ROLLING:  # a rolling or rocking body: its largest velocity over the last 0.1 s
            window.append(float(np.abs(data.generalized_velocity.numpy()).max()))
    speed = max(window) if window else float(np.abs(data.generalized_velocity.numpy()).max())  # the others: stopped
    assert speed < ROLLING.get(scene, 1e-3), speed
    mj = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(mj)
    for _ in range(1500):
        mujoco.mj_step(mj, d)
    for name, position in _positions(model, data).items():
        expected = d.xpos[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, name)]
        np.testing.assert_allclose(position, expected, atol=REST_TOL, err_msg=name)


TWO_SPHERES = """<mujoco><option gravity="0 0 0"/><worldbody>
  <body name="a" pos="0 0 1"><freejoint/><geom name="ga" type="sphere" size=".1" mass="1" friction="0.7"/></body>
  <body name="b" pos="0.15 0.05 1.02"><freejoint/><geom name="gb" type="sphere" size=".08" mass="0.5" friction="0.4"/></body>
</worldbody></mujoco>"""


def test_one_contact_is_the_soft_law_by_hand():
    """Two interpenetrating spheres moving apart sideways: the wrench on each is the Hunt/Crossley force at the depth
    -dist along MuJoCo's normal with the relative velocity of the contact point, its tangential part capped at the
    pair's mu (the larger sliding friction, 0.7) times the normal force, equal and opposite on the two links."""
    model = _model(TWO_SPHERES)
    qpos = np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0], dtype=np.float64)
    v_a, w_a, v_b, w_b = np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.5, -2.0]), np.array([-0.4, 0.6, 0.1]), np.array([0.3, -1.0, 0.2])
    data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=np.concatenate([v_a, w_a, v_b, w_b]))
    W_f = wd.contact.link_contact_forces(model, data, output_vel_repr=wd.VelRepr.Inertial)[0].numpy()
    contact = wd.contact.geom_contacts(model, data)
    assert list(contact.count.numpy()) == [1]
    p, n, dist = contact.position.numpy()[0], contact.frame.numpy()[0, 0], float(contact.distance.numpy()[0])
    c_a, c_b = np.array([0, 0, 1.0]), np.array([0.15, 0.05, 1.02])
    assert dist == pytest.approx(np.linalg.norm(c_b - c_a) - 0.18, abs=1e-15)
    v = (v_b + np.cross(w_b, p - c_b)) - (v_a + np.cross(w_a, p - c_a))
    K, D, p_e = 1e6, 2000.0, 0.5
    delta = -dist
    fn = max(0.0, K * (delta + 2.220446049250313e-16) ** p_e * delta - D * (delta + 2.220446049250313e-16) ** p_e * (v @ n))
    v_t = v - (v @ n) * n
    f_t = -D * (delta + 2.220446049250313e-16) ** p_e * v_t
    if np.linalg.norm(f_t) > 0.7 * fn:
        f_t *= 0.7 * fn / np.linalg.norm(f_t)
    f = fn * n + f_t
    links = model.link_names()
    np.testing.assert_allclose(W_f[links.index("b")], np.concatenate([f, np.cross(p, f)]), rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(W_f[links.index("a")], -W_f[links.index("b")], rtol=0, atol=0)


def test_a_slots_deformation_is_the_tangential_spring():
    """The contact in a pair's slot carries JaxSim's tangential deformation m (its row in the contact state after the
    collidable points'): the tangential force is -(K delta^p m_t + D delta^q v_t) within the cone, and m's rate is
    v_t - (K / D) m_n while it sticks; an empty slot's deformation relaxes as -(K / D) m."""
    model = _model(TWO_SPHERES)
    points = len(model.kin_dyn_structure().contact_parameters.body)
    assert model.contact_state_rows() == points + 1
    qpos = np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0], dtype=np.float64)
    velocities = np.array([0.01, -0.02, 0.0, 0.0, 0.0, 0.0, -0.01, 0.01, 0.0, 0.0, 0.0, 0.0])
    m = np.zeros((points + 1, 3))
    m[points] = [2e-5, -1e-5, 3e-6]
    data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=velocities, contact_state={"tangential_deformation": m})
    W_f, rates = wd.contact.link_contact_forces(model, data, output_vel_repr=wd.VelRepr.Inertial)
    contact = wd.contact.geom_contacts(model, data)
    p, n, delta = contact.position.numpy()[0], contact.frame.numpy()[0, 0], -float(contact.distance.numpy()[0])
    v = (velocities[6:9] + np.cross(velocities[9:], p - np.array([0.15, 0.05, 1.02]))) - (velocities[:3] + np.cross(velocities[3:6], p - np.array([0, 0, 1.0])))
    K, D, eps = 1e6, 2000.0, 2.220446049250313e-16
    power = (delta + eps) ** 0.5
    fn = K * power * delta - D * power * (v @ n)
    v_t, m_n = v - (v @ n) * n, (m[points] @ n) * n
    f_t = -(K * power * (m[points] - m_n) + D * power * v_t)
    assert np.linalg.norm(f_t) < 0.7 * fn  # it sticks
    f = fn * n + f_t
    np.testing.assert_allclose(W_f.numpy()[model.link_names().index("b")], np.concatenate([f, np.cross(p, f)]), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(rates["m_dot"].numpy()[points], v_t - K / D * m_n, rtol=1e-12, atol=1e-15)
    apart = wd.data.Data.build(model, joint_positions=qpos + np.r_[np.zeros(7), 0.5, 0, 0, np.zeros(4)], contact_state={"tangential_deformation": m})
    np.testing.assert_allclose(wd.contact.link_contact_forces(model, apart)[1]["m_dot"].numpy()[points], -K / D * m[points], rtol=1e-15)


SLOPE = """<mujoco><option timestep="0.001"/><worldbody>
  <geom name="ramp" type="box" size="2 .5 .05" pos="0 0 1" euler="0 20 0" friction="0.8"/>
  <body name="box"><freejoint/><geom type="box" size=".05 .05 .05" mass="0.5" friction="0.8"/></body>
</worldbody></mujoco>"""
"""A box on a ramp tilted 20 degrees (tan 20 = 0.364), 1 m above the terrain: friction 0.8 holds it, 0.3 lets it slide."""


@pytest.mark.parametrize("mu", [0.8, 0.3])
def test_static_friction_holds_a_box_on_a_slope(mu):
    """Placed on the ramp, the box sticks where mu > tan 20 degrees: it moves less than 1e-8 m from 0.5 s to 2 s (the
    deformation holds it; without it, the law's damper alone let it creep 20 mm/s; MuJoCo's soft constraints creep 1.7
    mm/s here); where mu < tan 20 it slides down with Coulomb's acceleration g (sin 20 - mu cos 20) within 1e-6 (relative)."""
    model = _model(SLOPE.replace('friction="0.8"', f'friction="{mu}"'))
    angle = np.radians(20.0)
    normal = np.array([np.sin(angle), 0.0, np.cos(angle)])
    data = wd.data.Data.build(model, base_position=[0, 0, 1] + 0.1 * normal, base_quaternion=[np.cos(angle / 2), 0, np.sin(angle / 2), 0])
    positions = {}
    for k in range(2000):
        data = wd.model.step(model, data)
        if k + 1 in (500, 1000, 2000):
            positions[k + 1] = wd.model.forward_kinematics(model, data).numpy()[0, :3, 3]
    assert bool(data.healthy.numpy().all())
    if mu > np.tan(angle):
        assert np.linalg.norm(positions[2000] - positions[500]) < 1e-8
        return
    s = {k: p @ np.array([np.cos(angle), 0.0, -np.sin(angle)]) for k, p in positions.items()}  # down the ramp [m]
    acceleration = 2.0 * ((s[2000] - s[1000]) / 1.0 - (s[1000] - s[500]) / 0.5) / 1.5
    np.testing.assert_allclose(acceleration, 9.81 * (np.sin(angle) - mu * np.cos(angle)), rtol=1e-6)


def test_momentum_is_conserved_in_free_flight():
    """Without gravity or terrain, two spheres thrown at each other (and spinning) keep their total linear and angular
    momentum about the origin through the collision: the contact wrenches are equal and opposite at one point (float64,
    1e-10 relative over 400 steps of semi-implicit Euler, whose momentum update is exact for internal forces)."""
    model = _model(TWO_SPHERES)
    qpos = np.array([-0.3, 0, 1, 1, 0, 0, 0, 0.3, 0.04, 1.02, 1, 0, 0, 0], dtype=np.float64)
    velocity = np.array([1.0, 0, 0, 0, 2.0, 0, -1.5, 0, 0, 0, 0, 3.0])
    data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=velocity)

    def momentum(data):  # [linear; angular about the world's origin] (the base frame of a scene is the world)
        return wd.model.total_momentum(model, data).numpy()

    before = momentum(data)
    touched = False
    for _ in range(400):
        data = wd.model.step(model, data)
        touched = touched or bool(wd.contact.geom_contacts(model, data).count.numpy().sum())
    assert touched
    np.testing.assert_allclose(momentum(data), before, rtol=1e-10, atol=1e-10)


def test_off_by_default():
    """model.geom_contacts is False unless set (the spheres then pass through each other); data built before it was
    set is refused, naming the rows (the relaxed-rigid and rigid laws on the pairs: test_body_contacts_solved.py)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(TWO_SPHERES, dtype=np.float64)
    assert model.geom_contacts is False
    data = wd.data.Data.build(model, joint_positions=np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0.0]))
    np.testing.assert_array_equal(wd.contact.link_contact_forces(model, data)[0].numpy(), 0.0)
    model.geom_contacts = True  # the pairs' contact slots join the contact state: data built before is refused
    with pytest.raises(ValueError, match=r"data holds 100 rows .* has 101: 100 collidable points and 1 geom pair contact slots"):
        wd.contact.link_contact_forces(model, data)
    data = wd.data.Data.build(model, joint_positions=np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0.0]))
    assert np.abs(wd.contact.link_contact_forces(model, data)[0].numpy()).max() > 1.0
    with pytest.raises(TypeError, match="geom_contacts"):
        model.geom_contacts = 1


MIXED = """<mujoco><option timestep="0.001"/><worldbody>
  <body name="box" pos="0 0 1" euler="2 -1 3"><freejoint/><geom type="box" size=".2 .2 .05" mass="2"/></body>
  <body name="ball" pos="0.03 0.02 1.098"><freejoint/><geom type="sphere" size=".05" mass="0.5"/></body>
  <body name="lying" pos="-0.05 0.05 1.078" euler="0 89 20"><freejoint/><geom type="capsule" size=".03 .1" mass="0.5"/></body>
  <body name="across" pos="-0.05 0.05 1.135" euler="0 91 80"><freejoint/><geom type="capsule" size=".03 .1" mass="0.5"/></body>
  <body name="can" pos="0.1 -0.1 1.12" euler="20 0 0"><freejoint/><geom type="cylinder" size=".03 .05" mass="0.5"/></body>
  <body name="pebble" pos="0.1 -0.1 1.2"><freejoint/><geom type="sphere" size=".03" mass="0.5"/></body>
  <body name="brick" pos="-0.1 -0.1 1.083" euler="2 -1.5 20"><freejoint/><geom type="box" size=".05 .04 .04" mass="0.5"/></body>
</worldbody></mujoco>"""
"""Bodies in the air, touching: sphere-box, capsule-box (lying flat: two contacts), capsule-capsule, sphere-cylinder,
box-box (a brick tilted on the slab: a clipped face manifold of 4 contacts)."""


@pytest.mark.parametrize("implicit", [False, True], ids=["explicit", "implicit"])
def test_a_steps_jacobians_through_body_contacts_equal_central_differences(implicit):
    """wd.autodiff's reverse A and B (one taped step, its adjoint through the narrow phase and the law) equal
    MuJoCo-style central differences (h = 1e-7) to 1e-7 of the largest entry (the differences' own error: the law's
    curvature, delta^1.5, over h; 1.2e-8 measured). Box-box faces exactly parallel are not differentiable: which box's
    face is the reference flips with rounding (MuJoCo's tie), and the contacts of the two choices have different
    derivatives; the brick here is tilted. The same with the linearly implicit contacts (their terms' adjoint too)."""
    model = _model(MIXED)
    model.implicit_contacts = implicit
    data = wd.data.Data.build(model, joint_velocities=np.random.default_rng(0).normal(size=model.dofs()) * 0.3)
    count = wd.contact.geom_contacts(model, data).count.numpy()
    names = wd.contact.geom_pairs(model).names
    touching = {names[k]: int(count[k]) for k in np.flatnonzero(count)}
    assert len(touching) >= 5 and max(touching.values()) == 4, touching
    reverse = wd.autodiff.transition_matrices(model, data, method="reverse")
    central = wd.autodiff.transition_matrices(model, data, method="central", h=1e-7)
    for name in ("A", "B"):
        r, c = reverse[name].numpy(), central[name].numpy()
        assert np.abs(r - c).max() < 1e-7 * np.abs(c).max(), (name, np.abs(r - c).max(), np.abs(c).max())


PUSHER = """<mujoco><option timestep="0.001"/><worldbody><geom type="plane" size="5 5 .1" friction="0.6"/>
  <body name="slide" pos="0 0 0.05"><joint name="push" type="slide" axis="1 0 0" damping="50"/>
    <geom type="capsule" size=".03 .08" euler="90 0 0" mass="1"/></body>
  <body name="box" pos="0.2 0.03 0.0505"><freejoint/><geom type="box" size=".05 .05 .05" mass="0.8" friction="0.6"/></body>
</worldbody>
<actuator><position joint="push" kp="3000"/></actuator></mujoco>"""
"""A capsule on a position-controlled slide joint pushes a box across the floor (friction 0.6 in both: warpdyn's
terrain through SoftContactsParams' mu, the box-capsule pair through the geoms')."""


def test_a_pusher_moves_a_box_as_in_mujoco():
    """The slide's target ramps from 0 to 0.3 m over 1.5 s and holds: the capsule meets the box, pushes it 18 cm and
    stops; the box slides to rest where MuJoCo's does (within REST_TOL; 0.4 mm measured), with the pusher."""
    model = _model(PUSHER)
    model.contact_params = wd.model.SoftContactsParams(mu=0.6)
    data = wd.data.Data.build(model)
    mj = mujoco.MjModel.from_xml_string(PUSHER)
    d = mujoco.MjData(mj)
    for k in range(2500):
        u = np.array([min(k * 1e-3 / 1.5, 1.0) * 0.3])
        data = wd.model.step(model, data, ctrl=u)
        d.ctrl[:] = u
        mujoco.mj_step(mj, d)
    box = _positions(model, data)["box"]
    np.testing.assert_allclose(box, d.xpos[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, "box")], atol=REST_TOL)
    assert box[0] > 0.37 and float(np.abs(data.generalized_velocity.numpy()).max()) < 1e-3


def test_condim_1_is_frictionless():
    """A pair whose condim is 1 (MuJoCo: frictionless) gets no tangential force: the two spheres' wrench, moving
    sideways against each other, lies along the contact normal."""
    model = _model(TWO_SPHERES.replace('friction="0.7"', 'friction="0.7" condim="1"').replace('friction="0.4"', 'friction="0.4" condim="1"'))
    assert wd.contact.geom_pairs(model).condim.tolist() == [1]
    qpos = np.array([0, 0, 1, 1, 0, 0, 0, 0.15, 0.05, 1.02, 1, 0, 0, 0], dtype=np.float64)
    data = wd.data.Data.build(model, joint_positions=qpos, joint_velocities=np.array([0.0, 0.5, 0, 0, 0, 0, 0, -0.5, 0, 0, 0, 0]))
    f = wd.contact.link_contact_forces(model, data, output_vel_repr=wd.VelRepr.Inertial)[0].numpy()[model.link_names().index("b"), :3]
    n = wd.contact.geom_contacts(model, data).frame.numpy()[0, 0]
    assert np.linalg.norm(f) > 1.0 and np.linalg.norm(f - (f @ n) * n) < 1e-9 * np.linalg.norm(f)


def test_in_contact_reads_the_bodies_touching_as_mujoco():
    """wd.contact.in_contact with model.geom_contacts: a body is in contact where MuJoCo has a contact involving it at
    dist <= 0 (the other boxes or the floor: warpdyn's terrain under the boxes' corner points), over 40 random poses
    of the stack of boxes (positions within a few centimetres of each other, any orientation); without
    geom_contacts only the floor counts."""
    xml = SCENES["a stack of boxes"]
    model = _model(xml)
    mj = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(mj)
    rng = np.random.default_rng(8)
    names = model.link_names()
    qpos = np.zeros((40, mj.nq))
    for k in range(3):
        qpos[:, 7 * k : 7 * k + 3] = np.array([0.0, 0.0, 0.1 + 0.09 * k]) + rng.uniform(-0.05, 0.05, (40, 3))
        quaternion = rng.normal(size=(40, 4))
        qpos[:, 7 * k + 3 : 7 * k + 7] = quaternion / np.linalg.norm(quaternion, axis=1, keepdims=True)
    data = wd.data.Data.build(model, num_envs=40, joint_positions=qpos)
    touching = wd.contact.in_contact(model, data).numpy()
    terrain_only = wd.contact.in_contact(model.replace(geom_contacts=False), data).numpy()
    seen = np.zeros(3, dtype=int)
    for env in range(40):
        d.qpos[:] = qpos[env]
        mujoco.mj_forward(mj, d)
        bodies, floor = set(), set()
        for c in d.contact[: d.ncon]:
            if c.dist <= 0.0:
                pair = {int(mj.geom_bodyid[c.geom1]), int(mj.geom_bodyid[c.geom2])}
                bodies |= pair
                if 0 in pair:
                    floor |= pair
        for body in (1, 2, 3):
            name = mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_BODY, body)
            assert touching[env, names.index(name)] == (body in bodies), (env, name)
            assert terrain_only[env, names.index(name)] == (body in floor), (env, name)
        seen += [(body in bodies) and (body not in floor) for body in (1, 2, 3)]
    assert seen.min() > 0  # each box touches another box, off the floor, in some pose
    repeated = wd.contact.in_contact(model, data, link_names=["top", "middle", "top"]).numpy()
    np.testing.assert_array_equal(repeated, touching[:, [names.index("top"), names.index("middle"), names.index("top")]])


PINCH = """<mujoco><option timestep="0.001"/>
<worldbody><geom type="plane" size="5 5 .1"/>
  <body name="carrier" pos="0 0 0.03">
    <joint name="lift" type="slide" axis="0 0 1" damping="100"/>
    <inertial pos="0 0 0" mass="1" diaginertia="0.01 0.01 0.01"/>
    <body name="left" pos="0 0.06 0"><joint name="left_slide" type="slide" axis="0 -1 0" damping="20"/>
      <geom type="box" size=".02 .01 .025" mass="0.2" friction="1"/></body>
    <body name="right" pos="0 -0.06 0"><joint name="right_slide" type="slide" axis="0 1 0" damping="20"/>
      <geom type="box" size=".02 .01 .025" mass="0.2" friction="1"/></body>
  </body>
  <body name="cube" pos="0 0 0.0255"><freejoint/><geom type="box" size=".025 .025 .025" mass="0.1" friction="1"/></body>
</worldbody>
<contact><exclude body1="carrier" body2="left"/><exclude body1="carrier" body2="right"/><exclude body1="left" body2="right"/></contact>
<actuator><position joint="lift" kp="3000" kv="200"/><position joint="left_slide" kp="400"/><position joint="right_slide" kp="400"/></actuator>
</mujoco>"""
"""Two box fingers on slides squeeze a 0.1 kg cube (7.5 N each at the target) and a position-controlled carrier lifts
them 15 cm: a light body on 16 contacts."""


def _pinch(dt: float, squeeze: np.ndarray, seconds: float, implicit: bool = False):
    """The pinch scene at time step dt, environment e squeezing to squeeze[e] [m], with explicit or linearly implicit
    contacts (model.implicit_contacts): (the final data, the cube's and the left finger's heights (steps, N) after the
    lift began)."""
    model = _model(PINCH.replace('timestep="0.001"', f'timestep="{dt}"'))
    model.implicit_contacts = implicit
    N = len(squeeze)
    data = wd.data.Data.build(model, num_envs=N)
    cube, left = model.link_names().index("cube"), model.link_names().index("left")
    heights = []
    for k in range(int(round(seconds / dt))):
        t = k * dt
        lift = 0.0 if t < 0.5 else min(0.15, 0.3 * (t - 0.5))
        ctrl = np.stack([np.full(N, lift), np.where(t > 0.2, squeeze, 0.0), np.where(t > 0.2, squeeze, 0.0)], axis=1)
        data = wd.model.step(model, data, ctrl=ctrl)
        if t >= 1.1:
            H = wd.model.forward_kinematics(model, data).numpy()
            heights.append((H[:, cube, 2, 3], H[:, left, 2, 3]))
    return data, np.array(heights)


def test_a_light_body_squeezed_beyond_the_dampers_stability_is_flagged():
    """The soft law's damping is explicit: squeezed at 1 ms, the cube's contacts damp its velocity at 3 times the
    step's stable rate (their coefficients D delta^q summed, over its mass), and without a check it was thrown
    kilometres while its environment stayed 'healthy'. Now that environment is flagged and frozen as the squeeze
    begins; a second one that does not squeeze is not; at 0.25 ms the squeeze is stable, the cube is lifted and held
    by the contacts' tangential deformation (static friction): it slips down the fingers by less than 0.01 mm/s
    (measured 2.6e-3 mm/s; 5.4 mm/s before the contacts carried the deformation; MuJoCo's soft constraints let it
    slip 2.2 mm/s)."""
    data, _ = _pinch(0.001, np.array([0.04, 0.0]), 0.5)
    assert data.healthy.numpy().tolist() == [0, 1]
    assert np.abs(data.generalized_velocity.numpy()[0]).max() < 10.0  # frozen at the flag, not thrown
    data, heights = _pinch(0.00025, np.array([0.04]), 1.6)
    assert data.healthy.numpy().all()
    cube, finger = heights[:, 0, 0], heights[:, 1, 0]
    assert cube[-1] > 0.15  # lifted with the fingers
    slip = ((finger[-1] - cube[-1]) - (finger[0] - cube[0])) / (0.25e-3 * (len(cube) - 1))
    assert abs(slip) < 1e-5, slip


def test_implicit_contacts_hold_the_squeezed_cube_at_1ms():
    """The same squeeze and lift at 1 ms with the linearly implicit contacts (model.implicit_contacts): nothing is
    flagged, the cube is lifted and slips down the fingers by less than 0.02 mm/s (measured 9.8e-3 mm/s; MuJoCo's
    soft constraints 2.2 mm/s), and the cube that is not squeezed stays on the floor."""
    data, heights = _pinch(0.001, np.array([0.04, 0.0]), 1.6, implicit=True)
    assert data.healthy.numpy().all()
    cube, finger = heights[:, 0, 0], heights[:, 1, 0]
    assert cube[-1] > 0.15
    slip = ((finger[-1] - cube[-1]) - (finger[0] - cube[0])) / (1e-3 * (len(cube) - 1))
    assert abs(slip) < 2e-5, slip
    assert abs(heights[-1, 0, 1] - 0.025) < 1e-3


def test_the_damper_check_flags_steps_not_queries():
    """A 2 g ball 2 cm deep in a static box (its contacts' damping far beyond the step's stable rate): a step flags it,
    while link_contact_forces at the same state reports the law's finite wrench (the check is the step's)."""
    model = _model("""<mujoco><option timestep="0.001" gravity="0 0 0"/><worldbody>
      <body name="block" pos="0 0 0.1"><geom type="box" size=".1 .1 .1"/></body>
      <body name="ball" pos="0 0 0.23"><freejoint/><geom type="sphere" size=".05" mass="0.002"/></body>
    </worldbody></mujoco>""")
    data = wd.data.Data.build(model)
    W_f = wd.contact.link_contact_forces(model, data)[0].numpy()
    assert np.isfinite(W_f).all() and W_f[model.link_names().index("ball"), 2] > 0.0
    assert not wd.model.step(model, data).healthy.numpy().all()


def test_a_stepper_refuses_geom_contacts_switched_after_it_was_built():
    """The pairs' contact slots change the contact state's rows: a Stepper built before geom_contacts is switched on
    (or off) refuses its next step, naming the rows (its buffers hold the old rows), instead of reading past them."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(TWO_SPHERES, dtype=np.float64)
    stepper = wd.simulation.Stepper(model, wd.data.Data.build(model))
    stepper.step()
    model.geom_contacts = True
    with pytest.raises(ValueError, match=r"contact state now has 101 rows .* this Stepper's 100: build a new Stepper"):
        stepper.step()
    on = wd.simulation.Stepper(model, wd.data.Data.build(model))
    on.step()
    model.geom_contacts = False
    with pytest.raises(ValueError, match=r"contact state now has 100 rows .* this Stepper's 101"):
        on.step()
