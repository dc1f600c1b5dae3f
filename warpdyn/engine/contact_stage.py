"""The contact-model seam of a step: what a contact model contributes to an evaluation of the state derivative.

An evaluation runs the joint forces, the passive link forces, the contact forces, ABA; an integrator then
advances the state. A contact model (`model.contact_model`, warpdyn.types.contact_models) enters it through its
stage alone (`ContactStage`), chosen from the model's class when the step's plan is built (`stage_for`,
`STAGES`):
- `bundle`: the kernels' Contacts bundle, the enabled collidable points ordered by link (the geometry, the
  model's) and the law's parameters (shared (1,) or per environment (N,), read in place when Warp arrays);
- the host's refusal of a setting that is unstable for the scene (`__init__`: the soft law's dt K / D where the
  points can touch the terrain) and the values of the device check that every step runs again on the
  parameters as they are then (`check_rate`, `check_reach`: kernels/parameter_checks.py);
- `launches`: the launches that write, at a state, each enabled point's Inertial contact wrench W_f_C (N, P, 6),
  the rate m_dot (N, rows, 3) of the model's contact state (Model.contact_state_rows) (the data's `tangential_deformation_state`), and each
  link's W_f_L (N, nL, 6) = the other external forces + its points' wrenches;
- `point_law`: where the force at a point depends on that point alone, the kernels' per-point law
  (kernels/soft_contacts.py's `law_parameters` and `contact_at`), which the fused step
  (kernels/fused_step.py) calls where the staged kernels do; None: the fused step does not apply.
- `buffers`: what its launches need beside the evaluation's (per evaluation); `after_step`: launches that end a
  step (JaxSim's rigid impact); `has_state`: whether it has a contact state whose rate it writes (else m_dot is 0);
  `reads_other_forces`: whether its forces depend on the joint and link forces acting besides them (JaxSim's
  rigid models: their free accelerations).
ABA and the integrators read W_f_L and m_dot, nothing else of a contact model. JaxSim's rigid and relaxed-rigid
models (`RigidContactStage`, `RelaxedRigidContactStage`) solve an environment's contact forces together from its
mass matrix and the points' Jacobians (kernels/rigid_contacts.py), and the geom pairs' contacts (model.geom_contacts)
with them, each contact slot a point after the collidable points (docs/architecture.md: where a contact law goes).
"""

from __future__ import annotations

import functools
import warnings

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.aba import ABA_RECORD
from ..kernels.aba import kernels as aba_kernels
from ..kernels.bundles import bundles
from ..kernels.crba import CRBA_RECORD
from ..kernels.crba import kernels as crba_kernels
from ..kernels.implicit_contacts import kernels as implicit_kernels
from ..kernels.jacobian_derivatives import kernels as derivative_kernels
from ..kernels.jacobians import kernels as jacobian_kernels
from ..kernels.kinematics import kernels as kinematics_kernels
from ..kernels.rigid_contacts import PYRAMID_ROWS
from ..kernels.relaxed_rigid import kernels as relaxed_kernels
from ..kernels.rigid_contacts import kernels as rigid_kernels
from ..kernels.rigid_impact import kernels as impact_kernels
from ..kernels.scratch import TRANSFORM
from ..kernels.contact_points import kernels as point_kernels
from ..kernels.contact_slots import kernels as slot_kernels
from ..kernels.soft_contacts import kernels as contact_kernels
from ..kernels.velocities import kernels as velocity_kernels
from ..types.contact_models import RelaxedRigidContacts, RigidContacts, SoftContacts
from ..types.enums import VelRepr
from ..types.model_constants import transforms
from ..types.settings import host_values
from . import collisions, tape
from .bundles import controls_bundle, per_env, state_bundle
from .kinematics import link_targets, targets
from .launch import Launch, launch, no_adjoint
from .stability import DEFORMATION_STABILITY, ContactReach, check_deformation_stability, check_reference_stability, contact_reach

__all__ = ["point_frames", "ContactStage", "SoftContactStage", "RigidContactStage", "RelaxedRigidContactStage", "STAGES", "stage_for", "contacts_per_environment"]


ROUNDING_FLOOR = 100.0
"""The rigid QP's tolerance is at least this many times float64's machine epsilon (2.2e-14; the QP is solved in
float64 whatever the model's dtype): below it its residuals stagnate on rounding."""


def contacts_per_environment(device, grad: bool) -> bool:
    """Whether the step's contact kernels run a thread per environment (its points, then its links, in a
    loop) rather than a thread per point and per link: with gradients (each adjoint of a link's pose,
    velocity or per-environment parameter then comes from one thread, in a fixed order: deterministic on a
    GPU) and on the CPU (whose threads run one after another: a loop costs less than a thread per point)."""
    return grad or not wp.get_device(device).is_cuda


def point_frames(model, rows: np.ndarray) -> wp.array:
    """(P, len(rows)) transforms (L_p_C, identity) of the collidable points `rows` (indices among all the points) in
    each environment's row of the model's points (`Model.collidable_point_rows`): the kernels' Targets' poses."""
    points = model.collidable_point_rows()[:, rows]
    offsets = np.tile(np.eye(4), (*points.shape[:2], 1, 1))
    offsets[..., :3, 3] = points
    return transforms(offsets, model.scalar, model.device).reshape(points.shape[:2])


class ContactStage:
    """A contact model's part of a step (the module docstring). The collidable points' geometry is common to
    every model: the enabled points ordered by link (a link's points consecutive), their rows in the contact
    state, and each link's first point and count."""

    point_law = None
    has_state = True
    impact = False  # whether `after_step` replaces the step's new velocities in place (the rigid law's impact)
    reads_other_forces = False  # whether its forces depend on the joint and link forces acting besides them
    checked_on_device = False  # whether the step's device check (kernels/parameter_checks.py) reads its K, D and mu

    def __init__(self, model, integrator):
        s, d = model.scalar, model.device
        nL = model.number_of_links()
        cp = model.kin_dyn_structure().contact_parameters
        rows = cp.indices_of_enabled_collidable_points
        links = np.asarray(cp.body, dtype=np.int64)[rows]
        order = np.argsort(links, kind="stable")
        rows, links = rows[order], links[order]
        first = np.full(nL, -1, dtype=np.int32)
        for k in range(len(links) - 1, -1, -1):
            first[links[k]] = k
        row_point = np.full(len(cp.body), -1, dtype=np.int32)
        row_point[rows] = np.arange(len(rows), dtype=np.int32)
        self.points = len(cp.body)  # every collidable point: the contact state's first rows
        self.count = len(rows)  # the enabled points
        self.point_links = links.astype(np.int64)  # (count,) each enabled point's link, by link: the kernels' order
        self.points_per_link = np.bincount(links, minlength=nL).astype(np.int32)
        self.point_out = wp.array(order.astype(np.int32), dtype=int, device=d)  # place among the enabled points
        c = self.bundle = bundles(s).Contacts()
        c.point_link = wp.array(links.astype(np.int32), dtype=int, device=d)
        # a model whose points a kernel computed (warpdyn.model.update_hw_parameters) under a tape: the soft stage
        # gathers them at each evaluation (`launches`), so that gradients reach them
        grad_points = model.collidable_point_array is not None and model.collidable_point_array.requires_grad
        self.point_array = model.collidable_point_array if grad_points else None
        c.L_p_C = wp.array(model.collidable_point_rows()[:, rows], dtype=wp.types.vector(3, s), device=d, requires_grad=grad_points)  # (P, nc)
        c.point_row = wp.array(rows.astype(np.int32), dtype=int, device=d)
        c.row_point = wp.array(row_point, dtype=int, device=d)
        c.link_first_point = wp.array(first, dtype=int, device=d)
        c.link_point_count = wp.array(self.points_per_link, dtype=int, device=d)
        # the geom pairs whose contacts act (model.geom_contacts; warpdyn.engine.collisions)
        if model.geom_contacts and "collidable_points" in model.per_environment_parameters():
            raise ValueError("model.geom_contacts with shapes per environment (update_hw_parameters): the geom pairs' shapes are the "
                             "description's, one for all environments; scale the shapes shared, or switch geom_contacts off")
        self.pair_arrays = collisions.pair_arrays(model) if model.geom_contacts else None
        self.pairs = self.pair_arrays["pairs"] if model.geom_contacts else 0
        self.state_rows = model.contact_state_rows()  # the contact state's rows: the points', then the pairs' slots'

    def per_env_parameters(self) -> tuple:
        """((name, array), ...): the law's parameters that may have one value per environment."""
        return ()

    def buffers(self, plan, N: int, grad: bool = False) -> dict:
        """The launches' own buffers for N environments (none); grad: whether a tape differentiates through them."""
        return {}

    def launches(self, plan, ev, x, f_ext, tau, N: int) -> list:
        """The launches of the contact forces at the state x (the module docstring; ev's link poses at x; tau
        (N, n) the joint forces or None (zero))."""
        raise NotImplementedError(f"{type(self).__name__} computes no contact forces")

    def after_step(self, plan, ev, Y, N: int) -> list:
        """The launches that end a step at its new state Y (none)."""
        return []


class SoftContactStage(ContactStage):
    """JaxSim's soft contacts (Hunt/Crossley normal force, a tangential spring-damper with a deformation
    state, Coulomb's cone): a law at each point (kernels/soft_contacts.py), so the fused step applies."""

    point_law = staticmethod(contact_kernels)
    checked_on_device = True

    def __init__(self, model, integrator):
        super().__init__(model, integrator)
        s, d = model.scalar, model.device
        c = model.contact_params
        self.bundle.K, self.bundle.D, self.bundle.mu = (per_env(getattr(c, k), k, s, d) for k in ("K", "D", "mu"))
        self.bundle.p, self.bundle.q = s(c.p), s(c.q)
        self.bundle.implicit = int(bool(model.implicit_contacts))  # the Coulomb limit of a linearly implicit step (kernels/soft_contacts.py)
        # the deformation's stability where the points can touch the terrain (contact_reach); the device check
        # of every step (kernels/parameter_checks.py) asks it again of values written in place
        reach = contact_reach(model) if self.count > 0 else ContactReach(0.0, False, "")
        if reach.may_touch or self.pairs:  # the geom pairs' contacts carry the deformation too
            check_deformation_stability(model.time_step, c.K, c.D, integrator, reach.why if reach.may_touch else "the geom pairs' contacts: model.geom_contacts")
        self.check_rate = s(DEFORMATION_STABILITY[integrator] / model.time_step)
        # the device check everywhere (-1) where the pairs' contacts carry the deformation: they touch off the terrain
        self.check_reach = s(reach.reach if np.isfinite(reach.reach) and not self.pairs else -1.0)

    def per_env_parameters(self) -> tuple:
        c = self.bundle
        return (("SoftContactsParams.K", c.K), ("SoftContactsParams.D", c.D), ("SoftContactsParams.mu", c.mu))

    def buffers(self, plan, N: int, grad: bool = False) -> dict:
        """The geom pairs' contacts (count, position, frame, dist: warpdyn.engine.collisions) where they act."""
        return collisions.contact_buffers(self.pair_arrays, N, grad) if self.pairs else {}

    def launches(self, plan, ev, x, f_ext, tau, N: int) -> list:
        """Link velocities, each enabled point's force and deformation rate (ev.W_f_C, ev.m_dot), and ev.W_f_L =
        f_ext (None: 0) + each link's; then, where geom contacts act, those of the geom pairs added to ev.W_f_L."""
        s = plan.scalar
        args = [plan.model, plan.no_targets, ev.W_H_L, x, int(VelRepr.Inertial)]
        launches = [Launch(velocity_kernels(s, plan.multi_dof).link_velocities, N, args, [ev.W_v_WL, ev.target_velocities])]
        if self.point_array is not None and self.count:
            launches.append(Launch(point_kernels(s).gather_points, self.bundle.L_p_C.shape, [self.bundle.point_row, self.point_array], [self.bundle.L_p_C]))
        f_in = f_ext if f_ext is not None else plan.zeros((plan.nL, 6), N)
        order = int(arrays.env_fastest(plan.device))
        rows, links = (self.points, plan.nL) if contacts_per_environment(plan.device, ev.grad) else (1, 1)
        args = [self.bundle, plan.terrain, ev.W_H_L, ev.W_v_WL, x.tangential_deformation, order, rows]
        launches.append(Launch(contact_kernels(s, plan.terrain.kind).point_contact_forces, N * self.points // rows, args, [ev.W_f_C, ev.m_dot]))
        args = [self.bundle, ev.W_f_C, f_in, order, links]
        launches.append(Launch(contact_kernels(s).link_contact_forces, N * plan.nL // links, args, [ev.W_f_L]))
        if ev.implicit is not None:  # the contacts' linearly implicit terms for the step's ABA (model.implicit_contacts)
            args = [self.bundle, plan.terrain, ev.W_H_L, ev.W_v_WL, x.tangential_deformation, plan.dt, order, links]
            launches.append(Launch(implicit_kernels(s, plan.terrain.kind).point_implicit_terms, N * plan.nL // links, args, [ev.implicit]))
        if self.pairs:
            # a step's evaluation flags an explicit damper's instability (an implicit one has none); a query's reports
            check = (self.check_rate, plan.model) if ev.checks and ev.implicit is None else None
            args = (self.pair_arrays, self.bundle, ev.W_H_L, ev.W_v_WL, x.tangential_deformation, ev.contact, ev.W_f_L, ev.m_dot, N)
            launches += collisions.force_launches(*args, check, (plan.dt, ev.implicit), per_environment=links > 1)
        return launches


class RigidContactStage(ContactStage):
    """JaxSim's rigid contacts (kernels/rigid_contacts.py's `rigid_rows`, `rigid_solve`, `point_wrenches`, and
    kernels/rigid_impact.py's impact after each step): the forces of an environment's points solved together, from
    ABA's accelerations without them, the mass matrix and the points' Jacobians and J̇ν at the state;
    differentiable (the solve's and the impact's adjoints registered by hand). mu, K, D: shared (1,) or per
    environment (N,). With model.geom_contacts the pairs' contact slots are the solve's points count + slot
    (`slot_launches`; their mu the pair's), at the evaluation's state and, for the impact, at the step's new state;
    their wrenches are added to both links after the points' (kernels/contact_slots.py's `slot_wrenches`); the solve
    holds `max_active` penetrating contacts (max_active_contacts; None: all)."""

    has_state = False
    reads_other_forces = True
    impact = True  # `after_step` launches the impact (and `buffers` holds its inputs at the step's new state)

    def __init__(self, model, integrator):
        super().__init__(model, integrator)
        self.slots = self.pair_arrays["contacts"] if self.pairs else 0  # the pairs' contact slots, solved after the points
        limit = getattr(model.contact_model, "max_active_contacts", None)
        self.max_active = self.count + self.slots if limit is None else min(limit, self.count + self.slots)  # the solve's rows / 3
        s, d = model.scalar, model.device
        c, contact_model = model.contact_params, model.contact_model
        K = rigid_kernels(s)
        self.kernels = K
        self.owner = type(c).__name__
        self.bundle.mu = per_env(c.mu, "mu", s, d, self.owner)
        self.bundle.K, self.bundle.D = self.baumgarte(c, s, d)
        self.bundle.p, self.bundle.q = s(0.5), s(0.5)
        law = self.law = K.RigidLaw()
        self.fill_law(law, c, contact_model, s)
        # the enabled points, in the stage's order, as targets of the Jacobian kernels
        params = model.kin_dyn_structure().contact_parameters
        rows = params.indices_of_enabled_collidable_points
        order = np.argsort(np.asarray(params.body, dtype=np.int64)[rows], kind="stable")
        self.targets = targets(model, self.bundle.point_link, point_frames(model, rows[order]))
        multi = model.multi_dof()
        self.bias = derivative_kernels(s, multi)
        self.jacobians = jacobian_kernels(s, multi).jacobians
        self.crba = crba_kernels(s, "tuned", multi).crba
        self.aba = aba_kernels(s, "tuned", multi).aba
        self.fk = kinematics_kernels(s, multi).forward_kinematics
        self.link_targets = link_targets(model) if self.pairs else None
        self.check_rate, self.check_reach = s(0.0), s(-1.0)  # the device check's soft-law terms do not apply
        reach = contact_reach(model) if self.count > 0 else ContactReach(0.0, False, "")
        if reach.may_touch or self.pairs:
            self.check_stability(model, c, integrator, reach.why if reach.may_touch else "the geom pairs' contacts: model.geom_contacts")
            self.warn_dtype(model)

    @staticmethod
    def warn_dtype(model) -> None:
        """A UserWarning for a float32 model: JaxSim's rigid law stops every penetrating point at each step, and
        float32's rounding of the points' positions and Jacobians decides which points those are: the benchmark's
        landings tipped over at some time steps in float32, never in float64."""
        if model.scalar == wp.float32:
            warnings.warn(
                f"model '{model.name()}': RigidContacts in float32 decide on float32 rounding which points are stopped at each step; "
                "in benchmarks/speed_accuracy.py's landings of the ergoCub legs some tipped over at 0.2 and 2 ms (RK4) in float32 and "
                "none in float64: build the model with dtype=np.float64 for rigid contacts",
                UserWarning,
                stacklevel=2,
            )

    @staticmethod
    def check_stability(model, c, integrator, why: str) -> None:
        """Refuse a time step at which Baumgarte's terms (K, D; their largest values over the environments) are
        unstable (warpdyn.engine.stability's `check_reference_stability`)."""
        K, D = (float(np.max(host_values(getattr(c, name), f"RigidContactsParams.{name}"))) for name in ("K", "D"))
        what = f"RigidContactsParams K = {K:g}, D = {D:g}"
        check_reference_stability(model.time_step, K, D, integrator, what, "smaller K and D (Baumgarte's terms)", why)

    @staticmethod
    def baumgarte(c, s, d) -> tuple:
        return per_env(c.K, "K", s, d, "RigidContactsParams"), per_env(c.D, "D", s, d, "RigidContactsParams")

    @staticmethod
    def fill_law(law, c, contact_model, s) -> None:
        """The rigid QP's options in the RigidLaw bundle (the impedance's fields unused)."""
        for name in ("time_constant", "damping_coefficient", "d_min", "d_max", "width", "midpoint", "power"):
            setattr(law, name, s(0.0))
        options = contact_model.solver_options
        law.eps = s(contact_model.regularization_delassus)
        law.tol = s(max(options["solver_tol"], ROUNDING_FLOOR * float(np.finfo(np.float64).eps)))
        law.iterations = int(options["max_iterations"])

    def per_env_parameters(self) -> tuple:
        c = self.bundle
        return ((f"{self.owner}.mu", c.mu), (f"{self.owner}.K", c.K), (f"{self.owner}.D", c.D))

    def buffers(self, plan, N: int, grad: bool = False) -> dict:
        """The kernels' inputs and scratch for N environments; grad: the law's inputs (a_free, J_t, J̇ν, M and what
        they are computed from) carry gradients (the float64 scratch never does)."""
        s, d = plan.scalar, plan.device
        K, P, nL = 6 + plan.n, self.count + self.slots, plan.nL
        m = 3 * self.max_active
        width = max(m, 6 + plan.n)
        vec6 = wp.types.vector(6, s)
        transform = wp.types.transformation(s)

        def empty(shape, dtype=s, differentiable=False):
            return arrays.empty(shape, N, dtype, d, grad and differentiable)

        out = {
            "a_free": empty((K,), differentiable=True),
            "no_joints": empty((0,), differentiable=True),
            "W_a_L": empty((nL,), vec6, differentiable=True),
            "J_t": empty((P, 6, K), differentiable=True),
            "Jdotnu_t": empty((P, 6), differentiable=True),
            "M": empty((K, K), differentiable=True),
            "crba_scratch": empty((max(nL, plan.n + 1), CRBA_RECORD), differentiable=True),
            "aba_scratch": empty((plan.rows, ABA_RECORD + TRANSFORM), differentiable=True),
            "active": empty((P,), wp.int32),
            "J": empty((m, K), wp.float64),
            "MinvJT": empty((m, K), wp.float64),
            "M64": empty((K, K), wp.float64),
            "Lm": empty((K, K), wp.float64),
        }
        out["scratch"] = self.scratch(empty, m, width)
        out.update(self.law_buffers(plan, empty, P))
        if self.slots:  # the pairs' contacts and the links' Inertial Jacobians, from which their slots' rows are made
            out.update(collisions.contact_buffers(self.pair_arrays, N, grad))
            out["J_L"] = empty((nL, 6, K), differentiable=True)
        if self.impact:  # the impact's own inputs at the step's new state, named as the evaluation's (a tape's adjoints read those)
            after = {"W_H_L": empty((nL,), transform, True), "parent_H_link": empty((nL,), transform, True), "W_v_WL": empty((nL,), vec6, True)}
            after.update(W_a_L=empty((nL,), vec6, True), J_t=empty((P, 6, K), differentiable=True), M=empty((K, K), differentiable=True))
            after["crba_scratch"] = empty((max(nL, plan.n + 1), CRBA_RECORD), differentiable=True)
            after.update({name: array for name, array in self.law_buffers(plan, empty, P).items() if name != "force"})  # the rows', not the forces
            if self.slots:
                after.update(collisions.contact_buffers(self.pair_arrays, N, grad))
                after.update(J_L=empty((nL, 6, K), differentiable=True), Jdotnu_t=empty((P, 6), differentiable=True))
            out["after"] = after
            out["nu_before"] = empty((K,), wp.float64)
        return out

    law_outputs = ("beta", "friction")  # the rows kernel's differentiable outputs, which the solve reads

    def law_buffers(self, plan, empty, P: int) -> dict:
        """Each point's depth (N, P), the rows' terms (`law_outputs`: Baumgarte's beta (N, P, 3), mu (N, P)) and the
        forces (N, P, 3), differentiable where grad is (P: the points, then the geom pairs' slots)."""
        vec3 = wp.types.vector(3, plan.scalar)
        return {"depth": empty((P,)), "beta": empty((P,), vec3, True), "friction": empty((P,), plan.scalar, True), "force": empty((P,), vec3, True)}

    def law_kernels(self, plan):
        """The (rows, solve, solve's adjoint) kernels, the rows kernel's inputs before the link poses and velocities
        and the solve's before the rows' inputs."""
        K = self.kernels
        return K.rigid_rows, K.rigid_solve, K.rigid_solve_adjoint, [self.bundle, plan.terrain], [plan.model, self.law]

    def law_launches(self, plan, ev, N: int) -> list:
        """The rows (a tape records them: Warp differentiates them), the solve (its adjoint written by hand, registered
        where ev.grad; run unrecorded otherwise) and the points' wrenches ev.W_f_C (recorded)."""
        b = ev.contact
        rows, solve, solve_adjoint, head, solve_head = self.law_kernels(plan)
        outputs = [b["depth"], *(b[name] for name in self.law_outputs)]
        args = [*solve_head, b["J_t"], b["Jdotnu_t"], b["M"], b["a_free"], *outputs]
        args += [b["active"], b["J"], b["MinvJT"], b["M64"], b["Lm"], *b["scratch"]]
        if ev.grad:
            grads = [b[name].grad for name in ("force", "J_t", "Jdotnu_t", "M", "a_free", *self.law_outputs)]
            adjoint = functools.partial(launch, solve_adjoint, N, [*args, *grads], [], device=plan.device, record_tape=False)
        else:
            adjoint = no_adjoint
        return [
            Launch(rows, N, [*head, ev.W_H_L, ev.W_v_WL], outputs),
            *self.slot_launches(plan, b, ev.W_H_L, ev.W_v_WL, N),
            Launch(solve, N, args, [b["force"]], adjoint=adjoint),
            Launch(self.kernels.point_wrenches, N, [self.bundle, ev.W_H_L, b["force"]], [ev.W_f_C]),
        ]

    def slot_kernel(self, plan) -> tuple:
        """The kernel of the slots' rows and its inputs before the pairs' arrays (kernels/contact_slots.py's
        `rigid_slot_rows`: Baumgarte's terms and the pair's mu)."""
        return slot_kernels(plan.scalar).rigid_slot_rows, [self.bundle]

    def slot_launches(self, plan, b: dict, W_H_L, W_v_WL, N: int) -> list:
        """The geom pairs' contacts at the link poses W_H_L (N, nL) into b's count, position, frame and dist, the links'
        Inertial Jacobians b["J_L"], and the contact slots as the solve's points count + slot: their rows, J̇ν (from the
        Inertial velocities W_v_WL and b["W_a_L"]), depth and `law_outputs` into b's (`slot_kernel`); none without pairs."""
        if not self.slots:
            return []
        a, inertial = self.pair_arrays, int(VelRepr.Inertial)
        kernel, head = self.slot_kernel(plan)
        inputs = [*head, a["link1"], a["link2"], a["mu"], a["first"], a["slot_pair"], b["count"], b["position"], b["frame"], b["dist"]]
        inputs += [b["J_L"], W_v_WL, b["W_a_L"], self.count]
        return [
            collisions.contact_launch(a, W_H_L, b, N),
            Launch(self.jacobians, (N, plan.nL), [plan.model, self.link_targets, W_H_L, inertial, inertial], [b["J_L"]]),
            Launch(kernel, N, inputs, [b["J_t"], b["Jdotnu_t"], b["depth"], *(b[name] for name in self.law_outputs)]),
        ]

    def scratch(self, empty, m: int, width: int) -> list:
        """The QP's float64 scratch for m rows (m / 3 points): Q, H, LH (m x m); q, x, rd, dx, y, w (width); s, z, rp,
        rc, ds, dz, ds_aff, dz_aff (5 m / 3); mu (m / 3)."""
        rows, f64 = PYRAMID_ROWS * (m // 3), wp.float64
        vectors = [empty((width,), f64) for _ in range(6)] + [empty((rows,), f64) for _ in range(8)]
        return [empty((m, m), f64) for _ in range(3)] + vectors + [empty((m // 3,), f64)]

    def launches(self, plan, ev, x, f_ext, tau, N: int) -> list:
        """At x: the link velocities and bias terms, the points' Jacobians and J̇ν, the mass matrix, ABA's
        accelerations a_free at tau and f_ext (their own ABA: explicit, MuJoCo's implicit damping aside), the points'
        forces ev.W_f_C and ev.W_f_L = f_ext (None: 0) + each link's contact wrench (what ABA reads; a contact query takes
        f_ext back out: warpdyn.engine.contact's `link_wrenches_and_rates`)."""
        self.refuse_gradients(ev)
        s, b = plan.scalar, ev.contact
        inertial, mixed = int(VelRepr.Inertial), int(VelRepr.Mixed)
        f_in = f_ext if f_ext is not None else plan.zeros((plan.nL, 6), N)
        controls = controls_bundle(s, plan.device, tau if plan.n > 0 and tau is not None else None, f_in)
        launches = [
            Launch(self.bias.link_bias_recursion, N, [plan.model, ev.W_H_L, x], [ev.W_v_WL, b["W_a_L"]]),
            Launch(self.jacobians, (N, self.count), [plan.model, self.targets, ev.W_H_L, inertial, mixed], [b["J_t"]]),
            Launch(self.bias.bias_accelerations, (N, self.count), [self.targets, ev.W_H_L, ev.W_v_WL, b["W_a_L"], inertial, mixed], [b["Jdotnu_t"]]),
            Launch(self.crba, N, [plan.model, x, inertial, b["crba_scratch"]], [b["M"]]),
            Launch(self.aba, N, [plan.model, x, controls, inertial, s(0.0), b["aba_scratch"]], [b["a_free"][:, :6], b["a_free"][:, 6:] if plan.n > 0 else b["no_joints"]]),
        ]
        launches += self.law_launches(plan, ev, N)
        order = int(arrays.env_fastest(plan.device))
        links = plan.nL if contacts_per_environment(plan.device, ev.grad) else 1
        launches.append(Launch(contact_kernels(s).link_contact_forces, N * plan.nL // links, [self.bundle, ev.W_f_C, f_in, order, links], [ev.W_f_L]))
        if self.slots:
            a = self.pair_arrays
            args = [a["link1"], a["link2"], a["slot_pair"], b["position"], b["frame"], b["force"], self.count]
            launches.append(Launch(slot_kernels(s).slot_wrenches, N, args, [ev.W_f_L]))
        return launches

    def refuse_gradients(self, ev) -> None:
        """A NotImplementedError where gradients would miss a dependence: collidable points computed under a tape
        (warpdyn.model.update_hw_parameters) move the Jacobians' targets, which this stage builds once."""
        if (ev.grad or tape.taping()) and self.point_array is not None:
            raise NotImplementedError(
                f"{self.owner.removesuffix('Params')} with collidable points that require gradients (update_hw_parameters under a tape): the "
                "points' Jacobians are built from the model's points once; use SoftContacts for gradients through the points"
            )

    def after_step(self, plan, ev, Y, N: int) -> list:
        """JaxSim's impact at the step's new state Y: its velocities replaced in place (kernels/rigid_impact.py), from
        the poses, the points' and the geom pairs' slots' depths and rows and the mass matrix at Y, in the impact's own
        buffers (ev.contact["after"]); its adjoint registered by hand where ev.grad."""
        b, K = ev.contact, impact_kernels(plan.scalar)
        at = b["after"]
        inertial, mixed = int(VelRepr.Inertial), int(VelRepr.Mixed)
        scratch = b["scratch"]
        args = [plan.model, at["depth"], at["J_t"], at["M"], b["active"], b["J"], b["MinvJT"]]
        args += [b["M64"], b["Lm"], scratch[0], scratch[2], *scratch[5:9], b["nu_before"]]
        adjoint = no_adjoint
        if ev.grad:
            fields = (Y.base_position, Y.base_quaternion, Y.joint_positions, Y.base_velocity, Y.joint_velocities)
            adj_state = state_bundle(plan.scalar, [a.grad for a in fields] + [None, None])
            grads = [adj_state, at["J_t"].grad, at["M"].grad]
            adjoint = functools.partial(launch, K.impact_adjoint, N, [*args, Y, scratch[3], scratch[4], *grads], [], device=plan.device, record_tape=False)
        return [
            Launch(self.fk, N, [plan.model, Y], [at["parent_H_link"], at["W_H_L"]]),
            Launch(self.bias.link_bias_recursion, N, [plan.model, at["W_H_L"], Y], [at["W_v_WL"], at["W_a_L"]]),
            Launch(self.jacobians, (N, self.count), [plan.model, self.targets, at["W_H_L"], inertial, mixed], [at["J_t"]]),
            Launch(self.kernels.rigid_rows, N, [self.bundle, plan.terrain, at["W_H_L"], at["W_v_WL"]], [at["depth"], at["beta"], at["friction"]]),
            *self.slot_launches(plan, at, at["W_H_L"], at["W_v_WL"], N),
            Launch(self.crba, N, [plan.model, Y, inertial, at["crba_scratch"]], [at["M"]]),
            Launch(K.impact_velocities, N, args, [Y], adjoint=adjoint),
        ]


class RelaxedRigidContactStage(RigidContactStage):
    """JaxSim's relaxed-rigid contacts (kernels/relaxed_rigid.py's `relaxed_rigid_rows`, `relaxed_rigid_solve`,
    `point_wrenches`): a linear solve, no impact; differentiable (the solve's adjoint registered by hand). mu:
    shared (1,) or per environment (N,); the impedance's parameters: one number each. The geom pairs' contacts as
    the rigid stage's, their slots' a_ref and R from the pair's mu and the bodies' reduced mass."""

    has_state = False
    impact = False

    law_outputs = ("a_ref", "R")

    def law_buffers(self, plan, empty, P: int) -> dict:
        """Each point's depth (N, P) and its rows' a_ref, R and force (N, P, 3), differentiable where grad is."""
        vec3 = wp.types.vector(3, plan.scalar)
        return {"depth": empty((P,)), **{name: empty((P,), vec3, True) for name in ("a_ref", "R", "force")}}

    def slot_kernel(self, plan) -> tuple:
        """kernels/relaxed_rigid.py's `relaxed_slot_rows` (the slots' a_ref and R)."""
        return relaxed_kernels(plan.scalar).relaxed_slot_rows, [plan.model, self.law]

    def law_kernels(self, plan):
        K = relaxed_kernels(plan.scalar)
        return K.relaxed_rigid_rows, K.relaxed_rigid_solve, K.relaxed_rigid_solve_adjoint, [plan.model, self.bundle, self.law, plan.terrain], [plan.model]

    @staticmethod
    def baumgarte(c, s, d) -> tuple:
        zero = wp.zeros(1, dtype=s, device=d)  # JaxSim's relaxed-rigid law reads no K and D
        return zero, zero

    @staticmethod
    def fill_law(law, c, contact_model, s) -> None:
        for name in ("time_constant", "damping_coefficient", "d_min", "d_max", "width", "midpoint", "power"):
            setattr(law, name, s(float(getattr(c, name))))
        law.eps, law.tol, law.iterations = s(0.0), s(0.0), 0

    def per_env_parameters(self) -> tuple:
        return ((f"{self.owner}.mu", self.bundle.mu),)

    @staticmethod
    def warn_dtype(model) -> None:
        """No warning: the relaxed-rigid landings in float32 and float64 are as far from the reference."""

    @staticmethod
    def check_stability(model, c, integrator, why: str) -> None:
        """Refuse a time step at which the reference acceleration a_ref (its stiffness 1 / (d_max tau zeta)^2 times
        the deepest impedance d_max, its damping 2 / (d_max tau)) is unstable: JaxSim's relaxed-rigid law, whose
        regularisation R only softens it, tends to it where R is small (its default)."""
        tau, zeta, d_max = float(c.time_constant), float(c.damping_coefficient), float(c.d_max)
        K, D = d_max / (d_max * tau * zeta) ** 2, 2.0 / (d_max * tau)
        what = f"RelaxedRigidContactsParams time_constant = {tau:g} s, damping_coefficient = {zeta:g}, d_max = {d_max:g}"
        check_reference_stability(model.time_step, K, D, integrator, what, "a larger time_constant (MuJoCo's rule: time constant >= 2 time steps)", why)

    def scratch(self, empty, m: int, width: int) -> list:
        """The solve's float64 scratch: A, LA (m x m); b, f, y, w (width)."""
        f64 = wp.float64
        return [empty((m, m), f64) for _ in range(2)] + [empty((width,), f64) for _ in range(4)]

    def after_step(self, plan, ev, Y, N: int) -> list:
        return []


STAGES: dict[type, type] = {SoftContacts: SoftContactStage, RigidContacts: RigidContactStage, RelaxedRigidContacts: RelaxedRigidContactStage}
"""The stage of each contact model class (`model.contact_model`'s type)."""


def stage_for(model, integrator) -> ContactStage:
    """The stage of `model.contact_model`: its class's in `STAGES`, or the nearest base class's (a ValueError
    naming the class when none has one)."""
    kind = type(model.contact_model)
    stage = next((STAGES[k] for k in kind.__mro__ if k in STAGES), None)
    if stage is None:
        known = ", ".join(sorted(k.__name__ for k in STAGES))
        raise ValueError(f"model.contact_model is a {kind.__name__}, which warpdyn's step does not simulate (it simulates {known})")
    if not isinstance(model.contact_params, model.contact_model.parameters_class):
        raise ValueError(
            f"model.contact_params is a {type(model.contact_params).__name__}, but model.contact_model ({kind.__name__}) takes "
            f"{model.contact_model.parameters_class.__name__}"
        )
    return stage(model, integrator)
