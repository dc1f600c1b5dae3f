"""GPU correctness: every kernel on the GPU gives the CPU's results for the same states (float64 and float32).

    python benchmarks/gpu_consistency.py

CI has no GPU, so this is how the env-fastest layout and the CUDA code paths are checked: the CPU run
(env-major layout, checked against MuJoCo by the tests) is the reference. Prints the largest absolute
difference per quantity and exits non-zero when one exceeds its tolerance (1e-9 in float64, 1e-3 in float32).
"""

from __future__ import annotations

import sys

import numpy as np
import warp as wp

import warpdyn as wd
from common import init_warp, np_dtype, seed_model


def quantities(model, data, tau, forces):
    out = {
        "forward_kinematics": wd.model.forward_kinematics(model, data),
        "jacobians": wd.model.generalized_free_floating_jacobian(model, data),
        "mass_matrix": wd.model.free_floating_mass_matrix(model, data),
        "bias_forces": wd.model.free_floating_bias_forces(model, data),
        "mass_matrix_inverse": wd.model.free_floating_mass_matrix_inverse(model, data),
    }
    out["aba_base"], out["aba_joints"] = wd.model.forward_dynamics_aba(model, data, joint_forces=tau, link_forces=forces)
    out["crb_base"], out["crb_joints"] = wd.model.forward_dynamics_crb(model, data, joint_forces=tau, link_forces=forces)
    out["rnea_base"], out["rnea_joints"] = wd.model.inverse_dynamics(model, data, joint_accelerations=tau, link_forces=forces)
    for repr in (wd.VelRepr.Body, wd.VelRepr.Inertial):
        with data.switch_velocity_representation(repr):
            out[f"jacobians_{repr.name}"] = wd.model.generalized_free_floating_jacobian(model, data)
            out[f"mass_matrix_{repr.name}"] = wd.model.free_floating_mass_matrix(model, data)
    return {k: v.numpy() for k, v in out.items()}


def main() -> int:
    init_warp()
    if not wp.is_cuda_available():
        print("no CUDA device: nothing to compare")
        return 0
    N = 257
    failures = 0
    for dtype_name, tol in (("float64", 1e-9), ("float32", 1e-3)):
        results = {}
        for device in ("cpu", "cuda:0"):
            model = seed_model(np_dtype[dtype_name], device)
            data = wd.data.random_model_data(model, num_envs=N, seed=3)
            rng = np.random.default_rng(4)
            tau = rng.uniform(-5, 5, (N, model.dofs()))
            forces = rng.uniform(-5, 5, (N, model.number_of_links(), 6))
            results[device] = quantities(model, data, tau, forces)
        for name, cpu in results["cpu"].items():
            error = float(np.max(np.abs(results["cuda:0"][name] - cpu) / (1.0 + np.abs(cpu))))
            ok = error <= tol
            failures += not ok
            print(f"{dtype_name} {name:28s} max rel diff {error:.2e} {'ok' if ok else 'FAIL'}")
    print(f"{failures} failed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
