"""JaxSim 0.9.0's hardware parametrisation of tests/jaxsim/hw_leg.sdf into tests/jaxsim/hardware.npz, float64:
the link masses, centres of mass, inertias (link axes), joint origins (λ_H_pre) and collidable points after `update_hw_parameters`
with the scaling factors stored beside them, and jax.grad, with respect to the dims and density factors, of
f = sum(W * M(q)) (the free-floating mass matrix, Mixed, at the stored state, weighted by the stored W) through
update_hw_parameters.

Run from the repository's root where JaxSim 0.9.0 is installed: `python tests/jaxsim/generate_hardware.py`.
Not run by the tests or CI.
"""

from __future__ import annotations

import pathlib

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]


def main() -> None:
    import jax
    import jax.numpy as jnp

    jax.config.update("jax_enable_x64", True)
    import jaxsim.api as js

    model = js.model.JaxSimModel.build_from_model_description((ROOT / "tests/jaxsim/hw_leg.sdf").read_text())
    nL, n = model.number_of_links(), model.dofs()
    rng = np.random.default_rng(0)
    dims = rng.uniform(0.8, 1.3, (nL, 3))
    density = rng.uniform(0.7, 1.5, nL)
    q = rng.uniform(-0.5, 0.5, n)
    W = rng.normal(size=(6 + n, 6 + n))
    base_quaternion = np.array([0.9, 0.1, -0.2, 0.3]) / np.linalg.norm([0.9, 0.1, -0.2, 0.3])
    data = js.data.JaxSimModelData.build(model=model, base_position=jnp.array([0.1, -0.2, 0.8]), base_quaternion=jnp.array(base_quaternion),
                                        joint_positions=jnp.array(q))
    factors = js.kin_dyn_parameters.ScalingFactors(dims=jnp.array(dims), density=jnp.array(density))
    updated = js.model.update_hw_parameters(model, factors)
    links = updated.kin_dyn_parameters.link_parameters

    def f(dims, density):
        moved = js.model.update_hw_parameters(model, js.kin_dyn_parameters.ScalingFactors(dims=dims, density=density))
        return jnp.sum(jnp.array(W) * js.model.free_floating_mass_matrix(moved, data))

    value, (g_dims, g_density) = jax.value_and_grad(f, argnums=(0, 1))(jnp.array(dims), jnp.array(density))
    np.savez(
        ROOT / "tests/jaxsim/hardware.npz",
        link_names=np.array(model.link_names()),
        joint_names=np.array(model.joint_names()),
        dims=dims,
        density=density,
        mass=np.asarray(links.mass),
        com=np.asarray(links.center_of_mass),
        inertia=np.asarray(jax.vmap(js.kin_dyn_parameters.LinkParameters.inertia_tensor)(links)),
        L_H_pre=np.asarray(updated.kin_dyn_parameters.joint_model.λ_H_pre[1:]),
        points=np.asarray(updated.kin_dyn_parameters.contact_parameters.point),
        points_before=np.asarray(model.kin_dyn_parameters.contact_parameters.point),
        joint_positions=q,
        base_position=np.array([0.1, -0.2, 0.8]),
        base_quaternion=base_quaternion,
        W=W,
        f=np.asarray(value),
        grad_dims=np.asarray(g_dims),
        grad_density=np.asarray(g_density),
    )
    print(f"f = {float(value):.6g}; |grad dims| = {np.abs(np.asarray(g_dims)).max():.3g}")


if __name__ == "__main__":
    main()
