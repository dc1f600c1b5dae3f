"""MuJoCo's joint limits (`model.limit_constraints`): an MJCF's limited hinge and slide joints held by soft
unilateral rows, solved with the equality constraints (kernels/equality_solve.py's active set), against MuJoCo 4's
mj_step with its limit rows active.

Reference: MuJoCo's Euler step, contacts and frictionloss disabled, its Newton solver run to a tolerance of 1e-15:
its constraint forces minimise a convex piecewise quadratic whose minimiser the active set reaches exactly, so
both compute the same equations in float64: 1e-12 of the velocities' size."""

import pathlib
import re
import warnings

import mujoco
import numpy as np
import pytest
import warp as wp

import mjcf_compare
import mjcf_models as mm
import robots
import warpdyn as wd
from warpdyn.description.mjcf import JOINT_LIMITS

# A three-link arm: a damped shoulder, an elbow with its own margin, solref and solimp (MuJoCo's limit defaults
# otherwise), a slider at its tip.
ARM = """
<mujoco model="limited arm">
  <compiler angle="radian"/>
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <default><geom contype="0" conaffinity="0" type="capsule" size="0.02"/><joint limited="true"/></default>
  <worldbody>
    <body name="upper" pos="0 0 1">
      <joint name="shoulder" axis="0 1 0" range="-0.5 0.8" damping="0.05"/>
      <geom fromto="0 0 0 0.3 0 0" mass="0.6"/>
      <body name="fore" pos="0.3 0 0">
        <joint name="elbow" axis="0 1 0" range="-1.2 0.1" margin="0.02" solreflimit="0.01 0.8" solimplimit="0.8 0.99 0.01 0.4 3"/>
        <geom fromto="0 0 0 0.25 0 0" mass="0.4"/>
        <body name="slider" pos="0.25 0 0">
          <joint name="slide" type="slide" axis="1 0 0" range="-0.05 0.05"/>
          <geom type="box" size="0.03 0.03 0.03" mass="0.3"/>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>"""

UNMODELLED = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) | int(mujoco.mjtDisableBit.mjDSBL_FRICTIONLOSS)


def _load(xml: str = ARM, dtype=np.float64, limits: bool = True) -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        model = wd.model.Model.build_from_model_description(xml, dtype=dtype)
    model.limit_constraints = limits
    return model


def _mujoco_step(mj, qpos, qvel, implicit: bool, steps: int = 1, friction: bool = False) -> mujoco.MjData:
    """MuJoCo's Euler steps with its limit rows (and its friction rows where `friction`), its Newton solver run to
    convergence."""
    disable = int(mujoco.mjtDisableBit.mjDSBL_CONTACT) if friction else UNMODELLED
    mc = mm.reference_model(mj, constraints=True, eulerdamp=implicit, integrator=mujoco.mjtIntegrator.mjINT_EULER, extra_disable=disable)
    mc.opt.tolerance, mc.opt.ls_tolerance, mc.opt.iterations = 1e-15, 1e-15, 200
    d = mm.make_data(mc, qpos, qvel)
    for _ in range(steps):
        mujoco.mj_step(mc, d)
    return d


def _follow(mj, model, data, qpos, qvel, steps: int) -> tuple:
    """`steps` of MuJoCo's Euler with its limit rows (Newton run to convergence, implicit damping) from (qpos, qvel) and
    of warpdyn's from `data`: (MuJoCo's MjData, warpdyn's Data, the MuJoCo joints whose limits engaged)."""
    mc = mm.reference_model(mj, constraints=True, eulerdamp=True, integrator=mujoco.mjtIntegrator.mjINT_EULER, extra_disable=UNMODELLED)
    mc.opt.tolerance, mc.opt.ls_tolerance, mc.opt.iterations = 1e-15, 1e-15, 200
    d = mm.make_data(mc, qpos, qvel)
    engaged = set()
    for _ in range(steps):
        mujoco.mj_step(mc, d)
        engaged |= {int(j) for j in d.efc_id[: d.nefc]}
        data = wd.model.step(model, data)
    return d, data, engaged


def _states(count: int, seed: int = 0) -> list:
    """(qpos, qvel) pairs of the arm, each joint drawn up to 0.2 rad (2 cm) past either bound, velocities N(0, 2^2)."""
    rng = np.random.default_rng(seed)
    return [(np.array([rng.uniform(-0.7, 1.0), rng.uniform(-1.4, 0.3), rng.uniform(-0.07, 0.07)]), rng.normal(0.0, 2.0, 3)) for _ in range(count)]


def _data(model, mj, qpos, qvel):
    return wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs)


@pytest.mark.parametrize("implicit", [True, False], ids=["implicit damping", "explicit damping"])
def test_a_step_at_the_limits_equals_mujocos(implicit):
    """One Euler step from states past, at and within the bounds equals mj_step's with its limit rows: rows that push
    (the step differs from the free one by far more than the tolerance), rows past a bound that MuJoCo's solver
    leaves at zero force (the joint leaves its bound fast enough: the active set drops them), margins, per-joint
    solref and solimp, MuJoCo's implicit joint damping or not."""
    mj, model = mujoco.MjModel.from_xml_string(ARM), _load()
    model.implicit_damping = implicit
    pushing = released = 0
    for qpos, qvel in _states(24):
        d = _mujoco_step(mj, qpos, qvel, implicit)
        stepped = wd.model.step(model, _data(model, mj, qpos, qvel))
        scale = max(1.0, float(np.abs(d.qvel).max()))
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), d.qvel, rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(stepped.joint_positions.numpy(), d.qpos, rtol=0, atol=1e-12)
        effect = np.abs(mm.euler_step(mj, qpos, qvel, eulerdamp=implicit).qvel - d.qvel).max()
        pushing += effect > 1e-2
        released += d.nefc > 0 and np.all(d.efc_force == 0.0)
    assert pushing >= 8 and released >= 2, (pushing, released)


def test_a_second_of_motion_follows_mujoco():
    """The arm thrown against its stops for 0.5 s (250 steps, the limits engaged and released again and again)
    stays on MuJoCo's trajectory within 1e-8 rad."""
    mj, model = mujoco.MjModel.from_xml_string(ARM), _load()
    qpos, qvel = np.array([0.7, 0.0, 0.04]), np.array([3.0, -6.0, 1.0])
    d, data, engaged = _follow(mj, model, _data(model, mj, qpos, qvel), qpos, qvel, 250)
    assert engaged == {0, 1, 2}, engaged
    np.testing.assert_allclose(data.joint_positions.numpy(), d.qpos, rtol=0, atol=1e-8)
    low, high = mj.jnt_range[:, 0], mj.jnt_range[:, 1]
    assert np.all(d.qpos > low - 0.05) and np.all(d.qpos < high + 0.05)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_environments_each_hold_their_own_limits(dtype):
    """Sixteen environments in one step, each past other bounds, each equal to its own MuJoCo step (float32 to its
    rounding: 1e-4 of the velocities' size)."""
    mj, model = mujoco.MjModel.from_xml_string(ARM), _load(dtype=dtype)
    states = _states(16, seed=1)
    kwargs = [mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs for qpos, qvel in states]
    data = wd.data.Data.build(model, num_envs=16, **{key: np.stack([k[key] for k in kwargs]) for key in ("joint_positions", "joint_velocities")})
    stepped = wd.model.step(model, data).joint_velocities.numpy()
    tolerance = 1e-12 if dtype == np.float64 else 1e-4
    for k, (qpos, qvel) in enumerate(states):
        expected = _mujoco_step(mj, qpos, qvel, True).qvel
        np.testing.assert_allclose(stepped[k], expected, rtol=0, atol=tolerance * max(1.0, np.abs(expected).max()))


def test_the_ranges_are_the_models_position_limits_per_environment():
    """The rows' bounds are the model's position_limits (JaxSim's parameter, per environment where set so): two
    environments from one state, the second's elbow range narrowed to [-0.6, -0.2], each equal to MuJoCo's step with
    that range."""
    mj, model = mujoco.MjModel.from_xml_string(ARM), _load()
    limits = np.array(mj.jnt_range, dtype=np.float64)
    narrowed = limits.copy()
    narrowed[1] = (-0.6, -0.2)
    model.set_joint_parameters(position_limits=np.stack([limits, narrowed]))
    qpos, qvel = np.array([0.3, -0.1, 0.0]), np.array([0.5, 1.0, 0.0])
    start = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
    data = wd.data.Data.build(model, num_envs=2, **{k: np.stack([v, v]) for k, v in start.items() if k in ("joint_positions", "joint_velocities")})
    stepped = wd.model.step(model, data).joint_velocities.numpy()
    for k, ranges in enumerate((limits, narrowed)):
        mk = mujoco.MjModel.from_xml_string(ARM)
        mk.jnt_range[:] = ranges
        expected = _mujoco_step(mk, qpos, qvel, True)
        assert (expected.nefc > 0) == (k == 1)
        np.testing.assert_allclose(stepped[k], expected.qvel, rtol=0, atol=1e-12 * max(1.0, np.abs(expected.qvel).max()))


def test_steps_against_the_limits_differentiate():
    """A and B of one step and of ten with two limits pushing (kernels/equality_solve.py: the solve's adjoint on the
    rows the active set keeps) equal central differences, 2e-6 of the largest entry."""
    mj, model = mujoco.MjModel.from_xml_string(ARM), _load()
    qpos, qvel = np.array([0.85, -1.25, 0.02]), np.array([1.0, -0.5, 0.3])
    assert _mujoco_step(mj, qpos, qvel, True).nefc == 2
    data = _data(model, mj, qpos, qvel)
    robots.assert_transitions_equal_central(model, data, steps=(1, 10))
    free = wd.autodiff.transition_matrices(_load(limits=False), data)["A"].numpy()
    assert np.abs(free - wd.autodiff.transition_matrices(model, data)["A"].numpy()).max() > 1e-2, "the limits act on A"


def test_the_setting_and_what_is_named():
    """Off by default (a step is the free one; the loader names the limits it leaves out, a ball joint's among them:
    its bound on the rotation angle, in radians); refused where there is nothing to solve (a URDF of continuous joints), for a
    range narrower than twice its margin, and for a value that is not a bool; carried by a reduction that keeps a
    limited joint; the post-stabilisation leaves the limits to the solve."""
    mj = mujoco.MjModel.from_xml_string(ARM)
    with pytest.warns(wd.model.NotModelledWarning, match=re.escape(f"{JOINT_LIMITS}: ['shoulder', 'elbow', 'slide']")):
        model = wd.model.Model.build_from_model_description(ARM, dtype=np.float64)
    assert model.limit_constraints is False and [e.name for e in model.tree.limits] == ["shoulder", "elbow", "slide"]
    qpos, qvel = np.array([0.9, -1.3, 0.06]), np.array([1.0, -1.0, 0.5])
    free = wd.model.step(model, _data(model, mj, qpos, qvel)).joint_velocities.numpy()
    np.testing.assert_allclose(free, mm.euler_step(mj, qpos, qvel).qvel, rtol=0, atol=1e-12)
    with pytest.raises(TypeError, match="limit_constraints must be a bool, got 1"):
        model.limit_constraints = 1
    urdf = wd.model.Model.build_from_model_description(robots.pendulum_chain_urdf(2))
    with pytest.raises(ValueError, match=rf"model.limit_constraints on '{urdf.name()}': it has no MuJoCo limit constraints"):
        urdf.limit_constraints = True
    narrow = _load(ARM.replace('margin="0.02"', 'margin="0.7"'))
    with pytest.raises(NotImplementedError, match=r"joints \[\"'elbow' \(range 1.3, margin 0.7\)\"\] have a range narrower than twice their margin"):
        wd.model.step(narrow, wd.data.Data.build(narrow))
    model.limit_constraints = True
    reduced = wd.model.reduce(model, ["elbow", "slide"])
    assert reduced.limit_constraints and [e.name for e in reduced.tree.limits] == ["elbow", "slide"]
    projected = _load()
    projected.equality_projection = 2
    a = wd.model.step(projected, _data(projected, mj, qpos, qvel))
    b = wd.model.step(model, _data(model, mj, qpos, qvel))
    np.testing.assert_array_equal(a.joint_positions.numpy(), b.joint_positions.numpy())
    ball = """<mujoco><worldbody><body><joint name="wrist" type="ball" range="0 60"/><geom size="0.1" mass="1"/></body></worldbody></mujoco>"""
    with pytest.warns(wd.model.NotModelledWarning, match=re.escape(f"{JOINT_LIMITS}: ['wrist']")):
        wrist = wd.model.Model.build_from_model_description(ball)
    assert [(e.name, e.angle) for e in wrist.tree.limits] == [("wrist", pytest.approx(np.radians(60.0), rel=1e-15))]


MENAGERIE = pathlib.Path(__file__).parent / "models" / "menagerie"


@pytest.mark.parametrize("name", ["cassie.xml", "rby1a_1.2.xml"])
def test_limits_beside_equality_constraints_on_a_floating_robot(name):
    """Menagerie's Cassie (16 limited hinges, 4 connects) and RB-Y1 (26 limited hinges and slides, 2 joint couplings,
    a free-joint damper), floating, with half their limited joints put up to 0.1 past a bound: a step with the
    limits and the equality rows solved together equals mj_step's (implicit damping as the files ask), 1e-10 of the
    velocities' size; the limits change it by far more."""
    path = MENAGERIE / name
    mj = mujoco.MjModel.from_xml_path(str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = robots.contact_free(wd.model.Model.build_from_model_description(str(path), dtype=np.float64))
    without = model.copy()
    model.limit_constraints = True
    rng = np.random.default_rng(2)
    for _ in range(2):
        qpos, qvel = mm.random_state(mj, rng, 0.5)
        for j in np.flatnonzero(mj.jnt_limited):
            if rng.uniform() < 0.5:
                side = int(rng.integers(2))
                qpos[mj.jnt_qposadr[j]] = mj.jnt_range[j, side] + (2 * side - 1) * rng.uniform(0.0, 0.1)
        start = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
        d = _mujoco_step(mj, qpos, qvel, model.implicit_damping)
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **start))
        free = wd.model.step(without, wd.data.Data.build(without, **start)).joint_velocities.numpy()
        scale = max(1.0, float(np.abs(expected["joint_velocities"]).max()))
        assert np.abs(free - expected["joint_velocities"]).max() > 1e-4 * scale, "the limits act (1e6 times the tolerance)"
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-10 * scale)
        v = stepped.base_velocity.numpy()
        np.testing.assert_allclose(v[:3], expected["base_linear_velocity"], rtol=0, atol=1e-10 * scale)
        np.testing.assert_allclose(v[3:], expected["base_angular_velocity"], rtol=0, atol=1e-10 * scale)


# The arm with frictionloss on its joints (the elbow's with its own solreffriction and solimpfriction): MuJoCo's
# friction constraints, beside the limits.
FRICTION_ARM = (
    ARM.replace('range="-0.5 0.8" damping="0.05"', 'range="-0.5 0.8" damping="0.05" frictionloss="0.4"')
    .replace('margin="0.02"', 'margin="0.02" frictionloss="0.15" solreffriction="0.01 0.7" solimpfriction="0.8 0.9 0.001 0.5 2"')
    .replace('range="-0.05 0.05"/>', 'range="-0.05 0.05" frictionloss="1.5"/>')
)


def _friction_model(dtype=np.float64) -> wd.model.Model:
    model = _load(FRICTION_ARM, dtype=dtype)
    model.frictionloss_constraints = True
    return model


@pytest.mark.parametrize("implicit", [True, False], ids=["implicit damping", "explicit damping"])
def test_frictionloss_as_mujocos_friction_constraints(implicit):
    """One Euler step with frictionloss solved as MuJoCo's friction constraints (and the limits) equals mj_step's
    with its friction and limit rows: states where a joint sticks (its row's force within its bound) and where it
    slides (the force at its bound), per-joint solreffriction and solimpfriction; JaxSim's static friction is left
    out (the step differs from one with it where a joint sticks; where all slide the two agree)."""
    mj, model = mujoco.MjModel.from_xml_string(FRICTION_ARM), _friction_model()
    model.implicit_damping = implicit
    jaxsim = _load(FRICTION_ARM)
    jaxsim.implicit_damping = implicit
    sticking = sliding = differing = 0
    rng = np.random.default_rng(3)
    for qpos, qvel in _states(24, seed=3):
        qvel = qvel * rng.choice([0.0, 0.01, 1.0], size=3)  # some joints at rest, some creeping, some moving
        d = _mujoco_step(mj, qpos, qvel, implicit, friction=True)
        start = _data(model, mj, qpos, qvel)
        stepped = wd.model.step(model, start)
        scale = max(1.0, float(np.abs(d.qvel).max()))
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), d.qvel, rtol=0, atol=1e-12 * scale)
        friction = d.efc_type[: d.nefc] == mujoco.mjtConstraint.mjCNSTR_FRICTION_DOF
        bound = mj.dof_frictionloss[d.efc_id[: d.nefc][friction]]
        force = np.abs(d.efc_force[: d.nefc][friction])
        sticking += int(np.sum(force < bound * (1 - 1e-9)))
        sliding += int(np.sum(force >= bound * (1 - 1e-9)))
        static = wd.model.step(jaxsim, _data(jaxsim, mj, qpos, qvel)).joint_velocities.numpy()
        differing += not np.allclose(static, d.qvel, rtol=0, atol=1e-6)  # alike where every joint slides
    assert sticking >= 10 and sliding >= 10 and differing >= 10, (sticking, sliding, differing)


def test_friction_per_environment_and_over_time():
    """friction_static is each friction row's bound, per environment where set so: two environments of the arm
    released at rest, one with frictionlosses above what gravity asks of the joints and one with a tenth of them,
    0.5 s each equal to MuJoCo's with those frictionlosses within 1e-8 rad; the first holds its shoulder (it creeps,
    as MuJoCo's soft rows let it), the second's falls."""
    mj, model = mujoco.MjModel.from_xml_string(FRICTION_ARM), _friction_model()
    base = np.array([6.0, 2.0, 3.0])  # above the joints' gravity torques and force at rest (about 4.2 N m, 1.2 N m, 1 N)
    model.set_joint_parameters(friction_static=np.stack([base, 0.1 * base]))
    qpos, qvel = np.array([0.2, -0.6, 0.0]), np.zeros(3)
    start = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
    data = wd.data.Data.build(model, num_envs=2, **{k: np.stack([v, v]) for k, v in start.items() if k in ("joint_positions", "joint_velocities")})
    for _ in range(250):
        data = wd.model.step(model, data)
    moved = []
    for k, scale in enumerate((1.0, 0.1)):
        mk = mujoco.MjModel.from_xml_string(FRICTION_ARM)
        mk.dof_frictionloss[:] = scale * base
        d = _mujoco_step(mk, qpos, qvel, True, steps=250, friction=True)
        np.testing.assert_allclose(data.joint_positions.numpy()[k], d.qpos, rtol=0, atol=1e-8)
        moved.append(abs(d.qpos[0] - qpos[0]))
    assert moved[0] < 0.2 * moved[1], moved  # measured 0.065 and 0.60 rad


def test_steps_with_friction_rows_differentiate():
    """A and B through sticking and sliding friction rows equal central differences (2e-6 of the largest entry);
    gradients of friction_static itself, which a saturated row's force is, are refused under a tape, as is a
    friction_static on a joint without a row (the step drops JaxSim's static friction there)."""
    mj, model = mujoco.MjModel.from_xml_string(FRICTION_ARM), _friction_model()
    qpos, qvel = np.array([0.2, -0.6, 0.01]), np.array([0.0, 1.5, 0.0])
    data = _data(model, mj, qpos, qvel)
    robots.assert_transitions_equal_central(model, data)
    marked = model.copy()
    wd.model.parameters_requiring_grad(marked, names=("friction_static",))
    with wp.Tape(), pytest.raises(NotImplementedError, match=r"'limited arm' \(MuJoCo's friction constraints, with gradients of friction_static\)"):
        wd.model.step(marked, data)
    plain = _load(ARM)
    with pytest.raises(ValueError, match=r"model.frictionloss_constraints on 'limited arm': it has no MuJoCo friction constraints"):
        plain.frictionloss_constraints = True
    partial = _load(FRICTION_ARM.replace('frictionloss="1.5"', ""))
    partial.frictionloss_constraints = True
    partial.set_joint_parameters(friction_static=np.array([0.4, 0.15, 0.2]))
    with pytest.raises(NotImplementedError, match=r"joints \['slide'\] have a friction_static but no MuJoCo friction row"):
        wd.model.step(partial, _data(partial, mj, qpos, qvel))


# A floating torso with a shoulder ball limited to a 0.6 rad cone (pivot off its body's origin, its own solref and
# margin), a limited elbow hinge below it, and a hip ball with MuJoCo's defaults.
BALLS = """
<mujoco model="ball limits">
  <option timestep="0.002" gravity="0 0 -9.81"/>
  <default><geom contype="0" conaffinity="0" type="capsule" size="0.02"/><joint limited="true"/></default>
  <worldbody>
    <body name="torso" pos="0 0 1"><freejoint name="root"/><geom type="box" size="0.1 0.15 0.2" mass="3"/>
      <body name="arm" pos="0.1 0.2 0.1" euler="0.2 0 0.3">
        <joint name="shoulder" type="ball" pos="0.02 0 0.01" range="0 0.6" margin="0.03" solreflimit="0.01 0.9"/>
        <geom fromto="0 0 0 0.25 0 -0.05" mass="0.5"/>
        <body name="fore" pos="0.25 0 -0.05"><joint name="elbow" axis="0 1 0" range="-1.5 0"/><geom fromto="0 0 0 0.2 0 0" mass="0.3"/></body>
      </body>
      <body name="leg" pos="0 -0.05 -0.2"><joint name="hip" type="ball" range="0 0.9"/><geom fromto="0 0 0 0 0 -0.35" mass="0.8"/></body>
    </body>
  </worldbody>
</mujoco>"""


def _ball_states(mj, count: int, seed: int) -> list:
    """(qpos, qvel) of BALLS: each ball turned about a random axis by up to 0.25 rad past or 0.1 inside its cone (past pi
    the quaternion's w < 0: MuJoCo's shorter way round), the elbow past or within its range, velocities N(0, 1.5^2)."""
    rng = np.random.default_rng(seed)
    states = []
    for _ in range(count):
        qpos, qvel = mm.random_state(mj, rng, 0.5)
        for name, bound in (("shoulder", 0.6), ("hip", 0.9)):
            axis = rng.normal(size=3)
            angle = bound + rng.uniform(-0.1, 0.25) if rng.uniform() < 0.8 else rng.uniform(2.9, 3.5)
            a = mj.jnt_qposadr[mj.joint(name).id]
            qpos[a : a + 4] = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis / np.linalg.norm(axis)])
        qpos[mj.jnt_qposadr[mj.joint("elbow").id]] = rng.uniform(-1.6, 0.1)
        qvel[:] = rng.normal(0.0, 1.5, mj.nv)
        states.append((qpos, qvel))
    return states


def test_ball_joint_limits_equal_mujocos():
    """A ball joint's limit (a row on its rotation angle against the larger end of its range: J = -u on its three DoFs,
    u the rotation vector's axis as mju_quat2Vel reads the quaternion, w < 0 included) beside a hinge's, on a floating
    torso: one Euler step from 16 states past, at and within the cones equals mj_step's (Newton run to convergence) to
    1e-12 of the velocities' size, the rows changing it by far more; 100 steps of the shoulder thrown against its cone
    stay within 1e-8 of MuJoCo's (measured 1e-10: the swinging chain held by stiff rows amplifies rounding about 1000
    times per 50 steps, to 1e-2 by 250, where without the rows 250 steps stay within 1e-14); A and B equal central
    differences through a pushing ball limit; the MJCF export writes the rows back."""
    mj = mujoco.MjModel.from_xml_string(BALLS)
    model = _load(BALLS)
    without = _load(BALLS, limits=False)
    acted = 0
    states = _ball_states(mj, 16, seed=4)
    shoulder = mj.jnt_qposadr[mj.joint("shoulder").id]
    assert any(qpos[shoulder] < 0.0 for qpos, _ in states), "a quaternion past pi (w < 0): MuJoCo's shorter way round"
    for qpos, qvel in states:
        start = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
        d = _mujoco_step(mj, qpos, qvel, implicit=True)
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **start))
        scale = max(1.0, float(np.abs(expected["joint_velocities"]).max()))
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-12 * scale)
        v = stepped.base_velocity.numpy()
        np.testing.assert_allclose(v[:3], expected["base_linear_velocity"], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(v[3:], expected["base_angular_velocity"], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(stepped.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-12 * scale)
        free = wd.model.step(without, wd.data.Data.build(without, **start)).joint_velocities.numpy()
        acted += np.abs(free - expected["joint_velocities"]).max() > 1e-3 * scale
    assert acted >= 8, acted
    qpos, qvel = _ball_states(mj, 1, seed=5)[0]
    assert 2.0 * np.arccos(abs(qpos[shoulder])) > 0.6 - 0.03, "the shoulder's row acts where A and B are checked"
    qvel[:] = 0.0
    qvel[mj.jnt_dofadr[mj.joint("shoulder").id] : mj.jnt_dofadr[mj.joint("shoulder").id] + 3] = [3.0, -2.0, 4.0]
    data = wd.data.Data.build(model, **mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs)
    robots.assert_transitions_equal_central(model, data)
    d, data, engaged = _follow(mj, model, data, qpos, qvel, 100)
    assert mj.joint("shoulder").id in engaged, engaged
    expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
    np.testing.assert_allclose(data.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-8)
    back = _load(model.export_updated_model(format="mjcf"))  # the export writes the rows back: a ball's range its angle
    assert [(e.name, e.angle, e.margin) for e in back.tree.limits] == [(e.name, e.angle, e.margin) for e in model.tree.limits]
    np.testing.assert_allclose([e.invweight for e in back.tree.limits], [e.invweight for e in model.tree.limits], rtol=1e-12)
