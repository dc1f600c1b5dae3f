"""Functions of one link, as JaxSim's `jaxsim.api.link`. Link index 0 is the base.

Results are Warp arrays on the model's device, with a leading N axis for batched data.
"""

from __future__ import annotations

import numpy as np

from . import arrays
from .engine import centroidal, derivatives, kinematics
from .types import names as _names

__all__ = [
    "name_to_idx",
    "idx_to_name",
    "names_to_idxs",
    "idxs_to_names",
    "mass",
    "transform",
    "velocity",
    "jacobian",
    "jacobian_derivative",
    "bias_acceleration",
    "spatial_inertia",
    "com_position",
]


def name_to_idx(model, *, link_name: str) -> int:
    return _names.name_to_idx("link", model.link_names(), link_name)


def idx_to_name(model, *, link_index: int) -> str:
    return model.link_names()[_names.check_idx("link", model.number_of_links(), link_index)]


def names_to_idxs(model, *, link_names) -> np.ndarray:
    return np.array([name_to_idx(model, link_name=name) for name in link_names], dtype=int)


def idxs_to_names(model, *, link_indices) -> tuple[str, ...]:
    return tuple(idx_to_name(model, link_index=int(i)) for i in np.asarray(link_indices).ravel())


def mass(model, *, link_index: int):
    """The mass of the link [kg], lumped links included: a float, or (N,) when given per environment."""
    m = model.link_mass.numpy()[..., _names.check_idx("link", model.number_of_links(), link_index)]
    return float(m) if m.ndim == 0 else m.copy()


def _target(model, link_index: int):
    """The link as the kernels' Targets (cached per link on the model)."""
    i = _names.check_idx("link", model.number_of_links(), link_index)
    return model.cached(("link target", i), lambda: kinematics.targets(model, model.all_links[i : i + 1], model.identity_offsets[i : i + 1]))


def transform(model, data, *, link_index: int):
    """W_H_L: (4, 4) or (N, 4, 4)."""
    target = _target(model, link_index)
    return arrays.squeeze_env(kinematics.poses(model, data, target)[:, 0], data.num_envs)


def velocity(model, data, *, link_index: int, output_vel_repr=None):
    """The link's velocity in output_vel_repr (default: the data's): (6,) or (N, 6), [linear; angular]."""
    target = _target(model, link_index)
    return arrays.squeeze_env(kinematics.velocities(model, data, target, output_vel_repr)[:, 0], data.num_envs)


def jacobian(model, data, *, link_index: int, output_vel_repr=None):
    """The link's free-floating Jacobian: (6, 6 + n) or (N, 6, 6 + n).

    Input: the generalized velocity in the data's representation; output: the link velocity in
    output_vel_repr (default: the data's).
    """
    target = _target(model, link_index)
    return arrays.squeeze_env(kinematics.jacobians(model, data, target, output_vel_repr)[:, 0], data.num_envs)


def jacobian_derivative(model, data, *, link_index: int, output_vel_repr=None):
    """The time derivative of the link's free-floating Jacobian along the state's motion: (6, 6 + n) or
    (N, 6, 6 + n). Input: ν in the data's representation; output: output_vel_repr (default: the data's)."""
    target = _target(model, link_index)
    Jdot = derivatives.jacobian_derivatives(model, data, target, output_vel_repr)
    return arrays.squeeze_env(Jdot[:, 0], data.num_envs)


def bias_acceleration(model, data, *, link_index: int):
    """J̇ν of the link in the data's representation: (6,) or (N, 6), [linear; angular] [m/s^2, rad/s^2]."""
    target = _target(model, link_index)
    return arrays.squeeze_env(derivatives.bias_accelerations(model, data, target, None)[:, 0], data.num_envs)


def spatial_inertia(model, *, link_index: int):
    """L_M_L: the link's spatial inertia about its origin in link axes, (6, 6), or (N, 6, 6) with
    per-environment parameters, [linear; angular]: [[m 1, -m c^], [m c^, I_c - m c^ c^]] (lumped links
    included)."""
    i = _names.check_idx("link", model.number_of_links(), link_index)
    M = centroidal.link_spatial_inertia_matrices(model)
    return M[:, i] if M.ndim == 4 else M[i]


def com_position(model, data, *, link_index: int, in_link_frame: bool = True):
    """The link's CoM: L_p_CoM (in_link_frame, the default) or W_p_CoM: (3,) or (N, 3) [m]."""
    i = _names.check_idx("link", model.number_of_links(), link_index)
    return arrays.squeeze_env(centroidal.link_com_position(model, data, i, bool(in_link_frame)), data.num_envs)
