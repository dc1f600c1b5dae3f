"""The checks of a Data's state arrays against each other and against a model, run before every launch
that reads them: attribute reads only (types, dtypes, devices, shapes), no device synchronisation. A data
that passed them is remembered with the model (and its version) and the state arrays it was checked with:
while those are the same objects, `check_data` returns at once (a Warp array's dtype, device and shape do
not change)."""

from __future__ import annotations

import operator
import weakref

import warp as wp

__all__ = ["check_data", "check_state", "check_contact_state", "passes_like", "state_arrays"]

_STATE_ARRAYS = (
    ("base_position_state", 3),
    ("base_quaternion_state", 4),
    ("joint_positions_state", None),
    ("base_velocity_state", 6),
    ("joint_velocities_state", None),
)
"""The state arrays every computation reads, and their per-environment length (None: the joints', nq or nv)."""


def check_data(model, data, parameters: bool = False) -> list:
    """Errors naming what does not match between the data and the model, before any kernel reads the data:
    data of another dtype, model or device, then each state array (`check_state`). Attribute reads only:
    no device synchronisation. parameters: the caller reads the link or joint parameters, which, given per
    environment, need data of those N environments (per-environment joint origins and collidable points always
    do: kinematics read them). Returns the data's `state_arrays`: the list the checks
    remember while those arrays stay (the same list object from call to call, which callers may key on)."""
    memo = getattr(data, "__dict__", None)
    passed = memo.get("_checked") if memo is not None else None
    arrays = state_arrays(data) if passed is not None else None
    if (
        passed is not None
        and passed[0]() is model
        and passed[1] == model.version
        and passed[2] >= parameters
        and passed[3] == data.num_envs
        and all(map(operator.is_, passed[4], arrays))
    ):
        return passed[4]
    _check_types(data)
    if data.scalar != model.scalar:
        raise TypeError(f"data is in {data.dtype.name} but the model computes in {model.dtype.name}")
    nq, nv = model.number_of_joint_coordinates(), model.dofs()
    for name, expected in (("joint_positions_state", nq), ("joint_velocities_state", nv)):
        shape = tuple(getattr(data, name).shape)
        if shape[1:] != (expected,):
            raise ValueError(
                f"data.{name} has shape {shape}, expected ({shape[0]}, {expected}): model '{model.name()}' has {nq} joint "
                f"positions and {nv} joint velocities"
            )
    if data.device is not model.device and str(data.device) != str(model.device):
        raise ValueError(f"data is on device '{data.device}' but the model is on '{model.device}'")
    _check_shapes(data)
    N = data.base_position_state.shape[0]
    per_env = model.per_environment_parameters()
    read = per_env if parameters else {k: v for k, v in per_env.items() if k in ("joint_origins", "collidable_points")}  # kinematics read them
    if any(count != N for count in read.values()):
        raise ValueError(f"the model's parameters {per_env} are given per environment, but the data has {N} environments")
    arrays = state_arrays(data)
    if memo is not None:
        memo["_checked"] = (weakref.ref(model), model.version, parameters, data.num_envs, arrays)
    return arrays


def passes_like(data, source) -> None:
    """Remember that `data` passes the checks that `source` passed last, when its state arrays were made with the
    dtypes, devices and shapes of those of `source` and its num_envs is the same (a step's result: the next call
    on it then checks nothing)."""
    passed = getattr(source, "__dict__", {}).get("_checked")
    memo = getattr(data, "__dict__", None)
    if passed is None or memo is None or passed[3] != data.num_envs or not all(map(operator.is_, passed[4], state_arrays(source))):
        return
    memo["_checked"] = (*passed[:4], state_arrays(data))


def state_arrays(data) -> list:
    """The state of `data` as the kernels take it: (p, Q, s, v (Mixed), sdot, m, valid); also what the checks
    remember a data by."""
    return [
        data.base_position_state,
        data.base_quaternion_state,
        data.joint_positions_state,
        data.base_velocity_state,
        data.joint_velocities_state,
        data.tangential_deformation_state,
        data.valid_state,
    ]


def check_state(data) -> None:
    """A TypeError or ValueError naming the state array of `data` that is not a Warp array of the data's
    dtype (that of base_position_state) on its device, with one batch size N for all (N, 3), (N, 4), (N, n),
    (N, 6), (N, n), (N, nc, 3) and (N,) int32 (a kernel launched over N would otherwise read past a
    shorter array), or whose num_envs disagrees with N. The contact state and the health flag may be None
    (functions that do not read them); `step` requires them. Attribute reads only."""
    _check_types(data)
    _check_shapes(data)


def _check_types(data) -> None:
    for name, _ in _STATE_ARRAYS:
        value = getattr(data, name, _ABSENT)
        if value is not _ABSENT and (not isinstance(value, wp.array) or value.ndim != 2):
            raise TypeError(f"data.{name} must be a Warp array (N, k), got {_described(value)}")


def _check_shapes(data) -> None:
    position = data.base_position_state
    N, scalar, device = position.shape[0], position.dtype, position.device
    for name, item in _STATE_ARRAYS:
        array = getattr(data, name)
        _check_field(name, array, (N, array.shape[1] if item is None else item), scalar, device)
    deformation = data.tangential_deformation_state
    if deformation is not None:
        if not isinstance(deformation, wp.array) or deformation.ndim != 3:
            raise TypeError(f"data.tangential_deformation_state must be a Warp array (N, nc, 3) or None, got {_described(deformation)}")
        _check_field("tangential_deformation_state", deformation, (N, deformation.shape[1], 3), scalar, device)
    valid = data.valid_state
    if valid is not None:
        if not isinstance(valid, wp.array):
            raise TypeError(f"data.valid_state must be a Warp array (N,) of int32 or None, got {_described(valid)}")
        _check_field("valid_state", valid, (N,), wp.int32, device)
    if data.num_envs is not None and data.num_envs != N or data.num_envs is None and N != 1:
        raise ValueError(f"data.num_envs is {data.num_envs}, but its arrays hold {N} environments (None means 1)")


_ABSENT = object()


def _described(value) -> str:
    if isinstance(value, wp.array):
        return f"an array of shape {tuple(value.shape)}"
    return "None" if value is None else f"a {type(value).__name__}"


def _check_field(name: str, array: wp.array, shape: tuple, dtype, device) -> None:
    """A TypeError or ValueError naming data.<name> when its dtype, device or shape is not the expected."""
    if array.dtype != dtype:
        raise TypeError(f"data.{name} has dtype {wp.types.type_repr(array.dtype)}, expected {wp.types.type_repr(dtype)}")
    if array.device is not device and str(array.device) != str(device):
        raise ValueError(f"data.{name} is on device '{array.device}', the data's other arrays on '{device}'")
    if tuple(array.shape) != shape:
        raise ValueError(
            f"data.{name} has shape {tuple(array.shape)}, expected {shape}: N = {shape[0]} environments (from "
            "data.base_position_state)"
        )


def check_contact_state(model, data) -> None:
    """A ValueError when the data's contact state does not hold the model's rows (Model.contact_state_rows)."""
    total = model.contact_state_rows()
    m = data.tangential_deformation_state
    if m is None or m.shape[1] != total:
        got = None if m is None else m.shape[1]
        points = len(model.kin_dyn_structure().contact_parameters.body)
        slots = f" and {total - points} geom pair contact slots (model.geom_contacts)" if total > points else ""
        raise ValueError(
            f"data holds {got} rows of tangential deformation but the model's contact state has {total}: {points} "
            f"collidable points{slots}; build the data from this model (wd.data.Data.build) after changing its "
            "collidable points or geom_contacts"
        )
