"""MJCF equality constraints (issue 36): connects, welds and joint couplings solved as MuJoCo solves them
(warpdyn.engine.equality, kernels/equality.py), against MuJoCo's mj_step with the same constraints active.

Reference: MuJoCo 4's Euler step with its equality rows active and its contacts, limits and frictionloss
disabled (warpdyn models those apart or not at all; the models' actuators are modelled, their ctrl 0), mapped by tests/mjcf_compare.py. Both compute
the same equations in float64 (MuJoCo's Newton solver reaches the quadratic's minimiser in one step, to its
tolerance 1e-8 on a cost of the size of the accelerations): 1e-10 of the velocities' size."""

import pathlib
import warnings

import mujoco
import numpy as np
import pytest
from scipy.spatial.transform import Rotation
import warp as wp

import mjcf_compare
import mjcf_models as mm
import robots
import warpdyn as wd

MENAGERIE = pathlib.Path(__file__).parent / "models" / "menagerie"
UNMODELLED = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_LIMIT) | int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)


def _mjcf(name: str, bodies: str, equality: str, tendons: str = "") -> str:
    """An MJCF of the world's `bodies` and `equality` constraints (and `tendons`): 1 ms steps, gravity, capsules
    that collide with nothing."""
    return f"""
<mujoco model="{name}">
  <option timestep="0.001" gravity="0 0 -9.81"/>
  <default><geom contype="0" conaffinity="0" type="capsule" size="0.01"/></default>
  <worldbody>{bodies}</worldbody>{tendons}
  <equality>{equality}</equality>
</mujoco>"""


FOUR_BAR = _mjcf(
    "four-bar",
    """
    <body name="crank">
      <joint name="crank" axis="0 1 0" damping="0.002"/>
      <geom fromto="0 0 0 0.1 0 0" mass="0.1"/>
      <body name="coupler" pos="0.1 0 0">
        <joint name="coupler" axis="0 1 0"/>
        <geom fromto="0 0 0 0.3 0 0.1" mass="0.2"/>
      </body>
    </body>
    <body name="rocker" pos="0.3 0 0">
      <joint name="rocker" axis="0 1 0"/>
      <geom fromto="0 0 0 0.1 0 0.1" mass="0.1"/>
    </body>
  """,
    """<connect name="loop" body1="coupler" body2="rocker" anchor="0.3 0 0.1"/>""",
)

SLIDER_CRANK = _mjcf(
    "slider-crank",
    """
    <body name="crank">
      <joint name="crank" axis="0 1 0"/>
      <geom fromto="0 0 0 0.0707107 0 0.0707107" mass="0.2"/>
      <body name="rod" pos="0.0707107 0 0.0707107">
        <joint name="rod" axis="0 1 0"/>
        <geom fromto="0 0 0 0.2915476 0 -0.0707107" mass="0.1"/>
        <body name="rod_end" pos="0.2915476 0 -0.0707107"/>
      </body>
    </body>
    <body name="slider" pos="0.3622583 0 0">
      <joint name="slide" type="slide" axis="1 0 0" damping="0.5"/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.3"/>
    </body>
  """,
    """<connect name="pin" body1="rod_end" body2="slider" anchor="0 0 0"/>""",
)


# A two-link arm with a free lid welded to its forearm (body semantics, torquescale 0.5: MuJoCo's relpose from the
# description's poses) and a free tag welded to a site at its tip (site semantics, its own solref).
WELDS = _mjcf(
    "welds",
    """
    <body name="upper" pos="0 0 1" euler="0.2 0 0">
      <joint name="shoulder" axis="0 1 0" damping="0.05"/>
      <geom fromto="0 0 0 0.3 0 0" mass="0.5"/>
      <body name="lower" pos="0.3 0 0" euler="0 0.3 0.1">
        <joint name="elbow" axis="0 1 0"/>
        <geom fromto="0 0 0 0.25 0 0" mass="0.3"/>
        <site name="tip" pos="0.25 0 0" euler="0.1 0.2 0.3"/>
      </body>
    </body>
    <body name="lid" pos="0.6 0.05 0.95" euler="0.4 -0.2 0.3">
      <freejoint/>
      <geom type="box" size="0.05 0.04 0.02" mass="0.2"/>
    </body>
    <body name="tag" pos="0.2 0.4 1.1" euler="0.1 0.1 0.1">
      <freejoint/>
      <geom type="box" size="0.02 0.02 0.02" mass="0.1"/>
      <site name="tag_site" pos="0.01 0 0" euler="0 0.5 0"/>
    </body>
  """,
    """
    <weld name="lid_on_arm" body1="lower" body2="lid" torquescale="0.5"/>
    <weld name="tag_on_tip" site1="tip" site2="tag_site" solref="0.005 1"/>
  """,
)


def _load(source, dtype=np.float64) -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        model = wd.model.Model.build_from_model_description(str(source) if isinstance(source, pathlib.Path) else source, dtype=dtype)
    return robots.contact_free(model)


def _mujoco(source) -> mujoco.MjModel:
    return mujoco.MjModel.from_xml_path(str(source)) if isinstance(source, pathlib.Path) else mujoco.MjModel.from_xml_string(source)


def _mujoco_steps(mj, qpos, qvel, steps: int, implicit: bool) -> mujoco.MjData:
    mc = mm.reference_model(mj, constraints=True, eulerdamp=implicit, integrator=mujoco.mjtIntegrator.mjINT_EULER, extra_disable=UNMODELLED)
    d = mm.make_data(mc, qpos, qvel)
    for _ in range(steps):
        mujoco.mj_step(mc, d)
    return d


def _anchor_gap(model, data) -> float:
    """The largest distance between a connect's anchors [m] (the first environment)."""
    W = wd.model.forward_kinematics(model, data).numpy().reshape(-1, model.number_of_links(), 4, 4)[0]
    gaps = []
    for e in model.tree.equalities:
        p1 = W[e.link1][:3, :3] @ e.p1 + W[e.link1][:3, 3] if e.link1 >= 0 else e.p1
        p2 = W[e.link2][:3, :3] @ e.p2 + W[e.link2][:3, 3] if e.link2 >= 0 else e.p2
        gaps.append(np.linalg.norm(p1 - p2))
    return max(gaps)


@pytest.mark.parametrize(
    ("name", "kinds", "own_damping"),
    [
        ("cassie.xml", {"connect"}, True), ("cassie.xml", {"connect"}, False), ("mjx_single_cube.xml", {"joint"}, True),
        ("rby1a_1.2.xml", {"joint"}, True), ("rby1a_1.2.xml", {"joint"}, False),
    ],
    ids=["cassie connects, floating base, implicit damping", "the same, explicit damping",
         "panda finger coupling beside a free cube", "rby1 joint couplings, floating base with a free-joint damper, implicit",
         "the same, explicit damping"],
)  # fmt: skip
def test_a_step_with_equality_constraints_equals_mujocos(name, kinds, own_damping):
    """One Euler step from random states equals mj_step's with the equality rows active, with the description's
    damping (Cassie's and RBY1's implicit, the Panda's explicit: its MJCF disables eulerdamp) or explicit damping in
    both; the constraints change the step by far more than the tolerance. RBY1's free joint has a damper: implicit,
    it acts in MuJoCo's free-joint coordinates (kernels/equality.py's base block of D)."""
    path = MENAGERIE / name
    mj, model = _mujoco(path), _load(path)
    if not own_damping:
        model.implicit_damping = False
    implicit = model.implicit_damping
    assert implicit == (name != "mjx_single_cube.xml" and own_damping)
    assert {e.kind for e in model.tree.equalities} == kinds and len(model.tree.equalities) == int(mj.neq)
    for seed in range(2):
        qpos, qvel = mm.random_state(mj, np.random.default_rng(seed), 0.5)
        data = wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs)
        stepped = wd.model.step(model, data)
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, *_step_of(mj, qpos, qvel, implicit)).data_kwargs
        unconstrained = mm.euler_step(mj, qpos, qvel, eulerdamp=implicit)
        free = mjcf_compare.mujoco_to_warpdyn_state(model, mj, unconstrained.qpos, unconstrained.qvel).data_kwargs
        scale = max(1.0, float(np.abs(expected["joint_velocities"]).max()))
        assert np.abs(free["joint_velocities"] - expected["joint_velocities"]).max() > 1e-3 * scale, "the constraints act"
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(stepped.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-10)
        if model.floating_base():
            v = stepped.base_velocity.numpy()
            np.testing.assert_allclose(v[:3], expected["base_linear_velocity"], rtol=0, atol=1e-10 * scale)
            np.testing.assert_allclose(v[3:], expected["base_angular_velocity"], rtol=0, atol=1e-10 * scale)
            np.testing.assert_allclose(stepped.base_position.numpy(), expected["base_position"], rtol=0, atol=1e-10)


def test_welds_step_as_mujocos():
    """Welds by body (torquescale 0.5, MuJoCo's relpose) and by site (the sites' frames) between an arm and two
    free bodies: an Euler step from random states equals mj_step's (MuJoCo's implicit damping in both), and 2 s
    of motion follow MuJoCo's (1e-9)."""
    mj, model = _mujoco(WELDS), _load(WELDS)
    assert [(e.kind, e.torquescale) for e in model.tree.equalities] == [("weld", 0.5), ("weld", 1.0)] and model.implicit_damping
    for seed in range(2):
        qpos, qvel = mm.random_state(mj, np.random.default_rng(seed), 0.5)
        before = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **before))
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, *_step_of(mj, qpos, qvel, True)).data_kwargs
        change = np.abs(expected["joint_velocities"] - before["joint_velocities"]).max()
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-12 * change)
        np.testing.assert_allclose(stepped.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-12)
    qpos, qvel = mj.qpos0.copy(), np.zeros(mj.nv)
    stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs), substeps=100)
    for _ in range(20):
        out = stepper.step()
    d = _mujoco_steps(mj, qpos, qvel, 2000, True)
    expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
    assert np.abs(expected["joint_positions"] - mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs["joint_positions"]).max() > 0.05, "the arm swung"
    np.testing.assert_allclose(out.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("dtype", [np.float64, np.float32], ids=["float64", "float32"])
def test_batched_environments_each_equal_mujocos(dtype):
    """Four environments of Cassie in one step, each from its own random state, each equal to MuJoCo's step from
    it: 1e-10 of the velocities' size in float64, 5e-4 in float32 (the float32 rounding of M, J and J̇ν, some 3e-7,
    amplified by the constraint solve: 5.4e-5 measured on the CPU, 1.4e-4 on an H200; float64 3e-13 there)."""
    path = MENAGERIE / "cassie.xml"
    mj, reference, model = _mujoco(path), _load(path), _load(path, dtype)
    states = [mm.random_state(mj, np.random.default_rng(seed), 0.5) for seed in range(4)]
    starts = [mjcf_compare.mujoco_to_warpdyn_state(reference, mj, q, v).data_kwargs for q, v in states]
    stepped = wd.model.step(model, wd.data.Data.build(model, num_envs=4, **{k: np.stack([s[k] for s in starts]) for k in starts[0]}))
    expected = np.stack([mjcf_compare.mujoco_to_warpdyn_state(reference, mj, *_step_of(mj, q, v, True)).data_kwargs["joint_velocities"] for q, v in states])
    tolerance = 1e-10 if dtype == np.float64 else 5e-4
    np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected, rtol=0, atol=tolerance * np.abs(expected).max())
    assert stepped.valid_state.numpy().all()


def _step_of(mj, qpos, qvel, implicit):
    d = _mujoco_steps(mj, qpos, qvel, 1, implicit)
    return d.qpos.copy(), d.qvel.copy()


# Two pendulums whose fixed tendons (a sum, a difference of joint angles) are coupled by a cubic, and a third
# joint held by a tendon of its own against a constant.
TENDONS = _mjcf(
    "tendon couplings",
    """
    <body name="a" pos="0 0 1"><joint name="a1" axis="0 1 0" damping="0.02"/><geom fromto="0 0 0 0.2 0 0" mass="0.3"/>
      <body name="a_tip" pos="0.2 0 0"><joint name="a2" axis="0 1 0"/><geom fromto="0 0 0 0.15 0 0" mass="0.2"/></body></body>
    <body name="b" pos="0.5 0 1"><joint name="b1" axis="0 1 0"/><geom fromto="0 0 0 0.2 0 0" mass="0.4"/></body>
    <body name="c" pos="1 0 1"><joint name="c1" type="slide" axis="0 0 1"/><geom type="box" size="0.02 0.02 0.02" mass="0.5"/></body>
  """,
    """
    <tendon name="couple" tendon1="sum_a" tendon2="twist_b" polycoef="0.05 0.7 0.1 0.02 0"/>
    <tendon name="hold" tendon1="lift_c" polycoef="0.01 0 0 0 0" solref="0.01 1"/>
  """,
    """<tendon>
    <fixed name="sum_a"><joint joint="a1" coef="1"/><joint joint="a2" coef="0.5"/></fixed>
    <fixed name="twist_b"><joint joint="b1" coef="-2"/></fixed>
    <fixed name="lift_c"><joint joint="c1" coef="3"/></fixed>
  </tendon>""",
)


def test_fixed_tendon_couplings_step_as_mujocos():
    """MJCF tendon equalities between fixed tendons (linear combinations of joint positions), one coupling two
    tendons by a polynomial and one holding a tendon alone: Euler steps from random states equal mj_step's
    (1e-12 of the change), and 2 s follow MuJoCo's (1e-9); a spatial tendon's would be named in the warning."""
    mj, model = _mujoco(TENDONS), _load(TENDONS)
    assert [(e.kind, len(e.terms1), len(e.terms2)) for e in model.tree.equalities] == [("tendon", 2, 1), ("tendon", 1, 0)]
    for seed in range(2):
        qpos, qvel = mm.random_state(mj, np.random.default_rng(seed), 0.5)
        before = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **before))
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, *_step_of(mj, qpos, qvel, model.implicit_damping)).data_kwargs
        change = np.abs(expected["joint_velocities"] - before["joint_velocities"]).max()
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-12 * change)
    qpos, qvel = mj.qpos0.copy(), np.zeros(mj.nv)
    stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs), substeps=100)
    for _ in range(20):
        out = stepper.step()
    d = _mujoco_steps(mj, qpos, qvel, 2000, model.implicit_damping)
    expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
    assert np.abs(expected["joint_positions"]).max() > 0.05, "the pendulums swung"
    np.testing.assert_allclose(out.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-9)


@pytest.mark.parametrize("xml", [FOUR_BAR, SLIDER_CRANK], ids=["four-bar", "slider-crank"])
def test_closed_chains_follow_mujoco_for_ten_seconds(xml):
    """A four-bar linkage and a slider-crank (each a loop closed by a connect, two trees of one world), driven
    by an initial crank speed under gravity for 10 s (10 000 steps of 1 ms, a Stepper of 100 substeps): the
    joints follow MuJoCo's to 1e-9, and the loop stays as closed as MuJoCo keeps it (a soft constraint: with
    MuJoCo's default solref and solimp the anchors part by up to 0.9 mm (four-bar) and 4 mm (slider-crank)
    while the crank spins, and by MuJoCo's residual at the end)."""
    mj, model = _mujoco(xml), _load(xml)
    qpos, qvel = mj.qpos0.copy(), np.zeros(mj.nv)
    qvel[0] = 3.0
    data = wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs)
    stepper = wd.simulation.Stepper(model, data, substeps=100)
    gap = 0.0
    for _ in range(100):
        out = stepper.step()
        gap = max(gap, _anchor_gap(model, out))
    d = _mujoco_steps(mj, qpos, qvel, 10_000, implicit=True)
    expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
    assert np.abs(expected["joint_positions"] - data.joint_positions.numpy()).max() > 0.1, "the mechanism moved"
    np.testing.assert_allclose(out.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-9)
    mc = mm.reference_model(mj, constraints=True, integrator=mujoco.mjtIntegrator.mjINT_EULER, extra_disable=UNMODELLED)
    mujoco.mj_forward(mc, d)
    assert abs(_anchor_gap(model, out) - np.linalg.norm(d.efc_pos[:3])) < 1e-9
    assert 0.0 < gap < 1e-2 and out.valid_state.numpy().all()


def test_a_stiffer_constraint_closes_the_loop_tighter():
    """solref at 2 dt and solimp near 1 (MuJoCo's stiffest reference) keep the four-bar's anchors within
    5e-5 m over 10 s (measured 2.6e-5 m), against 1.5e-4 m with the defaults."""
    stiff = FOUR_BAR.replace('<connect name="loop"', '<connect name="loop" solref="0.002 1" solimp="0.9999 0.9999 0.001 0.5 2"')
    gaps = []
    for xml in (FOUR_BAR, stiff):
        model = _load(xml)
        velocities = np.zeros(model.dofs())
        velocities[model.joint_names().index("crank")] = 3.0
        stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, joint_velocities=velocities), substeps=100)
        gaps.append(max(_anchor_gap(model, stepper.step()) for _ in range(100)))
    assert gaps[1] < 5e-5 < gaps[0]


def _consistent_start(xml):
    """MuJoCo's qpos0 with the crank at 3 rad/s, made consistent with the loop by one projected step of 1 ms: the
    joints' (positions, velocities)."""
    model = _load(xml)
    model.equality_projection = 2
    mj = _mujoco(xml)
    qvel = np.zeros(mj.nv)
    qvel[0] = 3.0
    data = wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, mj.qpos0.copy(), qvel).data_kwargs)
    out = wd.model.step(model, data)
    return out.joint_positions.numpy().copy(), out.joint_velocities.numpy().copy()


@pytest.mark.parametrize("xml, tag", [(FOUR_BAR, '<connect name="loop"'), (SLIDER_CRANK, '<connect name="pin"')], ids=["four-bar", "slider-crank"])
def test_the_projection_closes_loops_and_follows_mujocos_stiffest_constraint(xml, tag):
    """model.equality_projection = 2 (post-stabilisation after each step): from a state consistent with the loop, 10 s
    of 1 ms steps keep the anchors together to 1e-12 m (MuJoCo's soft defaults let them part by 0.4 and 4 mm), and
    the joints follow MuJoCo's stiffest constraint (solref 2 dt, solimp 0.9999) to 1e-2 (measured 2.3e-3 rad and
    6.9e-3 m), closer than MuJoCo's defaults follow it (5.6e-2 and 0.24)."""
    q0, v0 = _consistent_start(xml)
    model = _load(xml)
    model.equality_projection = 2
    stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, joint_positions=q0, joint_velocities=v0), substeps=10)
    ours, gap = [], 0.0
    for _ in range(1000):
        out = stepper.step()
        ours.append(out.joint_positions.numpy().copy())
        gap = max(gap, _anchor_gap(model, out))
    assert gap < 1e-12 and np.abs(np.array(ours) - q0).max() > 0.5, "closed while it moved"
    differences = {}
    for name, m in (("default", _mujoco(xml)), ("stiff", _mujoco(xml.replace(tag, tag + ' solref="0.002 1" solimp="0.9999 0.9999 0.001 0.5 2"')))):
        qpos, qvel = np.zeros(m.nq), np.zeros(m.nv)
        for k, joint in enumerate(model.joint_names()):
            qpos[m.jnt_qposadr[m.joint(joint).id]], qvel[m.jnt_dofadr[m.joint(joint).id]] = q0[k], v0[k]
        mc = mm.reference_model(m, constraints=True, eulerdamp=True, integrator=mujoco.mjtIntegrator.mjINT_EULER, extra_disable=UNMODELLED)
        d, theirs = mm.make_data(mc, qpos, qvel), []
        for _ in range(1000):
            for _ in range(10):
                mujoco.mj_step(mc, d)
            theirs.append(mjcf_compare.mujoco_to_warpdyn_state(model, m, d.qpos, d.qvel).data_kwargs["joint_positions"])
        differences[name] = np.abs(np.array(theirs) - np.array(ours)).max()
    assert differences["stiff"] < 1e-2 < differences["default"], differences


# A free ball hung by a connect from a static hook (a body welded to the world: scenery, which a floating base's
# description drops) and by a second connect to a point of the world's frame, MuJoCo's refsafe disabled and a time
# constant below 2 dt.
HOOK = """
<mujoco model="hook">
  <option timestep="0.002" gravity="0 0 -9.81"><flag refsafe="disable"/></option>
  <default><geom contype="0" conaffinity="0"/></default>
  <worldbody>
    <body name="hook" pos="0.1 0.2 2" euler="0.3 0.2 0.1"><geom type="box" size="0.02 0.02 0.02"/></body>
    <body name="ball" pos="0.1 0.2 1.6" euler="0.2 0 0"><freejoint/><geom type="sphere" size="0.05" mass="0.4"/></body>
  </worldbody>
  <equality>
    <connect name="string" body1="ball" body2="hook" anchor="0.03 0 0.4" solref="0.003 1"/>
    <connect name="to_world" body1="ball" anchor="0 0.05 0" solref="0.02 0.5"/>
  </equality>
</mujoco>"""


def test_constraints_to_the_world_and_static_scenery_beside_a_floating_base():
    """A floating ball hung from static scenery and from the world (the bodies welded to the world become the
    world, their anchors in world axes), with MuJoCo's refsafe off and a time constant below 2 dt: steps from
    random states equal mj_step's (1e-12 of the change: 1e-11 of 22 to 345 measured)."""
    mj, model = _mujoco(HOOK), _load(HOOK)
    assert model.floating_base() and [(e.link1, e.link2) for e in model.tree.equalities] == [(0, -1), (0, -1)]
    for seed in range(2):
        qpos, qvel = mm.random_state(mj, np.random.default_rng(seed), 0.5)
        before = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **before))
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, *_step_of(mj, qpos, qvel, model.implicit_damping)).data_kwargs
        v = stepped.base_velocity.numpy()
        for part, name in ((v[:3], "base_linear_velocity"), (v[3:], "base_angular_velocity")):
            change = np.abs(expected[name] - before[name]).max()
            assert change > 10.0, "the constraints act"
            np.testing.assert_allclose(part, expected[name], rtol=0, atol=1e-12 * change)


WELDED_BOX = """
<mujoco model="welded box">
  <option timestep="0.001" gravity="0 0 -9.81"/>
  <worldbody>
    <body name="box" pos="0.3 -0.2 1.1" euler="0.4 0.1 -0.3"><freejoint/><geom type="box" size="0.1 0.05 0.02" mass="1.3"/></body>
  </worldbody>
  <equality><weld name="hold" body1="box" torquescale="0.5"/></equality>
</mujoco>"""


def test_the_projection_holds_a_floating_base_on_its_connects_and_welds():
    """The post-stabilisation with a floating base, RK4 (after semi-implicit Euler the projected ball, spinning near
    its pivot at 27 rad/s, gains energy: model_settings' equality_projection): the ball hung by two connects, started
    at random velocities (about 1 m/s and 1 rad/s), keeps both anchors together to 1e-12 m over 1 s and loses energy
    (no more than 2 %); a box welded to the world (torquescale 0.5), kicked, is held (3 passes) at its pose to 1e-12 m and rad and
    at rest to 1e-12 after each step, the kick and gravity removed; the base's quaternion stays unit (1e-14)."""
    model = _load(HOOK)
    model.equality_projection, model.integrator = 2, wd.model.IntegratorType.RungeKutta4
    rng = np.random.default_rng(3)
    data = wd.data.Data.build(model, base_linear_velocity=rng.normal(size=3), base_angular_velocity=rng.normal(size=3))
    stepper = wd.simulation.Stepper(model, data, substeps=10)
    energy = []
    for _ in range(100):
        out = stepper.step()
        assert _anchor_gap(model, out) < 1e-12
        energy.append(float(wd.model.mechanical_energy(model, out).numpy()[0]))
    assert energy[0] > energy[-1] > 0.98 * energy[0]
    assert abs(np.linalg.norm(out.base_orientation.numpy()) - 1.0) < 1e-14
    box = _load(WELDED_BOX)
    box.equality_projection = 3  # the kick moves it 2 mrad in the first step: a third pass takes 4e-12 to rounding
    pose = wd.model.forward_kinematics(box, wd.data.Data.build(box)).numpy().reshape(4, 4)
    kicked = wd.data.Data.build(box, base_linear_velocity=[0.3, -0.1, 0.2], base_angular_velocity=[1.0, 0.5, -2.0])
    for _ in range(3):
        kicked = wd.model.step(box, kicked)
        now = wd.model.forward_kinematics(box, kicked).numpy().reshape(4, 4)
        assert np.abs(now - pose).max() < 1e-12 and np.abs(kicked.generalized_velocity.numpy()).max() < 1e-12


def test_the_projected_four_bar_keeps_its_energy_with_rk4():
    """Without damping, RK4 and the projection: the four-bar's mechanical energy decays by less than 0.5 % over 9 s
    (measured 0.25 %; MuJoCo's soft loop, unprojected, loses 3.4 %); after semi-implicit Euler it gains 2 % (the
    setting's docstring says why)."""
    xml = FOUR_BAR.replace('damping="0.002"', "")
    q0, v0 = _consistent_start(xml)
    energies = {}
    for integrator in (wd.model.IntegratorType.RungeKutta4, wd.model.IntegratorType.SemiImplicitEulerSO3):
        model = _load(xml)
        model.equality_projection, model.integrator = 2, integrator
        # a graph of 100 steps replayed 10 times a second (capturing 1000 steps costs the CPU 30 s: 0.9 ms a launch)
        stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, joint_positions=q0, joint_velocities=v0), substeps=100)
        energies[integrator] = []
        for _ in range(9):
            for _ in range(10):
                data = stepper.step()
            energies[integrator].append(float(wd.model.mechanical_energy(model, data).numpy()[0]))
    rk4, euler = energies[wd.model.IntegratorType.RungeKutta4], energies[wd.model.IntegratorType.SemiImplicitEulerSO3]
    assert rk4[0] > rk4[-1] > 0.995 * rk4[0] and euler[-1] > 1.015 * euler[0], (rk4, euler)


def test_the_projection_in_float32():
    """In float32 (RK4, 2 s of 1 ms steps) the four-bar and the ball on two connects (a dependent row: float32's
    damping, PROJECTION_DAMPING) close to their positions' rounding, below 1e-6 m, and stay healthy."""
    for xml, start in ((FOUR_BAR, {"joint_velocities": [3.0, 0.0, 0.0]}), (HOOK, {"base_linear_velocity": [0.5, 0.2, 0.1]})):
        model = _load(xml, dtype=np.float32)
        model.equality_projection, model.integrator = 2, wd.model.IntegratorType.RungeKutta4
        stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, **start), substeps=100)
        for _ in range(20):
            out = stepper.step()
            assert _anchor_gap(model, out) < 1e-6 and out.valid_state.numpy().all()


def _frame_gap(model, data) -> float:
    """The largest distance [m] and rotation angle [rad] between a weld's two frames (the first environment)."""
    W = wd.model.forward_kinematics(model, data).numpy().reshape(-1, model.number_of_links(), 4, 4)[0]
    gaps = []
    for e in model.tree.equalities:
        frames = []
        for link, p, Q in ((e.link1, e.p1, e.Q1), (e.link2, e.p2, e.Q2)):
            H = W[link] if link >= 0 else np.eye(4)
            frames.append((H[:3, :3] @ p + H[:3, 3], H[:3, :3] @ Rotation.from_quat(np.roll(Q, -1)).as_matrix()))
        (p1, R1), (p2, R2) = frames
        gaps.append(max(np.linalg.norm(p1 - p2), np.arccos(np.clip((np.trace(R1.T @ R2) - 1) / 2, -1.0, 1.0))))
    return max(gaps)


def test_the_projection_holds_welded_free_bodies_on_an_arm():
    """Ball and free joints: the arm whose forearm carries a free lid (weld by body, torquescale 0.5) and whose tip
    carries a free tag (weld by site), from MuJoCo's qpos0 with random joint velocities (the lid's and tag's free
    joints included), 1 s of RK4 steps with the projection: each weld's frames stay together to 1e-12 m and 1e-7 rad
    (an angle from a cosine near 1: its rounding) while the arm swings; MuJoCo's soft welds part by millimetres."""
    model = _load(WELDS)
    model.equality_projection, model.integrator = 2, wd.model.IntegratorType.RungeKutta4
    velocities = np.random.default_rng(5).normal(size=model.dofs())
    stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, joint_velocities=velocities), substeps=10)
    start = wd.data.Data.build(model).joint_positions.numpy().copy()
    for _ in range(100):
        out = stepper.step()
        assert _frame_gap(model, out) < 1e-7 and _anchor_gap(model, out) < 1e-12
    assert np.abs(out.joint_positions.numpy() - start).max() > 0.1 and out.valid_state.numpy().all()


def test_the_projection_keeps_cassies_free_fall_rigid():
    """Cassie's four connects (a floating base; some of their rows nearly dependent) in free fall from MuJoCo's
    qpos0 at rest, 0.25 s with the projection: the loops stay closed to 1e-14 m and nothing turns or slides
    sideways (1e-12 m): the damped solve moves nothing along nearly dependent rows (dropping them at a pivot of
    1e-10 instead amplified rounding into a 3 mm drift)."""
    path = MENAGERIE / "cassie.xml"
    mj, model = _mujoco(path), _load(path)
    model.equality_projection = 2
    data = wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, mj.qpos0.copy(), np.zeros(mj.nv)).data_kwargs)
    start = data.base_position.numpy().copy()
    stepper = wd.simulation.Stepper(model, data, substeps=50)
    for _ in range(10):
        out = stepper.step()
        assert _anchor_gap(model, out) < 1e-14
    assert np.abs(out.base_position.numpy()[:2] - start[:2]).max() < 1e-12 and np.abs(out.base_velocity.numpy()[3:]).max() < 1e-12


def test_the_projection_setting():
    """equality_projection takes 0 to 10 position passes (a TypeError names another type, a ValueError another
    number), is carried by reduce, and a step with a solved contact model is refused by name."""
    model = _load(FOUR_BAR)
    for bad, error, message in ((-1, ValueError, "from 0 to 10"), (11, ValueError, "from 0 to 10"), (1.5, TypeError, "an integer"),
                                (True, TypeError, "an integer"), ("2", TypeError, "an integer")):  # fmt: skip
        with pytest.raises(error, match=f"equality_projection must be {message}"):
            model.equality_projection = bad
    model.equality_projection = 3
    assert wd.model.reduce(model, considered_joints=list(model.joint_names())).equality_projection == 3
    rigid = model.replace(contact_model=wd.rbda.contacts.RelaxedRigidContacts())
    with pytest.raises(NotImplementedError, match="equality_projection with RelaxedRigidContacts on 'four-bar'.*use SoftContacts"):
        wd.model.step(rigid, wd.data.Data.build(rigid))


COUPLED_BALL = _mjcf(
    "coupled ball",
    """
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0"/>
      <geom fromto="0 0 0 0.3 0 0" mass="0.5"/>
      <body name="lower" pos="0.3 0 0">
        <joint name="elbow" axis="0 1 0"/>
        <geom fromto="0 0 0 0.25 0 0" mass="0.3"/>
      </body>
    </body>
    <body name="bob" pos="0 0.5 1">
      <joint name="swivel" type="ball"/>
      <geom fromto="0 0 0 0 0 -0.3" mass="0.4"/>
      <body name="tip" pos="0 0 -0.3"/>
    </body>
  """,
    """<joint name="couple" joint1="elbow" joint2="shoulder" polycoef="0 0.5 0 0 0"/>
    <connect name="tether" body1="tip" anchor="0 0 0"/>""",
)
"""A two-link arm whose elbow follows half its shoulder (a joint coupling) and a bob on a ball joint whose tip is
held to the world's point (a connect): it can only spin about its own axis."""


def test_the_projection_of_couplings_and_ball_joints_per_environment():
    """A joint coupling and a ball joint's connect, two environments at random velocities, 1 s of RK4 steps with
    the projection: the elbow stays at half the shoulder to 1e-12 rad and the bob's tip at its point to 1e-12 m in
    each environment while the arm swings; an environment flagged before the step is left as it is."""
    model = _load(COUPLED_BALL)
    model.equality_projection, model.integrator = 2, wd.model.IntegratorType.RungeKutta4
    shoulder, elbow = (int(model.tree.q_start[model.joint_names().index(name) + 1]) for name in ("shoulder", "elbow"))  # their positions' addresses
    velocities = np.random.default_rng(7).normal(size=(2, model.dofs()))
    data = wd.data.Data.build(model, joint_velocities=velocities, num_envs=2)
    stepper = wd.simulation.Stepper(model, data, substeps=10)
    for _ in range(100):
        out = stepper.step()
        q = out.joint_positions.numpy()
        assert np.abs(q[:, elbow] - 0.5 * q[:, shoulder]).max() < 1e-12 and _anchor_gap(model, out) < 1e-12
    assert np.abs(q[:, shoulder]).min() > 0.05, "the arm swung"
    flagged = wd.data.Data.build(model, joint_velocities=velocities, num_envs=2)
    flagged.valid_state.assign(np.array([1, 0], dtype=np.int32))
    before = flagged.joint_positions.numpy().copy()
    after = wd.model.step(model, flagged)
    assert np.array_equal(after.joint_positions.numpy()[1], before[1]) and after.valid_state.numpy().tolist() == [1, 0]



def test_mujocos_rules_for_solref_and_spatial_tendons():
    """A solref mixing MuJoCo's formats is replaced by MuJoCo's default, with a warning naming the constraint; a
    coupling of a spatial tendon is named in the NotModelledWarning."""
    mixed = FOUR_BAR.replace('<connect name="loop"', '<connect name="loop" solref="0.02 -1"')
    with pytest.warns(UserWarning, match=r"loop: solref \[0.02, -1.0\] mixes MuJoCo's standard and direct formats"):
        model = _load(mixed)
    np.testing.assert_array_equal(model.tree.equalities[0].solref, [0.02, 1.0])
    spatial = FOUR_BAR.replace("<equality>", '<tendon><spatial name="cord"><site site="s1"/><site site="s2"/></spatial></tendon><equality>').replace(
        '<geom fromto="0 0 0 0.3 0 0.1" mass="0.2"/>', '<geom fromto="0 0 0 0.3 0 0.1" mass="0.2"/><site name="s1"/>').replace(
        '<geom fromto="0 0 0 0.1 0 0.1" mass="0.1"/>', '<geom fromto="0 0 0 0.1 0 0.1" mass="0.1"/><site name="s2"/>').replace(
        "</equality>", '<tendon name="taut" tendon1="cord"/></equality>')  # fmt: skip
    with pytest.warns(wd.model.NotModelledWarning, match=r"equality constraints other than connect, weld, joint and fixed-tendon.*'taut'"):
        wd.model.Model.build_from_model_description(spatial)


@pytest.mark.parametrize("name", ["FOUR_BAR", "SLIDER_CRANK", "WELDS", "TENDONS", "COUPLED_BALL"])
def test_constrained_steps_differentiate(name):
    """A step's A and B through the constraints (kernels/equality_solve.py: Warp's adjoint of the rows, the solve's
    by hand) equal central differences, for one step and ten, with RK4 (connects, welds to free bodies, joint and
    fixed-tendon couplings, ball joints). Tolerance 2e-6 of the largest entry: the stiff constraints' curvature gives
    the differences a truncation error that falls with h (the welds' A: 4e-7 at h = 1e-6, 5e-8 at 3e-7) while their
    rounding grows (its B: 1.9e-7, 8.8e-7); measured at 3e-7: 9e-7 at most."""
    model = _load(globals()[name]).replace(integrator=wd.model.IntegratorType.RungeKutta4)
    velocities = np.random.default_rng(0).normal(0.0, 0.5, model.dofs())
    data = wd.data.Data.build(model, joint_velocities=velocities)
    robots.assert_transitions_equal_central(model, data, steps=(1, 10))


def test_implicit_damping_differentiates_and_what_has_no_adjoint_is_refused():
    """With MuJoCo's Euler and its implicit damping (the MJCF's integrator) A and B equal central differences: the
    four-bar's joint damping (measured 4.8e-9 of the largest entry at h = 3e-7) and a welded box's free-joint damper
    on a floating base, whose force depends on the base's position and velocity (1.8e-8; 2.6e-8 over 10 steps);
    bound 2e-6. Refused under a tape, naming what differentiates: gradients of the damping with implicit damping
    (the solve's adjoint leaves them out) and the post-stabilisation."""
    model = _load(FOUR_BAR)
    assert model.implicit_damping
    data = wd.data.Data.build(model, joint_velocities=np.array([0.4, -0.2, 0.3]))
    exact = wd.autodiff.transition_matrices(model, data)
    central = wd.autodiff.transition_matrices(model, data, method="central", h=3e-7)
    for key in ("A", "B"):
        assert np.abs(exact[key].numpy() - central[key].numpy()).max() <= 2e-6 * np.abs(exact[key].numpy()).max(), key
    marked = model.copy()
    wd.model.parameters_requiring_grad(marked, names=("damping",))
    with wp.Tape(), pytest.raises(NotImplementedError, match=r"'four-bar' \(equality constraints, MuJoCo's implicit damping with gradients of the damping\)"):
        wd.model.step(marked, data)
    damped = _load(WELDED_BOX.replace("<freejoint/>", '<joint type="free" damping="0.3"/>'))
    assert damped.floating_base() and damped.implicit_damping
    moving = wd.data.Data.build(damped, base_linear_velocity=np.array([0.3, -0.1, 0.2]), base_angular_velocity=np.array([0.5, -0.4, 0.3]))
    for steps in (1, 10):
        exact = wd.autodiff.transition_matrices(damped, moving, steps=steps)["A"].numpy()
        central = wd.autodiff.transition_matrices(damped, moving, steps=steps, method="central", h=3e-7)["A"].numpy()
        assert np.abs(exact - central).max() <= 2e-6 * np.abs(exact).max(), steps
    projected = model.replace(integrator=wd.model.IntegratorType.RungeKutta4)
    projected.equality_projection = 2
    with wp.Tape(), pytest.raises(NotImplementedError, match=r"model.equality_projection = 2 under a wp.Tape.*set model.equality_projection = 0"):
        wd.model.step(projected, wd.data.Data.build(projected, requires_grad=True))


def test_what_is_not_enforced_is_named():
    """An equality constraint inactive at the start is named in the NotModelledWarning; a joint coupling whose joint
    a reduction locks is dropped with a warning naming it; the enforced ones are not named."""
    tendon = FOUR_BAR.replace("</equality>", '<connect name="glue" body1="crank" body2="rocker" anchor="0 0 0" active="false"/></equality>')
    with pytest.warns(wd.model.NotModelledWarning, match=r"equality constraints other than connect, weld, joint and fixed-tendon couplings, and those inactive at the start.*\['glue'\]"):
        model = wd.model.Model.build_from_model_description(tendon)
    assert [e.name for e in model.tree.equalities] == ["loop"]
    coupled = FOUR_BAR.replace("</equality>", '<joint name="couple" joint1="rocker" joint2="crank" polycoef="0 1 0 0 0"/></equality>')
    model = _load(coupled)
    assert [e.kind for e in model.tree.equalities] == ["connect", "joint"]
    with pytest.warns(wd.model.NotModelledWarning, match=r"equality constraints on joints that the reduction locks are dropped: \['couple \(on rocker, crank\)'\]"):
        reduced = wd.model.reduce(model, ["crank", "coupler"])
    assert [e.name for e in reduced.tree.equalities] == ["loop"]


def test_queries_that_do_not_step_take_the_constraints_plan():
    """A constrained model's queries build the step's plan too (the joint torques, the contacts): they run."""
    model = _load(MENAGERIE / "rby1a_1.2.xml")
    assert wd.contact.in_contact(model, wd.data.Data.build(model)) is not None