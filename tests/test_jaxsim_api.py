"""JaxSim's API in JaxSim's call form, renamed (`js.` as `wd.`): the names of docs/porting.md that
tests/test_jaxsim_parity.py does not compare with JaxSim's stored numbers (queries, constructors, data
handling, the host helpers' identities, the documented differences). Each test's reference is in its
docstring: warpdyn's own functions that the parity test checked against JaxSim, exact identities, or the
definitions JaxSim documents.
"""

from __future__ import annotations

import pathlib
import warnings

import mujoco
import numpy as np
import pytest

import warpdyn as wd
from warpdyn import VelRepr

ROOT = pathlib.Path(__file__).resolve().parents[1]
ARM = (ROOT / "tests" / "jaxsim" / "arm.sdf").read_text()
HOPPER = (ROOT / "tests" / "jaxsim" / "hopper.sdf").read_text()


def _build(text: str, **kwargs) -> wd.model.JaxSimModel:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", wd.model.NotModelledWarning)
        return wd.model.JaxSimModel.build_from_model_description(text, dtype=np.float64, **kwargs)


def test_integrator_types():
    """IntegratorType has JaxSim's three members with JaxSim's values (enum.auto: 1, 2, 3), and MuJoCo's Euler."""
    I = wd.model.IntegratorType
    assert (I.SemiImplicitEuler, I.RungeKutta4, I.RungeKutta4Fast) == (1, 2, 3) and I.SemiImplicitEulerSO3 == 4


def test_model_queries():
    """The model's queries on the hopper SDF (reference: the file: 5 links, 4 joints, 2 frames, floating)."""
    model = _build(HOPPER)
    assert isinstance(model, wd.model.Model) and wd.model.JaxSimModel is wd.model.Model
    assert (model.name(), model.number_of_links(), model.number_of_joints(), model.number_of_frames(), model.dofs()) == ("hopper", 5, 4, 2, 4)
    assert model.floating_base() and model.base_link() == "torso"
    assert model.link_names() == ("torso", "l_thigh", "r_thigh", "l_shank", "r_shank")
    assert model.joint_names() == ("l_hip", "r_hip", "l_knee", "r_knee") and model.frame_names() == ("l_foot", "r_foot")
    assert isinstance(model.description, wd.description.ModelDescription) and model.built_from == HOPPER
    assert model.gravity == -wd.math.STANDARD_GRAVITY


def test_model_build_keywords():
    """build_from_model_description's JaxSim keywords set the settings; Model.build from a parsed description
    equals it; parametrized_links is kept, constraints that are not a ConstraintMap are refused (an
    empty one is JaxSim's default: tests/test_kinematic_constraints.py sets real ones)."""
    terrain = wd.terrain.FlatTerrain.build(height=0.1)
    params = wd.rbda.contacts.SoftContactsParams.build(K=5e4, D=500.0)
    model = _build(
        HOPPER, time_step=0.002, terrain=terrain, contact_model=wd.rbda.contacts.SoftContacts.build(), contact_params=params,
        actuation_params=wd.model.ActuationParams(torque_max=50.0), integrator=wd.model.IntegratorType.RungeKutta4, gravity=3.0,
    )  # fmt: skip
    assert (model.time_step, model.terrain, model.contact_params, model.gravity) == (0.002, terrain, params, -3.0)
    assert model.actuation_params.torque_max == 50.0 and model.integrator == wd.model.IntegratorType.RungeKutta4
    built = wd.model.JaxSimModel.build(wd.description.load(HOPPER), time_step=0.002, dtype=np.float64)
    assert built == model and hash(built) == hash(model)
    assert _build(HOPPER, parametrized_links=("l_shank",)).parametrized_links == ("l_shank",)  # tests/test_hardware.py scales with it
    with pytest.raises(TypeError, match="constraints must be a wd.kin_dyn_parameters.ConstraintMap or None, got tuple"):
        _build(HOPPER, constraints=())
    assert len(_build(HOPPER, constraints=wd.kin_dyn_parameters.ConstraintMap()).constraints) == 0


def test_reduce():
    """reduce keeps the considered joints, locks the others at locked_joint_positions, ignores the kept ones'
    (JaxSim's), carries the settings; its kinematics equal the full model's at the locked positions (the
    legs' FK of the full hopper with the knees at -0.5)."""
    full = _build(HOPPER, time_step=0.004)
    full.terrain = wd.terrain.FlatTerrain.build(height=0.02)
    reduced = wd.model.reduce(model=full, considered_joints=["l_hip", "r_hip"], locked_joint_positions={"l_knee": -0.5, "r_knee": -0.5, "l_hip": 9.0})
    assert reduced.joint_names() == ("l_hip", "r_hip") and (reduced.time_step, reduced.terrain) == (0.004, full.terrain)
    data_full = wd.data.JaxSimModelData.build(model=full, joint_positions=[0.2, -0.1, -0.5, -0.5])
    data = wd.data.JaxSimModelData.build(model=reduced, joint_positions=[0.2, -0.1])
    foot = wd.frame.transform(model=reduced, data=data, frame_index=wd.frame.name_to_idx(model=reduced, frame_name="l_foot"))
    expected = wd.frame.transform(model=full, data=data_full, frame_index=wd.frame.name_to_idx(model=full, frame_name="l_foot"))
    np.testing.assert_allclose(foot.numpy(), expected.numpy(), atol=1e-14)
    with pytest.raises(ValueError, match="phantom"):
        wd.model.reduce(model=full, considered_joints=["l_hip"], locked_joint_positions={"phantom": 0.0})


def test_link_order_with_lumping_in_mid_tree():
    """Links and joints in JaxSim's order when a fixed joint lumps a link that carries a jointed child, and after
    a reduction that lumps such links (reference: JaxSim 0.9.0 on tests/jaxsim/lumped.sdf: links (base, B, C, Z,
    D), joints (j_b, j_c, j_z, j_d), frames (A,); reduced to j_c and j_d: links (base, C, D), frames (A, B, Z)).
    JaxSim walks the reduced graph breadth-first, each link's children by name; C, the child of the lumped A,
    is a child of the base there."""
    model = _build((ROOT / "tests" / "jaxsim" / "lumped.sdf").read_text())
    assert (model.link_names(), model.joint_names(), model.frame_names()) == (("base", "B", "C", "Z", "D"), ("j_b", "j_c", "j_z", "j_d"), ("A",))
    reduced = wd.model.reduce(model=model, considered_joints=["j_c", "j_d"])
    assert (reduced.link_names(), reduced.joint_names(), reduced.frame_names()) == (("base", "C", "D"), ("j_c", "j_d"), ("A", "B", "Z"))


def test_model_replace_editable_equality():
    """JaxSim's dataclass methods: replace and editable give changed copies (the original unchanged),
    mutable_context edits in place and restores on an error; models are equal (and hash alike) when name,
    time step and structure are, whatever their parameters' values (JaxSim's definition)."""
    model = _build(ARM)
    other = model.replace(time_step=0.01, terrain=wd.terrain.FlatTerrain.build(height=-1.0))
    assert (other.time_step, model.time_step) == (0.01, 0.001) and other != model
    with model.editable(validate=False) as edited:
        edited.time_step = 0.02
    assert (edited.time_step, model.time_step) == (0.02, 0.001)
    with pytest.raises(ZeroDivisionError), model.mutable_context() as same:
        same.time_step = 0.5
        1 / 0  # noqa: B018
    assert model.time_step == 0.001
    heavier = model.copy()
    heavier.set_link_parameters(mass=2.0 * model.link_mass.numpy())
    assert heavier == model and hash(heavier) == hash(model) and model != _build(HOPPER)
    with pytest.raises(TypeError, match="unknown model fields"):
        model.replace(no_such_field=1)


def test_data_build_and_properties():
    """JaxSimModelData.build in JaxSim's argument order and keywords; zero; the properties are what was built
    (base velocity read back in the representation it was given in)."""
    model = _build(HOPPER)
    q = np.array([0.9, 0.1, -0.2, 0.3]) / np.linalg.norm([0.9, 0.1, -0.2, 0.3])
    data = wd.data.JaxSimModelData.build(model, [0.1, 0.2, 0.3], q, [0.1, 0.2, -0.3, -0.4], [1.0, 0.0, 0.0], [0.0, 0.5, 0.0], None, None, VelRepr.Body)
    assert wd.data.JaxSimModelData is wd.data.Data and data.velocity_representation == VelRepr.Body
    np.testing.assert_allclose(data.base_position.numpy(), [0.1, 0.2, 0.3])
    np.testing.assert_allclose(data.base_quaternion.numpy(), q)
    np.testing.assert_allclose(data.joint_positions.numpy(), [0.1, 0.2, -0.3, -0.4])
    np.testing.assert_allclose(data.base_velocity.numpy(), [1.0, 0.0, 0.0, 0.0, 0.5, 0.0], atol=1e-15)
    np.testing.assert_allclose(data.joint_velocities.numpy(), 0.0)
    zero = wd.data.JaxSimModelData.zero(model=model, velocity_representation=VelRepr.Inertial)
    assert zero.velocity_representation == VelRepr.Inertial and not zero.joint_positions.numpy().any()


def test_data_copy_and_resets():
    """copy makes its own arrays; reset_base_quaternion normalises (JaxSim's); reset_base_pose sets position and
    orientation of a (4, 4) pose."""
    model = _build(HOPPER)
    data = wd.data.random_model_data(model=model, key=3)
    copy = data.copy()
    assert copy.joint_positions_state is not data.joint_positions_state
    np.testing.assert_array_equal(copy.generalized_velocity.numpy(), data.generalized_velocity.numpy())
    turned = data.reset_base_quaternion(model=model, base_quaternion=[0.0, 0.0, 0.0, 2.0])
    np.testing.assert_allclose(turned.base_quaternion.numpy(), [0.0, 0.0, 0.0, 1.0])
    H = wd.math.Transform.from_rotation_and_translation(rotation=wd.math.Rotation.z(0.4), translation=[1.0, 2.0, 3.0])
    moved = data.reset_base_pose(model=model, base_pose=H)
    np.testing.assert_allclose(moved.base_transform.numpy(), H, atol=1e-15)
    batch = wd.data.random_model_data(model=model, key=4, num_envs=3)
    for name in ("joint_positions_state", "base_velocity_state", "tangential_deformation_state"):  # the device's layout kept
        assert getattr(batch.copy(), name).strides == getattr(batch, name).strides, name
    nc = len(model.kin_dyn_parameters.contact_parameters.body)
    m = np.arange(3 * nc * 3, dtype=np.float64).reshape(3, nc, 3) * 1e-3
    partly = batch.replace(model=model, contact_state={"tangential_deformation": m}, envs=[1])
    np.testing.assert_array_equal(partly.tangential_deformation_state.numpy()[1], m[1])
    np.testing.assert_array_equal(partly.tangential_deformation_state.numpy()[[0, 2]], batch.tangential_deformation_state.numpy()[[0, 2]])


def test_random_model_data():
    """random_model_data: JaxSim's bounds (base position, Euler angles in base_rpy_seq, velocities), joints
    within the model's limits as set; a JAX-style key (uint32 words), an integer and a Generator are keys; the
    same key draws the same data."""
    model = _build(HOPPER)
    model.set_joint_parameters(position_limits=np.tile([0.1, 0.2], (4, 1)))
    data = wd.data.random_model_data(model=model, key=np.array([0, 7], dtype=np.uint32), base_pos_bounds=((0, 0, 1), (0.1, 0.1, 2)), base_rpy_seq="zyx")
    s = data.joint_positions.numpy()
    assert np.all((s >= 0.1) & (s <= 0.2)) and 1.0 <= data.base_position.numpy()[2] <= 2.0
    again = wd.data.random_model_data(model=model, key=np.array([0, 7], dtype=np.uint32), base_pos_bounds=((0, 0, 1), (0.1, 0.1, 2)), base_rpy_seq="zyx")
    np.testing.assert_array_equal(again.generalized_velocity.numpy(), data.generalized_velocity.numpy())
    assert wd.data.random_model_data(model=model, key=np.random.default_rng(1)).valid(model=model)
    with pytest.raises(ValueError, match="base_rpy_seq"):
        wd.data.random_model_data(model=model, base_rpy_seq="XXY")


def test_random_joint_positions():
    """JaxSim's rule: within limits; a revolute joint with a range of 2 pi or more in an interval of 2 pi inside
    it ([-pi, pi] when that fits); an unlimited prismatic joint in [-1, 1] m."""
    model = _build(ARM)
    model.set_joint_parameters(position_limits=[[-1.0, 1.0], [-10.0, -2.0], [-np.inf, np.inf], [-np.inf, np.inf]])
    draws = np.array([wd.joint.random_joint_positions(model=model, key=k) for k in range(200)])
    low, high = draws.min(axis=0), draws.max(axis=0)
    assert low[0] >= -1.0 and high[0] <= 1.0
    assert low[1] >= -2.0 - 2 * np.pi and high[1] <= -2.0  # the 2 pi below the upper limit
    assert low[2] >= -np.pi and high[2] <= np.pi and low[3] >= -1.0 and high[3] <= 1.0
    names = wd.joint.random_joint_positions(model=model, joint_names=["slide"], key=1)
    assert names.shape == (1,)
    model.set_joint_parameters(position_limits=[[-1.0, 1.0], [-1.0, 1.0], [-1.0, 1.0], [5.0, np.inf]])  # one side: 2 m above it
    one_sided = np.array([wd.joint.random_joint_positions(model=model, key=k)[3] for k in range(50)])
    assert one_sided.min() >= 5.0 and one_sided.max() <= 7.0


def test_references():
    """JaxSimModelReferences: zero, build (JaxSim's argument order), valid, joint force references by name,
    link forces in and out of representations, frame forces moved to their links (the arm's tool tip)."""
    model = _build(ARM)
    data = wd.data.JaxSimModelData.build(model=model, joint_positions=[0.3, -0.2, 0.5, 0.05], velocity_representation=VelRepr.Mixed)
    zero = wd.references.JaxSimModelReferences.zero(model=model, data=data)
    assert zero.valid(model=model) and not zero.joint_force_references(model=model).numpy().any()
    refs = wd.references.JaxSimModelReferences.build(model, [1.0, 2.0, 3.0, 4.0], None, data, VelRepr.Mixed)
    refs = refs.set_joint_force_references(forces=[9.0], model=model, joint_names=("elbow_roll",))
    np.testing.assert_array_equal(refs.joint_force_references(model=model).numpy(), [1.0, 2.0, 9.0, 4.0])
    f = np.array([[1.0, 2.0, 3.0, 0.1, 0.2, 0.3]])
    refs = refs.apply_link_forces(forces=f, model=model, data=data, link_names=("tool",), additive=False)
    np.testing.assert_allclose(refs.link_forces(model=model, data=data, link_names=("tool",)).numpy(), f, atol=1e-14)
    tip = refs.apply_frame_forces(forces=f, model=model, data=data, frame_names=("tool_tip",))
    W_H_F = wd.frame.transform(model=model, data=data, frame_index=wd.frame.name_to_idx(model=model, frame_name="tool_tip")).numpy()
    W_H_L = wd.link.transform(model=model, data=data, link_index=wd.link.name_to_idx(model=model, link_name="tool")).numpy()
    torque = f[0, 3:] + np.cross(W_H_F[:3, 3] - W_H_L[:3, 3], f[0, :3])  # Mixed: moved from the frame's origin to the link's
    np.testing.assert_allclose(tip.link_forces(model=model, data=data, link_names=("tool",)).numpy()[0], [*f[0, :3], *torque], atol=1e-13)
    assert not refs.valid(model=_build((ROOT / "tests" / "jaxsim" / "box.sdf").read_text()))  # no joints, one link


def test_representation_conversions():
    """inertial_to_other_representation and other_representation_to_inertial invert each other, and convert a
    link's Inertial velocity to its Body and Mixed ones (wd.link.velocity, checked against JaxSim by the
    parity test)."""
    model = _build(ARM)
    data = wd.data.JaxSimModelData.build(model=model, joint_positions=[0.3, -0.2, 0.5, 0.05], joint_velocities=[0.4, -0.5, 0.6, 0.1], velocity_representation=VelRepr.Inertial)
    i = wd.link.name_to_idx(model=model, link_name="tool")
    W_H_L = wd.link.transform(model=model, data=data, link_index=i).numpy()
    W_v = wd.link.velocity(model=model, data=data, link_index=i).numpy()
    conv = wd.common.ModelDataWithVelocityRepresentation
    for other in (VelRepr.Body, VelRepr.Mixed):
        expected = wd.link.velocity(model=model, data=data, link_index=i, output_vel_repr=other).numpy()
        got = conv.inertial_to_other_representation(array=W_v, other_representation=other, transform=W_H_L, is_force=False)
        np.testing.assert_allclose(got, expected, atol=1e-14)
        back = conv.other_representation_to_inertial(array=got, other_representation=other, transform=W_H_L, is_force=False)
        np.testing.assert_allclose(back, W_v, atol=1e-14)
        f = np.array([1.0, -2.0, 0.5, 0.3, 0.2, -0.1])
        O_f = conv.inertial_to_other_representation(array=f, other_representation=other, transform=W_H_L, is_force=True)
        assert abs(O_f @ got - f @ W_v) < 1e-13  # power does not depend on the representation
    assert isinstance(data, conv)


def test_index_functions():
    """name_to_idx / idx_to_name / names_to_idxs / idxs_to_names of links, frames and joints round trip;
    frame indices start at number_of_links() (JaxSim's)."""
    model = _build(HOPPER)
    for module, names, keyword in ((wd.link, model.link_names(), "link"), (wd.joint, model.joint_names(), "joint"), (wd.frame, model.frame_names(), "frame")):
        idxs = getattr(module, "names_to_idxs")(model=model, **{f"{keyword}_names": names})
        assert getattr(module, "idxs_to_names")(model=model, **{f"{keyword}_indices": idxs}) == tuple(names)
        assert getattr(module, "idx_to_name")(model=model, **{f"{keyword}_index": int(idxs[-1])}) == names[-1]
    assert wd.frame.name_to_idx(model=model, frame_name="l_foot") == model.number_of_links()


def test_contact_parameters():
    """estimate_good_contact_parameters is ContactsParams.build_default_from_jaxsim_model of the CoM height
    (JaxSim's); the deprecated estimate_good_soft_contacts_parameters warns and returns the same;
    SoftContactsParams.build refuses unknown keywords; valid() reads the values now."""
    model = _build(HOPPER)
    estimate = wd.contact.estimate_good_contact_parameters(model=model, max_penetration=0.002)
    direct = wd.rbda.contacts.SoftContactsParams.build_default_from_jaxsim_model(model=model, max_penetration=0.002)
    assert estimate == direct and isinstance(direct, wd.rbda.contacts.ContactsParams)
    m = wd.model.total_mass(model=model)
    assert np.isclose(estimate.K, min(m * 9.81 / 0.002**1.5, wd.rbda.contacts.MAX_STIFFNESS))
    with pytest.warns(DeprecationWarning):
        assert wd.contact.estimate_good_soft_contacts_parameters(model=model, max_penetration=0.002) == estimate
    with pytest.raises(TypeError, match="takes K, D, mu, p and q"):
        wd.rbda.contacts.SoftContactsParams.build(K=1.0, E=2.0)
    assert wd.rbda.contacts.SoftContactsParams.build().valid()


def test_contact_models():
    """model.contact_model is SoftContacts; its build, state variables (one row per point, enabled or not),
    state update (JaxSim's: the rate becomes the state's derivative) and impact update (none, for soft)."""
    model = _build(HOPPER)
    contact_model = model.contact_model
    assert isinstance(contact_model, wd.rbda.contacts.SoftContacts) and isinstance(contact_model, wd.rbda.contacts.ContactModel)
    assert contact_model == wd.rbda.contacts.SoftContacts.build() and contact_model._parameters_class is wd.rbda.contacts.SoftContactsParams
    state = contact_model.zero_state_variables(model=model)
    assert state["tangential_deformation"].shape == (len(model.kin_dyn_parameters.contact_parameters.body), 3)
    assert contact_model.update_contact_state({"m_dot": 7}) == {"tangential_deformation": 7}
    data = wd.data.random_model_data(model=model)
    assert contact_model.update_velocity_after_impact(model=model, data=data) is data


def test_kin_dyn_parameters():
    """KinDynParameters: counts, supports, joint transforms (equal to wd.model.joint_transforms), tree
    transforms (the inverse adjoints of lambda_H_pre), set_link_inertia applied by replace, the joint model's
    methods, the frames, JointParameters of a description's joint."""
    model = _build(ARM)
    kd = model.kin_dyn_parameters
    assert (kd.number_of_links(), kd.number_of_joints(), kd.number_of_frames()) == (5, 4, 2)
    assert kd.support_body_array(link_index=4).tolist() == [0, 1, 2, 3, 4]
    assert kd.contact_parameters.indices_of_enabled_collidable_points.tolist() == list(range(len(kd.contact_parameters.body)))
    s, H = np.array([0.3, -0.2, 0.5, 0.05]), np.eye(4)
    np.testing.assert_allclose(kd.joint_transforms(joint_positions=s, base_transform=H), wd.model.joint_transforms(model=model, joint_positions=s, base_transform=H).numpy(), atol=1e-14)
    jm = kd.joint_model
    np.testing.assert_allclose(kd.tree_transforms()[1:], wd.math.Adjoint.from_transform(transform=jm.parent_H_predecessor(joint_index=np.arange(1, 5)), inverse=True), atol=1e-14)
    np.testing.assert_array_equal(jm.successor_H_child(joint_index=2), np.eye(4))
    assert kd.frame_parameters.name == model.frame_names()
    inertia = np.diag([0.1, 0.2, 0.3])
    heavier = model.replace(kin_dyn_parameters=kd.set_link_inertia(link_index=2, inertia=inertia))
    np.testing.assert_array_equal(heavier.kin_dyn_parameters.link_parameters.inertia_elements[2], [0.1, 0.0, 0.0, 0.2, 0.0, 0.3])
    assert isinstance(kd, wd.kin_dyn_parameters.KinDynParameters) and wd.kin_dyn_parameters.KinDynParameters.build(model) == kd
    model.link_mass.assign(np.array([3.0, 1.5, 7.0, 0.5, 0.2]))  # an edit in place: the next snapshot sees it
    assert model.kin_dyn_parameters.link_parameters.mass[2] == 7.0
    lighter = model.replace(kin_dyn_parameters=model.kin_dyn_parameters.set_link_mass(link_index=1, mass=1.0))
    np.testing.assert_array_equal(lighter.link_mass.numpy(), [3.0, 1.0, 7.0, 0.5, 0.2])  # the edit kept, link 1 set
    single = wd.model.JaxSimModel.build_from_model_description(ARM, dtype=np.float32)
    single = single.replace(kin_dyn_parameters=model.kin_dyn_parameters)  # a float64 model's: its points in float32
    points = wd.contact.collidable_point_positions(model=single, data=wd.data.JaxSimModelData.build(model=single))
    assert points.numpy().dtype == np.float32
    joint = wd.description.load(ARM).joints[1]
    params = wd.kin_dyn_parameters.JointParameters.build_from_joint_description(joint_description=joint, index=1)
    assert (float(params.friction_static), float(params.friction_viscous)) == (joint.friction, joint.damping)
    assert wd.math.JointModel.build(model).joint_names[1:] == model.joint_names()


def test_link_parameters():
    """LinkParameters' static functions invert each other and give the spatial inertia of Inertia.to_sixd."""
    LP = wd.kin_dyn_parameters.LinkParameters
    c, inertia = np.array([0.01, -0.02, 0.03]), np.array([[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.25]])
    params = LP.build_from_inertial_parameters(index=3, m=2.5, I=inertia, c=c)
    M = LP.spatial_inertia(params)
    np.testing.assert_allclose(M, wd.math.Inertia.to_sixd(mass=2.5, com=c, I=inertia), atol=1e-15)
    back = LP.build_from_spatial_inertia(index=3, M=M)
    np.testing.assert_allclose(LP.flat_parameters(back), LP.flat_parameters(params), atol=1e-14)
    again = LP.build_from_flat_parameters(index=3, parameters=LP.flat_parameters(params))
    np.testing.assert_allclose(LP.inertia_tensor(again), inertia, atol=1e-15)
    np.testing.assert_array_equal(LP.unflatten_inertia_tensor(LP.flatten_inertia_tensor(inertia)), inertia)


def test_rk4fast():
    """rk4fast_integration holds the first stage's contact forces: it equals an RK4 step of the model without
    collidable points under those forces as Inertial link forces (the hopper, feet in the ground), and its
    deformation advances by dt m_dot. Without contacts it equals RK4 exactly. Tolerance: rounding (1e-13)."""
    model = _build(HOPPER)
    data = wd.data.JaxSimModelData.build(model=model, base_position=[0.0, 0.0, 0.535], joint_positions=[0.3, 0.25, -0.6, -0.55], base_linear_velocity=[0.1, 0.0, -0.2], velocity_representation=VelRepr.Inertial)
    tau = np.array([1.0, -1.0, 0.5, 0.2])
    W_f_C, aux = wd.contact.link_contact_forces(model=model, data=data)
    assert np.abs(W_f_C.numpy()).max() > 1.0, "the feet must touch the ground"
    fast = wd.integrators.rk4fast_integration(model=model, data=data, link_forces=None, joint_torques=tau)
    free = wd.contact.with_collidable_points(model, enabled=np.zeros(len(model.kin_dyn_parameters.contact_parameters.body), dtype=bool))
    held = wd.integrators.rk4_integration(model=free, data=data, link_forces=W_f_C, joint_torques=tau)
    for name in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities"):
        np.testing.assert_allclose(getattr(fast, name).numpy(), getattr(held, name).numpy(), atol=1e-13, err_msg=name)
    m_next = data.contact_state["tangential_deformation"].numpy() + model.time_step * aux["m_dot"].numpy()
    np.testing.assert_allclose(fast.contact_state["tangential_deformation"].numpy(), m_next, atol=1e-15)
    plain = wd.integrators.rk4_integration(model=free, data=data, link_forces=None, joint_torques=tau)
    same = wd.integrators.rk4fast_integration(model=free, data=data, link_forces=None, joint_torques=tau)
    np.testing.assert_array_equal(same.joint_velocities.numpy(), plain.joint_velocities.numpy())


def test_terrains():
    """Terrain's height and normal: the base class's normal by central differences equals the plane's exact
    one; a heightfield of a plane is that plane; terrains are immutable and compare by value."""
    plane = wd.terrain.PlaneTerrain.build(height=0.1, normal=[0.2, -0.1, 1.0])
    assert isinstance(plane, wd.terrain.Terrain)
    xs, ys = np.linspace(-1, 1, 5), np.linspace(-0.5, 0.5, 5)
    np.testing.assert_allclose(wd.terrain.Terrain.normal(plane, xs, ys), plane.normal(xs, ys), atol=1e-12)
    grid_x, grid_y = np.meshgrid(np.arange(11) * 0.2 - 1.0, np.arange(11) * 0.2 - 1.0, indexing="ij")
    field = wd.terrain.HeightfieldTerrain(plane.height(grid_x, grid_y), origin=(-1.0, -1.0), spacing=(0.2, 0.2))
    np.testing.assert_allclose(field.height(xs, ys), plane.height(xs, ys), atol=1e-12)
    np.testing.assert_allclose(field.normal(xs, ys), plane.normal(xs, ys), atol=1e-12)
    assert plane == wd.terrain.PlaneTerrain(normal=[0.2, -0.1, 1.0], point=[0.0, 0.0, 0.1]) and hash(plane) == hash(wd.terrain.PlaneTerrain.build(height=0.1, normal=[0.2, -0.1, 1.0]))
    with pytest.raises(AttributeError, match="immutable"):
        plane.point = (0.0, 0.0, 0.0)
    heights = np.array([0.0, 0.1])
    flat = wd.terrain.FlatTerrain.build(height=heights)  # one height per environment, a copy kept
    before = hash(flat)
    heights[0] = 5.0
    assert hash(flat) == before and flat.elevation.tolist() == [0.0, 0.1] and wd.terrain.FlatTerrain([0.0, 0.1]) == flat
    points = np.array([[[0.0, 0.0, -0.01]], [[0.0, 0.0, 0.05]]])  # environment e's points on its height
    np.testing.assert_allclose(flat.penetration(points), [[0.01], [0.05]], atol=1e-15)
    depth, _, _ = wd.rbda.contacts.compute_penetration_data(points, np.zeros_like(points), flat)
    np.testing.assert_allclose(depth, [[0.01], [0.05]], atol=1e-15)


def test_host_contact_law_per_point_parameters():
    """The host soft law takes one K, D, mu per point (broadcast against the points) and per-environment
    terrain heights (reference: the same law called point by point with scalars)."""
    law = wd.rbda.contacts.SoftContacts.hunt_crossley_contact_model
    p = np.array([[0.0, 0.0, -0.001], [1.0, 0.0, -0.002]])
    v, m = np.zeros((2, 3)), np.zeros((2, 3))
    flat = wd.terrain.FlatTerrain()
    K, D, mu = np.array([1e5, 1e3]), np.array([100.0, 10.0]), np.array([0.5, 0.8])
    f, _ = law(p, v, m, flat, K, D, mu)
    for k in range(2):
        f_k, _ = law(p[k], v[k], m[k], flat, K[k], D[k], mu[k])
        np.testing.assert_allclose(f[k], f_k, rtol=1e-15)
    assert f[0, 2] > 10 * f[1, 2]
    with pytest.raises(ValueError, match="exponent p"):
        law(p, v, m, flat, 1e5, 100.0, 0.5, p=[0.5, 0.5])


def test_log_vee_at_every_angle():
    """Rotation.log_vee inverts from_axis_angle at angles from 0 to pi, in one batch, without warnings
    (reference: the axis-angle drawn; 1e-12)."""
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    angles = np.array([0.0, 1e-9, 1e-3, 0.3, 2.0, np.pi - 1e-4, np.pi - 1e-9])
    R = np.stack([wd.math.Rotation.from_axis_angle(vector=axis * a) for a in angles])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        np.testing.assert_allclose(wd.math.Rotation.log_vee(R), angles[:, None] * axis, atol=1e-12)


def test_mesh_inertia_equals_mujocos_and_scales_by_its_moments():
    """JaxSim's mesh helpers on HwLinkMetadata: compute_mesh_inertia of an irregular closed hexahedron equals MuJoCo's
    mass, centre of mass and inertia of the same mesh geom (1e-6 relative: MuJoCo keeps a mesh's vertices in float32);
    the winding does not matter; compute_mesh_inertia_from_moments(precompute_mesh_moments, dims, density) equals the
    inertia of the mesh scaled by dims (1e-12); empty() holds no links."""
    H = wd.kin_dyn_parameters.HwLinkMetadata
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], dtype=np.float64)
    vertices = corners * [0.1, 0.2, 0.15] + np.random.default_rng(0).uniform(-0.02, 0.02, (8, 3)) + [0.05, -0.02, 0.1]
    faces = np.array([[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4], [1, 5, 7], [1, 7, 3]])
    mass, com, inertia = H.compute_mesh_inertia(vertices, faces, 800.0)
    mj = mujoco.MjModel.from_xml_string(f"""<mujoco><asset><mesh name="m" vertex="{' '.join(map(repr, vertices.ravel().tolist()))}"
        face="{' '.join(map(str, faces.ravel().tolist()))}"/></asset><worldbody><body><freejoint/><geom type="mesh" mesh="m" density="800"/></body></worldbody></mujoco>""")
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, mj.body_iquat[1])
    R = R.reshape(3, 3)
    assert mass == pytest.approx(mj.body_mass[1], rel=1e-6)
    np.testing.assert_allclose(com, mj.body_ipos[1], rtol=0, atol=1e-6 * np.abs(vertices).max())
    np.testing.assert_allclose(inertia, R @ np.diag(mj.body_inertia[1]) @ R.T, rtol=0, atol=1e-6 * np.abs(inertia).max())
    flipped = H.compute_mesh_inertia(vertices, faces[:, ::-1], 800.0)
    assert flipped[0] == pytest.approx(mass, rel=1e-14) and np.allclose(flipped[2], inertia, rtol=1e-13, atol=0)
    dims = np.array([1.3, 0.7, 1.1])
    scaled_mass, scaled_inertia = H.compute_mesh_inertia_from_moments(H.precompute_mesh_moments(vertices, faces), dims, 500.0)
    expected = H.compute_mesh_inertia(vertices * dims, faces, 500.0)
    assert scaled_mass == pytest.approx(expected[0], rel=1e-12)
    np.testing.assert_allclose(scaled_inertia, expected[2], rtol=0, atol=1e-12 * np.abs(expected[2]).max())
    assert H.empty().link_shape.shape == (0,) and H.empty().L_H_pre.shape == (0, 4, 4)
