"""Equality constraints in a step: MJCF connects, welds, and joint and fixed-tendon couplings (warpdyn.description.tree's
TreeEquality), and with `model.limit_constraints` and `model.frictionloss_constraints` the joints' limits and friction
constraints (an MJCF's, a URDF's or an SDF's), solved as MuJoCo solves them, and JaxSim's kinematic constraints (the
model's ConstraintMap: frame welds), solved as JaxSim solves them (kernels/equality.py). After an evaluation's ABA
(its accelerations a0', Inertial base) at a state x, with the link poses of its FK, the launches compute the mass
matrix (Inertial base), for connects and welds the links' velocities and bias terms and their anchors' Jacobians and
J̇ν (Mixed, ν Inertial), and the constrained accelerations into the evaluation's nu_dot. With the model setting
`equality_projection`, `after_step` ends the step with the post-stabilisation (kernels/equality.py's
`equality_projection`; SoftContacts only). Differentiable (kernels/equality_solve.py: the rows recorded, the
solve's adjoint registered by hand) but for what `check_steppable` refuses under a tape.
"""

from __future__ import annotations

import functools

import numpy as np
import warp as wp

from .. import arrays
from ..kernels.crba import CRBA_RECORD
from ..kernels.crba import kernels as crba_kernels
from ..kernels.equality import CONNECT, COUPLING, FRAME_WELD, FRICTION, LIMIT, ROWS, WELD
from ..kernels.equality import kernels as equality_kernels
from ..kernels.equality import projection_kernels
from ..kernels.equality_solve import kernels as solve_kernels
from ..kernels.jacobian_derivatives import kernels as derivative_kernels
from ..kernels.jacobians import kernels as jacobian_kernels
from ..kernels.kinematics import kernels as kinematics_kernels
from ..types.contact_models import SoftContacts
from ..types.enums import VelRepr
from ..types.model_constants import transforms
from .bundles import model_bundle, state_bundle
from .kinematics import targets
from .launch import Launch, launch, no_adjoint

__all__ = ["EqualityPlan", "equalities", "equality_plan", "check_steppable"]

PROJECTION_DAMPING = {wp.float64: 1.0e-10, wp.float32: 1.0e-5}
"""Per dtype, the projection's Levenberg-Marquardt damping, times the largest diagonal entry of J M^-1 J^T: above the
rounding of a pivot whose row depends on the others (about 1e-16 of the diagonal in float64, 1e-7 in float32), far
below the pivots of independent rows. Measured: Cassie's four connects, solved with dependent rows dropped at a
pivot of 1e-10, drifted its base by 3 mm in 0.25 s of free fall (near-dependent rows amplified rounding); damped,
not at all; a ball on two connects in float32 parted by 5e-6 m with 1e-10, by 2.9e-7 m (its rounding) with 1e-5."""


class EqualityPlan:
    """A model's equality constraints as the kernels read them: the Equalities bundle, the anchors of connects and
    welds as Targets (two each: anchor 1, anchor 2; a world anchor on link 0, unread), m rows; refsafe: MuJoCo's
    time constant raised to 2 dt (unless the description disables "refsafe")."""

    def __init__(self, model):
        s, d = model.scalar, model.device
        tree = model.tree
        E = equalities(model)
        self.count, self.model_name = len(E), model.name()
        self.projection_passes = model.equality_projection  # the post-stabilisation's position passes after each step (0: none)
        if self.projection_passes and not isinstance(model.contact_model, SoftContacts):
            raise NotImplementedError(
                f"model.equality_projection with {type(model.contact_model).__name__} on '{model.name()}': the projection would "
                "undo the solved contacts' velocities (the rigid impact) and push their points into the ground; use SoftContacts"
            )
        self.refsafe = int("refsafe" not in model.description.disabled)  # MuJoCo's timeconst >= 2 dt unless disabled
        # what the solve's adjoint leaves out with MuJoCo's implicit damping: gradients of the damping (`check_steppable`)
        self.dampings = (model.parameter("damping"), model.parameter("base_damping"))
        # and with friction rows those of their bounds, the joints' friction_static (a saturated row's force)
        self.friction_bounds = model.parameter("friction_static") if any(e.kind == "friction" for e in E) else None
        if self.friction_bounds is not None:
            _check_friction_rows(model, E)
        _check_limit_ranges(model, E)
        _check_invweights(model, E)
        kinds = [{"connect": CONNECT, "weld": WELD, "frame_weld": FRAME_WELD, "joint": COUPLING, "tendon": COUPLING, "limit": LIMIT, "friction": FRICTION}[e.kind] for e in E]
        rows = np.cumsum([0] + [ROWS[int(k)] for k in kinds])
        self.rows = int(rows[-1])
        anchored = [e for e in E if e.kind in ("connect", "weld", "frame_weld")]  # two anchors each
        target_of, t = [], 0
        for kind in kinds:
            target_of.append(t)
            t += 0 if kind == COUPLING else 2
        links = [max(link, 0) for e in anchored for link in (e.link1, e.link2)]
        offsets = np.tile(np.eye(4), (len(links), 1, 1))
        offsets[:, :3, 3] = [p for e in anchored for p in (e.p1, e.p2)] if anchored else np.zeros((0, 3))
        self.targets = targets(model, wp.array(np.array(links, dtype=int), dtype=int, device=d), transforms(offsets, s, d))
        self.T = len(links)
        self.rates = any(e.kind in ("connect", "weld") for e in E)  # MuJoCo's J̇ν (the anchors' bias accelerations); frame welds have none
        q_start, v_start = tree.q_start, tree.v_start  # joint j moves link j + 1
        K = equality_kernels(s)
        eq = self.bundle = K.Equalities()

        def ints(values):
            return wp.array(np.array(values, dtype=np.int32).reshape(-1), dtype=wp.int32, device=d)

        def floats(values, width=None):
            shape = (self.count,) if width is None else (self.count, width)
            return wp.array(np.array(values, dtype=np.float64).reshape(shape), dtype=s, device=d)

        eq.kind = ints(kinds)
        eq.row = ints(rows[:-1])
        eq.target = ints(target_of)
        eq.link1 = ints([e.link1 for e in E])
        eq.link2 = ints([e.link2 for e in E])
        eq.p1 = wp.array(np.array([e.p1 for e in E], dtype=np.float64).reshape(-1, 3), dtype=wp.types.vector(3, s), device=d)
        eq.p2 = wp.array(np.array([e.p2 for e in E], dtype=np.float64).reshape(-1, 3), dtype=wp.types.vector(3, s), device=d)
        quat = wp.types.quaternion(s)
        eq.Q1 = wp.array(np.array([np.roll(e.Q1, -1) for e in E], dtype=np.float64).reshape(-1, 4), dtype=quat, device=d)  # (x, y, z, w)
        eq.Q2 = wp.array(np.array([np.roll(e.Q2, -1) for e in E], dtype=np.float64).reshape(-1, 4), dtype=quat, device=d)
        eq.torquescale = floats([e.torquescale for e in E])
        eq.invweight_rotation = floats([e.invweight_rotation for e in E])
        eq.dof_parent = ints(dof_parents(tree, model.floating_base()))
        # a coupling's lengths: its terms (position address, DoF, coefficient), side 1 then side 2 of each
        terms, first1, count1, first2, count2 = [], [], [], [], []
        for e in E:
            for side, first, count in ((e.terms1, first1, count1), (e.terms2, first2, count2)):
                first.append(len(terms))
                count.append(len(side))
                terms += [(int(q_start[j + 1]), int(v_start[j + 1]), coef) for j, coef in side]
        eq.term_q = ints([t[0] for t in terms])
        eq.term_dof = ints([t[1] for t in terms])
        eq.term_coef = wp.array(np.array([t[2] for t in terms], dtype=np.float64), dtype=s, device=d)
        eq.first1, eq.count1, eq.first2, eq.count2 = ints(first1), ints(count1), ints(first2), ints(count2)
        eq.ref1 = floats([e.ref1 for e in E])
        eq.ref2 = floats([e.ref2 for e in E])
        eq.polycoef = floats([e.polycoef for e in E], 5)
        eq.solref = floats([e.solref for e in E], 2)
        eq.solimp = floats([e.solimp for e in E], 5)
        eq.invweight = floats([e.invweight for e in E])
        eq.baumgarte = floats([e.baumgarte for e in E], 2)
        eq.regularization = floats([e.regularization for e in E])
        eq.joint = ints([e.terms1[0][0] if e.kind in ("limit", "friction") else -1 for e in E])
        eq.margin = floats([e.margin for e in E])
        eq.ball_angle = floats([-1.0 if e.angle is None else e.angle for e in E])
        # each row's one column where J has no other (a hinge's or slide's limit or friction row: 6 + its DoF), else -1
        one_column = [kinds[i] in (LIMIT, FRICTION) and E[i].angle is None for i in range(self.count)]
        eq.row_column = ints([6 + terms[first1[i]][1] if one_column[i] else -1 for i in range(self.count) for _ in range(ROWS[int(kinds[i])])])
        eq.position_limits = model_bundle(model).position_limits  # the limits' ranges: the model's parameter (P, nj)
        multi = model.multi_dof()
        self.solve, self.projection_kernel = solve_kernels(s), projection_kernels(s, multi).equality_projection
        self.fk = kinematics_kernels(s, multi).forward_kinematics
        self.bias = derivative_kernels(s, multi)
        self.jacobians = jacobian_kernels(s, multi).jacobians
        self.crba = crba_kernels(s, "tuned", multi).crba

    def buffers(self, plan, N: int, grad: bool = False) -> dict:
        """An evaluation's buffers for N environments; grad: the solve's inputs (and what they are computed from) carry
        gradients (the scratch never does)."""
        s, d = plan.scalar, plan.device
        K, m, nL = 6 + plan.n, self.rows, plan.nL
        vec6 = wp.types.vector(6, s)

        def empty(shape, dtype=s, differentiable=False):
            return arrays.empty(shape, N, dtype, d, grad and differentiable)

        width = max(m, K)
        out = {
            name: empty(shape, dtype, True)
            for name, shape, dtype in (
                ("nu_free", (K,), s), ("W_v_WL", (nL,), vec6), ("W_a_L", (nL,), vec6), ("J_t", (self.T, 6, K), s), ("Jdotnu_t", (self.T, 6), s),
                ("M", (K, K), s), ("crba_scratch", (max(nL, plan.n + 1), CRBA_RECORD), s), ("J", (m, K), s), ("aref", (m,), s), ("R", (m,), s),
            )
        }
        # the solve's scratch: L (K, K), MinvJT (m, K), A and LA (m, m), y, rhs, w, active, u, v, a0, t (width)
        out["scratch"] = [empty((K, K)), empty((m, K)), empty((m, m)), empty((m, m))] + [empty((width,)) for _ in range(8)]
        if self.projection_passes:
            out["parent_H_link_next"], out["W_H_L_next"] = (empty((nL,), wp.types.transformation(s)) for _ in range(2))
        return out

    def launches(self, plan, ev, x, N: int) -> list:
        """After ABA wrote ev.equality["nu_free"] at x (ev.W_H_L: FK at x): the constrained ev.nu_dot (the rows
        recorded by a tape, the solve's adjoint registered by hand where ev.grad)."""
        b = ev.equality
        inertial, mixed = int(VelRepr.Inertial), int(VelRepr.Mixed)
        launches = [Launch(self.crba, N, [plan.model, x, inertial, b["crba_scratch"]], [b["M"]])]
        if self.rates:  # the links' velocities (a weld's angular rates) and the anchors' J̇ν
            launches.append(Launch(self.bias.link_bias_recursion, N, [plan.model, ev.W_H_L, x], [b["W_v_WL"], b["W_a_L"]]))
        if self.T:  # the anchors of connects and welds, MJCF's and JaxSim's
            launches.append(Launch(self.jacobians, (N, self.T), [plan.model, self.targets, ev.W_H_L, inertial, mixed], [b["J_t"]]))
        if self.rates:
            launches.append(Launch(self.bias.bias_accelerations, (N, self.T), [self.targets, ev.W_H_L, b["W_v_WL"], b["W_a_L"], inertial, mixed], [b["Jdotnu_t"]]))
        rows = [self.bundle, x, ev.W_H_L, b["W_v_WL"], b["J_t"], b["Jdotnu_t"], plan.dt, self.refsafe]
        launches.append(Launch(self.solve.equality_rows, N, rows, [b["J"], b["aref"], b["R"]]))
        scratch = b["scratch"]
        args = [plan.model, self.bundle, x, b["J"], b["aref"], b["R"], b["M"], b["nu_free"], plan.implicit_dt, *scratch[:8]]
        adjoint = no_adjoint
        if ev.grad:
            fields = (x.base_position, x.base_quaternion, x.joint_positions, x.base_velocity, x.joint_velocities)
            adj_x = state_bundle(plan.scalar, [a.grad if a.grad is not None else wp.zeros_like(a) for a in fields] + [None, None])
            grads = [ev.nu_dot.grad, adj_x, b["J"].grad, b["aref"].grad, b["R"].grad, b["M"].grad, b["nu_free"].grad]
            adjoint = functools.partial(launch, self.solve.equality_solve_adjoint, N, [*args, *scratch[8:12], *grads], [], device=plan.device, record_tape=False)
        launches.append(Launch(self.solve.equality_solve, N, args, [ev.nu_dot], adjoint=adjoint))
        return launches

    def after_step(self, plan, ev, Y, N: int) -> list:
        """The post-stabilisation of the step's new state Y, in place (kernels/equality.py): `projection_passes`
        position passes and one velocity pass (none when it is 0), each after forward kinematics, the mass matrix and the anchors' Jacobians at Y."""
        b = ev.equality
        inertial, mixed = int(VelRepr.Inertial), int(VelRepr.Mixed)
        launches = []
        for velocity_pass in [0] * self.projection_passes + [1] * (self.projection_passes > 0):
            launches += [
                Launch(self.fk, N, [plan.model, Y], [b["parent_H_link_next"], b["W_H_L_next"]]),
                Launch(self.crba, N, [plan.model, Y, inertial, b["crba_scratch"]], [b["M"]]),
            ]
            if self.T:
                launches.append(Launch(self.jacobians, (N, self.T), [plan.model, self.targets, b["W_H_L_next"], inertial, mixed], [b["J_t"]]))
            scratch = [b["J"], *b["scratch"][:4], *b["scratch"][4:7]]  # J, L, MinvJT, A, LA, y, rhs, w
            args = [plan.model, self.bundle, b["W_H_L_next"], b["W_v_WL"], b["J_t"], b["Jdotnu_t"], b["M"], plan.scalar(PROJECTION_DAMPING[plan.scalar]), velocity_pass, *scratch]
            launches.append(Launch(self.projection_kernel, N, args, [Y]))
        return launches


def _check_limit_ranges(model, E: list) -> None:
    """Refuse a hinge's or slide's limit whose range (the model's position_limits, in any environment) is narrower than
    twice its margin: MuJoCo gives such a joint both bounds' rows at once, warpdyn one row per joint (a ball's limit
    has one bound)."""
    if not any(e.kind == "limit" for e in E):
        return
    limits = np.asarray(model.parameter_host("position_limits"), dtype=np.float64).reshape(-1, model.tree.number_of_joints, 2)
    width = (limits[..., 1] - limits[..., 0]).min(axis=0)
    narrow = [f"'{e.name}' (range {float(width[e.terms1[0][0]]):.6g}, margin {e.margin:g})" for e in E
              if e.kind == "limit" and e.angle is None and width[e.terms1[0][0]] < 2.0 * e.margin]  # fmt: skip
    if narrow:
        raise NotImplementedError(
            f"model.limit_constraints on '{model.name()}': joints {narrow} have a range narrower than twice their margin, which MuJoCo "
            "holds by both bounds' rows at once; warpdyn solves one row per joint (lower the margin or widen position_limits)"
        )


def _check_invweights(model, E: list) -> None:
    """Refuse limit and friction rows without an inverse weight (NaN: a URDF's or SDF's tree whose mass matrix at the
    zero positions is singular, warpdyn.description.invweight), which MuJoCo would refuse to compile."""
    missing = sorted({e.name for e in E if e.kind in ("limit", "friction") and not np.isfinite(e.invweight)})
    if missing:
        raise ValueError(
            f"model.limit_constraints or model.frictionloss_constraints on '{model.name()}': joints {missing} have no "
            "dof_invweight0 (the mass matrix at the zero positions is singular: a chain of massless links), which their rows' "
            "regularisation needs; give those links mass or turn the setting off"
        )


def _check_friction_rows(model, E: list) -> None:
    """With MuJoCo's friction rows the step drops JaxSim's static friction: refuse a friction_static on a DoF that
    has no row (a ball joint's, or one set after loading where the description had no frictionloss)."""
    tree = model.tree
    rows = {int(tree.v_start[j + 1]) for e in E if e.kind == "friction" for j, _ in e.terms1}
    static = np.asarray(model.parameter_host("friction_static"), dtype=np.float64).reshape(-1, int(tree.v_start[-1]))
    names = model.joint_names()
    joint_of = tree.dof_joint()
    left = sorted({names[int(joint_of[d])] for d in np.flatnonzero(np.any(static != 0.0, axis=0)) if int(d) not in rows})
    if left:
        raise NotImplementedError(
            f"model.frictionloss_constraints on '{model.name()}': joints {left} have a friction_static but no MuJoCo friction row "
            "(a ball joint, or friction set where the description has no frictionloss), and the step drops JaxSim's static friction "
            "for the rows; set their friction_static to 0 or model.frictionloss_constraints = False"
        )


def dof_parents(tree, floating: bool) -> np.ndarray:
    """(6 + nv,) int32: each DoF's parent DoF (the generalized velocity's order, base first): a base DoF the one
    before it (-1 for the first, and for all six of a fixed base), a joint's first DoF the last DoF of its
    parent link's joint (of the base: 5, or -1 when the base is fixed), its others the DoF before."""
    nv = int(tree.v_start[-1])
    parent = np.full(6 + nv, -1, dtype=np.int32)
    if floating:
        parent[1:6] = np.arange(5)
    for i in range(1, tree.number_of_links):
        first, last = 6 + int(tree.v_start[i]), 6 + int(tree.v_start[i + 1])
        p = int(tree.parent[i])
        parent[first] = (5 if floating else -1) if p == 0 else 6 + int(tree.v_start[p + 1]) - 1
        parent[first + 1 : last] = np.arange(first, last - 1)
    return parent


def equalities(model) -> list:
    """The constraints a step enforces (TreeEquality): the description's (MJCF equality constraints), the model's
    JaxSim kinematic constraints (`model.constraints`, a ConstraintMap) as frame welds, then with
    `model.limit_constraints` the joints' limits (unilateral rows) and with `model.frictionloss_constraints` their
    friction constraints (rows bounded by the joints' friction_static)."""
    limits = list(model.tree.limits) if model.limit_constraints else []
    friction = list(model.tree.friction_rows) if model.frictionloss_constraints else []
    return list(model.tree.equalities) + model.constraints.tree_equalities(model) + limits + friction


def equality_plan(model) -> EqualityPlan | None:
    """The model's EqualityPlan, None without equality constraints or limits to solve."""
    if not equalities(model):
        return None
    return EqualityPlan(model)


def check_steppable(plan, recorded: bool) -> None:
    """Refuse a recorded step of a constrained model where the solve's adjoint leaves something out: gradients of
    the damping with MuJoCo's implicit damping; the friction rows' bounds; the post-stabilisation (`equality_projection`).
    Queries that do not step pass."""
    if plan.equality is None or not recorded:
        return
    eq = plan.equality
    if float(plan.implicit_dt) > 0.0 and any(d.requires_grad for d in eq.dampings):
        raise NotImplementedError(
            f"a step of '{eq.model_name}' (equality constraints, MuJoCo's implicit damping with gradients of the damping) under a "
            "wp.Tape: that solve's adjoint leaves them out; use an explicit integrator (JaxSim's SemiImplicitEuler or RungeKutta4, "
            "or model.implicit_damping = False) or step it outside the tape"
        )
    if eq.friction_bounds is not None and eq.friction_bounds.requires_grad:
        raise NotImplementedError(
            f"a step of '{eq.model_name}' (MuJoCo's friction constraints, with gradients of friction_static) under a wp.Tape: the "
            "solve's adjoint leaves out a saturated friction row's bound; differentiate without model.frictionloss_constraints"
        )
    if eq.projection_passes:
        raise NotImplementedError(
            f"a step of '{eq.model_name}' with model.equality_projection = {eq.projection_passes} under a wp.Tape: "
            "the post-stabilisation has no adjoint yet; set model.equality_projection = 0 to differentiate, or step it outside the tape"
        )
