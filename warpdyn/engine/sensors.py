"""Sensors: the height scan around each base (kernels/height_scan.py), and a frame's pose and velocity written
into given buffers (an IMU on a link), so that both run inside captured graphs without allocating."""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.height_scan import kernels as scan_kernels
from ..kernels.kinematics import kernels as kinematics_kernels
from ..kernels.velocities import kernels as velocity_kernels
from ..types.data_checks import check_data
from ..types.enums import VelRepr
from .bundles import model_bundle
from .kinematics import state_of, targets
from .launch import launch
from .step import plan

__all__ = ["height_scan", "frame_motion_buffers", "frame_motion"]


def height_scan(model, data, pattern: wp.array, out: wp.array | None = None) -> wp.array:
    """(N, P) [m]: the height of `model.terrain` under each point of `pattern` (P, 2) [m] (a Warp array of the
    model's dtype on its device) in each environment's base yaw frame, around its base, into `out` (N, P) when given
    (else a new array; gradients reach the base pose and a heightfield's heights under a tape)."""
    current = plan(model)
    N, P = data.batch_size, pattern.shape[0]
    current.check_envs(N)
    if out is None:
        out = arrays.output((P,), N, model.scalar, model.device, data.requires_grad or model.parameters_require_grad(("terrain",)))
    launch(
        scan_kernels(model.scalar).height_scan,
        dim=(N, P),
        inputs=[current.terrain, data.base_position_state, data.base_quaternion_state, pattern],
        outputs=[out],
        device=model.device,
    )
    return out


def frame_motion_buffers(model, link: int, link_H_frame, N: int) -> dict:
    """The buffers of `frame_motion` for N environments: the frame (a Targets bundle of one frame on link `link` at
    link_H_frame, a Warp transform of the model's dtype), the links' poses and velocities (N, nL), and the outputs
    W_H_F (N, 1, 4, 4) and its Mixed velocity (N, 1, 6)."""
    s, d, nL = model.scalar, model.device, model.number_of_links()
    transform = wp.types.transformation(s)
    return dict(
        target=targets(model, wp.array([link], dtype=int, device=d), wp.array([link_H_frame], dtype=transform, device=d)),
        parent_H_link=arrays.empty((nL,), N, transform, d),
        W_H_L=arrays.empty((nL,), N, transform, d),
        W_v_WL=arrays.empty((nL,), N, wp.types.vector(6, s), d),
        W_H_F=arrays.empty((1, 4, 4), N, s, d),
        W_v_WF=arrays.empty((1, 6), N, s, d),
    )


def frame_motion(model, data, buffers: dict) -> tuple[wp.array, wp.array]:
    """(W_H_F (N, 1, 4, 4), W_v_WF (N, 1, 6) [m/s, rad/s], Mixed: the frame origin's velocity and the link's angular
    velocity, world axes) of the frame of `buffers` (`frame_motion_buffers`) at the data's state: forward kinematics,
    the links' velocities and the frame's pose, three launches into the buffers."""
    check_data(model, data)
    model_args, state = model_bundle(model), state_of(model, data)
    kinematics = kinematics_kernels(model.scalar, model.multi_dof())
    N, b = data.batch_size, buffers
    launch(kinematics.forward_kinematics, dim=N, inputs=[model_args, state], outputs=[b["parent_H_link"], b["W_H_L"]], device=model.device)
    launch(
        velocity_kernels(model.scalar, model.multi_dof()).link_velocities,
        dim=N,
        inputs=[model_args, b["target"], b["W_H_L"], state, int(VelRepr.Mixed)],
        outputs=[b["W_v_WL"], b["W_v_WF"]],
        device=model.device,
    )
    launch(kinematics.homogeneous_matrices, dim=(N, 1), inputs=[b["W_H_L"], b["target"]], outputs=[b["W_H_F"]], device=model.device)
    return b["W_H_F"], b["W_v_WF"]
