"""`warpdyn.model.step` from Python: outputs from a pool, launches replayed from captured graphs.

A step is functional: it returns new Data whose arrays the caller owns, and nothing it returns is overwritten
while anybody can still see it (warpdyn.engine.step.step, which allocates them). Here the output state comes
from an output pool (warpdyn.engine.pool: a few sets of state arrays, each handed out again once nobody refers
to it), so a step allocates nothing. When the input data's state is itself one of the pool's sets (the usual
`data = step(model, data, ...)`), the launches from that set to the output set are captured once per pair of
sets (and velocity representation, and which controls are given) as a graph (Warp's CPU graph on the CPU, a
CUDA graph on a GPU) and replayed: no argument packing, one call. An input state that is not the pool's (data
that a user built, or another pool's) is treated the same way while it is the last such state (`foreign`: its
arrays are kept alive while graphs read them), so stepping one state again and again with new controls is as
fast. The controls reach those graphs through the pool's fixed input buffers, into which each call copies the
user's values, checked as before (on the CPU through NumPy; on a GPU on the device, ordered on the stream
before the replay). A launch list is a `Program` (warpdyn.engine.launch): replayed from its recording for its
first CAPTURE_AFTER calls, then captured, only while no other thread works on that kind of device
(warpdyn.engine.launch.graphs_allowed, as for Rollout and Stepper: on a GPU other threads' launches would join
the capture and their `array.numpy()` copies fail during it, CUDA error 906 on an H100; Warp's CPU capture is
process-wide); otherwise it stays a recorded replay (benchmarks/latency.py measures both). The
result is that of warpdyn.engine.step.step bit for bit: the same kernels on the same numbers.

Fresh arrays, as in warpdyn.engine.step.step, under a wp.Tape or a graph capture, when gradients are needed
(the data, an input or a model parameter requires them), where reference counts say nothing
(`pool.available()`), and when every set of the pool is held (a caller that keeps its results).

One pool per model version, plan (warpdyn.engine.step.plan), thread and stream, and number of environments
(warpdyn.engine.launch.per_thread): a setter (a new model version) drops it with its graphs.
"""

from __future__ import annotations

import operator

import warp as wp

from .. import arrays
from . import pool, tape
from .bundles import state_bundle
from .kinematics import state_arrays
from .input_buffers import InputBuffers
from .launch import Program, per_thread
from .step import Plan, Workspace, advance, prepare, state_buffers, step_inputs, step_launches, with_state
from .step import plan as step_plan

__all__ = ["step", "steps_of", "CAPTURE_AFTER"]

_INPUTS = ("joint_force_references", "link_forces", "ctrl")


def step(model, data, *, link_forces=None, joint_force_references=None, ctrl=None):
    """The data after one step (see warpdyn.model.step): new Data, same representation, arrays the caller owns."""
    current, N = prepare(model, data, health=True)
    if tape.taping() or current.device.is_capturing or not pool.available() or _requires_grad(model, data, joint_force_references, link_forces, ctrl):
        return advance(model, data, current, *step_inputs(current, data, joint_force_references, link_forces, ctrl))
    steps = per_thread(model, ("pooled steps", N, current), lambda: _Steps(current, N))
    return steps.step(model, data, (joint_force_references, link_forces, ctrl))


def steps_of(model, N: int):
    """The calling thread's pooled steps of `model` for N environments (made if there are none): for tests, which
    look at the sets they hand out (`.pool.slots`) and the graphs they captured (`.graphs`)."""
    current = step_plan(model)
    return per_thread(model, ("pooled steps", N, current), lambda: _Steps(current, N))


def _requires_grad(model, data, *inputs) -> bool:
    return data.requires_grad or any(isinstance(v, wp.array) and v.requires_grad for v in inputs) or model.parameters_require_grad()


def _shadow(scalar):
    """The engine's side of a set of state arrays: their aliases and the State bundle of those."""

    def make(state: tuple) -> tuple:
        aliases = [pool.alias(a) for a in state]
        return aliases, state_bundle(scalar, aliases)

    return make


CAPTURE_AFTER = 2
"""Calls of one launch list (input state, output set, representation, which controls are given) replayed
from its recording before it is captured as a graph: a capture costs far more than a replay, so launches that
run once or twice (a few steps of a new model) are not captured."""


class _Steps:
    """A thread's pooled steps of a model for N environments: the output pool, the input buffers, the
    workspaces, the last input state that is not one of the pool's sets (`foreign`), and the programs
    (warpdyn.engine.launch.Program) from an input state to an output set."""

    def __init__(self, plan: Plan, N: int):
        self.N = N
        self.pool = pool.OutputPool(lambda: state_buffers(plan, N, False), _shadow(plan.scalar))
        self.buffers = InputBuffers(plan.scalar, plan.device, N)  # by input index
        self.plan = plan
        self.workspaces: dict = {}  # link forces given -> Workspace
        # keyed by (input: a set's index or "foreign", output set, representation, which controls are given):
        self.programs: dict = {}  # -> Program
        self.foreign = None  # (state arrays, (the same as a list, their State bundle))

    def step(self, model, data, values: tuple):
        plan = self.plan
        tau, f, u = (self._input(k, value, data) for k, value in enumerate(values))
        x = state_arrays(data)
        source = self.pool.slot_of(x)
        out = self.pool.take(busy=source)
        if out is None:  # every set is held: fresh arrays
            return advance(model, data, plan, tau, f, u)
        y = self.pool.hand_out(out)  # held from here: a step inside this one (a finalizer) cannot take the set
        name, shadow = (source.index, source.shadow) if source is not None else ("foreign", self._foreign(x))
        key = (name, out.index, int(data.velocity_representation), tau is not None, f is not None, u is not None)
        program = self.programs.get(key)
        if program is None:
            launches = self._launches(*shadow, out, tau, f, u, key[2])
            program = self.programs[key] = Program(launches, plan.device, "auto", "wd.model.step", CAPTURE_AFTER)
        program.run()
        return with_state(data, y)

    @property
    def graphs(self) -> dict:
        """{key: the replay of its captured graph} of the programs that run from a captured graph."""
        return {key: p.replay for key, p in self.programs.items() if p.replay is not None}

    def _foreign(self, x: list) -> tuple:
        """(x, its State bundle) for an input state that is not the pool's: kept (alive, while graphs read its
        memory) until another such state comes, which drops its programs."""
        held = self.foreign
        if held is None or not all(map(operator.is_, held[0], x)):
            for key in [k for k in self.programs if k[0] == "foreign"]:
                del self.programs[key]
            held = self.foreign = (tuple(x), (x, state_bundle(self.plan.scalar, x)))
        return held[1]

    def _launches(self, x, X, out, tau, f, u, repr: int) -> list:
        plan, N = self.plan, self.N
        forces = f is not None
        ws = self.workspaces.get(forces)
        if ws is None:
            ws = self.workspaces[forces] = Workspace(plan, N, False, forces)
        y, Y = out.shadow
        tau = tau if tau is not None else plan.zeros((plan.n,), N)
        return step_launches(plan, ws, x, y, tau, f, repr, ctrl=u, bundles=(X, Y))

    def _input(self, k: int, value, data):
        """The input buffer k holding the user's value (checked as warpdyn.arrays.batched_input checks it), or
        None for an absent input."""
        if value is None:
            return None
        plan = self.plan
        per_env = ((plan.n,), (plan.nL, 6), (plan.na,))[k]
        value = arrays.checked_input(value, _INPUTS[k], per_env, data.num_envs, plan.scalar, plan.device)
        return self.buffers.fill(k, per_env, value)
