"""Functions of joints, as JaxSim's `jaxsim.api.joint`. Joint i moves link i + 1."""

from __future__ import annotations

import numpy as np

from .types import names as _names

__all__ = ["name_to_idx", "idx_to_name", "names_to_idxs", "idxs_to_names", "position_limit", "position_limits"]


def name_to_idx(model, *, joint_name: str) -> int:
    return _names.name_to_idx("joint", model.joint_names(), joint_name)


def idx_to_name(model, *, joint_index: int) -> str:
    return model.joint_names()[_names.check_idx("joint", model.number_of_joints(), joint_index)]


def names_to_idxs(model, *, joint_names) -> np.ndarray:
    return np.array([name_to_idx(model, joint_name=name) for name in joint_names], dtype=int)


def idxs_to_names(model, *, joint_indices) -> tuple[str, ...]:
    return tuple(idx_to_name(model, joint_index=int(i)) for i in np.asarray(joint_indices).ravel())


def position_limit(model, *, joint_index: int) -> tuple[float, float]:
    """(lower, upper) position limit of one joint [rad or m]; -inf/inf where it has none."""
    lower, upper = model.tree.position_limits[_names.check_idx("joint", model.number_of_joints(), joint_index)]
    return float(lower), float(upper)


def position_limits(model, *, joint_names=None) -> tuple[np.ndarray, np.ndarray]:
    """(lower (k,), upper (k,)) position limits of the named joints (all when None)."""
    idxs = np.arange(model.dofs()) if joint_names is None else names_to_idxs(model, joint_names=joint_names)
    limits = model.tree.position_limits[idxs].reshape(-1, 2)
    return limits[:, 0].copy(), limits[:, 1].copy()
