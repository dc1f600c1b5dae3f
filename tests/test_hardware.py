"""JaxSim's hardware parametrisation (issue 38, item 1): `wd.model.update_hw_parameters` with
`wd.kin_dyn_parameters.ScalingFactors`, against JaxSim 0.9.0 on tests/jaxsim/hw_leg.sdf (a floating leg whose links
carry a box, a cylinder with turned inertial axes, a box and a sphere; tests/jaxsim/hardware.npz from
tests/jaxsim/generate_hardware.py), float64:
- the links' masses, centres of mass and inertias and the joints' origins after scaling equal JaxSim's (1e-13);
- jax.grad of sum(W * M(q)) with respect to the dims and density factors, through update_hw_parameters, equals the
  tape's gradient through warpdyn's (1e-10 of its size);
- unit factors give back the description's masses; gradients through a rollout equal central differences.
"""

import pathlib

import mujoco
import numpy as np
import pytest
import warp as wp

import warpdyn as wd
from gradcheck import weighted_sum

ROOT = pathlib.Path(__file__).resolve().parent
REFERENCE = np.load(ROOT / "jaxsim" / "hardware.npz")


def load(text: str, dtype=np.float64):
    return wd.model.Model.build_from_model_description(text, dtype=dtype)


def leg(dtype=np.float64):
    return wd.model.Model.build_from_model_description((ROOT / "jaxsim" / "hw_leg.sdf").read_text(), dtype=dtype)


def test_metadata_and_unit_factors_keep_the_masses():
    """Every link of the leg is parametrised (box, cylinder, box, sphere); unit factors keep each mass, put the
    centre of mass where the inertial frame is and the shape's inertia in its axes, and move no joint."""
    model = leg()
    metadata = wd.kin_dyn_parameters.hw_link_metadata(model)
    shapes = wd.kin_dyn_parameters.LinkParametrizableShape
    assert metadata.link_shape.tolist() == [shapes.Box, shapes.Cylinder, shapes.Box, shapes.Sphere]
    nL = model.number_of_links()
    unit = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((nL, 3)), density=np.ones(nL)))
    np.testing.assert_allclose(unit.link_mass.numpy(), model.link_mass.numpy(), rtol=1e-14)
    np.testing.assert_allclose(unit.link_com.numpy(), model.link_com.numpy(), rtol=0, atol=1e-15)
    np.testing.assert_allclose(wd.model.joint_origins(unit)[0], wd.model.joint_origins(model)[0], rtol=0, atol=1e-15)
    box = model.link_mass.numpy()[0] / 12.0 * np.diag([0.25**2 + 0.1**2, 0.3**2 + 0.1**2, 0.3**2 + 0.25**2])
    np.testing.assert_allclose(unit.link_inertia.numpy()[0], box, rtol=1e-14)


def test_scaled_links_equal_jaxsims():
    """The reference's factors: masses, centres of mass, inertias (link axes), joint origins and the collidable points
    (the foot sphere's 50, moved up to 1 cm) equal JaxSim's; a step reads the moved points."""
    model = leg()
    assert tuple(REFERENCE["link_names"]) == model.link_names() and tuple(REFERENCE["joint_names"]) == model.joint_names()
    factors = wd.kin_dyn_parameters.ScalingFactors(dims=REFERENCE["dims"], density=REFERENCE["density"])
    updated = wd.model.update_hw_parameters(model, factors)
    np.testing.assert_allclose(updated.link_mass.numpy(), REFERENCE["mass"], rtol=1e-13)
    np.testing.assert_allclose(updated.link_com.numpy(), REFERENCE["com"], rtol=0, atol=1e-14)
    np.testing.assert_allclose(updated.link_inertia.numpy(), REFERENCE["inertia"], rtol=0, atol=1e-14)
    positions, rotations = wd.model.joint_origins(updated)
    np.testing.assert_allclose(positions, REFERENCE["L_H_pre"][:, :3, 3], rtol=0, atol=1e-14)
    np.testing.assert_allclose(wd.math.Quaternion.to_dcm(rotations), REFERENCE["L_H_pre"][:, :3, :3], rtol=0, atol=1e-14)
    assert np.abs(positions - wd.model.joint_origins(model)[0]).max() > 0.01  # the scaling moved the joints
    np.testing.assert_allclose(model.kin_dyn_parameters.contact_parameters.point, REFERENCE["points_before"], rtol=0, atol=1e-15)
    np.testing.assert_allclose(updated.kin_dyn_parameters.contact_parameters.point, REFERENCE["points"], rtol=0, atol=1e-14)
    data = wd.data.Data.build(updated)
    W_H_L = wd.model.forward_kinematics(updated, data).numpy()
    foot = REFERENCE["points"]  # all on the foot link
    body = np.asarray(updated.kin_dyn_parameters.contact_parameters.body)
    expected = np.einsum("kij,kj->ki", W_H_L[body, :3, :3], foot) + W_H_L[body, :3, 3]
    np.testing.assert_allclose(wd.contact.collidable_point_positions(updated, data).numpy(), expected, rtol=0, atol=1e-14)


def test_gradients_through_the_mass_matrix_equal_jaxsims():
    """The tape's gradient of sum(W * M(q)) (Mixed) with respect to the dims and density factors, through
    update_hw_parameters, equals JaxSim's jax.grad of the same function."""
    model = leg()
    dims = wp.array(REFERENCE["dims"], dtype=wp.float64, requires_grad=True)
    density = wp.array(REFERENCE["density"], dtype=wp.float64, requires_grad=True)
    data = wd.data.Data.build(model, base_position=REFERENCE["base_position"], base_quaternion=REFERENCE["base_quaternion"],
                              joint_positions=REFERENCE["joint_positions"])
    with wp.Tape() as tape:
        updated = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=density))
        M = wd.model.free_floating_mass_matrix(updated, data)
        loss = weighted_sum([M], [wp.array(REFERENCE["W"], dtype=wp.float64)])
    assert abs(float(loss.numpy()[0]) - float(REFERENCE["f"])) <= 1e-12 * abs(float(REFERENCE["f"]))
    tape.backward(loss)
    np.testing.assert_allclose(dims.grad.numpy(), REFERENCE["grad_dims"], rtol=0, atol=1e-10 * np.abs(REFERENCE["grad_dims"]).max())
    np.testing.assert_allclose(density.grad.numpy(), REFERENCE["grad_density"], rtol=0, atol=1e-10 * np.abs(REFERENCE["grad_density"]).max())


@wp.kernel
def final_height(p: wp.array3d(dtype=wp.float64), loss: wp.array(dtype=wp.float64)):
    env = wp.tid()
    wp.atomic_add(loss, 0, p[p.shape[0] - 1, env, 2])


def test_gradients_through_a_rollout_equal_finite_differences():
    """The leg dropped 2 mm onto the ground on its foot sphere, 40 steps: the gradient of the final base height with
    respect to the shank's length factor, the thigh's density factor and the foot sphere's radius factor (which moves
    the collidable points) equals central differences (measured 1.2e-6 of it: the differences' round-off over 40 steps
    in contact, eps |z| / h ~ 1e-10 a step; bound 1e-5 + 1e-9)."""
    model = leg()
    nL = model.number_of_links()
    posture = np.array([[0.3, -0.6, 0.0], [0.1, -0.2, 0.01]])
    lowest = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, num_envs=2, joint_positions=posture)).numpy()[..., 2].min(axis=1)
    data = wd.data.Data.build(model, num_envs=2, base_position=np.stack([np.zeros(2), np.zeros(2), 0.002 - lowest], axis=1), joint_positions=posture)
    dims_host, density_host = np.ones((nL, 3)), np.ones(nL)
    dims = wp.array(dims_host, dtype=wp.float64, requires_grad=True)
    density = wp.array(density_host, dtype=wp.float64, requires_grad=True)
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        updated = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=density))
        _, rec = wd.simulation.rollout(updated, data, steps=40, record=("base_position",))
        wp.launch(final_height, dim=2, inputs=[rec["base_position"]], outputs=[loss])
    tape.backward(loss)

    def height(d, r):
        moved = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=d, density=r))
        return wd.simulation.rollout(moved, data, steps=40, record=("base_position",))[1]["base_position"].numpy()[-1, :, 2].sum()

    def check(which: str, link: str, component: int | None, smallest: float) -> None:
        """The tape's gradient with respect to one factor against its central difference (h = 1e-6)."""
        h, k = 1e-6, model.link_names().index(link)
        plus, minus = ({"dims": dims_host, "density": density_host}[which].copy() for _ in range(2))
        at = (k, component) if component is not None else k
        plus[at] += h
        minus[at] -= h
        args = {"dims": lambda x: (x, density_host), "density": lambda x: (dims_host, x)}[which]
        fd = (height(*args(plus)) - height(*args(minus))) / (2 * h)
        grad = {"dims": dims, "density": density}[which].grad.numpy()[at]
        assert abs(grad - fd) <= 1e-5 * abs(fd) + 1e-9 and abs(fd) > smallest, (which, link, grad, fd)

    check("dims", "shank", 2, 1e-4)
    check("density", "thigh", None, 1e-6)
    check("dims", "foot", 0, 1e-5)  # the foot sphere's radius: its collidable points move


def test_per_environment_densities_randomise_the_links():
    """density factors (N, nL): environment e's masses, centres of mass and inertias are those of the shared update
    with its row, and a step of the N environments equals N steps of those models; the tape's gradient of the
    environments' mass sums comes back per environment, equal to the volumes' densities (d m / d factor = m0)."""
    model = leg()
    nL, N = model.number_of_links(), 3
    rng = np.random.default_rng(2)
    dims, density = rng.uniform(0.9, 1.2, (nL, 3)), rng.uniform(0.7, 1.5, (N, nL))
    randomised = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=density))
    assert randomised.per_environment_parameters() == {"link_mass": N, "link_com": N, "link_inertia": N}
    data = wd.data.Data.build(randomised, num_envs=N, base_position=(0.0, 0.0, 1.0), joint_positions=rng.uniform(-0.3, 0.3, (N, 3)))
    stepped = wd.model.step(randomised, data).joint_velocities.numpy()
    for e in range(N):
        alone = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=density[e]))
        for name in ("link_mass", "link_com", "link_inertia"):
            np.testing.assert_allclose(getattr(randomised, name).numpy()[e], getattr(alone, name).numpy(), rtol=1e-15, atol=0, err_msg=name)
        one = wd.data.Data.build(alone, num_envs=1, base_position=(0.0, 0.0, 1.0), joint_positions=data.joint_positions.numpy()[e])
        np.testing.assert_allclose(stepped[e], wd.model.step(alone, one).joint_velocities.numpy()[0], rtol=0, atol=1e-12)
    factors = wp.array(density, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        updated = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=factors))
        total = weighted_sum([updated.link_mass], [wp.array(np.ones((N, nL)), dtype=wp.float64)])
    tape.backward(total)
    unit = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=np.ones(nL))).link_mass.numpy()
    np.testing.assert_allclose(factors.grad.numpy(), np.broadcast_to(unit, (N, nL)), rtol=1e-14)


def test_per_environment_shapes_randomise_lengths_and_contacts():
    """dims factors (N, nL, 3), the leg dropped 2 mm onto the ground, 40 steps: environment e's link parameters, joint
    origins, collidable points and rollout equal those of the shared update with its row (1e-12), and the gradient of
    the final heights with respect to environment e's shank length and foot radius equals central differences (as in
    the shared case: 1e-5 relative)."""
    model = leg()
    nL, N = model.number_of_links(), 3
    rng = np.random.default_rng(5)
    dims_host = rng.uniform(0.85, 1.2, (N, nL, 3))
    posture = rng.uniform(-0.3, 0.3, (N, 3))
    lowest = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, num_envs=N, joint_positions=posture)).numpy()[..., 2].min(axis=1)
    data = wd.data.Data.build(model, num_envs=N, base_position=np.stack([np.zeros(N), np.zeros(N), 0.002 - lowest], axis=1), joint_positions=posture)
    dims = wp.array(dims_host, dtype=wp.float64, requires_grad=True)
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        randomised = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=np.ones(nL)))
        _, rec = wd.simulation.rollout(randomised, data, steps=40, record=("base_position",))
        wp.launch(final_height, dim=N, inputs=[rec["base_position"]], outputs=[loss])
    tape.backward(loss)
    assert randomised.per_environment_parameters() == {"link_mass": N, "link_com": N, "link_inertia": N, "joint_origins": N, "collidable_points": N}
    points = wd.contact.collidable_point_positions(randomised, data).numpy()
    heights = rec["base_position"].numpy()[:, :, 2]

    def alone(row):
        return wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=row, density=np.ones(nL)))

    for e in range(N):
        shared = alone(dims_host[e])
        for name in ("link_mass", "link_com", "link_inertia"):
            np.testing.assert_allclose(getattr(randomised, name).numpy()[e], getattr(shared, name).numpy(), rtol=1e-15, atol=0, err_msg=name)
        np.testing.assert_allclose(wd.model.joint_origins(randomised)[0][e], wd.model.joint_origins(shared)[0], rtol=0, atol=1e-15)
        np.testing.assert_allclose(points[e], wd.contact.collidable_point_positions(shared, data).numpy()[e], rtol=0, atol=1e-14)
        _, out = wd.simulation.rollout(shared, data, steps=40, record=("base_position",))
        np.testing.assert_allclose(heights[:, e], out["base_position"].numpy()[:, e, 2], rtol=0, atol=1e-12)
    assert np.ptp(heights[-1]) > 1e-3  # the environments differ

    def final(d):
        moved = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=d, density=np.ones(nL)))
        return wd.simulation.rollout(moved, data, steps=40, record=("base_position",))[1]["base_position"].numpy()[-1, :, 2].sum()

    for at in ((1, model.link_names().index("foot"), 0), (2, model.link_names().index("shank"), 2)):
        plus, minus = dims_host.copy(), dims_host.copy()
        plus[at] += 1e-6
        minus[at] -= 1e-6
        fd = (final(plus) - final(minus)) / 2e-6
        assert abs(dims.grad.numpy()[at] - fd) <= 1e-5 * abs(fd) + 1e-9 and abs(fd) > 1e-5, (at, dims.grad.numpy()[at], fd)


def test_bad_factors_raise_naming_the_link():
    model = leg()
    nL = model.number_of_links()
    with pytest.raises(ValueError, match=r"scaling_factors.dims has shape \(3, 3\), expected \(4, 3\)"):
        wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((3, 3)), density=np.ones(nL)))
    bad = np.ones(nL)
    bad[2] = -1.0
    with pytest.raises(ValueError, match="scaling_factors.density of link 'shank' is -1.0"):
        wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((nL, 3)), density=bad))
    bad = np.ones((2, nL))
    bad[1, 3] = np.inf
    with pytest.raises(ValueError, match="scaling_factors.density of link 'foot' in environment 1 is inf"):
        wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((nL, 3)), density=bad))
    with pytest.raises(TypeError, match="ScalingFactors"):
        wd.model.update_hw_parameters(model, (np.ones((nL, 3)), np.ones(nL)))
    positions = wd.model.joint_origins(model)[0]
    per_env = wd.model.with_joint_origins(model, positions=np.stack([positions, 1.1 * positions]))
    with pytest.raises(ValueError, match=r"update_hw_parameters: \['joint_origins'\] are given per environment"):
        wd.model.update_hw_parameters(per_env, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((nL, 3)), density=np.ones(nL)))
    with pytest.raises(ValueError, match=r"dims are given for 3 environments, density for 2: one N"):
        wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((3, nL, 3)), density=np.ones((2, nL))))
    colliding = model.copy()
    colliding.geom_contacts = True
    with pytest.raises(ValueError, match=r"shapes per environment, but the model's geom pairs collide"):
        wd.model.update_hw_parameters(colliding, wd.kin_dyn_parameters.ScalingFactors(dims=np.ones((2, nL, 3)), density=np.ones(nL)))


LUMPED = """<robot name="lumped">
  <link name="body">
    <inertial><mass value="2"/><inertia ixx="0.02" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><box size="0.2 0.2 0.2"/></geometry></visual>
    <collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision>
  </link>
  <link name="pad">
    <collision><origin xyz="0 0 -0.1"/><geometry><sphere radius="0.03"/></geometry></collision>
  </link>
  <joint name="pad_weld" type="fixed"><parent link="body"/><child link="pad"/><origin xyz="0.05 0 0"/></joint>
  <link name="arm">
    <inertial><mass value="0.5"/><inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial>
    <visual><geometry><sphere radius="0.05"/></geometry></visual>
  </link>
  <joint name="hinge" type="revolute"><parent link="body"/><child link="arm"/><origin xyz="0 0 0.2"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" effort="10" velocity="5"/></joint>
</robot>"""


def test_lumped_members_shapes_are_named_when_their_link_is_scaled():
    """A sphere on a link fused into a parametrised box: update_hw_parameters names it (its collidable points move
    with the box's scaling, its shape in the description, which export writes, does not)."""
    model = wd.model.Model.build_from_model_description(LUMPED, dtype=np.float64)
    nL = model.number_of_links()
    with pytest.warns(wd.description.NotModelledWarning, match=r"lumped into parametrised links, 'pad' \(in 'body'\)"):
        wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=np.full((nL, 3), 1.1), density=np.ones(nL)))


def test_enabling_points_keeps_the_scaled_points_per_environment():
    """with_collidable_points after per-environment shapes: a new enabled mask keeps each environment's moved points
    (the foot's alone enabled: its positions equal the scaled model's), new options are refused (they would make the
    points from environment 0's shapes), and so is a step with geom contacts (the pairs' shapes are one)."""
    model = leg()
    nL = model.number_of_links()
    dims = np.ones((2, nL, 3))
    dims[1] *= 1.2
    scaled = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=np.ones(nL)))
    data = wd.data.Data.build(scaled, num_envs=2)
    feet = wd.contact.with_collidable_points(scaled, enabled_links=("foot",))
    body = np.asarray(scaled.kin_dyn_structure().contact_parameters.body)
    on_foot = body[body >= 0] == model.link_names().index("foot")
    all_points = wd.contact.collidable_point_positions(scaled, data).numpy()
    np.testing.assert_allclose(wd.contact.collidable_point_positions(feet, data).numpy(), all_points[:, on_foot], rtol=0, atol=1e-15)
    assert np.abs(all_points[1] - all_points[0]).max() > 0.01
    with pytest.raises(ValueError, match="the model's points are per environment"):
        wd.contact.with_collidable_points(scaled, options=wd.contact.CollidablePointsOptions())
    colliding = scaled.copy()
    colliding.geom_contacts = True  # the geom pairs' shapes would be environment 0's
    with pytest.raises(ValueError, match="model.geom_contacts with shapes per environment"):
        wd.model.step(colliding, data)


CAPSULE_LEG = """<sdf version="1.9"><model name="capsule_leg">
  <link name="torso">
    <inertial><mass>3.0</mass><inertia><ixx>0.03</ixx><iyy>0.03</iyy><izz>0.03</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial>
    <visual name="torso_box"><geometry><box><size>0.2 0.2 0.1</size></box></geometry></visual>
  </link>
  <joint name="hip" type="revolute"><pose relative_to="torso">0 0 -0.05 0 0 0</pose><parent>torso</parent><child>shin</child>
    <axis><xyz>0 1 0</xyz><limit><lower>-1</lower><upper>1</upper></limit></axis></joint>
  <link name="shin">
    <pose relative_to="hip">0 0 0 0 0 0</pose>
    <inertial><pose>0 0 -0.15 0 0 0</pose><mass>0.9</mass>
      <inertia><ixx>0.008</ixx><iyy>0.008</iyy><izz>0.0004</izz><ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia></inertial>
    <visual name="shin_capsule"><pose>0 0 -0.15 0 0 0</pose><geometry><capsule><radius>0.03</radius><length>0.24</length></capsule></geometry></visual>
    <collision name="shin_capsule"><pose>0 0 -0.15 0 0 0</pose><geometry><capsule><radius>0.03</radius><length>0.24</length></capsule></geometry></collision>
  </link>
</model></sdf>"""


def test_a_capsule_is_parametrised_as_mujoco_weighs_it():
    """A capsule visual (warpdyn's addition: JaxSim parametrises boxes, cylinders and spheres): its density is the
    link's mass over the capsule's volume, and scaled by (radius 1.3, length 0.8) its mass and inertia equal those
    MuJoCo computes for a capsule geom of the scaled size and that density (1e-12), its collidable points lie where
    the scaled collision shape's are (the model exported as MJCF: 1e-12) and the gradient of a landing's final height with
    respect to the radius factor equals central differences."""
    model = load(CAPSULE_LEG)
    metadata = wd.kin_dyn_parameters.hw_link_metadata(model)
    shin = model.link_names().index("shin")
    assert metadata.link_shape[shin] == wd.kin_dyn_parameters.LinkParametrizableShape.Capsule
    r, l = 0.03, 0.24
    np.testing.assert_allclose(metadata.density[shin], 0.9 / (np.pi * r * r * l + 4.0 / 3.0 * np.pi * r**3), rtol=1e-15)
    nL = model.number_of_links()
    dims = np.ones((nL, 3))
    dims[shin, :2] = (1.3, 0.8)
    scaled = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=dims, density=np.ones(nL)))
    mj = mujoco.MjModel.from_xml_string(f"""<mujoco><compiler inertiafromgeom="true"/><worldbody><body><freejoint/>
        <geom type="capsule" size="{1.3 * r!r} {0.4 * l!r}" density="{float(metadata.density[shin])!r}"/></body></worldbody></mujoco>""")
    np.testing.assert_allclose(scaled.link_mass.numpy()[shin], mj.body_mass[1], rtol=1e-12)
    np.testing.assert_allclose(np.diag(scaled.link_inertia.numpy()[shin]), mj.body_inertia[1], rtol=1e-12)
    data = wd.data.random_model_data(model, key=2, num_envs=2)
    exported = load(scaled.export_updated_model(format="mjcf"))
    points = [np.sort(wd.contact.collidable_point_positions(m, data).numpy().reshape(-1, 3), axis=0) for m in (scaled, exported)]
    np.testing.assert_allclose(points[0], points[1], rtol=0, atol=1e-12)

    tilted = wd.data.Data.build(model, num_envs=1, joint_positions=[[0.3]])
    lowest = wd.contact.collidable_point_positions(model, tilted).numpy()[..., 2].min()
    drop = wd.data.Data.build(model, num_envs=1, base_position=(0.0, 0.0, 0.002 - lowest), joint_positions=[[0.3]])

    def final(d):
        moved = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=d, density=np.ones(nL)))
        return wd.simulation.rollout(moved, drop, steps=40, record=("base_position",))[1]["base_position"].numpy()[-1, 0, 2]

    unit = np.ones((nL, 3))  # the drop is the unscaled model's: 2 mm above the ground
    factors = wp.array(unit, dtype=wp.float64, requires_grad=True)
    loss = wp.zeros(1, dtype=wp.float64, requires_grad=True)
    with wp.Tape() as tape:
        moved = wd.model.update_hw_parameters(model, wd.kin_dyn_parameters.ScalingFactors(dims=factors, density=np.ones(nL)))
        _, rec = wd.simulation.rollout(moved, drop, steps=40, record=("base_position",))
        wp.launch(final_height, dim=1, inputs=[rec["base_position"]], outputs=[loss])
    tape.backward(loss)
    plus, minus = unit.copy(), unit.copy()
    plus[shin, 0] += 1e-6
    minus[shin, 0] -= 1e-6
    fd = (final(plus) - final(minus)) / 2e-6
    assert abs(factors.grad.numpy()[shin, 0] - fd) <= 1e-5 * abs(fd) + 1e-9 and abs(fd) > 1e-4, (factors.grad.numpy()[shin, 0], fd)


def test_parametrized_links_choose_what_the_parametrisation_scales():
    """JaxSim's `parametrized_links`: the links outside it are Unsupported in hw_link_metadata and update_hw_parameters
    leaves them as they are (mass, inertia, the joint origins they carry), the chosen one scales as with every link
    parametrised; reduce keeps the names it still has; unknown names are refused, naming them."""
    every = leg()
    names = every.link_names()
    shapes = wd.kin_dyn_parameters.hw_link_metadata(every).link_shape
    chosen = next(n for n, shape in zip(names, shapes) if shape >= 0 and n != names[0])
    model = wd.model.Model.build_from_model_description((ROOT / "jaxsim" / "hw_leg.sdf").read_text(), dtype=np.float64, parametrized_links=(chosen,))
    metadata = wd.kin_dyn_parameters.hw_link_metadata(model)
    assert [n for n, shape in zip(names, metadata.link_shape) if shape >= 0] == [chosen]
    nL = model.number_of_links()
    factors = wd.kin_dyn_parameters.ScalingFactors(dims=np.full((nL, 3), 1.2), density=np.full(nL, 0.9))
    some, all_ = wd.model.update_hw_parameters(model, factors), wd.model.update_hw_parameters(every, factors)
    k = names.index(chosen)
    mass, base = some.link_mass.numpy(), model.link_mass.numpy()
    np.testing.assert_allclose(mass[k], all_.link_mass.numpy()[k], rtol=1e-15)
    assert mass[k] != base[k] and np.array_equal(np.delete(mass, k), np.delete(base, k))
    assert wd.model.reduce(model, list(model.joint_names())).parametrized_links == (chosen,)
    assert np.array_equal(model.kin_dyn_parameters.hw_link_metadata.link_shape, metadata.link_shape)  # JaxSim's field, filled
    with pytest.raises(ValueError, match=r"parametrized_links names links that model '.*' does not have: \['phantom'\]"):
        wd.model.Model.build_from_model_description((ROOT / "jaxsim" / "hw_leg.sdf").read_text(), dtype=np.float64, parametrized_links=("phantom",))
    with pytest.raises(TypeError, match="parametrized_links must be link names"):
        model.parametrized_links = chosen
