"""JaxSim 0.9.0's kinematic constraints on tests/jaxsim/constraint_cases.py's mechanisms into
tests/jaxsim/constraints.npz, float64 (jax_enable_x64): each case's trajectory twice,
- `released/<case>/<quantity>`: JaxSim 0.9.0 as released;
- `<case>/<quantity>`: JaxSim with three corrections to jaxsim.rbda.kinematic_constraints, the equations warpdyn
  solves (kernels/equality.py's frame weld):
  1. the frames' Jacobians take the generalized velocity in the representation the solve multiplies them with
     (Mixed: js.frame.jacobian with the data in Mixed); JaxSim's take a Body-fixed base velocity (its doubly-left
     Jacobian, only the output converted) and are multiplied with Mixed ones, which differs once the base turns;
  2. on a fixed base, M^-1 of the joints alone (the base's block 0): JaxSim inverts the floating-base mass
     matrix, so its solve lets the fixed base move (the weld's rows have non-zero base columns);
  3. the rotation residual in world axes, R_F2 log(R_F2^T R_F1), as the rows' angular velocities: JaxSim's
     log(R_F2^T R_F1) is in F2's axes, which turns its pull away from the error once F2 turns from the world's axes.
Prints the weld's error of both every constraint_cases.EVERY steps.

Run from the repository's root where JaxSim 0.9.0 is installed: `python tests/jaxsim/generate_constraints.py`.
Not run by the tests or CI.
"""

from __future__ import annotations

import pathlib
import sys

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "jaxsim"))

import constraint_cases  # noqa: E402


def corrected(js, kc):
    """Replace kinematic_constraints' Jacobians, Baumgarte term and the mass matrix inverse it calls with the
    corrected ones (the module docstring); returns a function that puts JaxSim's back."""
    import jax
    import jax.numpy as jnp
    from jaxsim.math.rotation import Rotation

    Mixed = js.common.VelRepr.Mixed
    released = (kc._compute_constraint_jacobians_batched, kc._compute_constraint_baumgarte_term, js.model.free_floating_mass_matrix_inverse)

    def jacobians(model, data, constraints, W_H_constraint_pairs):
        with data.switch_velocity_representation(Mixed):

            def frame(index):
                return js.frame.jacobian(model=model, data=data, frame_index=index, output_vel_repr=Mixed)

            return jax.vmap(frame)(constraints.frame_idxs_1) - jax.vmap(frame)(constraints.frame_idxs_2)

    def baumgarte(J_constr, nu, W_H_F_constr, constraint):
        W_H_F1, W_H_F2 = W_H_F_constr
        rotation = W_H_F2[0:3, 0:3] @ Rotation.log_vee(W_H_F2[0:3, 0:3].T @ W_H_F1[0:3, 0:3])
        residual = jnp.concatenate([W_H_F1[0:3, 3] - W_H_F2[0:3, 3], rotation])
        return constraint.K_P * residual + constraint.K_D * (J_constr @ nu)

    def inverse(model, data):
        if model.floating_base():
            return released[2](model=model, data=data)
        M = js.model.free_floating_mass_matrix(model=model, data=data)
        return jnp.zeros_like(M).at[6:, 6:].set(jnp.linalg.inv(M[6:, 6:]))

    kc._compute_constraint_jacobians_batched, kc._compute_constraint_baumgarte_term, js.model.free_floating_mass_matrix_inverse = jacobians, baumgarte, inverse

    def restore():
        kc._compute_constraint_jacobians_batched, kc._compute_constraint_baumgarte_term, js.model.free_floating_mass_matrix_inverse = released

    return restore


def main() -> None:
    import jax

    jax.config.update("jax_enable_x64", True)
    import jaxsim
    import jaxsim.api as js
    import jaxsim.rbda.kinematic_constraints as kc

    out = {"jaxsim_version": np.array(jaxsim.__version__)}
    for prefix in ("released/", ""):
        restore = corrected(js, kc) if not prefix else None
        for name in constraint_cases.CASES:
            jax.clear_caches()  # compute_constraint_wrenches is jitted: trace it again with the functions in place
            model = constraint_cases.build(js, name)
            for key, value in constraint_cases.rollout(js, model, name).items():
                out[f"{prefix}{name}/{key}"] = value
            error = constraint_cases.weld_error({k[len(prefix):]: v for k, v in out.items() if k.startswith(prefix)}, name)
            print(f"{prefix or 'corrected/'}{name}: the weld's error every {constraint_cases.EVERY} steps [m, rad]: {np.array2string(error, precision=2)}")
        if restore is not None:
            restore()
    np.savez_compressed(ROOT / "tests" / "jaxsim" / "constraints.npz", **out)


if __name__ == "__main__":
    main()
