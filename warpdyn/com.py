"""Centre-of-mass and centroidal quantities, as JaxSim's `jaxsim.api.com`: every function takes (model, data).

The centroidal frame G has its origin at the CoM, W_p_CoM, and the world's orientation, G[W], when the
data's velocity representation is Inertial or Mixed, or the base's orientation, G[B], when it is Body.
Momenta are 6D forces [linear; angular] with the angular part about the CoM; velocities are 6D
velocities of the frame G; Jacobians take ν in the data's representation.

Results are Warp arrays on the model's device: JaxSim's shapes for single-environment data, a
leading N axis for batched data. The kernels are in warpdyn.kernels.centroidal, launched by warpdyn.engine.centroidal.
"""

from __future__ import annotations


from . import arrays
from .engine import centroidal, derivatives
from .engine.kinematics import link_targets
from .types.enums import VelRepr

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


def com_position(model, data):
    """W_p_CoM: (3,) or (N, 3) [m]."""
    return arrays.squeeze_env(centroidal.com_position(model, data, centroidal.sums(model, data)), data.num_envs)


def com_linear_velocity(model, data):
    """The CoM's velocity in G's axes: W_pdot_CoM (G[W]) or B_R_W W_pdot_CoM (G[B]): (3,) or (N, 3) [m/s].

    The linear part of average_centroidal_velocity, i.e. the linear momentum over the total mass.
    """
    S = centroidal.sums(model, data)
    out = centroidal.velocity_in(model, data, S, centroidal.centroidal_frame(data), rows=3)
    return arrays.squeeze_env(out, data.num_envs)


def centroidal_momentum(model, data):
    """G_h: the total momentum in G (angular part about the CoM): (6,) or (N, 6) [kg m/s; kg m^2/s];
    equal to centroidal_momentum_jacobian(model, data) @ ν."""
    S = centroidal.sums(model, data)
    return arrays.squeeze_env(centroidal.force_in(model, data, S, centroidal.centroidal_frame(data)), data.num_envs)


def centroidal_momentum_jacobian(model, data):
    """J_CMM, the centroidal momentum matrix: (6, 6 + n) or (N, 6, 6 + n), G_h = J_CMM ν."""
    S = centroidal.sums(model, data)
    J = centroidal.jacobian_in(model, data, S, centroidal.centroidal_frame(data), average=False)
    return arrays.squeeze_env(J, data.num_envs)


def locked_centroidal_spatial_inertia(model, data):
    """G_M, the locked spatial inertia in G: blockdiag(m 1, I_CoM) in G's axes: (6, 6) or (N, 6, 6)."""
    S = centroidal.sums(model, data)
    M = centroidal.inertia_in(model, data, S, centroidal.centroidal_frame(data))
    return arrays.squeeze_env(M, data.num_envs)


def average_centroidal_velocity(model, data):
    """G_v = G_M^-1 G_h, the average velocity as a velocity of G: (6,) or (N, 6) [m/s; rad/s]."""
    S = centroidal.sums(model, data)
    v = centroidal.velocity_in(model, data, S, centroidal.centroidal_frame(data))
    return arrays.squeeze_env(v, data.num_envs)


def average_centroidal_velocity_jacobian(model, data):
    """G_M^-1 J_CMM: (6, 6 + n) or (N, 6, 6 + n), G_v = J ν."""
    S = centroidal.sums(model, data)
    J = centroidal.jacobian_in(model, data, S, centroidal.centroidal_frame(data), average=True)
    return arrays.squeeze_env(J, data.num_envs)


def bias_acceleration(model, data):
    """The CoM's bias acceleration: its acceleration at ν̇ = 0 (ν in the data's representation), in
    G's axes as com_linear_velocity: (3,) or (N, 3) [m/s^2].

    Σ_L m_L W_pddot_CL / m with every link's body-fixed bias acceleration J̇ν (warpdyn.engine.derivatives),
    as JaxSim's `com.bias_acceleration`. (JaxSim's text builds G[B] by `.at[0:3].set(W_p_CoM)`, which
    overwrites the rotation rows as well; this uses G[B] = (W_p_CoM, [B]) as its docstring says.)
    """
    S = centroidal.sums(model, data)
    a_body = derivatives.bias_accelerations(model, data, link_targets(model), VelRepr.Body)
    return arrays.squeeze_env(centroidal.com_bias_acceleration(model, data, S, a_body), data.num_envs)

