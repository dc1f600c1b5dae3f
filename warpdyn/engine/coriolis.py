"""The free-floating Coriolis matrix behind JaxSim's `free_floating_coriolis_matrix` (warpdyn.model).

    M(q) nu_dot + C(q, nu) nu + g(q) = B tau + sum_L J_L^T f_L,

with nu in the data's velocity representation. C is JaxSim's choice among the matrices with C nu = h - g
(the one built from the body-frame link terms, see warpdyn.kernels.coriolis), for which Mdot - 2C is
skew-symmetric, Mdot being the time derivative of M along the motion. It is computed without Jacobians,
by composite inertias and O(n^2) dot products (Echeandia and Wensing, 2021), in two kernel launches,
and is differentiable by wp.Tape (every element is written once).

Fixed-base models: warpdyn's free_floating_mass_matrix, free_floating_bias_forces and
free_floating_gravity_forces keep the base rows (the base treated as a floating base at rest; h's base
rows are the wrench the world exerts on the base). C follows them: it is the floating-base matrix at
zero base velocity, so that C nu = h - g and the skew-symmetry of Mdot - 2C hold in every row. Its joint
block equals JaxSim's. JaxSim instead drops the base link's term and zeroes the base-joint blocks, to
match its RNEA, which returns a zero base force for fixed bases; the base rows and columns of JaxSim's
C differ from these, and multiply a base velocity that is zero.
"""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.coriolis import kernels as coriolis_kernels
from ..types.data_checks import check_data
from .bundles import model_bundle
from .bundles import requires_grad
from .kinematics import state_of
from .launch import launch

__all__ = ["coriolis_matrix"]


def coriolis_matrix(model, data) -> wp.array:
    """C(q, nu): (N, 6 + nv, 6 + nv), in the data's representation.

    Rows are generalized forces dual to nu (base rows: the base wrench in the representation's frame,
    [N; N m]), columns act on nu (base: the base velocity in the data's representation); C nu = h - g.
    Units: those of M (kg, kg m, kg m^2) per second.
    """
    check_data(model, data, parameters=True)
    s, d, rg = model.scalar, model.device, requires_grad(model, data)
    N, nL, n = data.batch_size, model.number_of_links(), model.dofs()
    transform = wp.types.transformation(s)
    vec6 = wp.types.vector(6, s)
    mat66 = wp.types.matrix((6, 6), s)
    per_dof = [arrays.empty((n + 1,), N, vec6, d, rg) for _ in range(5)]  # S, Sdot, F, f, g at rows d + 1
    C = arrays.output((6 + n, 6 + n), N, s, d, rg)
    k = coriolis_kernels(s, model.multi_dof())
    bundle = model_bundle(model)
    scratch = [
        arrays.empty((nL,), N, transform, d, rg),
        arrays.empty((nL,), N, vec6, d, rg),
        arrays.empty((nL,), N, mat66, d, rg),
        arrays.empty((nL,), N, mat66, d, rg),
    ]
    launch(
        k.coriolis_links,
        dim=N,
        inputs=[bundle, state_of(model, data), int(data.velocity_representation), *scratch],
        outputs=[*per_dof, C],
        device=d,
    )
    if n > 0:
        launch(k.coriolis_joints, dim=(N, n), inputs=[bundle, *per_dof], outputs=[C], device=d)
    return C
