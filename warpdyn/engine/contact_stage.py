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
  the rate m_dot (N, nc, 3) of the model's contact state (the data's `tangential_deformation_state`), and each
  link's W_f_L (N, nL, 6) = the other external forces + its points' wrenches;
- `point_law`: where the force at a point depends on that point alone, the kernels' per-point law
  (kernels/soft_contacts.py's `law_parameters` and `contact_at`), which the fused step
  (kernels/fused_step.py) calls where the staged kernels do; None: the fused step does not apply.
ABA and the integrators read W_f_L and m_dot, nothing else of a contact model. JaxSim's rigid and relaxed-rigid
models, which solve for an environment's contact forces together from its mass matrix and the points'
Jacobians, and contacts between bodies are further stages (docs/architecture.md: where a contact law goes).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.bundles import bundles
from ..kernels.soft_contacts import kernels as contact_kernels
from ..kernels.velocities import kernels as velocity_kernels
from ..types.contact_models import SoftContacts
from ..types.enums import VelRepr
from .bundles import per_env
from .launch import Launch
from .stability import DEFORMATION_STABILITY, ContactReach, check_deformation_stability, contact_reach

__all__ = ["ContactStage", "SoftContactStage", "STAGES", "stage_for", "contacts_per_environment"]


def contacts_per_environment(device, grad: bool) -> bool:
    """Whether the step's contact kernels run a thread per environment (its points, then its links, in a
    loop) rather than a thread per point and per link: with gradients (each adjoint of a link's pose,
    velocity or per-environment parameter then comes from one thread, in a fixed order: deterministic on a
    GPU) and on the CPU (whose threads run one after another: a loop costs less than a thread per point)."""
    return grad or not wp.get_device(device).is_cuda


class ContactStage:
    """A contact model's part of a step (the module docstring). The collidable points' geometry is common to
    every model: the enabled points ordered by link (a link's points consecutive), their rows in the contact
    state, and each link's first point and count."""

    point_law = None

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
        self.total = len(cp.body)  # the contact state's rows: every collidable point
        self.count = len(rows)  # the enabled points
        self.points_per_link = np.bincount(links, minlength=nL).astype(np.int32)
        self.point_out = wp.array(order.astype(np.int32), dtype=int, device=d)  # place among the enabled points
        c = self.bundle = bundles(s).Contacts()
        c.point_link = wp.array(links.astype(np.int32), dtype=int, device=d)
        c.L_p_C = wp.array(np.asarray(cp.point, dtype=np.float64)[rows].reshape(-1, 3), dtype=wp.types.vector(3, s), device=d)
        c.point_row = wp.array(rows.astype(np.int32), dtype=int, device=d)
        c.row_point = wp.array(row_point, dtype=int, device=d)
        c.link_first_point = wp.array(first, dtype=int, device=d)
        c.link_point_count = wp.array(self.points_per_link, dtype=int, device=d)

    def per_env_parameters(self) -> tuple:
        """((name, array), ...): the law's parameters that may have one value per environment."""
        return ()

    def launches(self, plan, ev, x, f_ext, N: int) -> list:
        """The launches of the contact forces at the state x (the module docstring; ev's link poses at x)."""
        raise NotImplementedError(f"{type(self).__name__} computes no contact forces")


class SoftContactStage(ContactStage):
    """JaxSim's soft contacts (Hunt/Crossley normal force, a tangential spring-damper with a deformation
    state, Coulomb's cone): a law at each point (kernels/soft_contacts.py), so the fused step applies."""

    point_law = staticmethod(contact_kernels)

    def __init__(self, model, integrator):
        super().__init__(model, integrator)
        s, d = model.scalar, model.device
        c = model.contact_params
        self.bundle.K, self.bundle.D, self.bundle.mu = (per_env(getattr(c, k), k, s, d) for k in ("K", "D", "mu"))
        self.bundle.p, self.bundle.q = s(c.p), s(c.q)
        # the deformation's stability where the points can touch the terrain (contact_reach); the device check
        # of every step (kernels/parameter_checks.py) asks it again of values written in place
        reach = contact_reach(model) if self.count > 0 else ContactReach(0.0, False, "")
        if reach.may_touch:
            check_deformation_stability(model.time_step, c.K, c.D, integrator, reach.why)
        self.check_rate = s(DEFORMATION_STABILITY[integrator] / model.time_step)
        self.check_reach = s(reach.reach if np.isfinite(reach.reach) else -1.0)

    def per_env_parameters(self) -> tuple:
        c = self.bundle
        return (("SoftContactsParams.K", c.K), ("SoftContactsParams.D", c.D), ("SoftContactsParams.mu", c.mu))

    def launches(self, plan, ev, x, f_ext, N: int) -> list:
        """Link velocities, each enabled point's force and deformation rate (ev.W_f_C, ev.m_dot), and ev.W_f_L =
        f_ext (None: 0) + each link's."""
        s = plan.scalar
        args = [plan.model, plan.no_targets, ev.W_H_L, x, int(VelRepr.Inertial)]
        launches = [Launch(velocity_kernels(s, plan.multi_dof).link_velocities, N, args, [ev.W_v_WL, ev.target_velocities])]
        f_in = f_ext if f_ext is not None else plan.zeros((plan.nL, 6), N)
        order = int(arrays.env_fastest(plan.device))
        rows, links = (self.total, plan.nL) if contacts_per_environment(plan.device, ev.grad) else (1, 1)
        args = [self.bundle, plan.terrain, ev.W_H_L, ev.W_v_WL, x.tangential_deformation, order, rows]
        launches.append(Launch(contact_kernels(s, plan.terrain.kind).point_contact_forces, N * self.total // rows, args, [ev.W_f_C, ev.m_dot]))
        args = [self.bundle, ev.W_f_C, f_in, order, links]
        launches.append(Launch(contact_kernels(s).link_contact_forces, N * plan.nL // links, args, [ev.W_f_L]))
        return launches


STAGES: dict[type, type] = {SoftContacts: SoftContactStage}
"""The stage of each contact model class (`model.contact_model`'s type)."""


def stage_for(model, integrator) -> ContactStage:
    """The stage of `model.contact_model`: its class's in `STAGES`, or the nearest base class's (a ValueError
    naming the class when none has one)."""
    kind = type(model.contact_model)
    stage = next((STAGES[k] for k in kind.__mro__ if k in STAGES), None)
    if stage is None:
        known = ", ".join(sorted(k.__name__ for k in STAGES))
        raise ValueError(f"model.contact_model is a {kind.__name__}, which warpdyn's step does not simulate (it simulates {known})")
    return stage(model, integrator)
