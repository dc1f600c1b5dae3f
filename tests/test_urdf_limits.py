"""MuJoCo's limit and friction constraints of a URDF's or SDF's joints (`model.limit_constraints`,
`model.frictionloss_constraints`): MuJoCo's URDF import makes a hinge or slide with both bounds limited and its
`<dynamics friction>` a frictionloss, with its default solref and solimp, and dof_invweight0 from M^-1 at qpos0;
warpdyn computes that diagonal on the lumped tree (warpdyn.description.invweight). Against MuJoCo 4 loading the same
URDF text, its Euler step with its Newton solver run to 1e-15 (tests/test_joint_limits.py's reference)."""

import warnings

import mujoco
import numpy as np
import pytest

import mjcf_compare
import mjcf_models as mm
import warpdyn as wd
from warpdyn.description.invweight import dof_invweight0
from warpdyn.description.tree import JOINT_KINDS

INERTIA = '<inertia ixx="{0}" iyy="{1}" izz="{2}" ixy="0.0003" ixz="-0.0002" iyz="0.0001"/>'

# A shoulder with friction, a tilted elbow, a slider with friction at the tip; its base welded to the world
ARM_URDF = f"""<robot name="urdf arm">
  <link name="world"/>
  <link name="base"><inertial><mass value="2.0"/>{INERTIA.format(0.02, 0.02, 0.03)}</inertial></link>
  <joint name="weld" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 1"/></joint>
  <link name="upper"><inertial><origin xyz="0.15 0.01 0" rpy="0.1 0 0.2"/><mass value="0.6"/>{INERTIA.format(0.001, 0.006, 0.0055)}</inertial></link>
  <joint name="shoulder" type="revolute"><parent link="base"/><child link="upper"/><origin xyz="0 0 0.1" rpy="0 0 0.3"/>
    <axis xyz="0 1 0"/><limit lower="-0.5" upper="0.8" effort="10" velocity="5"/><dynamics friction="0.4"/></joint>
  <link name="fore"><inertial><origin xyz="0.12 0 0.01"/><mass value="0.4"/>{INERTIA.format(0.001, 0.004, 0.004)}</inertial></link>
  <joint name="elbow" type="revolute"><parent link="upper"/><child link="fore"/><origin xyz="0.3 0 0" rpy="0.2 0.1 0"/>
    <axis xyz="0 0.6 0.8"/><limit lower="-1.2" upper="0.1" effort="10" velocity="5"/></joint>
  <link name="tip"><inertial><mass value="0.3"/>{INERTIA.format(0.002, 0.002, 0.002)}</inertial></link>
  <joint name="slide" type="prismatic"><parent link="fore"/><child link="tip"/><origin xyz="0.25 0 0"/>
    <axis xyz="1 0 0"/><limit lower="-0.05" upper="0.05" effort="10" velocity="1"/><dynamics friction="0.2"/></joint>
</robot>"""

# The same arm on a floating base (MuJoCo: a free joint added to its base)
FLOATING_URDF = ARM_URDF.replace('<link name="world"/>', "").replace(
    '<joint name="weld" type="fixed"><parent link="world"/><child link="base"/><origin xyz="0 0 1"/></joint>', ""
)

# Two hinges on one axis with a massless link between them: their DoFs move the tip alike, M is singular
MASSLESS_CHAIN = f"""<robot name="massless chain">
  <link name="world"/><link name="base"/><link name="between"/>
  <link name="tip"><inertial><origin xyz="0.2 0 0"/><mass value="1.0"/>{INERTIA.format(0.01, 0.01, 0.01)}</inertial></link>
  <joint name="weld" type="fixed"><parent link="world"/><child link="base"/></joint>
  <joint name="inner" type="revolute"><parent link="base"/><child link="between"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="outer" type="revolute"><parent link="between"/><child link="tip"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
</robot>"""

BALL_MJCF = """<mujoco><worldbody>
  <body name="a" pos="0 0 1"><freejoint name="a"/><geom type="box" size="0.1 0.2 0.05" mass="2"/>
    <body name="b" pos="0.2 0.1 0" euler="0.3 0.2 0.1"><joint name="ball" type="ball" pos="0.05 0 0.02"/>
      <geom type="capsule" fromto="0 0 0 0.3 0 0" size="0.03" mass="0.7"/>
      <body name="c" pos="0.3 0 0" euler="0 0.4 0"><joint name="hinge" axis="0 1 1" pos="0.01 0.02 0"/>
        <geom type="box" size="0.05 0.02 0.04" pos="0.05 0 0" mass="0.4"/>
        <body name="d" pos="0.1 0 0"><joint name="slider" type="slide" axis="1 0 0.3"/><geom type="sphere" size="0.03" mass="0.2"/></body>
      </body>
    </body>
  </body>
  <body name="cube" pos="1 0 0.5"><freejoint name="cube"/><geom type="box" size="0.05 0.05 0.05" mass="0.1"/></body>
</worldbody></mujoco>"""


def _load(text: str) -> wd.model.Model:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        warnings.simplefilter("ignore", wd.contact.NoCollidablePointsWarning)
        return wd.model.Model.build_from_model_description(text, dtype=np.float64)


def _mujoco(text: str, floating: bool) -> mujoco.MjModel:
    spec = mujoco.MjSpec.from_string(text)
    if floating:
        spec.body("base").add_freejoint()
    return spec.compile()


def _tree_invweight(model) -> np.ndarray:
    t = model.tree
    names = {code: name for name, code in JOINT_KINDS.items()}
    kinds = [None] + [names[int(k)] for k in t.joint_type[1:]]
    return dof_invweight0(t.parent, kinds, t.parent_H_joint, t.joint_axis, t.joint_pivot, t.link_mass, t.link_com, t.link_inertia,
                          t.v_start, t.armature, model.floating_base())  # fmt: skip


def _mujoco_dofs(model, mj) -> np.ndarray:
    """MuJoCo's DoF of each of warpdyn's joint DoFs (by joint name)."""
    dofs = []
    for k, name in enumerate(model.joint_names()):
        v = wd.joint.velocity_slice(model, joint_index=k)
        dofs += list(range(mj.jnt_dofadr[mj.joint(name).id], mj.jnt_dofadr[mj.joint(name).id] + v.stop - v.start))
    return np.array(dofs)


@pytest.mark.parametrize("source", ["panda", "anymal c", "ball"])
def test_the_inverse_mass_diagonal_is_mujocos_dof_invweight0(source):
    """dof_invweight0 of a lumped tree equals MuJoCo's compiled one (1e-12 relative) on a fixed arm, a floating
    quadruped and a floating chain of a ball (its pivot off the body's origin), a tilted hinge and a slide beside a free
    cube: a ball's and a free joint's entries averaged as MuJoCo's."""
    if source == "ball":
        model, mj = _load(BALL_MJCF), mujoco.MjModel.from_xml_string(BALL_MJCF)
    else:
        path = str(wd.assets.franka_panda_mjcf() if source == "panda" else wd.assets.anymal_c_mjcf())
        model, mj = _load(path), mujoco.MjModel.from_xml_path(path)
    expected = mj.dof_invweight0[_mujoco_dofs(model, mj)]
    np.testing.assert_allclose(_tree_invweight(model), expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize("floating", [False, True], ids=["fixed base", "floating base"])
def test_a_urdfs_rows_are_mujocos(floating):
    """A URDF's limited joints and joints with friction carry MuJoCo's rows: its default solref and solimp, margin 0 and
    the dof_invweight0 MuJoCo compiles from the same URDF (1e-12 relative), the base welded or floating."""
    text = FLOATING_URDF if floating else ARM_URDF
    model, mj = _load(text), _mujoco(text, floating)
    assert model.floating_base() == floating
    assert [e.name for e in model.tree.limits] == ["shoulder", "elbow", "slide"]
    assert [e.name for e in model.tree.friction_rows] == ["shoulder", "slide"]
    for row in model.tree.limits + model.tree.friction_rows:
        j = mj.joint(row.name).id
        solref, solimp = (mj.jnt_solref[j], mj.jnt_solimp[j]) if row.kind == "limit" else (mj.dof_solref[mj.jnt_dofadr[j]], mj.dof_solimp[mj.jnt_dofadr[j]])
        np.testing.assert_array_equal(row.solref, solref)
        np.testing.assert_array_equal(row.solimp, solimp)
        assert row.margin == mj.jnt_margin[j] == 0.0
        np.testing.assert_allclose(row.invweight, mj.dof_invweight0[mj.jnt_dofadr[j]], rtol=1e-12)
    assert mj.dof_frictionloss[mj.jnt_dofadr[mj.joint("shoulder").id]] == 0.4
    assert all(mj.jnt_limited[mj.joint(name).id] for name in ("shoulder", "elbow", "slide"))


def _mujoco_step(mj, qpos, qvel, dt) -> mujoco.MjData:
    """MuJoCo's Euler step with its limit and friction rows, contacts off, its Newton solver run to convergence."""
    mc = mm.reference_model(mj, constraints=True, eulerdamp=False, integrator=mujoco.mjtIntegrator.mjINT_EULER,
                            extra_disable=int(mujoco.mjtDisableBit.mjDSBL_CONTACT))  # fmt: skip
    mc.opt.timestep, mc.opt.tolerance, mc.opt.ls_tolerance, mc.opt.iterations = dt, 1e-15, 1e-15, 200
    d = mm.make_data(mc, qpos, qvel)
    mujoco.mj_step(mc, d)
    return d


@pytest.mark.parametrize("floating", [False, True], ids=["fixed base", "floating base"])
def test_a_urdf_step_at_its_limits_equals_mujocos(floating):
    """One step of the URDF arm from states past, at and within its bounds, its joints sticking or sliding, with both
    settings on equals mj_step's on MuJoCo's import of the same URDF (1e-12 of the velocities' size); the rows change
    it by far more (JaxSim's limit springs and static friction in their place)."""
    text = FLOATING_URDF if floating else ARM_URDF
    model, mj = _load(text), _mujoco(text, floating)
    model.integrator = wd.integrators.IntegratorType.SemiImplicitEulerSO3  # MuJoCo's Euler on a floating base (an MJCF's)
    without = model.copy()
    model.limit_constraints = model.frictionloss_constraints = True
    rng = np.random.default_rng(3)
    acted = 0
    for _ in range(12):
        qpos, qvel = mm.random_state(mj, rng, 1.0)
        joints = [mj.joint(name).id for name in model.joint_names()]
        for j in joints:
            side = int(rng.integers(2))
            qpos[mj.jnt_qposadr[j]] = mj.jnt_range[j, side] + (2 * side - 1) * rng.uniform(-0.05, 0.1)
            qvel[mj.jnt_dofadr[j]] = rng.normal(0.0, 1.0)
        start = mjcf_compare.mujoco_to_warpdyn_state(model, mj, qpos, qvel).data_kwargs
        d = _mujoco_step(mj, qpos, qvel, float(model.time_step))
        expected = mjcf_compare.mujoco_to_warpdyn_state(model, mj, d.qpos, d.qvel).data_kwargs
        stepped = wd.model.step(model, wd.data.Data.build(model, **start))
        scale = max(1.0, float(np.abs(expected["joint_velocities"]).max()))
        np.testing.assert_allclose(stepped.joint_velocities.numpy(), expected["joint_velocities"], rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(stepped.joint_positions.numpy(), expected["joint_positions"], rtol=0, atol=1e-12 * scale)
        if floating:
            v = stepped.base_velocity.numpy()
            np.testing.assert_allclose(v[:3], expected["base_linear_velocity"], rtol=0, atol=1e-12 * scale)
            np.testing.assert_allclose(v[3:], expected["base_angular_velocity"], rtol=0, atol=1e-12 * scale)
        free = wd.model.step(without, wd.data.Data.build(without, **start)).joint_velocities.numpy()
        acted += np.abs(free - expected["joint_velocities"]).max() > 1e-3 * scale
    assert acted >= 8, acted


def test_a_reduction_recomputes_the_rows_and_joints_without_them():
    """A reduction that locks the elbow has the rows of the URDF whose elbow is fixed, as MuJoCo compiles it (its
    invweights 1e-12 relative; the settings carried); a joint whose bounds are equal has no limit row (MuJoCo ignores
    them); a URDF of continuous joints has no row to solve (the settings refused, naming why); a massless chain, whose
    mass matrix is singular, loads, and its rows are refused when a step would solve them. tests/test_sdf.py's twins
    hold an SDF's rows to the URDF's."""
    urdf = _load(ARM_URDF)
    urdf.limit_constraints = urdf.frictionloss_constraints = True
    reduced = wd.model.reduce(urdf, ["shoulder", "slide"])
    assert reduced.limit_constraints and reduced.frictionloss_constraints
    mj = _mujoco(ARM_URDF.replace('type="revolute"><parent link="upper"/>', 'type="fixed"><parent link="upper"/>'), False)
    assert [e.name for e in reduced.tree.limits] == ["shoulder", "slide"]
    assert [e.name for e in reduced.tree.friction_rows] == ["shoulder", "slide"]
    for row in reduced.tree.limits + reduced.tree.friction_rows:
        np.testing.assert_allclose(row.invweight, mj.dof_invweight0[mj.jnt_dofadr[mj.joint(row.name).id]], rtol=1e-12)
    continuous = _load(ARM_URDF.replace('type="revolute"', 'type="continuous"').replace('type="prismatic"', 'type="continuous"')
                       .replace('<dynamics friction="0.4"/>', "").replace('<dynamics friction="0.2"/>', ""))  # fmt: skip
    with pytest.raises(ValueError, match=r"'urdf arm': it has no MuJoCo limit constraints \(no limited hinge, slide or ball joint\)"):
        continuous.limit_constraints = True
    with pytest.raises(ValueError, match=r"'urdf arm': it has no MuJoCo friction constraints \(no hinge or slide joint with friction\)"):
        continuous.frictionloss_constraints = True

    equal = ARM_URDF.replace('lower="-1.2" upper="0.1"', 'lower="0.1" upper="0.1"')
    assert [e.name for e in _load(equal).tree.limits] == ["shoulder", "slide"]
    assert not mujoco.MjModel.from_xml_string(equal).jnt_limited[_mujoco(equal, False).joint("elbow").id]
    chain = _load(MASSLESS_CHAIN)
    assert np.isnan([row.invweight for row in chain.tree.limits]).all()
    chain.limit_constraints = True
    with pytest.raises(ValueError, match=r"'massless chain': joints \['inner', 'outer'\] have no dof_invweight0"):
        wd.model.step(chain, wd.data.Data.build(chain))
