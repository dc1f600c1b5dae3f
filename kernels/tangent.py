"""The state's tangent space, to first order: a state moved by a tangent vector, and a state's tangent
coordinates (what Jacobians of a step need; warpdyn.autodiff).

A tangent vector of an environment is dx = [dq; dv], nx = 2 (nb + nv) numbers, nb = 6 for a floating base and 0
for a fixed one:
- dq: the base's [δp (3, world axes) [m]; δθ (3) [rad]] (floating base), then each joint's, in DoF order:
  a revolute or prismatic joint's δs; a ball joint's δθ in its child's axes (Q = Q0 (x) exp(δθ), MuJoCo's
  mj_integratePos); a free joint's δp (its parent's axes) then δθ (child axes). The base's δθ is in world axes
  (Q = exp(δθ) (x) Q0, `base_axes` 0: the Mixed and Inertial representations' angular velocity) or in base
  axes (Q = Q0 (x) exp(δθ), `base_axes` 1: the Body representation's).
- dv: the base velocity (6, in the representation the caller converts) then the joint velocities (nv), added.
Environments come in copies: row c of a replicated array is copy c % m of environment c // m.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .integrators import kernels as integrators
from .joints import joints
from .spatial import BALL, FREE, spatial


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The tangent maps in `scalar` for models with (multi_dof) or without ball and free joints."""
    B = bundles(scalar)
    sp = spatial(scalar)
    jm = joints(scalar, multi_dof)
    I = integrators(scalar, multi_dof)
    quat4 = I.quat4

    @wp.func
    def rotated(Q0: quat4, d: wp.array2d(dtype=scalar), row: int, at: int, base_axes: int):
        """Q0 (x) exp(δθ) (base_axes 1) or exp(δθ) (x) Q0 (0), δθ = d[row, at:at + 3]."""
        step = I.rotation_step(Q0, sp.vec3(d[row, at], d[row, at + 1], d[row, at + 2]), scalar(1.0))
        if base_axes != 0:
            return I.quaternion_product(Q0, step)
        return I.quaternion_product(step, Q0)

    @wp.func
    def rotation_tangent(Q: quat4, Q_ref: quat4, base_axes: int):
        """δθ with Q = Q_ref (x) exp(δθ) (base_axes 1) or exp(δθ) (x) Q_ref (0), to first order: twice the vector
        part of conj(Q_ref) (x) Q, or of Q (x) conj(Q_ref)."""
        conj = quat4(Q_ref[0], -Q_ref[1], -Q_ref[2], -Q_ref[3])
        e = I.quaternion_product(Q, conj)
        if base_axes != 0:
            e = I.quaternion_product(conj, Q)
        return sp.vec3(scalar(2.0) * e[1], scalar(2.0) * e[2], scalar(2.0) * e[3])

    @wp.kernel(module="unique")
    def moved_state(
        model: B.Model,
        p0: wp.array2d(dtype=scalar),
        Q0: wp.array2d(dtype=scalar),
        s0: wp.array2d(dtype=scalar),
        base_v0: wp.array2d(dtype=scalar),
        sdot0: wp.array2d(dtype=scalar),
        dx: wp.array2d(dtype=scalar),
        copies: int,
        nb: int,
        base_axes: int,
        # outputs
        p: wp.array2d(dtype=scalar),
        Q: wp.array2d(dtype=scalar),
        s: wp.array2d(dtype=scalar),
        base_linear: wp.array2d(dtype=scalar),
        base_angular: wp.array2d(dtype=scalar),
        sdot: wp.array2d(dtype=scalar),
    ):
        """Each copy (N m rows) of the environments' state (p0 (N, 3), Q0 (N, 4) (w, x, y, z), s0 (N, nq), base_v0
        (N, 6), sdot0 (N, nv)) moved by its tangent vector dx (N m, nx) (the module docstring): p, Q, s, the base
        velocity's linear and angular parts (N m, 3) and sdot (N m, nv). Launched over N m."""
        row = wp.tid()
        env = row / copies
        nv = sdot0.shape[1]
        base = quat4(Q0[env, 0], Q0[env, 1], Q0[env, 2], Q0[env, 3])
        if nb > 0:
            base = rotated(base, dx, row, 3, base_axes)
        for k in range(4):
            Q[row, k] = base[k]
        for k in range(3):
            dp = scalar(0.0)
            dv = scalar(0.0)
            dw = scalar(0.0)
            if nb > 0:
                dp = dx[row, k]
                dv = dx[row, nb + nv + k]
                dw = dx[row, nb + nv + 3 + k]
            p[row, k] = p0[env, k] + dp
            base_linear[row, k] = base_v0[env, k] + dv
            base_angular[row, k] = base_v0[env, 3 + k] + dw
        for i in range(1, model.parent.shape[0]):
            kind = model.joint_type[i]
            a = jm.position_address(model, i)
            d = nb + jm.dof_address(model, i)
            if wp.static(multi_dof) and (kind == BALL or kind == FREE):
                r = 0
                if kind == FREE:
                    r = 3
                    for k in range(3):
                        s[row, a + k] = s0[env, a + k] + dx[row, d + k]
                turned = rotated(I.read4(s0, env, a + r), dx, row, d + r, 1)
                for k in range(4):
                    s[row, a + r + k] = turned[k]
            else:
                s[row, a] = s0[env, a] + dx[row, d]
        for j in range(nv):
            sdot[row, j] = sdot0[env, j] + dx[row, nb + nv + nb + j]

    @wp.kernel(module="unique")
    def state_tangent(
        model: B.Model,
        p: wp.array2d(dtype=scalar),
        Q: wp.array2d(dtype=scalar),
        s: wp.array2d(dtype=scalar),
        base_v: wp.array2d(dtype=scalar),
        sdot: wp.array2d(dtype=scalar),
        Q_ref: wp.array2d(dtype=scalar),
        s_ref: wp.array2d(dtype=scalar),
        copies: int,
        reference: int,
        nb: int,
        base_axes: int,
        # outputs
        y: wp.array2d(dtype=scalar),
    ):
        """y (N m, nx): the tangent coordinates of each row's state (p, Q, s, base_v (N m, 6), sdot) about the
        rotations of Q_ref and s_ref (read without gradients) at the row itself (reference < 0: its derivative is
        the state's tangent map, its rotation entries 0) or at copy `reference` of the row's environment (finite
        differences): positions as they are, rotations as `rotation_tangent`. Launched over N m."""
        row = wp.tid()
        at = row
        if reference >= 0:
            at = (row / copies) * copies + reference
        nv = sdot.shape[1]
        if nb > 0:
            for k in range(3):
                y[row, k] = p[row, k]
            turn = rotation_tangent(I.read4(Q, row, 0), I.read4(Q_ref, at, 0), base_axes)
            for k in range(3):
                y[row, 3 + k] = turn[k]
            for k in range(6):
                y[row, nb + nv + k] = base_v[row, k]
        for i in range(1, model.parent.shape[0]):
            kind = model.joint_type[i]
            a = jm.position_address(model, i)
            d = nb + jm.dof_address(model, i)
            if wp.static(multi_dof) and (kind == BALL or kind == FREE):
                r = 0
                if kind == FREE:
                    r = 3
                    for k in range(3):
                        y[row, d + k] = s[row, a + k]
                turn = rotation_tangent(I.read4(s, row, a + r), I.read4(s_ref, at, a + r), 1)
                for k in range(3):
                    y[row, d + r + k] = turn[k]
            else:
                y[row, d] = s[row, a]
        for j in range(nv):
            y[row, nb + nv + nb + j] = sdot[row, j]

    @wp.kernel(module="unique")
    def perturbations(copies: int, nx: int, h: scalar, u: wp.array2d(dtype=scalar), dx: wp.array2d(dtype=scalar), u_rows: wp.array2d(dtype=scalar)):
        """The copies of central differences (m = 2 (nx + nu) + 1 per environment): copy 2 k + (0, 1) moves the
        state's tangent entry k by (+h, -h), copy 2 nx + 2 j + (0, 1) control j of u (N, nu), the last copy
        nothing. dx (N m, nx) zeroed beforehand; u_rows (N m, nu). Launched over N m."""
        row = wp.tid()
        env = row / copies
        c = row % copies
        sign = scalar(1.0) - scalar(2.0) * scalar(c % 2)
        if c < 2 * nx:
            dx[row, c / 2] = sign * h
        for j in range(u.shape[1]):
            u_rows[row, j] = u[env, j]
        if c >= 2 * nx and c < copies - 1:
            j = (c - 2 * nx) / 2
            u_rows[row, j] = u[env, j] + sign * h

    @wp.kernel(module="unique")
    def central_differences(y: wp.array2d(dtype=scalar), copies: int, nx: int, h: scalar, A: wp.array3d(dtype=scalar), B: wp.array3d(dtype=scalar)):
        """A (N, nx, nx) and B (N, nx, nu) from the tangents y (N m, nx) of `perturbations`' copies: column k is
        (y[2 k] - y[2 k + 1]) / 2 h. Launched over (N, nx + nu)."""
        env, k = wp.tid()
        plus = env * copies + 2 * k
        for i in range(nx):
            d = (y[plus, i] - y[plus + 1, i]) / (scalar(2.0) * h)
            if k < nx:
                A[env, i, k] = d
            else:
                B[env, i, k - nx] = d

    @wp.kernel(module="unique")
    def replicate(src: wp.array2d(dtype=scalar), copies: int, dst: wp.array2d(dtype=scalar)):
        """dst[row, k] = src[row / copies, k]: each environment's row copied to its m rows; launched over dst."""
        row, k = wp.tid()
        dst[row, k] = src[row / copies, k]

    @wp.kernel(module="unique")
    def replicate_3d(src: wp.array3d(dtype=scalar), copies: int, dst: wp.array3d(dtype=scalar)):
        """dst[row, a, b] = src[row / copies, a, b]; launched over dst."""
        row, a, b = wp.tid()
        dst[row, a, b] = src[row / copies, a, b]

    @wp.kernel(module="unique")
    def poison_flagged(valid_rows: wp.array(dtype=wp.int32), copies: int, data_valid: wp.array(dtype=wp.int32), out: wp.array2d(dtype=scalar)):
        """out[e, k] = NaN where environment e was flagged in the data (data_valid (N,) 0) or any of its copies by
        the evaluation (valid_rows (N m,) 0); an empty array flags nothing. Launched over out (N, K)."""
        e, k = wp.tid()
        flagged = False
        if data_valid.shape[0] > 0:
            flagged = data_valid[e] == 0
        if valid_rows.shape[0] > 0:
            for c in range(copies):
                if valid_rows[e * copies + c] == 0:
                    flagged = True
        if flagged:
            out[e, k] = scalar(wp.nan)

    @wp.kernel(module="unique")
    def column(x: wp.array(dtype=scalar), y: wp.array2d(dtype=scalar)):
        """y[row, 0] = x[row], launched over x."""
        row = wp.tid()
        y[row, 0] = x[row]

    @wp.kernel(module="unique")
    def flatten(x: wp.array3d(dtype=scalar), y: wp.array2d(dtype=scalar)):
        """y[row, a * n + b] = x[row, a, b] (n = x.shape[2]), launched over x."""
        row, a, b = wp.tid()
        y[row, a * x.shape[2] + b] = x[row, a, b]

    @wp.kernel(module="unique")
    def seed_rows(copies: int, seed: wp.array2d(dtype=scalar)):
        """seed[row, row % copies] = 1: copy c of each environment seeds output c. Launched over N m."""
        row = wp.tid()
        seed[row, row % copies] = scalar(1.0)

    return types.SimpleNamespace(moved_state=moved_state, state_tangent=state_tangent, perturbations=perturbations,
                                 central_differences=central_differences, replicate=replicate, replicate_3d=replicate_3d, poison_flagged=poison_flagged, column=column, flatten=flatten, seed_rows=seed_rows)
