"""Simulation: soft contacts with the terrain, actuation, and the integrators of `wd.model.step`.

A step, as JaxSim's `js.model.step` with SoftContacts:
1. the user's link forces (the data's representation) made Inertial; the joint torques from the joint
   force references through friction, limit springs and the torque-speed curve (kernels/actuation.py),
   once per step at its start;
2. the contact forces of the enabled collidable points (kernels/soft_contacts.py) added to the link forces,
   and the rate of the tangential deformation;
3. forward dynamics by ABA in the Inertial representation;
4. the integrator (kernels/integrators.py); environments whose new state is not finite are flagged
   (`data.valid`) and keep their state.
`step` returns new Data (fresh arrays): nothing an adjoint needs is overwritten, so a wp.Tape through
many steps gives gradients.

Structure. What a model's steps launch is chosen once per model (`_Plan`, cached on the model and rebuilt
only when a parameter it reads is replaced: `set_joint_parameters`, `contact_params`, `terrain`,
`actuation_params`, `integrator`, `time_step`, other collidable points). Parts a model does not need are
not launched (no enabled collidable points: no FK, link-velocity or contact kernel; no link forces: no
conversion, and ABA skips the force terms) or not compiled (no limit springs, no friction: an actuation
kernel without that code). A step is then a fixed list of launches on given arrays (`_step_launches`):
nothing allocated, nothing read back, so `warpdyn.simulation` captures many of them in a graph.
Launches per semi-implicit Euler step: actuation (if joints), [FK, link velocities, contacts] (if enabled
points), [FK if no contacts, force conversion] (if link forces not Inertial), ABA, integrator.

Gradients with respect to model parameters (`PARAMETERS`, marked by `warpdyn.model.parameters_requiring_grad`).
Every parameter a step reads is an array the user holds: the plan's launch arguments are the model's own
arrays (`model_args`, the actuation's joint parameters) and the contact K, D, mu are read in place when
`contact_params` holds Warp arrays (`_per_env` copies only numbers and NumPy arrays). Under a tape the
adjoints accumulate into those arrays' .grad: `step` allocates fresh buffers with gradients when the data,
an input or a parameter requires them (`parameters_require_grad`), and a rollout under a tape always does;
the shared workspace and recorded launches serve only calls outside a tape. Marking a friction or limit gain
keeps its term in the compiled actuation kernel even where it is zero (part of `_plan_key`, so marking one
rebuilds the plan once). With nothing marked, nothing changes: a few attribute reads per step.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from .engine import launch as launching
from . import arrays as _arrays
from .engine import tape as _tape
from ._dynamics import model_args
from .types.enums import IntegratorType, VelRepr
from .types.settings import ActuationParams, SoftContactsParams
from .types.settings import host_values as _host
from .kernels.aba import ABA_RECORD
from .kernels.aba import kernels as aba_kernels
from .kernels.actuation import kernel as actuation_kernel
from .kernels.forces import kernels as force_kernels
from .kernels.integrators import kernels as integrator_kernels
from .kernels.kinematics import kernels as kinematics_kernels
from .kernels.scratch import TRANSFORM
from .kernels.soft_contacts import kernels as contact_kernels
from .kernels.velocities import kernels as velocity_kernels
from .types.terrain import FlatTerrain, HeightfieldTerrain


__all__ = ["IntegratorType", "SoftContactsParams", "ActuationParams", "step", "estimate_good_contact_parameters"]


PARAMETERS = (
    "link_mass",
    "link_com",
    "link_inertia",
    "friction_static",
    "friction_viscous",
    "joint_limit_spring",
    "joint_limit_damper",
    "K",
    "D",
    "mu",
    "terrain_height",
)
"""The model parameters that tape gradients reach (warpdyn.model.parameters_requiring_grad)."""

MODEL_ARRAYS = ("link_mass", "link_com", "link_inertia", "friction_static", "friction_viscous", "joint_limit_spring", "joint_limit_damper")
"""The parameters held as the model's own arrays (link and joint parameters, shared or per environment)."""


def parameters_require_grad(model) -> bool:
    """Whether any parameter in PARAMETERS requires gradients (a few attribute reads)."""
    c = model.contact_params
    return (
        model.link_mass.requires_grad
        or model.link_com.requires_grad
        or model.link_inertia.requires_grad
        or model.friction_static.requires_grad
        or model.friction_viscous.requires_grad
        or model.joint_limit_spring.requires_grad
        or model.joint_limit_damper.requires_grad
        or any(isinstance(v, wp.array) and v.requires_grad for v in (c.K, c.D, c.mu, *_terrain_parameters(model.terrain)))
    )


def _taping() -> bool:
    """Whether a wp.Tape is recording (True when this Warp version does not say)."""
    return _tape.taping()


def _terrain_parameters(terrain) -> tuple:
    """The terrain's Warp arrays that kernels read in place (and may require gradients)."""
    if isinstance(terrain, FlatTerrain) and isinstance(terrain.height, wp.array):
        return (terrain.height,)
    if isinstance(terrain, HeightfieldTerrain) and isinstance(terrain.heights, wp.array):
        return (terrain.heights,)
    return ()


def parameter_value(model, name: str):
    """The model's current value of the parameter `name` (in PARAMETERS): a Warp array, or for the contact
    parameters and the terrain's height possibly a number or NumPy array (None for a PlaneTerrain's)."""
    if name in ("K", "D", "mu"):
        return getattr(model.contact_params, name)
    if name == "terrain_height":
        terrain = model.terrain
        return terrain.height if isinstance(terrain, FlatTerrain) else terrain.heights if isinstance(terrain, HeightfieldTerrain) else None
    return getattr(model, name)


def _terrain_args(model) -> list:
    """The terrain as the contact kernels take it: kind, plane normal, heights at the origin (1,) or (N,),
    the heightfield (nx, ny), its grid. Warp arrays in the terrain are read in place (their .grad gets
    the gradient)."""
    terrain = model.terrain
    s, d = model.scalar, model.device
    vec3 = wp.types.vector(3, s)
    vec4 = wp.types.vector(4, s)
    if isinstance(terrain, HeightfieldTerrain):
        heights = terrain.heights
        if isinstance(heights, wp.array):
            _arrays.check_device_array(heights, "HeightfieldTerrain.heights", s, d)
        else:
            heights = wp.array(heights, dtype=s, device=d)
        grid = vec4(*terrain.origin, *terrain.spacing)
        return [terrain.kind, vec3(0.0, 0.0, 1.0), wp.zeros(1, dtype=s, device=d), heights, grid]
    empty = wp.zeros((2, 2), dtype=s, device=d)
    if isinstance(terrain, FlatTerrain):
        h0 = _per_env(terrain.height, "height", s, d, owner="FlatTerrain")
        return [terrain.kind, vec3(0.0, 0.0, 1.0), h0, empty, vec4(0.0, 0.0, 1.0, 1.0)]
    normal, h0 = terrain.plane()
    return [terrain.kind, vec3(*normal), wp.array([h0], dtype=s, device=d), empty, vec4(0.0, 0.0, 1.0, 1.0)]


def _per_env(value, name, scalar, device, owner="SoftContactsParams") -> wp.array:
    """A parameter shared (1,) or per environment (N,) as the kernels read it: a Warp array is the user's,
    read in place (its .grad gets the gradient); numbers and NumPy arrays are copied."""
    if isinstance(value, wp.array):
        if value.ndim != 1 or value.dtype != scalar or value.device != device:
            raise ValueError(
                f"{owner}.{name} as a Warp array must be 1-D with the model's dtype {scalar.__name__} on "
                f"{device}, got shape {value.shape}, dtype {getattr(value.dtype, '__name__', value.dtype)} on {value.device}"
            )
        return value
    host = np.atleast_1d(np.asarray(value, dtype=np.float64))
    if host.ndim != 1:
        raise ValueError(f"{owner}.{name} has shape {host.shape}: give a number or one value per environment (N,)")
    return wp.array(host, dtype=scalar, device=device)


def _plan_key(model) -> tuple:
    """What a plan depends on: compared by identity, so replacing any of them (set_joint_parameters makes new
    arrays; contact_params, actuation_params, terrain and with_collidable_points make new objects) rebuilds it."""
    return (
        model.kin_dyn_parameters,
        model.terrain,
        model.contact_params,
        model.actuation_params,
        model.integrator,
        model.time_step,
        model.quaternion_tolerance,
        model.gravity,
        model.position_limits,
        # the parameter arrays and their gradients (the plan holds views of them, see Model.kernel_parameter)
        *(getattr(model, name) for name in MODEL_ARRAYS),
        *(getattr(model, name).grad for name in MODEL_ARRAYS),
        # the kernels compiled for the actuation depend on these (a parameter that requires gradients keeps
        # its term even where it is zero)
        model.friction_static.requires_grad or model.friction_viscous.requires_grad,
        model.joint_limit_spring.requires_grad or model.joint_limit_damper.requires_grad,
    )


class _Plan:
    """What a step of one model launches, chosen once per model (see `_plan`).

    - actuation: a kernel compiled with only the terms the joint parameters need (no limit springs: no
      limit code; no friction, or friction disabled: no friction code); none without joints;
    - contacts: the enabled points ordered by link and the contact parameters on the device; without enabled
      points no FK, link-velocity or contact kernel is launched and the deformation rate is a zero array;
    - the terrain's arrays (a heightfield's heights are uploaded once, not per step).
    Host work per step is then a few identity comparisons (`_plan`), no NumPy reductions, no uploads.
    """

    def __init__(self, model):
        s, d = model.scalar, model.device
        self.key = _plan_key(model)
        self.scalar, self.device = s, d
        self.n, self.nL = model.dofs(), model.number_of_links()
        self.floating_base = bool(model.floating_base())
        self.integrator = IntegratorType(model.integrator)
        self.dt = s(model.time_step)
        self.quaternion_tolerance = s(model.quaternion_tolerance)
        # actuation
        a = model.actuation_params
        self.with_limits = bool(np.any(model.joint_limit_spring_host != 0.0)) or bool(self.key[-1])
        self.with_friction = bool(a.enable_friction) and (
            bool(np.any(model.friction_static_host != 0.0) or np.any(model.friction_viscous_host != 0.0)) or bool(self.key[-2])
        )
        self.actuation = actuation_kernel(s, self.with_limits, self.with_friction) if self.n > 0 else None
        self.actuation_args = [
            model.position_limits,
            model.kernel_parameter("joint_limit_spring"),
            model.kernel_parameter("joint_limit_damper"),
            model.kernel_parameter("friction_static"),
            model.kernel_parameter("friction_viscous"),
            s(a.torque_max),
            s(a.omega_th),
            s(a.omega_max),
        ]
        # collidable points: the enabled ones ordered by link (the contact kernel sums them per link)
        cp = model.kin_dyn_parameters.contact_parameters
        rows = cp.indices_of_enabled_collidable_points
        links = np.asarray(cp.body, dtype=np.int64)[rows]
        order = np.argsort(links, kind="stable")
        rows, links = rows[order], links[order]
        first = np.full(self.nL, -1, dtype=np.int32)
        for k in range(len(links) - 1, -1, -1):
            first[links[k]] = k
        enabled = np.zeros(len(cp.body), dtype=np.int32)
        enabled[rows] = 1
        self.total = len(cp.body)
        self.count = len(rows)
        self.contacts = self.count > 0
        if self.contacts:
            _check_deformation_stability(model)
        self.point_link = wp.array(links.astype(np.int32), dtype=int, device=d)
        self.L_p_C = wp.array(np.asarray(cp.point, dtype=np.float64)[rows].reshape(-1, 3), dtype=wp.types.vector(3, s), device=d)
        self.point_row = wp.array(rows.astype(np.int32), dtype=int, device=d)
        self.point_out = wp.array(order.astype(np.int32), dtype=int, device=d)  # place among the enabled points
        self.link_first_point = wp.array(first, dtype=int, device=d)
        self.terrain_args = _terrain_args(model)
        c = model.contact_params
        self.K, self.D, self.mu = (_per_env(getattr(c, k), k, s, d) for k in ("K", "D", "mu"))
        self.contact_args = [
            self.point_link,
            self.L_p_C,
            self.point_row,
            wp.array(enabled, dtype=int, device=d),
            self.link_first_point,
            *self.terrain_args,
            self.K,
            self.D,
            self.mu,
            s(c.p),
            s(c.q),
        ]
        # kernels and the model constants they read
        self.fk = kinematics_kernels(s).forward_kinematics
        self.fk_args = [model.parent, model.joint_type, model.X_tree, model.joint_axis, model.joint_pivot]
        self.link_velocities = velocity_kernels(s).link_velocities
        self.velocity_args = [
            model.parent,
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            model.all_links[:0],
            model.identity_offsets[:0],
        ]
        self.aba = aba_kernels(s).aba
        self.aba_args = [
            *model_args(model),
            model.gravity,
            int(self.floating_base),
        ]
        self.integrators = integrator_kernels(s)
        self._zeros: dict = {}
        self._workspaces: dict = {}

    def check_envs(self, N: int) -> None:
        per_env = (("SoftContactsParams.K", self.K), ("SoftContactsParams.D", self.D), ("SoftContactsParams.mu", self.mu))
        for name, value in (*per_env, ("the terrain's height", self.terrain_args[2])):
            if value.shape[0] not in (1, N):
                raise ValueError(f"{name} has shape {value.shape}: give a number or one value per environment ({N},)")

    def zeros(self, shape: tuple, N: int) -> wp.array:
        """A zero array of logical shape (N, *shape) that no kernel writes: one row, broadcast (env stride 0)."""
        key = tuple(shape)
        row = self._zeros.get(key)
        if row is None:
            row = self._zeros[key] = wp.zeros((1, *shape), dtype=self.scalar, device=self.device)
        return broadcast_envs(row, N)

    def shared_workspace(self, N: int, forces: bool) -> _Workspace:
        """The workspace `step` reuses outside a tape (no adjoint reads it later); one per CUDA stream."""
        key = (N, forces, self.device.stream if self.device.is_cuda else None)
        ws = self._workspaces.get(key)
        if ws is None:
            ws = self._workspaces[key] = _Workspace(self, N, False, forces)
        return ws


def broadcast_envs(row: wp.array, N: int) -> wp.array:
    """The (N, *S) view of a (1, *S) array with a zero stride on the environment axis (its gradient likewise):
    what kernels read as one value per environment, without N copies. The view does not own the memory:
    keep `row` alive."""
    if row.shape[0] != 1:
        raise ValueError(f"broadcast_envs needs a leading axis of 1, got shape {row.shape}")
    if N == 1:
        return row
    view = wp.array(ptr=row.ptr, dtype=row.dtype, shape=(N, *row.shape[1:]), strides=(0, *row.strides[1:]), device=row.device)
    if row.grad is not None:
        view.grad = wp.array(
            ptr=row.grad.ptr, dtype=row.dtype, shape=(N, *row.shape[1:]), strides=(0, *row.grad.strides[1:]), device=row.device
        )
    return view


DEFORMATION_STABILITY = {IntegratorType.SemiImplicitEuler: 2.0, IntegratorType.RungeKutta4: 2.785}
"""Stability limits of dt K / D: the tangential deformation relaxes as m_dot = -(K / D) m (out of contact,
and for p = q in contact), which explicit Euler integrates stably for dt K / D < 2 and RK4 for
dt K / D < 2.785 (its stability region on the negative real axis). Beyond, m grows geometrically while
staying finite for many steps, so no health check would catch it: `step` refuses such settings."""


def _check_deformation_stability(model) -> None:
    c = model.contact_params
    rate = float(np.max(_host(c.K) / _host(c.D)))
    limit = DEFORMATION_STABILITY[IntegratorType(model.integrator)]
    if model.time_step * rate >= limit:
        raise ValueError(
            f"time_step {model.time_step} s with contact K/D = {rate:.4g} 1/s gives dt K/D = {model.time_step * rate:.3g}, "
            f"beyond the stability limit {limit} of {IntegratorType(model.integrator).name} for the tangential "
            f"deformation: take time_step < {limit / rate:.3g} s, or a smaller K (a larger D also lowers K/D but makes "
            "the explicit contact damping less stable: README, 'Speed and accuracy')"
        )


def _plan(model) -> _Plan:
    """The model's plan, rebuilt when a parameter it depends on was replaced since (see `_plan_key`)."""
    cached = model.__dict__.get("_simulation_plan")
    if cached is not None:
        key = _plan_key(model)
        if all(a is b for a, b in zip(key, cached.key)):
            return cached
    plan = model.__dict__["_simulation_plan"] = _Plan(model)
    return plan


class _Eval:
    """Buffers of one evaluation of the state derivative (one per stage of RK4)."""

    def __init__(self, plan: _Plan, N: int, grad: bool, forces: bool, nu_dot: wp.array | None, aba: bool = True):
        s, d = plan.scalar, plan.device
        nL, n = plan.nL, plan.n

        def out(shape, dtype=s):
            return _arrays.output(shape, N, dtype, d, grad)

        transform = wp.types.transformation(s)
        vec6 = wp.types.vector(6, s)
        if plan.contacts:
            self.parent_H_link = out((nL,), transform)
            self.W_H_L = out((nL,), transform)
            self.W_v_WL = out((nL,), vec6)
            self.target_velocities = _arrays.empty((0, 6), N, s, d)
            self.W_f_C = out((plan.count, 6))
            self.m_dot = out((plan.total, 3))
            self.W_f_L = out((nL, 6))
            self.chain = _arrays.empty((plan.count,), N, vec6, d, grad)
        else:
            self.m_dot = plan.zeros((plan.total, 3), N)
        if not aba:  # contact results only (warpdyn.contact)
            return
        self.aba_scratch = _aba_scratch(plan, N, grad, plan.contacts or forces)
        # nu_dot (N, 6 + n) = [W_vdot_WB (Inertial); sddot]: the semi-implicit Euler's (given), or this stage's
        self.nu_dot = out((6 + n,)) if nu_dot is None else nu_dot
        self.base_acceleration = self.nu_dot[:, :6]
        self.joint_accelerations = self.nu_dot[:, 6:] if n > 0 else out((0,))


class _Workspace:
    """Buffers of one step's intermediate results for N environments (`_step_launches` writes them).

    `step` reuses one per model outside a tape and makes fresh ones under a tape (the adjoint reads them
    later); a rollout keeps one for all steps, or one per step when it must be differentiable.
    forces: whether the steps get external link forces (room for their Inertial conversion and for ABA's).
    """

    def __init__(self, plan: _Plan, N: int, grad: bool, forces: bool):
        s, d = plan.scalar, plan.device
        n, nL = plan.n, plan.nL
        self.N, self.grad, self.forces = N, grad, forces
        self.recorded = None  # see _run_recorded
        self.tau = _arrays.output((n,), N, s, d, grad)
        transform = wp.types.transformation(s)
        if forces:
            self.W_f_ext = _arrays.output((nL, 6), N, s, d, grad)
            if not plan.contacts:  # otherwise the first evaluation's link poses serve
                self.parent_H_link = _arrays.output((nL,), N, transform, d, grad)
                self.W_H_L = _arrays.output((nL,), N, transform, d, grad)
        if plan.integrator == IntegratorType.SemiImplicitEuler:
            self.nu_dot = _arrays.output((6 + n,), N, s, d, grad)
            self.evals = [_Eval(plan, N, grad, forces, self.nu_dot)]
        else:
            self.evals = [_Eval(plan, N, grad, forces, None) for _ in range(4)]
            size = plan.integrators.state_size(n, plan.total)
            self.slopes = [_arrays.output((size,), N, s, d, grad) for _ in range(4)]
            self.stages = [_state_buffers(plan, N, grad)[:6] for _ in range(3)]


def _state_buffers(plan: _Plan, N: int, grad: bool) -> list:
    """Uninitialised state arrays (p, Q, s, v, sdot, m, valid) for N environments, in the device's layout."""
    s, d, n = plan.scalar, plan.device, plan.n
    return [
        _arrays.output((3,), N, s, d, grad),
        _arrays.output((4,), N, s, d, grad),
        _arrays.output((n,), N, s, d, grad),
        _arrays.output((6,), N, s, d, grad),
        _arrays.output((n,), N, s, d, grad),
        _arrays.output((plan.total, 3), N, s, d, grad),
        wp.empty(N, dtype=wp.int32, device=d),
    ]


def _evaluate(plan: _Plan, ev: _Eval, x: list, tau, f_ext, poses_done: bool, aba: bool = True) -> list:
    """The launches of one derivative evaluation at the state x: contacts (if any), then ABA (Inertial).

    f_ext (N, nL, 6) Inertial or None. poses_done: ev's link poses already hold FK at x.
    """
    N = x[0].shape[0]
    launches = []
    f_aba = f_ext
    if plan.contacts:
        if not poses_done:
            launches.append((plan.fk, N, [*plan.fk_args, x[0], x[1], x[2]], [ev.parent_H_link, ev.W_H_L]))
        launches.append(
            (
                plan.link_velocities,
                N,
                [*plan.velocity_args, ev.W_H_L, x[3], x[4], int(VelRepr.Inertial)],
                [ev.W_v_WL, ev.target_velocities],
            )
        )
        launches.append(
            (
                contact_kernels(plan.scalar).contact_forces,
                N,
                [*plan.contact_args, ev.W_H_L, ev.W_v_WL, x[5], f_ext if f_ext is not None else plan.zeros((plan.nL, 6), N), ev.chain],
                [ev.W_f_C, ev.m_dot, ev.W_f_L],
            )
        )
        f_aba = ev.W_f_L
    if aba:
        launches.append(_aba_launch(plan, ev, x, tau, f_aba))
    return launches


def _aba_scratch(plan: _Plan, N: int, grad: bool, forces: bool) -> wp.array:
    """ABA's scratch record (N, nL, ABA_RECORD [+ TRANSFORM with link forces]), see kernels/aba.py."""
    return _arrays.empty((plan.nL, ABA_RECORD + (TRANSFORM if forces else 0)), N, plan.scalar, plan.device, grad)


def _aba_launch(plan: _Plan, ev: _Eval, x: list, tau, f_L):
    """ABA at the state x in the Inertial representation: joint forces tau (N, n), link forces f_L (N, nL, 6)
    Inertial or None (ABA skips them), into ev.nu_dot."""
    N = x[0].shape[0]
    inputs = [*plan.aba_args, *x[:5], tau if plan.n > 0 else None, f_L, int(VelRepr.Inertial), ev.aba_scratch]
    return (plan.aba, N, inputs, [ev.base_acceleration, ev.joint_accelerations])


def _step_launches(plan: _Plan, ws: _Workspace, x: list, y: list, tau_ref, f_user, repr: int, tau_out=None) -> list:
    """The launches of one step from the state x to the state y (lists of 7 arrays, see `_state_arrays`), as
    (kernel, dim, inputs, outputs), all arrays given: nothing is allocated, nothing read back.

    tau_ref (N, n): the joint force references; f_user (N, nL, 6) in representation `repr`, or None;
    tau_out (N, n): where the applied joint torques go (default ws.tau).
    """
    N = x[0].shape[0]
    tau = ws.tau if tau_out is None else tau_out
    launches = []
    if plan.n > 0:
        launches.append((plan.actuation, (N, plan.n), [*plan.actuation_args, x[2], x[4], tau_ref], [tau]))
    f_ext = None
    poses_done = False
    if f_user is not None:
        if repr == int(VelRepr.Inertial):
            f_ext = f_user
        else:
            holder = ws.evals[0] if plan.contacts else ws
            launches.append((plan.fk, N, [*plan.fk_args, x[0], x[1], x[2]], [holder.parent_H_link, holder.W_H_L]))
            poses_done = plan.contacts
            launches.append((force_kernels(plan.scalar).link_forces_to_inertial, (N, plan.nL), [holder.W_H_L, f_user, repr], [ws.W_f_ext]))
            f_ext = ws.W_f_ext
    K = plan.integrators
    ev = ws.evals[0]
    launches += _evaluate(plan, ev, x, tau, f_ext, poses_done)
    if plan.integrator == IntegratorType.SemiImplicitEuler:
        launches.append((K.semi_implicit_euler, N, [plan.dt, plan.quaternion_tolerance, *x, ws.nu_dot, ev.m_dot], list(y)))
        return launches
    stage = x
    for i, c in enumerate((0.5, 0.5, 1.0, None)):
        ev = ws.evals[i]
        if i > 0:
            launches += _evaluate(plan, ev, stage, tau, f_ext, False)
        launches.append((K.slope, N, [*stage[:6], ev.base_acceleration, ev.joint_accelerations, ev.m_dot], [ws.slopes[i]]))
        if c is not None:
            stage = [*ws.stages[i], x[6]]
            launches.append((K.rk4_stage, N, [plan.scalar(c * float(plan.dt)), *x[:6], ws.slopes[i]], stage[:6]))
    launches.append((K.rk4_combine, N, [plan.dt, plan.quaternion_tolerance, *x, *ws.slopes], list(y)))
    return launches


def _run(launches, device) -> None:
    for kernel, dim, inputs, outputs in launches:
        launching.launch(kernel, dim=dim, inputs=inputs, outputs=outputs, device=device)


def _run_recorded(ws: _Workspace, launches, device) -> None:
    """`_run` through launches recorded in `ws` (launching.launch(record_cmd=True)): a later call with the same
    kernels re-packs only the arguments that are not the ones bound last time (the new state arrays), not
    the ~100 arguments of a step. Outside a tape only (a tape records wp.launch calls)."""
    recorded = ws.recorded
    if recorded is None or len(recorded) != len(launches) or any(r[0].kernel is not l[0] for r, l in zip(recorded, launches)):
        recorded = ws.recorded = []
        for kernel, dim, inputs, outputs in launches:
            args = [*inputs, *outputs]
            recorded.append((launching.launch(kernel, dim=dim, inputs=args, device=device, record_cmd=True), args))
    else:
        for (command, bound), (kernel, dim, inputs, outputs) in zip(recorded, launches):
            for i, a in enumerate((*inputs, *outputs)):
                b = bound[i]
                if a is b or (type(a) in (int, float) and type(b) is type(a) and a == b):
                    continue
                command.set_param_at_index(i, a)
                bound[i] = a
    for command, _ in recorded:
        command.launch()


def tangential_deformation(model, data) -> wp.array:
    """The data's contact state m (N, nc_all, 3), checked against the model's points."""
    total = len(model.kin_dyn_parameters.contact_parameters.body)
    m = data.tangential_deformation_state
    if m is None or m.shape[1] != total:
        got = None if m is None else m.shape[1]
        raise ValueError(
            f"data holds the tangential deformation of {got} collidable points but the model has {total}: "
            "build the data from this model (wd.data.Data.build) after changing its collidable points"
        )
    return m


def _inputs_require_grad(*values) -> bool:
    return any(isinstance(v, wp.array) and v.requires_grad for v in values)


def _joint_force_references(plan: _Plan, data, value) -> wp.array:
    if value is None:
        return plan.zeros((plan.n,), data.batch_size)
    return _arrays.batched_input(value, "joint_force_references", (plan.n,), data.num_envs, plan.scalar, plan.device)


def _link_forces(plan: _Plan, data, value):
    if value is None:
        return None
    return _arrays.batched_input(value, "link_forces", (plan.nL, 6), data.num_envs, plan.scalar, plan.device)


def _prepare(model, data, parameters: bool = True):
    """(plan, N) after checking the data against the model (parameters: the caller reads the link or joint
    parameters, see model._check_data; the contact parameters and the terrain are checked in any case)."""
    from .model import _check_data

    _check_data(model, data, parameters)
    tangential_deformation(model, data)
    plan = _plan(model)
    plan.check_envs(data.batch_size)
    return plan, data.batch_size


def resultant_torques(model, data, joint_force_references) -> wp.array:
    """tau (N, n): the joint torques a step applies, from the references (see kernels/actuation.py)."""
    plan, N = _prepare(model, data)
    tau_ref = _joint_force_references(plan, data, joint_force_references)
    if plan.n == 0:
        return _arrays.empty((0,), N, plan.scalar, plan.device)
    grad = data.requires_grad or _inputs_require_grad(tau_ref) or parameters_require_grad(model)
    tau = _arrays.output((plan.n,), N, plan.scalar, plan.device, grad)
    _run([(plan.actuation, (N, plan.n), [*plan.actuation_args, data.joint_positions_state, data.joint_velocities_state, tau_ref], [tau])], plan.device)
    return tau


def _contact_evaluation(model, data, W_f_ext=None) -> tuple[_Plan, _Eval | None]:
    """(plan, ev): ev holds FK, link velocities and the contact kernel's results at the data's state (fresh
    arrays), None without enabled points. W_f_ext (N, nL, 6) Inertial or None (zero)."""
    plan, N = _prepare(model, data, parameters=False)
    if not plan.contacts:
        return plan, None
    grad = data.requires_grad or _inputs_require_grad(W_f_ext) or parameters_require_grad(model)
    ev = _Eval(plan, N, grad, W_f_ext is not None, None, aba=False)
    x = _state_arrays(data)
    launches = _evaluate(plan, ev, x, None, W_f_ext, False, aba=False)
    _run(launches, plan.device)
    return plan, ev


def contact_forces(model, data, W_f_ext: wp.array | None = None):
    """(W_f_C (N, nc, 6), m_dot (N, nc_all, 3), W_f_L (N, nL, 6)): the Inertial contact wrench of each
    enabled point (ordered by link), the deformation rate of every point, and W_f_ext (Inertial; None: zero)
    plus the contact wrenches per link."""
    plan, ev = _contact_evaluation(model, data, W_f_ext)
    N, s, d = data.batch_size, plan.scalar, plan.device
    if ev is None:
        m_dot = _arrays.output((plan.total, 3), N, s, d)
        m_dot.zero_()
        W_f_L = W_f_ext
        if W_f_L is None:
            W_f_L = _arrays.zeros((plan.nL, 6), N, s, d)
        return _arrays.output((0, 6), N, s, d), m_dot, W_f_L
    return ev.W_f_C, ev.m_dot, ev.W_f_L


def step(model, data, *, link_forces=None, joint_force_references=None):
    """The data after one step of `model.time_step` [s] with `model.integrator`, as JaxSim's step.

    link_forces (nL, 6) or (N, nL, 6): external forces in the data's representation, held for the step.
    joint_force_references (n,) or (N, n): joint forces before friction, limits and the torque-speed curve.
    Returns new Data (fresh arrays, same representation); `data` is unchanged. Outside a wp.Tape the step's
    intermediate arrays and its recorded launches are kept per model and reused (a call packs only its new
    arguments); under one they are fresh (the adjoint reads them later).
    """
    plan, N = _prepare(model, data)
    tau_ref = _joint_force_references(plan, data, joint_force_references)
    f_user = _link_forces(plan, data, link_forces)
    grad = data.requires_grad or _inputs_require_grad(tau_ref, f_user) or parameters_require_grad(model)
    forces = f_user is not None
    y = _state_buffers(plan, N, grad)
    repr = int(data.velocity_representation)
    if _taping():
        ws = _Workspace(plan, N, grad, forces)
        _run(_step_launches(plan, ws, _state_arrays(data), y, tau_ref, f_user, repr), plan.device)
    else:
        ws = plan.shared_workspace(N, forces)
        _run_recorded(ws, _step_launches(plan, ws, _state_arrays(data), y, tau_ref, f_user, repr), plan.device)
    return _from_arrays(data, y)


def _state_arrays(data) -> list:
    """The state of `data` as the kernels take it: (p, Q, s, v (Mixed), sdot, m, valid)."""
    return [
        data.base_position_state,
        data.base_quaternion_state,
        data.joint_positions_state,
        data.base_velocity_state,
        data.joint_velocities_state,
        data.tangential_deformation_state,
        data.valid_state,
    ]


def _from_arrays(data, arrays):
    return dataclasses.replace(
        data,
        base_position_state=arrays[0],
        base_quaternion_state=arrays[1],
        joint_positions_state=arrays[2],
        base_velocity_state=arrays[3],
        joint_velocities_state=arrays[4],
        tangential_deformation_state=arrays[5],
        valid_state=arrays[6],
    )


def estimate_good_contact_parameters(
    model,
    *,
    standard_gravity: float = 9.81,
    static_friction_coefficient: float = 0.5,
    number_of_active_collidable_points_steady_state: int = 1,
    damping_ratio: float = 1.0,
    max_penetration: float | None = None,
) -> SoftContactsParams:
    """JaxSim's estimate: K so that the robot's weight shared by the active points penetrates
    max_penetration (default: 1% of the CoM height above the lowest collidable point at the zero state),
    K = m g / n / delta_max^(1 + p) clipped to 1e6, and D = damping_ratio 2 sqrt(K m) clipped to 1e4.
    m is the model's current total mass (`model.link_mass`); with masses given per environment, K and D are
    one value per environment (N,)."""
    from . import contact, com
    from .data import Data

    masses = np.asarray(model.link_mass.numpy(), dtype=np.float64)
    m = masses.sum(axis=-1)
    num_envs = masses.shape[0] if masses.ndim == 2 else None
    nc = int(number_of_active_collidable_points_steady_state)
    if nc < 1:
        raise ValueError(f"number_of_active_collidable_points_steady_state must be >= 1, got {nc}")
    if max_penetration is None:
        zero = Data.build(model, num_envs=num_envs)
        height = com.com_position(model, zero).numpy()[..., 2]
        if model.floating_base():
            points = contact.collidable_point_positions(model, zero).numpy()
            if points.shape[-2]:
                height = height - points[..., 2].min(axis=-1)
        max_penetration = 0.01 * height
    max_penetration = np.asarray(max_penetration, dtype=np.float64)
    if not np.all(max_penetration > 0.0):
        raise ValueError(f"max_penetration must be positive, got {max_penetration}")
    p = 0.5
    K = np.clip(m * standard_gravity / nc / max_penetration ** (1.0 + p), 0.0, 1e6)
    D = np.clip(damping_ratio * 2.0 * np.sqrt(K * m), 0.0, 1e4)
    if num_envs is None:
        K, D = float(K), float(D)
    return SoftContactsParams(K=K, D=D, mu=static_friction_coefficient, p=p, q=0.5)
