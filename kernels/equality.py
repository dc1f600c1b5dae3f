"""Equality constraints, joint limits and joint friction solved as MuJoCo solves them (its soft constraints: equality,
limit and friction rows): one thread per environment.

MuJoCo >= 3.10's semantics (its Jdot v correction of connects and welds: older versions leave it out). Each
constraint e contributes rows (a connect 3, a weld 6, a joint or fixed-tendon coupling, a limit, a friction row 1) with a position residual
r, a Jacobian J (rows of the generalized velocity nu, Inertial base) and J̇ν (MuJoCo's Jdot v of a connect or
weld: the anchors' bias accelerations; 0 for a coupling, as in MuJoCo):
- connect: r = p1 - p2, the anchors in world axes; J = J_p1 - J_p2 (their Mixed linear Jacobians);
- weld: a connect's rows, then MuJoCo's rotation rows: with q0 and q1 the welded frames' world orientations,
  r = s vec(q1* q0), J = s/2 vec(q1* (J_w1 - J_w2) q0) (J_w: the links' angular Jacobians, world axes; pure
  quaternions inside), J̇ν = s/2 vec(q1dot* dw q0 + q1* (J̇ν_w1 - J̇ν_w2) q0 + q1* dw q0dot), dw = w1 - w2,
  qdot = 1/2 w q, s the torquescale;
- coupling: r = L1 - L1_0 - sum_k c_k (L2 - L2_0)^k, J = dL1 - (sum_k k c_k (L2 - L2_0)^(k-1)) dL2, L a joint's
  position or a fixed tendon's length sum_j coef_j q_j (dL its coefficients on the DoFs);
- limit (MuJoCo's limit of a hinge, slide or ball joint, `model.limit_constraints`; docs/mujoco_semantics.md): at the
  nearer bound of the joint's position_limits, dist = q - lower (J = +1 at the joint's DoF) or upper - q (J = -1),
  r = dist - margin; a ball joint's: dist = ball_angle - theta, J = -u on its three DoFs (theta u its rotation vector,
  `ball_rotation`); while r >= 0 the row is empty (J = 0, aref = 0, R = 1: no force), and where r < 0 it is
  unilateral: kernels/equality_solve.py's active set keeps its force f >= 0;
- friction (MuJoCo's friction constraint, `model.frictionloss_constraints`): J = 1 at the joint's DoF, r = 0 (so
  aref = -b J nu and imp = solimp[0]), its force bounded by the joint's frictionloss, |f| <= friction_static
  (kernels/equality_solve.py's active set: within the bound, or saturated at it);
- frame weld (JaxSim's kinematic constraint, jaxsim.rbda.kinematic_constraints): two frames F1, F2 held together,
  J = J_F1 - J_F2 (their Mixed Jacobians: the origins' linear velocities and the angular ones, world axes),
  r = [p_F1 - p_F2; R_F2 log(R_F2^T R_F1)], J̇ν = 0 (JaxSim leaves it out), aref = -(K_P r + K_D J nu) and
  R = its regularisation (JaxSim's 1e-3), no impedance. JaxSim's rotation residual is log(R_F2^T R_F1) itself, in
  F2's axes, against rows in world axes: its rotational error then obeys e'' + K_D e' + K_P R_F2^T e = 0, unstable
  once F2 turns more than 76 degrees from the world's axes (K_D = 2 sqrt(K_P); the roots of s^2 + K_D s + K_P
  e^(i theta) cross the imaginary axis at cos theta = sqrt(5) - 2); warpdyn's residual is that vector in world
  axes, equal to JaxSim's where F2 keeps the world's axes or the frames' orientations agree.
MuJoCo's reference acceleration and regularisation (mj_makeImpedance, mj_referenceConstraint): with solref
(timeconst, dampratio) (timeconst raised to 2 dt, MuJoCo's refsafe, unless disabled; or direct (-stiffness,
-damping)) and the impedance imp = solimp's function of |r| (of the rows' norm for a connect or weld),
    aref = -b J nu - k imp r - J̇ν,   R = max(1e-15, (1 - imp) / imp invweight)
(a weld's rotation rows: invweight_rotation), b = 2 / (dmax timeconst), k = 1 / (dmax^2 timeconst^2 dampratio^2),
dmax = solimp[1]. With equality rows only, MuJoCo's constrained accelerations minimise a quadratic whose minimiser is
    f = (J M^-1 J^T + diag(R))^-1 (aref - J a0),   nu_dot = a0 + M^-1 J^T f,
a0 = M^-1 tau the unconstrained accelerations (its Newton solver reaches it in one step). With MuJoCo's implicit
joint damping (the Euler step's (M + dt D)), the constraint force is that of the explicit a0 = a0' + dt M^-1 D a0'
(a0' = (M + dt D)^-1 tau, ABA's), and the step's accelerations are a0' + (M + dt D)^-1 J^T f (mj_Euler's); a
floating base's damper d acts on MuJoCo's free-joint coordinates T nu, so D's base block is d T^T T and its
force d T^T (T a0' + T_dot nu) (`base_coordinates`).

M is factorised along the tree (Featherstone's LTDL: only the entries its branches fill, `tree_factor`), A densely
(kernels/cholesky.py's `factor` and `substitute`). The accelerations' kernels, differentiable, are in
kernels/equality_solve.py; the rows (`constraint_rows`) write each entry once so that Warp differentiates them. The
post-stabilisation below is forward only.

Post-stabilisation (`equality_projection`, after a step; the model setting `equality_projection` its position passes;
the hard constraints JaxSim's kinematic constraints aim at): the step's new position is moved by the least change in
the mass metric that zeroes r to first order, dq = -M^-1 J^T (J M^-1 J^T)^+ r (Gauss-Newton: r shrinks
quadratically over the iterations), then its velocity projected onto J nu = 0 at the corrected position (the
least change in kinetic energy); (J M^-1 J^T)^+ is solved with Levenberg-Marquardt's damping (rows that depend on
the others move nothing), the velocity's solve refined three times. Measured, not explained: after a semi-implicit
Euler step the projected motion gains energy where it turns (the energy enters in the step from the projected
state, not in the projection); after RK4 it loses a little (model_settings' `equality_projection` gives the figures).
"""

import types

import warp as wp

from .bundles import bundles
from .cholesky import kernels as cholesky_kernels
from .factory import factory
from .integrators import kernels as integrator_kernels
from .joints import joints
from .spatial import BALL, FREE, MIXED, spatial

CONNECT = wp.constant(0)
COUPLING = wp.constant(1)  # a joint or fixed-tendon coupling
WELD = wp.constant(2)
FRAME_WELD = wp.constant(3)  # JaxSim's weld between two frames (its ConstraintMap's ConstraintType.Weld)
LIMIT = wp.constant(4)  # MuJoCo's limit of a hinge, slide or ball joint (mjCNSTR_LIMIT_JOINT): unilateral
FRICTION = wp.constant(5)  # MuJoCo's friction constraint of a hinge or slide joint (mjCNSTR_FRICTION_DOF): bounded
ROWS = {0: 3, 1: 1, 2: 6, 3: 6, 4: 1, 5: 1}
"""The rows of each kind."""

MIN_VALUE = 1.0e-15
"""MuJoCo's mjMINVAL, the floor of R."""

MIN_IMPEDANCE = 1.0e-4
MAX_IMPEDANCE = 0.9999
"""MuJoCo's mjMINIMP and mjMAXIMP, the range of solimp's impedances."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The equality-constraint kernel in `scalar`."""
    sp, B = spatial(scalar), bundles(scalar)

    @wp.struct
    class Equalities:
        """E constraints, m rows (warpdyn.engine.equality fills it): kind (E,) CONNECT, WELD, FRAME_WELD or COUPLING,
        row (E,) its first row; a connect's or weld's targets target (E,) (its anchors p1, p2 are the targets target and
        target + 1 of the step's Targets), link1, link2 (E,) (-1: the world) and anchors p1, p2 (E,) in their
        links' frames; a weld's frames Q1, Q2 (E,) in those links' frames and torquescale (E,); a joint or
        fixed-tendon coupling's lengths L = sum coef q over its terms (term_q, term_dof, term_coef (T,): position
        address, DoF, coefficient), side 1 its first1 and count1 terms, side 2 its first2 and count2 (0: none),
        their values at qpos0 ref1, ref2, polycoef (E, 5);
        solref (E, 2), solimp (E, 5), invweight (E,), invweight_rotation (E,) (a weld's rotation rows); a frame
        weld's gains baumgarte (E, 2) (K_P [1/s^2], K_D [1/s]) and regularization (E,) (its R); a limit's or friction
        row's joint (E,) (-1 for the others; also as a coupling's side 1: one term, coefficient 1) and a limit's margin
        (E,) [rad or m], its range the model's position_limits (P, nj) (a friction row's bound its friction_static), a
        ball joint's limit its bound on the rotation angle ball_angle (E,) [rad] (-1 for the others); row_column (m,): the one column of J that a row can fill (a limit's and a friction row's: 6 + its DoF), -1 for
        the rows that fill several; dof_parent (K = 6 + nv,): each DoF's parent DoF in the tree (the base's six a
        chain; -1 at a root), for `tree_factor`."""

        kind: wp.array(dtype=wp.int32)
        row: wp.array(dtype=wp.int32)
        target: wp.array(dtype=wp.int32)
        link1: wp.array(dtype=wp.int32)
        link2: wp.array(dtype=wp.int32)
        p1: wp.array(dtype=sp.vec3)
        p2: wp.array(dtype=sp.vec3)
        Q1: wp.array(dtype=sp.quat)
        Q2: wp.array(dtype=sp.quat)
        torquescale: wp.array(dtype=scalar)
        term_q: wp.array(dtype=wp.int32)
        term_dof: wp.array(dtype=wp.int32)
        term_coef: wp.array(dtype=scalar)
        first1: wp.array(dtype=wp.int32)
        count1: wp.array(dtype=wp.int32)
        first2: wp.array(dtype=wp.int32)
        count2: wp.array(dtype=wp.int32)
        ref1: wp.array(dtype=scalar)
        ref2: wp.array(dtype=scalar)
        polycoef: wp.array2d(dtype=scalar)
        solref: wp.array2d(dtype=scalar)
        solimp: wp.array2d(dtype=scalar)
        invweight: wp.array(dtype=scalar)
        invweight_rotation: wp.array(dtype=scalar)
        baumgarte: wp.array2d(dtype=scalar)
        regularization: wp.array(dtype=scalar)
        joint: wp.array(dtype=wp.int32)
        margin: wp.array(dtype=scalar)
        ball_angle: wp.array(dtype=scalar)
        row_column: wp.array(dtype=wp.int32)
        position_limits: wp.array2d(dtype=wp.types.vector(2, scalar))
        dof_parent: wp.array(dtype=wp.int32)

    @wp.func
    def pure(w: sp.vec3):
        """The pure quaternion (w, 0)."""
        return sp.quat(w[0], w[1], w[2], scalar(0.0))

    @wp.func
    def vector_part(q: sp.quat):
        return sp.vec3(q[0], q[1], q[2])

    @wp.func
    def frame_of(W_H_L: wp.array2d(dtype=sp.transform), env: int, link: int, Q: sp.quat):
        """The world orientation of the frame Q on `link` (-1: the world)."""
        if link >= 0:
            return wp.transform_get_rotation(W_H_L[env, link]) * Q
        return Q

    @wp.func
    def angular_velocity(W_v_WL: wp.array2d(dtype=sp.vec6), env: int, link: int):
        """A link's angular velocity, world axes (0 for the world)."""
        if link >= 0:
            return sp.ang(W_v_WL[env, link])
        return sp.vec3(scalar(0.0))

    @wp.func
    def length_of(eq: Equalities, x: B.State, env: int, first: int, count: int):
        """A coupling side's length: sum of coef q over its terms (a joint's position, or a fixed tendon's)."""
        total = scalar(0.0)
        for k in range(first, first + count):
            total = total + eq.term_coef[k] * x.joint_positions[env, eq.term_q[k]]
        return total

    @wp.func
    def power(a: scalar, b: scalar):
        """a^b, exact for b = 1 and 2 (MuJoCo's `power`)."""
        if b == scalar(1.0):
            return a
        if b == scalar(2.0):
            return a * a
        return wp.pow(a, b)

    @wp.func
    def impedance(eq: Equalities, e: int, distance: scalar):
        """MuJoCo's getimpedance: imp at the residual's size `distance` (no margin), solimp clamped as in
        getsolparam."""
        d0 = wp.clamp(eq.solimp[e, 0], scalar(MIN_IMPEDANCE), scalar(MAX_IMPEDANCE))
        dmax = wp.clamp(eq.solimp[e, 1], scalar(MIN_IMPEDANCE), scalar(MAX_IMPEDANCE))
        width = wp.max(eq.solimp[e, 2], scalar(0.0))
        mid = wp.clamp(eq.solimp[e, 3], scalar(MIN_IMPEDANCE), scalar(MAX_IMPEDANCE))
        p = wp.max(eq.solimp[e, 4], scalar(1.0))
        if d0 == dmax or width <= scalar(MIN_VALUE):
            return scalar(0.5) * (d0 + dmax)
        x = wp.abs(distance / width)
        if x >= scalar(1.0):
            return dmax
        if x <= scalar(0.0):
            return d0
        y = x
        if p != scalar(1.0):
            if x <= mid:
                y = power(x, p) / power(mid, p - scalar(1.0))
            else:
                y = scalar(1.0) - power(scalar(1.0) - x, p) / power(scalar(1.0) - mid, p - scalar(1.0))
        return d0 + y * (dmax - d0)

    @wp.func
    def reference(eq: Equalities, e: int, dt: scalar, refsafe: int, imp: scalar):
        """(k imp, b): MuJoCo's stiffness times impedance and damping of constraint e's rows (mj_makeImpedance),
        its timeconst raised to 2 dt when refsafe."""
        dmax = wp.clamp(eq.solimp[e, 1], scalar(MIN_IMPEDANCE), scalar(MAX_IMPEDANCE))
        timeconst = eq.solref[e, 0]
        ratio = eq.solref[e, 1]
        k = -timeconst / wp.max(scalar(MIN_VALUE), dmax * dmax)
        if timeconst > scalar(0.0):
            if refsafe != 0:
                timeconst = wp.max(timeconst, scalar(2.0) * dt)
            k = scalar(1.0) / wp.max(scalar(MIN_VALUE), dmax * dmax * timeconst * timeconst * ratio * ratio)
        b = -ratio / wp.max(scalar(MIN_VALUE), dmax)
        if ratio > scalar(0.0):
            b = scalar(2.0) / wp.max(scalar(MIN_VALUE), dmax * timeconst)
        return k * imp, b

    @wp.func
    def base_coordinates(x: B.State, env: int):
        """T (6 x 6): the Inertial base velocity [v; w] to MuJoCo's free-joint coordinates [p_dot; R^T w] (world
        linear velocity of the base's origin, body angular velocity): its Mixed velocity (spatial's
        `inertial_to_repr`), the angular part in the base's axes."""
        W_H_B = B.base_pose(x, env)
        Q = wp.transform_get_rotation(W_H_B)
        T = sp.mat66(scalar(0.0))
        for c in range(6):
            unit = sp.vec6(scalar(0.0))
            unit[c] = scalar(1.0)
            mixed = sp.inertial_to_repr(MIXED, W_H_B, unit)
            column = sp.stack(sp.lin(mixed), wp.quat_rotate_inv(Q, sp.ang(mixed)))
            for r in range(6):
                T[r, c] = column[r]
        return T

    @wp.func
    def tree_factor(model: B.Model, M: wp.array3d(dtype=scalar), env: int, off: int, parent: wp.array(dtype=wp.int32), implicit_dt: scalar,
                    base_damper: sp.mat66, L: wp.array3d(dtype=scalar)):
        """L[env] = the LTDL factors of M[env] + implicit_dt D over DoFs off to K - 1, D the joints' damping on the
        diagonal and the base's block `base_damper` (Featherstone's RBDA, table 6.3: M = L^T D L, D on L's diagonal,
        L's unit lower part where a DoF's ancestor is; parent (K,): each DoF's parent DoF, -1 at a root), only the
        entries the tree's branches can fill (a floating base's six DoFs are a chain: its block is whole)."""
        K = M.shape[1]
        for k in range(off, K):
            i = k
            while i >= 0:
                L[env, k, i] = M[env, k, i]
                if k < 6:
                    L[env, k, i] = L[env, k, i] + implicit_dt * base_damper[k, i]
                i = parent[i]
            if k >= 6:
                L[env, k, k] = L[env, k, k] + implicit_dt * B.joint_parameter(model.damping, env, k - 6)
        for kk in range(K - off):
            k = K - 1 - kk
            i = parent[k]
            while i >= 0:
                a = L[env, k, i] / L[env, k, k]
                j = i
                while j >= 0:
                    L[env, i, j] = L[env, i, j] - a * L[env, k, j]
                    j = parent[j]
                L[env, k, i] = a
                i = parent[i]

    @wp.func
    def tree_solve(L: wp.array3d(dtype=scalar), env: int, off: int, parent: wp.array(dtype=wp.int32), x: wp.array2d(dtype=scalar)):
        """x[env, off:K] = M^-1 x[env, off:K] with M's LTDL factors L (`tree_factor`; RBDA, table 6.4)."""
        K = L.shape[1]
        for kk in range(K - off):
            i = K - 1 - kk
            j = parent[i]
            while j >= 0:
                x[env, j] = x[env, j] - L[env, i, j] * x[env, i]
                j = parent[j]
        for i in range(off, K):
            x[env, i] = x[env, i] / L[env, i, i]
        for i in range(off, K):
            j = parent[i]
            while j >= 0:
                x[env, i] = x[env, i] - L[env, i, j] * x[env, j]
                j = parent[j]

    @wp.func
    def inverse_mass_rows(
        model: B.Model, M: wp.array3d(dtype=scalar), env: int, off: int, parent: wp.array(dtype=wp.int32), J: wp.array3d(dtype=scalar),
        column: wp.array(dtype=wp.int32), L: wp.array3d(dtype=scalar), w: wp.array2d(dtype=scalar), MinvJT: wp.array3d(dtype=scalar),
        used: wp.array2d(dtype=scalar),
    ):
        """MinvJT[env, r] = M^-1 J[env, r] for every row r of J (DoFs off to K - 1), M factorised into L along the tree
        (`tree_factor`, no damper); an empty row's (a limit within its range) 0 without a solve, used[env, r] 0 for it
        (1 otherwise: `delassus_rows` skips the empty rows); column (m,): Equalities.row_column (a row's only column,
        or -1); w: scratch (K)."""
        K = M.shape[1]
        tree_factor(model, M, env, off, parent, scalar(0.0), sp.mat66(scalar(0.0)), L)
        for r in range(J.shape[1]):
            empty = int(1)
            if column[r] >= 0:
                for i in range(off, K):
                    w[env, i] = scalar(0.0)
                value = J[env, r, column[r]]
                w[env, column[r]] = value
                if value != scalar(0.0):
                    empty = int(0)
            else:
                for i in range(off, K):
                    w[env, i] = J[env, r, i]
                    if J[env, r, i] != scalar(0.0):
                        empty = int(0)
            used[env, r] = scalar(1.0)
            if empty == 0:
                tree_solve(L, env, off, parent, w)
            else:
                used[env, r] = scalar(0.0)
            for i in range(off, K):
                MinvJT[env, r, i] = w[env, i]

    @wp.func
    def row_velocity(J: wp.array3d(dtype=scalar), env: int, r: int, v_B: sp.vec6, x: B.State):
        """Row r of J nu: nu the base's Inertial velocity v_B and the joints' velocities in x."""
        total = scalar(0.0)
        for c in range(6):
            total = total + J[env, r, c] * v_B[c]
        for c in range(6, J.shape[2]):
            total = total + J[env, r, c] * x.joint_velocities[env, c - 6]
        return total

    @wp.func
    def delassus_rows(J: wp.array3d(dtype=scalar), MinvJT: wp.array3d(dtype=scalar), env: int, off: int, column: wp.array(dtype=wp.int32),
                      used: wp.array2d(dtype=scalar), A: wp.array3d(dtype=scalar)):
        """A[env] = J M^-1 J^T over the rows of J (DoFs off to K - 1; MinvJT and used: `inverse_mass_rows`; an empty
        row's entries 0 without a sum; a pair with a one-column row (column: Equalities.row_column) one product)."""
        for r in range(J.shape[1]):
            for q in range(r + 1):
                total = scalar(0.0)
                if used[env, r] != scalar(0.0) and used[env, q] != scalar(0.0):
                    if column[r] >= 0:
                        total = J[env, r, column[r]] * MinvJT[env, q, column[r]]
                    elif column[q] >= 0:
                        total = J[env, q, column[q]] * MinvJT[env, r, column[q]]
                    else:
                        for c in range(off, J.shape[2]):
                            total = total + J[env, r, c] * MinvJT[env, q, c]
                A[env, r, q] = total
                A[env, q, r] = total

    @wp.func
    def norm(v: sp.vec6):
        """|v|, 0 at 0 (whose derivative, unlike wp.length's, is then 0 rather than 0/0)."""
        square = wp.dot(v, v)
        if square > scalar(0.0):
            return wp.sqrt(square)
        return scalar(0.0)

    @wp.func
    def anchor_row(J_t: wp.array4d(dtype=scalar), env: int, t: int, link1: int, link2: int, a: int, c: int):
        """Row a, column c of anchor 1's Jacobian less anchor 2's (targets t and t + 1; a world anchor's 0)."""
        value = scalar(0.0)
        if link1 >= 0:
            value = J_t[env, t, a, c]
        if link2 >= 0:
            value = value - J_t[env, t + 1, a, c]
        return value

    @wp.func
    def anchor_bias(Jdotnu_t: wp.array3d(dtype=scalar), env: int, t: int, link1: int, link2: int):
        """Anchor 1's J̇ν (6) less anchor 2's (0 for a world anchor)."""
        bias = sp.vec6(scalar(0.0))
        if link1 >= 0:
            bias = sp.vec6(Jdotnu_t[env, t, 0], Jdotnu_t[env, t, 1], Jdotnu_t[env, t, 2], Jdotnu_t[env, t, 3], Jdotnu_t[env, t, 4], Jdotnu_t[env, t, 5])
        if link2 >= 0:
            u = t + 1
            bias = bias - sp.vec6(Jdotnu_t[env, u, 0], Jdotnu_t[env, u, 1], Jdotnu_t[env, u, 2], Jdotnu_t[env, u, 3], Jdotnu_t[env, u, 4], Jdotnu_t[env, u, 5])
        return bias

    @wp.func
    def ball_rotation(eq: Equalities, x: B.State, env: int, e: int):
        """Ball joint e's rotation at the state x as MuJoCo's mju_quat2Vel reads its quaternion (w, x, y, z): (its
        angle theta in [0, pi] [rad], the unit axis u of the rotation vector theta u, (1, 0, 0) at the identity). MuJoCo
        takes 2 atan2(|v|, w) less 2 pi where that passes pi, the axis then -v/|v|: 2 atan2(|v|, -w) for w < 0."""
        a = eq.term_q[eq.first1[e]]
        v = sp.vec3(x.joint_positions[env, a + 1], x.joint_positions[env, a + 2], x.joint_positions[env, a + 3])
        w = x.joint_positions[env, a]
        square = wp.dot(v, v)
        axis = sp.vec3(scalar(1.0), scalar(0.0), scalar(0.0))
        angle = scalar(0.0)
        if square > scalar(0.0):
            s = wp.sqrt(square)
            axis = v / s
            if w < scalar(0.0):
                axis = -axis
                w = -w
            angle = scalar(2.0) * wp.atan2(s, w)
        return angle, axis

    @wp.func
    def limit_gap(eq: Equalities, x: B.State, env: int, e: int):
        """Limit e at the state x: (dist - margin, side), its nearer bound's distance dist (negative: past it; the
        bounds the joint's position_limits in environment env) and the row's sign side (+1 at the lower bound, -1 at
        the upper: MuJoCo's Jacobian -side of its own sign). The row acts where dist - margin < 0 (one row: a range
        narrower than twice the margin is refused on the host). A ball joint's: dist = ball_angle - its rotation's
        angle (`ball_rotation`), side 1."""
        if eq.ball_angle[e] >= scalar(0.0):
            angle, axis = ball_rotation(eq, x, env, e)
            return eq.ball_angle[e] - angle - eq.margin[e], scalar(1.0)
        q = x.joint_positions[env, eq.term_q[eq.first1[e]]]
        limits = B.pair_parameter(eq.position_limits, env, eq.joint[e])
        below = q - limits[0]
        above = limits[1] - q
        if below <= above:
            return below - eq.margin[e], scalar(1.0)
        return above - eq.margin[e], scalar(-1.0)

    @wp.func
    def constraint_rows(
        eq: Equalities, x: B.State, W_H_L: wp.array2d(dtype=sp.transform), W_v_WL: wp.array2d(dtype=sp.vec6), J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar), env: int, e: int, J: wp.array3d(dtype=scalar), with_rates: int,
    ):
        """Constraint e's rows (the module docstring) written into J[env, row:row + rows] (K columns, each entry once: a
        tape differentiates it): returns (r, J̇ν (their first `rows` entries; 0 unless with_rates, W_v_WL and Jdotnu_t
        then unread), rows, the residual's size |r|)."""
        K = J.shape[2]
        row = eq.row[e]
        residual = sp.vec6(scalar(0.0))
        bias = sp.vec6(scalar(0.0))
        rows = 1
        if eq.kind[e] == FRICTION:  # J = 1 at the joint's DoF, r = 0
            dof = 6 + eq.term_dof[eq.first1[e]]
            for c in range(K):
                value = scalar(0.0)
                if c == dof:
                    value = scalar(1.0)
                J[env, row, c] = value
        elif eq.kind[e] == LIMIT:  # J = side at the joint's DoF while it acts (0 otherwise), r = dist - margin
            gap, side = limit_gap(eq, x, env, e)
            dof = 6 + eq.term_dof[eq.first1[e]]
            axis = sp.vec3(scalar(0.0))  # a ball's: J = -u on its three DoFs (d theta / dt = u . omega)
            if eq.ball_angle[e] >= scalar(0.0):
                angle, u = ball_rotation(eq, x, env, e)
                axis = -u
            for c in range(K):
                value = scalar(0.0)
                if gap < scalar(0.0):
                    if eq.ball_angle[e] >= scalar(0.0):
                        if c >= dof and c < dof + 3:
                            value = axis[c - dof]
                    elif c == dof:
                        value = side
                J[env, row, c] = value
            residual = sp.vec6(gap, scalar(0.0), scalar(0.0), scalar(0.0), scalar(0.0), scalar(0.0))
        elif eq.kind[e] == COUPLING:
            dif = scalar(0.0)
            slope = scalar(0.0)
            if eq.count2[e] > 0:
                dif = length_of(eq, x, env, eq.first2[e], eq.count2[e]) - eq.ref2[e]
                c1 = eq.polycoef[e, 1]
                c2 = eq.polycoef[e, 2]
                c3 = eq.polycoef[e, 3]
                c4 = eq.polycoef[e, 4]
                slope = c1 + dif * (scalar(2.0) * c2 + dif * (scalar(3.0) * c3 + dif * scalar(4.0) * c4))
            for c in range(K):
                total = scalar(0.0)
                for k in range(eq.first1[e], eq.first1[e] + eq.count1[e]):
                    if 6 + eq.term_dof[k] == c:
                        total = total + eq.term_coef[k]
                for k in range(eq.first2[e], eq.first2[e] + eq.count2[e]):
                    if 6 + eq.term_dof[k] == c:
                        total = total - slope * eq.term_coef[k]
                J[env, row, c] = total
            value = eq.polycoef[e, 0] + dif * (eq.polycoef[e, 1] + dif * (eq.polycoef[e, 2] + dif * (eq.polycoef[e, 3] + dif * eq.polycoef[e, 4])))
            residual = sp.vec6(length_of(eq, x, env, eq.first1[e], eq.count1[e]) - eq.ref1[e] - value, scalar(0.0), scalar(0.0), scalar(0.0), scalar(0.0), scalar(0.0))
        else:
            t = eq.target[e]
            link1 = eq.link1[e]
            link2 = eq.link2[e]
            P1 = eq.p1[e]
            if link1 >= 0:
                P1 = wp.transform_point(W_H_L[env, link1], P1)
            P2 = eq.p2[e]
            if link2 >= 0:
                P2 = wp.transform_point(W_H_L[env, link2], P2)
            translation = P1 - P2
            # the anchors' linear rows (and J̇ν), then for a weld MuJoCo's rotation rows from the links' angular ones
            for a in range(3):
                for c in range(K):
                    J[env, row + a, c] = anchor_row(J_t, env, t, link1, link2, a, c)
            if with_rates != 0 and eq.kind[e] != FRAME_WELD:  # (a frame weld's J̇ν is 0: its W_v_WL and Jdotnu_t go unread)
                bias = anchor_bias(Jdotnu_t, env, t, link1, link2)
            rotation = sp.vec3(scalar(0.0))
            rate = sp.vec3(scalar(0.0))
            rows = 3
            if eq.kind[e] == FRAME_WELD:  # the frames' angular rows as they are; no J̇ν (JaxSim's)
                rows = 6
                for a in range(3, 6):
                    for c in range(K):
                        J[env, row + a, c] = anchor_row(J_t, env, t, link1, link2, a, c)
                R1 = frame_of(W_H_L, env, link1, eq.Q1[e])
                R2 = frame_of(W_H_L, env, link2, eq.Q2[e])
                rotation = wp.quat_rotate(R2, sp.rotation_vector(wp.quat_inverse(R2) * R1))
            if eq.kind[e] == WELD:
                rows = 6
                s = eq.torquescale[e]
                q0 = frame_of(W_H_L, env, link1, eq.Q1[e])
                q1 = wp.quat_inverse(frame_of(W_H_L, env, link2, eq.Q2[e]))
                rotation = s * vector_part(q1 * q0)
                if with_rates != 0:
                    w1 = angular_velocity(W_v_WL, env, link1)
                    w2 = angular_velocity(W_v_WL, env, link2)
                    dw = w1 - w2
                    q1dot = wp.quat_inverse(scalar(0.5) * (pure(w2) * wp.quat_inverse(q1)))
                    q0dot = scalar(0.5) * (pure(w1) * q0)
                    djw = sp.vec3(bias[3], bias[4], bias[5])
                    rate = scalar(0.5) * s * vector_part(q1dot * pure(dw) * q0 + q1 * pure(djw) * q0 + q1 * pure(dw) * q0dot)
                for c in range(K):
                    jw = sp.vec3(anchor_row(J_t, env, t, link1, link2, 3, c), anchor_row(J_t, env, t, link1, link2, 4, c), anchor_row(J_t, env, t, link1, link2, 5, c))
                    column = scalar(0.5) * s * vector_part(q1 * pure(jw) * q0)
                    for a in range(3):
                        J[env, row + 3 + a, c] = column[a]
            residual = sp.stack(translation, rotation)
            bias = sp.stack(sp.lin(bias), rate)
        return residual, bias, rows, norm(residual)

    return types.SimpleNamespace(
        Equalities=Equalities, constraint_rows=constraint_rows, limit_gap=limit_gap, inverse_mass_rows=inverse_mass_rows, row_velocity=row_velocity,
        delassus_rows=delassus_rows, impedance=impedance, reference=reference, base_coordinates=base_coordinates, tree_factor=tree_factor,
        tree_solve=tree_solve,
    )


@factory
def projection_kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The post-stabilisation kernel in `scalar`, for models with ball or free joints (multi_dof) or without."""
    sp, B, jm = spatial(scalar), bundles(scalar), joints(scalar, multi_dof)
    E, C, I = kernels(scalar), cholesky_kernels(scalar), integrator_kernels(scalar, multi_dof)

    @wp.func
    def correction(MinvJT: wp.array3d(dtype=scalar), w: wp.array2d(dtype=scalar), env: int, m: int, i: int):
        """DoF i of -M^-1 J^T w (MinvJT's rows are those of (M^-1 J^T)^T, w[env, :m] the rows' multipliers)."""
        change = scalar(0.0)
        for r in range(m):
            change = change - MinvJT[env, r, i] * w[env, r]
        return change

    @wp.kernel(module="unique", enable_backward=False)
    def equality_projection(
        model: B.Model,
        eq: E.Equalities,
        W_H_L: wp.array2d(dtype=sp.transform),
        W_v_WL: wp.array2d(dtype=sp.vec6),
        J_t: wp.array4d(dtype=scalar),
        Jdotnu_t: wp.array3d(dtype=scalar),
        M: wp.array3d(dtype=scalar),
        damping: scalar,
        velocity_pass: int,
        # scratch: J (N, m, K), L (N, K, K), MinvJT (N, m, K), A and LA (N, m, m), y, rhs, w (N, max(m, K))
        J: wp.array3d(dtype=scalar),
        L: wp.array3d(dtype=scalar),
        MinvJT: wp.array3d(dtype=scalar),
        A: wp.array3d(dtype=scalar),
        LA: wp.array3d(dtype=scalar),
        y: wp.array2d(dtype=scalar),
        rhs: wp.array2d(dtype=scalar),
        w: wp.array2d(dtype=scalar),
        # input and output: the state, projected in place
        x: B.State,
    ):
        """One pass of the post-stabilisation (the module docstring) of x (N environments) at
        its link poses W_H_L, anchors' Jacobians J_t (N, T, 6, K; Mixed, nu Inertial) and mass matrix M (N, K, K;
        Inertial base). velocity_pass 0: the position moved by dq = -M^-1 J^T (J M^-1 J^T)^+ r; 1: the velocity projected,
        nu - M^-1 J^T (J M^-1 J^T)^+ J nu, (J M^-1 J^T)^+ the inverse of J M^-1 J^T + `damping` times its largest diagonal
        entry (Levenberg-Marquardt's: rows that depend on the others, a planar loop's out-of-plane row, two connects
        on one body, or nearly so, move nothing instead of amplifying rounding). W_v_WL and Jdotnu_t are not read (the rows without their J̇ν). A flagged
        environment is left as it is; one whose new state is not finite is flagged (x.valid = 0)."""
        env = wp.tid()
        if x.valid[env] == 0:
            return
        K = M.shape[1]
        off = 6
        if model.floating_base != 0:
            off = 0
        m = J.shape[1]
        W_H_B = B.base_pose(x, env)
        v_B = sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(x, env))
        for r in range(m):
            for c in range(K):
                J[env, r, c] = scalar(0.0)
        for e in range(eq.kind.shape[0]):
            residual, bias, rows, distance = E.constraint_rows(eq, x, W_H_L, W_v_WL, J_t, Jdotnu_t, env, e, J, 0)
            if eq.kind[e] == LIMIT or eq.kind[e] == FRICTION:  # inequalities: the step's solve holds them, the projection leaves them out
                for c in range(K):
                    J[env, eq.row[e], c] = scalar(0.0)
                residual = sp.vec6(scalar(0.0))
            if velocity_pass == 0:  # the position pass's right-hand side (the velocity pass writes J nu there)
                for a in range(rows):
                    rhs[env, eq.row[e] + a] = residual[a]
        E.inverse_mass_rows(model, M, env, off, eq.dof_parent, J, eq.row_column, L, w, MinvJT, y)  # y: the rows used (free until the corrections)
        E.delassus_rows(J, MinvJT, env, off, eq.row_column, y, A)
        largest = scalar(0.0)
        for r in range(m):
            largest = wp.max(largest, A[env, r, r])
        if largest <= scalar(0.0):
            return
        for r in range(m):
            A[env, r, r] = A[env, r, r] + damping * largest
        C.factor(A, env, 0, m, scalar(-1.0), LA)  # positive definite once damped
        if velocity_pass != 0:  # nu - M^-1 J^T (J M^-1 J^T)^+ J nu, refined: the damped solve leaves damping / eigenvalue of J nu
            for sweep in range(3):
                for r in range(m):
                    rhs[env, r] = E.row_velocity(J, env, r, v_B, x)
                C.substitute(LA, env, m, rhs, w, 0)
                for i in range(off, K):
                    change = correction(MinvJT, w, env, m, i)
                    if i < 6:
                        v_B[i] = v_B[i] + change
                    else:
                        x.joint_velocities[env, i - 6] = x.joint_velocities[env, i - 6] + change
            v_mixed = sp.inertial_to_repr(MIXED, W_H_B, v_B)
            nonfinite = int(0)
            for k in range(6):
                x.base_velocity[env, k] = v_mixed[k]
                if not wp.isfinite(v_mixed[k]):
                    nonfinite = 1
            for i in range(6, K):
                if not wp.isfinite(x.joint_velocities[env, i - 6]):
                    nonfinite = 1
            if nonfinite != 0:
                x.valid[env] = 0
            return
        # the position moved by -M^-1 J^T w (into y), per joint on its manifold (a ball's or free joint's rotation
        # Q (x) exp(dw), body axes, as the integrators step it), the base by its Inertial displacement
        C.substitute(LA, env, m, rhs, w, 0)
        for i in range(off, K):
            y[env, i] = correction(MinvJT, w, env, m, i)
        for link in range(1, W_H_L.shape[1]):
            kind = model.joint_type[link]
            a = jm.position_address(model, link)
            d = 6 + jm.dof_address(model, link)
            if wp.static(multi_dof) and (kind == BALL or kind == FREE):
                r = 0
                if kind == FREE:
                    r = 3
                    for k in range(3):
                        x.joint_positions[env, a + k] = x.joint_positions[env, a + k] + y[env, d + k]
                Qj = I.body_rotated(I.read4(x.joint_positions, env, a + r), sp.vec3(y[env, d + r], y[env, d + r + 1], y[env, d + r + 2]), scalar(1.0))
                for k in range(4):
                    x.joint_positions[env, a + r + k] = Qj[k]
            else:
                x.joint_positions[env, a] = x.joint_positions[env, a] + y[env, d]
        if model.floating_base != 0:
            dv = sp.vec6(y[env, 0], y[env, 1], y[env, 2], y[env, 3], y[env, 4], y[env, 5])
            p = wp.transform_get_translation(W_H_B)
            dp = sp.lin(dv) + wp.cross(sp.ang(dv), p)  # the base origin's displacement
            Q = I.quaternion_of(x, env)  # turned by the world-axes rotation ang(dv), as so3_base_step turns it
            Q = I.quaternion_product(I.rotation_step(Q, sp.ang(dv), scalar(1.0)), Q / wp.length(Q))
            Q = Q / wp.length(Q)
            for k in range(3):
                x.base_position[env, k] = p[k] + dp[k]
            for k in range(4):
                x.base_quaternion[env, k] = Q[k]
        nonfinite = int(0)
        for i in range(off, K):
            if not wp.isfinite(y[env, i]):
                nonfinite = 1
        if nonfinite != 0:
            x.valid[env] = 0

    return types.SimpleNamespace(equality_projection=equality_projection)
