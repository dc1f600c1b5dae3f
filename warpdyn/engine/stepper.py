"""In-place steps of N environments: the fast path of `warpdyn.simulation.Stepper` (its docstring says what a
user sees).

A Stepper owns two state buffers (ping-pong), one step workspace and its controls, all allocated once; step
k reads buffer k % 2 and writes the other. The launches of `substeps` steps from each buffer are built once
(`warpdyn.engine.step.step_launches` on those arrays), a Program each (warpdyn.engine.launch: captured as a
graph, a CUDA graph on GPUs, Warp's CPU graph on the CPU, or replayed from its recording): a call replays them,
with no allocation, no argument packing and no host check. A change of the model (a setter: `model.version`) rebuilds them at
the next call. Not differentiable (states are overwritten): refused under a wp.Tape.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.state import kernels as state_kernels
from ..types.enums import VelRepr
from . import tape
from .kinematics import state_arrays
from .launch import Program, launch
from .launch import run as run_launches
from .rollout import copy_launch
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
            self._build(current)
        program = self._programs[self._current]
        if program is None:
            program = self._programs[self._current] = self._program(self._current)
        program.run()
        self.advance_buffers()
        return self._data[self._current]

    def advance_buffers(self) -> None:
        """Account for one call's `substeps` steps run by a replay of a graph the caller captured around
        `step()` (warpdyn.envs): the buffer that call wrote becomes the current one, as `step()` makes it."""
        self._current = (self._current + self.substeps) % 2

    @property
    def contact_wrenches(self):
        """W_f_C (N, nc, 6): the Inertial wrench [force; torque about the world origin] [N, N m] of each enabled
        collidable point's contact force (points in the order of `model.kin_dyn_parameters.enabled_link`: by
        link) at the start of the last step of the latest call, a sample of one step (None for a model without
        enabled points); a view of the Stepper's workspace, overwritten by each call and replaced when a
        setter changes the model."""
        evaluation = self._workspace.evals[0]
        return evaluation.W_f_C if self._plan.contacts else None

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
