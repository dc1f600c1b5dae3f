"""External link forces: their representation, and forces on targets moved to their links
(kernels/forces.py), behind warpdyn.references."""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.forces import kernels as force_kernels
from .kinematics import link_poses, targets
from .launch import launch

__all__ = ["forces_in", "forces_inertial", "with_target_forces"]


def forces_in(model, data, W_f_L: wp.array, repr: int) -> wp.array:
    """(N, nL, 6): the Inertial link forces W_f_L in representation `repr` (each link its body frame)."""
    return _converted(model, data, W_f_L, repr, 0)


def forces_inertial(model, data, f_L: wp.array, repr: int) -> wp.array:
    """(N, nL, 6): the link forces f_L, given in representation `repr`, Inertial."""
    return _converted(model, data, f_L, repr, 1)


def _converted(model, data, f: wp.array, repr: int, to_inertial: int) -> wp.array:
    _, W_H_L = link_poses(model, data)
    out = arrays.output(f.shape[1:], f.shape[0], f.dtype, f.device, data.requires_grad or f.requires_grad or W_H_L.requires_grad)
    launch(force_kernels(f.dtype).convert_link_forces, dim=(f.shape[0], f.shape[1]), inputs=[W_H_L, f, int(repr), to_inertial], outputs=[out], device=f.device)
    return out


def with_target_forces(model, data, W_f_L: wp.array, links: np.ndarray, link_H_target: wp.array, values: wp.array, repr: int, additive: bool) -> wp.array:
    """(N, nL, 6) Inertial link forces: W_f_L with the forces `values` (N, T, 6), given in `repr` on T targets
    (target t at link_H_target[t] on link links[t], host indices), replacing those links' forces (or added
    to them when `additive`)."""
    N, T = W_f_L.shape[0], len(links)
    target = targets(model, wp.array(np.asarray(links, dtype=np.int32), dtype=int, device=model.device), link_H_target)
    _, W_H_L = link_poses(model, data)
    grad = data.requires_grad or values.requires_grad or W_f_L.requires_grad or W_H_L.requires_grad
    out = arrays.empty(W_f_L.shape[1:], N, model.scalar, model.device, grad)
    replaced = np.zeros(model.number_of_links(), dtype=np.int32)
    if not additive:
        replaced[links] = 1
    K = force_kernels(model.scalar)
    launch(K.kept_forces, dim=out.shape, inputs=[W_f_L, wp.array(replaced, dtype=int, device=model.device)], outputs=[out], device=model.device)
    launch(K.add_target_forces, dim=(N, T), inputs=[target, W_H_L, values, int(repr)], outputs=[out], device=model.device)
    return out
