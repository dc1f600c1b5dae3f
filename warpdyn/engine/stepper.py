"""In-place steps of N environments: the fast path of `warpdyn.simulation.Stepper` (its docstring says what a
user sees).

A Stepper owns two state buffers (ping-pong), one step workspace and its controls, all allocated once; step
k reads buffer k % 2 and writes the other. The launches of `substeps` steps from each buffer are built once
(`warpdyn.engine.step.step_launches` on those arrays), a Program each (warpdyn.engine.launch: captured as a
graph, a CUDA graph on GPUs, Warp's CPU graph on the CPU, or replayed from its recording): a call replays them,
with no allocation, no argument packing and no host check. A change of the model (a setter: `model.version`) rebuilds them at
the next call. Not differentiable (states are overwritten): refused under a wp.Tape.

A caller's step around `step()` (torch ops: warpdyn.envs) is a `StepProgram` (`Stepper.step_program`): a Program
per buffer its steps start from, captured in the caller's kind of graph; it keeps the buffers' turn (host
state, which `step()` advances) across replays, where `step()` does not run.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.state import kernels as state_kernels
from ..types.enums import VelRepr
from . import tape
from .kinematics import state_arrays
from .bundles import state_bundle
from .launch import Launch, Program, copy_launch, launch
from .launch import run as run_launches
from .step import Workspace, prepare, state_buffers, step_launches, with_state
from .step import plan as step_plan

__all__ = ["Stepper"]


class Stepper:
    """See warpdyn.simulation.Stepper."""

    def __init__(self, model, data, *, substeps: int = 1, link_forces: bool = False, use_graph="auto"):
        if isinstance(substeps, (bool, np.bool_)) or not isinstance(substeps, (int, np.integer)) or substeps < 1:
            raise ValueError(f"substeps must be a positive integer, got {substeps!r}")
        if use_graph not in ("auto", True, False):
            raise ValueError(f"use_graph must be 'auto', True or False, got {use_graph!r}")
        plan, N = prepare(model, data)
        self.model, self.substeps, self.num_envs = model, int(substeps), data.num_envs
        self.batch_size, self.use_graph = N, use_graph
        self.scalar, self.device = plan.scalar, plan.device
        self.velocity_representation = VelRepr(data.velocity_representation)
        n, nL, na = plan.n, plan.nL, plan.na
        s, d = self.scalar, self.device
        # the user's controls, written in place (wp.to_torch shares them), zero until written; their `assign`
        # checks what it is given (warpdyn.arrays.InputArray)
        self.joint_force_references = arrays.input_array((n,), N, s, d, "Stepper.joint_force_references")
        self.ctrl = arrays.input_array((na,), N, s, d, "Stepper.ctrl")
        self.link_forces = arrays.input_array((nL, 6), N, s, d, "Stepper.link_forces") if link_forces else None
        self._slots = [state_buffers(plan, N, False) for _ in range(2)]
        self._data = [with_state(data, slot) for slot in self._slots]
        self._current = 0
        self._calls = 0  # of step(): a StepProgram checks that its body steps once
        self._build(plan)
        self.set_state(data)

    def _build(self, plan) -> None:
        """The launches (or graphs) of `substeps` steps from each buffer, for the model's current plan."""
        self._plan = plan
        self._workspace = Workspace(plan, self.batch_size, False, self.link_forces is not None)
        self._programs = [None, None]

    def _launches(self, start: int) -> list:
        launches = []
        for k in range(self.substeps):
            x, y = self._slots[(start + k) % 2], self._slots[(start + k + 1) % 2]
            u = self.ctrl if self._plan.na > 0 else None
            last = k == self.substeps - 1  # its evaluation holds `contact_wrenches`
            launches += step_launches(
                self._plan, self._workspace, x, y, self.joint_force_references, self.link_forces, int(self.velocity_representation), ctrl=u,
                evaluation=last,
            )  # fmt: skip
        if np.isfinite(self.model.divergence_speed):  # the call's last state beyond it: flagged now, not at the next call
            end = state_bundle(self.scalar, self._slots[(start + self.substeps) % 2])
            launches.append(Launch(self._plan.integrators.flag_fast_state, self.batch_size, [self._plan.divergence_speed, end], []))
        return launches

    def _program(self, start: int) -> Program:
        """The Program (warpdyn.engine.launch) of `substeps` steps from buffer `start`: captured as a graph at its
        first run where `use_graph` allows, else replayed from its recording."""
        return Program(self._launches(start), self.device, self.use_graph, "a Stepper")

    def step(self):
        """Advance every environment by `substeps` steps of `model.time_step`, in place; returns `data`."""
        if tape.taping():
            raise RuntimeError("a Stepper overwrites its states, which a wp.Tape needs: use wd.model.step or a rollout")
        current = step_plan(self.model)
        if current is not self._plan:  # a setter changed the model: the launches read its new arrays
            current.check_envs(self.batch_size)
            rows = self._slots[0][5].shape[1]
            if current.state_rows != rows:
                raise ValueError(
                    f"the model's contact state now has {current.state_rows} rows (model.contact_state_rows(): its collidable points, "
                    f"then the geom pairs' contact slots where geom_contacts is set), this Stepper's {rows}: build a new Stepper "
                    "after changing geom_contacts or the collidable points"
                )
            self._build(current)
        program = self._programs[self._current]
        if program is None:
            program = self._programs[self._current] = self._program(self._current)
        program.run()
        self._current = (self._current + self.substeps) % 2
        self._calls += 1
        return self._data[self._current]

    def step_program(self, body, capture, use_graph="auto", what: str = "a Stepper.step_program") -> StepProgram:
        """`body` (a caller's step: work around one call of `step()`) as a StepProgram, captured by `capture` where
        `use_graph` allows (see warpdyn.simulation.Stepper)."""
        if use_graph not in ("auto", True, False):
            raise ValueError(f"use_graph must be 'auto', True or False, got {use_graph!r}")
        if not callable(body) or not callable(capture):
            raise TypeError(f"step_program takes a callable body and a callable capture, got {type(body).__name__} and {type(capture).__name__}")
        if use_graph is not False and self.use_graph is not False:
            raise ValueError(
                f"{what} captures this Stepper's steps in the caller's graph (use_graph={use_graph!r}), where they "
                f"cannot be a graph of their own: build the Stepper with use_graph=False (it has {self.use_graph!r})"
            )
        return StepProgram(self, body, capture, use_graph, what)

    @property
    def contact_wrenches(self):
        """W_f_C (N, nc, 6): the Inertial wrench [force; torque about the world origin] [N, N m] of each enabled
        collidable point's contact force (points by link, each link's in the description's order: row r on link
        `contact_point_links[r]`) at the start of the last step of the latest call, a sample of one step (None for a model without
        enabled points); a view of the Stepper's workspace, overwritten by each call and replaced when a
        setter changes the model."""
        evaluation = self._workspace.evals[0]
        return evaluation.W_f_C if self._plan.contacts else None

    @property
    def contact_point_links(self) -> np.ndarray:
        """(nc,) int: the link of each row of `contact_wrenches` (the description's enabled points sorted by link,
        stably: model.kin_dyn_parameters.enabled_link lists them in the description's order)."""
        return self._plan.contact_stage.point_links.copy()

    @property
    def buffers(self) -> tuple:
        """The two state buffers as Data (views): `data` is one of them, the other the previous state."""
        return tuple(self._data)

    @property
    def data(self):
        """The current state as Data (views of the Stepper's buffers: the next `step` overwrites them)."""
        return self._data[self._current]

    def set_state(self, data, envs=None) -> None:
        """Copy `data`'s state (the model's, N environments, the Stepper's representation) into the current state:
        every environment, or those where `envs` (a Warp int32 array (N,), nonzero: copy) says, on the device
        without a host synchronisation (automatic resets). A copied environment is valid again."""
        prepare(self.model, data, parameters=False)
        if data.batch_size != self.batch_size or VelRepr(data.velocity_representation) != self.velocity_representation:
            raise ValueError(
                f"data has {data.batch_size} environments in {VelRepr(data.velocity_representation).name}; this Stepper "
                f"steps {self.batch_size} in {self.velocity_representation.name}"
            )
        target = self._slots[self._current]
        source = state_arrays(data)
        if envs is None:
            run_launches([k for k in (copy_launch(self.scalar, a, b) for a, b in zip(source, target)) if k is not None], self.device)
            return
        if not isinstance(envs, wp.array) or envs.dtype != wp.int32 or envs.device != self.device:
            got = f"a Warp array of {getattr(envs.dtype, '__name__', envs.dtype)} on {envs.device}" if isinstance(envs, wp.array) else type(envs).__name__
            raise TypeError(f"envs must be a Warp int32 array on {self.device} (nonzero: set that environment), got {got}")
        if tuple(envs.shape) != (self.batch_size,):
            raise ValueError(f"envs has shape {tuple(envs.shape)}; expected ({self.batch_size},), nonzero where an environment is set")
        K = state_kernels(self.scalar)
        for a, b in zip(source[:6], target[:6]):
            if b.size:
                kernel = K.select_rows_3d if b.ndim == 3 else K.select_rows
                launch(kernel, dim=self.batch_size, inputs=[envs, a, b], outputs=[b], device=self.device)
        launch(K.select_valid, dim=self.batch_size, inputs=[envs, target[6]], outputs=[target[6]], device=self.device)


class StepProgram:
    """A caller's step (`body()`, which calls its Stepper's `step()` once) run again and again (see
    Stepper.step_program and warpdyn.simulation.Stepper): a Program (warpdyn.engine.launch) for each buffer a
    step starts from, its body eager at the first run of the StepProgram and captured by `capture` at the next
    run from that buffer, and dropped when a setter changes the model. After each run the buffers' turn is the
    one `body`'s step leaves, replayed or not."""

    def __init__(self, stepper: Stepper, body, capture, use_graph, what: str):
        self._stepper, self._body, self._capture = stepper, body, capture
        self.use_graph, self.what = use_graph, what
        self._programs: dict = {}  # start buffer -> Program
        self._plan = stepper._plan  # the model's plan the Programs' graphs read

    @property
    def captured(self) -> int:
        """How many graphs it has captured (at most one per buffer a step starts from)."""
        return sum(program.replay is not None for program in self._programs.values())

    def run(self):
        """One step of the caller: `body()` or a replay of its graph; returns what it returns."""
        stepper = self._stepper
        current = step_plan(stepper.model)
        if current is not self._plan:  # a setter changed the model: the graphs read its old arrays
            self._programs.clear()
            self._plan = current
        start = stepper._current
        program = self._programs.get(start)
        if program is None:
            warm = any(p.eager_runs for p in self._programs.values())  # the body ran once outside a capture
            program = self._programs[start] = Program(self._stepping, stepper.device, self.use_graph, self.what, 0 if warm else 1, self._capture)
        outputs = program.run()
        stepper._current = (start + stepper.substeps) % 2
        return outputs

    def _stepping(self):
        """`body()`, checked to call the Stepper's `step()` once."""
        calls = self._stepper._calls
        outputs = self._body()
        if self._stepper._calls != calls + 1:
            raise RuntimeError(f"the body of {self.what} must call its Stepper's step() once; it called it {self._stepper._calls - calls} times")
        return outputs
