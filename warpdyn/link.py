"""Functions of one link, as JaxSim's `jaxsim.api.link`. Link index 0 is the base.

Results are Warp arrays on the model's device, with a leading N axis for batched data.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from . import arrays
from .engine import centroidal, derivatives, kinematics, sensors
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
    "FrameMotion",
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


class FrameMotion:
    """warpdyn's (not JaxSim's): a frame fixed on a link whose pose and velocity are written into the same buffers at
    each call, for N environments, so that a sensor reads them inside a captured graph (nothing is allocated): an
    IMU on a link (warpdyn.envs.sensors). `link_index`; `position` (3,) [m] and `quaternion` (w, x, y, z) of the
    frame in the link's frame (default: the link's own).

        motion = wd.link.FrameMotion(model, link_index=3, position=[0, 0, 0.05], num_envs=N)
        W_H_F, W_v_WF = motion(data)    # (N, 4, 4); (N, 6) Mixed: the frame origin's velocity, world axes [m/s, rad/s]
    """

    def __init__(self, model, *, link_index: int, position=(0.0, 0.0, 0.0), quaternion=(1.0, 0.0, 0.0, 0.0), num_envs: int = 1):
        i = _names.check_idx("link", model.number_of_links(), link_index)
        p = arrays.host_numbers(position, "position")
        q = arrays.host_numbers(quaternion, "quaternion")
        if p.shape != (3,) or q.shape != (4,) or not (np.all(np.isfinite(p)) and np.all(np.isfinite(q))):
            raise ValueError(f"FrameMotion takes a finite position (3,) [m] and quaternion (4,) (w, x, y, z), got shapes {p.shape} and {q.shape}")
        if abs(np.linalg.norm(q) - 1.0) > 1e-6:
            raise ValueError(f"FrameMotion's quaternion must be a unit quaternion (w, x, y, z), got {q.tolist()}")
        if type(num_envs) is not int or num_envs < 1:
            raise ValueError(f"FrameMotion's num_envs must be an integer >= 1, got {num_envs!r}")
        self.model, self.num_envs = model, num_envs
        frame = wp.types.transformation(model.scalar)(p, (q[1], q[2], q[3], q[0]))
        self._buffers = sensors.frame_motion_buffers(model, i, frame, num_envs)

    def __call__(self, data) -> tuple[wp.array, wp.array]:
        """(W_H_F (N, 4, 4), W_v_WF (N, 6)) at the data's state (N = num_envs), in the same arrays at every call."""
        if data.batch_size != self.num_envs:
            raise ValueError(f"this FrameMotion was made for {self.num_envs} environments, the data holds {data.batch_size}")
        W_H_F, W_v_WF = sensors.frame_motion(self.model, data, self._buffers)
        return W_H_F[:, 0], W_v_WF[:, 0]
