"""The memory of a rollout (warpdyn.engine.rollout): what its buffers, graphs and step workspaces take,
counted without allocating them (`Rollout.memory_bytes`) and from the arrays a run allocated
(`Rollout.nbytes`)."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..types.enums import VelRepr
from .step import Evaluation, Workspace

__all__ = [
    "STATE_INDEX",
    "control_shapes",
    "counts",
    "record_is_view",
    "state_shapes",
    "roots",
    "nbytes",
    "plan_rows",
    "workspace_bytes_per_env",
    "plan_memory",
]

STATE_INDEX = {
    "base_position": 0,
    "base_quaternion": 1,
    "joint_positions": 2,
    "base_velocity": 3,
    "joint_velocities": 4,
    "tangential_deformation": 5,
    "valid": 6,
}
"""The index of each state record in a state's list of arrays (p, Q, s, v, sdot, m, valid)."""


def control_shapes(plan) -> dict:
    """{control: its shape per environment}."""
    return {"joint_force_references": (plan.n,), "link_forces": (plan.nL, 6), "ctrl": (plan.na,)}


def counts(storage: str, T: int, every: int, grad: bool) -> tuple[int, int, int]:
    """(kept, between, workspaces): how many states a configuration keeps for the whole rollout (ping-pong's
    two slots, the trajectory's T + 1, the checkpoints' ceil(T / every) + 1), how many it keeps for one
    segment (every - 1) and how many workspaces of step intermediates it has."""
    if storage == "ping-pong":
        return 2, 0, 1
    if storage == "trajectory":
        return T + 1, 0, T if grad else 1
    return -(-T // every) + 1, every - 1, every if grad else 1


def record_is_view(name: str, storage: str, every: int, repr: int) -> bool:
    """Whether a state record is a view of the kept states (all T + 1 of them kept, in the same form)."""
    all_kept = storage == "trajectory" or (storage == "checkpointed" and every == 1)
    return all_kept and (name != "base_velocity" or repr == int(VelRepr.Mixed))


def state_shapes(plan) -> list:
    """The per-environment shapes of the float state arrays (p, Q, s, v, sdot, m); `valid` is an int32 more."""
    return [(3,), (4,), (plan.n,), (6,), (plan.n,), (plan.total, 3)]


def roots(obj, found: dict, skip: set) -> dict:
    """{id: array}: the allocations (arrays owning their memory) that the Warp arrays in `obj` (an array, a
    list or tuple of them, a step workspace) are views of, except those in `skip` (ids)."""
    if isinstance(obj, wp.array):
        root = obj
        while getattr(root, "_ref", None) is not None:
            root = root._ref
        if root.deleter is not None and id(root) not in skip:  # not a view of memory owned elsewhere
            found[id(root)] = root
    elif isinstance(obj, (list, tuple)):
        for item in obj:
            roots(item, found, skip)
    elif isinstance(obj, (Workspace, Evaluation)):
        for item in vars(obj).values():
            roots(item, found, skip)
    return found


def nbytes(roots) -> int:
    """Bytes of these allocations and of their gradients."""
    total = 0
    for array in roots:
        for a in (array, array.grad):
            if a is not None:
                total += a.size * wp.types.type_size_in_bytes(a.dtype)
    return total


def plan_rows(plan) -> set:
    """Ids of the plan's shared zero rows (a workspace may hold them; they are the plan's, not the rollout's)."""
    return {id(row) for row in plan.zero_rows()}


def workspace_bytes_per_env(plan, grad: bool, forces: bool) -> int:
    """Bytes (gradients included) of one step workspace per environment: one built for 1 environment (every
    workspace array is (N, ...), so the bytes are N times these)."""
    ws = Workspace(plan, 1, grad, forces)
    return nbytes(roots(ws, {}, plan_rows(plan)).values())


def plan_memory(roll, plan, N: int, repr: int, storage: str, grad: bool, layouts: dict) -> dict:
    """{part: bytes} of a configuration of the Rollout `roll`, and the checkpoint interval it uses (see
    Rollout.memory_bytes)."""
    T, s = roll.steps, plan.scalar
    size = wp.types.type_size_in_bytes(s)
    g = 2 if grad else 1
    shapes = state_shapes(plan)
    state = sum(int(np.prod(shape)) for shape in shapes) * size * g + 4  # + the int32 health flag
    workspace = workspace_bytes_per_env(plan, grad, layouts["link_forces"].kind is not None)
    per_control = control_shapes(plan)

    def controls():
        total = 0
        for name, layout in layouts.items():
            per_env = per_control[name]
            if layout.kind is not None:
                rows = 1 if layout.shared else N
                total += rows * (T if layout.kind == "step" else 1) * int(np.prod(per_env)) * size * g
        return total

    def parts(every: int) -> dict:
        kept, between, count = counts(storage, T, every, grad)
        records = 0
        for name in roll.record:
            if name in STATE_INDEX:
                if record_is_view(name, storage, every, repr):
                    continue
                i = STATE_INDEX[name]
                records += (T + 1) * (4 if name == "valid" else int(np.prod(shapes[i])) * size * g)
            else:
                per_env = {"joint_torques": (plan.n,), "link_contact_forces": (plan.nL, 6), "collidable_point_forces": (plan.count, 6)}[name]
                records += T * int(np.prod(per_env)) * size * g
        out = {"states": (kept + between) * state * N, "intermediates": count * workspace * N, "controls": controls(), "records": records * N}
        out["total"] = sum(out.values())
        return out

    every = 1
    if storage == "checkpointed":
        every = roll.checkpoint_every
        if every is None:  # the interval that keeps the fewest bytes (ties: the shorter one)
            every = min(range(1, T + 1), key=lambda S: parts(S)["total"])
    result = parts(every)
    result["checkpoint_every"] = every if storage == "checkpointed" else None
    return result

