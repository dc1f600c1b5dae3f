"""Rollouts: many steps of `wd.model.step` in one call, with per-step controls, recording into device arrays.

    final, rec = wd.simulation.rollout(model, data, steps=T, joint_force_references=tau)   # tau (T, N, n)
    rec["joint_positions"]        # (T + 1, N, n): s at t = 0 (the given data) ... T

    roll = wd.simulation.Rollout(model, steps=T, record=("base_position", "joint_torques"))
    for episode in ...:                        # buffers, kernels and graphs are reused: nothing allocated,
        final, rec = roll.run(data, joint_force_references=tau)          # no host work per step

    with wp.Tape() as tape:                    # long differentiable horizons: keep checkpoints, recompute
        final, rec = wd.simulation.rollout(model, data, steps=1000, joint_force_references=tau_wp,
                                           storage="checkpointed")            # segments in tape.backward
        loss = ...
    tape.backward(loss)                        # tau_wp.grad, data's .grad, marked parameters' .grad

A rollout is `steps` applications of `wd.model.step` (same launches, same numbers: bitwise equal to calling
`step` in a loop; without gradients both run the semi-implicit Euler integrators as one fused kernel per
step, under a tape as the launch list, which agree to rounding: `warpdyn.config.fused_step`), with these
differences:
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
    ctrl, with per-environment shape (na,): the controls of the model's actuators (MJCF <actuator>, in the
    order of `model.actuator_names()`), held during each step (see `wd.model.actuator_forces`).
For batched data a 2-D control is (N, n) (constant per environment), never (T, n): give (T, 1, n).

Records (`record=`, names below). Shapes for batched data; single-environment data drops the N axis.
State records have T + 1 entries, the state at t = 0 (the given data) to T; step records have T, entry t
being what step t (from the state t to t + 1) computed at its start:
    base_position (T+1, N, 3) [m]        base_quaternion (T+1, N, 4) (w, x, y, z)
    joint_positions (T+1, N, n)          joint_velocities (T+1, N, n)
    base_velocity (T+1, N, 6) in the data's representation
    tangential_deformation (T+1, N, rows, 3) [m]         valid (T+1, N) int32 (see Data.healthy)
    joint_torques (T, N, n): the joint forces step t applied (references through friction, limits, clip;
        the joints' springs and dampers; the actuators)
    link_contact_forces (T, N, nL, 6): the contact wrench on each link in the data's representation, as
        `wd.contact.link_contact_forces(..., output_vel_repr=data.velocity_representation)[0]` at the state t
        (for RungeKutta4 and RungeKutta4Fast: at the first stage)
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
  S = 13 + 2 n + 3 rows numbers (rows: model.contact_state_rows()), and under a tape the step's intermediates, about
  2 n + 6 + 79 nL + 12 nc + 3 nc_all numbers for the semi-implicit Euler with contacts (ABA keeps 46-53
  per link), about four times that for RK4; gradients double both. The ergoCub legs (n = 12, nL = 13,
  nc = 32): ~3,300 numbers per environment and step, 27 kB in float64, so 1024 environments x 100 steps
  take ~2.7 GB. Without a tape, "trajectory" keeps only the states (one step's intermediates, reused).
- "checkpointed" (`checkpoint_every=c`): differentiable like "trajectory", in far less memory. Under a
  tape the steps run unrecorded (as a graph with use_graph "auto") and keep only the states at
  t = 0, c, 2c, ..., T (the checkpoints), plus the c - 1 states and c steps' intermediates of one segment,
  reused by every segment. `run` registers one function on the tape (`Tape.record_func`); `tape.backward`
  runs it: it recomputes the segments from last to first, each from its checkpoint under a tape of its
  own (the same launches on the same numbers), and runs that tape's backward. Gradients reach the initial
  data, the controls and the marked model parameters as with "trajectory" and equal its gradients (bit for
  bit on the CPU, where the adjoints add in the same order: tests/test_rollout_checkpoint.py), and
  `tape.zero()` zeroes them. State records are copies (T + 1 entries, with gradients), except with c = 1:
  all states kept, the records are views as with "trajectory". Memory per environment: ceil(T / c) + c
  states and c steps' intermediates, all with gradients, + the records and the rollout's copy of the
  controls; per environment and step about S / c + c (S + W) / T for states of S numbers and intermediates
  of W, least for c ~ sqrt(T S / (S + W)). `checkpoint_every=None` (the default) takes the c that keeps the
  fewest bytes (`Rollout.memory_bytes`). The ergoCub legs in float32 with the joint positions recorded,
  T = 1000: semi-implicit Euler c = 9, 432 bytes per environment and step instead of "trajectory"'s 13,461
  (4096 environments: 1.65 GiB instead of 51 GiB); RK4 c = 4, 689 bytes instead of 57,509 (2.6 GiB instead
  of 219 GiB); float64 doubles them (benchmarks/rollout_memory.py). Cost: every step runs twice, in the
  forward pass and again in the backward pass, there eagerly (launch by launch, as a tape records them); the
  forward pass records nothing. The backward recomputes from the rollout's buffers with the model's
  parameters as they are then: call it before the next `run` of the same Rollout (which overwrites the
  checkpoints, as it overwrites "trajectory"'s states: the backward of an earlier run is then refused with
  a RuntimeError) and before changing the parameters. Callbacks are
  refused under a tape (what they launch would be recorded out of order with the recomputation). Without a
  tape it is a forward rollout in the same buffers (no gradients; callbacks allowed).
"auto" picks "trajectory" under a tape, "ping-pong" otherwise, when `run` is called.

Memory: `Rollout.memory_bytes(num_envs, ...)` computes, without allocating the rollout's buffers (it builds
one step's workspace to count its arrays), the bytes `run` keeps (states,
step intermediates, the rollout's copy of the controls, records, the stage buffers of chunked graphs, and
their gradients: "total"), to size a run, and apart the host memory its captured graphs take ("graph": an
estimate, 4 KiB per captured launch as measured on Warp's CPU graphs); `Rollout.nbytes` is what the last
run allocated (equal to "total"). A run whose buffers exceed what the device has available (the host's
MemAvailable on Linux, a GPU's free memory) is refused with a MemoryError naming its size before anything
is allocated, as is an allocation or graph capture that fails.

Callbacks: `callback(t, data)` after the steps t = k * callback_every (k = 1, 2, ...), with the state at t
as Data (views of the rollout's buffers, valid during the call). Between callbacks the steps run as one
graph (chunks of one graph, for "ping-pong"), so callbacks cost nothing per step that they do not run at;
`callback_every=1` makes one graph per step (with "ping-pong", one per parity, replayed). A callback may return Data (same environments, dtype and representation) to replace the state
(resets in RL: `data.reset(model, done)`); the records at t then hold the replacement. Not under a tape.

Graphs (`use_graph`): "auto" captures unless a tape records the steps (a tape must see each launch; under a
tape, "checkpointed" storage captures its forward pass, which the tape does not record); a graph is
captured per stretch between callbacks on the first run and replayed on later runs with the same
configuration (batch size, representation, control shapes, storage). With "ping-pong" storage a graph
holds at most GRAPH_CHUNK = 256 steps (warpdyn/engine/rollout_memory.py) and is replayed once per chunk:
its steps read per-step controls from and write records into (256, ...) stage buffers that a few plain
launches fill and empty around each replay, so the graphs' memory does not grow with T (on the CPU a
20,000-step rollout of a 3-link chain grew the process by 415 MB with one graph, by 8 MB now, and captured
in 0.2 s instead of 13 s; replays cost the same to 1 %). "trajectory" and "checkpointed" storage keep a state per step: their
graphs hold every step (about 4 KiB per launch, see `memory_bytes`). Replacing a model parameter (contact,
joint or link parameters, terrain, integrator, time step) makes the next run capture again; a parameter's
Warp array edited in place (`model.link_mass.assign(...)`, a Warp K in `contact_params`) is read by the
replayed graph as it is then (a graph holds arrays, not values), while numbers and NumPy arrays in
`contact_params` and the terrain are uploaded when the step's plan is built. Two things are decided when
the plan is built, from the values then: whether the step compiles joint friction and limit-spring terms
(none when all are zero: editing a zero friction in place then changes nothing; set it with
`set_joint_parameters`, which makes a new array, or mark it with `parameters_requiring_grad`, which keeps
the term), and the stability check of the contact K and D.
"""

from __future__ import annotations

from .engine.rollout import DEFAULT_RECORD, STATE_RECORDS, STEP_RECORDS, Rollout
from .engine.step import check_deformation_stability
from .engine.stepper import Stepper as _Stepper
from .engine.tape import taping

__all__ = ["Rollout", "rollout", "Stepper", "STATE_RECORDS", "STEP_RECORDS", "DEFAULT_RECORD", "check_contact_stability", "taping"]


class Stepper(_Stepper):
    """In-place steps of N environments, for loops that step from Python (control, RL): the fast path.

        stepper = wd.simulation.Stepper(model, data, substeps=4)   # 4 steps of model.time_step a call
        for _ in range(1000):
            stepper.joint_force_references.assign(tau)             # (N, n) or (n,), checked; or stepper.ctrl
            data = stepper.step()                                  # replays one graph: no allocation
        view = wp.to_torch(stepper.ctrl)                           # (N, na), zero-copy: view[:] = ... unchecked

    What `wd.model.step` computes (the same kernels, numbers and health flags; with a finite
    `model.divergence_speed` a call also flags the state it ends on where that is beyond the bound, which a step
    would flag at the next call), but its state lives in the Stepper: `step()` overwrites it, and `data` (returned by `step`) is a Data of views of the Stepper's
    buffers, valid until the next call (copy what you keep, e.g. `data.joint_positions.numpy()`). The
    controls are the Stepper's arrays, zero until written, held over each call's `substeps` steps:
    `joint_force_references` (N, n) [N m or N], `ctrl` (N, na) (the model's actuators), and, when built with
    link_forces=True, `link_forces` (N, nL, 6) in the data's representation. Write them with `.assign(values)`,
    which checks them (warpdyn.arrays.InputArray): one row per environment (N, ...) or one environment's
    values (...), written to every environment; NumPy-like real finite numbers, or a Warp array of the model's
    dtype (copied on the device, its values unchecked); a TypeError or ValueError naming the array otherwise.
    They are Warp arrays over the Stepper's memory: zero-copy writes (through `wp.to_torch(stepper.ctrl)`,
    `wp.copy`, a kernel) reach the next call as written, unchecked. `set_state(data, envs=None)`
    copies a state in, for every environment or, without a host synchronisation, those an int32 mask (N,)
    selects (resets). `contact_wrenches` (N, nc, 6) holds the enabled collidable points' contact wrenches at
    the start of the last step of a call (Inertial: [force; torque about the world origin]). The launches of
    a call are built once, and captured as a graph unless use_graph=False (CUDA graph on GPUs, Warp's CPU
    graph on the CPU); setting a model parameter or setting rebuilds them at the next call, while writing
    into a parameter's array in place does not need to. Not differentiable: use `wd.model.step` or a rollout
    under a wp.Tape. One Stepper serves one thread at a time.

    A caller's step around `step()` (torch ops before and after it: warpdyn.envs) is captured whole
    by `step_program(body, capture, use_graph="auto", what=...)`, which returns a program whose `run()` runs
    one such step and returns what `body()` returns:

        program = stepper.step_program(env_step, capture_in_torch_graph)   # env_step() calls stepper.step()
        outputs = program.run()          # eager at the first run, then the captured graph's replay

    `body()` calls `step()` once (a RuntimeError otherwise). `capture(body)` captures one call of `body` in
    the caller's kind of graph, without running it (e.g. in torch.cuda.graph, whose memory pool holds the
    torch ops' allocations; Warp's launches join it through wp.ScopedStream on the capturing stream), and
    returns a function that replays that graph and returns what a run returns (its outputs are the graph's
    buffers: copy them there). The program's first run calls `body()`; its next run from each buffer a
    step starts from (one; both for an odd `substeps`) captures a graph, by the rules of the Stepper's own
    graphs: one capture at a time, only while no other thread works with warpdyn on that kind of device;
    use_graph "auto" runs `body()` meanwhile, True raises a RuntimeError naming `what` and those threads,
    False never captures. A setter's change of the model drops the graphs (the next run calls `body()`,
    the one after captures again). A replay keeps the buffers' turn: `data` after any run is the state it
    wrote. The Stepper's launches join the caller's graph, so a program that may capture needs a Stepper
    built with use_graph=False (a ValueError otherwise).
    """


def rollout(
    model,
    data,
    *,
    steps: int,
    joint_force_references=None,
    link_forces=None,
    ctrl=None,
    record=DEFAULT_RECORD,
    callback=None,
    callback_every: int = 1,
    storage: str = "auto",
    checkpoint_every: int | None = None,
    use_graph="auto",
):
    """(final Data, {name: record}): `steps` steps of `wd.model.step` from `data` (see the module docstring
    for the controls' shapes, the records, storage and checkpoint_every, callbacks and graphs). `data` is
    unchanged."""
    roll = Rollout(model, steps=steps, record=record, storage=storage, checkpoint_every=checkpoint_every, use_graph=use_graph)
    return roll.run(
        data,
        joint_force_references=joint_force_references,
        link_forces=link_forces,
        ctrl=ctrl,
        callback=callback,
        callback_every=callback_every,
    )


def check_contact_stability(model, *, K=None, D=None) -> None:
    """A ValueError when the contact stiffness K and damping D (default: the model's, numbers or (N,)) make
    the tangential deformation unstable at the model's time step and integrator (dt K / D at or beyond
    2 for the semi-implicit Euler, 2.785 for RK4; `step` refuses such settings)."""
    c = model.contact_params
    check_deformation_stability(model.time_step, c.K if K is None else K, c.D if D is None else D, model.integrator)
