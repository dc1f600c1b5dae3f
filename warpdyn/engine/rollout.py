"""Rollouts: many steps in one call, with per-step controls, recording into device arrays (the engine of
warpdyn.simulation, whose docstring describes controls, records, storage, callbacks and graphs).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import warp as wp

from .. import arrays, config
from ..kernels.contact_wrenches import kernels as wrench_kernels
from ..kernels.rollout import kernels as rollout_kernels
from ..kernels.state import kernels as state_kernels
from ..types.enums import VelRepr
from .tape import suspended
from .tape import taping as tape_records
from .kinematics import state_arrays
from .launch import Launch, Program, copy_launch, graphs_allowed, launch
from .launch import run as run_launches
from . import rollout_memory as memory
from .rollout_memory import GRAPH_BYTES_PER_LAUNCH, STATE_INDEX, check_available, control_shapes, counts, memory_error, nbytes
from .rollout_memory import plan_memory, plan_rows, reads_evaluation, record_is_view, roots, state_shapes
from .step import Workspace, broadcast_envs, prepare, state_buffers, step_launches, with_state
from .step import plan as step_plan

__all__ = ["Rollout", "STATE_RECORDS", "STEP_RECORDS", "DEFAULT_RECORD", "CONTROLS"]

STATE_RECORDS = (
    "base_position",
    "base_quaternion",
    "joint_positions",
    "joint_velocities",
    "base_velocity",
    "tangential_deformation",
    "valid",
)
"""Quantities of the state, recorded at t = 0 ... T."""

STEP_RECORDS = ("joint_torques", "link_contact_forces", "collidable_point_forces")
"""Quantities of a step, recorded for t = 0 ... T - 1."""

DEFAULT_RECORD = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")

CONTROLS = ("joint_force_references", "link_forces", "ctrl")
"""The controls of a rollout's steps (warpdyn.model.step's arguments)."""


def _env_array(lead: tuple, N: int, per_env: tuple, dtype, device, grad: bool = False) -> wp.array:
    """An array of logical shape (*lead, N, *per_env) in the device's layout (environment fastest on GPUs,
    see warpdyn.arrays), so that a slice [t] is an (N, *per_env) array as a step's kernels want it."""
    lead, per_env = tuple(int(x) for x in lead), tuple(int(x) for x in per_env)
    if arrays.env_fastest(device) and per_env:
        physical = wp.empty((*lead, *per_env, N), dtype=dtype, device=device, requires_grad=grad)
        L, P = len(lead), len(per_env)
        array = physical.transpose((*range(L), L + P, *range(L, L + P)))
    else:
        array = wp.empty((*lead, N, *per_env), dtype=dtype, device=device, requires_grad=grad)
    if config.fill_outputs_with_nan and dtype in (wp.float32, wp.float64):
        array.fill_(float("nan"))
    return array


def _at(array: wp.array, t: int) -> wp.array:
    """array[t] (Warp cannot slice an array that has a zero-length axis: then an empty array of that shape)."""
    if array.size == 0:
        return wp.empty(tuple(array.shape[1:]), dtype=array.dtype, device=array.device)
    return array[t]


@dataclasses.dataclass(frozen=True)
class _Layout:
    """How a control is given: kind None (absent), "const" or "step"; shared: one value for all environments."""

    kind: str | None
    shared: bool = False


def _control_layout(shape: tuple, name: str, per_env: tuple, T: int, N: int, batched: bool) -> tuple:
    """(target, layout): a control of `shape` as a Warp array of logical shape `target`, (1 or N, *per_env)
    ("const") or (T, 1 or N, *per_env) ("step"). Raises ValueError for shapes not accepted."""
    per_env, shape = tuple(per_env), tuple(int(x) for x in shape)
    accepted = {per_env: (per_env, "const", True), (T, 1, *per_env): ((T, 1, *per_env), "step", True)}
    if batched:
        accepted[(N, *per_env)] = ((N, *per_env), "const", False)
        accepted[(T, N, *per_env)] = ((T, N, *per_env), "step", False)
    else:
        accepted[(T, *per_env)] = ((T, 1, *per_env), "step", True)
        accepted[(1, *per_env)] = ((1, *per_env), "const", True)
    if shape not in accepted:
        raise ValueError(f"{name} has shape {shape}; accepted: {sorted(accepted, key=len)} (T = {T} steps, N = {N})")
    target, kind, shared = accepted[shape]
    if kind == "const" and shared:
        target = (1, *per_env)
    return target, _Layout(kind, shared)


def _control(value, name: str, per_env: tuple, T: int, N: int, batched: bool, scalar, device):
    """(layout, source): the control as a Warp array of logical shape (1 or N, *per_env) ("const") or
    (T, 1 or N, *per_env) ("step"), or (_Layout(None), None)."""
    if value is None:
        return _Layout(None), None
    shape = tuple(value.shape) if isinstance(value, wp.array) else np.shape(value)
    target, layout = _control_layout(shape, name, per_env, T, N, batched)
    if isinstance(value, wp.array):
        arrays.check_device_array(value, name, scalar, device)
        source = value if tuple(value.shape) == target else value.reshape(target)
    else:
        host = arrays.host_numbers(value, name)
        bad = np.argwhere(~np.isfinite(host))
        if bad.size:
            raise ValueError(f"{name} has non-finite values, first at index {tuple(bad[0].tolist())}: {host[tuple(bad[0])]}")
        source = wp.array(np.ascontiguousarray(host.reshape(target)), dtype=scalar, device=device)
    return layout, source


# ------------------------------------------------------------------------------------------ configuration


class _Config:
    """A rollout's buffers, launches and graphs for one configuration (see `Rollout`).

    storage: "ping-pong", "trajectory" or "checkpointed"; every: the checkpoint interval S (1 otherwise).
    States: ping-pong's two slots (`slots`), or the kept states `traj` (all T + 1, or the checkpoints
    t = 0, S, 2S, ..., T) and, for checkpointed storage with S > 1, `seg`: the S - 1 states inside one
    segment, reused by every segment.

    Graphs of ping-pong storage are captured in chunks of at most GRAPH_CHUNK steps (rollout_memory), one graph per chunk
    length and parity of its first step (which slot it starts from), replayed as many times as the run has
    chunks: their steps read their controls from and write their records into `stage`, (K, ...) buffers
    (K = min(T, GRAPH_CHUNK)) that plain launches fill and empty around each replay, so that a graph's memory
    does not grow with T. Other storages keep their states per step: their graphs hold every step.
    """

    def __init__(self, roll: Rollout, plan, N: int, num_envs, repr: int, storage: str, every: int, grad: bool, layouts: dict):
        self.plan, self.N, self.num_envs, self.repr = plan, N, num_envs, repr
        self.storage, self.every, self.grad, self.layouts = storage, every, grad, layouts
        T, s, d = roll.steps, plan.scalar, plan.device
        self.T, self.scalar, self.device = T, s, d
        self.use_graph = roll.use_graph  # the chunks' Programs capture as the Rollout allows
        kept, between, count = counts(storage, T, every, grad)
        per_env = state_shapes(plan)
        self.slots = self.traj = self.seg = None
        if storage == "ping-pong":
            self.slots = [state_buffers(plan, N, False) for _ in range(2)]
        else:
            self.traj = [_env_array((kept,), N, shape, s, d, grad) for shape in per_env]
            self.traj.append(_env_array((kept,), N, (), wp.int32, d))
            if between:
                self.seg = [_env_array((between,), N, shape, s, d, grad) for shape in per_env]
                self.seg.append(_env_array((between,), N, (), wp.int32, d))
        with_forces = layouts["link_forces"].kind is not None
        self.workspaces = [Workspace(plan, N, grad, with_forces) for _ in range(count)]
        # controls: {name: the rollout's copy, None when absent}
        shapes = control_shapes(plan)
        self.buffers = {name: self._control_buffer(layout, shapes[name]) for name, layout in layouts.items()}
        # records
        self.records: dict[str, wp.array] = {}
        self.state_records: dict[str, wp.array] = {}  # the ones written by launches (not views of the states)
        for name in roll.record:
            if name in STATE_INDEX:
                i = STATE_INDEX[name]
                if record_is_view(name, storage, every, repr):
                    self.records[name] = self.traj[i]
                    continue
                if name == "valid":
                    array = _env_array((T + 1,), N, (), wp.int32, d)
                else:
                    array = _env_array((T + 1,), N, per_env[i], s, d, grad)
                self.records[name] = self.state_records[name] = array
            elif name == "joint_torques":
                self.records[name] = _env_array((T,), N, (plan.n,), s, d, grad)
            elif name == "link_contact_forces":
                array = self.records[name] = _env_array((T,), N, (plan.nL, 6), s, d, grad)
                if not plan.contacts:
                    array.zero_()
            elif name == "collidable_point_forces":
                self.records[name] = _env_array((T,), N, (plan.count, 6), s, d, grad)
        # the state records that are plain copies of a state array (the checkpointed backward adds their
        # gradients to the states' instead of recomputing the copies); the others are launches of the steps
        converted = ("valid",) if repr == int(VelRepr.Mixed) else ("valid", "base_velocity")
        self.copied = [name for name in self.state_records if name not in converted]
        self.launched = [name for name in self.state_records if name in converted]
        self.graphs: dict[tuple, Program] = {}  # the Programs of its chunks of steps (graphs where captured)
        self.stage: dict[str, wp.array] | None = None  # allocated by the first chunked capture (`_staging`)
        self._scratch_grads = None
        self.runs = 0  # runs of this configuration (a checkpointed backward checks that it is the latest)
        self.template = None  # the data of the last run (see `data_at`)

    def _control_buffer(self, layout: _Layout, per_env: tuple):
        if layout.kind is None:
            return None
        rows = 1 if layout.shared else self.N
        lead = (self.T,) if layout.kind == "step" else ()
        return _env_array(lead, rows, per_env, self.scalar, self.device, self.grad)

    def nbytes(self) -> int:
        """Bytes of the buffers this configuration allocated (states, workspaces, controls, records), with
        their gradients; the model's and plan's constants are not counted."""
        owned = [self.slots, self.traj, self.seg, self.workspaces, list(self.buffers.values()), list(self.records.values())]
        owned.append(list(self.stage.values()) if self.stage is not None else None)
        return nbytes(roots([x for x in owned if x is not None], {}, plan_rows(self.plan)).values())

    # ----------------------------------------------------------------------------------- views per step

    def state(self, t: int) -> list:
        if self.slots is not None:
            return self.slots[t % 2]
        S = self.every
        if t % S == 0 or t == self.T:
            return [_at(a, -(-t // S)) for a in self.traj]  # checkpoint ceil(t / S): t / S, or the last one at T
        return [_at(a, t % S - 1) for a in self.seg]

    def _input(self, name: str, t: int, absent, k: int | None = None):
        """Control `name` at step t as an (N, *shape) array (`absent` when not given); from stage row k when given."""
        layout, buffer = self.layouts[name], self.buffers[name]
        if layout.kind is None:
            return absent
        if layout.kind == "step":
            view = _at(buffer, t) if k is None else _at(self.stage[name], k)
        else:
            view = buffer
        return broadcast_envs(view, self.N) if layout.shared else view

    def _record(self, name: str, t: int, k: int | None) -> wp.array:
        """Record `name` at t, or stage row k when given."""
        return _at(self.records[name] if k is None else self.stage[name], t if k is None else k)

    def record_state(self, t: int, x: list, names=None, k: int | None = None) -> list:
        """The launches writing the state records at t (those in `names`, default all) from the state arrays x
        (into stage row k when given)."""
        launches = []
        for name in self.state_records if names is None else names:
            out = self._record(name, t, k)
            if name == "base_velocity" and self.repr != int(VelRepr.Mixed):
                launches.append(Launch(state_kernels(self.scalar).base_velocity_to_repr, self.N, [x[0], x[1], x[3], self.repr], [out]))
            else:
                launches.append(copy_launch(self.scalar, x[STATE_INDEX[name]], out))
        return [k for k in launches if k is not None]

    def step(self, t: int, copies: bool = True, k: int | None = None) -> list:
        """The launches of step t: the state t to t + 1, its records, and the state records at t + 1 (without
        the plain copies unless `copies`); controls and records in stage row k when given (chunked graphs)."""
        plan = self.plan
        ws = self.workspaces[t % len(self.workspaces)]
        x, y = self.state(t), self.state(t + 1)
        tau_ref = self._input("joint_force_references", t, plan.zeros((plan.n,), self.N), k)
        f_user = self._input("link_forces", t, None, k)
        ctrl = self._input("ctrl", t, None, k)
        tau_out = self._record("joint_torques", t, k) if "joint_torques" in self.records else None
        launches = step_launches(plan, ws, x, y, tau_ref, f_user, self.repr, tau_out, ctrl, evaluation=reads_evaluation(self.records))
        ev = ws.evals[0]
        K = wrench_kernels(self.scalar)
        if "link_contact_forces" in self.records and plan.contacts:
            out = self._record("link_contact_forces", t, k)
            launches.append(Launch(K.link_wrenches, (self.N, plan.nL), [plan.contact_bundle, ev.W_H_L, ev.W_f_C, self.repr], [out]))
        if "collidable_point_forces" in self.records and plan.contacts:
            out = self._record("collidable_point_forces", t, k)
            args = [plan.contact_bundle, plan.point_out, ev.W_H_L, ev.W_f_C, self.repr]
            launches.append(Launch(K.point_wrenches, (self.N, plan.count), args, [out]))
        return launches + self.record_state(t + 1, y, None if copies else self.launched, k)

    def data_at(self, t: int):
        """The state at t as the caller's kind of Data (views of the rollout's buffers)."""
        return with_state(self.template, self.state(t))

    def load_state(self, t: int, data) -> None:
        """Launches copying `data`'s state into the state t (recorded by a tape)."""
        x = self.state(t)
        src = state_arrays(data)
        run_launches([k for k in (copy_launch(self.scalar, a, b) for a, b in zip(src, x)) if k is not None], self.device)

    def load_controls(self, sources: dict) -> None:
        """Copy the given controls ({name: source}) into the rollout's buffers (recorded by a tape)."""
        launches = []
        for name, source in sources.items():
            if source is not None:
                launches.append(copy_launch(self.scalar, source, self.buffers[name]))
        run_launches([k for k in launches if k is not None], self.device)

    def run_steps(self, start: int, stop: int, graph: bool) -> None:
        if not graph:
            for t in range(start, stop):
                run_launches(self.step(t), self.device)
            return
        if self.slots is None:  # every step has its own states: one graph of the stretch
            self._replay((start, stop), lambda: [k for t in range(start, stop) for k in self.step(t)])
            return
        self._staging()
        chunk = memory.GRAPH_CHUNK
        for first in range(start, stop, chunk):
            length = min(chunk, stop - first)
            run_launches(self._stage_copies(first, length, into_stage=True), self.device)
            self._replay(("chunk", length, first % 2), lambda: [k for i in range(length) for k in self.step(first + i, k=i)])
            run_launches(self._stage_copies(first, length, into_stage=False), self.device)

    def _replay(self, key: tuple, launches) -> None:
        """Run the Program of `launches()` kept under `key` (warpdyn.engine.launch: captured at its first run where
        `use_graph` allows, as the caller found it does; else replayed from its recording)."""
        program = self.graphs.get(key)
        if program is None:
            program = self.graphs[key] = Program(launches(), self.device, self.use_graph, "a Rollout")
        try:
            program.run()
        except RuntimeError as error:  # a failed allocation of its capture; other errors pass as they are
            if program.replay is not None or "alloc" not in str(error).lower():
                raise
            del self.graphs[key]
            n = len(program.work)
            raise memory_error(f"capturing a graph of {n} launches", n * GRAPH_BYTES_PER_LAUNCH, error) from None

    def _staging(self) -> None:
        """The stage buffers of chunked graphs (see the class docstring), allocated once: a row per step of a
        chunk for each per-step control and each record a step writes."""
        if self.stage is not None:
            return
        rows = min(self.T, memory.GRAPH_CHUNK)
        self.stage = {}
        for name, layout in self.layouts.items():
            if layout.kind == "step":
                buffer = self.buffers[name]
                self.stage[name] = _env_array((rows,), buffer.shape[1], buffer.shape[2:], self.scalar, self.device)
        for name, record in self.records.items():
            if name in self.state_records or name == "joint_torques" or self.plan.contacts:
                self.stage[name] = _env_array((rows,), self.N, record.shape[2:], record.dtype, self.device)

    def _stage_copies(self, first: int, length: int, into_stage: bool) -> list:
        """The launches copying the controls of steps first .. first + length - 1 into the stage
        (into_stage), or the stage's records out to theirs (state records at t + 1, step records at t)."""
        launches = []
        for name, stage in self.stage.items():
            control = name in self.buffers
            if control != into_stage or stage.size == 0:
                continue
            offset = first + (1 if name in self.state_records else 0)
            full = (self.buffers if control else self.records)[name][offset : offset + length]
            src, dst = (full, stage[:length]) if into_stage else (stage[:length], full)
            launches.append(copy_launch(self.scalar, src, dst))
        return [k for k in launches if k is not None]

    # ----------------------------------------------------------------------------------- checkpointed

    def tape_arrays(self) -> list:
        """The rollout's arrays whose gradients the checkpointed backward reads or adds into, for the user's
        tape to zero in `Tape.zero()` (it sees none of the steps' launches): the kept states, the records and
        the control buffers."""
        candidates = [*self.traj, *self.records.values(), *self.buffers.values()]
        return [a for a in candidates if a is not None and a.grad is not None and a.size > 0]

    def parameters(self) -> list:
        """The model parameters the steps read that require gradients (the plan's launch arguments)."""
        return [a for a in self.plan.parameter_arrays() if a.grad is not None and a.size > 0]

    def _add_record_grads(self, start: int, stop: int) -> None:
        """state.grad[t] += record.grad[t] for t in [start, stop) (stop - 1 at most one segment after start), for
        the records that are plain copies of a state: the adjoints of the copies, which the recomputation leaves
        out. Run just before the steps' adjoints that add into those states, as the tape of "trajectory" storage
        adds the loss's first: the same sums in the same order."""
        K = rollout_kernels(self.scalar).copy
        for name in self.copied:
            i, record = STATE_INDEX[name], self.state_records[name]
            if record.size == 0:
                continue
            pairs = [(self.state(start)[i], record[start])]
            if stop - start > 1:
                pairs.append((self.seg[i][: stop - start - 1], record[start + 1 : stop]))
            for state, rec in pairs:
                launch(
                    K[rec.ndim], dim=rec.shape, inputs=[state], outputs=[rec], adj_inputs=[state.grad], adj_outputs=[rec.grad],
                    adjoint=True, device=self.device,
                )

    def backward(self, tape: wp.Tape, run: int) -> None:
        """The adjoint of the T steps, run by the user's `tape` (`Tape.record_func`), segments last to first.
        run: the number of the run that recorded it; a later run of this configuration overwrote the buffers
        the recomputation starts from, so its backward is refused (RuntimeError) rather than wrong.

        Each segment [start, stop) is recomputed from its checkpoint under an inner tape (the launches of the
        forward pass on the same arrays, so the same numbers, less the records' plain copies: the records
        hold their values already) and that tape's backward is run: it reads the gradients already in the
        state at `stop` (from the later segments and the records) and in the segment's step records, and
        adds into the state at `start`, the control buffers and the model parameters; before, the gradients
        of the copied state records are added to the segment's states.

        The segment's scratch (its states between checkpoints and the workspaces), reused by every segment,
        has its gradients zeroed once, before the last segment: Warp zeroes an array element's gradient when
        the adjoint of the launch that wrote it reads it (arrays without retain_grad), and every scratch
        element whose gradient a segment's adjoints add to is written in that segment, so each segment
        leaves them zero for the next (tests/test_rollout_checkpoint.py checks it); zeroing per segment
        would cost a launch per array and step.

        The model parameters' gradients are entered in the user's tape's `gradients` here, when their adjoints
        run, as its own launches' adjoints enter theirs, so that `tape.zero()` zeroes the gradient arrays the
        parameters hold at the backward pass."""
        if run != self.runs:
            raise RuntimeError(
                "a checkpointed rollout's backward pass recomputes from the Rollout's buffers, which a later run "
                "of the same Rollout overwrote: call tape.backward before running it again (or use another Rollout)"
            )
        if self._scratch_grads is None:
            scratch = roots([self.seg, self.workspaces] if self.seg is not None else self.workspaces, {}, plan_rows(self.plan))
            self._scratch_grads = [r.grad for r in scratch.values() if r.grad is not None and r.size > 0]
        S, T = self.every, self.T
        for a in self.parameters():
            tape.gradients[a] = a.grad
        with suspended():
            for g in self._scratch_grads:
                g.zero_()
            self._add_record_grads(T, T + 1)
            for start in reversed(range(0, T, S)):
                stop = min(start + S, T)
                self._add_record_grads(start, stop)
                inner = wp.Tape()
                with inner:
                    for t in range(start, stop):
                        run_launches(self.step(t, copies=False), self.device)
                inner.backward()


class Rollout:
    """Reusable rollouts of `steps` steps of a model (see the module docstring).

    record: names among STATE_RECORDS and STEP_RECORDS. storage: "auto", "ping-pong", "trajectory" or
    "checkpointed". checkpoint_every: for "checkpointed" only, the interval c in steps between kept states
    (1 <= c <= steps; c = 1 keeps all T + 1 states and recomputes only the steps' intermediates), or None:
    the c that minimises the bytes the rollout keeps (`memory_bytes`), about sqrt(T S / (S + W)) for states
    of S numbers and step intermediates of W (module docstring). use_graph: "auto", True or False (True is
    refused under a tape except with "checkpointed" storage). Buffers are allocated by the first `run` and
    kept for the last configuration (batch size, representation, control shapes, storage, whether a tape
    records, the model's parameters); `nbytes` says how many bytes they take, `memory_bytes` how many a
    configuration would take.
    """

    def __init__(self, model, *, steps: int, record=DEFAULT_RECORD, storage: str = "auto", checkpoint_every: int | None = None, use_graph="auto"):
        if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 1:
            raise ValueError(f"steps must be a positive integer, got {steps!r}")
        if isinstance(record, str):
            record = (record,)
        record = tuple(dict.fromkeys(record))
        unknown = [r for r in record if r not in STATE_RECORDS + STEP_RECORDS]
        if unknown:
            raise ValueError(f"record names unknown quantities {unknown}; known: {list(STATE_RECORDS + STEP_RECORDS)}")
        if storage not in ("auto", "ping-pong", "trajectory", "checkpointed"):
            raise ValueError(f"storage must be 'auto', 'ping-pong', 'trajectory' or 'checkpointed', got {storage!r}")
        if checkpoint_every is not None:
            if storage != "checkpointed":
                raise ValueError(f"checkpoint_every applies to storage='checkpointed', not {storage!r}")
            bad = isinstance(checkpoint_every, (bool, np.bool_)) or not isinstance(checkpoint_every, (int, np.integer))
            if bad or not 1 <= checkpoint_every <= steps:
                raise ValueError(f"checkpoint_every must be an integer from 1 to steps = {steps}, got {checkpoint_every!r}")
            checkpoint_every = int(checkpoint_every)
        if use_graph not in ("auto", True, False):
            raise ValueError(f"use_graph must be 'auto', True or False, got {use_graph!r}")
        self.model = model
        self.steps = int(steps)
        self.record = record
        self.storage = storage
        self.checkpoint_every = checkpoint_every
        self.use_graph = use_graph
        self._config: _Config | None = None
        self._key = None

    def _storage(self, taping: bool) -> str:
        if self.storage == "auto":
            return "trajectory" if taping else "ping-pong"
        return self.storage

    def memory_bytes(
        self, num_envs, *, grad: bool = True, velocity_representation=VelRepr.Mixed, joint_force_references=None, link_forces=None, ctrl=None
    ) -> dict:
        """The bytes `run` would keep allocated for `num_envs` environments (None: single-environment data),
        with gradients when `grad` (under a wp.Tape), without allocating them: {"states", "intermediates"
        (the step workspaces), "controls" (the rollout's copies), "records", "staging" (the stage buffers of
        chunked graphs), "total"} in bytes, "graph" (host memory of the captured graphs without callbacks,
        an estimate: GRAPH_BYTES_PER_LAUNCH per launch; not in "total") and "checkpoint_every" (the interval
        used, None unless storage is "checkpointed").

        The controls are given as to `run`, or anything with their `.shape` (only the shape is read:
        `np.broadcast_to(0.0, (T, N, n))` costs nothing). Counted: the buffers the rollout owns and their
        gradients (exactly what `nbytes` reports after a run); not counted: the model, the user's data and
        controls, the tape, a loss. "auto" storage is taken as under a tape when `grad`, else ping-pong.
        Memory per environment and step: total / (num_envs * steps).
        """
        plan = step_plan(self.model)
        batched = num_envs is not None
        if batched and (isinstance(num_envs, (bool, np.bool_)) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1):
            raise ValueError(f"num_envs must be a positive integer or None (single-environment data), got {num_envs!r}")
        N = int(num_envs) if batched else 1
        plan.check_envs(N)
        given = {"joint_force_references": joint_force_references, "link_forces": link_forces, "ctrl": ctrl}
        layouts = {}
        for (name, value), per_env in zip(given.items(), control_shapes(plan).values()):
            shape = None if value is None else (tuple(value.shape) if hasattr(value, "shape") else np.shape(value))
            layouts[name] = _Layout(None) if shape is None else _control_layout(shape, name, per_env, self.steps, N, batched)[1]
        storage = self._storage(grad)
        grad = grad and storage != "ping-pong"
        return plan_memory(self, plan, N, int(velocity_representation), storage, grad, layouts)

    @property
    def nbytes(self) -> int:
        """Bytes of the buffers the last `run` allocated, gradients included (0 before the first run)."""
        return 0 if self._config is None else self._config.nbytes()

    def run(self, data, *, joint_force_references=None, link_forces=None, ctrl=None, callback=None, callback_every: int = 1):
        """(final Data, {name: record}) after `steps` steps from `data` (unchanged)."""
        model, T = self.model, self.steps
        plan, N = prepare(model, data, health=True)
        taping = tape_records()
        storage = self._storage(taping)
        checkpointed = storage == "checkpointed"
        if storage == "ping-pong" and taping:
            raise ValueError("storage='ping-pong' overwrites states, which a wp.Tape needs: use 'trajectory', 'checkpointed' (or 'auto')")
        if self.use_graph is True and taping and not checkpointed:
            raise ValueError("use_graph=True under a wp.Tape: the tape must record each launch; use 'auto' or False")
        if callback is not None:
            if isinstance(callback_every, (bool, np.bool_)) or not isinstance(callback_every, (int, np.integer)) or callback_every < 1:
                raise ValueError(f"callback_every must be a positive integer, got {callback_every!r}")
            if checkpointed and taping:
                raise ValueError(
                    "callbacks are not supported with storage='checkpointed' under a wp.Tape: the steps run unrecorded and "
                    "are recomputed in the backward pass, so what a callback launched would not be differentiated in order; "
                    "use storage='trajectory'"
                )
        s, d, batched = plan.scalar, plan.device, data.num_envs is not None
        given = {"joint_force_references": joint_force_references, "link_forces": link_forces, "ctrl": ctrl}
        layouts, sources = {}, {}
        for (name, value), per_env in zip(given.items(), control_shapes(plan).values()):
            layouts[name], sources[name] = _control(value, name, per_env, T, N, batched, s, d)
        grad = taping and storage != "ping-pong"
        repr = int(data.velocity_representation)
        key = (plan, N, data.num_envs, repr, storage, self.checkpoint_every, grad, *layouts.values())
        if self._key is None or len(key) != len(self._key) or not all(a is b or a == b for a, b in zip(key, self._key)):
            self._config = None  # release the old buffers first
            budget = plan_memory(self, plan, N, repr, storage, grad, layouts)
            every = (self.checkpoint_every or budget["checkpoint_every"]) if checkpointed else 1
            what = f"a rollout of {T} steps of {N} environments ({storage} storage)"
            check_available(d, budget["total"] + (0 if d.is_cuda else budget["graph"]), what)  # CPU graphs: host memory
            try:
                self._config = _Config(self, plan, N, data.num_envs, repr, storage, every, grad, layouts)
            except RuntimeError as error:  # Warp's "Failed to allocate N bytes on device"
                if "allocate" not in str(error):
                    raise
                raise memory_error(what, budget["total"], error) from None
            self._key = key
        cfg = self._config
        cfg.template = data  # the Data the records and callbacks' states are made like
        cfg.runs += 1
        graph = (not taping or checkpointed) if self.use_graph == "auto" else bool(self.use_graph)
        graph = graph and graphs_allowed(d, self.use_graph, "a Rollout")
        cfg.load_controls(sources)
        cfg.load_state(0, data)
        if checkpointed and taping:
            # the steps and the records' plain copies run unrecorded (the backward recomputes the steps and adds
            # the copies' gradients); the converting records at 0 are recorded, as with "trajectory"
            with suspended() as recording:
                run_launches(cfg.record_state(0, cfg.state(0), cfg.copied), d)
                cfg.run_steps(0, T, graph)
            run_launches(cfg.record_state(0, cfg.state(0), cfg.launched), d)
            recording.record_func(backward=functools.partial(cfg.backward, recording, cfg.runs), arrays=cfg.tape_arrays())
            return cfg.data_at(T), {name: _squeeze(a, data.num_envs) for name, a in cfg.records.items()}
        run_launches(cfg.record_state(0, cfg.state(0)), d)
        stops = list(range(callback_every, T, callback_every)) + [T] if callback is not None else [T]
        start = 0
        for stop in stops:
            cfg.run_steps(start, stop, graph)
            if callback is not None and stop % callback_every == 0:
                replacement = callback(stop, cfg.data_at(stop))
                if replacement is not None:
                    self._replace(cfg, stop, replacement, taping)
            start = stop
        return cfg.data_at(T), {name: _squeeze(a, data.num_envs) for name, a in cfg.records.items()}

    def _replace(self, cfg: _Config, t: int, data, taping: bool) -> None:
        if taping:
            raise ValueError("a callback replaced the state under a wp.Tape: resets are not differentiable")
        if type(data) is not type(cfg.template):
            raise TypeError(f"a callback returns None or Data, got {type(data).__name__}")
        prepare(self.model, data, health=True)
        if data.batch_size != cfg.N or int(data.velocity_representation) != cfg.repr:
            raise ValueError(
                f"the callback's data has {data.batch_size} environments in {VelRepr(data.velocity_representation).name}, "
                f"the rollout {cfg.N} in {VelRepr(cfg.repr).name}"
            )
        cfg.load_state(t, data)
        run_launches(cfg.record_state(t, cfg.state(t)), cfg.device)


def _squeeze(array: wp.array, num_envs) -> wp.array:
    """A record (L, N, ...) as it is for batched data, (L, ...) (environment 0) for single-environment data."""
    if num_envs is not None:
        return array
    if array.size == 0:
        return wp.empty((array.shape[0], *array.shape[2:]), dtype=array.dtype, device=array.device)
    return array[:, 0]
