"""Functions of one frame, as JaxSim's `jaxsim.api.frame`.

Frames are the links lumped into their parents. Frame indices follow the link indices: the frame k
of `model.frame_names()` has index number_of_links() + k.
"""

from __future__ import annotations

import numpy as np

from . import arrays
from .engine import derivatives, kinematics
from .types import names as _names

__all__ = [
    "idx_of_parent_link",
    "name_to_idx",
    "idx_to_name",
    "names_to_idxs",
    "idxs_to_names",
    "transform",
    "velocity",
    "jacobian",
    "jacobian_derivative",
]


def _row(model, frame_index) -> int:
    return _names.check_idx("frame", model.number_of_frames(), frame_index, model.number_of_links()) - model.number_of_links()


def idx_of_parent_link(model, *, frame_index: int) -> int:
    return int(model.tree.frame_parent[_row(model, frame_index)])


def name_to_idx(model, *, frame_name: str) -> int:
    return _names.name_to_idx("frame", model.frame_names(), frame_name, model.number_of_links())


def idx_to_name(model, *, frame_index: int) -> str:
    return model.frame_names()[_row(model, frame_index)]


def names_to_idxs(model, *, frame_names) -> np.ndarray:
    return np.array([name_to_idx(model, frame_name=name) for name in frame_names], dtype=int)


def idxs_to_names(model, *, frame_indices) -> tuple[str, ...]:
    return tuple(idx_to_name(model, frame_index=int(i)) for i in np.asarray(frame_indices).ravel())


def _target(model, frame_index: int):
    """The frame as the kernels' Targets (cached per frame on the model)."""
    k = _row(model, frame_index)
    return model.cached(("frame target", k), lambda: kinematics.targets(model, model.frame_parent[k : k + 1], model.link_H_frame[k : k + 1]))


def transform(model, data, *, frame_index: int):
    """W_H_F: (4, 4) or (N, 4, 4)."""
    target = _target(model, frame_index)
    return arrays.squeeze_env(kinematics.poses(model, data, target)[:, 0], data.num_envs)


def velocity(model, data, *, frame_index: int, output_vel_repr=None):
    """The frame's velocity in output_vel_repr (default: the data's): (6,) or (N, 6)."""
    target = _target(model, frame_index)
    return arrays.squeeze_env(kinematics.velocities(model, data, target, output_vel_repr)[:, 0], data.num_envs)


def jacobian(model, data, *, frame_index: int, output_vel_repr=None):
    """The frame's free-floating Jacobian: (6, 6 + n) or (N, 6, 6 + n) (input: the data's representation)."""
    target = _target(model, frame_index)
    return arrays.squeeze_env(kinematics.jacobians(model, data, target, output_vel_repr)[:, 0], data.num_envs)


def jacobian_derivative(model, data, *, frame_index: int, output_vel_repr=None):
    """The time derivative of the frame's free-floating Jacobian along the state's motion: (6, 6 + n) or
    (N, 6, 6 + n). Input: ν in the data's representation; output: output_vel_repr (default: the data's)."""
    target = _target(model, frame_index)
    Jdot = derivatives.jacobian_derivatives(model, data, target, output_vel_repr)
    return arrays.squeeze_env(Jdot[:, 0], data.num_envs)
