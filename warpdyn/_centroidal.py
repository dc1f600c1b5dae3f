"""Momentum, locked inertia, average velocity and energy of the whole model: JaxSim's `jaxsim.api.model`
functions of those names, with their signatures (re-exported by warpdyn.model).

Frames, as in JaxSim: a quantity "in the data's representation" is expressed in the frame of the base
velocity's representation, W (Inertial), B (Body) or B[W] (Mixed, the base origin with the world's
orientation); momenta are 6D forces [linear; angular] (linear momentum [kg m/s]; angular momentum about
the frame's origin [kg m^2/s]), average velocities 6D velocities of that frame. The centroidal frame
G is G[W] = (W_p_CoM, [W]) for Inertial or Mixed data and G[B] = (W_p_CoM, [B]) for Body data
(`warpdyn.com`).

Shapes: JaxSim's for single-environment data, a leading N axis for batched data. Scalars (the energies)
are Warp arrays of shape (N,) for batched data and (1,) for single-environment data: Warp has no 0-d
arrays, and a Python float would synchronise the host and leave the tape; read one with
`float(e.numpy()[0])`.

The algorithms are in warpdyn.kernels.centroidal: one pass over the links accumulates the total mass,
the CoM, the rotational inertia about the CoM, the centroidal momentum and the kinetic energy; the
Jacobians add one backward pass of composite inertias.
"""

from __future__ import annotations

import types
import weakref

import numpy as np
import warp as wp

from .engine import launch as launching
from . import arrays as _arrays
from . import config
from . import model as _model
from ._dynamics import mass_parameters_require_grad, requires_grad
from .types.enums import VelRepr, output_repr
from .kernels.centroidal import FRAME_GB, FRAME_GW
from .kernels.centroidal import kernels as centroidal_kernels

__all__ = [
    "link_spatial_inertia_matrices",
    "total_momentum",
    "total_momentum_jacobian",
    "locked_spatial_inertia",
    "average_velocity",
    "average_velocity_jacobian",
    "kinetic_energy",
    "potential_energy",
    "mechanical_energy",
]

_TOPOLOGY: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _topology(model) -> tuple[wp.array, wp.array]:
    """(first_child, next_sibling), each (nL,) int on the model's device, -1 where there is none:
    the smallest-index child of each link, and the next larger-index child of its parent."""
    cached = _TOPOLOGY.get(model)
    if cached is None:
        parent = np.asarray(model.tree.parent)
        nL = len(parent)
        first_child = np.full(nL, -1, dtype=np.int32)
        next_sibling = np.full(nL, -1, dtype=np.int32)
        last_child = {}
        for i in range(1, nL):
            p = int(parent[i])
            if first_child[p] < 0:
                first_child[p] = i
            else:
                next_sibling[last_child[p]] = i
            last_child[p] = i
        cached = (
            wp.array(first_child, dtype=int, device=model.device),
            wp.array(next_sibling, dtype=int, device=model.device),
        )
        _TOPOLOGY[model] = cached
    return cached


def _frame_of(velocity_representation) -> int:
    """The output-frame code of a representation's base frame: B, B[W] or W (kernels.centroidal)."""
    return int(VelRepr(velocity_representation))


def centroidal_frame(data) -> int:
    """G[B] for Body data, G[W] otherwise."""
    return FRAME_GB if data.velocity_representation == VelRepr.Body else FRAME_GW


def sums(model, data) -> types.SimpleNamespace:
    """One launch of the centroidal sums: W_H_L, W_v_WL (N, nL) and, per environment (N,), mass,
    W_p_G, G_I (about the CoM, world axes), G_h (centroidal momentum in G[W]) and K."""
    _model._check_data(model, data, parameters=True)
    _, W_H_L = _model.link_poses(model, data)
    N, nL, s, d, g = data.batch_size, model.number_of_links(), model.scalar, model.device, requires_grad(model, data)
    sp = types.SimpleNamespace(
        vec3=wp.types.vector(3, s), vec6=wp.types.vector(6, s), mat33=wp.types.matrix((3, 3), s)
    )
    out = types.SimpleNamespace(
        W_H_L=W_H_L,
        W_v_WL=_arrays.empty((nL,), N, sp.vec6, d, g),
        mass=_arrays.empty((), N, s, d, g),
        W_p_G=_arrays.empty((), N, sp.vec3, d, g),
        G_I=_arrays.empty((), N, sp.mat33, d, g),
        G_h=_arrays.empty((), N, sp.vec6, d, g),
        K=_arrays.output((), N, s, d, g),
    )
    scratch = [
        _arrays.empty((nL,), N, sp.vec3, d, g),
        _arrays.empty((nL,), N, s, d, g),
        _arrays.empty((nL,), N, sp.vec3, d, g),
        _arrays.empty((nL,), N, sp.mat33, d, g),
        _arrays.empty((nL,), N, sp.vec6, d, g),
        _arrays.empty((nL,), N, s, d, g),
    ]
    launching.launch(
        centroidal_kernels(s).centroidal_sums,
        dim=N,
        inputs=[
            model.parent,
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            model.kernel_parameter("link_mass"),
            model.kernel_parameter("link_com"),
            model.kernel_parameter("link_inertia"),
            W_H_L,
            data.base_velocity_state,
            data.joint_velocities_state,
        ],
        outputs=[out.W_v_WL, *scratch, out.mass, out.W_p_G, out.G_I, out.G_h, out.K],
        device=d,
    )
    return out


def force_in(model, data, S, frame: int) -> wp.array:
    """(N, 6): the momentum in the frame `frame`."""
    out = _arrays.output((6,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launching.launch(
        centroidal_kernels(model.scalar).force_output,
        dim=data.batch_size,
        inputs=[data.base_position_state, data.base_quaternion_state, S.W_p_G, S.G_h, int(frame)],
        outputs=[out],
        device=model.device,
    )
    return out


def velocity_in(model, data, S, frame: int, rows: int = 6) -> wp.array:
    """(N, rows): the first `rows` entries of the average velocity in the frame `frame`."""
    out = _arrays.output((rows,), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launching.launch(
        centroidal_kernels(model.scalar).velocity_output,
        dim=data.batch_size,
        inputs=[data.base_position_state, data.base_quaternion_state, S.mass, S.W_p_G, S.G_I, S.G_h, int(frame)],
        outputs=[out],
        device=model.device,
    )
    return out


def inertia_in(model, data, S, frame: int) -> wp.array:
    """(N, 6, 6): the locked spatial inertia in the frame `frame`."""
    out = _arrays.output((6, 6), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launching.launch(
        centroidal_kernels(model.scalar).inertia_output,
        dim=data.batch_size,
        inputs=[data.base_position_state, data.base_quaternion_state, S.mass, S.W_p_G, S.G_I, int(frame)],
        outputs=[out],
        device=model.device,
    )
    return out


def jacobian_in(model, data, S, frame: int, average: bool) -> wp.array:
    """(N, 6, 6 + n): the momentum Jacobian (or, average, the average-velocity Jacobian) in `frame`;
    columns act on ν in the data's representation."""
    N, nL, s, d, g = data.batch_size, model.number_of_links(), model.scalar, model.device, requires_grad(model, data)
    vec3, mat33 = wp.types.vector(3, s), wp.types.matrix((3, 3), s)
    scratch = [_arrays.empty((nL,), N, t, d, g) for t in (s, vec3, mat33, s, vec3, mat33)]
    J = _arrays.output((6, 6 + model.dofs()), N, s, d, g)
    first_child, next_sibling = _topology(model)
    launching.launch(
        centroidal_kernels(s).momentum_jacobian,
        dim=N,
        inputs=[
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            model.kernel_parameter("link_mass"),
            model.kernel_parameter("link_com"),
            model.kernel_parameter("link_inertia"),
            first_child,
            next_sibling,
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
    out = _arrays.output((), data.batch_size, model.scalar, model.device, requires_grad(model, data))
    launching.launch(
        centroidal_kernels(model.scalar).energy_output,
        dim=data.batch_size,
        inputs=[model.scalar(model.gravity), S.mass, S.W_p_G, S.K, int(kinetic), int(potential)],
        outputs=[out],
        device=model.device,
    )
    return out


# JaxSim's functions ----------------------------------------------------------------------------


def link_spatial_inertia_matrices(model) -> wp.array:
    """L_M_L: the spatial inertia of every link about its origin in link axes, (nL, 6, 6), or (N, nL, 6, 6)
    when the inertial parameters are given per environment, [linear; angular]: [[m 1, -m c^],
    [m c^, I_c - m c^ c^]] (m [kg], c the CoM in the link frame [m], I_c about the CoM [kg m^2])."""
    nL = model.number_of_links()
    args = [model.kernel_parameter(name) for name in ("link_mass", "link_com", "link_inertia")]
    P = max(a.shape[0] for a in args)
    out = wp.empty((P, nL, 6, 6), dtype=model.scalar, device=model.device, requires_grad=mass_parameters_require_grad(model))
    if config.fill_outputs_with_nan:
        out.fill_(float("nan"))
    launching.launch(centroidal_kernels(model.scalar).link_spatial_inertias, dim=(P, nL), inputs=args, outputs=[out], device=model.device)
    return out if model.per_environment_parameters().keys() & {"link_mass", "link_com", "link_inertia"} else out[0]


def total_momentum(model, data) -> wp.array:
    """The total momentum in the data's representation: (6,) or (N, 6), [kg m/s; kg m^2/s].

    Expressed in W, B or B[W] (Inertial, Body, Mixed), the angular part about that frame's origin;
    equal to total_momentum_jacobian(model, data) @ ν.
    """
    S = sums(model, data)
    return _arrays.squeeze_env(force_in(model, data, S, _frame_of(data.velocity_representation)), data.num_envs)


def total_momentum_jacobian(model, data, *, output_vel_repr=None) -> wp.array:
    """J_h: (6, 6 + n) or (N, 6, 6 + n), mapping ν (the data's representation) to the total momentum in
    the frame of output_vel_repr (default: the data's): W, B or B[W]. With the data's representation as
    output it is the first six rows of the mass matrix, as in JaxSim."""
    S = sums(model, data)
    J = jacobian_in(model, data, S, _frame_of(output_repr(data, output_vel_repr)), average=False)
    return _arrays.squeeze_env(J, data.num_envs)


def locked_spatial_inertia(model, data) -> wp.array:
    """The locked spatial inertia (all joints locked) in the data's representation's frame: (6, 6) or
    (N, 6, 6), [[kg, kg m], [kg m, kg m^2]]; equal to total_momentum_jacobian(model, data)[:, :6]."""
    S = sums(model, data)
    return _arrays.squeeze_env(inertia_in(model, data, S, _frame_of(data.velocity_representation)), data.num_envs)


def average_velocity(model, data) -> wp.array:
    """The average 6D velocity (locked inertia^-1 times momentum) as a velocity of the data's
    representation's frame (W, B or B[W]): (6,) or (N, 6), [m/s; rad/s]."""
    S = sums(model, data)
    return _arrays.squeeze_env(velocity_in(model, data, S, _frame_of(data.velocity_representation)), data.num_envs)


def average_velocity_jacobian(model, data, *, output_vel_repr=None) -> wp.array:
    """J_avg: (6, 6 + n) or (N, 6, 6 + n), mapping ν (the data's representation) to the average velocity
    as a velocity of the frame of output_vel_repr (default: the data's).

    JaxSim computes it as O_X_G · average_centroidal_velocity_jacobian and, when the output
    representation differs from the data's, takes G to be G[W] or G[B] after the output rather than the
    data; that agrees with this function except between Body and the other two, where JaxSim's
    result is not the average velocity of any frame. This function applies the proper transform always.
    """
    S = sums(model, data)
    J = jacobian_in(model, data, S, _frame_of(output_repr(data, output_vel_repr)), average=True)
    return _arrays.squeeze_env(J, data.num_envs)


def kinetic_energy(model, data) -> wp.array:
    """K = 1/2 ν^T M ν = Σ_L 1/2 L_v^T L_M_L L_v [J]: (N,) for batched data, (1,) for one environment."""
    return energy(model, data, sums(model, data), kinetic=True, potential=False)


def potential_energy(model, data) -> wp.array:
    """U = m g z_CoM [J], gravity g = model.gravity along -z (so U grows with height): (N,) or (1,).

    JaxSim's text computes m z_CoM model.gravity with its model.gravity = -9.81, the opposite sign,
    with which K + U is not conserved; this follows the physics (and MuJoCo's energy[0])."""
    return energy(model, data, sums(model, data), kinetic=False, potential=True)


def mechanical_energy(model, data) -> wp.array:
    """K + U [J]: (N,) or (1,); conserved by the unforced, frictionless dynamics."""
    return energy(model, data, sums(model, data), kinetic=True, potential=True)
