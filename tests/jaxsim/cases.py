"""The JaxSim 0.9.0 parity cases: models, states and calls, each call written once in JaxSim's call form with
`api` standing for `jaxsim.api` (tests/jaxsim/generate_reference.py, run where JaxSim is installed, stores
JaxSim's results in reference.npz) or for `warpdyn` (tests/test_jaxsim_parity.py compares warpdyn's with
them). So every call here is JaxSim code that ports by renaming `js` to `wd`.

Imports NumPy only. Paths are relative to the repository's root.
"""

from __future__ import annotations

import zlib

import numpy as np

LEG_JOINTS = (
    "l_hip_pitch", "l_hip_roll", "l_hip_yaw", "l_knee", "l_ankle_pitch", "l_ankle_roll",
    "r_hip_pitch", "r_hip_roll", "r_hip_yaw", "r_knee", "r_ankle_pitch", "r_ankle_roll",
)  # fmt: skip

MODELS = {
    "legs": dict(path="warpdyn/assets/ergoCubSN001.sdf", considered_joints=LEG_JOINTS, height=0.9, link="l_ankle_2", frame="l_foot_front"),
    "arm": dict(path="tests/jaxsim/arm.sdf", considered_joints=None, height=0.0, link="tool", frame="tool_tip"),
    "hopper": dict(path="tests/jaxsim/hopper.sdf", considered_joints=None, height=0.545, link="l_shank", frame="l_foot"),
    "box": dict(path="tests/jaxsim/box.sdf", considered_joints=None, height=0.095, link="box_link", frame=None),
}
"""The models: the ergoCub's legs (floating, 12 joints; its feet's four boxes give JaxSim and warpdyn the same 32
collidable points, above the ground at `height`: tests/jaxsim/generate_contact_models.py lowers them), a welded
arm (revolute, continuous and prismatic joints, frames, boxes and a sphere), a floating hopper whose sphere
feet touch the ground, and a floating box whose corners do. height: the base's height in the states, which
puts the hopper's and the box's lowest points a few millimetres into the ground."""

REPRESENTATIONS = ("Inertial", "Body", "Mixed")


def state(name: str, joint_names, floating: bool) -> dict:
    """JaxSimModelData.build's keywords for model `name`: joints by name (so that the state does not depend on
    the joints' order), a base pose near `height` tilted by a few degrees and a base velocity (floating bases
    only), all drawn from a generator seeded by the model's name."""
    rng = np.random.default_rng(zlib.crc32(name.encode()))
    limits = 0.6 if name != "box" else 0.0
    values = {joint: (rng.uniform(-limits, limits), rng.uniform(-1.0, 1.0)) for joint in sorted(joint_names)}
    kwargs = dict(
        joint_positions=np.array([values[j][0] for j in joint_names]),
        joint_velocities=np.array([values[j][1] for j in joint_names]),
        base_position=np.array([0.05, -0.1, MODELS[name]["height"]]),
    )
    if name == "hopper":  # a standing posture: hips and knees folded so that both feet are below the torso
        kwargs["joint_positions"] = np.array([{"l_hip": 0.3, "r_hip": 0.25, "l_knee": -0.6, "r_knee": -0.55}[j] for j in joint_names])
    tilt = rng.normal(size=3) * 0.05
    quaternion = np.array([1.0, *tilt]) / np.linalg.norm([1.0, *tilt])
    kwargs["base_quaternion"] = quaternion
    if floating:
        kwargs["base_linear_velocity"] = rng.uniform(-0.3, 0.3, 3)
        kwargs["base_angular_velocity"] = rng.uniform(-0.5, 0.5, 3)
    else:
        kwargs["base_position"] = np.zeros(3)
        kwargs["base_quaternion"] = np.array([1.0, 0.0, 0.0, 0.0])
    return kwargs


def inputs(name: str, n: int, nL: int) -> dict:
    """Deterministic joint forces (n,), link forces (nL, 6), joint and base accelerations for model `name`."""
    rng = np.random.default_rng(zlib.crc32(("inputs " + name).encode()))
    return dict(
        tau=rng.uniform(-2.0, 2.0, n),
        f_L=rng.uniform(-1.0, 1.0, (nL, 6)),
        s_ddot=rng.uniform(-1.0, 1.0, n),
        v_dot=rng.uniform(-1.0, 1.0, 6),
    )


def _names(api, model):
    return dict(links=model.link_names(), joints=model.joint_names(), frames=model.frame_names())


def _repr(api, name: str):
    return getattr(api.common.VelRepr, name)


def calls(api, model, data, x: dict) -> dict:
    """{name: zero-argument callable} of the calls of every public function that takes (model, data) or
    (model), in JaxSim's call form. x: `inputs`, and "frame" and "link" (a frame's and a link's name)."""
    VelRepr = api.common.VelRepr
    link = api.link.name_to_idx(model=model, link_name=x["link"])
    frame = api.frame.name_to_idx(model=model, frame_name=x["frame"]) if x["frame"] else None
    out = {
        "model.forward_kinematics": lambda: api.model.forward_kinematics(model=model, data=data),
        "model.free_floating_mass_matrix": lambda: api.model.free_floating_mass_matrix(model=model, data=data),
        "model.free_floating_mass_matrix_inverse": lambda: api.model.free_floating_mass_matrix_inverse(model=model, data=data),
        "model.free_floating_bias_forces": lambda: api.model.free_floating_bias_forces(model=model, data=data),
        "model.free_floating_gravity_forces": lambda: api.model.free_floating_gravity_forces(model=model, data=data),
        "model.free_floating_coriolis_matrix": lambda: api.model.free_floating_coriolis_matrix(model=model, data=data),
        "model.forward_dynamics_aba": lambda: api.model.forward_dynamics_aba(model=model, data=data, joint_forces=x["tau"], link_forces=x["f_L"]),
        "model.forward_dynamics_crb": lambda: api.model.forward_dynamics_crb(model=model, data=data, joint_forces=x["tau"], link_forces=x["f_L"]),
        "model.forward_dynamics": lambda: api.model.forward_dynamics(model=model, data=data, joint_forces=x["tau"], link_forces=x["f_L"], prefer_aba=False),
        "model.inverse_dynamics": lambda: api.model.inverse_dynamics(
            model=model, data=data, joint_accelerations=x["s_ddot"], base_acceleration=x["v_dot"], link_forces=x["f_L"]
        ),
        "model.locked_spatial_inertia": lambda: api.model.locked_spatial_inertia(model=model, data=data),
        "model.total_momentum": lambda: api.model.total_momentum(model=model, data=data),
        "model.average_velocity": lambda: api.model.average_velocity(model=model, data=data),
        "model.link_bias_accelerations": lambda: api.model.link_bias_accelerations(model=model, data=data),
        "model.joint_transforms": lambda: api.model.joint_transforms(model=model, joint_positions=data.joint_positions, base_transform=data.base_transform),
        "model.kinetic_energy": lambda: api.model.kinetic_energy(model=model, data=data),
        "model.potential_energy": lambda: api.model.potential_energy(model=model, data=data),
        "model.mechanical_energy": lambda: api.model.mechanical_energy(model=model, data=data),
        "model.total_mass": lambda: api.model.total_mass(model=model),
        "model.link_spatial_inertia_matrices": lambda: api.model.link_spatial_inertia_matrices(model=model),
        "com.com_position": lambda: api.com.com_position(model=model, data=data),
        "com.com_linear_velocity": lambda: api.com.com_linear_velocity(model=model, data=data),
        "com.centroidal_momentum": lambda: api.com.centroidal_momentum(model=model, data=data),
        "com.centroidal_momentum_jacobian": lambda: api.com.centroidal_momentum_jacobian(model=model, data=data),
        "com.locked_centroidal_spatial_inertia": lambda: api.com.locked_centroidal_spatial_inertia(model=model, data=data),
        "com.average_centroidal_velocity": lambda: api.com.average_centroidal_velocity(model=model, data=data),
        "com.average_centroidal_velocity_jacobian": lambda: api.com.average_centroidal_velocity_jacobian(model=model, data=data),
        "com.bias_acceleration": lambda: api.com.bias_acceleration(model=model, data=data),
        "link.transform": lambda: api.link.transform(model=model, data=data, link_index=link),
        "link.com_position": lambda: api.link.com_position(model=model, data=data, link_index=link),
        "link.com_position_world": lambda: api.link.com_position(model=model, data=data, link_index=link, in_link_frame=False),
        "link.mass": lambda: api.link.mass(model=model, link_index=link),
        "link.spatial_inertia": lambda: api.link.spatial_inertia(model=model, link_index=link),
        "link.bias_acceleration": lambda: api.link.bias_acceleration(model=model, data=data, link_index=link),
        "joint.position_limits": lambda: api.joint.position_limits(model=model),
        "joint.position_limit": lambda: api.joint.position_limit(model=model, joint_index=0),
        "data.base_velocity": lambda: data.base_velocity,
        "data.base_orientation": lambda: data.base_orientation,
        "data.base_transform": lambda: data.base_transform,
        "data.generalized_velocity": lambda: data.generalized_velocity,
        "data.generalized_position": lambda: data.generalized_position,
        "data.valid": lambda: data.valid(model=model),
        "data.reset_base_pose": lambda: data.reset_base_pose(model=model, base_pose=np.eye(4)).base_velocity,
        "data.replace": lambda: data.replace(model=model, base_linear_velocity=np.array([0.1, 0.2, 0.3])).generalized_velocity,
        "references.link_forces": lambda: api.references.JaxSimModelReferences.build(
            model=model, link_forces=x["f_L"], data=data, velocity_representation=data.velocity_representation
        ).link_forces(model=model, data=data),
        "references.link_forces_inertial": lambda: _inertial_forces(api, model, data, x),
        "actuation_model.compute_resultant_torques": lambda: api.actuation_model.compute_resultant_torques(model, data, joint_force_references=x["tau"]),
        "actuation_model.tn_curve_fn": lambda: api.actuation_model.tn_curve_fn(model, data),
        "ode.system_acceleration": lambda: api.ode.system_acceleration(model=model, data=data, link_forces=x["f_L"], joint_torques=x["tau"]),
        "ode.system_position_dynamics": lambda: api.ode.system_position_dynamics(data=data),
        "ode.system_dynamics": lambda: api.ode.system_dynamics(model=model, data=data, link_forces=x["f_L"], joint_torques=x["tau"]),
        "model.step": lambda: _stepped(api, model, api.model.step(model=model, data=data, link_forces=x["f_L"], joint_force_references=x["tau"])),
        "integrators.semi_implicit_euler_integration": lambda: _stepped(
            api, model, api.integrators.semi_implicit_euler_integration(model=model, data=data, link_forces=_inertial_forces(api, model, data, x), joint_torques=x["tau"])
        ),
        "integrators.rk4_integration": lambda: _stepped(
            api, model, api.integrators.rk4_integration(model=model, data=data, link_forces=_inertial_forces(api, model, data, x), joint_torques=x["tau"])
        ),
        "kin_dyn_parameters.tree_transforms": lambda: model.kin_dyn_parameters.tree_transforms(),
        "kin_dyn_parameters.links_spatial_inertia": lambda: model.kin_dyn_parameters.links_spatial_inertia(),
        "kin_dyn_parameters.motion_subspaces": lambda: model.kin_dyn_parameters.motion_subspaces,
        "kin_dyn_parameters.support_body_array_bool": lambda: model.kin_dyn_parameters.support_body_array_bool,
        "kin_dyn_parameters.parent_array": lambda: model.kin_dyn_parameters.parent_array,
        "kin_dyn_parameters.level_nodes": lambda: model.kin_dyn_parameters.level_nodes,
        "kin_dyn_parameters.level_mask": lambda: model.kin_dyn_parameters.level_mask,
        "kin_dyn_parameters.joint_parameters.position_limits_min": lambda: model.kin_dyn_parameters.joint_parameters.position_limits_min,
        "kin_dyn_parameters.joint_parameters.friction_static": lambda: model.kin_dyn_parameters.joint_parameters.friction_static,
        "kin_dyn_parameters.joint_parameters.friction_viscous": lambda: model.kin_dyn_parameters.joint_parameters.friction_viscous,
        "kin_dyn_parameters.link_parameters.inertia_elements": lambda: model.kin_dyn_parameters.link_parameters.inertia_elements,
        "kin_dyn_parameters.joint_model.λ_H_pre": lambda: model.kin_dyn_parameters.joint_model.λ_H_pre,
        "kin_dyn_parameters.set_link_mass": lambda: api.model.free_floating_mass_matrix(
            model=model.replace(kin_dyn_parameters=model.kin_dyn_parameters.set_link_mass(link_index=link, mass=3.0)), data=data
        ),
        "contact.estimate_good_contact_parameters": lambda: _soft_params(api.contact.estimate_good_contact_parameters(model=model)),
    }
    for output in REPRESENTATIONS:
        o = getattr(VelRepr, output)
        out[f"model.generalized_free_floating_jacobian[{output}]"] = lambda o=o: api.model.generalized_free_floating_jacobian(model=model, data=data, output_vel_repr=o)
        out[f"model.generalized_free_floating_jacobian_derivative[{output}]"] = lambda o=o: api.model.generalized_free_floating_jacobian_derivative(
            model=model, data=data, output_vel_repr=o
        )
        out[f"model.total_momentum_jacobian[{output}]"] = lambda o=o: api.model.total_momentum_jacobian(model=model, data=data, output_vel_repr=o)
        out[f"model.average_velocity_jacobian[{output}]"] = lambda o=o: api.model.average_velocity_jacobian(model=model, data=data, output_vel_repr=o)
        out[f"link.jacobian[{output}]"] = lambda o=o: api.link.jacobian(model=model, data=data, link_index=link, output_vel_repr=o)
        out[f"link.velocity[{output}]"] = lambda o=o: api.link.velocity(model=model, data=data, link_index=link, output_vel_repr=o)
        out[f"link.jacobian_derivative[{output}]"] = lambda o=o: api.link.jacobian_derivative(model=model, data=data, link_index=link, output_vel_repr=o)
        if frame is not None:
            out[f"frame.jacobian[{output}]"] = lambda o=o: api.frame.jacobian(model=model, data=data, frame_index=frame, output_vel_repr=o)
            out[f"frame.velocity[{output}]"] = lambda o=o: api.frame.velocity(model=model, data=data, frame_index=frame, output_vel_repr=o)
            out[f"frame.jacobian_derivative[{output}]"] = lambda o=o: api.frame.jacobian_derivative(model=model, data=data, frame_index=frame, output_vel_repr=o)
        if len(model.kin_dyn_parameters.contact_parameters.body):
            out[f"contact.jacobian[{output}]"] = lambda o=o: api.contact.jacobian(model=model, data=data, output_vel_repr=o)
            out[f"contact.jacobian_derivative[{output}]"] = lambda o=o: api.contact.jacobian_derivative(model=model, data=data, output_vel_repr=o)
    if frame is not None:
        out["frame.transform"] = lambda: api.frame.transform(model=model, data=data, frame_index=frame)
        out["frame.idx_of_parent_link"] = lambda: api.frame.idx_of_parent_link(model=model, frame_index=frame)
    if len(model.kin_dyn_parameters.contact_parameters.body):
        out.update(
            {
                "contact.collidable_point_kinematics": lambda: api.contact.collidable_point_kinematics(model=model, data=data),
                "contact.collidable_point_positions": lambda: api.contact.collidable_point_positions(model=model, data=data),
                "contact.collidable_point_velocities": lambda: api.contact.collidable_point_velocities(model=model, data=data),
                "contact.in_contact": lambda: api.contact.in_contact(model=model, data=data, link_names=model.link_names()),
                "contact.transforms": lambda: api.contact.transforms(model=model, data=data),
                "contact.link_contact_forces": lambda: api.contact.link_contact_forces(model=model, data=data),
                "contact.link_forces_from_contact_forces": lambda: api.contact.link_forces_from_contact_forces(
                    model=model, contact_forces=model.contact_model.compute_contact_forces(model=model, data=data)[0]
                ),
                "contact_model.compute_contact_forces": lambda: model.contact_model.compute_contact_forces(model=model, data=data),
            }
        )
    return out


def _inertial_forces(api, model, data, x):
    """The link forces x["f_L"], given in the data's representation, as Inertial forces (what JaxSim's step
    hands its integrators)."""
    references = api.references.JaxSimModelReferences.build(model=model, link_forces=x["f_L"], data=data, velocity_representation=data.velocity_representation)
    with references.switch_velocity_representation(api.common.VelRepr.Inertial):
        return references.link_forces(model=model, data=data)


def _stepped(api, model, data):
    """The state after a step: (base position, base quaternion, joint positions, base velocity in the data's
    representation, joint velocities, tangential deformation)."""
    state = [data.base_position, data.base_quaternion, data.joint_positions, data.base_velocity, data.joint_velocities]
    deformation = data.contact_state.get("tangential_deformation")
    return (*state, deformation if deformation is not None else np.zeros((0, 3)))


def _soft_params(params):
    return (params.K, params.D, params.mu, params.p, params.q)


def host(value):
    """A call's result as NumPy: arrays (JAX, Warp, NumPy), numbers, booleans, tuples and dicts (by sorted keys)."""
    if isinstance(value, dict):
        return tuple(host(value[k]) for k in sorted(value))
    if isinstance(value, (tuple, list)):
        return tuple(host(v) for v in value)
    if hasattr(value, "numpy") and callable(value.numpy):
        return np.asarray(value.numpy())
    return np.asarray(value)


def flatten(value, prefix: str) -> dict:
    """{key: ndarray} of a host() result: nested tuples become `prefix/0`, `prefix/1/0`, ..."""
    if isinstance(value, tuple):
        out = {}
        for k, v in enumerate(value):
            out.update(flatten(v, f"{prefix}/{k}"))
        return out
    return {prefix: value}


def math_calls(math, terrain, contacts) -> dict:
    """{name: zero-argument callable}: JaxSim's math helpers (`jaxsim.math` / `warpdyn.math`), terrains
    (`jaxsim.terrain` / `warpdyn.terrain`) and point contact law (`jaxsim.rbda.contacts` /
    `warpdyn.rbda.contacts`) on fixed numbers, in JaxSim's call form."""
    rng = np.random.default_rng(34)
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    p, w, v6 = rng.normal(size=3), rng.normal(size=3), rng.normal(size=6)
    R = np.array([[0.36, 0.48, -0.8], [-0.8, 0.6, 0.0], [0.48, 0.64, 0.6]])
    H = np.eye(4)
    H[:3, :3], H[:3, 3] = R, p
    c, inertia = np.array([0.01, -0.02, 0.03]), np.array([[0.2, 0.01, 0.0], [0.01, 0.3, 0.02], [0.0, 0.02, 0.25]])
    flat, plane = terrain.FlatTerrain.build(height=0.02), terrain.PlaneTerrain.build(height=0.05, normal=[0.1, -0.2, 1.0])
    params = contacts.SoftContactsParams.build(K=2e5, D=3e3, mu=0.7, p=0.5, q=0.5)
    point, velocity, deformation = np.array([0.3, -0.2, 0.01]), np.array([0.4, -0.1, -0.3]), np.array([0.001, -0.002, 0.0])
    return {
        "math.Adjoint.from_quaternion_and_translation": lambda: math.Adjoint.from_quaternion_and_translation(quaternion=q, translation=p),
        "math.Adjoint.from_quaternion_and_translation[inverse]": lambda: math.Adjoint.from_quaternion_and_translation(quaternion=q, translation=p, inverse=True),
        "math.Adjoint.from_transform": lambda: math.Adjoint.from_transform(transform=H),
        "math.Adjoint.from_transform[inverse]": lambda: math.Adjoint.from_transform(transform=H, inverse=True),
        "math.Adjoint.from_rotation_and_translation": lambda: math.Adjoint.from_rotation_and_translation(rotation=R, translation=p),
        "math.Adjoint.to_transform": lambda: math.Adjoint.to_transform(adjoint=math.Adjoint.from_transform(transform=H)),
        "math.Adjoint.inverse": lambda: math.Adjoint.inverse(adjoint=math.Adjoint.from_transform(transform=H)),
        "math.Cross.vx": lambda: math.Cross.vx(velocity_sixd=v6),
        "math.Cross.vx_star": lambda: math.Cross.vx_star(velocity_sixd=v6),
        "math.Inertia.to_sixd": lambda: math.Inertia.to_sixd(mass=2.5, com=c, I=inertia),
        "math.Inertia.to_params": lambda: math.Inertia.to_params(M=math.Inertia.to_sixd(mass=2.5, com=c, I=inertia)),
        "math.Quaternion.to_xyzw": lambda: math.Quaternion.to_xyzw(wxyz=q),
        "math.Quaternion.to_wxyz": lambda: math.Quaternion.to_wxyz(xyzw=q),
        "math.Quaternion.to_dcm": lambda: math.Quaternion.to_dcm(quaternion=q),
        "math.Quaternion.from_dcm": lambda: math.Quaternion.from_dcm(dcm=R),
        "math.Quaternion.derivative": lambda: np.asarray(math.Quaternion.derivative(quaternion=q, omega=w, omega_in_body_fixed=False)).reshape(-1),
        "math.Quaternion.derivative[body]": lambda: np.asarray(math.Quaternion.derivative(quaternion=q, omega=w, omega_in_body_fixed=True, K=0.5)).reshape(-1),
        "math.Quaternion.integration": lambda: math.Quaternion.integration(quaternion=q, dt=0.01, omega=w, omega_in_body_fixed=False),
        "math.Quaternion.integration[body]": lambda: math.Quaternion.integration(quaternion=q, dt=0.01, omega=w, omega_in_body_fixed=True),
        "math.Rotation.x": lambda: math.Rotation.x(theta=0.3),
        "math.Rotation.y": lambda: math.Rotation.y(theta=-0.7),
        "math.Rotation.z": lambda: math.Rotation.z(theta=1.1),
        "math.Rotation.from_axis_angle": lambda: math.Rotation.from_axis_angle(vector=w),
        "math.Rotation.log_vee": lambda: math.Rotation.log_vee(R=R),
        "math.Skew.wedge": lambda: math.Skew.wedge(vector=w),
        "math.Skew.vee": lambda: math.Skew.vee(matrix=math.Skew.wedge(vector=w)),
        "math.Transform.from_quaternion_and_translation": lambda: math.Transform.from_quaternion_and_translation(quaternion=q, translation=p),
        "math.Transform.from_rotation_and_translation": lambda: math.Transform.from_rotation_and_translation(rotation=R, translation=p, inverse=True),
        "math.Transform.inverse": lambda: math.Transform.inverse(transform=H),
        "math.safe_norm": lambda: math.safe_norm(v6, axis=-1),
        "math.safe_norm[zero]": lambda: math.safe_norm(np.zeros(3)),
        "math.supported_joint_motion[revolute]": lambda: math.supported_joint_motion(joint_types=1, joint_positions=0.7, joint_axes=w / np.linalg.norm(w)),
        "math.supported_joint_motion[prismatic]": lambda: math.supported_joint_motion(joint_types=2, joint_positions=0.2, joint_axes=w / np.linalg.norm(w)),
        "math.STANDARD_GRAVITY": lambda: math.STANDARD_GRAVITY,
        "terrain.FlatTerrain.height": lambda: flat.height(x=0.4, y=-1.0),
        "terrain.FlatTerrain.normal": lambda: flat.normal(x=0.4, y=-1.0),
        "terrain.PlaneTerrain.height": lambda: plane.height(x=0.4, y=-1.0),
        "terrain.PlaneTerrain.normal": lambda: plane.normal(x=0.4, y=-1.0),
        "terrain.equality": lambda: (flat == terrain.FlatTerrain.build(height=0.02), hash(flat) == hash(terrain.FlatTerrain.build(height=0.02)), flat == plane),
        "rbda.contacts.SoftContactsParams.valid": lambda: params.valid(),
        "rbda.contacts.SoftContacts.hunt_crossley_contact_model": lambda: contacts.SoftContacts.hunt_crossley_contact_model(
            position=point, velocity=velocity, tangential_deformation=deformation, terrain=plane, K=2e5, D=3e3, mu=0.7
        ),
        "rbda.contacts.SoftContacts.compute_contact_force": lambda: contacts.SoftContacts.compute_contact_force(
            position=point, velocity=velocity, tangential_deformation=deformation, parameters=params, terrain=plane
        ),
        "rbda.contacts.compute_penetration_data": lambda: contacts.common.compute_penetration_data(p=point, v=velocity, terrain=plane)
        if hasattr(contacts, "common")
        else contacts.compute_penetration_data(p=point, v=velocity, terrain=plane),
        "rbda.contacts.MAX_STIFFNESS": lambda: (contacts.common.MAX_STIFFNESS, contacts.common.MAX_DAMPING)
        if hasattr(contacts, "common")
        else (contacts.MAX_STIFFNESS, contacts.MAX_DAMPING),
    }
