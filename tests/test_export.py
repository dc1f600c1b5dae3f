"""`Model.export_updated_model` (JaxSim's name; issue 38): a model as URDF (or MJCF) text with its current parameters,
which loads back to the same model: the same links, joints and frames, parameters, mass matrix, collidable points (in
their order) and frame poses, in float64 to rounding (1e-15 relative). Covers the ergoCub (whole and its legs,
welded and floating), a model whose parameters and joint origins were changed (JaxSim's hardware parametrisation
on tests/jaxsim/hw_leg.sdf, an SDF model exported as URDF), and what URDF cannot hold. The MJCF export (ball joints,
armature, MuJoCo's damper, springs, actuators) on a random tree, the ball fixture, the shipped Panda and the scaled
leg, with MuJoCo's own mass matrix and bias forces of the text against warpdyn's where the base is welded.
"""

import pathlib
import warnings

import mujoco
import numpy as np
import pytest

import robots
import warpdyn as wd
from warpdyn.description.tree import JOINT_FREE
from mjcf_fixtures import BALL
from mjcf_models import full_mass_matrix
from test_fused_step import FREE_TREES
from test_geom_contacts import SCENE

ROOT = pathlib.Path(__file__).resolve().parent


def assert_same_model(model, back):
    assert back.link_names() == model.link_names() and back.joint_names() == model.joint_names()
    assert sorted(back.frame_names()) == sorted(model.frame_names()) and back.floating_base() == model.floating_base()
    for name in ("link_mass", "link_com", "link_inertia", "position_limits", "friction_static", "friction_viscous"):
        np.testing.assert_allclose(getattr(back, name).numpy(), getattr(model, name).numpy(), rtol=1e-15, atol=1e-15, err_msg=name)
    np.testing.assert_allclose(wd.model.joint_origins(back)[0], wd.model.joint_origins(model)[0], rtol=0, atol=1e-15)
    data = wd.data.random_model_data(model, key=3, num_envs=2)
    M = wd.model.free_floating_mass_matrix(model, data).numpy()
    np.testing.assert_allclose(wd.model.free_floating_mass_matrix(back, data).numpy(), M, rtol=0, atol=1e-15 * np.abs(M).max())
    np.testing.assert_allclose(wd.contact.collidable_point_positions(back, data).numpy(), wd.contact.collidable_point_positions(model, data).numpy(),
                               rtol=0, atol=1e-14)
    for frame in model.frame_names()[:: max(1, len(model.frame_names()) // 10)]:
        ours = wd.frame.transform(model, data, frame_index=wd.frame.name_to_idx(model, frame_name=frame)).numpy()
        theirs = wd.frame.transform(back, data, frame_index=wd.frame.name_to_idx(back, frame_name=frame)).numpy()
        np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-14, err_msg=frame)


def load(text: str):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the ergoCub's meshes and its frames' zero masses, as when it was loaded
        return wd.model.Model.build_from_model_description(text, dtype=np.float64)


@pytest.mark.parametrize("which", ["whole", "legs", "welded leg"])
def test_the_ergocub_round_trips(which):
    """The shipped ergoCub (its 146 frames, 32 collidable points of its foot boxes), its legs (locked joints lumped)
    and one leg welded 1 m above the ground."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if which == "welded leg":
            W_H_B = np.eye(4)
            W_H_B[2, 3] = 1.0
            full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), fixed_base=True, base_pose=W_H_B, dtype=np.float64)
        else:
            full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=np.float64)
    joints = {"whole": None, "legs": wd.assets.ERGOCUB_LEG_JOINTS, "welded leg": ("r_hip_pitch", "r_hip_roll", "r_hip_yaw", "r_knee")}[which]
    model = full if joints is None else wd.model.reduce(full, considered_joints=list(joints))
    assert_same_model(model, load(model.export_updated_model()))


def test_updated_parameters_and_origins_round_trip():
    """After update_hw_parameters (masses, inertias and joint origins changed on the device) and a joint friction set
    with a setter, the exported URDF holds the new values: its model equals the updated one."""
    model = wd.model.Model.build_from_model_description((ROOT / "jaxsim" / "hw_leg.sdf").read_text(), dtype=np.float64)
    nL = model.number_of_links()
    rng = np.random.default_rng(1)
    updated = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=rng.uniform(0.8, 1.3, (nL, 3)), density=rng.uniform(0.7, 1.5, nL)))
    updated.set_joint_parameters(friction_viscous=np.array([0.1, 0.2, 0.3]))
    back = load(updated.export_updated_model())
    assert np.abs(back.link_mass.numpy() - model.link_mass.numpy()).max() > 0.1  # the update is in the text
    assert_same_model(updated, back)


def test_what_urdf_cannot_hold_is_refused():
    ball = wd.model.Model.build_from_model_description(BALL, dtype=np.float64)
    with pytest.raises(ValueError, match="joint 'ball' is a ball or free joint"):
        ball.export_updated_model()
    model = wd.model.Model.build_from_model_description((ROOT / "jaxsim" / "hw_leg.sdf").read_text(), dtype=np.float64)
    model.set_link_parameters(mass=np.ones((2, model.number_of_links())))
    with pytest.raises(ValueError, match=r"\['link_mass'\] are given per environment"):
        model.export_updated_model()


MJCF_JOINT_PARAMETERS = ("position_limits", "friction_static", "armature", "stiffness", "joint_actuator_force_range", "base_armature",
                         "base_damping", "base_stiffness")


def mjcf_source(which: str):
    """The models the MJCF export is checked on: a random tree (floating base, revolute, prismatic, fixed joints
    lumped), the ball-joint fixture, the shipped Panda (MJCF: its mesh geoms' vertices, 8 position actuators, armature,
    damping) and the hardware-scaled SDF leg with joint frictions set (viscous friction: URDF's, written as MuJoCo's
    damper). The floating ones step with MuJoCo's Euler (JaxSim's has no MJCF counterpart: a warning's matter)."""
    if which == "random tree":  # its floating base given MuJoCo's free-joint armature, damper and spring
        model = load(robots.random_tree_urdf(6, 12))
        model.set_joint_parameters(base_armature=[0.02], base_damping=[0.3], base_stiffness=[1.5])
        return model.replace(integrator=wd.model.IntegratorType.SemiImplicitEulerSO3)
    if which == "ball":
        return load(BALL)
    if which == "free trees":
        return load(FREE_TREES)
    if which == "panda":
        return load(wd.assets.franka_panda_mjcf())
    model = load((ROOT / "jaxsim" / "hw_leg.sdf").read_text())
    nL = model.number_of_links()
    updated = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.full((nL, 3), 1.2), density=np.ones(nL)))
    updated.set_joint_parameters(friction_viscous=np.array([0.1, 0.2, 0.3]), friction_static=np.array([0.5, 0.0, 0.2]))
    return updated.replace(integrator=wd.model.IntegratorType.SemiImplicitEulerSO3)


@pytest.mark.parametrize("which", ["random tree", "ball", "free trees", "panda", "scaled leg"])
def test_the_mjcf_export_round_trips_and_mujoco_reads_it(which):
    """export_updated_model(format="mjcf") loads back to the same model (links, joints, frames, link and joint
    parameters, actuators, joint origins, limit rows, mass matrix, bias forces, collidable points as sets; the
    viscous friction comes back as MuJoCo's damper, the same torque), and MuJoCo's own M and bias forces of the text
    equal warpdyn's at random states (float64, 1e-12 of the largest entry)."""
    model = mjcf_source(which)
    text = model.export_updated_model(format="mjcf")
    back = load(text)
    assert back.link_names() == model.link_names() and back.joint_names() == model.joint_names()
    assert sorted(back.frame_names()) == sorted(model.frame_names()) and back.floating_base() == model.floating_base()
    for name in ("link_mass", "link_com", "link_inertia", *MJCF_JOINT_PARAMETERS):
        np.testing.assert_allclose(back.parameter(name).numpy(), model.parameter(name).numpy(), rtol=1e-15, atol=1e-15, err_msg=name)
    np.testing.assert_allclose(back.damping.numpy(), model.damping.numpy() + model.friction_viscous.numpy(), rtol=1e-15, atol=0)
    assert back.actuator_names() == model.actuator_names()
    for name in ("actuator_gear", "actuator_gain", "actuator_bias", "actuator_ctrl_range", "actuator_force_range") if model.actuator_names() else ():
        np.testing.assert_allclose(back.parameter(name).numpy(), model.parameter(name).numpy(), rtol=1e-15, atol=0, err_msg=name)
    np.testing.assert_allclose(wd.model.joint_origins(back)[0], wd.model.joint_origins(model)[0], rtol=0, atol=1e-15)
    assert [row.name for row in back.tree.limits] == [row.name for row in model.tree.limits]
    for ours, theirs in zip(model.tree.limits, back.tree.limits):  # MuJoCo's limit rows: a URDF's defaults, a ball's angle
        assert (theirs.margin, theirs.angle) == (ours.margin, ours.angle), ours.name  # (invweights: the scaled links' own)
        np.testing.assert_array_equal(theirs.solref, ours.solref)
        np.testing.assert_array_equal(theirs.solimp, ours.solimp)
    data = wd.data.random_model_data(model, key=4, num_envs=3)
    for quantity in (wd.model.free_floating_mass_matrix, wd.model.free_floating_bias_forces):
        ours, theirs = quantity(model, data).numpy(), quantity(back, data).numpy()
        np.testing.assert_allclose(theirs, ours, rtol=0, atol=1e-12 * np.abs(ours).max(), err_msg=quantity.__name__)
    points = [np.sort(wd.contact.collidable_point_positions(m, data).numpy().reshape(-1, 3), axis=0) for m in (model, back)]
    np.testing.assert_allclose(points[1], points[0], rtol=0, atol=1e-13)
    if model.floating_base() or any(int(kind) == JOINT_FREE for kind in model.tree.joint_type):
        return  # MuJoCo's free joints' velocities are other coordinates: the round trip above holds the dynamics
    mj = mujoco.MjModel.from_xml_string(text)
    d = mujoco.MjData(mj)
    s, sd = data.joint_positions.numpy(), data.joint_velocities.numpy()
    M, h = wd.model.free_floating_mass_matrix(model, data).numpy(), wd.model.free_floating_bias_forces(model, data).numpy()
    for env in range(3):
        d.qpos[:], d.qvel[:] = s[env], sd[env]
        mujoco.mj_forward(mj, d)
        np.testing.assert_allclose(full_mass_matrix(mj, d), M[env, 6:, 6:], rtol=0, atol=1e-12 * np.abs(M).max())
        np.testing.assert_allclose(d.qfrc_bias, h[env, 6:], rtol=0, atol=1e-12 * np.abs(h).max())


def test_what_the_mjcf_export_cannot_hold_is_refused():
    model = mjcf_source("random tree")
    with pytest.raises(ValueError, match="format must be 'urdf' or 'mjcf', got 'sdf'"):
        model.export_updated_model(format="sdf")
    model.set_gravity(np.tile([0.0, 0.0, -9.81], (2, 1)))
    with pytest.raises(ValueError, match=r"\['world_gravity'\] are given per environment; a MJCF file holds one model"):
        model.export_updated_model(format="mjcf")


def test_a_scene_exports_its_free_bodies_static_geoms_pairs_and_excludes():
    """tests/test_geom_contacts.py's scene (four free bodies of the world, a shelf welded to it, a floor, an <exclude>,
    an explicit <pair>, bit masks, priority, margins) exported as MJCF loads back with the same geom pairs and their
    parameters (by geom names), the same static geoms and terrain, and the same mass matrix and bias forces; MuJoCo
    reads the text's bodies with the original's masses and inertias, its <pair> and <exclude>."""
    model = load(SCENE)
    text = model.export_updated_model(format="mjcf")
    back = load(text)
    assert back.joint_names() == model.joint_names() and back.link_names() == model.link_names()

    def pairs(m):
        name = {shape.geom: shape.name for shape in (*m.description.world_geoms, *(s for link in m.description.links for s in link.collisions))}
        return sorted((*sorted((name[p.geom1], name[p.geom2])), round(p.margin, 12), round(p.gap, 12), p.friction, p.condim) for p in m.description.geom_pairs)

    assert pairs(back) == pairs(model) and len(pairs(model)) == 38
    assert [shape.name for shape in back.description.world_geoms] == [shape.name for shape in model.description.world_geoms] == ["shelf_box"]
    assert back.terrain == model.terrain
    data = wd.data.random_model_data(model, key=5, num_envs=2)
    for quantity in (wd.model.free_floating_mass_matrix, wd.model.free_floating_bias_forces):  # the joints' (the world's mass moves nothing)
        ours = quantity(model, data).numpy()[:, 6:]
        theirs = quantity(back, data).numpy()[:, 6:]
        np.testing.assert_allclose(theirs[..., 6:] if theirs.ndim == 3 else theirs, ours[..., 6:] if ours.ndim == 3 else ours, rtol=0,
                                   atol=1e-12 * np.abs(ours).max(), err_msg=quantity.__name__)
    original, exported = mujoco.MjModel.from_xml_string(SCENE), mujoco.MjModel.from_xml_string(text)
    for body in ("arm", "hand", "crate", "ball", "pin"):
        ours, theirs = (m.body(body) for m in (original, exported))
        np.testing.assert_allclose(theirs.mass, ours.mass, rtol=1e-12, err_msg=body)
        np.testing.assert_allclose(np.sort(theirs.inertia), np.sort(ours.inertia), rtol=1e-12, err_msg=body)
    lumped = original.body("forearm").mass + original.body("wrist_plate").mass  # welded: one link, its frame massless
    np.testing.assert_allclose(exported.body("forearm").mass + exported.body("wrist_plate").mass, lumped, rtol=1e-12)
    assert exported.body("wrist_plate").mass == 0.0
    assert exported.npair == original.npair == 1 and exported.nexclude == original.nexclude == 1


def test_massless_moving_links_and_per_dof_values_in_the_mjcf():
    """A massless link between two hinges (MuJoCo refuses massless moving bodies) is written with MuJoCo's boundmass and
    named in a warning, and MuJoCo loads the text; a ball joint whose three DoFs have different armatures is refused
    (an MJCF joint has one)."""
    text = """<robot name="chain"><link name="base"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <link name="mid"/>
      <link name="tip"><inertial><origin xyz="0 0 -0.2"/><mass value="0.5"/><inertia ixx="0.002" iyy="0.002" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
      <joint name="a" type="revolute"><parent link="base"/><child link="mid"/><axis xyz="0 1 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
      <joint name="b" type="revolute"><parent link="mid"/><child link="tip"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
    </robot>"""
    model = load(text).replace(integrator=wd.model.IntegratorType.SemiImplicitEulerSO3)
    assert "mid" in model.link_names()
    with pytest.warns(wd.description.NotModelledWarning, match=r"the massless moving links \['mid'\] get MuJoCo's boundmass"):
        exported = model.export_updated_model(format="mjcf")
    assert mujoco.MjModel.from_xml_string(exported).nv == 8
    ball = load(BALL)
    armature = ball.armature.numpy().copy()
    armature[:3] = (0.01, 0.02, 0.03)
    ball.set_joint_parameters(armature=armature)
    with pytest.raises(ValueError, match=r"joint 'ball' has armature \[0.01, 0.02, 0.03\] on its DoFs"):
        ball.export_updated_model(format="mjcf")


@pytest.mark.parametrize("which", ["FOUR_BAR", "SLIDER_CRANK", "WELDS", "TENDONS", "COUPLED_BALL", "cassie"])
def test_the_mjcf_export_writes_the_equality_constraints(which):
    """The MJCF export writes the equality constraints (connects and welds between sites, on the description's own
    bodies where written, lumped frames included; joint couplings; fixed-tendon couplings): the reloaded model has the
    same constraints (kinds, links, anchors and frames to 1e-12, solref and solimp exactly, MuJoCo's invweights of
    the written model to 1e-9 relative) and its step equals the original's to 1e-12 (float64); MuJoCo reads the text,
    and without free joints its constrained qacc equals that of the original MJCF (1e-9 of the largest). Cassie's
    joints start at MuJoCo's `ref` (qpos0), which the export writes."""
    import test_equality as te

    text = (ROOT / "models" / "menagerie" / "cassie.xml").read_text() if which == "cassie" else getattr(te, which)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(text, dtype=np.float64)
        exported = model.export_updated_model(format="mjcf")
        back = wd.model.Model.build_from_model_description(exported, dtype=np.float64)
    assert len(back.tree.equalities) == len(model.tree.equalities) > 0
    for a, b in zip(model.tree.equalities, back.tree.equalities):
        assert (b.name, b.kind, b.link1, b.link2, b.terms1, b.terms2) == (a.name, a.kind, a.link1, a.link2, a.terms1, a.terms2)
        for field in ("p1", "p2", "polycoef", "ref1", "ref2"):
            np.testing.assert_allclose(getattr(b, field), getattr(a, field), rtol=0, atol=1e-12, err_msg=field)
        for field in ("Q1", "Q2"):  # unit quaternions: q and -q are one rotation
            assert min(np.abs(getattr(b, field) - s * getattr(a, field)).max() for s in (1.0, -1.0)) <= 1e-12, field
        assert np.array_equal(b.solref, a.solref) and np.array_equal(b.solimp, a.solimp)
        for field in ("invweight", "invweight_rotation"):
            assert getattr(b, field) == pytest.approx(getattr(a, field), rel=1e-9, abs=1e-12), field
    data = wd.data.Data.build(model, joint_velocities=np.linspace(-0.4, 0.5, model.dofs()))
    stepped = [wd.model.step(m, data).joint_velocities.numpy() for m in (model, back)]
    np.testing.assert_allclose(stepped[1], stepped[0], rtol=0, atol=1e-12 * max(1.0, np.abs(stepped[0]).max()))
    mj = mujoco.MjModel.from_xml_string(exported)
    assert mj.neq == len(model.tree.equalities)
    if model.floating_base() or any(int(kind) == JOINT_FREE for kind in model.tree.joint_type):
        return  # MuJoCo's free joints' velocities are other coordinates (and their dofs' order the text's): the round trip above holds the dynamics
    accelerations = []
    for xml in (text, exported):  # each text's DoFs by joint name (the export writes the joints in the tree's order)
        mj = mujoco.MjModel.from_xml_string(xml)
        mj.opt.disableflags |= te.UNMODELLED
        d = mujoco.MjData(mj)
        dofs = {mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_JOINT, j): np.flatnonzero(mj.dof_jntid == j) for j in range(mj.njnt)}
        order = np.concatenate([dofs[name] for name in sorted(dofs)])
        d.qvel[order] = np.linspace(-0.4, 0.5, mj.nv)
        mujoco.mj_forward(mj, d)
        accelerations.append(d.qacc[order].copy())
    np.testing.assert_allclose(accelerations[1], accelerations[0], rtol=0, atol=1e-9 * np.abs(accelerations[0]).max())


def test_the_export_names_the_constraints_it_leaves_out():
    """A URDF holds no equality constraints, and neither format JaxSim's kinematic constraints (Baumgarte welds):
    each export that leaves some out says so, naming them."""
    import test_equality as te

    four_bar = wd.model.Model.build_from_model_description(te.FOUR_BAR, dtype=np.float64)
    with pytest.warns(wd.model.NotModelledWarning, match=r"the URDF does not hold the model's equality constraints \['loop'\]"):
        four_bar.export_updated_model()
    welded = wd.model.Model.build_from_model_description((ROOT / "jaxsim" / "four_bar.sdf").read_text(), dtype=np.float64)
    welded.constraints = wd.kin_dyn_parameters.ConstraintMap().add_constraint(
        welded, *(wd.frame.name_to_idx(welded, frame_name=f) for f in ("m1", "m2")), wd.kin_dyn_parameters.ConstraintType.Weld)
    for format in ("urdf", "mjcf"):
        with pytest.warns(wd.model.NotModelledWarning, match=rf"the {format.upper()} does not hold the model's JaxSim's kinematic constraints \(ConstraintMap welds \['m1 - m2'\]"):
            welded.export_updated_model(format=format)


def test_the_mjcf_export_keeps_refsafe_disabled():
    """A description that disables MuJoCo's refsafe (the constraints' time constant not raised to 2 dt) is written with
    the flag off, and loads back with it."""
    import test_equality as te

    xml = te.FOUR_BAR.replace('<option timestep="0.001" gravity="0 0 -9.81"/>', '<option timestep="0.001" gravity="0 0 -9.81"><flag refsafe="disable"/></option>')
    model = wd.model.Model.build_from_model_description(xml, dtype=np.float64)
    assert "refsafe" in model.description.disabled
    back = wd.model.Model.build_from_model_description(model.export_updated_model(format="mjcf"), dtype=np.float64)
    assert "refsafe" in back.description.disabled


LUMPED_MASS = """
<mujoco model="lumped">
  <option><flag eulerdamp="disable"/></option>
  <default><geom contype="0" conaffinity="0" type="capsule" size="0.01"/></default>
  <worldbody>
    <body name="a"><joint name="ja" axis="0 1 0" ref="0.3"/><geom fromto="0 0 0 0.2 0 0" mass="0.2"/>
      <body name="tip" pos="0.2 0 0"><geom type="sphere" size="0.02" mass="1"/></body>
    </body>
    <body name="b" pos="0.3 0 0"><joint name="jb" type="slide" axis="0 0 1" ref="0.1"/><geom type="sphere" size="0.02" mass="0.5"/></body>
  </worldbody>
  <equality><connect name="equality1" body1="tip" body2="b" anchor="0 0 0"/><connect body1="a" body2="b" anchor="0.1 0 0"/></equality>
</mujoco>
"""


def test_the_mjcf_export_names_what_moves_the_constraints_and_keeps_names_and_flags_apart():
    """A connect on a link holding a lumped body with mass: MuJoCo's invweights of the written (lumped) link differ, named
    in a NotModelledWarning; an explicit equality name equal to the loader's name of an unnamed one is written apart
    (suffixed), each constraint on its own bodies; the description's disable flags (eulerdamp here) are written; a
    URDF names the joints' start positions (MuJoCo's ref) it cannot hold."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        model = wd.model.Model.build_from_model_description(LUMPED_MASS, dtype=np.float64)
    assert [e.name for e in model.tree.equalities] == ["equality1", "equality1"] and "eulerdamp" in model.description.disabled
    with pytest.warns(wd.model.NotModelledWarning, match=r"constraints \['equality1', 'equality1'\] are on links that hold lumped bodies with mass"):
        text = model.export_updated_model(format="mjcf")
    mj = mujoco.MjModel.from_xml_string(text)
    assert [mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_EQUALITY, i) for i in range(mj.neq)] == ["equality1", "equality1_1"]
    assert mj.opt.disableflags & int(mujoco.mjtDisableBit.mjDSBL_EULERDAMP)
    bodies = [mujoco.mj_id2name(mj, mujoco.mjtObj.mjOBJ_BODY, int(mj.site_bodyid[mj.eq_obj1id[i]])) for i in range(mj.neq)]
    assert bodies == ["tip", "a"]
    np.testing.assert_allclose(mj.qpos0, mujoco.MjModel.from_xml_string(LUMPED_MASS).qpos0, rtol=0, atol=1e-15)  # ja's ref in degrees there
    with pytest.warns(wd.model.NotModelledWarning, match=r"joints' start positions \(MuJoCo's ref, qpos0\) of \['ja', 'jb'\]"):
        model.export_updated_model()


def test_the_mjcf_export_writes_the_integrator():
    """RungeKutta4 is written as MuJoCo's RK4, SemiImplicitEulerSO3 as the description's Euler, implicit or implicitfast
    with eulerdamp disabled unless the damping is implicit: each loads back with the same integrator and damping;
    JaxSim's SemiImplicitEuler on a floating base has no MuJoCo counterpart, named in a NotModelledWarning."""
    import test_equality as te

    implicit = te.FOUR_BAR.replace('<option timestep="0.001"', '<option integrator="implicitfast" timestep="0.001"')
    for xml, integrator, damping in ((te.FOUR_BAR, wd.model.IntegratorType.RungeKutta4, False), (te.FOUR_BAR, wd.model.IntegratorType.SemiImplicitEulerSO3, False),
                                     (implicit, wd.model.IntegratorType.SemiImplicitEulerSO3, True)):  # fmt: skip
        model = wd.model.Model.build_from_model_description(xml, dtype=np.float64).replace(integrator=integrator, implicit_damping=damping)
        text = model.export_updated_model(format="mjcf")
        back = wd.model.Model.build_from_model_description(text, dtype=np.float64)
        assert (back.integrator, back.implicit_damping) == (integrator, damping)
        euler = mujoco.mjtIntegrator.mjINT_IMPLICITFAST if xml is implicit else mujoco.mjtIntegrator.mjINT_EULER
        expected = mujoco.mjtIntegrator.mjINT_RK4 if integrator == wd.model.IntegratorType.RungeKutta4 else euler
        assert mujoco.MjModel.from_xml_string(text).opt.integrator == expected
    free = wd.model.Model.build_from_model_description(te.WELDED_BOX, dtype=np.float64).replace(integrator=wd.model.IntegratorType.SemiImplicitEuler)
    with pytest.warns(wd.model.NotModelledWarning, match="IntegratorType.SemiImplicitEuler has no MuJoCo counterpart"):
        free.export_updated_model(format="mjcf")


def test_ellipsoids_export_to_mjcf_and_are_refused_by_urdf():
    """tests/test_geom_contacts.py's EGGS (two free ellipsoids among free bodies over a table): the MJCF export loads back
    with the same shapes (kinds, radii) and geom pairs; URDF has no ellipsoid, and says so, naming the link."""
    from test_geom_contacts import EGGS

    model = load(EGGS)
    back = load(model.export_updated_model(format="mjcf"))

    def shapes(m):
        return sorted((s.name, s.kind, tuple(np.round(s.size, 12)) if s.kind == "ellipsoid" else ()) for link in m.description.links for s in link.collisions)

    assert shapes(back) == shapes(model) and ("egg", "ellipsoid", (0.06, 0.04, 0.03)) in shapes(model)
    assert sorted(wd.contact.geom_pairs(back).names) == sorted(wd.contact.geom_pairs(model).names)
    with pytest.raises(ValueError, match=r"link 'egg' has a collision URDF cannot hold \(ellipsoid"):
        model.export_updated_model()
