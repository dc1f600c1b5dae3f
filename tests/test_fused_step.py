"""The fused Euler step (kernels/fused_step.py) against the launch list it replaces (warpdyn.engine.step's
FK, link velocities, contact, ABA and integrator kernels, which the rest of the suite checks against MuJoCo,
JaxSim and identities).

Both compute the same equations in another order (the fused kernel takes a point's velocity from the link's
velocity in link coordinates, sums a link's contact wrenches before converting them, recomputes the joint
transforms or keeps them), so they agree to rounding, not bit for bit: to 1e-12 of each quantity's size in
float64 and 1e-4 in float32, tolerances that leave room for other states and for a GPU's fused multiply-adds
(on an H100 the legs' second float32 step differs by 4e-5 of the largest joint velocity, 47 rad/s in an
environment that the contact drives hard: the articulated terms are summed in another order).
The health flags must agree exactly. Every test of a step runs each variant of the kernel (the `keep`
fixture; warpdyn.engine.fused_layout.keeps_joint_transforms: the CPU keeps the joint transforms, a GPU
keeps them for few environments only), on one thread per environment and on the lanes of the walk's groups
(the `lanes` fixture, warpdyn.config.fused_lanes; warpdyn.engine.fused_layout.fused_lanes: a GPU's choice
for few environments, run on the CPU here as Warp's blocks of fibers).
"""

import dataclasses
import pathlib
import re
import warnings

import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from warpdyn.engine import contact_stage, fused_layout, launch, warp_private
from warpdyn.engine import evaluations as engine_evaluations
from warpdyn.engine import step as engine_step
from warpdyn.engine.fused_layout import fused_walk
from warpdyn.kernels import fused_step
from warpdyn.kernels.fused_step import BASE
from warpdyn.types.enums import VelRepr

STATE = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities", "tangential_deformation_state")
TOLERANCE = {np.float64: 1e-12, np.float32: 1e-4}
SO3 = wd.model.IntegratorType.SemiImplicitEulerSO3


@pytest.fixture(params=[True, False], ids=["kept transforms", "recomputed transforms"])
def keep(request, monkeypatch):
    """Each variant of the fused kernel, whatever the device and N would choose."""
    monkeypatch.setattr(fused_layout, "keeps_joint_transforms", lambda device, N: request.param)
    return request.param


@pytest.fixture(params=[False, True], ids=["one thread", "lanes"])
def lanes(request, monkeypatch):
    """One thread per environment, or one per group of the model's walk (on the CPU: Warp's blocks of threads,
    which it runs with wp.config.enable_cpu_blocks only), whatever the device and N would choose."""
    monkeypatch.setattr(wp.config, "enable_cpu_blocks", request.param)
    monkeypatch.setattr(wd.config, "fused_lanes", request.param)
    return request.param


def _standing(model, N, seed=0, spread=1.0, repr_=VelRepr.Mixed):
    """N states of the legs near a stance, the feet 3 mm in the ground (+- 2 mm): random joints, base velocity
    and joint velocities (scaled by `spread`), so contacts stick, slip and release across the batch."""
    rng = np.random.default_rng(seed)
    lowest = float(wd.contact.collidable_point_positions(model, wd.data.Data.build(model)).numpy()[:, 2].min())
    z = -lowest - 0.003 + rng.uniform(-0.002, 0.002, N)
    n = model.dofs()
    return wd.data.Data.build(
        model,
        num_envs=N,
        base_position=np.stack([np.zeros(N), np.zeros(N), z], axis=1),
        joint_positions=rng.uniform(-0.05, 0.05, (N, n)),
        joint_velocities=spread * rng.uniform(-1.0, 1.0, (N, n)),
        base_linear_velocity=spread * rng.normal(0.0, 0.3, (N, 3)),
        base_angular_velocity=spread * rng.normal(0.0, 0.5, (N, 3)),
        velocity_representation=repr_,
    )


def _with(data, m=None, valid=None):
    """data with the tangential deformation m (N, nc, 3) and the health flags valid (N,) given."""
    changes = {}
    if m is not None:
        changes["tangential_deformation_state"] = wp.array(m, dtype=data.scalar, device=data.device)
    if valid is not None:
        changes["valid_state"] = wp.array(valid, dtype=wp.int32, device=data.device)
    return dataclasses.replace(data, **changes)


def _legs(dtype, integrator=robots.SIE):
    model = robots.ergocub_seed_with_points(dtype)
    model = wd.model.reduce(model, model.joint_names())  # its own plan and caches
    model.integrator = integrator
    return model


def _both(monkeypatch, model, data, **inputs):
    """(fused, launch list): the data after one step (warpdyn.engine.step.step, which builds its launches at
    each call) with warpdyn.config.fused_step on, then off."""
    out = []
    for fused in (True, False):
        monkeypatch.setattr(wd.config, "fused_step", fused)
        out.append(engine_step.step(model, data, **inputs))
    return out


def _assert_close(fused, listed, dtype, label=""):
    tolerance = TOLERANCE[dtype]
    np.testing.assert_array_equal(fused.valid_state.numpy(), listed.valid_state.numpy(), err_msg=f"{label} health flags")
    for name in STATE:
        a, b = getattr(fused, name).numpy(), getattr(listed, name).numpy()
        finite = np.abs(b[np.isfinite(b)])
        scale = max(1.0, float(finite.max())) if finite.size else 1.0
        np.testing.assert_allclose(a, b, rtol=0.0, atol=tolerance * scale, err_msg=f"{label} {name}")


def test_the_fused_step_is_what_a_step_launches_without_gradients(monkeypatch, keep, lanes):
    model = _legs(np.float64)
    data = _standing(model, 4)
    monkeypatch.setattr(wd.config, "fused_step", True)
    plan, _ = engine_step.prepare(model, data, health=True)
    assert plan.lanes == 2, "the legs: one group per leg"
    ws = engine_step.Workspace(plan, 4, False, False)
    x, y = engine_step.state_arrays(data), engine_step.state_buffers(plan, 4, False)
    launches = engine_step.step_launches(plan, ws, x, y, plan.zeros((plan.n,), 4), None, int(data.velocity_representation))
    fused, dim, block_dim = engine_step.fused_kernel(plan, 4)
    check = engine_step.parameter_check(plan, None, None, 4).kernel
    assert [item.kernel for item in launches] == [fused, check], "the joint forces in the fused kernel, then the parameters' check"
    shared = fused_layout.shared_records(plan, 1, wd.config.cuda_block_dim if plan.device.is_cuda else None)[0]
    assert (launches[0].dim, launches[0].block_dim) == (((4, 2), 2) if lanes else (4, shared or None))
    assert fused is engine_step.fused_kernel(plan, 4)[0] and fused is not engine_step.plan(model).fused(not keep, 2 if lanes else 1)
    assert fused is not engine_step.plan(model).fused(keep, 1 if lanes else 2)
    grad_ws = engine_step.Workspace(plan, 4, True, False)
    listed = engine_step.step_launches(plan, grad_ws, x, y, plan.zeros((plan.n,), 4), None, int(data.velocity_representation))
    assert fused not in [item.kernel for item in listed] and len(listed) == 9, "with gradients: the launch list, the parameters' check last"
    with wp.Tape():
        taped = engine_step.step_launches(plan, ws, x, y, plan.zeros((plan.n,), 4), None, int(data.velocity_representation))
    assert fused not in [item.kernel for item in taped], "under a tape: the launch list"


@pytest.mark.usefixtures("keep", "lanes")
@pytest.mark.parametrize("integrator", [robots.SIE, SO3], ids=["jaxsim_euler", "mujoco_euler"])
def test_legs_in_contact_with_torques(monkeypatch, dtype, integrator):
    model = _legs(dtype, integrator)
    data = _standing(model, 64)
    tau = np.random.default_rng(1).normal(0.0, 5.0, (64, model.dofs()))
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    assert fused.valid_state.numpy().all()
    _assert_close(fused, listed, dtype)
    # a second step from a state whose tangential deformation is not zero
    fused2, listed2 = _both(monkeypatch, model, listed, joint_force_references=tau)
    assert np.abs(listed.tangential_deformation_state.numpy()).max() > 1e-6
    _assert_close(fused2, listed2, dtype, "second step")


@pytest.mark.usefixtures("keep", "lanes")
@pytest.mark.parametrize("repr_", [VelRepr.Inertial, VelRepr.Body, VelRepr.Mixed], ids=lambda r: r.name)
def test_link_forces_in_each_representation(monkeypatch, repr_):
    model = _legs(np.float64)
    data = _standing(model, 8, repr_=repr_)
    f = np.random.default_rng(2).normal(0.0, 5.0, (8, model.number_of_links(), 6))
    fused, listed = _both(monkeypatch, model, data, link_forces=f)
    _assert_close(fused, listed, np.float64, repr_.name)


@pytest.mark.usefixtures("keep", "lanes")
def test_actuators_armature_implicit_damping_and_per_environment_contact_parameters(monkeypatch):
    model = _legs(np.float64)
    model = wd.model.add_actuators(model, "position", kp=300.0, kv=5.0, ctrl_range=(-1.5, 1.5), force_range=(-100.0, 100.0))
    n = model.dofs()
    model.set_joint_parameters(armature=np.full(n, 0.05), damping=np.full(n, 0.3))
    model.implicit_damping = True
    N = 16
    rng = np.random.default_rng(3)
    model.contact_params = wd.contact.SoftContactsParams(K=rng.uniform(5e5, 2e6, N), D=rng.uniform(2e3, 5e3, N), mu=rng.uniform(0.2, 1.0, N))
    data = _standing(model, N)
    ctrl = rng.uniform(-1.0, 1.0, (N, model.number_of_actuators()))
    fused, listed = _both(monkeypatch, model, data, ctrl=ctrl)
    _assert_close(fused, listed, np.float64)


@pytest.mark.usefixtures("keep", "lanes")
@pytest.mark.parametrize("implicit", [False, True], ids=["explicit damping", "implicit damping"])
def test_gravity_compensation_and_the_bases_free_joint_armature_damper_and_spring(monkeypatch, implicit):
    """The passive link forces (MJCF's gravcomp on some links, per environment; the floating base's free-joint
    damper and spring) and the base's free-joint armature (+ dt damping when implicit) in the fused kernel equal
    the launch list's (kernels/forces.py's passive_link_wrench, kernels/aba.py's base terms in both)."""
    model = _legs(np.float64)
    N, nL = 16, model.number_of_links()
    rng = np.random.default_rng(11)
    gravcomp = np.zeros((N, nL))
    gravcomp[:, 1::2] = rng.uniform(0.1, 2.0, (N, len(range(1, nL, 2))))
    model.set_link_parameters(gravcomp_mass=gravcomp, gravcomp_com=rng.uniform(-0.05, 0.05, (N, nL, 3)))
    model.set_joint_parameters(base_armature=rng.uniform(0.01, 0.5, (N, 1)), base_damping=rng.uniform(0.1, 3.0, (N, 1)), base_stiffness=rng.uniform(1.0, 20.0, (N, 1)))
    model.implicit_damping = implicit
    data = _standing(model, N)
    assert engine_step.plan(model).fused is not None and engine_step.plan(model).gravcomp
    tau = rng.uniform(-5.0, 5.0, (N, model.dofs()))
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    _assert_close(fused, listed, np.float64)
    without = wd.model.step(_legs(np.float64), data, joint_force_references=tau)
    assert np.abs(fused.base_velocity.numpy() - without.base_velocity.numpy()).min() > 1e-6, "the terms act in each environment"


@pytest.mark.usefixtures("keep", "lanes")
def test_friction_limit_springs_and_the_torque_speed_curve(monkeypatch):
    """JaxSim's joint forces, computed in the fused kernel, with each term active somewhere in the batch: joints
    beyond their limits, static and viscous friction, references clipped by the torque-speed curve. The
    applied torques it writes are the actuation kernel's."""
    model = _legs(np.float64)
    n, N = model.dofs(), 16
    rng = np.random.default_rng(7)
    model.set_joint_parameters(
        limit_spring=rng.uniform(50.0, 500.0, n), limit_damper=rng.uniform(0.0, 0.2, n), friction_static=rng.uniform(0.0, 5.0, n), friction_viscous=rng.uniform(0.0, 2.0, n)
    )
    model.actuation_params = wd.model.ActuationParams(torque_max=40.0, omega_th=0.5, omega_max=2.0)
    data = _standing(model, N, spread=2.0)
    lower, upper = wd.joint.position_limits(model)
    s = data.joint_positions.numpy()
    s[: N // 2] = np.where(rng.random((N // 2, n)) < 0.5, lower - 0.05, upper + 0.05)  # beyond a limit
    data = dataclasses.replace(data, joint_positions_state=wp.array(s, dtype=wp.float64, device=data.device))
    tau = rng.uniform(-80.0, 80.0, (N, n))
    plan, _ = engine_step.prepare(model, data, health=True)
    assert plan.with_limits and plan.with_friction
    applied = []
    for fused in (True, False):
        monkeypatch.setattr(wd.config, "fused_step", fused)
        ws = engine_step.Workspace(plan, N, False, False)
        x, y = engine_step.state_arrays(data), engine_step.state_buffers(plan, N, False)
        tau_ref = wp.array(tau, dtype=wp.float64, device=data.device)
        launch.run(engine_step.step_launches(plan, ws, x, y, tau_ref, None, int(data.velocity_representation)), plan.device)
        applied.append(ws.tau.numpy())
    assert (np.abs(applied[1]) == 40.0).any() and (np.abs(applied[1]) < 40.0).any(), "clipped and not"
    np.testing.assert_array_equal(applied[0], applied[1])
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    _assert_close(fused, listed, np.float64)


@pytest.mark.usefixtures("keep", "lanes")
def test_heightfield_terrain_and_disabled_points(monkeypatch):
    model = _legs(np.float64)
    count = len(model.kin_dyn_parameters.contact_parameters.body)
    enabled = np.arange(count) % 3 != 0
    model = wd.contact.with_collidable_points(model, enabled=enabled)
    xs = np.linspace(-1.0, 1.0, 9)
    heights = 0.01 * np.sin(3.0 * xs)[:, None] * np.cos(2.0 * xs)[None, :]
    model.terrain = wd.terrain.HeightfieldTerrain(heights, origin=(-1.0, -1.0), spacing=(0.25, 0.25))
    data = _standing(model, 8)
    m = np.random.default_rng(4).normal(0.0, 1e-3, (8, count, 3))
    data = _with(data, m=m)
    fused, listed = _both(monkeypatch, model, data)
    _assert_close(fused, listed, np.float64)
    np.testing.assert_array_equal(fused.tangential_deformation_state.numpy()[:, ~enabled], m[:, ~enabled])


TERRAINS = {
    "flat": wd.terrain.FlatTerrain(height=0.002),
    "plane": wd.terrain.PlaneTerrain(normal=(0.05, -0.03, 1.0), point=(0.0, 0.0, 0.004)),
    "heightfield": wd.terrain.HeightfieldTerrain(
        0.004 * np.sin(np.linspace(0.0, 3.0, 9))[:, None] * np.cos(np.linspace(0.0, 2.0, 9))[None, :], origin=(-1.0, -1.0), spacing=(0.25, 0.25)
    ),
}


@pytest.mark.parametrize("terrain", list(TERRAINS))
def test_contacts_made_for_a_terrain_kind_equal_those_for_any_kind(monkeypatch, terrain):
    """The contact kernel made for the plan's terrain kind (kernels/soft_contacts.py's kernels(scalar, kind):
    a constant, the other kinds' code dropped, on flat terrain no products with the normal) gives the numbers
    of the one that reads the kind at run time: each point's wrench and deformation rate, and the links'
    wrenches, to rounding (the CPU's agree bit for bit; on an H100 the heightfield's differed by 6e-18 relative:
    the compiler contracts the two kernels' products into fused multiply-adds differently), some points in
    contact, others not."""
    contact_kernels = contact_stage.contact_kernels
    out = []
    for any_kind in (False, True):
        if any_kind:
            monkeypatch.setattr(contact_stage, "contact_kernels", lambda scalar, kind=None: contact_kernels(scalar))
        model = _legs(np.float64)  # its own plan: the launches are built afresh
        model.terrain = TERRAINS[terrain]
        data = _with(_standing(model, 8), m=np.random.default_rng(9).normal(0.0, 2e-3, (8, 32, 3)))
        out.append([a.numpy() for a in engine_evaluations.contact_forces(model, data)])
    W_f_C, m_dot, W_f_L = out[0]
    assert (np.abs(W_f_C[..., 2]) > 0.0).any() and (W_f_C[..., 2] == 0.0).any(), "points in contact and not"
    for name, specific, generic in zip(("W_f_C", "m_dot", "W_f_L"), out[0], out[1]):
        np.testing.assert_allclose(specific, generic, rtol=0.0, atol=1e-13 * max(1.0, np.abs(generic).max()), err_msg=f"{terrain}: {name}")


@pytest.mark.usefixtures("keep", "lanes")
@pytest.mark.parametrize("case", ["no_points", "fixed_base_chain", "single_body"])
def test_models_without_contacts_or_without_a_floating_base(monkeypatch, case):
    if case == "no_points":
        legs = _legs(np.float64)
        data = _standing(legs, 8)  # placed by the points, which the model then disables (the rows stay)
        model = robots.contact_free(legs)
    elif case == "fixed_base_chain":
        model = robots.build(robots.pendulum_chain_urdf(5), np.float64, is_urdf=True)
        data = wd.data.Data.build(model, num_envs=8, **robots.random_state_kwargs(model, np.random.default_rng(5), 8))
    else:
        model = robots.build(robots.BODY_URDF, np.float64, is_urdf=True)
        data = wd.data.Data.build(model, num_envs=8, **robots.random_state_kwargs(model, np.random.default_rng(6), 8))
    fused, listed = _both(monkeypatch, model, data)
    _assert_close(fused, listed, np.float64, case)


@pytest.mark.usefixtures("keep", "lanes")
@pytest.mark.parametrize(("seed", "fixed_base"), [(0, False), (1, False), (0, True)])
def test_random_trees_branching_below_the_base(monkeypatch, seed, fixed_base):
    """Trees whose links have several children anywhere (the walk's slots), floating and fixed bases."""
    model = robots.build(robots.random_tree_urdf(seed, num_links=14, max_depth=4, fixed_base=fixed_base), np.float64, is_urdf=True)
    walk = fused_walk(model.tree.parent, fused_layout.MAX_LANES)
    assert walk.slots >= 2 and walk.groups >= 2, "the case is meant to branch at the base and below it"
    data = wd.data.Data.build(model, num_envs=8, **robots.random_state_kwargs(model, np.random.default_rng(seed), 8))
    tau = np.random.default_rng(seed + 1).normal(0.0, 2.0, (8, model.dofs()))
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    _assert_close(fused, listed, np.float64, f"tree {seed}")


@pytest.mark.usefixtures("keep", "lanes")
def test_the_whole_ergocub_in_contact(monkeypatch):
    """The whole ergoCub (legs, torso, arms and head: branches below the base) with its points."""
    model = wd.contact.with_collidable_points(robots.ergocub_full_model(np.float64), options=robots.NO_MESH)
    walk = fused_walk(model.tree.parent, fused_layout.MAX_LANES)
    assert walk.slots >= 3 and walk.groups == 3, "the base's legs and torso, and branches below"
    data = _standing(model, 8)
    fused, listed = _both(monkeypatch, model, data)
    _assert_close(fused, listed, np.float64)


# A floating robot (a free base whose hinges branch) and a crate with its free joint's armature, damper and
# spring: in one world, two free-joint trees below its fixed base, their boxes and spheres near the ground.
FREE_TREES = """
<mujoco model="free trees">
  <option gravity="0 0 -9.81" timestep="0.001"/>
  <worldbody>
    <body name="torso" pos="0 0 0.32" euler="0.1 -0.05 0.3">
      <freejoint name="torso_free"/>
      <inertial pos="0.01 0 0" mass="4" diaginertia="0.05 0.08 0.1"/>
      <geom type="box" size="0.2 0.1 0.05"/>
      <body name="left" pos="0.15 0.12 0">
        <joint name="left_hip" axis="0 1 0" damping="0.2" armature="0.01"/>
        <inertial pos="0 0 -0.1" mass="0.6" diaginertia="0.004 0.004 0.001"/>
        <geom type="capsule" fromto="0 0 0 0 0 -0.2" size="0.02"/>
        <body name="left_foot" pos="0 0 -0.2">
          <joint name="left_knee" axis="0 1 0"/>
          <inertial pos="0 0 -0.05" mass="0.3" diaginertia="0.001 0.001 0.0005"/>
          <geom type="sphere" pos="0 0 -0.08" size="0.03"/>
        </body>
      </body>
      <body name="right" pos="0.15 -0.12 0">
        <joint name="right_hip" axis="0 1 0" damping="0.2"/>
        <inertial pos="0 0 -0.1" mass="0.6" diaginertia="0.004 0.004 0.001"/>
        <geom type="sphere" pos="0 0 -0.25" size="0.03"/>
      </body>
    </body>
    <body name="crate" pos="1 0.5 0.09" euler="0.02 -0.01 0.5">
      <joint name="crate_free" type="free" armature="0.02" damping="0.3" stiffness="2"/>
      <inertial pos="0.01 0.02 -0.01" mass="2.5" diaginertia="0.03 0.04 0.05"/>
      <geom type="box" size="0.1 0.15 0.1"/>
    </body>
  </worldbody>
</mujoco>
"""


def _scene(which: str, dtype):
    """(a scene whose trees hang from its world by free joints, 4 states of it): Menagerie's Panda beside a free
    cube (without its fingers' equality constraint), or FREE_TREES; random joint velocities about MuJoCo's qpos0, each free body 3 mm lower (the cube
    and the crate in the ground)."""
    source = FREE_TREES
    if which == "panda_cube":  # without its finger coupling (an equality constraint: the launch list, tests/test_equality.py)
        source = re.sub(r"<equality>.*?</equality>", "", (pathlib.Path(__file__).parent / "models" / "menagerie" / "mjx_single_cube.xml").read_text(), flags=re.S)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # what the scenes hold that warpdyn does not model, named in warnings elsewhere
        model = wd.model.Model.build_from_model_description(source, dtype=dtype)
    model.time_step = 0.002
    rng = np.random.default_rng(7)
    positions = wd.data.Data.build(model, num_envs=4).joint_positions.numpy()
    for k in range(model.number_of_joints()):
        at = wd.joint.position_slice(model, joint_index=k)
        if at.stop - at.start == 7:  # a free joint: 3 mm lower
            positions[:, at.start + 2] -= 0.003
    velocities = rng.normal(0.0, 0.5, (4, model.dofs()))
    return model, wd.data.Data.build(model, num_envs=4, joint_positions=positions, joint_velocities=velocities)


@pytest.mark.usefixtures("keep", "lanes")
@pytest.mark.parametrize(("which", "dtype"), [("panda_cube", np.float64), ("free_trees", np.float64), ("free_trees", np.float32)], ids=["panda_cube-float64", "free_trees-float64", "free_trees-float32"])
def test_scenes_whose_trees_hang_from_free_joints(monkeypatch, which, dtype):
    """A scene's free bodies and floating robots (free joints below its fixed world) take the fused step, their
    six DoFs solved together (kernels/aba.py's free_joint_acceleration), and equal the launch list's DoF-by-DoF
    ABA to rounding, over two steps with joint forces on every DoF, contacts and the free joints' armature,
    damper and spring (MuJoCo's implicit damping)."""
    model, data = _scene(which, dtype)
    monkeypatch.setattr(wd.config, "fused_step", True)
    plan, _ = engine_step.prepare(model, data, health=True)
    assert plan.fused is not None and plan.count > 0 and model.multi_dof()
    tau = np.random.default_rng(3).normal(0.0, 1.0, (4, model.dofs()))
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    assert listed.valid_state.numpy().all() and np.abs(listed.tangential_deformation_state.numpy()).max() > 0, "in contact"
    _assert_close(fused, listed, dtype, which)
    fused2, listed2 = _both(monkeypatch, model, listed, joint_force_references=tau)
    _assert_close(fused2, listed2, dtype, f"{which}, second step")


def test_which_scenes_take_the_fused_step():
    """Free joints below the world take it; a ball joint, or a free joint below a floating base (a URDF floating
    joint), take the launch list."""
    ball = FREE_TREES.replace('<joint name="right_hip" axis="0 1 0" damping="0.2"/>', '<joint name="right_hip" type="ball"/>')
    inertia = '<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.2" izz="0.3" ixy="0" ixz="0" iyz="0"/></inertial>'
    floating = f"""<robot name="r"><link name="base">{inertia}</link><link name="loose">{inertia}</link>
      <joint name="float" type="floating"><parent link="base"/><child link="loose"/></joint></robot>"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        models = {name: wd.model.Model.build_from_model_description(xml) for name, xml in (("free roots", FREE_TREES), ("ball", ball), ("below a floating base", floating))}
    assert models["below a floating base"].floating_base() and models["below a floating base"].multi_dof()
    assert {name: engine_step.plan(m).fused is not None for name, m in models.items()} == {"free roots": True, "ball": False, "below a floating base": False}


def test_the_walk_visits_each_link_after_its_parent_and_hands_over_through_slots():
    """fused_walk on a tree whose base and link 1 branch: depth-first, children in index order; the parent's slot
    only where the parent is not the link just before."""
    #      0
    #    /   \
    #   1     4
    #  / \    |
    # 2   3   5
    #  \
    #   6
    walk, starts, slots = fused_walk([-1, 0, 1, 1, 0, 4, 2])
    assert slots == 2 and starts.tolist() == [1, 7]
    assert walk.tolist() == [[0, 0, -1], [1, 1, BASE], [2, -1, -1], [6, -1, -1], [3, -1, 1], [4, -1, 0], [5, -1, -1]]
    walk, starts, slots = fused_walk([-1, 0, 1, 1, 0, 4, 2], 2)  # each subtree of the base in a group of its own
    assert slots == 2 and starts.tolist() == [1, 5, 7]
    assert walk.tolist() == [[0, 0, -1], [1, 1, BASE], [2, -1, -1], [6, -1, -1], [3, -1, 1], [4, -1, BASE], [5, -1, -1]]
    chain = fused_walk([-1, 0, 1, 2], 4)
    assert chain.slots == 0 and chain.groups == 1 and chain.walk.tolist() == [[0, -1, -1], [1, -1, BASE], [2, -1, -1], [3, -1, -1]]
    assert fused_walk([-1], 4).starts.tolist() == [1, 1], "a single body: one empty group"
    for seed in range(20):
        rng = np.random.default_rng(seed)
        parent = [-1] + [int(rng.integers(0, i)) for i in range(1, 12)]
        groups = int(rng.integers(1, 5))
        walk, starts, slots = fused_walk(parent, groups)
        order = walk[:, 0].tolist()
        assert sorted(order) == list(range(12)) and order[0] == 0
        assert len(starts) - 1 == min(groups, max(1, parent.count(0))) and starts[0] == 1 and starts[-1] == 12
        for k in range(1, 12):
            i, up = order[k], walk[k, 2]
            assert order.index(parent[i]) < k
            if k in starts:
                assert parent[i] == 0 and up == BASE, "a group begins below the base"
            else:
                assert (up == -1) == (order[k - 1] == parent[i])
            if up >= 0:
                assert walk[order.index(parent[i]), 1] == up
        group = np.searchsorted(starts, np.arange(1, 12), side="right") - 1
        for k in range(1, 12):  # a link walks in its parent's group
            p = order.index(parent[order[k]])
            if p > 0:
                assert group[p - 1] == group[k - 1]


def test_the_groups_share_the_work_of_the_base_subtrees():
    """Largest subtree first, to the group with the least work so far; a link's work counts its points."""
    #          0
    #   /   /    \    \
    #  1   4      6    8
    #  |   |      |
    #  2   5      7
    #  |
    #  3
    parent = [-1, 0, 1, 2, 0, 4, 0, 6, 0]
    walk, starts, _ = fused_walk(parent, 2)
    groups = [walk[starts[g]:starts[g + 1], 0].tolist() for g in range(2)]
    assert groups == [[1, 2, 3, 8], [4, 5, 6, 7]], "3 + 1 links against 2 + 2"
    work = np.ones(9)
    work[8] = 10.0  # a link with many points
    walk, starts, _ = fused_walk(parent, 2, work)
    groups = [walk[starts[g]:starts[g + 1], 0].tolist() for g in range(2)]
    assert groups == [[8], [1, 2, 3, 4, 5, 6, 7]]
    assert fused_walk(parent, 8).groups == 4, "no more groups than subtrees"


@pytest.mark.usefixtures("keep", "lanes")
def test_unhealthy_environments_are_flagged_alike_and_keep_their_state(monkeypatch):
    model = _legs(np.float64)
    count = len(model.kin_dyn_parameters.contact_parameters.body)
    enabled = np.arange(count) != 0
    model = wd.contact.with_collidable_points(model, enabled=enabled)
    data = _standing(model, 7)
    tau = np.zeros((7, model.dofs()))
    tau[1, 3] = np.nan  # a NaN torque
    tau[2, 0] = np.inf  # an infinite torque
    m = np.zeros((7, count, 3))
    m[3, 0, 1] = np.inf  # a disabled point's deformation: not finite
    # in the air, an infinite deformation of a point that the last group walks: its force is 0, its next
    # deformation NaN, seen by that group's lane only (the lanes sum their checks)
    plan, _ = engine_step.prepare(model, data, health=True)
    walk, starts = plan.walk.numpy(), plan.walk_starts.numpy()
    last_group = walk[starts[-2] : starts[-1], 0]
    point_links = np.asarray(model.kin_dyn_parameters.contact_parameters.body)
    row = int(np.flatnonzero(enabled & np.isin(point_links, last_group))[0])
    m[6, row, 2] = np.inf
    position = data.base_position.numpy()
    position[6, 2] += 0.2
    valid = np.ones(7, dtype=np.int32)
    valid[4] = 0  # already flagged
    data = _with(data, m=m, valid=valid)
    data = dataclasses.replace(data, base_position_state=wp.array(position, dtype=wp.float64, device=data.device))
    tau = wp.array(tau, dtype=wp.float64, device=data.device)  # a device array: not checked on the host
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    np.testing.assert_array_equal(fused.valid_state.numpy(), [1, 0, 0, 0, 0, 1, 0])
    _assert_close(fused, listed, np.float64)
    for name in STATE:  # a flagged environment keeps its state
        np.testing.assert_array_equal(getattr(fused, name).numpy()[1:5], getattr(data, name).numpy()[1:5], err_msg=name)
        np.testing.assert_array_equal(getattr(fused, name).numpy()[6], getattr(data, name).numpy()[6], err_msg=name)


@pytest.mark.usefixtures("keep", "lanes")
def test_a_stepper_reports_the_contact_wrenches_of_its_last_substep(monkeypatch):
    """Stepper.contact_wrenches with the fused step: the wrenches at the start of a call's last step, as the
    launch list's contact kernel wrote them."""
    model = _legs(np.float64)
    data = _standing(model, 8)
    out = []
    for fused in (True, False):
        monkeypatch.setattr(wd.config, "fused_step", fused)
        stepper = wd.simulation.Stepper(model, data, substeps=3, use_graph=False)
        stepper.step()
        out.append((stepper.contact_wrenches.numpy(), stepper.data))
    (W_f_fused, data_fused), (W_f_listed, data_listed) = out
    assert np.abs(W_f_listed[:, :, 2]).max() > 1.0, "the feet press on the ground"
    np.testing.assert_allclose(W_f_fused, W_f_listed, rtol=0.0, atol=1e-9 * np.abs(W_f_listed).max())
    _assert_close(data_fused, data_listed, np.float64, "after 3 substeps")


def test_the_settings_are_checked():
    with pytest.raises(TypeError, match="fused_step"):
        wd.config.fused_step = 1
    with pytest.raises(TypeError, match="fused_lanes"):
        wd.config.fused_lanes = "auto"
    with pytest.raises(TypeError, match="fused_shared_records"):
        wd.config.fused_shared_records = None
    assert wd.config.fused_shared_records is True


def test_which_devices_sizes_and_settings_give_lanes(monkeypatch):
    """By default a GPU's groups up to LANES_UP_TO environments (by the scalar's size), one thread beyond and
    on the CPU; True forces the groups, on the CPU only with Warp's CPU blocks; False one thread."""
    gpu = type("GPU", (), {"is_cpu": False, "is_cuda": True})()
    for dtype, size in ((np.float32, 4), (np.float64, 8)):
        model = _legs(dtype)
        lanes = engine_step.prepare(model, _standing(model, 1), health=True)[0].lanes
        limit = fused_layout.LANES_UP_TO[size]
        plan = type("Plan", (), {"device": wp.get_device("cpu"), "lanes": lanes, "scalar": wp.dtype_from_numpy(np.dtype(dtype))})()
        assert fused_layout.fused_lanes(plan, 1) == 1, "the CPU"
        on_gpu = type("Plan", (), {"device": gpu, "lanes": lanes, "scalar": plan.scalar})()
        assert fused_layout.fused_lanes(on_gpu, 1) == fused_layout.fused_lanes(on_gpu, limit) == 2
        assert fused_layout.fused_lanes(on_gpu, limit + 1) == 1
        monkeypatch.setattr(wd.config, "fused_lanes", False)
        assert fused_layout.fused_lanes(on_gpu, 1) == 1
        monkeypatch.setattr(wd.config, "fused_lanes", True)
        assert fused_layout.fused_lanes(on_gpu, 10 * limit) == 2
        monkeypatch.setattr(wp.config, "enable_cpu_blocks", False)
        with pytest.raises(RuntimeError, match="enable_cpu_blocks"):
            fused_layout.fused_lanes(plan, 1)
        monkeypatch.setattr(wp.config, "enable_cpu_blocks", True)
        assert fused_layout.fused_lanes(plan, 1) == 2
        monkeypatch.setattr(wd.config, "fused_lanes", None)


def test_which_devices_and_sizes_keep_the_joint_transforms():
    """The CPU keeps them at any N; a GPU up to KEEP_JOINT_TRANSFORMS_UP_TO environments (the `keep` fixture
    replaces this rule in the tests of the step)."""
    rule, limit = fused_layout.keeps_joint_transforms, fused_layout.KEEP_JOINT_TRANSFORMS_UP_TO
    cpu = wp.get_device("cpu")
    gpu = type("GPU", (), {"is_cpu": False, "is_cuda": True})()
    assert rule(cpu, 1) and rule(cpu, 10 * limit)
    assert rule(gpu, 1) and rule(gpu, limit) and not rule(gpu, limit + 1)


def test_which_devices_blocks_and_settings_keep_the_records_in_shared_memory(monkeypatch):
    """A GPU on one thread per environment: the whole records when a block's fit SHARED_RECORDS_BYTES, else
    without c_i when those fit; else (the CPU, lanes, blocks too large for the model, and
    warpdyn.config.fused_shared_records = False) each thread's local memory (0, False)."""
    rule, budget = fused_layout.shared_records, fused_layout.SHARED_RECORDS_BYTES
    gpu = type("GPU", (), {"is_cpu": False, "is_cuda": True})()

    def plan(device, scalar, nL):
        return type("Plan", (), {"device": device, "scalar": scalar, "nL": nL})()

    legs32, legs64 = plan(gpu, wp.float32, 13), plan(gpu, wp.float64, 13)
    assert rule(legs32, 1, 64) == (64, True) and rule(legs32, 1, 32) == (32, True)
    assert rule(legs32, 1, 96) == (96, False), "13 links x 13 numbers x 4 B x 96 threads: 63.4 KiB; x 7 numbers: 34.1 KiB"
    assert rule(legs32, 1, 192) == (0, False), "x 7 numbers x 192 threads: 68.25 KiB"
    assert rule(legs64, 1, 64) == (64, False) and rule(legs64, 1, 32) == (32, True)
    assert rule(legs32, 2, 2) == (0, False), "lanes"
    assert rule(plan(wp.get_device("cpu"), wp.float32, 13), 1, None) == (0, False), "the CPU"
    whole, without_c = budget // (13 * 4 * 64), budget // (7 * 4 * 64)
    assert rule(plan(gpu, wp.float32, whole), 1, 64) == (64, True) and rule(plan(gpu, wp.float32, whole + 1), 1, 64) == (64, False)
    assert rule(plan(gpu, wp.float32, without_c), 1, 64) == (64, False) and rule(plan(gpu, wp.float32, without_c + 1), 1, 64) == (0, False)
    with pytest.raises(ValueError, match="one thread per environment, not 2 lanes"):
        fused_step.kernel(wp.float32, 13, 1, False, None, contact_stage.SoftContactStage.point_law, None, False, False, False, 2, 64)
    monkeypatch.setattr(wd.config, "fused_shared_records", False)
    assert rule(legs32, 1, 64) == (0, False) and rule(legs64, 1, 32) == (0, False)


@pytest.mark.skipif(not wp.get_device().is_cuda, reason="shared memory: the tests' device is not a GPU")
@pytest.mark.parametrize(
    ("dtype_", "block", "shared_c"),
    [(np.float32, 32, True), (np.float32, 64, True), (np.float32, 96, False), (np.float64, 32, True), (np.float64, 64, False)],
    ids=["float32-32", "float32-64", "float32-96", "float64-32", "float64-64"],
)
def test_records_in_shared_memory_are_what_a_step_launches_in_each_block_size(monkeypatch, keep, dtype_, block, shared_c):
    """On a GPU, one thread per environment: the kernel made for the block size of warpdyn.config.cuda_block_dim
    (records whole or without c_i, as they fit), its launches pinned to it, the step as the launch list's."""
    monkeypatch.setattr(wd.config, "fused_lanes", False)
    monkeypatch.setattr(wd.config, "cuda_block_dim", block)
    model = _legs(dtype_)
    data = _standing(model, 100)
    plan, _ = engine_step.prepare(model, data, health=True)
    assert fused_layout.shared_records(plan, 1, block) == (block, shared_c)
    kernel, dim, block_dim = engine_step.fused_kernel(plan, 100)
    assert (dim, block_dim) == (100, block) and kernel is plan.fused(keep, 1, block, shared_c)
    assert kernel is not plan.fused(keep, 1) and kernel is not plan.fused(keep, 1, block, not shared_c)
    monkeypatch.setattr(wd.config, "fused_shared_records", False)
    assert engine_step.fused_kernel(plan, 100) == (plan.fused(keep, 1), 100, None), "local memory"
    monkeypatch.setattr(wd.config, "fused_shared_records", True)
    tau = np.random.default_rng(1).normal(0.0, 5.0, (100, model.dofs()))
    fused, listed = _both(monkeypatch, model, data, joint_force_references=tau)
    assert fused.valid_state.numpy().all()
    _assert_close(fused, listed, dtype_)
    fused2, listed2 = _both(monkeypatch, model, listed, joint_force_references=tau)
    _assert_close(fused2, listed2, dtype_, "second step")


@pytest.mark.skipif(not warp_private.compiles_cuda(), reason="this Warp build compiles no CUDA code")
@pytest.mark.parametrize(("dtype_", "shared_c", "size"), [(np.float32, True, 4), (np.float64, False, 8)], ids=["float32", "float64"])
def test_the_shared_records_compile_for_a_gpu_at_their_size(tmp_path, dtype_, shared_c, size):
    """Without a GPU too: the kernels that keep the records in shared memory compile to PTX (sm_90), whose
    shared array holds a block's records (shared_numbers x the scalar's bytes: 42.25 KiB for the legs in float32
    in blocks of 64, 45.5 KiB in float64 without c_i), within SHARED_RECORDS_BYTES."""
    model = _legs(dtype_)
    plan = engine_step.plan(model)
    gpu = type("Plan", (), {"device": type("GPU", (), {"is_cuda": True})(), "scalar": plan.scalar, "nL": plan.nL})()
    assert fused_layout.shared_records(gpu, 1, 64) == (64, shared_c)
    kernel = plan.fused(False, 1, 64, shared_c)
    wp.compile_aot_module(kernel.module, arch=90, module_dir=str(tmp_path), use_ptx=True)
    ptx = next(tmp_path.glob("*.ptx")).read_text(errors="replace")
    declared = [int(n) for n in re.findall(r"\.shared\s.*records\[(\d+)\]", ptx)]
    expected = fused_step.shared_numbers(plan.nL, 64, shared_c) * size
    assert declared == [expected] and expected <= fused_layout.SHARED_RECORDS_BYTES
