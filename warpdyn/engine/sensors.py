"""Sensors that read the world around a robot: the height scan (kernels/height_scan.py)."""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.height_scan import kernels as scan_kernels
from .launch import launch
from .step import plan

__all__ = ["height_scan"]


def height_scan(model, data, pattern: wp.array, out: wp.array | None = None) -> wp.array:
    """(N, P) [m]: the height of `model.terrain` under each point of `pattern` (P, 2) [m] (a Warp array of the
    model's dtype on its device) in each environment's base yaw frame, around its base, into `out` (N, P) when given
    (else a new array; gradients reach the base pose and a heightfield's heights under a tape)."""
    current = plan(model)
    N, P = data.batch_size, pattern.shape[0]
    current.check_envs(N)
    if out is None:
        out = arrays.output((P,), N, model.scalar, model.device, data.requires_grad)
    launch(
        scan_kernels(model.scalar).height_scan,
        dim=(N, P),
        inputs=[current.terrain, data.base_position_state, data.base_quaternion_state, pattern],
        outputs=[out],
        device=model.device,
    )
    return out
