"""PyTorch bridge: a differentiable rollout that takes and returns torch tensors (optional; needs torch).

    import warpdyn.torch as wdt
    rec = wdt.rollout(model, steps=T, joint_positions=s0, joint_velocities=v0,         # torch tensors
                      joint_force_references=tau, parameters={"link_mass": m},
                      record=("joint_positions", "joint_velocities"))
    loss = (rec["joint_positions"][-1] - target).square().sum()
    loss.backward()                                   # s0.grad, v0.grad, tau.grad, m.grad

`rollout` is `warpdyn.simulation.rollout` as a `torch.autograd.Function`: the forward runs the rollout under
its own `wp.Tape`, the backward seeds the records' adjoints with torch's output gradients, runs the tape
backwards and returns the gradients of the initial state, the controls and the chosen model parameters. It
composes with any torch code: losses, networks producing the torques, `torch.optim` optimisers,
`torch.autograd.gradcheck`.

Memory. Tensors are shared with Warp, not copied (`wp.from_torch` / `wp.to_torch`): the inputs are read in
place by the kernels that load them into the rollout's state and control buffers (on the tape, so that
gradients reach them), and the returned records are the rollout's own buffers (fresh per call). Under autograd the tape keeps every step's intermediates (see
`warpdyn.simulation`, storage "trajectory") on a tensor saved for the backward pass, so torch frees them
with its saved tensors: after a backward pass without retain_graph, or when the graph is dropped. With
retain_graph the tape stays and is zeroed before each further backward pass (gradcheck does that). When
no tensor requires a gradient, or under `torch.no_grad()`, no tape is recorded and the rollout may keep
two states only (storage "auto"). Input and parameter gradients are copies (small: the state, the
controls, the parameters).

Devices and dtypes. Every tensor must be on the model's device (CPU, or the CUDA device of the model) and in
the model's dtype (float32 or float64); nothing is converted silently. On CUDA, Warp's launches go on torch's
current stream when that is a non-default stream (`wp.stream_from_torch`), and on Warp's stream otherwise
(torch's legacy default stream orders itself with Warp's blocking streams), so no synchronisation is needed
around a call.

Model parameters (`parameters=`, names in `warpdyn.model.PARAMETERS`) are functional: the tensors'
values are used for this call only. They are written into the model's arrays (marked for gradients with
`warpdyn.model.parameters_requiring_grad`, which also makes K, D, mu and the terrain's height Warp arrays of
the model's `contact_params` and `terrain`) for the forward pass and again for the backward pass, and the
model's own values are put back after each; the backward pass sets the model's .grad arrays aside and puts
their values back after it, so a `.grad` they hold for a user's own `wp.Tape` is left as it was. Parameters
given per environment (`Model.set_link_parameters`, ...) take tensors with the leading N. The model's
arrays of the parameters named stay marked for gradients after the call (`parameters_requiring_grad`):
later calls of warpdyn's functions on that model then give their outputs gradient arrays.

Importing `warpdyn` does not import torch; `import warpdyn.torch` does.
"""

from __future__ import annotations

import contextlib
import dataclasses

import numpy as np
import torch
import warp as wp

from warpdyn import model as _model
from warpdyn import simulation as _simulation
from warpdyn.data import Data
from warpdyn.engine import warp_private
from warpdyn.model import VelRepr

__all__ = ["rollout", "torch_device", "STATE_INPUTS"]

STATE_INPUTS = (
    "base_position",
    "base_quaternion",
    "joint_positions",
    "base_velocity",
    "joint_velocities",
    "tangential_deformation",
)
"""The initial-state tensors `rollout` takes, in this order (see its docstring for shapes)."""

_POSITIVE = ("D",)
_NON_NEGATIVE = (
    "link_mass", "gravcomp_mass", "friction_static", "friction_viscous", "joint_limit_spring", "joint_limit_damper", "armature",
    "damping", "stiffness", "K", "mu",
)  # fmt: skip


def torch_device(model) -> torch.device:
    """The torch device of the model's Warp device (where `rollout`'s tensors must be): cuda:k or cpu."""
    return torch.device(wp.device_to_torch(model.device))


def rollout(
    model,
    *,
    steps: int,
    base_position: torch.Tensor | None = None,
    base_quaternion: torch.Tensor | None = None,
    joint_positions: torch.Tensor | None = None,
    base_velocity: torch.Tensor | None = None,
    joint_velocities: torch.Tensor | None = None,
    tangential_deformation: torch.Tensor | None = None,
    joint_force_references: torch.Tensor | None = None,
    link_forces: torch.Tensor | None = None,
    ctrl: torch.Tensor | None = None,
    parameters: dict[str, torch.Tensor] | None = None,
    record=_simulation.DEFAULT_RECORD,
    velocity_representation: VelRepr = VelRepr.Mixed,
    num_envs: int | None = None,
    validate: bool = True,
    **rollout_kwargs,
) -> dict:
    """{name: torch.Tensor} for each name in `record`: `steps` steps of `wd.model.step` from the given
    initial state, differentiable by torch with respect to every tensor argument.

    Initial state (torch tensors in the model's dtype and on its device; None: Data.build's default, zero,
    the identity quaternion, or the welded pose of a fixed base). Each is shared by all environments (the
    per-environment shape below) or given per environment (a leading axis N):
        base_position (3,) W_p_B [m]; base_quaternion (4,) W_Q_B as (w, x, y, z), unit norm;
        joint_positions (nq,) s [rad or m; a ball or free joint's quaternion (w, x, y, z)], in the model's joint order;
        base_velocity (6,) [linear; angular] of the base in `velocity_representation` [m/s, rad/s]
            (kept Mixed inside; the conversion is on the tape, so its gradient is in this representation);
        joint_velocities (n,) sdot [rad/s or m/s];
        tangential_deformation (rows, 3) m of every collidable point, then geom pair slot (model.contact_state_rows()) [m] (None: zero).
    The data is batched (records with a leading N axis) when any state tensor has the leading axis, or when
    `num_envs` is given; otherwise it is one environment, and the records have JaxSim's shapes.

    Controls (as in `warpdyn.simulation`): joint_force_references [N m or N] per environment per step
    (T, N, n), shared per step (T, 1, n), or (T, n) for one environment; constant (N, n) or (n,).
    link_forces [N, N m], the same with (nL, 6) per environment instead of (n,), in `velocity_representation`.
    ctrl, the same with (na,): the controls of the model's actuators (`model.actuator_names()`).

    parameters: {name: tensor} of model parameters that replace the model's values for this call (see the
    module docstring), each with the shape of `wp.to_torch` of the model's array: "link_mass" (nL,) [kg],
    "link_com" (nL, 3) [m, link frame], "link_inertia" (nL, 3, 3) [kg m^2, about the CoM, link frame],
    "friction_static", "friction_viscous", "joint_limit_spring", "joint_limit_damper", "armature", "damping",
    "stiffness", "springref" (n,) (Model.set_joint_parameters' units), "actuator_gear" (na,), "actuator_gain",
    "actuator_bias" (na, 3) (Model.set_actuator_parameters'), "K", "D", "mu" (1,) or (N,) as
    `model.contact_params` holds them (give the model per-environment values first to get per-environment
    tensors); every name in `wd.model.PARAMETERS`.

    Records (`record=`, names in `warpdyn.simulation.STATE_RECORDS` and `STEP_RECORDS`), shapes for batched
    data (single-environment data drops the N axis): state records (T + 1, N, ...) from t = 0 (the given
    state) to T, step records (T, N, ...); base_velocity and link_contact_forces in `velocity_representation`;
    "valid" (T + 1, N) int32 is not differentiable. The tensors share the rollout's buffers (fresh per call).

    validate: check the inputs' values on the host (finite, unit quaternions, parameter signs, the contact
    parameters' stability limit, as Data.build and SoftContactsParams do): a synchronisation on CUDA; False
    skips it. rollout_kwargs: passed on to `warpdyn.simulation.rollout` (storage, use_graph, ...; their
    defaults pick a differentiable storage and no graph when gradients are wanted, and two states and a graph
    otherwise). A callback there sees Warp Data and may not replace the state when gradients are wanted.
    """
    if _simulation.taping():
        raise RuntimeError("warpdyn.torch.rollout records its own wp.Tape: call it outside a wp.Tape")
    if isinstance(record, str):
        record = (record,)
    record = tuple(dict.fromkeys(record))
    unknown = [r for r in record if r not in _simulation.STATE_RECORDS + _simulation.STEP_RECORDS]
    if unknown:
        raise ValueError(f"record names unknown quantities {unknown}; known: {list(_simulation.STATE_RECORDS + _simulation.STEP_RECORDS)}")
    torch_dtype = wp.dtype_to_torch(model.scalar)
    device = wp.get_device(model.device)
    given = {
        "base_position": base_position,
        "base_quaternion": base_quaternion,
        "joint_positions": joint_positions,
        "base_velocity": base_velocity,
        "joint_velocities": joint_velocities,
        "tangential_deformation": tangential_deformation,
        "joint_force_references": joint_force_references,
        "link_forces": link_forces,
        "ctrl": ctrl,
    }
    parameters = {} if parameters is None else dict(parameters)
    unknown = [name for name in parameters if name not in _model.PARAMETERS]
    if unknown:
        raise ValueError(f"parameters names unknown model parameters {unknown}; known: {list(_model.PARAMETERS)}")
    for name, value in {**given, **{f"parameters['{k}']": v for k, v in parameters.items()}}.items():
        if value is not None:
            _check_tensor(value, name, torch_dtype, device)

    n, nq = model.dofs(), model.number_of_joint_coordinates()
    nc = model.contact_state_rows()
    per_env = {
        "base_position": (3,),
        "base_quaternion": (4,),
        "joint_positions": (nq,),
        "base_velocity": (6,),
        "joint_velocities": (n,),
        "tangential_deformation": (nc, 3),
    }
    num_envs = _batch(given, per_env, num_envs)
    N = 1 if num_envs is None else num_envs
    for name, shape in per_env.items():
        value = given[name]
        if value is not None:
            accepted = [shape] + ([(N, *shape)] if num_envs is not None else [])
            if tuple(value.shape) not in accepted:
                raise ValueError(f"{name} has shape {tuple(value.shape)}; accepted: {accepted} (nq = {nq} joint positions, nv = {n} joint velocities, {nc} contact state rows: model.contact_state_rows())")

    marked = _model_parameters(model, parameters, N)
    if validate:
        _validate(model, given, parameters)

    names = [k for k, v in given.items() if v is not None]
    param_names = list(parameters)
    tensors = [given[k] for k in names] + [parameters[k] for k in param_names]
    spec = _Spec(
        model=model,
        steps=steps,
        num_envs=num_envs,
        velocity_representation=VelRepr(velocity_representation),
        record=record,
        rollout_kwargs=dict(rollout_kwargs),
        validate=validate,
        taping=torch.is_grad_enabled() and any(t.requires_grad for t in tensors),
        inputs=tuple(names),
        parameters=tuple(param_names),
        marked=tuple(marked[k] for k in param_names),
        others=tuple(a for a in _parameter_arrays(model) if a.requires_grad and not any(a is b for b in marked.values())),
    )
    outputs = _Rollout.apply(spec, *tensors)
    return dict(zip(record, outputs))


@dataclasses.dataclass(frozen=True, eq=False)
class _Spec:
    """What `_Rollout` needs besides the tensors (autograd.Function takes it as a non-tensor argument)."""

    model: object
    steps: int
    num_envs: int | None
    velocity_representation: VelRepr
    record: tuple
    rollout_kwargs: dict
    validate: bool
    taping: bool  # gradients wanted: grad mode on and some tensor requires a gradient
    inputs: tuple  # names of the state and control tensors, in the order given to apply
    parameters: tuple  # names of the parameter tensors, after the inputs
    marked: tuple  # the model's Warp arrays of those parameters
    others: tuple  # the model's other parameter arrays that require gradients (for a user's own tapes)


class _Rollout(torch.autograd.Function):
    """The rollout as an autograd node: forward(spec, *inputs, *parameters) -> records (see `rollout`)."""

    @staticmethod
    def forward(ctx, spec: _Spec, *tensors):
        ctx.set_materialize_grads(False)
        model = spec.model
        k = len(spec.inputs)
        inputs, params = tensors[:k], tensors[k:]
        needs = tuple(ctx.needs_input_grad[1:]) if spec.taping else (False,) * len(tensors)
        with _stream(model.device):
            # the inputs, shared with torch; each input needing a gradient gets its own (Warp) gradient array (a
            # contact state shared by N environments is expanded to N rows, its gradient summed over them)
            shapes = tuple(tuple(t.shape) for t in inputs)
            inputs = [_expanded(name, t, spec.num_envs) for name, t in zip(spec.inputs, inputs)]
            arrays = {name: _wrap(t, model.scalar, grad) for name, t, grad in zip(spec.inputs, inputs, needs[:k])}
            with _parameter_values(spec.marked, params):
                tape = wp.Tape() if spec.taping else None
                with tape if spec.taping else contextlib.nullcontext():
                    data = _data(spec, arrays, spec.taping)
                    _, rec = _simulation.rollout(
                        model,
                        data,
                        steps=spec.steps,
                        joint_force_references=arrays.get("joint_force_references"),
                        link_forces=arrays.get("link_forces"),
                        ctrl=arrays.get("ctrl"),
                        record=spec.record,
                        **spec.rollout_kwargs,
                    )
            outputs = tuple(_to_torch(rec[name], model) for name in spec.record)
        if "valid" in spec.record:
            ctx.mark_non_differentiable(outputs[spec.record.index("valid")])
        if spec.taping:
            # The tape and its arrays hang on a saved tensor, not on ctx: torch frees saved tensors after a
            # backward pass without retain_graph (and with the graph), which frees the tape's memory then.
            holder = torch.empty(0)
            holder._warpdyn_rollout = _Taped(spec, tape, rec, arrays, needs, shapes)
            # the parameters' values go into the model again for the backward; the records are saved so that
            # torch refuses a backward after they were changed in place (the tape reads the states they show)
            ctx.save_for_backward(holder, *params, *outputs)
        return outputs

    @staticmethod
    def backward(ctx, *grad_outputs):
        holder, *saved = ctx.saved_tensors
        taped: _Taped = holder._warpdyn_rollout
        params = saved[: len(taped.spec.parameters)]
        spec, tape, records, arrays, needs = taped.spec, taped.tape, taped.records, taped.arrays, taped.needs
        shapes = taped.input_shapes
        k = len(spec.inputs)
        with _stream(spec.model.device):
            # the parameter arrays' gradients are the user's (their own tapes) outside this pass: kept aside
            # and put back after it; in it they start at zero and those of `parameters` are returned
            wanted = needs[k:]
            with _parameter_values(spec.marked, params), _preserved_grads(spec.marked + spec.others):
                tape.zero()  # a backward pass before this one (retain_graph) left adjoints on the tape's arrays
                for name, g in zip(spec.record, grad_outputs):
                    if g is None or name == "valid" or records[name].size == 0:
                        continue
                    wp.to_torch(records[name].grad, requires_grad=False).copy_(g)
                tape.backward()
                # copies: a later backward pass through the same graph zeroes these arrays first
                grads = [_input_grad(arrays[name], shape) if need else None for name, shape, need in zip(spec.inputs, shapes, needs[:k])]
                grads += [_param_grad(a.grad, p) if need else None for a, p, need in zip(spec.marked, params, wanted)]
        return (None, *grads)


@dataclasses.dataclass(eq=False)
class _Taped:
    """What the backward pass needs: the tape, the records (their .grad take torch's output gradients), the
    wrapped inputs (their .grad give the input gradients), and which inputs need gradients."""

    spec: _Spec
    tape: wp.Tape
    records: dict
    arrays: dict
    needs: tuple
    input_shapes: tuple  # the input tensors' shapes as given (before `_expanded`)


# ----------------------------------------------------------------------------------------------- helpers


def _check_tensor(value, name: str, torch_dtype, device) -> None:
    """TypeError for a non-tensor or a wrong dtype, ValueError for a wrong device, naming the tensor."""
    if not isinstance(value, torch.Tensor):
        raise TypeError(f"{name} must be a torch.Tensor, got {type(value).__name__}")
    described = f"{name} (dtype {value.dtype}, device {value.device}, shape {tuple(value.shape)})"
    if value.dtype != torch_dtype:
        raise TypeError(f"{described}: the model computes in {torch_dtype}; convert it (tensor.to({torch_dtype}))")
    try:
        same = wp.get_device(wp.device_from_torch(value.device)) == device
    except (RuntimeError, ValueError):
        same = False
    if not same:
        raise ValueError(f"{described}: the model is on '{device}' (torch device '{wp.device_to_torch(device)}')")


def _batch(given: dict, per_env: dict, num_envs) -> int | None:
    """N from the state tensors with a leading environment axis (or `num_envs`), None for one environment."""
    if num_envs is not None:
        if isinstance(num_envs, (bool, np.bool_)) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be a positive integer or None, got {num_envs!r}")
        num_envs = int(num_envs)
    found = {}
    for name, shape in per_env.items():
        value = given[name]
        if value is not None and value.ndim == len(shape) + 1:
            found[name] = int(value.shape[0])
    sizes = set(found.values()) | ({num_envs} if num_envs is not None else set())
    if len(sizes) > 1:
        raise ValueError(f"the state tensors disagree on the number of environments: {found} (num_envs={num_envs})")
    return sizes.pop() if sizes else None


def _model_parameters(model, parameters: dict, N: int) -> dict:
    """The model's Warp arrays of the named parameters (marked for gradients), each checked against its tensor."""
    if not parameters:
        return {}
    arrays = _model.parameters_requiring_grad(model, names=tuple(parameters))
    for name, tensor in parameters.items():
        expected = tuple(arrays[name].shape) + warp_private.item_shape(arrays[name].dtype)
        if tuple(tensor.shape) != expected:
            hint = ""
            if name in ("K", "D", "mu"):
                hint = f" (the model holds {expected[0]} value(s); for one per environment set model.contact_params with ({N},) first)"
            elif name == "terrain_height":
                hint = f" (for one per environment set model.terrain = FlatTerrain(height=...) with ({N},) first)"
            elif len(tensor.shape) == len(expected) + 1:
                hint = " (for one row per environment give the model's values per environment first: Model.set_link_parameters, set_joint_parameters or set_gravity)"
            raise ValueError(f"parameters['{name}'] has shape {tuple(tensor.shape)}, the model's {name} {expected}{hint}")
    return arrays


def _validate(model, given: dict, parameters: dict) -> None:
    """Host checks of the values (one synchronisation per tensor on CUDA)."""
    for name, value in {**given, **parameters}.items():
        if value is not None and not bool(torch.isfinite(value).all()):
            raise ValueError(f"{name} has non-finite values")
    for name, value in parameters.items():
        if name in _POSITIVE and not bool((value > 0).all()):
            raise ValueError(f"parameters['{name}'] must be positive")
        if name in _NON_NEGATIVE and not bool((value >= 0).all()):
            raise ValueError(f"parameters['{name}'] must be non-negative")
    if ("K" in parameters or "D" in parameters) and len(model.kin_dyn_structure().contact_parameters.indices_of_enabled_collidable_points):
        c = model.contact_params
        K = parameters["K"].detach().cpu().numpy() if "K" in parameters else c.K
        D = parameters["D"].detach().cpu().numpy() if "D" in parameters else c.D
        _simulation.check_contact_stability(model, K=K, D=D)


@contextlib.contextmanager
def _stream(device):
    """Warp's launches on torch's current CUDA stream when that is not the legacy default stream (which
    orders itself with Warp's blocking streams and cannot be captured in a graph); nothing on the CPU."""
    device = wp.get_device(device)
    if not device.is_cuda:
        yield
        return
    current = torch.cuda.current_stream(wp.device_to_torch(device))
    if current.cuda_stream == 0:
        yield
        return
    with wp.ScopedStream(wp.stream_from_torch(current)):
        yield


def _wrap(t: torch.Tensor, scalar, grad: bool) -> wp.array:
    """The tensor as a Warp array sharing its memory; with its own zero Warp gradient array when `grad`
    (torch's `.grad` of the tensor is left alone: torch accumulates the returned gradient into it)."""
    array = wp.from_torch(t.detach().contiguous(), dtype=scalar, requires_grad=False)
    if grad:
        array.requires_grad = True
    return array


def _data(spec: _Spec, arrays: dict, grad: bool) -> Data:
    """The initial Data from the wrapped tensors, built on the tape (copies and the velocity conversion)."""
    model = spec.model
    velocity = arrays.get("base_velocity")
    linear = angular = None
    if velocity is not None:
        linear, angular = (velocity[:3], velocity[3:]) if velocity.ndim == 1 else (velocity[:, :3], velocity[:, 3:])
    data = Data.build(
        model,
        base_position=arrays.get("base_position"),
        base_quaternion=arrays.get("base_quaternion"),
        joint_positions=arrays.get("joint_positions"),
        base_linear_velocity=linear,
        base_angular_velocity=angular,
        joint_velocities=arrays.get("joint_velocities"),
        velocity_representation=spec.velocity_representation,
        num_envs=spec.num_envs,
        requires_grad=grad,
        validate=spec.validate,
    )
    deformation = arrays.get("tangential_deformation")
    if deformation is not None and deformation.size > 0:
        if deformation.ndim == 2:  # one environment (forward expanded a shared one to N rows)
            deformation = deformation.reshape((1, *deformation.shape))
        data.tangential_deformation_state = deformation  # the rollout copies it into its state (on the tape)
    return data


def _to_torch(array: wp.array, model) -> torch.Tensor:
    """A record as a tensor sharing its memory (a new empty tensor for an empty record)."""
    if array.size == 0:
        return torch.empty(tuple(array.shape), dtype=wp.dtype_to_torch(array.dtype), device=wp.device_to_torch(model.device))
    return wp.to_torch(array, requires_grad=False)


@contextlib.contextmanager
def _parameter_values(marked: tuple, values: tuple):
    """The model's parameter arrays hold `values` inside the block and their own values again after it."""
    views = [wp.to_torch(a, requires_grad=False) for a in marked]
    saved = [v.clone() for v in views]
    try:
        for view, value in zip(views, values):
            view.copy_(value.detach())
        yield
    finally:
        for view, old in zip(views, saved):
            view.copy_(old)


@contextlib.contextmanager
def _preserved_grads(arrays: tuple):
    """Inside the block the arrays' .grad hold zeros (so that a backward pass accumulates only its own
    adjoints); after it, the values they held before. The arrays keep their .grad objects: kernels recorded
    on a tape may hold views of them (Model.kernel_parameter)."""
    grads = [wp.to_torch(a.grad, requires_grad=False) for a in arrays]
    saved = [g.clone() for g in grads]
    try:
        for g in grads:
            g.zero_()
        yield
    finally:
        for g, old in zip(grads, saved):
            g.copy_(old)


def _parameter_arrays(model) -> list:
    """The model's current arrays of the parameters in PARAMETERS (K, D, mu and the terrain's height only
    where they are Warp arrays)."""
    out = []
    for name in _model.PARAMETERS:
        value = model.parameter(name)
        if isinstance(value, wp.array):
            out.append(value)
    return out


def _expanded(name: str, t: torch.Tensor, num_envs) -> torch.Tensor:
    """The tensor, or a contact state (nc, 3) shared by the environments as N rows (a view)."""
    if name == "tangential_deformation" and num_envs is not None and t.ndim == 2:
        return t.unsqueeze(0).expand(num_envs, *t.shape)
    return t


def _input_grad(array: wp.array, shape: tuple) -> torch.Tensor:
    """A copy of an input's gradient in the input's shape (summed over the environments it was expanded to)."""
    grad = wp.to_torch(array.grad, requires_grad=False).clone()
    return grad if tuple(grad.shape) == shape else grad.sum(0)


def _param_grad(grad: wp.array, like: torch.Tensor) -> torch.Tensor:
    """A copy of a parameter's gradient, shaped as its tensor."""
    return wp.to_torch(grad, requires_grad=False).reshape(like.shape).clone()
