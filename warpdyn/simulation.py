"""Rollouts: many steps of `wd.model.step` in one call, with per-step controls, recording into device arrays.

    final, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau)   # tau (T, N, n)
    rec["joint_positions"]        # (T + 1, N, n): s at t = 0 (the given data) ... T

    roll = wd.simulation.Rollout(model, steps=T, record=("base_position", "joint_torques"))
    for episode in ...:                        # buffers, kernels and graphs are reused: nothing allocated,
        final, rec = roll.run(data, joint_force_references=tau)          # no host work per step

A rollout is `steps` applications of `wd.model.step` (same launches, same numbers: bitwise equal to calling
`step` in a loop), with these differences:
- every array it uses is allocated before the first step, so the whole loop can be captured as a graph:
  a CUDA graph on GPUs, Warp's CPU graph (APIC) on the CPU; replaying it costs no Python per step;
- controls for all steps are given at once and the results a user asks for are recorded on the device.

Controls (NumPy-like or Warp arrays in the model's dtype; Warp arrays may require gradients):
    joint_force_references, per environment per step (T, N, n); shared by the environments, per step
    (T, 1, n), or (T, n) for single-environment data; constant over the rollout (N, n) or (n,);
    None: zero. They enter each step as `step`'s joint_force_references (before friction, limits and the
    torque-speed curve).
    link_forces, with per-environment shape (nL, 6) instead of (n,), in the data's representation, held
    during each step.
For batched data a 2-D control is (N, n) (constant per environment), never (T, n): give (T, 1, n).

Records (`record=`, names below). Shapes for batched data; single-environment data drops the N axis.
State records have T + 1 entries, the state at t = 0 (the given data) to T; step records have T, entry t
being what step t (from the state t to t + 1) computed at its start:
    base_position (T+1, N, 3) [m]        base_quaternion (T+1, N, 4) (w, x, y, z)
    joint_positions (T+1, N, n)          joint_velocities (T+1, N, n)
    base_velocity (T+1, N, 6) in the data's representation
    tangential_deformation (T+1, N, nc_all, 3) [m]         valid (T+1, N) int32 (see Data.valid)
    joint_torques (T, N, n): the torques step t applied (references through friction, limits, clip)
    link_contact_forces (T, N, nL, 6): the contact wrench on each link in the data's representation, as
        `wd.contact.link_contact_forces` at the state t (for RK4: at the first stage)
    collidable_point_forces (T, N, nc, 6): each enabled point's wrench, as `wd.contact.collidable_point_forces`
Records are Warp arrays on the model's device. A `Rollout`'s records, and the final data it returns, are
its own buffers: the next `run` overwrites them (copy what you keep). `rollout()` makes a new Rollout
per call, so its results are the caller's.

Storage: how the states between steps are kept.
- "ping-pong": two state buffers, step t reads one and writes the other; recorded quantities are copied
  into the records. Memory: 2 states + one step's intermediates + the records. Not differentiable
  (states are overwritten); the default outside a `wp.Tape`.
- "trajectory": all T + 1 states, step t reads slice t and writes slice t + 1, and, under a tape, every
  step keeps its own intermediates (link poses and velocities, point and link wrenches, ABA's scratch,
  RK4's stages). Nothing an adjoint needs is overwritten, so `wp.Tape` differentiates the rollout with
  respect to the initial data, the controls (Warp arrays with requires_grad) and the model parameters marked
  by `warpdyn.model.parameters_requiring_grad` (their .grad); the state records are views of
  the trajectory (no copies). The default under a tape. Memory per environment and step: the state,
  S = 13 + 2 n + 3 nc_all numbers, and under a tape the step's intermediates, about
  2 n + 6 + 79 nL + 12 nc + 3 nc_all numbers for the semi-implicit Euler with contacts (ABA keeps 46-53
  per link), about four times that for RK4; gradients double both. The ergoCub legs (n = 12, nL = 13,
  nc = 32): ~3,300 numbers per environment and step, 27 kB in float64, so 1024 environments x 100 steps
  take ~2.7 GB. Without a tape, "trajectory" keeps only the states (one step's intermediates, reused).
"auto" picks by whether a tape is recording when `run` is called.

Callbacks: `callback(t, data)` after the steps t = k * callback_every (k = 1, 2, ...), with the state at t
as Data (views of the rollout's buffers, valid during the call). Between callbacks the steps run as one
graph, so callbacks cost nothing per step that they do not run at; `callback_every=1` makes one graph per
step. A callback may return Data (same environments, dtype and representation) to replace the state
(resets in RL: `data.reset(model, done)`); the records at t then hold the replacement. Not under a tape.

Graphs (`use_graph`): "auto" captures unless a tape records (a tape must see each launch); a graph is
captured per stretch between callbacks on the first run and replayed on later runs with the same
configuration (batch size, representation, control shapes, storage); the model's parameters (contact,
joint, terrain, integrator, time step) are read when captured: changing them makes the next run capture
again.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from . import _arrays
from . import _simulation as _sim
from .common import VelRepr
from .data import Data
from .kernels.contact_wrenches import kernels as wrench_kernels
from .kernels.rollout import int_kernels as rollout_int_kernels
from .kernels.rollout import kernels as rollout_kernels
from .kernels.state import kernels as state_kernels

__all__ = ["Rollout", "rollout", "STATE_RECORDS", "STEP_RECORDS", "DEFAULT_RECORD"]

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

_STATE_INDEX = {
    "base_position": 0,
    "base_quaternion": 1,
    "joint_positions": 2,
    "base_velocity": 3,
    "joint_velocities": 4,
    "tangential_deformation": 5,
    "valid": 6,
}


def rollout(
    model,
    data,
    *,
    steps: int,
    joint_force_references=None,
    link_forces=None,
    record=DEFAULT_RECORD,
    callback=None,
    callback_every: int = 1,
    storage: str = "auto",
    use_graph="auto",
):
    """(final Data, {name: record}): `steps` steps of `wd.model.step` from `data` (see the module docstring
    for the controls' shapes, the records, storage, callbacks and graphs). `data` is unchanged."""
    roll = Rollout(model, steps=steps, record=record, storage=storage, use_graph=use_graph)
    return roll.run(
        data,
        joint_force_references=joint_force_references,
        link_forces=link_forces,
        callback=callback,
        callback_every=callback_every,
    )


def _env_array(lead: tuple, N: int, per_env: tuple, dtype, device, grad: bool = False) -> wp.array:
    """An array of logical shape (*lead, N, *per_env) in the device's layout (environment fastest on GPUs,
    see warpdyn._arrays), so that a slice [t] is an (N, *per_env) array as a step's kernels want it."""
    lead, per_env = tuple(int(x) for x in lead), tuple(int(x) for x in per_env)
    if _arrays.env_fastest(device) and per_env:
        physical = wp.empty((*lead, *per_env, N), dtype=dtype, device=device, requires_grad=grad)
        L, P = len(lead), len(per_env)
        array = physical.transpose((*range(L), L + P, *range(L, L + P)))
    else:
        array = wp.empty((*lead, N, *per_env), dtype=dtype, device=device, requires_grad=grad)
    if _arrays.FILL_OUTPUTS_WITH_NAN and dtype in (wp.float32, wp.float64):
        array.fill_(float("nan"))
    return array


def _at(array: wp.array, t: int) -> wp.array:
    """array[t] (Warp cannot slice an array that has a zero-length axis: then an empty array of that shape)."""
    if array.size == 0:
        return wp.empty(tuple(array.shape[1:]), dtype=array.dtype, device=array.device)
    return array[t]


def _copy_launch(scalar, src: wp.array, dst: wp.array):
    """The launch copying src into dst (same logical shape; src may broadcast with zero strides)."""
    if dst.size == 0:
        return None
    if dst.dtype == wp.int32:
        return (rollout_int_kernels().copy_flags, dst.shape, [src], [dst])
    return (rollout_kernels(scalar).copy[dst.ndim], dst.shape, [src], [dst])


@dataclasses.dataclass(frozen=True)
class _Layout:
    """How a control is given: kind None (absent), "const" or "step"; shared: one value for all environments."""

    kind: str | None
    shared: bool = False


def _control(value, name: str, per_env: tuple, T: int, N: int, batched: bool, scalar, device):
    """(layout, source): the control as a Warp array of logical shape (1 or N, *per_env) ("const") or
    (T, 1 or N, *per_env) ("step"), or (_Layout(None), None)."""
    if value is None:
        return _Layout(None), None
    per_env = tuple(per_env)
    shape = tuple(value.shape) if isinstance(value, wp.array) else np.shape(value)
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
    if isinstance(value, wp.array):
        _arrays.check_device_array(value, name, scalar, device)
        source = value if tuple(value.shape) == target else value.reshape(target)
    else:
        try:
            host = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise TypeError(f"{name} must be an array of numbers: {error}") from None
        if not np.all(np.isfinite(host)):
            raise ValueError(f"{name} has non-finite values")
        source = wp.array(np.ascontiguousarray(host.reshape(target)), dtype=scalar, device=device)
    return _Layout(kind, shared), source


class _Config:
    """A rollout's buffers, launches and graphs for one configuration (see `Rollout`)."""

    def __init__(self, roll: Rollout, plan, N: int, num_envs, repr: int, trajectory: bool, grad: bool, tau: _Layout, forces: _Layout):
        self.plan, self.N, self.num_envs, self.repr = plan, N, num_envs, repr
        self.trajectory, self.grad, self.tau_layout, self.force_layout = trajectory, grad, tau, forces
        T, s, d = roll.steps, plan.scalar, plan.device
        self.T, self.scalar, self.device = T, s, d
        per_env = [(3,), (4,), (plan.n,), (6,), (plan.n,), (plan.total, 3)]
        if trajectory:
            self.traj = [_env_array((T + 1,), N, shape, s, d, grad) for shape in per_env]
            self.traj.append(_env_array((T + 1,), N, (), wp.int32, d))
            self.slots = None
        else:
            self.slots = [_sim._state_buffers(plan, N, False) for _ in range(2)]
        with_forces = forces.kind is not None
        count = T if (trajectory and grad) else 1
        self.workspaces = [_sim._Workspace(plan, N, grad, with_forces) for _ in range(count)]
        # controls
        self.tau_buffer = self._control_buffer(tau, (plan.n,))
        self.force_buffer = self._control_buffer(forces, (plan.nL, 6))
        # records
        self.records: dict[str, wp.array] = {}
        self.state_records: dict[str, wp.array] = {}  # the ones written by launches (not trajectory views)
        for name in roll.record:
            if name in _STATE_INDEX:
                i = _STATE_INDEX[name]
                if trajectory and (name != "base_velocity" or repr == int(VelRepr.Mixed)):
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
        self.graphs: dict[tuple[int, int], object] = {}

    def _control_buffer(self, layout: _Layout, per_env: tuple):
        if layout.kind is None:
            return None
        rows = 1 if layout.shared else self.N
        lead = (self.T,) if layout.kind == "step" else ()
        return _env_array(lead, rows, per_env, self.scalar, self.device, self.grad)

    # ----------------------------------------------------------------------------------- views per step

    def state(self, t: int) -> list:
        if self.trajectory:
            return [_at(a, t) for a in self.traj]
        return self.slots[t % 2]

    def _input(self, layout: _Layout, buffer, t: int, absent):
        if layout.kind is None:
            return absent
        view = _at(buffer, t) if layout.kind == "step" else buffer
        return _sim.broadcast_envs(view, self.N) if layout.shared else view

    def record_state(self, t: int, x: list) -> list:
        """The launches writing the state records at t from the state arrays x."""
        launches = []
        for name, array in self.state_records.items():
            out = _at(array, t)
            if name == "base_velocity" and self.repr != int(VelRepr.Mixed):
                launches.append((state_kernels(self.scalar).base_velocity_to_repr, self.N, [x[0], x[1], x[3], self.repr], [out]))
            else:
                launches.append(_copy_launch(self.scalar, x[_STATE_INDEX[name]], out))
        return [k for k in launches if k is not None]

    def step(self, t: int) -> list:
        """The launches of step t: the state t to t + 1, its records, and the state records at t + 1."""
        plan = self.plan
        ws = self.workspaces[t if len(self.workspaces) > 1 else 0]
        x, y = self.state(t), self.state(t + 1)
        tau_ref = self._input(self.tau_layout, self.tau_buffer, t, plan.zeros((plan.n,), self.N))
        f_user = self._input(self.force_layout, self.force_buffer, t, None)
        torques = self.records.get("joint_torques")
        tau_out = _at(torques, t) if torques is not None else None
        launches = _sim._step_launches(plan, ws, x, y, tau_ref, f_user, self.repr, tau_out)
        ev = ws.evals[0]
        K = wrench_kernels(self.scalar)
        if "link_contact_forces" in self.records and plan.contacts:
            out = self.records["link_contact_forces"][t]
            launches.append((K.link_wrenches, (self.N, plan.nL), [plan.link_first_point, ev.W_H_L, ev.chain, self.repr], [out]))
        if "collidable_point_forces" in self.records and plan.contacts:
            out = self.records["collidable_point_forces"][t]
            args = [plan.point_link, plan.L_p_C, plan.point_out, ev.W_H_L, ev.W_f_C, self.repr]
            launches.append((K.point_wrenches, (self.N, plan.count), args, [out]))
        return launches + self.record_state(t + 1, y)

    def data_at(self, t: int) -> Data:
        x = self.state(t)
        return Data(
            base_position_state=x[0],
            base_quaternion_state=x[1],
            joint_positions_state=x[2],
            base_velocity_state=x[3],
            joint_velocities_state=x[4],
            velocity_representation=VelRepr(self.repr),
            num_envs=self.num_envs,
            tangential_deformation_state=x[5],
            valid_state=x[6],
        )

    def load_state(self, t: int, data: Data) -> None:
        """Launches copying `data`'s state into the state t (recorded by a tape)."""
        x = self.state(t)
        src = _sim._state_arrays(data)
        _sim._run([k for k in (_copy_launch(self.scalar, a, b) for a, b in zip(src, x)) if k is not None], self.device)

    def load_controls(self, tau_source, force_source) -> None:
        launches = []
        for source, buffer in ((tau_source, self.tau_buffer), (force_source, self.force_buffer)):
            if source is not None:
                launches.append(_copy_launch(self.scalar, source, buffer))
        _sim._run([k for k in launches if k is not None], self.device)

    def run_steps(self, start: int, stop: int, graph: bool) -> None:
        if not graph:
            for t in range(start, stop):
                _sim._run(self.step(t), self.device)
            return
        key = (start, stop)
        captured = self.graphs.get(key)
        if captured is None:
            launches = [k for t in range(start, stop) for k in self.step(t)]
            for kernel in {k[0] for k in launches}:
                kernel.module.load(self.device)
            with wp.ScopedCapture(device=self.device) as capture:
                _sim._run(launches, self.device)
            captured = self.graphs[key] = capture.graph
        wp.capture_launch(captured)


class Rollout:
    """Reusable rollouts of `steps` steps of a model (see the module docstring).

    record: names among STATE_RECORDS and STEP_RECORDS. storage: "auto", "ping-pong" or "trajectory".
    use_graph: "auto", True or False. Buffers are allocated by the first `run` and kept for the last
    configuration (batch size, representation, control shapes, storage, the model's parameters).
    """

    def __init__(self, model, *, steps: int, record=DEFAULT_RECORD, storage: str = "auto", use_graph="auto"):
        if isinstance(steps, (bool, np.bool_)) or not isinstance(steps, (int, np.integer)) or steps < 1:
            raise ValueError(f"steps must be a positive integer, got {steps!r}")
        if isinstance(record, str):
            record = (record,)
        record = tuple(dict.fromkeys(record))
        unknown = [r for r in record if r not in STATE_RECORDS + STEP_RECORDS]
        if unknown:
            raise ValueError(f"record names unknown quantities {unknown}; known: {list(STATE_RECORDS + STEP_RECORDS)}")
        if storage not in ("auto", "ping-pong", "trajectory"):
            raise ValueError(f"storage must be 'auto', 'ping-pong' or 'trajectory', got {storage!r}")
        if use_graph not in ("auto", True, False):
            raise ValueError(f"use_graph must be 'auto', True or False, got {use_graph!r}")
        self.model = model
        self.steps = int(steps)
        self.record = record
        self.storage = storage
        self.use_graph = use_graph
        self._config: _Config | None = None
        self._key = None

    def run(self, data, *, joint_force_references=None, link_forces=None, callback=None, callback_every: int = 1):
        """(final Data, {name: record}) after `steps` steps from `data` (unchanged)."""
        model, T = self.model, self.steps
        plan, N = _sim._prepare(model, data)
        taping = _sim._taping()
        if self.storage == "ping-pong" and taping:
            raise ValueError("storage='ping-pong' overwrites states, which a wp.Tape needs: use 'trajectory' (or 'auto')")
        if self.use_graph is True and taping:
            raise ValueError("use_graph=True under a wp.Tape: the tape must record each launch; use 'auto' or False")
        if callback is not None:
            if isinstance(callback_every, (bool, np.bool_)) or not isinstance(callback_every, (int, np.integer)) or callback_every < 1:
                raise ValueError(f"callback_every must be a positive integer, got {callback_every!r}")
        trajectory = self.storage == "trajectory" or (self.storage == "auto" and taping)
        s, d, batched = plan.scalar, plan.device, data.num_envs is not None
        tau_layout, tau_source = _control(joint_force_references, "joint_force_references", (plan.n,), T, N, batched, s, d)
        force_layout, force_source = _control(link_forces, "link_forces", (plan.nL, 6), T, N, batched, s, d)
        grad = taping and trajectory
        repr = int(data.velocity_representation)
        key = (plan, N, data.num_envs, repr, trajectory, grad, tau_layout, force_layout)
        if self._key is None or len(key) != len(self._key) or not all(a is b or a == b for a, b in zip(key, self._key)):
            self._config = None  # release the old buffers first
            self._config = _Config(self, plan, N, data.num_envs, repr, trajectory, grad, tau_layout, force_layout)
            self._key = key
        cfg = self._config
        graph = (not taping) if self.use_graph == "auto" else bool(self.use_graph)
        cfg.load_controls(tau_source, force_source)
        cfg.load_state(0, data)
        _sim._run(cfg.record_state(0, cfg.state(0)), d)
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
        if not isinstance(data, Data):
            raise TypeError(f"a callback returns None or Data, got {type(data).__name__}")
        _sim._prepare(self.model, data)
        if data.batch_size != cfg.N or int(data.velocity_representation) != cfg.repr:
            raise ValueError(
                f"the callback's data has {data.batch_size} environments in {VelRepr(data.velocity_representation).name}, "
                f"the rollout {cfg.N} in {VelRepr(cfg.repr).name}"
            )
        cfg.load_state(t, data)
        _sim._run(cfg.record_state(t, cfg.state(t)), cfg.device)


def _squeeze(array: wp.array, num_envs) -> wp.array:
    """A record (L, N, ...) as it is for batched data, (L, ...) (environment 0) for single-environment data."""
    if num_envs is not None:
        return array
    if array.size == 0:
        return wp.empty((array.shape[0], *array.shape[2:]), dtype=array.dtype, device=array.device)
    return array[:, 0]
