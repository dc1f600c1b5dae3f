"""JaxSim 0.9.0's rigid and relaxed-rigid contacts on the parity cases' box, hopper and ergoCub legs
(tests/jaxsim/cases.py) into tests/jaxsim/contact_models.npz: the contact forces at the cases' state, one step and
the states of a 300-step rollout (every 50th), float64. The legs' state is the parity cases' lowered until their
lowest collidable point is 3 mm deep (its base position stored, key `<case>/base_position`).

Run from the repository's root where JaxSim 0.9.0 is installed: `python tests/jaxsim/generate_contact_models.py
[CASE ...]` (default: every case; named cases replace theirs in the existing file).
Each contact model is asked for its answer to the tightest tolerance its solver reaches (the relaxed-rigid
L-BFGS: tol 1e-12, 1000 iterations; the rigid qpax interior point: solver_tol 1e-10), so that the
comparison measures the physics and not JaxSim's default tolerances; the relaxed-rigid default's answer
is stored too (key `<case>/forces_default`). The rigid rollouts rebuild JaxSim's data from its state after each
step: JaxSim 0.9.0's RigidContacts.update_velocity_after_impact sets the velocities with dataclasses.replace, which
leaves the data's cached link velocities at their values before the impact, and its next step reads those (the
points' velocities and J̇ν of its contact solve); a data built from the state has them right. Not run by the tests
or CI.
"""

from __future__ import annotations

import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "jaxsim"))

import cases  # noqa: E402

CONTACT_CASES = {
    "relaxed_box": dict(model="box", contact_model="RelaxedRigidContacts", options={"tol": 1e-12, "maxiter": 1000}, params={}),
    "relaxed_hopper": dict(model="hopper", contact_model="RelaxedRigidContacts", options={"tol": 1e-12, "maxiter": 1000}, params={}),
    "rigid_box": dict(model="box", contact_model="RigidContacts", options={"solver_tol": 1e-10}, params={"K": 1e4, "D": 100.0}),
    "rigid_hopper": dict(model="hopper", contact_model="RigidContacts", options={"solver_tol": 1e-10}, params={"K": 1e4, "D": 100.0, "mu": 0.8}),
    "relaxed_legs": dict(model="legs", contact_model="RelaxedRigidContacts", options={"tol": 1e-12, "maxiter": 1000}, params={}),
    "rigid_legs": dict(model="legs", contact_model="RigidContacts", options={"solver_tol": 1e-10}, params={"K": 1e4, "D": 100.0}),
}
"""The cases: a model of cases.MODELS, JaxSim's contact model, its solver options and its parameters."""

STEPS, EVERY = 300, 50
DEPTH = 0.003
"""[m] how deep the legs' lowest collidable point starts."""


def run(name: str) -> dict:
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxsim.api as js
    import jaxsim.rbda.contacts as contacts

    case = CONTACT_CASES[name]
    spec = cases.MODELS[case["model"]]
    model = js.model.JaxSimModel.build_from_model_description((ROOT / spec["path"]).read_text(), considered_joints=spec["considered_joints"])
    kind = getattr(contacts, case["contact_model"])
    with model.editable(validate=False) as edited:
        edited.contact_model = kind.build(solver_options=case["options"])
        edited.contact_params = edited.contact_model._parameters_class(**case["params"])
    model = edited
    kwargs = cases.state(case["model"], model.joint_names(), model.floating_base())
    data = js.data.JaxSimModelData.build(model=model, velocity_representation=js.common.VelRepr.Inertial, **kwargs)
    out = {}
    if case["model"] == "legs":  # lowered into contact (the module docstring)
        low = float(np.min(np.asarray(js.contact.collidable_point_positions(model, data))[:, 2]))
        kwargs["base_position"] = np.asarray(kwargs["base_position"]) - np.array([0.0, 0.0, low + DEPTH])
        data = js.data.JaxSimModelData.build(model=model, velocity_representation=js.common.VelRepr.Inertial, **kwargs)
        out[f"{name}/base_position"] = np.asarray(kwargs["base_position"])
    x = cases.inputs(case["model"], model.dofs(), model.number_of_links())
    forces, _ = model.contact_model.compute_contact_forces(model, data, joint_force_references=x["tau"])
    out[f"{name}/forces"] = np.asarray(forces)
    if case["contact_model"] == "RelaxedRigidContacts":
        with model.editable(validate=False) as default:
            default.contact_model = kind.build()
        out[f"{name}/forces_default"] = np.asarray(default.contact_model.compute_contact_forces(default, data, joint_force_references=x["tau"])[0])
    step = jax.jit(lambda d: js.model.step(model, d, joint_force_references=np.zeros(model.dofs())))
    states = []
    for k in range(STEPS + 1):
        if k % EVERY == 0 or k == 1:
            states.append(np.concatenate([np.asarray(a).ravel() for a in (data.base_position, data.base_orientation, data.joint_positions, data.base_velocity, data.joint_velocities)]))
        if k < STEPS:
            data = step(data)
            if case["contact_model"] == "RigidContacts":  # its link velocities after the impact (the module docstring)
                data = js.data.JaxSimModelData.build(
                    model=model, velocity_representation=js.common.VelRepr.Inertial, base_position=data.base_position,
                    base_quaternion=data.base_orientation, joint_positions=data.joint_positions, base_linear_velocity=data.base_velocity[:3],
                    base_angular_velocity=data.base_velocity[3:], joint_velocities=data.joint_velocities,
                )
    out[f"{name}/states"] = np.array(states)
    return out


def main(names: list[str]) -> None:
    import jaxsim

    path = ROOT / "tests" / "jaxsim" / "contact_models.npz"
    out = dict(np.load(path)) if names and path.exists() else {}
    out["jaxsim_version"] = np.asarray(jaxsim.__version__)
    for name in names or CONTACT_CASES:
        out = {k: v for k, v in out.items() if not k.startswith(f"{name}/")} | run(name)
        print(name, flush=True)
    np.savez_compressed(path, **out)


if __name__ == "__main__":
    main(sys.argv[1:])
