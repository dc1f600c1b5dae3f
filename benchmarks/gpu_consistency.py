"""GPU correctness: every kernel on the GPU gives the CPU's results for the same states (float64, float32).

    python benchmarks/gpu_consistency.py --write-reference ref.npz     # here, on the CPU
    python benchmarks/gpu_consistency.py --reference ref.npz           # on the GPU machine

CI has no GPU, so this is how the environment-fastest layout and the CUDA code paths are checked: the CPU
results (environment-major layout, checked against MuJoCo by the tests) are the reference. The reference
file holds the states and the results; Warp on the GPU machine need not compile for its CPU. Prints the
largest relative difference per quantity and exits non-zero when one exceeds its tolerance (1e-9 in
float64, 1e-3 in float32, 1e-2 for float32's dense solves).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np
import warp as wp

import warpdyn as wd
from common import init_warp, np_dtype, seed_model, write_reference
from warpdyn import VelRepr

N = 257
TOLERANCE = {"float64": 1e-9, "float32": 1e-3}
CONDITIONED = {"mass_matrix_inverse": 1e-2, "crb_base": 1e-2, "crb_joints": 1e-2}
"""float32 tolerances of the dense solves: M agrees to ~1e-5, but M^-1 amplifies that by cond(M) (on the
CPU alone, float32 M^-1 is 8.6e-4 from float64's)."""


def states(model, seed: int = 3) -> dict[str, np.ndarray]:
    data = wd.data.random_model_data(model, num_envs=N, key=seed)
    rng = np.random.default_rng(seed + 1)
    return {
        "base_position": data.base_position.numpy(),
        "base_quaternion": data.base_quaternion.numpy(),
        "joint_positions": data.joint_positions.numpy(),
        "base_velocity": data.base_velocity.numpy(),
        "joint_velocities": data.joint_velocities.numpy(),
        "tau": rng.uniform(-5, 5, (N, model.dofs())),
        "forces": rng.uniform(-5, 5, (N, model.number_of_links(), 6)),
    }


def quantities(model, s: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    data = wd.data.Data.build(
        model,
        base_position=s["base_position"],
        base_quaternion=s["base_quaternion"],
        joint_positions=s["joint_positions"],
        base_linear_velocity=s["base_velocity"][:, :3],
        base_angular_velocity=s["base_velocity"][:, 3:],
        joint_velocities=s["joint_velocities"],
        num_envs=N,
    )
    tau, forces = s["tau"], s["forces"]
    out = {
        "forward_kinematics": wd.model.forward_kinematics(model, data),
        "link_velocities": wd.model.generalized_free_floating_jacobian(model, data),
        "mass_matrix_inverse": wd.model.free_floating_mass_matrix_inverse(model, data),
        "jacobian_derivatives": wd.model.generalized_free_floating_jacobian_derivative(model, data),
        "kinetic_energy": wd.model.kinetic_energy(model, data),
        "centroidal_momentum_jacobian": wd.com.centroidal_momentum_jacobian(model, data),
    }
    out["crb_base"], out["crb_joints"] = wd.model.forward_dynamics_crb(model, data, joint_forces=tau, link_forces=forces)
    for repr in VelRepr:
        with data.switch_velocity_representation(repr):
            out[f"jacobians_{repr.name}"] = wd.model.generalized_free_floating_jacobian(model, data)
            out[f"mass_matrix_{repr.name}"] = wd.model.free_floating_mass_matrix(model, data)
            out[f"bias_forces_{repr.name}"] = wd.model.free_floating_bias_forces(model, data)
            base, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=tau, link_forces=forces)
            out[f"aba_base_{repr.name}"], out[f"aba_joints_{repr.name}"] = base, joints
            f_B, tau_id = wd.model.inverse_dynamics(model, data, joint_accelerations=tau, link_forces=forces)
            out[f"rnea_base_{repr.name}"], out[f"rnea_joints_{repr.name}"] = f_B, tau_id
    return {k: v.numpy() for k, v in out.items()}


def main() -> int:
    parser = argparse.ArgumentParser()
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--write-reference")
    group.add_argument("--reference")
    args = parser.parse_args()
    init_warp()
    if args.write_reference:
        write_reference(args.write_reference, TOLERANCE, states, quantities)
        return 0
    reference = np.load(args.reference)
    failures = 0
    for dtype_name, tol in TOLERANCE.items():
        model = seed_model(np_dtype[dtype_name], "cuda:0")
        prefix = f"{dtype_name}/state/"
        s = {k[len(prefix) :]: reference[k] for k in reference.files if k.startswith(prefix)}
        got = quantities(model, s)
        for name, value in got.items():
            cpu = reference[f"{dtype_name}/result/{name}"]
            error = float(np.max(np.abs(value - cpu) / (1.0 + np.abs(cpu))))
            ok = error <= (CONDITIONED.get(name, tol) if dtype_name == "float32" else tol)
            failures += not ok
            print(f"{dtype_name} {name:30s} max rel diff {error:.2e} {'ok' if ok else 'FAIL'}")
    print(f"{wp.get_device('cuda:0').name}: {failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
