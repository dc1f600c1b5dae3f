"""Simulation steps: soft contacts with the terrain, actuation, and the integrators of `warpdyn.model.step`.

A step, as JaxSim's `js.model.step` with SoftContacts:
1. the user's link forces (the data's representation) made Inertial; the joint torques from the joint
   force references through friction, limit springs and the torque-speed curve (kernels/actuation.py),
   once per step at its start;
2. the contact forces of the enabled collidable points (kernels/soft_contacts.py) added to the link forces,
   and the rate of the tangential deformation;
3. forward dynamics by ABA in the Inertial representation;
4. the integrator (kernels/integrators.py); environments whose new state is not finite, or whose state read has a
   velocity beyond model.divergence_speed, are flagged (`data.healthy`) and keep their state;
5. the parameters' ranges (kernels/parameter_checks.py, `parameter_check`): environments whose parameters,
   as their arrays hold them now (edits in place included, which no host check sees), are out of range,
   or whose dt K / D is unstable where their points can reach the terrain, are flagged likewise.
`step` returns new Data (fresh arrays): nothing an adjoint needs is overwritten, so a wp.Tape through
many steps gives gradients. warpdyn.model.step comes here under a tape and when gradients are needed;
otherwise it goes through warpdyn.engine.fast_step (pooled outputs, captured graphs: the same launches).

Structure. What a model's steps launch is chosen once per model version (`Plan`, cached on the model:
warpdyn.types.model). Parts a model does not need are not launched (no enabled collidable points: no FK,
link-velocity or contact kernel; no link forces: no conversion, and ABA skips the force terms) or not
compiled (no limit springs, no friction: an actuation kernel without that code). A step is then a fixed
list of launches on given arrays (`step_launches`): nothing allocated, nothing read back, so
warpdyn.engine.rollout captures many of them in a graph. Launches per semi-implicit Euler step:
actuation (if joints), [FK, link velocities, the points' contact forces, their sums per link] (if enabled
points; a thread per point and per link, or per environment: warpdyn.engine.contact_stage), [FK if no
contacts, force conversion] (if link forces not Inertial), ABA, integrator, parameter check; without
gradients, outside a tape (`fused_applies`): [FK, force conversion] (if link forces not Inertial), then one
kernel for the rest (kernels/fused_step.py, the joint forces included), on one thread per environment or, on a
GPU for few environments, on one thread per group of the model's walk (warpdyn.engine.fused_layout), then the
parameter check.

Checks on the host, once per model version (when the plan is built): the parameters' ranges
(warpdyn.types.parameters.validate_parameters: the arrays as they are then), and the stability of the
contact deformation, dt K / D below the integrator's limit (DEFORMATION_STABILITY), only where the scene can
have contacts: enabled collidable points, and a floating base or a point that can reach the terrain from the
welded base (warpdyn.engine.stability); stiff parameters that never act are not refused.

Gradients with respect to model parameters (warpdyn.types.parameters). Every parameter a step reads is an
array the user holds: the model bundle holds the model's own arrays, and the contact K, D, mu and the
terrain's heights are read in place when they are Warp arrays (numbers and NumPy arrays are copied when
the plan is built). Under a tape the adjoints accumulate into those arrays' .grad: `step` allocates fresh
buffers with gradients when the data, an input or a parameter requires them, and a rollout under a tape
always does; the per-thread workspace and recorded launches serve only calls outside a tape. Marking a
friction or limit gain keeps its term in the compiled actuation kernel even where it is zero.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
import warp as wp

from .. import arrays, config
from ..kernels.aba import ABA_RECORD
from ..kernels.aba import kernels as aba_kernels
from ..kernels.actuation import kernel as actuation_kernel
from ..kernels.actuation import mujoco_kernel
from ..kernels.bundles import bundles
from ..kernels.forces import kernels as force_kernels
from ..kernels.fused_step import kernel as fused_step_kernel
from ..kernels.implicit_contacts import IMPLICIT
from ..kernels.integrators import kernels as integrator_kernels
from ..kernels.kinematics import kernels as kinematics_kernels
from ..kernels.parameter_checks import kernels as parameter_check_kernels
from ..kernels.scratch import TRANSFORM
from ..types.enums import IntegratorType, VelRepr
from ..types.data_checks import check_contact_state, check_data, passes_like
from ..types.parameters import MODEL_ARRAYS, validate_parameters
from ..types.terrain import FlatTerrain, HeightfieldTerrain
from . import fused_layout, tape
from .bundles import controls_bundle, empty_like_input, model_bundle, per_env, state_bundle
from .kinematics import state_arrays, targets
from .launch import Launch, Recorded, copy_launch, no_adjoint, per_thread, run
from .loading import block_size
from .contact_stage import stage_for
from .equality import check_steppable, equality_plan
from .stability import DEFORMATION_STABILITY, ContactReach, check_deformation_stability, contact_reach

__all__ = [
    "DEFORMATION_STABILITY",
    "evaluate",
    "joint_forces",
    "torque_reference_input",
    "link_force_input",
    "ctrl_input",
    "inputs_require_grad",
    "Plan",
    "Workspace",
    "Evaluation",
    "plan",
    "prepare",
    "step",
    "step_inputs",
    "advance",
    "step_launches",
    "fused_applies",
    "fused_kernel",
    "state_buffers",
    "broadcast_envs",
    "terrain_bundle",
    "check_deformation_stability",
    "ContactReach",
    "contact_reach",
    "parameter_check",
]

def terrain_bundle(model):
    """The kernels' Terrain bundle of `model.terrain`; its Warp arrays are read in place (their .grad gets
    the gradient)."""
    terrain = model.terrain
    s, d = model.scalar, model.device
    B = bundles(s)
    bundle = B.Terrain()
    bundle.kind = terrain.kind
    bundle.normal = wp.types.vector(3, s)(0.0, 0.0, 1.0)
    bundle.heights = wp.zeros((2, 2), dtype=s, device=d)
    bundle.grid = B.vec4(0.0, 0.0, 1.0, 1.0)
    if isinstance(terrain, HeightfieldTerrain):
        heights = terrain.heights
        if isinstance(heights, wp.array):
            arrays.check_device_array(heights, "HeightfieldTerrain.heights", s, d)
        else:
            heights = wp.array(heights, dtype=s, device=d)
        bundle.height = wp.zeros(1, dtype=s, device=d)
        bundle.heights = heights
        bundle.grid = B.vec4(*terrain.origin, *terrain.spacing)
    elif isinstance(terrain, FlatTerrain):
        bundle.height = per_env(terrain.elevation, "height", s, d, owner="FlatTerrain")
    else:
        normal, h0 = terrain.plane()
        bundle.normal = wp.types.vector(3, s)(*normal)
        bundle.height = wp.array([h0], dtype=s, device=d)
    return bundle


class Plan:
    """What a step of one model launches, chosen once per model version (see `plan`).

    - actuation: a kernel compiled with only the terms the joint parameters need (no limit springs: no
      limit code; no friction, or friction disabled: no friction code); none without joints;
    - contacts: the enabled points ordered by link and the contact parameters (the kernels' Contacts
      bundle); without enabled points no FK, link-velocity or contact kernel is launched and the
      deformation rate is a zero array;
    - the terrain (a heightfield's heights uploaded once, not per step).
    Host work per step is then a cache look-up (`plan`), no NumPy reductions, no uploads.
    """

    def __init__(self, model, gradient_terms: tuple):
        validate_parameters(model)  # the arrays as they are now, in-place edits included (once per model version)
        s, d = model.scalar, model.device
        self.scalar, self.device = s, d
        self.n, self.nq, self.nL = model.dofs(), model.number_of_joint_coordinates(), model.number_of_links()
        self.multi_dof = model.multi_dof()  # ball or free joints: the kernels' multi-DoF variants (kernels/joints.py)
        self.rows = model.scratch_rows()  # of a scratch with a record per link and per DoF (kernels/aba.py)
        self.integrator = IntegratorType(model.integrator)
        self.dt = s(model.time_step)
        self.quaternion_tolerance = s(model.quaternion_tolerance)
        self.divergence_speed = s(model.divergence_speed)
        self.model = model_bundle(model)
        # actuation: the terms whose parameters are nonzero or marked for gradients
        a = model.actuation_params
        friction_grad, limits_grad, passive_grad, gravcomp_grad, base_grad = gradient_terms

        def nonzero(*names):
            return any(bool(np.any(model.parameter_host(name) != 0.0)) for name in names)

        self.na = model.number_of_actuators()
        self.with_limits = nonzero("joint_limit_spring") or limits_grad
        # with MuJoCo's friction constraints (model.frictionloss_constraints) the solve stands for the static term
        self.static_friction = not model.frictionloss_constraints
        frictions = ("friction_static", "friction_viscous") if self.static_friction else ("friction_viscous",)
        self.with_friction = bool(a.enable_friction) and (nonzero(*frictions) or friction_grad)
        self.with_passive = nonzero("stiffness", "damping") or passive_grad
        per_joint = model.actuators_per_joint
        self.euler = self.integrator not in (IntegratorType.RungeKutta4, IntegratorType.RungeKutta4Fast)
        # RK4 evaluates MuJoCo's state-dependent joint forces at each stage, on JaxSim's part held from the start
        self.stage_forces = not self.euler and self.n > 0 and (self.with_passive or per_joint > 0)
        if self.stage_forces:
            self.actuation = actuation_kernel(s, self.with_limits, self.with_friction, multi_dof=self.multi_dof, static_friction=self.static_friction)
            self.stage_actuation = mujoco_kernel(s, self.with_passive, per_joint, self.multi_dof)
        else:
            self.actuation = (actuation_kernel(s, self.with_limits, self.with_friction, self.with_passive, per_joint, self.multi_dof, self.static_friction)
                              if self.n > 0 else None)
        self.torque_curve = [s(a.torque_max), s(a.omega_th), s(a.omega_max)]
        # MuJoCo's joint forces alone (on given torques: warpdyn.engine.evaluations.integrate)
        self.mujoco_part = mujoco_kernel(s, self.with_passive, per_joint, self.multi_dof) if self.n > 0 and (self.with_passive or per_joint > 0) else None
        # MuJoCo's implicit joint damping in the Euler integrators (ABA's d_i + dt damping_i)
        implicit = self.euler and model.implicit_damping
        self.implicit_dt = s(model.time_step if implicit else 0.0)
        # passive link forces (gravity compensation, a floating base's free-joint damper and spring): link forces
        # from the links' poses at each evaluation (kernels/forces.py's passive_link_forces); the base's armature
        # is ABA's
        self.gravcomp = nonzero("gravcomp_mass", "base_damping", "base_stiffness") or gravcomp_grad or base_grad
        # the contact model's stage (warpdyn.engine.contact_stage): its points, parameters and launches
        stage = self.contact_stage = stage_for(model, self.integrator)
        self.contact_bundle, self.count, self.point_out = stage.bundle, stage.count, stage.point_out
        self.state_rows = stage.state_rows  # the contact state's rows (Model.contact_state_rows)
        self.contacts = self.count > 0 or stage.pairs > 0
        # the soft law's contacts linearly implicit in an Euler step (model.implicit_contacts: kernels/implicit_contacts.py)
        self.implicit_contacts = model.implicit_contacts and self.contacts
        if model.implicit_contacts and not (self.euler and stage.point_law is not None):
            raise ValueError(
                f"model '{model.name()}': implicit_contacts linearises the soft law in a semi-implicit Euler step; it has "
                f"{type(model.contact_model).__name__} and {self.integrator.name}: set model.implicit_contacts = False"
            )
        # MJCF equality constraints (warpdyn.engine.equality), solved after ABA
        self.equality = equality_plan(model)
        self.poses = self.contacts or self.gravcomp or self.equality is not None  # an evaluation runs FK
        self.check_rate, self.check_reach = stage.check_rate, stage.check_reach
        self.terrain = terrain_bundle(model)
        self.no_targets = targets(model, model.all_links[:0], model.identity_offsets[:0])
        self.integrators = integrator_kernels(s, self.multi_dof)
        # the fused Euler step (kernels/fused_step.py) by whether it keeps the joint transforms and its lanes, for
        # steps without gradients, of models whose joints have one DoF each, or are free joints below a fixed base
        # (a scene's free bodies and floating robots). Its walk's groups (the base's subtrees by their links and
        # points) are its lanes for few environments on a GPU (fused_layout.fused_lanes).
        self.fused = None
        tree = model.tree
        free_roots = not tree.one_dof_joints and tree.free_roots and not model.floating_base()
        if self.euler and (tree.one_dof_joints or free_roots) and stage.point_law is not None and self.equality is None and not stage.pairs and not self.implicit_contacts:
            walk = fused_layout.fused_walk(model.tree.parent, fused_layout.MAX_LANES, 1 + stage.points_per_link)
            self.walk = wp.array(walk.walk, dtype=wp.vec3i, device=d)
            self.walk_starts = wp.array(walk.starts, dtype=wp.int32, device=d)
            self.lanes = walk.groups
            so3 = self.integrator == IntegratorType.SemiImplicitEulerSO3
            actuation = (self.with_limits, self.with_friction, self.with_passive, per_joint) if self.n > 0 else None
            self.fused = functools.partial(fused_step_kernel, s, self.nL, max(walk.slots, 1), so3, actuation, stage.point_law, self.terrain.kind, self.gravcomp, free_roots)
        self.no_poses = wp.empty((0, 0), dtype=wp.types.transformation(s), device=d)
        self._zeros: dict = {}

    def check_envs(self, N: int) -> None:
        for name, value in (*self.contact_stage.per_env_parameters(), ("the terrain's height", self.terrain.height)):
            if value.shape[0] not in (1, N):
                raise ValueError(f"{name} has shape {value.shape}: give a number or one value per environment ({N},)")

    def zeros(self, shape: tuple, N: int) -> wp.array:
        """A zero array of logical shape (N, *shape) that no kernel writes: one row, broadcast (env stride 0)."""
        key = tuple(shape)
        if 0 in key:  # nothing to read: no memory to broadcast
            return wp.empty((N, *key), dtype=self.scalar, device=self.device)
        row = self._zeros.get(key)
        if row is None:
            row = self._zeros[key] = wp.zeros((1, *shape), dtype=self.scalar, device=self.device)
        return broadcast_envs(row, N)

    def zero_rows(self) -> list:
        """The zero rows `zeros` made (they are the plan's, not a workspace's or a rollout's)."""
        return list(self._zeros.values())

    def parameter_arrays(self) -> list:
        """The model parameters' Warp arrays that the steps read (the bundles' fields)."""
        parameters = [value for _, value in self.contact_stage.per_env_parameters()]
        return [getattr(self.model, name) for name in MODEL_ARRAYS] + parameters + [self.terrain.height, self.terrain.heights]


def broadcast_envs(row: wp.array, N: int) -> wp.array:
    """The (N, *S) view of a (1, *S) array with a zero stride on the environment axis (its gradient likewise):
    what kernels read as one value per environment, without N copies (it keeps `row` alive)."""
    if row.shape[0] != 1:
        raise ValueError(f"broadcast_envs needs a leading axis of 1, got shape {row.shape}")
    if N == 1:
        return row
    return arrays.strided_view(row, (N, *row.shape[1:]), (0, *row.strides[1:]))


_TERMS = (
    ("friction_static", "friction_viscous"),
    ("joint_limit_spring", "joint_limit_damper"),
    ("stiffness", "damping", "springref"),
    ("gravcomp_mass", "gravcomp_com"),
    ("base_armature", "base_damping", "base_stiffness"),
)
"""The parameters of the optional terms of a step (Plan's gradient_terms): friction, limits, passive, gravcomp, the
floating base's free joint."""


def plan(model) -> Plan:
    """The model's plan at its current version (and marking of the parameters of its optional terms). The
    parameters' arrays are looked up once per version (only a setter, which announces itself, replaces one);
    whether they require gradients is read at each call."""
    groups = model.cached("step plan terms", lambda: tuple(tuple(getattr(model, name) for name in names) for names in _TERMS))
    terms = tuple([any([a.requires_grad for a in group]) for group in groups])
    return model.cached(("step plan", terms), lambda: Plan(model, terms))


class Evaluation:
    """Buffers of one evaluation of the state derivative (one per stage of RK4)."""

    def __init__(self, plan: Plan, N: int, grad: bool, forces: bool, nu_dot: wp.array | None, aba: bool = True, equality: dict | None = None):
        s, d = plan.scalar, plan.device
        nL, n = plan.nL, plan.n
        self.grad = grad
        self.checks = aba  # a step's evaluation: its stability checks flag environments (a contact query's does not)
        self.implicit = None

        def out(shape, dtype=s):
            return arrays.output(shape, N, dtype, d, grad)

        transform = wp.types.transformation(s)
        vec6 = wp.types.vector(6, s)
        if plan.poses:
            self.parent_H_link = out((nL,), transform)
            self.W_H_L = out((nL,), transform)
        if plan.gravcomp and aba:
            self.W_f_gc = out((nL, 6))
        if plan.contacts:
            self.W_v_WL = out((nL,), vec6)
            self.target_velocities = arrays.empty((0, 6), N, s, d)
            self.W_f_C = out((plan.count, 6))
            self.m_dot = out((plan.state_rows, 3)) if plan.contact_stage.has_state else plan.zeros((plan.state_rows, 3), N)
            self.W_f_L = out((nL, 6))
            # the contacts' implicit terms per link (kernels/implicit_contacts.py), for a step's ABA
            self.implicit = out((nL, IMPLICIT)) if plan.implicit_contacts and aba else None
            self.contact = plan.contact_stage.buffers(plan, N, grad)  # the contact model's own (warpdyn.engine.contact_stage)
        else:
            self.m_dot = plan.zeros((plan.state_rows, 3), N)
        if not aba:  # contact results only (warpdyn.engine.contact)
            return
        link_forces = plan.contacts or plan.gravcomp or forces
        self.aba_scratch = arrays.empty((plan.rows, ABA_RECORD + (TRANSFORM if link_forces else 0)), N, s, d, grad)
        if plan.stage_forces:
            self.tau = out((n,))  # this stage's joint forces
        # nu_dot (N, 6 + n) = [W_vdot_WB (Inertial); sddot]: the semi-implicit Euler's (given), or this stage's
        self.nu_dot = out((6 + n,)) if nu_dot is None else nu_dot
        self.base_acceleration = self.nu_dot[:, :6]
        self.joint_accelerations = self.nu_dot[:, 6:] if n > 0 else out((0,))
        # with equality constraints ABA writes the unconstrained accelerations apart (warpdyn.engine.equality); the
        # solve's buffers (`equality`: shared by RK4's stages, which run one after the other)
        self.equality = None
        if plan.equality is not None:
            self.equality = equality if equality is not None else plan.equality.buffers(plan, N, grad)


class Workspace:
    """Buffers of one step's intermediate results for N environments (`step_launches` writes them).

    `step` reuses one per model and thread outside a tape and makes fresh ones under a tape (the adjoint
    reads them later); a rollout keeps one for all steps, or one per step when it must be differentiable.
    forces: whether the steps get external link forces (room for their Inertial conversion and for ABA's).
    """

    def __init__(self, plan: Plan, N: int, grad: bool, forces: bool):
        s, d = plan.scalar, plan.device
        n, nL = plan.n, plan.nL
        self.N, self.grad, self.forces = N, grad, forces
        # the step's new state at its end, kept under a tape where the rigid impact ends the step (`kept_after_step`)
        self.kept_after_step = state_buffers(plan, N, False) if grad and plan.contacts and plan.contact_stage.impact else None
        self.tau = arrays.output((n,), N, s, d, grad)
        if plan.stage_forces:
            self.tau_held = arrays.output((n,), N, s, d, grad)  # JaxSim's part, held over the RK4 stages
        transform = wp.types.transformation(s)
        if forces:
            self.W_f_ext = arrays.output((nL, 6), N, s, d, grad)
            if not plan.poses:  # otherwise the first evaluation's link poses serve
                self.parent_H_link = arrays.output((nL,), N, transform, d, grad)
                self.W_H_L = arrays.output((nL,), N, transform, d, grad)
        if plan.euler:
            self.nu_dot = arrays.output((6 + n,), N, s, d, grad)
            self.contact_flags = wp.zeros(N, dtype=wp.int32, device=d)  # integrators.contact_state_euler's, reset by each step
            self.evals = [Evaluation(plan, N, grad, forces, self.nu_dot)]
        else:
            shared = plan.equality.buffers(plan, N) if plan.equality is not None and not grad else None  # a tape's adjoints read each stage's
            self.evals = [Evaluation(plan, N, grad, forces, None, equality=shared) for _ in range(4)]
            size = plan.integrators.state_size(plan.nq, n, plan.state_rows)
            self.slopes = [arrays.output((size,), N, s, d, grad) for _ in range(4)]
            self.stages = [state_buffers(plan, N, grad)[:6] for _ in range(3)]


def state_buffers(plan: Plan, N: int, grad: bool) -> list:
    """Uninitialised state arrays (p, Q, s, v, sdot, m, valid) for N environments, in the device's layout."""
    s, d, n = plan.scalar, plan.device, plan.n
    return [
        arrays.output((3,), N, s, d, grad),
        arrays.output((4,), N, s, d, grad),
        arrays.output((plan.nq,), N, s, d, grad),
        arrays.output((6,), N, s, d, grad),
        arrays.output((n,), N, s, d, grad),
        arrays.output((plan.state_rows, 3), N, s, d, grad),
        wp.empty(N, dtype=wp.int32, device=d),
    ]


def evaluate(plan: Plan, ev: Evaluation, x, tau, f_ext, poses_done: bool, aba: bool = True, held: Evaluation | None = None) -> list:
    """The launches of one derivative evaluation at the state x (a State bundle): FK (if contacts or gravity
    compensation), the gravity compensation and contacts (if any), then ABA (Inertial). f_ext (N, nL, 6)
    Inertial or None. poses_done: ev's link poses already hold FK at x. aba=False: contact results only.
    held (RungeKutta4Fast's stages after the first): the first stage's evaluation, whose contact forces are
    held (f_ext + the contacts, its W_f_L) instead of evaluated at x. RungeKutta4Fast's first stage sums the
    contacts before the gravity compensation, so that W_f_L holds f_ext and the contacts alone."""
    N = x.base_position.shape[0]
    s = plan.scalar
    launches = []
    if plan.poses and not poses_done:
        launches.append(Launch(kinematics_kernels(s, plan.multi_dof).forward_kinematics, N, [plan.model, x], [ev.parent_H_link, ev.W_H_L]))
    contacts_first = plan.integrator == IntegratorType.RungeKutta4Fast
    if held is not None and plan.contacts:
        f_ext = held.W_f_L
    if plan.contacts and held is None and contacts_first:
        launches += plan.contact_stage.launches(plan, ev, x, f_ext, tau, N)
        f_ext = ev.W_f_L
    if plan.gravcomp and aba:
        f_in = f_ext if f_ext is not None else empty_like_input(s, plan.device, 3)
        launches.append(Launch(force_kernels(s).passive_link_forces, (N, plan.nL), [plan.model, x, ev.W_H_L, f_in, int(VelRepr.Inertial)], [ev.W_f_gc]))
        f_ext = ev.W_f_gc
    if plan.contacts and held is None and not contacts_first:
        launches += plan.contact_stage.launches(plan, ev, x, f_ext, tau, N)
        f_ext = ev.W_f_L
    if aba:
        controls = controls_bundle(s, plan.device, tau if plan.n > 0 else None, f_ext, ev.implicit if plan.implicit_contacts else None)
        args = [plan.model, x, controls, int(VelRepr.Inertial), plan.implicit_dt, ev.aba_scratch]
        outputs = [ev.base_acceleration, ev.joint_accelerations]
        if ev.equality is not None:
            free = ev.equality["nu_free"]
            outputs = [free[:, :6], free[:, 6:] if plan.n > 0 else ev.joint_accelerations]
        launches.append(Launch(aba_kernels(s, "tuned", plan.multi_dof).aba, N, args, outputs))
        if ev.equality is not None:
            launches += plan.equality.launches(plan, ev, x, N)
    return launches


def joint_forces(plan: Plan, X, tau_ref, u, tau, held) -> list:
    """The launches of the joint forces at the state X into tau: one kernel, or, for RK4 with MuJoCo's
    joint forces, JaxSim's part into `held` and then MuJoCo's part added (the first stage's forces)."""
    N = X.joint_positions.shape[0]
    if held is None:
        return [Launch(plan.actuation, (N, plan.n), [plan.model, *plan.torque_curve, X, tau_ref, u], [tau])]
    return [
        Launch(plan.actuation, (N, plan.n), [plan.model, *plan.torque_curve, X, tau_ref, u], [held]),
        Launch(plan.stage_actuation, (N, plan.n), [plan.model, X, held, u], [tau]),
    ]


def fused_applies(plan: Plan, ws: Workspace) -> bool:
    """Whether a step runs as the fused kernel (kernels/fused_step.py) after the joint forces: a semi-implicit
    Euler step of a model whose joints have one DoF each or are free joints below a fixed base, outside a tape, on a workspace without gradients, while
    warpdyn.config.fused_step is on. Its intermediate results (link poses, contact forces) are then not in
    the workspace."""
    return plan.fused is not None and config.fused_step and not ws.grad and not tape.taping()


def fused_kernel(plan: Plan, N: int):
    """The fused step's kernel for N environments (warpdyn.engine.fused_layout's `keeps_joint_transforms`,
    `fused_lanes` and `shared_records`), its launch dim and block size (None: warpdyn's). A kernel that
    keeps its records in shared memory is made for the block size of warpdyn.config.cuda_block_dim now, which
    its launches keep."""
    lanes = fused_layout.fused_lanes(plan, N)
    keep = fused_layout.keeps_joint_transforms(plan.device, N)
    if lanes > 1:
        return plan.fused(keep, lanes), (N, lanes), lanes
    block, shared_c = fused_layout.shared_records(plan, lanes, block_size(None, plan.device))
    if not block:
        return plan.fused(keep, 1), N, None
    return plan.fused(keep, 1, block, shared_c), N, block


def parameter_check(plan: Plan, X, Y, N: int) -> Launch:
    """The launch that ends every step: environments whose parameters, as their arrays hold them now, are out
    of range (or whose dt K / D is unstable where their points can reach the terrain) get y = x and valid 0
    (kernels/parameter_checks.py): in-place edits, which no host check sees, do not step silently."""
    args = [plan.model, plan.contact_bundle, plan.terrain, int(plan.contacts and plan.contact_stage.checked_on_device), plan.check_rate, plan.check_reach, X]
    return Launch(parameter_check_kernels(plan.scalar).keep_unphysical, N, args, [Y])


def step_launches(
    plan: Plan,
    ws: Workspace,
    x: list,
    y: list,
    tau_ref,
    f_user,
    repr: int,
    tau_out=None,
    ctrl=None,
    bundles=None,
    evaluation: bool = False,
    torques_given: bool = False,
) -> list:
    """The launches of one step from the state x to the state y (lists of 7 arrays, see
    warpdyn.engine.kinematics.state_arrays), all arrays given: nothing is allocated, nothing read back.
    Where the fused kernel applies (`fused_applies`) it leaves the workspace's intermediate results unwritten,
    but for the link poses and the points' contact wrenches (ws.evals[0].W_H_L, .W_f_C) when `evaluation`.

    tau_ref (N, n): the joint force references; f_user (N, nL, 6) in representation `repr`, or None;
    tau_out (N, n): where the applied joint torques go (default ws.tau); ctrl (N, na): the actuators'
    controls (None: zero); bundles: the State bundles (X, Y) of x and y when the caller has them.
    torques_given: tau_ref is JaxSim's part of the joint torques, its actuation model's output (JaxSim's
    integrators take it so): friction, limits and the torque-speed curve are not applied; MuJoCo's passive
    forces and actuators are added (at each stage for RK4), as in a step.
    """
    N = x[0].shape[0]
    s = plan.scalar
    check_steppable(plan, ws.grad or tape.taping())
    X, Y = bundles if bundles is not None else (state_bundle(s, x), state_bundle(s, y))
    tau = ws.tau if tau_out is None else tau_out
    launches = []
    u = ctrl if ctrl is not None else plan.zeros((plan.na,), N)
    fused = fused_applies(plan, ws) and not torques_given
    held = (tau_ref if torques_given else ws.tau_held) if plan.stage_forces else None
    if plan.n > 0 and not fused:
        if not torques_given:
            launches += joint_forces(plan, X, tau_ref, u, tau, held)
        elif plan.mujoco_part is None:
            tau = tau_ref
        else:
            launches.append(Launch(plan.mujoco_part, (N, plan.n), [plan.model, X, tau_ref, u], [tau]))
    f_ext = None
    poses_done = False
    if f_user is not None:
        if repr == int(VelRepr.Inertial):
            f_ext = f_user
        else:
            holder = ws.evals[0] if plan.poses else ws
            launches.append(Launch(kinematics_kernels(s, plan.multi_dof).forward_kinematics, N, [plan.model, X], [holder.parent_H_link, holder.W_H_L]))
            poses_done = plan.poses
            launches.append(Launch(force_kernels(s).convert_link_forces, (N, plan.nL), [holder.W_H_L, f_user, repr, 1], [ws.W_f_ext]))
            f_ext = ws.W_f_ext
    if fused:
        controls = controls_bundle(s, plan.device, tau if plan.n > 0 else None, f_ext)
        args = [plan.model, plan.contact_bundle, plan.terrain, X, controls, *plan.torque_curve, tau_ref, u, plan.walk, plan.walk_starts]
        args += [plan.dt, plan.quaternion_tolerance, plan.divergence_speed, plan.implicit_dt]
        outputs = [plan.no_poses, empty_like_input(s, plan.device, 3)]
        if evaluation and plan.contacts:
            outputs = [ws.evals[0].W_H_L, ws.evals[0].W_f_C]
        kernel, dim, block_dim = fused_kernel(plan, N)
        launches.append(Launch(kernel, dim, args, [Y, *outputs], block_dim))
        launches.append(parameter_check(plan, X, Y, N))
        return launches
    K = plan.integrators
    ev = ws.evals[0]
    launches += evaluate(plan, ev, X, tau, f_ext, poses_done)
    if plan.euler:
        euler = K.semi_implicit_euler_so3 if plan.integrator == IntegratorType.SemiImplicitEulerSO3 else K.semi_implicit_euler
        if plan.state_rows:  # the contact state, a thread per row (its rows may be thousands: geom pairs' slots)
            args = [plan.dt, X, ev.m_dot, int(arrays.env_fastest(plan.device))]
            launches.append(Launch(K.contact_state_euler, N * plan.state_rows, args, [ws.contact_flags, Y]))
        after = plan.contact_stage.after_step(plan, ev, Y, N) if plan.contacts else []
        keep, restore = kept_after_step(plan, ws, Y)
        args = [plan.model, plan.dt, plan.quaternion_tolerance, plan.divergence_speed, X, ws.nu_dot, ws.contact_flags]
        launches += [Launch(euler, N, args, [Y], after_adjoint=restore), *after]
        if plan.equality is not None:
            launches += plan.equality.after_step(plan, ev, Y, N)
        return [*launches, parameter_check(plan, X, Y, N), *keep]
    stage = X
    first = ws.evals[0]
    fast = plan.integrator == IntegratorType.RungeKutta4Fast  # the first stage's contacts held over the others
    for i, c in enumerate((0.5, 0.5, 1.0, None)):
        ev = ws.evals[i]
        if i > 0:
            tau_stage = tau
            if plan.stage_forces:
                tau_stage = ev.tau
                launches.append(Launch(plan.stage_actuation, (N, plan.n), [plan.model, stage, held, u], [tau_stage]))
            launches += evaluate(plan, ev, stage, tau_stage, f_ext, False, held=first if fast else None)
        m_dot = first.m_dot if fast and plan.contacts else ev.m_dot
        launches.append(Launch(K.slope, N, [plan.model, stage, ev.base_acceleration, ev.joint_accelerations, m_dot], [ws.slopes[i]]))
        if c is not None:
            stage = state_bundle(s, [*ws.stages[i], x[6]])
            launches.append(Launch(K.rk4_stage, N, [plan.model, s(c * float(plan.dt)), X, ws.slopes[i]], [stage]))
    after = plan.contact_stage.after_step(plan, first, Y, N) if plan.contacts else []
    keep, restore = kept_after_step(plan, ws, Y)
    args = [plan.model, plan.dt, plan.quaternion_tolerance, plan.divergence_speed, X, *ws.slopes]
    launches += [Launch(K.rk4_combine, N, args, [Y], after_adjoint=restore), *after]
    if plan.equality is not None:
        launches += plan.equality.after_step(plan, first, Y, N)
    return [*launches, parameter_check(plan, X, Y, N), *keep]


def kept_after_step(plan: Plan, ws: Workspace, Y) -> tuple[list, object]:
    """Under a tape, where the rigid impact ends the step (`after_step`: it replaces Y's velocities and may clear its
    health flags in place): (the launches copying Y into the workspace at the step's end, the integrator launch's
    `after_adjoint` copying it back). Warp's adjoint of the integrator replays its forward and rewrites some of Y
    with its values before the impact (and before the parameter check, which keeps a flagged environment's state),
    which the stepped data would keep and a second backward pass would read. ([], None) otherwise."""
    if not (plan.contacts and plan.contact_stage.impact and tape.taping()):
        return [], None
    if ws.kept_after_step is None:  # a workspace without gradients, under a tape all the same
        ws.kept_after_step = state_buffers(plan, ws.N, False)
    fields = (Y.base_position, Y.base_quaternion, Y.joint_positions, Y.base_velocity, Y.joint_velocities, Y.tangential_deformation, Y.valid)
    keep = [copy_launch(plan.scalar, a, kept) for a, kept in zip(fields, ws.kept_after_step)]
    back = [copy_launch(plan.scalar, kept, a) for a, kept in zip(fields, ws.kept_after_step)]

    def restore() -> None:
        with tape.suspended():
            run([k for k in back if k is not None], plan.device)

    return [k._replace(adjoint=no_adjoint) for k in keep if k is not None], restore  # unrecorded: kept has no gradient


def inputs_require_grad(*values) -> bool:
    return any(isinstance(v, wp.array) and v.requires_grad for v in values)


def torque_reference_input(plan: Plan, data, value) -> wp.array:
    if value is None:
        return plan.zeros((plan.n,), data.batch_size)
    return arrays.batched_input(value, "joint_force_references", (plan.n,), data.num_envs, plan.scalar, plan.device)


def link_force_input(plan: Plan, data, value):
    if value is None:
        return None
    return arrays.batched_input(value, "link_forces", (plan.nL, 6), data.num_envs, plan.scalar, plan.device)


def ctrl_input(plan: Plan, data, value):
    if value is None:
        return plan.zeros((plan.na,), data.batch_size)
    return arrays.batched_input(value, "ctrl", (plan.na,), data.num_envs, plan.scalar, plan.device)


def prepare(model, data, parameters: bool = True, health: bool = False) -> tuple[Plan, int]:
    """(plan, N) after checking the data against the model (parameters: the caller reads the link or joint
    parameters, see warpdyn.types.model.check_data; health: the caller steps, which reads and writes the
    health flag; the contact parameters and the terrain are checked in any case)."""
    check_data(model, data, parameters)
    check_contact_state(model, data)
    if health and data.valid_state is None:
        raise ValueError(
            "data.valid_state is None, but a step reads and writes each environment's health flag: build the data "
            "with wd.data.Data.build, or give valid_state=wp.ones(N, dtype=wp.int32)"
        )
    current = plan(model)
    current.check_envs(data.batch_size)
    return current, data.batch_size


class _Shared:
    """A thread's workspace and recorded launches of `step` for one plan, batch size and link-force presence."""

    def __init__(self, current: Plan, N: int, forces: bool):
        self.workspace = Workspace(current, N, False, forces)
        self.recorded = Recorded()


def step(model, data, *, link_forces=None, joint_force_references=None, ctrl=None):
    """The data after one step (see warpdyn.model.step): new Data, fresh arrays, same representation. The path
    under a wp.Tape; warpdyn.engine.fast_step serves warpdyn.model.step and comes here when it must."""
    current, _ = prepare(model, data, health=True)
    return advance(model, data, current, *step_inputs(current, data, joint_force_references, link_forces, ctrl))


def step_inputs(current: Plan, data, joint_force_references, link_forces, ctrl) -> tuple:
    """(tau_ref, f_user, u): a step's inputs as device arrays (N, ...), checked; absent ones zero or None."""
    tau_ref = torque_reference_input(current, data, joint_force_references)
    f_user = link_force_input(current, data, link_forces)
    u = ctrl_input(current, data, ctrl)
    return tau_ref, f_user, u


def advance(model, data, current: Plan, tau_ref, f_user, u):
    """`step` after `prepare` and `step_inputs`: new Data on fresh arrays (tau_ref or u None: zero)."""
    N = data.batch_size
    if tau_ref is None:
        tau_ref = current.zeros((current.n,), N)
    if u is None:
        u = current.zeros((current.na,), N)
    grad = data.requires_grad or inputs_require_grad(tau_ref, f_user, u) or model.parameters_require_grad()
    forces = f_user is not None
    y = state_buffers(current, N, grad)
    repr = int(data.velocity_representation)
    x = state_arrays(data)
    if tape.taping():
        ws = Workspace(current, N, grad, forces)
        run(step_launches(current, ws, x, y, tau_ref, f_user, repr, ctrl=u), current.device)
    else:
        shared = per_thread(model, ("step", N, forces, current), lambda: _Shared(current, N, forces))
        shared.recorded.run(step_launches(current, shared.workspace, x, y, tau_ref, f_user, repr, ctrl=u), current.device)
    return with_state(data, y)


def with_state(data, state: list):
    """`data` with its state arrays replaced by `state` (p, Q, s, v, sdot, m, valid), arrays made like the
    data's own (what the data passed of warpdyn.types.data_checks' checks, it passes)."""
    stepped = dataclasses.replace(
        data,
        base_position_state=state[0],
        base_quaternion_state=state[1],
        joint_positions_state=state[2],
        base_velocity_state=state[3],
        joint_velocities_state=state[4],
        tangential_deformation_state=state[5],
        valid_state=state[6],
    )
    passes_like(stepped, data)
    return stepped
