"""Centre-of-mass and centroidal quantities, as JaxSim's `jaxsim.api.com`: every function takes (model, data).

The centroidal frame G has its origin at the CoM, W_p_CoM, and the world's orientation, G[W], when the
data's velocity representation is Inertial or Mixed, or the base's orientation, G[B], when it is Body.
Momenta are 6D forces [linear; angular] with the angular part about the CoM; velocities are 6D
velocities of the frame G; Jacobians take ν in the data's representation.

Results are Warp arrays on the model's device: JaxSim's shapes for single-environment data, a
leading N axis for batched data. The kernels are in warpdyn.kernels.centroidal.
"""

from __future__ import annotations

import warp as wp

from .engine import launch as launching
from . import _centroidal
from . import arrays as _arrays
from ._dynamics import requires_grad
from .types.enums import VelRepr
from .kernels.centroidal import kernels as centroidal_kernels

__all__ = [
    "com_position",
    "com_linear_velocity",
    "centroidal_momentum",
    "centroidal_momentum_jacobian",
    "locked_centroidal_spatial_inertia",
    "average_centroidal_velocity",
    "average_centroidal_velocity_jacobian",
    "bias_acceleration",
]


def _sums(model, data):
    return _centroidal.sums(model, data)


def com_position(model, data):
    """W_p_CoM: (3,) or (N, 3) [m]."""
    S = _sums(model, data)
    out = _arrays.output((3,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launching.launch(
        centroidal_kernels(model.scalar).com_output,
        dim=data.batch_size,
        inputs=[S.W_p_G],
        outputs=[out],
        device=model.device,
    )
    return _arrays.squeeze_env(out, data.num_envs)


def com_linear_velocity(model, data):
    """The CoM's velocity in G's axes: W_pdot_CoM (G[W]) or B_R_W W_pdot_CoM (G[B]): (3,) or (N, 3) [m/s].

    The linear part of average_centroidal_velocity, i.e. the linear momentum over the total mass.
    """
    S = _sums(model, data)
    out = _centroidal.velocity_in(model, data, S, _centroidal.centroidal_frame(data), rows=3)
    return _arrays.squeeze_env(out, data.num_envs)


def centroidal_momentum(model, data):
    """G_h: the total momentum in G (angular part about the CoM): (6,) or (N, 6) [kg m/s; kg m^2/s];
    equal to centroidal_momentum_jacobian(model, data) @ ν."""
    S = _sums(model, data)
    return _arrays.squeeze_env(_centroidal.force_in(model, data, S, _centroidal.centroidal_frame(data)), data.num_envs)


def centroidal_momentum_jacobian(model, data):
    """J_CMM, the centroidal momentum matrix: (6, 6 + n) or (N, 6, 6 + n), G_h = J_CMM ν."""
    S = _sums(model, data)
    J = _centroidal.jacobian_in(model, data, S, _centroidal.centroidal_frame(data), average=False)
    return _arrays.squeeze_env(J, data.num_envs)


def locked_centroidal_spatial_inertia(model, data):
    """G_M, the locked spatial inertia in G: blockdiag(m 1, I_CoM) in G's axes: (6, 6) or (N, 6, 6)."""
    S = _sums(model, data)
    M = _centroidal.inertia_in(model, data, S, _centroidal.centroidal_frame(data))
    return _arrays.squeeze_env(M, data.num_envs)


def average_centroidal_velocity(model, data):
    """G_v = G_M^-1 G_h, the average velocity as a velocity of G: (6,) or (N, 6) [m/s; rad/s]."""
    S = _sums(model, data)
    v = _centroidal.velocity_in(model, data, S, _centroidal.centroidal_frame(data))
    return _arrays.squeeze_env(v, data.num_envs)


def average_centroidal_velocity_jacobian(model, data):
    """G_M^-1 J_CMM: (6, 6 + n) or (N, 6, 6 + n), G_v = J ν."""
    S = _sums(model, data)
    J = _centroidal.jacobian_in(model, data, S, _centroidal.centroidal_frame(data), average=True)
    return _arrays.squeeze_env(J, data.num_envs)


def bias_acceleration(model, data):
    """The CoM's bias acceleration: its acceleration at ν̇ = 0 (ν in the data's representation), in
    G's axes as com_linear_velocity: (3,) or (N, 3) [m/s^2].

    Σ_L m_L W_pddot_CL / m with every link's body-fixed bias acceleration J̇ν (warpdyn._derivatives),
    as JaxSim's `com.bias_acceleration`. (JaxSim's text builds G[B] by `.at[0:3].set(W_p_CoM)`, which
    overwrites the rotation rows as well; this uses G[B] = (W_p_CoM, [B]) as its docstring says.)
    """
    from . import _derivatives

    S = _sums(model, data)
    a_body = _derivatives.bias_accelerations(model, data, model.all_links, model.identity_offsets, VelRepr.Body)
    N, nL = data.batch_size, model.number_of_links()
    scratch = _arrays.empty((nL,), N, wp.types.vector(3, model.scalar), model.device, requires_grad(model, data))
    out = _arrays.output((3,), N, model.scalar, model.device, requires_grad(model, data))
    launching.launch(
        centroidal_kernels(model.scalar).com_bias_acceleration,
        dim=N,
        inputs=[model.kernel_parameter("link_mass"), model.kernel_parameter("link_com"), S.W_H_L, S.W_v_WL, a_body, S.mass, _centroidal.centroidal_frame(data)],
        outputs=[scratch, out],
        device=model.device,
    )
    return _arrays.squeeze_env(out, data.num_envs)

