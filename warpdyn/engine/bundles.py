"""The kernels' typed arguments (kernels/bundles.py) filled from a model, a state and the controls.

`model_bundle` is built once per model version (warpdyn.types.model: a setter announces a change) and per
set of gradient arrays of its parameters (marking one for gradients gives it a .grad, which the bundle's
descriptors carry). Parameters are handed to kernels as (P, count) arrays: P = 1 for a parameter shared by
the environments (a view of the (count,) array), N for one given per environment.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..kernels.bundles import bundles
from ..types.model_constants import JOINT_TERMS, quaternion_xyzw
from ..types.parameters import MODEL_ARRAYS, REGISTRY
from . import warp_private

__all__ = ["model_bundle", "model_bundle_and_grad", "state_bundle", "controls_bundle", "empty_like_input", "per_env"]

_PARAMETERS = MODEL_ARRAYS
_DYNAMICS = tuple(k for k, name in enumerate(_PARAMETERS) if REGISTRY[name].group != "actuator") + tuple(
    len(_PARAMETERS) + k for k in range(len(JOINT_TERMS)))
"""The positions in _PARAMETERS + JOINT_TERMS of the arrays the dynamics functions read (link, joint and world
parameters, the joint terms: wd.model.with_joint_origins makes them differentiable)."""


def _rows(model, name: str, per_env: dict) -> wp.array:
    """The (P, count) array of a link, joint, actuator or world parameter."""
    array = getattr(model, name)
    return array if name in per_env else array.reshape((1, *array.shape))


def _build_model_bundle(model):
    bundle = bundles(model.scalar).Model()
    bundle.parent = model.parent
    bundle.joint_type = model.joint_type
    for name in ("q_start", "v_start", "joint_Q0", "joint_Q1", "joint_t0", "joint_t1", "joint_t2", "dof_S", "dof_joint", "qpos_spring"):
        setattr(bundle, name, getattr(model, name))
    bundle.first_child = model.first_child
    bundle.next_sibling = model.next_sibling
    bundle.support = model.support
    k, j, zero_k, zero_j = _dof_pairs(model.tree)
    for name, values in (("pair_k", k), ("pair_j", j), ("zero_k", zero_k), ("zero_j", zero_j)):
        setattr(bundle, name, wp.array(values.astype(np.int32), dtype=int, device=model.device))
    bundle.actuator_joint = model.actuator_joint
    bundle.joint_actuator = model.joint_actuator
    bundle.joint_actuator_start = model.joint_actuator_start
    bundle.floating_base = int(model.floating_base())
    H = model.description.initial_world_H_base if model.floating_base() else None
    H = np.eye(4) if H is None else np.asarray(H, dtype=np.float64)
    bundle.base_reference = wp.types.transformation(model.scalar)(*H[:3, 3], *quaternion_xyzw(H[:3, :3]))
    per_env = model.per_environment_parameters()
    for name in _PARAMETERS:
        setattr(bundle, name, _rows(model, name, per_env))
    return bundle


def _dof_pairs(tree) -> tuple[np.ndarray, ...]:
    """(pair_k, pair_j, zero_k, zero_j): the DoF pairs (k, j) whose joint J supports DoF k's link (J moves it), once
    per pair within one joint (j <= k), and the pairs where neither joint moves the other's link (kernels/bundles.py)."""
    support = tree.support()[1:] != 0  # (nj, nj): [K, J] joint J moves link K + 1
    joint = tree.dof_joint()
    dof_support = support[joint[:, None], joint[None, :]]  # (nv, nv): [k, j] DoF j's joint moves DoF k's link
    same = joint[:, None] == joint[None, :]
    below = np.arange(len(joint))[None, :] <= np.arange(len(joint))[:, None]
    k, j = np.nonzero(dof_support & (below | ~same))
    zero_k, zero_j = np.nonzero(~(dof_support | dof_support.T))
    return k, j, zero_k, zero_j


def model_bundle(model):
    """The model's `bundles(scalar).Model` (see `model_bundle_and_grad`)."""
    return model_bundle_and_grad(model)[0]


def model_bundle_and_grad(model) -> tuple:
    """(the model's `bundles(scalar).Model`, whether a link, joint or world parameter requires gradients), cached per
    model version and per gradient arrays of its parameters (the parameters' arrays listed once per version:
    only a setter, which announces itself, replaces one; their .grad, which marking an array for gradients
    sets, read at each call). An array requires gradients exactly when it has a .grad (Warp's requires_grad
    and grad setters keep the two together)."""
    parameters = model.cached("model bundle arrays", lambda: tuple(getattr(model, name) for name in (*_PARAMETERS, *JOINT_TERMS)))
    grads = warp_private.grads(parameters)  # the arrays, not their ids: a freed grad's id may come back
    return model.cached(("model bundle", grads), lambda: (_build_model_bundle(model), any(grads[k] is not None for k in _DYNAMICS)))


def requires_grad(model, data, *inputs) -> bool:
    """Whether the data's state, an input or a link, joint or world parameter of the model (joint origins included:
    wd.model.with_joint_origins) requires gradients: then outputs and scratch get gradient arrays, so that the
    adjoint reaches them."""
    return requires_grad_with(model_bundle_and_grad(model)[1], data, inputs)


def requires_grad_with(parameters: bool, data, inputs) -> bool:
    """`requires_grad` with the parameters' part given (model_bundle_and_grad's)."""
    if parameters or data.requires_grad:
        return True
    for x in inputs:
        if isinstance(x, wp.array) and x.requires_grad:
            return True
    return False


def state_bundle(scalar, state: list):
    """A `bundles(scalar).State` of the state arrays (p, Q, s, v, sdot, m, valid) (see warpdyn.data); an
    absent contact state or health flag becomes an empty array."""
    bundle = bundles(scalar).State()
    bundle.base_position = state[0]
    bundle.base_quaternion = state[1]
    bundle.joint_positions = state[2]
    bundle.base_velocity = state[3]
    bundle.joint_velocities = state[4]
    device = state[0].device
    bundle.tangential_deformation = state[5] if state[5] is not None else empty_like_input(scalar, device, 3)
    bundle.valid = state[6] if state[6] is not None else wp.empty(0, dtype=wp.int32, device=device)
    return bundle


def empty_like_input(scalar, device, ndim: int) -> wp.array:
    """The absent input of `ndim` axes: an array whose axes are all 0 (kernels test `.shape[0] > 0`); one per
    (scalar, device, ndim), made once (it holds no memory and nothing writes it)."""
    key = (scalar, str(device), ndim)
    empty = _EMPTY.get(key)
    if empty is None:
        empty = _EMPTY[key] = wp.empty((0,) * ndim, dtype=scalar, device=device)
    return empty


_EMPTY: dict = {}
_NO_CONTROLS: dict = {}


def controls_bundle(scalar, device, joint_forces=None, link_forces=None, link_implicit=None):
    """A `bundles(scalar).Controls`: joint forces (N, n), link forces (N, nL, 6) and the contacts' implicit terms
    (N, nL, 27: kernels/implicit_contacts.py), None for absent (all absent: one bundle per (scalar, device), made
    once; nothing writes it)."""
    if joint_forces is None and link_forces is None and link_implicit is None:
        key = (scalar, str(device))
        bundle = _NO_CONTROLS.get(key)
        if bundle is None:
            bundle = _NO_CONTROLS[key] = controls_bundle(scalar, device, empty_like_input(scalar, device, 2))
        return bundle
    bundle = bundles(scalar).Controls()
    bundle.joint_forces = joint_forces if joint_forces is not None else empty_like_input(scalar, device, 2)
    bundle.link_forces = link_forces if link_forces is not None else empty_like_input(scalar, device, 3)
    bundle.link_implicit = link_implicit if link_implicit is not None else empty_like_input(scalar, device, 3)
    return bundle


def per_env(value, name, scalar, device, owner="SoftContactsParams") -> wp.array:
    """A parameter shared (1,) or per environment (N,) as the kernels read it: a Warp array is the user's,
    read in place (its .grad gets the gradient); numbers and NumPy arrays are copied."""
    if isinstance(value, wp.array):
        if value.ndim != 1 or value.dtype != scalar or value.device != device:
            raise ValueError(
                f"{owner}.{name} as a Warp array must be 1-D with the model's dtype {scalar.__name__} on "
                f"{device}, got shape {value.shape}, dtype {getattr(value.dtype, '__name__', value.dtype)} on {value.device}"
            )
        return value
    host = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if host.ndim != 1:
        raise ValueError(f"{owner}.{name} has shape {host.shape}: give a number or one value per environment (N,)")
    return wp.array(host, dtype=scalar, device=device)
