"""Integrators of the state, as JaxSim's (which integrate in the Inertial representation).

State x = (W_p_B, W_Q_B (w, x, y, z), s, W_v_WB (Inertial), sdot, m) with s (nq) the joints' positions and
sdot (nv) their velocities; the data stores the base velocity Mixed, [W_pdot_B; W_omega], converted here at
each end. Its derivative:
    W_pdot_B = v + omega x W_p_B,  W_Qdot_B = 1/2 (0, omega) (x) Q,  sdot (as position rates),  W_vdot_WB,
    sddot,  mdot,
where a joint's position rate is its velocity (revolute, prismatic), 1/2 Q (x) (0, omega) for a ball joint
(omega in child axes) and (v, 1/2 Q (x) (0, omega)) for a free one (`joint_position_rate`).
Semi-implicit Euler (JaxSim's default): velocities first, then positions with the new velocities,
    nu+ = nu + dt nu_dot;  p+ = p + dt (v+ + omega+ x p);  Q+ = normalise(Q + dt 1/2 (0, omega+) (x) Q);
    s+ = s + dt sdot+ (a ball or free joint's quaternion rotated exactly, Q+ = Q (x) exp(dt omega+ / 2), as
    MuJoCo's mj_integratePos);  m+ = m + dt mdot.
RK4: the classic four stages, contacts evaluated at each, the quaternions normalised at each stage.
Semi-implicit Euler on SO(3) (MuJoCo's Euler): the base's Mixed velocity integrated and its orientation
advanced by the exact rotation dt omega+ (see `so3_base_step`); the joints as above.

Health: an environment whose new state is not finite, or whose quaternion needed a normalisation by more than
`quaternion_tolerance` (|Q+| - 1 before normalising), is flagged (valid = 0) and keeps its state; so is one whose
state read has a velocity component (the base's Mixed velocity, the joints') beyond `divergence_speed` in
magnitude [m/s or rad/s]: a finite divergence, which the step before produced, flagged at the next step (the check
reads the state, not the new velocities: a tape's replay of the step recomputes those from buffers that later
launches overwrote, and its branch must be the forward's). An environment already flagged does not change.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import BALL, FREE, spatial


@factory
def kernels(scalar, multi_dof: bool):
    """The integrators in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)
    quat4 = wp.types.vector(4, scalar)

    @wp.func
    def quaternion_rate(Q: quat4, omega: sp.vec3):
        """1/2 (0, omega) (x) Q for Q = (w, x, y, z) and omega in world axes."""
        qv = sp.vec3(Q[1], Q[2], Q[3])
        r = scalar(0.5) * (Q[0] * omega + wp.cross(omega, qv))
        return quat4(scalar(-0.5) * wp.dot(omega, qv), r[0], r[1], r[2])

    @wp.func
    def rotation_step(Q: quat4, omega: sp.vec3, dt: scalar):
        """exp(dt omega / 2) as (cos h, sin(h) omega / |omega|), h = dt |omega| / 2 (a series below h^2 = 1e-8):
        the exact rotation by dt omega (w, x, y, z)."""
        h2 = scalar(0.25) * dt * dt * wp.dot(omega, omega)
        cos_h = scalar(1.0) - scalar(0.5) * h2 + h2 * h2 / scalar(24.0)
        k = scalar(0.5) * dt * (scalar(1.0) - h2 / scalar(6.0) + h2 * h2 / scalar(120.0))
        if h2 > scalar(1.0e-8):
            h = wp.sqrt(h2)
            cos_h = wp.cos(h)
            k = wp.sin(h) * scalar(0.5) * dt / h
        e = k * omega
        return quat4(cos_h, e[0], e[1], e[2])

    @wp.func
    def quaternion_product(a: quat4, b: quat4):
        """a (x) b, both (w, x, y, z)."""
        av = sp.vec3(a[1], a[2], a[3])
        bv = sp.vec3(b[1], b[2], b[3])
        r = a[0] * bv + b[0] * av + wp.cross(av, bv)
        return quat4(a[0] * b[0] - wp.dot(av, bv), r[0], r[1], r[2])

    @wp.func
    def body_rotated(Q: quat4, omega: sp.vec3, dt: scalar):
        """Q (x) exp(dt omega / 2), normalised: Q (w, x, y, z; normalised first) turned by dt omega in its own axes (a
        ball or free joint's rotation step)."""
        Q_next = quaternion_product(Q / wp.length(Q), rotation_step(Q, omega, dt))
        return Q_next / wp.length(Q_next)

    @wp.func
    def read4(a: wp.array2d(dtype=scalar), env: int, offset: int):
        return quat4(a[env, offset], a[env, offset + 1], a[env, offset + 2], a[env, offset + 3])

    @wp.func
    def euler_coordinate(position: scalar, velocity: scalar, acceleration: scalar, dt: scalar):
        """(position+, velocity+) of one coordinate by semi-implicit Euler: the velocity first, the position with
        the new velocity."""
        velocity_next = velocity + dt * acceleration
        return position + dt * velocity_next, velocity_next

    @wp.func
    def euler_rate(value: scalar, rate: scalar, dt: scalar):
        """value + dt rate: a first-order state (the contact deformation) by explicit Euler."""
        return value + dt * rate

    @wp.func
    def rotating_joint_step(kind: int, a: int, d: int, env: int, dt: scalar, x: B.State, acc: sp.vec6, write: bool, y: B.State, divergence_speed: scalar):
        """A ball or free joint (its positions from a, its DoFs from d) stepped by semi-implicit Euler (the module
        docstring) from x with its DoFs' accelerations acc (a ball joint's 3 first, a free joint's 6): written to
        y when `write`; returns 0, or NaN when a new value is not finite or a velocity read is beyond
        `divergence_speed` (the health check's)."""
        nonfinite = scalar(0.0)
        r = 0  # the quaternion's first position, its rotation's first DoF
        if kind == FREE:
            r = 3
            for k in range(3):
                p_next, v_next = euler_coordinate(x.joint_positions[env, a + k], x.joint_velocities[env, d + k], acc[k], dt)
                nonfinite = poison(poison(poison_speed(nonfinite, x.joint_velocities[env, d + k], divergence_speed), v_next), p_next)
                if write:
                    y.joint_velocities[env, d + k] = v_next
                    y.joint_positions[env, a + k] = p_next
        b = d + r  # the rotation's first DoF
        omega = read3(x.joint_velocities, env, b) + dt * sp.vec3(acc[r], acc[r + 1], acc[r + 2])
        for k in range(3):
            nonfinite = poison(poison_speed(nonfinite, x.joint_velocities[env, b + k], divergence_speed), omega[k])
            if write:
                y.joint_velocities[env, b + k] = omega[k]
        Q_next = body_rotated(read4(x.joint_positions, env, a + r), omega, dt)
        for k in range(4):
            nonfinite = poison(nonfinite, Q_next[k])
            if write:
                y.joint_positions[env, a + r + k] = Q_next[k]
        return nonfinite

    @wp.func
    def joint_euler_step(
        model: B.Model, i: int, env: int, dt: scalar, x: B.State, nu_dot: wp.array2d(dtype=scalar), write: bool, y: B.State, divergence_speed: scalar
    ):
        """Link i's joint stepped by semi-implicit Euler (the module docstring), from x with the accelerations
        nu_dot[env, 6 + d]: written to y when `write`; returns 0, or NaN when a new value is not finite or a
        velocity read is beyond `divergence_speed` (the health check's). Per joint kind, its loops of fixed length."""
        kind = model.joint_type[i]
        a = jm.position_address(model, i)
        d = jm.dof_address(model, i)
        nonfinite = scalar(0.0)
        if wp.static(multi_dof) and (kind == BALL or kind == FREE):
            zero = scalar(0.0)
            acc = sp.vec6(nu_dot[env, 6 + d], nu_dot[env, 7 + d], nu_dot[env, 8 + d], zero, zero, zero)
            if kind == FREE:
                acc = sp.vec6(nu_dot[env, 6 + d], nu_dot[env, 7 + d], nu_dot[env, 8 + d], nu_dot[env, 9 + d], nu_dot[env, 10 + d], nu_dot[env, 11 + d])
            nonfinite = rotating_joint_step(kind, a, d, env, dt, x, acc, write, y, divergence_speed)
        else:
            sd = x.joint_velocities[env, d]
            s_next, sd_next = euler_coordinate(x.joint_positions[env, a], sd, nu_dot[env, 6 + d], dt)
            nonfinite = poison(poison(poison_speed(nonfinite, sd, divergence_speed), sd_next), s_next)
            if write:
                y.joint_velocities[env, d] = sd_next
                y.joint_positions[env, a] = s_next
        return nonfinite

    @wp.func
    def joint_position_rate(model: B.Model, i: int, env: int, x: B.State, k: wp.array2d(dtype=scalar), at: int):
        """Link i's joint's position rate (the module docstring) at x, written to k[env, at + q] for its
        positions q."""
        kind = model.joint_type[i]
        a = jm.position_address(model, i)
        d = jm.dof_address(model, i)
        if wp.static(multi_dof) and (kind == BALL or kind == FREE):
            r = 0
            if kind == FREE:
                r = 3
                for c in range(3):
                    k[env, at + a + c] = x.joint_velocities[env, d + c]
            Q = read4(x.joint_positions, env, a + r)
            omega = sp.vec3(x.joint_velocities[env, d + r], x.joint_velocities[env, d + r + 1], x.joint_velocities[env, d + r + 2])
            rate = scalar(0.5) * quaternion_product(Q / wp.length(Q), quat4(scalar(0.0), omega[0], omega[1], omega[2]))
            for c in range(4):
                k[env, at + a + r + c] = rate[c]
        else:
            k[env, at + a] = x.joint_velocities[env, d]

    @wp.func
    def slope_sum(k1: wp.array2d(dtype=scalar), k2: wp.array2d(dtype=scalar), k3: wp.array2d(dtype=scalar), k4: wp.array2d(dtype=scalar),
                  env: int, c: int, rk4: bool):
        """Entry c of k1 + 2 (k2 + k3) + k4 (rk4), else of k1 alone."""
        if rk4:
            return k1[env, c] + scalar(2.0) * (k2[env, c] + k3[env, c]) + k4[env, c]
        return k1[env, c]

    @wp.func
    def combine_positions(
        model: B.Model, i: int, env: int, x: wp.array2d(dtype=scalar), k1: wp.array2d(dtype=scalar), k2: wp.array2d(dtype=scalar),
        k3: wp.array2d(dtype=scalar), k4: wp.array2d(dtype=scalar), w: scalar, rk4: bool, out: wp.array2d(dtype=scalar),
    ):
        """Link i's joint's positions x + w (k1 + 2 (k2 + k3) + k4) (rk4: RK4's combination), or x + w k1 (a stage),
        of the slopes' position rates at 7 + q, its quaternion, if any, normalised, written once to out (N, nq);
        returns 0, or NaN when a value is not finite (the health check's)."""
        kind = model.joint_type[i]
        a = jm.position_address(model, i)
        nonfinite = scalar(0.0)
        if wp.static(multi_dof) and (kind == BALL or kind == FREE):
            r = 0
            if kind == FREE:
                r = 3
                for c in range(3):
                    value = x[env, a + c] + w * slope_sum(k1, k2, k3, k4, env, 7 + a + c, rk4)
                    nonfinite = poison(nonfinite, value)
                    out[env, a + c] = value
            b = a + r
            Q = read4(x, env, b)
            step = quat4(slope_sum(k1, k2, k3, k4, env, 7 + b, rk4), slope_sum(k1, k2, k3, k4, env, 8 + b, rk4),
                         slope_sum(k1, k2, k3, k4, env, 9 + b, rk4), slope_sum(k1, k2, k3, k4, env, 10 + b, rk4))
            Q = Q / wp.length(Q) + w * step
            Q = Q / wp.length(Q)
            for c in range(4):
                nonfinite = poison(nonfinite, Q[c])
                out[env, b + c] = Q[c]
        else:
            value = x[env, a] + w * slope_sum(k1, k2, k3, k4, env, 7 + a, rk4)
            nonfinite = poison(nonfinite, value)
            out[env, a] = value
        return nonfinite

    @wp.func
    def finite3(v: sp.vec3):
        return wp.isfinite(v[0]) and wp.isfinite(v[1]) and wp.isfinite(v[2])

    @wp.func
    def poison(acc: scalar, value: scalar):
        """acc + 0 value: NaN once a value is NaN or +-inf (0 inf is NaN), 0 otherwise. The health checks of
        the integrators sum it over the state instead of `ok = ok and isfinite(...)`, whose short circuit makes
        every load wait for the previous one (a chain of ~130 loads per environment)."""
        return acc + scalar(0.0) * value

    @wp.func
    def poison_speed(acc: scalar, value: scalar, bound: scalar):
        """`poison` of a velocity read, also NaN where |value| > bound (a finite divergence; bound = inf: never): a
        select, not a branch, and no adjoint through it (a flagged environment's gradients stay finite)."""
        return poison(acc, value) + wp.where(wp.abs(value) <= bound, scalar(0.0), scalar(wp.nan))

    @wp.func
    def within3(v: sp.vec3, bound: scalar):
        """|v| <= bound componentwise (False for a NaN)."""
        return wp.abs(v[0]) <= bound and wp.abs(v[1]) <= bound and wp.abs(v[2]) <= bound

    @wp.kernel(module="unique")
    def flag_fast_state(divergence_speed: scalar, x: B.State):
        """x.valid[env] = 0 where x has a velocity component (the base's Mixed velocity, each joint's) beyond
        `divergence_speed` or a non-finite one: the integrators' check of the state they read, on a state that no step
        has read yet (a Stepper call's last, warpdyn.engine.stepper); the state is kept."""
        env = wp.tid()
        speeding = scalar(0.0)
        for j in range(x.joint_velocities.shape[1]):
            speeding = poison_speed(speeding, x.joint_velocities[env, j], divergence_speed)
        ok = within3(read3(x.base_velocity, env, 0), divergence_speed) and within3(read3(x.base_velocity, env, 3), divergence_speed)
        if not (ok and wp.isfinite(speeding)):
            x.valid[env] = 0

    @wp.func
    def keep_state(env: int, x: B.State, y: B.State):
        """A flagged environment: its next state y is its state x, and y.valid = 0."""
        for a in range(3):
            y.base_position[env, a] = x.base_position[env, a]
            y.base_velocity[env, a] = x.base_velocity[env, a]
            y.base_velocity[env, 3 + a] = x.base_velocity[env, 3 + a]
        for a in range(4):
            y.base_quaternion[env, a] = x.base_quaternion[env, a]
        for q in range(x.joint_positions.shape[1]):
            y.joint_positions[env, q] = x.joint_positions[env, q]
        for j in range(x.joint_velocities.shape[1]):
            y.joint_velocities[env, j] = x.joint_velocities[env, j]
        for c in range(x.tangential_deformation.shape[1]):
            for a in range(3):
                y.tangential_deformation[env, c, a] = x.tangential_deformation[env, c, a]
        y.valid[env] = 0

    @wp.func
    def quaternion_of(x: B.State, env: int):
        Q = x.base_quaternion
        return quat4(Q[env, 0], Q[env, 1], Q[env, 2], Q[env, 3])

    @wp.func
    def read3(a: wp.array2d(dtype=scalar), env: int, offset: int):
        return sp.vec3(a[env, offset], a[env, offset + 1], a[env, offset + 2])

    @wp.func
    def jaxsim_base_step(dt: scalar, p: sp.vec3, Q: quat4, pdot: sp.vec3, omega: sp.vec3, vdot: sp.vec3, omega_dot: sp.vec3):
        """JaxSim's semi-implicit Euler of the base (see the module docstring): (p+, pdot+, omega+, Q+, |Q+| before
        normalising)."""
        v_next = pdot - wp.cross(omega, p) + dt * vdot
        omega_next = omega + dt * omega_dot
        p_next = p + dt * (v_next + wp.cross(omega_next, p))
        Q_step = Q + dt * quaternion_rate(Q, omega_next)
        Q_norm = wp.length(Q_step)
        return p_next, v_next + wp.cross(omega_next, p_next), omega_next, Q_step / Q_norm, Q_norm

    @wp.func
    def so3_base_step(dt: scalar, p: sp.vec3, Q: quat4, pdot: sp.vec3, omega: sp.vec3, vdot: sp.vec3, omega_dot: sp.vec3):
        """MuJoCo's Euler of the base: the Mixed velocity integrated, pdot+ = pdot + dt pddot with
        pddot = vdot + omegadot x p + omega x pdot, omega+ = omega + dt omegadot; then p+ = p + dt pdot+ and
        Q+ = exp(dt omega+ / 2) (x) Q, the exact rotation by dt omega+ (world axes; MuJoCo's
        Q (x) exp(dt B_omega+ / 2) with B_omega+ = R^T omega+). Returns (p+, pdot+, omega+, Q+, 1)."""
        pdot_next = pdot + dt * (vdot + wp.cross(omega_dot, p) + wp.cross(omega, pdot))
        omega_next = omega + dt * omega_dot
        Q_next = quaternion_product(rotation_step(Q, omega_next, dt), Q)
        return p + dt * pdot_next, pdot_next, omega_next, Q_next / wp.length(Q_next), scalar(1.0)

    @wp.func
    def base_state(x: B.State, env: int):
        """Environment env's base in x: (position p, quaternion Q (w, x, y, z) as stored, Mixed velocity pdot and
        omega, healthy)."""
        return read3(x.base_position, env, 0), quaternion_of(x, env), read3(x.base_velocity, env, 0), read3(x.base_velocity, env, 3), x.valid[env] != 0

    @wp.func
    def euler_base(so3: int, dt: scalar, quaternion_tolerance: scalar, divergence_speed: scalar, x: B.State, env: int, vdot: sp.vec3, omega_dot: sp.vec3):
        """The semi-implicit Euler step of environment env's base with MuJoCo's base step (so3 != 0) or JaxSim's,
        from the Inertial base acceleration (vdot, omega_dot): (p+, pdot+, omega+, Q+, ok), ok when the
        environment is healthy, its velocity read within `divergence_speed`, the quaternion within
        `quaternion_tolerance` (see the kernel) and all finite."""
        p, Q, pdot, omega, healthy = base_state(x, env)
        return euler_base_from(so3, dt, quaternion_tolerance, divergence_speed, p, Q, pdot, omega, healthy, vdot, omega_dot)

    @wp.func
    def euler_base_from(
        so3: int,
        dt: scalar,
        quaternion_tolerance: scalar,
        divergence_speed: scalar,
        p: sp.vec3,
        Q: quat4,
        pdot: sp.vec3,
        omega: sp.vec3,
        healthy: bool,
        vdot: sp.vec3,
        omega_dot: sp.vec3,
    ):
        """`euler_base` from the base's `base_state`."""
        Q_read = wp.length(Q)
        Q = Q / Q_read
        if so3 != 0:
            p_next, pdot_next, omega_next, Q_next, Q_norm = so3_base_step(dt, p, Q, pdot, omega, vdot, omega_dot)
            Q_norm = Q_read
        else:
            p_next, pdot_next, omega_next, Q_next, Q_norm = jaxsim_base_step(dt, p, Q, pdot, omega, vdot, omega_dot)
        ok = healthy and wp.abs(Q_norm - scalar(1.0)) <= quaternion_tolerance
        ok = ok and finite3(p_next) and finite3(pdot_next) and finite3(omega_next) and wp.isfinite(Q_norm) and wp.isfinite(Q_next[0])
        ok = ok and within3(pdot, divergence_speed) and within3(omega, divergence_speed)
        return p_next, pdot_next, omega_next, Q_next, ok

    @wp.func
    def write_base(env: int, y: B.State, p: sp.vec3, pdot: sp.vec3, omega: sp.vec3, Q: quat4):
        """y's base position, Mixed velocity [pdot; omega] and quaternion (w, x, y, z) of environment env."""
        for a in range(3):
            y.base_position[env, a] = p[a]
            y.base_velocity[env, a] = pdot[a]
            y.base_velocity[env, 3 + a] = omega[a]
        for a in range(4):
            y.base_quaternion[env, a] = Q[a]

    def euler(so3: bool):
        """The semi-implicit Euler kernel with JaxSim's base step, or MuJoCo's (so3)."""
        SO3 = wp.constant(int(so3))

        @wp.kernel(module="unique")
        def semi_implicit_euler(
            model: B.Model,
            dt: scalar,
            quaternion_tolerance: scalar,
            divergence_speed: scalar,
            x: B.State,
            # derivatives at t
            nu_dot: wp.array2d(dtype=scalar),
            # in and out: where `contact_state_euler` found a non-finite deformation (N,), reset to 0
            contact_flags: wp.array(dtype=int),
            # outputs: the state at t + dt
            y: B.State,
        ):
            """One semi-implicit Euler step from x to y but the contact state, which `contact_state_euler` stepped
            before (launched over N rows, a thread per row: one thread per environment walked thousands of slots
            in series); nu_dot (N, 6 + nv) is [W_vdot_WB (Inertial); sddot]. The quaternion tolerance bounds |Q+| -
            1 before normalising (JaxSim's), |Q| - 1 of the state read (SO3); a velocity read beyond
            `divergence_speed` flags as a non-finite one. A flagged environment keeps all of x, its contact state too."""
            env = wp.tid()
            p_next, pdot_next, omega_next, Q_next, ok = euler_base(SO3, dt, quaternion_tolerance, divergence_speed, x, env, read3(nu_dot, env, 0), read3(nu_dot, env, 3))
            nL = model.parent.shape[0]
            nonfinite = scalar(0.0)
            for i in range(1, nL):
                nonfinite = nonfinite + joint_euler_step(model, i, env, dt, x, nu_dot, False, y, divergence_speed)
            ok = ok and wp.isfinite(nonfinite) and contact_flags[env] == 0
            contact_flags[env] = 0
            if ok:
                write_base(env, y, p_next, pdot_next, omega_next, Q_next)
                for i in range(1, nL):
                    joint_euler_step(model, i, env, dt, x, nu_dot, True, y, divergence_speed)
                y.valid[env] = 1
            else:
                keep_state(env, x, y)

        return semi_implicit_euler

    semi_implicit_euler = euler(False)
    semi_implicit_euler_so3 = euler(True)

    @wp.kernel(module="unique")
    def contact_state_euler(
        dt: scalar,
        x: B.State,
        m_dot: wp.array3d(dtype=scalar),
        env_fastest: int,
        # outputs: y's contact state; contact_flags[env] = 1 where a row of it is not finite
        contact_flags: wp.array(dtype=int),
        y: B.State,
    ):
        """The semi-implicit Euler step of the contact state, m+ = m + dt m_dot (N, rows, 3), launched over N rows
        threads (order: bundles.env_and_item), before `semi_implicit_euler`, which reads and resets contact_flags
        and keeps x's contact state in a flagged environment."""
        env, c = B.env_and_item(wp.tid(), x.valid.shape[0], x.tangential_deformation.shape[1], env_fastest)
        m = x.tangential_deformation
        nonfinite = scalar(0.0)
        for a in range(3):
            value = euler_rate(m[env, c, a], m_dot[env, c, a], dt)
            y.tangential_deformation[env, c, a] = value
            nonfinite = poison(nonfinite, value)
        if not wp.isfinite(nonfinite):
            contact_flags[env] = 1

    @wp.kernel(module="unique")
    def slope(
        model: B.Model,
        x: B.State,
        # its accelerations
        base_acceleration: wp.array2d(dtype=scalar),
        joint_accelerations: wp.array2d(dtype=scalar),
        m_dot: wp.array3d(dtype=scalar),
        # outputs
        k: wp.array2d(dtype=scalar),
    ):
        """k (N, 13 + nq + nv + 3 nc) = d/dt (p, Q, s, v (Inertial), sdot, m) at the stage x, in that order (s's
        rate: `joint_position_rate`)."""
        env = wp.tid()
        nq = x.joint_positions.shape[1]
        nv = x.joint_velocities.shape[1]
        Q = quaternion_of(x, env)
        Qdot = quaternion_rate(Q / wp.length(Q), read3(x.base_velocity, env, 3))
        for a in range(3):
            k[env, a] = x.base_velocity[env, a]
            k[env, 7 + nq + a] = base_acceleration[env, a]
            k[env, 10 + nq + a] = base_acceleration[env, 3 + a]
        for a in range(4):
            k[env, 3 + a] = Qdot[a]
        for i in range(1, model.parent.shape[0]):
            joint_position_rate(model, i, env, x, k, 7)
        for j in range(nv):
            k[env, 13 + nq + j] = joint_accelerations[env, j]
        for c in range(x.tangential_deformation.shape[1]):
            for a in range(3):
                k[env, 13 + nq + nv + 3 * c + a] = m_dot[env, c, a]

    @wp.kernel(module="unique")
    def rk4_stage(
        model: B.Model,
        h: scalar,
        x: B.State,
        k: wp.array2d(dtype=scalar),
        # outputs: the stage x + h k, quaternions normalised, base velocity Mixed (its valid is not written)
        stage: B.State,
    ):
        env = wp.tid()
        nq = x.joint_positions.shape[1]
        nv = x.joint_velocities.shape[1]
        p = read3(x.base_position, env, 0)
        omega = read3(x.base_velocity, env, 3)
        v = read3(x.base_velocity, env, 0) - wp.cross(omega, p)
        p_h = p + h * read3(k, env, 0)
        v_h = v + h * read3(k, env, 7 + nq)
        omega_h = omega + h * read3(k, env, 10 + nq)
        Q = quaternion_of(x, env)
        Q_h = Q / wp.length(Q) + h * quat4(k[env, 3], k[env, 4], k[env, 5], k[env, 6])
        Q_h = Q_h / wp.length(Q_h)
        write_base(env, stage, p_h, v_h + wp.cross(omega_h, p_h), omega_h, Q_h)
        for i in range(1, model.parent.shape[0]):
            combine_positions(model, i, env, x.joint_positions, k, k, k, k, h, False, stage.joint_positions)
        for j in range(nv):
            stage.joint_velocities[env, j] = x.joint_velocities[env, j] + h * k[env, 13 + nq + j]
        m = x.tangential_deformation
        for c in range(m.shape[1]):
            for a in range(3):
                stage.tangential_deformation[env, c, a] = m[env, c, a] + h * k[env, 13 + nq + nv + 3 * c + a]

    @wp.kernel(module="unique")
    def rk4_combine(
        model: B.Model,
        dt: scalar,
        quaternion_tolerance: scalar,
        divergence_speed: scalar,
        x: B.State,
        # slopes of the four stages
        k1: wp.array2d(dtype=scalar),
        k2: wp.array2d(dtype=scalar),
        k3: wp.array2d(dtype=scalar),
        k4: wp.array2d(dtype=scalar),
        # outputs: the state at t + dt
        y: B.State,
    ):
        """y = x + dt (k1 + 2 k2 + 2 k3 + k4) / 6, quaternions normalised; health as in semi_implicit_euler."""
        env = wp.tid()
        nq = x.joint_positions.shape[1]
        nv = x.joint_velocities.shape[1]
        m = x.tangential_deformation
        w = dt / scalar(6.0)
        p = read3(x.base_position, env, 0)
        omega = read3(x.base_velocity, env, 3)
        v = read3(x.base_velocity, env, 0) - wp.cross(omega, p)
        p_next = p + w * (read3(k1, env, 0) + scalar(2.0) * (read3(k2, env, 0) + read3(k3, env, 0)) + read3(k4, env, 0))
        v_next = v + w * (read3(k1, env, 7 + nq) + scalar(2.0) * (read3(k2, env, 7 + nq) + read3(k3, env, 7 + nq)) + read3(k4, env, 7 + nq))
        omega_next = omega + w * (
            read3(k1, env, 10 + nq) + scalar(2.0) * (read3(k2, env, 10 + nq) + read3(k3, env, 10 + nq)) + read3(k4, env, 10 + nq)
        )
        Q = quaternion_of(x, env)
        dQ = quat4(
            k1[env, 3] + scalar(2.0) * (k2[env, 3] + k3[env, 3]) + k4[env, 3],
            k1[env, 4] + scalar(2.0) * (k2[env, 4] + k3[env, 4]) + k4[env, 4],
            k1[env, 5] + scalar(2.0) * (k2[env, 5] + k3[env, 5]) + k4[env, 5],
            k1[env, 6] + scalar(2.0) * (k2[env, 6] + k3[env, 6]) + k4[env, 6],
        )
        Q_step = Q / wp.length(Q) + w * dQ
        Q_norm = wp.length(Q_step)
        Q_next = Q_step / Q_norm
        pdot_next = v_next + wp.cross(omega_next, p_next)
        ok = x.valid[env] != 0 and wp.abs(Q_norm - scalar(1.0)) <= quaternion_tolerance
        ok = ok and finite3(p_next) and finite3(pdot_next) and finite3(omega_next) and wp.isfinite(Q_norm)
        ok = ok and within3(read3(x.base_velocity, env, 0), divergence_speed) and within3(omega, divergence_speed)
        nonfinite = scalar(0.0)
        for q in range(nq):
            nonfinite = poison(nonfinite, k1[env, 7 + q] + k2[env, 7 + q] + k3[env, 7 + q] + k4[env, 7 + q])
        for j in range(nv):
            nonfinite = poison(nonfinite, k1[env, 13 + nq + j] + k2[env, 13 + nq + j] + k3[env, 13 + nq + j] + k4[env, 13 + nq + j])
            nonfinite = poison_speed(nonfinite, x.joint_velocities[env, j], divergence_speed)
        for c in range(3 * m.shape[1]):
            i = 13 + nq + nv + c
            nonfinite = poison(nonfinite, k1[env, i] + k2[env, i] + k3[env, i] + k4[env, i])
        ok = ok and wp.isfinite(nonfinite)
        if ok:
            write_base(env, y, p_next, pdot_next, omega_next, Q_next)
            for L in range(1, model.parent.shape[0]):
                combine_positions(model, L, env, x.joint_positions, k1, k2, k3, k4, w, True, y.joint_positions)
            for j in range(nv):
                i2 = 13 + nq + j
                y.joint_velocities[env, j] = x.joint_velocities[env, j] + w * (
                    k1[env, i2] + scalar(2.0) * (k2[env, i2] + k3[env, i2]) + k4[env, i2]
                )
            for c in range(m.shape[1]):
                for a in range(3):
                    i3 = 13 + nq + nv + 3 * c + a
                    y.tangential_deformation[env, c, a] = m[env, c, a] + w * (k1[env, i3] + scalar(2.0) * (k2[env, i3] + k3[env, i3]) + k4[env, i3])
            y.valid[env] = 1
        else:
            keep_state(env, x, y)

    def state_size(nq: int, nv: int, nc: int) -> int:
        """The length of x = (p, Q, s, v, sdot, m): 3 + 4 + nq + 6 + nv + 3 nc."""
        return 13 + nq + nv + 3 * nc

    return types.SimpleNamespace(
        quaternion_rate=quaternion_rate,
        rotation_step=rotation_step,
        quaternion_product=quaternion_product,
        body_rotated=body_rotated,
        quaternion_of=quaternion_of,
        read4=read4,
        poison=poison,
        poison_speed=poison_speed,
        euler_coordinate=euler_coordinate,
        euler_rate=euler_rate,
        rotating_joint_step=rotating_joint_step,
        keep_state=keep_state,
        flag_fast_state=flag_fast_state,
        euler_base=euler_base,
        base_state=base_state,
        euler_base_from=euler_base_from,
        write_base=write_base,
        semi_implicit_euler=semi_implicit_euler,
        semi_implicit_euler_so3=semi_implicit_euler_so3,
        contact_state_euler=contact_state_euler,
        slope=slope,
        rk4_stage=rk4_stage,
        rk4_combine=rk4_combine,
        state_size=state_size,
        quat4=quat4,
    )
