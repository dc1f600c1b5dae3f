"""Momentum, locked inertia, average velocity and energy of the whole model: the launches of
kernels/centroidal.py behind warpdyn.model's and warpdyn.com's functions of those names.

Frames, as in JaxSim: a quantity "in the data's representation" is expressed in the frame of the base
velocity's representation, W (Inertial), B (Body) or B[W] (Mixed, the base origin with the world's
orientation); momenta are 6D forces [linear; angular] (linear momentum [kg m/s]; angular momentum about
the frame's origin [kg m^2/s]), average velocities 6D velocities of that frame. The centroidal frame
G is G[W] = (W_p_CoM, [W]) for Inertial or Mixed data and G[B] = (W_p_CoM, [B]) for Body data.
One pass over the links (`sums`) accumulates the total mass, the CoM, the rotational inertia about the
CoM, the centroidal momentum and the kinetic energy; the Jacobians add one backward pass of composite
inertias. Results have a leading N axis; scalars (energies) are (N,) arrays.
"""

from __future__ import annotations

import types

import warp as wp

from .. import arrays, config
from ..kernels.centroidal import FRAME_GB, FRAME_GW
from ..kernels.centroidal import kernels as centroidal_kernels
from ..types.enums import VelRepr
from ..types.data_checks import check_data
from .bundles import model_bundle
from .bundles import requires_grad
from .kinematics import link_poses, state_of
from .launch import launch

__all__ = [
    "frame_of",
    "centroidal_frame",
    "sums",
    "force_in",
    "velocity_in",
    "inertia_in",
    "jacobian_in",
    "energy",
    "link_spatial_inertia_matrices",
    "link_com_position",
    "com_position",
    "com_bias_acceleration",
    "FRAME_GB",
    "FRAME_GW",
]


def frame_of(velocity_representation) -> int:
    """The output-frame code of a representation's base frame: B, B[W] or W (kernels.centroidal)."""
    return int(VelRepr(velocity_representation))


def centroidal_frame(data) -> int:
    """G[B] for Body data, G[W] otherwise."""
    return FRAME_GB if data.velocity_representation == VelRepr.Body else FRAME_GW


def sums(model, data) -> types.SimpleNamespace:
    """One launch of the centroidal sums: W_H_L, W_v_WL (N, nL) and, per environment (N,), mass,
    W_p_G, G_I (about the CoM, world axes), G_h (centroidal momentum in G[W]) and K."""
    check_data(model, data, parameters=True)
    _, W_H_L = link_poses(model, data)
    N, nL, s, d, g = data.batch_size, model.number_of_links(), model.scalar, model.device, requires_grad(model, data)
    sp = types.SimpleNamespace(
        vec3=wp.types.vector(3, s), vec6=wp.types.vector(6, s), mat33=wp.types.matrix((3, 3), s)
    )
    out = types.SimpleNamespace(
        W_H_L=W_H_L,
        W_v_WL=arrays.empty((nL,), N, sp.vec6, d, g),
        mass=arrays.empty((), N, s, d, g),
        W_p_G=arrays.empty((), N, sp.vec3, d, g),
        G_I=arrays.empty((), N, sp.mat33, d, g),
        G_h=arrays.empty((), N, sp.vec6, d, g),
        K=arrays.output((), N, s, d, g),
    )
    scratch = [
        arrays.empty((nL,), N, sp.vec3, d, g),
        arrays.empty((nL,), N, s, d, g),
        arrays.empty((nL,), N, sp.vec3, d, g),
        arrays.empty((nL,), N, sp.mat33, d, g),
        arrays.empty((nL,), N, sp.vec6, d, g),
        arrays.empty((nL,), N, s, d, g),
    ]
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).centroidal_sums,
        dim=N,
        inputs=[model_bundle(model), W_H_L, state_of(model, data)],
        outputs=[out.W_v_WL, *scratch, out.mass, out.W_p_G, out.G_I, out.G_h, out.K],
        device=d,
    )
    return out


def force_in(model, data, S, frame: int) -> wp.array:
    """(N, 6): the momentum in the frame `frame`."""
    out = arrays.output((6,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).force_output,
        dim=data.batch_size,
        inputs=[state_of(model, data), S.W_p_G, S.G_h, int(frame)],
        outputs=[out],
        device=model.device,
    )
    return out


def velocity_in(model, data, S, frame: int, rows: int = 6) -> wp.array:
    """(N, rows): the first `rows` entries of the average velocity in the frame `frame`."""
    out = arrays.output((rows,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).velocity_output,
        dim=data.batch_size,
        inputs=[state_of(model, data), S.mass, S.W_p_G, S.G_I, S.G_h, int(frame)],
        outputs=[out],
        device=model.device,
    )
    return out


def inertia_in(model, data, S, frame: int) -> wp.array:
    """(N, 6, 6): the locked spatial inertia in the frame `frame`."""
    out = arrays.output((6, 6), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).inertia_output,
        dim=data.batch_size,
        inputs=[state_of(model, data), S.mass, S.W_p_G, S.G_I, int(frame)],
        outputs=[out],
        device=model.device,
    )
    return out


def jacobian_in(model, data, S, frame: int, average: bool) -> wp.array:
    """(N, 6, 6 + n): the momentum Jacobian (or, average, the average-velocity Jacobian) in `frame`;
    columns act on ν in the data's representation."""
    N, nL, s, d, g = data.batch_size, model.number_of_links(), model.scalar, model.device, requires_grad(model, data)
    vec3, mat33 = wp.types.vector(3, s), wp.types.matrix((3, 3), s)
    scratch = [arrays.empty((nL,), N, t, d, g) for t in (s, vec3, mat33, s, vec3, mat33)]
    J = arrays.output((6, 6 + model.dofs()), N, s, d, g)
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).momentum_jacobian,
        dim=N,
        inputs=[
            model_bundle(model),
            S.W_H_L,
            int(data.velocity_representation),
            S.mass,
            S.W_p_G,
            S.G_I,
            int(frame),
            int(bool(average)),
        ],
        outputs=[*scratch, J],
        device=d,
    )
    return J


def energy(model, data, S, kinetic: bool, potential: bool) -> wp.array:
    out = arrays.output((), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).energy_output,
        dim=data.batch_size,
        inputs=[model_bundle(model), S.mass, S.W_p_G, S.K, int(kinetic), int(potential)],
        outputs=[out],
        device=model.device,
    )
    return out


def link_spatial_inertia_matrices(model) -> wp.array:
    """L_M_L: the spatial inertia of every link about its origin in link axes, (nL, 6, 6), or (N, nL, 6, 6)
    when the inertial parameters are given per environment, [linear; angular]: [[m 1, -m c^],
    [m c^, I_c - m c^ c^]] (m [kg], c the CoM in the link frame [m], I_c about the CoM [kg m^2])."""
    nL = model.number_of_links()
    bundle = model_bundle(model)
    P = max(a.shape[0] for a in (bundle.link_mass, bundle.link_com, bundle.link_inertia))
    out = wp.empty((P, nL, 6, 6), dtype=model.scalar, device=model.device, requires_grad=model.parameters_require_grad(("link",)))
    if config.fill_outputs_with_nan:
        out.fill_(float("nan"))
    launch(centroidal_kernels(model.scalar, model.multi_dof()).link_spatial_inertias, dim=(P, nL), inputs=[bundle], outputs=[out], device=model.device)
    return out if model.per_environment_parameters().keys() & {"link_mass", "link_com", "link_inertia"} else out[0]




def link_com_position(model, data, link: int, in_link_frame: bool) -> wp.array:
    """(N, 3): link `link`'s CoM, L_p_CoM (in_link_frame) or W_p_CoM [m]."""
    _, W_H_L = link_poses(model, data)
    out = arrays.output((3,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).link_com_positions,
        dim=data.batch_size,
        inputs=[model_bundle(model), link, int(in_link_frame), W_H_L],
        outputs=[out],
        device=model.device,
    )
    return out


def com_position(model, data, S) -> wp.array:
    """(N, 3): W_p_CoM [m] from the centroidal sums S."""
    out = arrays.output((3,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launch(centroidal_kernels(model.scalar, model.multi_dof()).com_output, dim=data.batch_size, inputs=[S.W_p_G], outputs=[out], device=model.device)
    return out


def com_bias_acceleration(model, data, S, a_body: wp.array) -> wp.array:
    """(N, 3): the CoM bias acceleration [m/s^2] in the centroidal frame's axes, from the sums S and the links'
    body-fixed bias accelerations a_body (N, nL, 6) (see kernels/centroidal.py: com_bias_acceleration)."""
    N, nL, g = data.batch_size, model.number_of_links(), requires_grad(model, data)
    scratch = arrays.empty((nL,), N, wp.types.vector(3, model.scalar), model.device, g)
    out = arrays.output((3,), N, model.scalar, model.device, g)
    launch(
        centroidal_kernels(model.scalar, model.multi_dof()).com_bias_acceleration,
        dim=N,
        inputs=[model_bundle(model), S.W_H_L, S.W_v_WL, a_body, S.mass, centroidal_frame(data)],
        outputs=[scratch, out],
        device=model.device,
    )
    return out
