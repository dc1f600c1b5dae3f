"""The memory of a rollout (warpdyn.engine.rollout): what its buffers, graphs and step workspaces take,
counted without allocating them (`Rollout.memory_bytes`) and from the arrays a run allocated
(`Rollout.nbytes`)."""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..types.enums import VelRepr
from . import warp_private
from .step import Evaluation, Workspace, state_buffers, step_launches

__all__ = [
    "GRAPH_CHUNK",
    "GRAPH_BYTES_PER_LAUNCH",
    "memory_error",
    "check_available",
    "launches_per_step",
    "reads_evaluation",
    "EVALUATION_RECORDS",
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

GRAPH_CHUNK = 256
"""The most steps one captured graph of a ping-pong rollout holds (see warpdyn.engine.rollout._Config): a graph
replayed ceil(T / GRAPH_CHUNK) times, around plain copies of the controls and records (a few launches per
chunk), so that its memory does not grow with T."""

GRAPH_BYTES_PER_LAUNCH = 4096
"""Host memory of one launch in a captured graph, measured with Warp 1.19's CPU graphs (their resident memory
freed when a graph is released, /proc/self/status after malloc_trim): 3.0 to 4.2 KiB per launch for the
pendulum chain (4 launches per step, 14-16 KiB per step) and the ergoCub legs with contacts (10 launches,
29-35 KiB per step). An estimate for `Rollout.memory_bytes`; a CUDA graph's memory is the driver's."""


def memory_error(what: str, size: int, error: Exception | None = None) -> MemoryError:
    """A MemoryError saying what needed how many bytes (and the allocator's message)."""
    cause = f": {error}" if error is not None else ""
    return MemoryError(f"{what} needs about {size / 2**30:.3g} GiB ({size} bytes){cause}")


def _available(device) -> int | None:
    """Bytes that can still be allocated on `device`: the CUDA device's free memory, the host's MemAvailable
    (Linux), None when unknown."""
    if device.is_cuda:
        return int(device.free_memory)
    try:
        with open("/proc/meminfo") as info:
            for line in info:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


def check_available(device, size: int, what: str) -> None:
    """A MemoryError naming `what` and its size when more than the device has available: the host would
    otherwise overcommit and kill the process when the pages are touched, a CUDA device fail midway."""
    available = _available(device)
    if available is not None and size > available:
        raise memory_error(what, size, RuntimeError(f"{available} bytes are available on '{device}'"))


EVALUATION_RECORDS = ("link_contact_forces", "collidable_point_forces")
"""The records read from a step's intermediate results (its workspace's evaluation: the link poses and the
points' contact wrenches), which a fused step then writes too (warpdyn.engine.step.step_launches)."""


def reads_evaluation(record) -> bool:
    """Whether recording `record` (names) reads the steps' intermediate results (EVALUATION_RECORDS)."""
    return any(name in EVALUATION_RECORDS for name in record)


def launches_per_step(plan, repr: int, record, forces: bool, ctrl: bool) -> int:
    """The launches of one step of a rollout with these records (built for one environment: the count does
    not depend on N)."""
    ws = Workspace(plan, 1, False, forces)
    x, y = state_buffers(plan, 1, False), state_buffers(plan, 1, False)
    f = arrays.zeros((plan.nL, 6), 1, plan.scalar, plan.device) if forces else None
    u = plan.zeros((plan.na,), 1) if ctrl else None
    count = len(step_launches(plan, ws, x, y, plan.zeros((plan.n,), 1), f, repr, None, u, evaluation=reads_evaluation(record)))
    shapes = state_shapes(plan)
    count += sum(1 for name in record if name in STATE_INDEX and (name == "valid" or int(np.prod(shapes[STATE_INDEX[name]])) > 0))
    count += sum(1 for name in record if name in EVALUATION_RECORDS and plan.contacts)
    return count


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
    return [(3,), (4,), (plan.nq,), (6,), (plan.n,), (plan.state_rows, 3)]


def roots(obj, found: dict, skip: set) -> dict:
    """{id: array}: the allocations (arrays owning their memory) that the Warp arrays in `obj` (an array, a
    list or tuple of them, a step workspace) are views of, except those in `skip` (ids)."""
    if isinstance(obj, wp.array):
        root = warp_private.allocation(obj)
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
    """{part: bytes} of a configuration of the Rollout `roll` (grad: under a tape), and the checkpoint interval
    it uses (see Rollout.memory_bytes)."""
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

    graphs = (not grad or storage == "checkpointed") if roll.use_graph == "auto" else bool(roll.use_graph)
    chunked = graphs and storage == "ping-pong"
    rows = min(T, GRAPH_CHUNK)

    def staging():
        """The stage buffers of chunked graphs: a row per step of a chunk for per-step controls and records."""
        if not chunked:
            return 0
        total = 0
        for name, layout in layouts.items():
            if layout.kind == "step":
                total += rows * (1 if layout.shared else N) * int(np.prod(per_control[name])) * size
        for name in roll.record:
            if name in STATE_INDEX:
                total += rows * N * (4 if name == "valid" else int(np.prod(shapes[STATE_INDEX[name]])) * size)
            elif name == "joint_torques" or plan.contacts:
                per_env = {"joint_torques": (plan.n,), "link_contact_forces": (plan.nL, 6), "collidable_point_forces": (plan.count, 6)}[name]
                total += rows * N * int(np.prod(per_env)) * size
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
        out["staging"] = staging()
        out["total"] = sum(out.values())
        return out

    every = 1
    if storage == "checkpointed":
        every = roll.checkpoint_every
        if every is None:  # the interval that keeps the fewest bytes (ties: the shorter one)
            every = min(range(1, T + 1), key=lambda S: parts(S)["total"])
    result = parts(every)
    result["checkpoint_every"] = every if storage == "checkpointed" else None
    steps = 0  # the steps the captured graphs hold (without callbacks)
    if graphs:
        steps = rows + (T % GRAPH_CHUNK if T > GRAPH_CHUNK else 0) if chunked else T
    per_step = launches_per_step(plan, repr, roll.record, layouts["link_forces"].kind is not None, layouts["ctrl"].kind is not None)
    result["graph"] = steps * per_step * GRAPH_BYTES_PER_LAUNCH
    return result

