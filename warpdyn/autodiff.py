"""Full Jacobians of warpdyn's computations, by one batched reverse pass.

Warp differentiates in reverse mode: one backward pass gives the gradient of one scalar. For the Jacobian of
m outputs, warpdyn runs the computation on m copies of each environment at once (N m environments), seeds
output c in copy c and runs one backward pass: copy c's input gradients are row c of its environment's
Jacobian. On a GPU, whose width the copies fill, m rows cost about what one does.

- `transition_matrices(model, data, ...)`: a step's A = ∂x'/∂x and B = ∂x'/∂u in the tangent space of the
  state (MuJoCo's mjd_transitionFD layout), with u the joint force references or the actuators' ctrl.
- `jacobian(function, model, data, ...)`: the Jacobian of any function of the data (and of per-environment
  controls) that returns an array with a leading environment axis, with respect to the state's tangent, the
  controls and model parameters.

The state's tangent x = [dq; dv] (nx = 2 (nb + nv), nb = 6 for a floating base, 0 for a fixed one): dq the base's
displacement δp [m, world axes] and rotation δθ [rad] (world axes in the Mixed and Inertial representations,
base axes in Body: the axes of the representation's angular velocity), then the joints' position tangents
(a ball joint's rotation in its child's axes, a free joint's δp then δθ, as MuJoCo's); dv the base velocity in
the data's representation, then the joint velocities. The contact deformation state (soft contacts) is held,
not differentiated. Gradients are those of the staged step under a wp.Tape (docs/differentiation.md for where
the derivative is one-sided); the solved contact models differentiate at the step's set of penetrating points
(their solves' adjoints written by hand).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import warp as wp

from . import arrays
from .data import Data
from .engine import tangent
from .model import Model, step
from .simulation import rollout
from .types.enums import VelRepr
from .types.parameters import REGISTRY
from .terrain import FlatTerrain

__all__ = ["jacobian", "transition_matrices"]

_SETTERS = {"link": "set_link_parameters", "joint": "set_joint_parameters", "actuator": "set_actuator_parameters"}


def transition_matrices(model: Model, data, *, control: str = "joint_force_references", joint_force_references=None, ctrl=None,
                        link_forces=None, parameters=(), method: str = "reverse", h: float = 1e-6, steps: int = 1) -> dict:
    """The linearisation of one `wd.model.step` about `data` and the controls: x' ≈ x'_0 + A dx + B du.

    control: "joint_force_references" (u = τ (nv,)) or "ctrl" (u = the actuators' controls (na,)). The controls
    and link_forces take `step`'s shapes. steps: linearise `steps` steps (`wd.simulation.rollout`) instead:
    A = ∂x_T/∂x_0, and B = ∂x_T/∂u for a control held over them, or ∂x_T/∂(u_0 .. u_T-1) (N, nx, T, nu) for one
    given per step as (T, N, nu) (N = 1 for single-environment data; the reverse method only). parameters: names
    of model parameters (warpdyn.types.parameters.REGISTRY: link, joint and actuator parameters, world_gravity,
    the soft contacts' K, D, mu) whose Jacobians ∂x'/∂θ come back too.
    Returns {"A": (N, nx, nx), "B": (N, nx, nu), name: (N, nx, k) for each parameter (k its numbers per
    environment, items flattened)}, Warp arrays on the model's device (no N axis for single-environment data);
    the tangent x as the module docstring says. An environment flagged before (data.healthy) or by the steps
    gets NaN.
    method: "reverse" (exact to rounding: one taped step and one backward pass over N nx copies) or "central"
    (MuJoCo's mjd_transitionFD's scheme: central differences of step h in the tangent, one untaped step over
    N (2 (nx + nu) + 1) copies, the fused step where it applies; no parameters). Central differences err by about
    h² times the step's third derivative plus eps |x'| / h: use them in float64 (benchmarks/jacobians.py compares
    the two methods).
    """
    if control not in ("joint_force_references", "ctrl"):
        raise ValueError(f"control must be 'joint_force_references' or 'ctrl', got {control!r}")
    repr = int(VelRepr(data.velocity_representation))
    copies = tangent.tangent_size(model)
    given = {"joint_force_references": joint_force_references, "ctrl": ctrl, "link_forces": link_forces}
    size = model.dofs() if control == "joint_force_references" else model.number_of_actuators()
    if given[control] is None:
        given[control] = np.zeros(size)

    if int(steps) != steps or steps < 1:
        raise ValueError(f"steps must be a positive integer, got {steps!r}")

    def evaluate(model_c, data_c, controls_c):
        new = _advanced(model_c, data_c, int(steps), controls_c)
        return tangent.state_tangent(model_c, new, repr), new.valid_state

    if method == "central":
        if parameters:
            raise ValueError("method='central' differentiates the state and the controls only: use method='reverse' for parameters")
        if np.ndim(_host(given[control], control)) == 3:
            raise ValueError(f"method='central' takes a {control} held over the steps ((nu,) or (N, nu)); per-step controls need method='reverse'")
        out = _central(model, data, repr, control, given, float(h), int(steps))
    elif method == "reverse":
        grads = _differentiate(model, data, copies, evaluate, given, (control,), tuple(parameters))
        out = {"A": grads.pop("state"), "B": grads.pop(control)}
        out.update(grads)
    else:
        raise ValueError(f"method must be 'reverse' or 'central', got {method!r}")
    return {name: arrays.squeeze_env(value, data.num_envs) for name, value in out.items()}


def jacobian(function, model: Model, data, *, controls: dict | None = None, wrt=("state",), parameters=()) -> dict:
    """The Jacobian of y = function(model, data, **controls) by one batched backward pass.

    function: returns a Warp array whose first axis is the environments (warpdyn's functions do, for batched
    data) and up to two more, m outputs per environment in all; it must record on a wp.Tape (every warpdyn
    function does). controls: {name: value} passed to it, each (N, k) or (k,) (shared), e.g. joint_forces,
    joint_force_references, ctrl. wrt: "state" (the tangent x of the module docstring) and names of
    `controls`; parameters: model parameter names (see `transition_matrices`).
    Returns {name: (N, m, k)} Warp arrays (no N axis for single-environment data), k = nx for "state"; an
    environment flagged in `data` (data.healthy) gets NaN.
    """
    controls = dict(controls or {})
    unknown = [name for name in wrt if name != "state" and name not in controls]
    if unknown:
        raise ValueError(f"wrt names {unknown} are neither 'state' nor keys of controls {sorted(controls)}")
    probe = function(model, data, **controls)
    if not isinstance(probe, wp.array):
        raise TypeError(f"function must return a Warp array, got {type(probe).__name__}")
    shape = probe.shape if data.num_envs is None else probe.shape[1:]
    copies = max(1, math.prod(shape))

    def evaluate(model_c, data_c, controls_c):
        return tangent.flattened(function(model_c, data_c, **controls_c)), None

    grads = _differentiate(model, data, copies, evaluate, controls, tuple(n for n in wrt if n != "state"), tuple(parameters))
    if "state" not in wrt:
        grads.pop("state")
    return {name: arrays.squeeze_env(value, data.num_envs) for name, value in grads.items()}


def _differentiate(model, data, copies: int, evaluate, controls: dict, wrt_controls: tuple, parameters: tuple) -> dict:
    """{"state": (N, m, nx), each of wrt_controls and parameters: (N, m, k)}: evaluate(model_c, data_c,
    controls_c) -> (y (N m, m), valid (N m,) or None) run on `copies` = m copies of each environment under a
    tape, output c seeded in copy c."""
    N = data.batch_size
    unknown = [name for name in parameters if name not in REGISTRY or REGISTRY[name].group == "terrain"]
    if unknown:
        raise ValueError(f"parameters {unknown} are not model parameters with Jacobians; known: "
                         f"{[n for n, p in REGISTRY.items() if p.group != 'terrain']}")
    model_c = _replicated_model(model, N, copies, parameters)
    marked = model_c.mark_for_gradients(parameters) if parameters else {}
    kept = _kept_grads(model_c, {id(a) for a in marked.values()})
    rows = N * copies
    nx = tangent.tangent_size(model)
    dx = wp.zeros((rows, nx), dtype=model.scalar, device=model.device, requires_grad=True)
    controls_c = {name: _replicated_control(model, name, value, N, copies, name in wrt_controls) for name, value in controls.items()
                  if value is not None}
    with wp.Tape() as tape:
        data_c = _copies(model, data, copies, dx)
        y, valid = evaluate(model_c, data_c, controls_c)
    if y.shape != (rows, copies):
        raise ValueError(f"the function's output changed shape between calls: {tuple(y.shape)}, expected ({rows}, {copies})")
    tangent.seed(y, copies)
    tape.backward()
    out = {"state": dx.grad.reshape((N, copies, nx))}  # dx is the tape's leaf: its gradient array is this call's
    for name in wrt_controls:
        array = controls_c[name]
        out[name] = _per_copy(array.grad, N, copies, model, per_step=array.ndim == (4 if name == "link_forces" else 3))
    for name, array in marked.items():
        out[name] = _per_copy(array.grad, N, copies, model)
    _restore(kept)
    tangent.poison_flagged(out.values(), valid, copies, data.valid_state)
    return out


def _advanced(model, data, steps: int, controls: dict) -> Data:
    """The data after `steps` steps with the controls (held, or per step as (T, N, ...))."""
    if steps == 1 and all(_host(value, name).ndim < (4 if name == "link_forces" else 3) for name, value in controls.items()):
        return step(model, data, **controls)
    return rollout(model, data, steps=steps, record=(), **controls)[0]


def _central(model, data, repr: int, control: str, controls: dict, h: float, steps: int) -> dict:
    """{"A", "B"} by central differences (see `transition_matrices`)."""
    N = data.batch_size
    nx = tangent.tangent_size(model)
    u = _replicated_control(model, control, controls[control], N, 1, False)
    copies = 2 * (nx + u.shape[1]) + 1
    dx, u_rows = tangent.perturbed(model, copies, h, u)
    others = {name: _replicated_control(model, name, value, N, copies, False) for name, value in controls.items() if value is not None and name != control}
    model_c = _replicated_model(model, N, copies, ())
    new = _advanced(model_c, _copies(model, data, copies, dx), steps, {**others, control: u_rows})
    A, B = tangent.central_differences(tangent.state_tangent(model_c, new, repr, copies, copies - 1), copies, u.shape[1], h)
    tangent.poison_flagged((A, B), new.valid_state, copies, data.valid_state)
    return {"A": A, "B": B}


def _copies(model, data, copies: int, dx: wp.array) -> Data:
    """Data of `copies` copies of each environment of `data`, copy c moved by its tangent vector dx[c] (N m, nx):
    engine.tangent.moved_state, recorded by a tape when dx requires gradients; the contact deformation copied."""
    rows = data.batch_size * copies
    state = tangent.moved_state(model, data, int(VelRepr(data.velocity_representation)), copies, dx)
    deformation = data.tangential_deformation_state
    return Data(
        base_position_state=state["base_position"],
        base_quaternion_state=state["base_quaternion"],
        joint_positions_state=state["joint_positions"],
        base_velocity_state=state["base_velocity"],
        joint_velocities_state=state["joint_velocities"],
        velocity_representation=data.velocity_representation,
        num_envs=rows,
        tangential_deformation_state=None if deformation is None else tangent.replicated(deformation, copies),
        valid_state=wp.ones(rows, dtype=wp.int32, device=model.device),
    )


def _per_copy(grad: wp.array, N: int, copies: int, model, per_step: bool = False) -> wp.array:
    """A gradient of N m rows (of numbers, vectors or matrices) as (N, m, k) numbers: row c of environment e is
    copy c's; per step ((T, N m, k) rows): (N, m, T, k)."""
    if not per_step and grad.dtype == model.scalar and grad.is_contiguous:
        return grad.reshape((N, copies, -1))  # rows of numbers: a view, no copy
    host = grad.numpy()
    if per_step:
        host = host.reshape(host.shape[0], N, copies, -1).transpose(1, 2, 0, 3)
    else:
        host = host.reshape(N, copies, -1)
    return wp.array(np.ascontiguousarray(host), dtype=model.scalar, device=model.device)


def _host(value, name: str) -> np.ndarray:
    return arrays.host_numbers(value.numpy() if isinstance(value, wp.array) else value, name)


def _replicated_control(model, name: str, value, N: int, copies: int, grad: bool) -> wp.array:
    """A control given shared, per environment or per step and environment (T, N, ...), as rows of N m
    environments ((N m, k), (N m, nL, 6) for link forces, (T, N m, ...) per step), row-major; a Warp array of the
    model's scalar on its device, shared or per environment, replicated there (no host copy)."""
    item = 2 if name == "link_forces" else 1
    if isinstance(value, wp.array) and value.dtype == model.scalar and str(value.device) == str(model.device) and value.ndim in (item, item + 1):
        rows = value.reshape((1, *value.shape)) if value.ndim == item else value
        if rows.shape[0] not in (1, N):
            raise ValueError(f"{name} has {rows.shape[0]} environments (shape {tuple(value.shape)}), the data {N}")
        out = tangent.replicated(rows, copies * (N if rows.shape[0] == 1 else 1), contiguous=True)
        out.requires_grad = grad
        return out
    host = _host(value, name)
    per_step = host.ndim == item + 2
    if not per_step:
        host = host if host.ndim == item + 1 else np.broadcast_to(host, (N, *host.shape))
    axis = 1 if per_step else 0
    if host.shape[axis] != N:
        raise ValueError(f"{name} has {host.shape[axis]} environments (shape {host.shape}), the data {N}")
    repeated = np.ascontiguousarray(np.repeat(host, copies, axis=axis))
    return wp.array(repeated, dtype=model.scalar, device=model.device, requires_grad=grad)


def _replicated_model(model: Model, N: int, copies: int, parameters: tuple) -> Model:
    """The model itself when nothing is per environment and no parameter is differentiated; else a copy whose
    per-environment parameters (and those in `parameters`) hold one row per copy of each environment."""
    contact = {name for name in ("K", "D", "mu") if _numbers(getattr(model.contact_params, name, None)).size > 1}
    terrain = model.terrain
    per_terrain = isinstance(terrain, FlatTerrain) and _numbers(terrain.elevation).size > 1
    per_env = set(model.per_environment_parameters())
    if not parameters and not per_env and not contact and not per_terrain:
        return model
    copy = model.copy()
    names = sorted((per_env | set(parameters)) - {"K", "D", "mu"})
    hosts = {name: np.asarray(model.parameter(name).numpy(), dtype=np.float64) for name in names}
    for name in per_env:  # shared first: a model holds one N of environments at a time
        _set_parameter(copy, name, hosts[name][0])
    for name in names:
        host = hosts[name] if name in per_env else np.broadcast_to(hosts[name], (N, *hosts[name].shape))
        _set_parameter(copy, name, np.repeat(host, copies, axis=0))
    replaced = {}
    for name in {"K", "D", "mu"} & (set(parameters) | contact):
        host = _numbers(getattr(model.contact_params, name))
        replaced[name] = np.repeat(np.broadcast_to(host, (N,)) if host.size == 1 else host, copies)
    if replaced:
        copy.contact_params = dataclasses.replace(copy.contact_params, **replaced)
    if per_terrain:
        copy.terrain = FlatTerrain(np.repeat(_numbers(terrain.elevation), copies))
    return copy


def _set_parameter(model: Model, name: str, value: np.ndarray) -> None:
    """Set a link, joint, actuator or world parameter from its registry layout ((count, *item) shared, (N, count,
    *item) per environment) through its group's setter."""
    parameter = REGISTRY[name]
    if parameter.group == "world":
        model.set_gravity(value.reshape(-1, 3) if value.ndim == 3 else value.reshape(3))
    else:
        getattr(model, _SETTERS[parameter.group])(**{parameter.keyword: value})


def _numbers(value) -> np.ndarray:
    """A number, NumPy or Warp array (or None: empty) as a flat float64 host array."""
    if value is None:
        return np.zeros(0)
    return np.asarray(value.numpy() if isinstance(value, wp.array) else value, dtype=np.float64).reshape(-1)


def _kept_grads(model: Model, mine: set) -> list:
    """(array, copy of its gradient) for the model's parameters that already require gradients and are not
    differentiated here: a backward pass adds into them, `_restore` puts them back."""
    kept = []
    for name in REGISTRY:
        value = model.parameter(name)
        if isinstance(value, wp.array) and value.requires_grad and id(value) not in mine and value.grad is not None:
            kept.append((value, wp.clone(value.grad)))
    return kept


def _restore(kept: list) -> None:
    for array, grad in kept:
        array.grad.assign(grad)
