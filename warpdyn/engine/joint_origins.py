"""Joint origins as kinematic parameters: each joint's frame in its parent link (URDF's joint <origin>), from which
the kernels' joint terms are computed on the device (kernels/joints.py's `joint_terms_from_origins`), recorded by
a wp.Tape so that gradients reach the origins through every function that moves a link.

The origins of joints 0 .. nj - 1 (joint j moves link j + 1) are shared by the environments or given per
environment; the base's terms (link 0) are kept.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.joints import joints as joint_kernels
from ..types.model_constants import JOINT_TERMS, quaternion_xyzw
from .launch import launch

__all__ = ["origins_of", "joint_terms"]


def origins_of(tree) -> tuple[np.ndarray, np.ndarray]:
    """(positions (nj, 3) [m], rotations (nj, 4) (w, x, y, z)): each joint's frame in its parent link, the
    tree's parent_H_joint of links 1 .. nL - 1 (float64)."""
    H = np.asarray(tree.parent_H_joint, dtype=np.float64)[1:]
    xyzw = np.array([quaternion_xyzw(R) for R in H[:, :3, :3]]).reshape(-1, 4)
    return H[:, :3, 3].copy(), np.concatenate([xyzw[:, 3:], xyzw[:, :3]], axis=1)


def joint_terms(model, positions: wp.array, rotations: wp.array, P: int) -> dict:
    """{name: (P, nL) array} of JOINT_TERMS from the joints' positions (1 or P, nj, 3) and rotations (1 or P, nj, 4)
    (w, x, y, z) in the model's scalar, P = 1 (shared) or N (per environment, environment-fastest on a GPU as the
    other per-environment parameters), the base's terms (link 0) the model's (constant): one launch, no copy through
    the host (a tape records it; the outputs require gradients when an input does)."""
    d, tree = model.device, model.tree
    grad = positions.requires_grad or rotations.requires_grad
    nL = tree.number_of_links
    out = {name: arrays.empty((nL,), P, getattr(model, name).dtype, d, requires_grad=grad) for name in JOINT_TERMS}
    axis, pivot = model.cached("joint axes and pivots", lambda: _axes_and_pivots(model))
    launch(
        joint_kernels(model.scalar, model.multi_dof()).joint_terms_from_origins,
        dim=(P, nL),
        inputs=[model.joint_type, positions, rotations, axis, pivot, model.joint_Q0, model.joint_t0],
        outputs=[out[name] for name in JOINT_TERMS],
        device=d,
    )
    return out


def _axes_and_pivots(model) -> tuple:
    """(axis, pivot): each link's joint axis and pivot (nL,) vec3 [child frame] on the model's device."""
    vec3 = wp.types.vector(3, model.scalar)
    return tuple(wp.array(np.asarray(v, dtype=np.float64), dtype=vec3, device=model.device) for v in (model.tree.joint_axis, model.tree.joint_pivot))
