"""The launches of JaxSim's hardware parametrisation (kernels/hardware.py): a model's link parameters and joint
origins from scaling factors, recorded by a tape."""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.hardware import kernels as hardware_kernels
from .launch import launch

__all__ = ["hw_parameters"]


def hw_parameters(model, metadata, dims: wp.array, density: wp.array) -> dict:
    """{"link_mass" (P, nL), "link_com" (P, nL) vec3, "link_inertia" (P, nL) mat33, "positions" (Pd, nj, 3), "points"
    (Pd, nc_all) vec3}: the model's link parameters, joint origins and collidable points (every one, in the link
    frame) after scaling its links' geometry by dims (Pd, nL, 3) and their densities by density (1 or P, nL)
    (Pd, P: 1 shared, or one row per environment; P the larger; warpdyn.types.hardware's metadata); the link
    parameters in the device's layout of per-environment arrays; outputs require gradients when an input does."""
    s, d = model.scalar, model.device
    vec3, mat33 = wp.types.vector(3, s), wp.types.matrix((3, 3), s)
    grad = dims.requires_grad or density.requires_grad
    nL, nj = model.number_of_links(), model.number_of_joints()
    shape, geometry, rho, L_R_G, L_p_G, parent, L_p_pre = model.cached("hw parameter constants", lambda: _constants(model, metadata))
    P, Pd = max(dims.shape[0], density.shape[0]), dims.shape[0]  # the origins and points follow the shapes only
    out = {
        "link_mass": arrays.empty((nL,), P, s, d, grad),
        "link_com": arrays.empty((nL,), P, vec3, d, grad),
        "link_inertia": arrays.empty((nL,), P, mat33, d, grad),
        "positions": wp.zeros((Pd, nj, 3), dtype=s, device=d, requires_grad=grad),
    }
    kernels = hardware_kernels(s)
    launch(
        kernels.link_parameters,
        dim=(P, nL),
        inputs=[shape, geometry, rho, L_R_G, L_p_G, dims, density,
                model.link_mass, model.link_com, model.link_inertia],
        outputs=[out["link_mass"], out["link_com"], out["link_inertia"]],
        device=d,
    )
    body, point = model.cached("hw points", lambda: _points(model))
    out["points"] = wp.empty((Pd, body.shape[0]), dtype=vec3, device=d, requires_grad=grad)
    if body.shape[0]:
        launch(kernels.collidable_points, dim=(Pd, body.shape[0]), inputs=[body, point, shape, geometry, L_R_G, dims, model.link_com, out["link_com"]], outputs=[out["points"]], device=d)
    if nj:
        launch(
            kernels.joint_positions,
            dim=(Pd, nj),
            inputs=[parent, shape, L_R_G, L_p_G, L_p_pre, dims],
            outputs=[out["positions"]],
            device=d,
        )
    return out


def _points(model) -> tuple:
    """(body (nc_all,) int, L_p_C (nc_all,) vec3): every collidable point's link and position, on the device."""
    contact = model.kin_dyn_structure().contact_parameters
    vec3 = wp.types.vector(3, model.scalar)
    body = wp.array(np.asarray(contact.body, dtype=np.int32), dtype=int, device=model.device)
    return body, wp.array(np.asarray(contact.point, dtype=np.float64).reshape(-1, 3), dtype=vec3, device=model.device)


def _constants(model, metadata) -> tuple:
    """The metadata on the device, once per model version: shape, geometry, density, L_R_G, L_p_G (per link), the
    joints' parents and L_p_pre (per joint)."""
    s, d = model.scalar, model.device
    vec3, mat33 = wp.types.vector(3, s), wp.types.matrix((3, 3), s)

    def constant(values, dtype):
        return wp.array(np.ascontiguousarray(values, dtype=np.float64), dtype=dtype, device=d)

    return (
        wp.array(metadata.link_shape, dtype=int, device=d),
        constant(metadata.geometry, vec3),
        constant(metadata.density, s),
        constant(metadata.L_H_G[:, :3, :3], mat33),
        constant(metadata.L_H_G[:, :3, 3], vec3),
        wp.array(metadata.joint_parent, dtype=int, device=d),
        constant(metadata.L_H_pre[:, :3, 3], vec3),
    )
