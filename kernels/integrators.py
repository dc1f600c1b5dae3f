"""Integrators of the state, as JaxSim's (which integrate in the Inertial representation).

State x = (W_p_B, W_Q_B (w, x, y, z), s, W_v_WB (Inertial), sdot, m); the data stores the base velocity
Mixed, [W_pdot_B; W_omega], converted here at each end. Its derivative:
    W_pdot_B = v + omega x W_p_B,  W_Qdot_B = 1/2 (0, omega) (x) Q,  sdot,  W_vdot_WB,  sddot,  mdot.
Semi-implicit Euler (JaxSim's default): velocities first, then positions with the new velocities,
    nu+ = nu + dt nu_dot;  p+ = p + dt (v+ + omega+ x p);  Q+ = normalise(Q + dt 1/2 (0, omega+) (x) Q);
    s+ = s + dt sdot+;  m+ = m + dt mdot.
RK4: the classic four stages, contacts evaluated at each, the quaternion normalised at each stage.
Semi-implicit Euler on SO(3) (MuJoCo's Euler): the base's Mixed velocity integrated and its orientation
advanced by the exact rotation dt omega+ (see `so3_base_step`); the joints as above.

Health: an environment whose new state is not finite, or whose quaternion needed a normalisation by more
than `quaternion_tolerance` (|Q+| - 1 before normalising), is flagged (valid = 0) and keeps its state;
an environment already flagged does not change.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import spatial


@factory
def kernels(scalar):
    sp = spatial(scalar)
    B = bundles(scalar)
    quat4 = wp.types.vector(4, scalar)

    @wp.func
    def quaternion_rate(Q: quat4, omega: sp.vec3):
        """1/2 (0, omega) (x) Q for Q = (w, x, y, z) and omega in world axes."""
        qv = sp.vec3(Q[1], Q[2], Q[3])
        r = scalar(0.5) * (Q[0] * omega + wp.cross(omega, qv))
        return quat4(scalar(-0.5) * wp.dot(omega, qv), r[0], r[1], r[2])

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
    def keep_state(env: int, x: B.State, y: B.State):
        """A flagged environment: its next state y is its state x, and y.valid = 0."""
        for a in range(3):
            y.base_position[env, a] = x.base_position[env, a]
            y.base_velocity[env, a] = x.base_velocity[env, a]
            y.base_velocity[env, 3 + a] = x.base_velocity[env, 3 + a]
        for a in range(4):
            y.base_quaternion[env, a] = x.base_quaternion[env, a]
        for j in range(x.joint_positions.shape[1]):
            y.joint_positions[env, j] = x.joint_positions[env, j]
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
        # exp(dt omega+ / 2) = (cos h, sin(h) omega+ / |omega+|), h = dt |omega+| / 2 (series below 1e-4)
        h2 = scalar(0.25) * dt * dt * wp.dot(omega_next, omega_next)
        cos_h = scalar(1.0) - scalar(0.5) * h2 + h2 * h2 / scalar(24.0)
        k = scalar(0.5) * dt * (scalar(1.0) - h2 / scalar(6.0) + h2 * h2 / scalar(120.0))
        if h2 > scalar(1.0e-8):
            h = wp.sqrt(h2)
            cos_h = wp.cos(h)
            k = wp.sin(h) * scalar(0.5) * dt / h
        e = k * omega_next
        qv = sp.vec3(Q[1], Q[2], Q[3])
        r = cos_h * qv + Q[0] * e + wp.cross(e, qv)
        Q_next = quat4(cos_h * Q[0] - wp.dot(e, qv), r[0], r[1], r[2])
        return p + dt * pdot_next, pdot_next, omega_next, Q_next / wp.length(Q_next), scalar(1.0)

    @wp.func
    def base_state(x: B.State, env: int):
        """Environment env's base in x: (position p, quaternion Q (w, x, y, z) as stored, Mixed velocity pdot and
        omega, healthy)."""
        return read3(x.base_position, env, 0), quaternion_of(x, env), read3(x.base_velocity, env, 0), read3(x.base_velocity, env, 3), x.valid[env] != 0

    @wp.func
    def euler_base(so3: int, dt: scalar, quaternion_tolerance: scalar, x: B.State, env: int, vdot: sp.vec3, omega_dot: sp.vec3):
        """The semi-implicit Euler step of environment env's base with MuJoCo's base step (so3 != 0) or JaxSim's,
        from the Inertial base acceleration (vdot, omega_dot): (p+, pdot+, omega+, Q+, ok), ok when the
        environment is healthy, the quaternion within `quaternion_tolerance` (see the kernel) and all finite."""
        p, Q, pdot, omega, healthy = base_state(x, env)
        return euler_base_from(so3, dt, quaternion_tolerance, p, Q, pdot, omega, healthy, vdot, omega_dot)

    @wp.func
    def euler_base_from(
        so3: int, dt: scalar, quaternion_tolerance: scalar, p: sp.vec3, Q: quat4, pdot: sp.vec3, omega: sp.vec3, healthy: bool, vdot: sp.vec3, omega_dot: sp.vec3
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
            dt: scalar,
            quaternion_tolerance: scalar,
            x: B.State,
            # derivatives at t
            nu_dot: wp.array2d(dtype=scalar),
            m_dot: wp.array3d(dtype=scalar),
            # outputs: the state at t + dt
            y: B.State,
        ):
            """One semi-implicit Euler step from x to y; nu_dot (N, 6 + n) is [W_vdot_WB (Inertial); sddot]. The
            quaternion tolerance bounds |Q+| - 1 before normalising (JaxSim's), |Q| - 1 of the state read (SO3)."""
            env = wp.tid()
            p_next, pdot_next, omega_next, Q_next, ok = euler_base(SO3, dt, quaternion_tolerance, x, env, read3(nu_dot, env, 0), read3(nu_dot, env, 3))
            n = x.joint_positions.shape[1]
            m = x.tangential_deformation
            nonfinite = scalar(0.0)
            for j in range(n):
                sd_next = x.joint_velocities[env, j] + dt * nu_dot[env, 6 + j]
                nonfinite = poison(poison(nonfinite, sd_next), x.joint_positions[env, j] + dt * sd_next)
            for c in range(m.shape[1]):
                for a in range(3):
                    nonfinite = poison(nonfinite, m[env, c, a] + dt * m_dot[env, c, a])
            ok = ok and wp.isfinite(nonfinite)
            if ok:
                write_base(env, y, p_next, pdot_next, omega_next, Q_next)
                for j in range(n):
                    sd_next = x.joint_velocities[env, j] + dt * nu_dot[env, 6 + j]
                    y.joint_velocities[env, j] = sd_next
                    y.joint_positions[env, j] = x.joint_positions[env, j] + dt * sd_next
                for c in range(m.shape[1]):
                    for a in range(3):
                        y.tangential_deformation[env, c, a] = m[env, c, a] + dt * m_dot[env, c, a]
                y.valid[env] = 1
            else:
                keep_state(env, x, y)

        return semi_implicit_euler

    semi_implicit_euler = euler(False)
    semi_implicit_euler_so3 = euler(True)

    @wp.kernel(module="unique")
    def slope(
        x: B.State,
        # its accelerations
        base_acceleration: wp.array2d(dtype=scalar),
        joint_accelerations: wp.array2d(dtype=scalar),
        m_dot: wp.array3d(dtype=scalar),
        # outputs
        k: wp.array2d(dtype=scalar),
    ):
        """k (N, 13 + 2n + 3 nc) = d/dt (p, Q, s, v (Inertial), sdot, m) at the stage x, in that order."""
        env = wp.tid()
        n = x.joint_positions.shape[1]
        Q = quaternion_of(x, env)
        Qdot = quaternion_rate(Q / wp.length(Q), read3(x.base_velocity, env, 3))
        for a in range(3):
            k[env, a] = x.base_velocity[env, a]
            k[env, 7 + n + a] = base_acceleration[env, a]
            k[env, 10 + n + a] = base_acceleration[env, 3 + a]
        for a in range(4):
            k[env, 3 + a] = Qdot[a]
        for j in range(n):
            k[env, 7 + j] = x.joint_velocities[env, j]
            k[env, 13 + n + j] = joint_accelerations[env, j]
        for c in range(x.tangential_deformation.shape[1]):
            for a in range(3):
                k[env, 13 + 2 * n + 3 * c + a] = m_dot[env, c, a]

    @wp.kernel(module="unique")
    def rk4_stage(
        h: scalar,
        x: B.State,
        k: wp.array2d(dtype=scalar),
        # outputs: the stage x + h k, quaternion normalised, base velocity Mixed (its valid is not written)
        stage: B.State,
    ):
        env = wp.tid()
        n = x.joint_positions.shape[1]
        p = read3(x.base_position, env, 0)
        omega = read3(x.base_velocity, env, 3)
        v = read3(x.base_velocity, env, 0) - wp.cross(omega, p)
        p_h = p + h * read3(k, env, 0)
        v_h = v + h * read3(k, env, 7 + n)
        omega_h = omega + h * read3(k, env, 10 + n)
        Q = quaternion_of(x, env)
        Q_h = Q / wp.length(Q) + h * quat4(k[env, 3], k[env, 4], k[env, 5], k[env, 6])
        Q_h = Q_h / wp.length(Q_h)
        write_base(env, stage, p_h, v_h + wp.cross(omega_h, p_h), omega_h, Q_h)
        for j in range(n):
            stage.joint_positions[env, j] = x.joint_positions[env, j] + h * k[env, 7 + j]
            stage.joint_velocities[env, j] = x.joint_velocities[env, j] + h * k[env, 13 + n + j]
        m = x.tangential_deformation
        for c in range(m.shape[1]):
            for a in range(3):
                stage.tangential_deformation[env, c, a] = m[env, c, a] + h * k[env, 13 + 2 * n + 3 * c + a]

    @wp.kernel(module="unique")
    def rk4_combine(
        dt: scalar,
        quaternion_tolerance: scalar,
        x: B.State,
        # slopes of the four stages
        k1: wp.array2d(dtype=scalar),
        k2: wp.array2d(dtype=scalar),
        k3: wp.array2d(dtype=scalar),
        k4: wp.array2d(dtype=scalar),
        # outputs: the state at t + dt
        y: B.State,
    ):
        """y = x + dt (k1 + 2 k2 + 2 k3 + k4) / 6, quaternion normalised; health as in semi_implicit_euler."""
        env = wp.tid()
        n = x.joint_positions.shape[1]
        m = x.tangential_deformation
        w = dt / scalar(6.0)
        p = read3(x.base_position, env, 0)
        omega = read3(x.base_velocity, env, 3)
        v = read3(x.base_velocity, env, 0) - wp.cross(omega, p)
        p_next = p + w * (read3(k1, env, 0) + scalar(2.0) * (read3(k2, env, 0) + read3(k3, env, 0)) + read3(k4, env, 0))
        v_next = v + w * (read3(k1, env, 7 + n) + scalar(2.0) * (read3(k2, env, 7 + n) + read3(k3, env, 7 + n)) + read3(k4, env, 7 + n))
        omega_next = omega + w * (
            read3(k1, env, 10 + n) + scalar(2.0) * (read3(k2, env, 10 + n) + read3(k3, env, 10 + n)) + read3(k4, env, 10 + n)
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
        nonfinite = scalar(0.0)
        for j in range(n):
            nonfinite = poison(nonfinite, k1[env, 7 + j] + k2[env, 7 + j] + k3[env, 7 + j] + k4[env, 7 + j])
            nonfinite = poison(nonfinite, k1[env, 13 + n + j] + k2[env, 13 + n + j] + k3[env, 13 + n + j] + k4[env, 13 + n + j])
        for c in range(3 * m.shape[1]):
            i = 13 + 2 * n + c
            nonfinite = poison(nonfinite, k1[env, i] + k2[env, i] + k3[env, i] + k4[env, i])
        ok = ok and wp.isfinite(nonfinite)
        if ok:
            write_base(env, y, p_next, pdot_next, omega_next, Q_next)
            for j in range(n):
                i = 7 + j
                y.joint_positions[env, j] = x.joint_positions[env, j] + w * (k1[env, i] + scalar(2.0) * (k2[env, i] + k3[env, i]) + k4[env, i])
                i2 = 13 + n + j
                y.joint_velocities[env, j] = x.joint_velocities[env, j] + w * (
                    k1[env, i2] + scalar(2.0) * (k2[env, i2] + k3[env, i2]) + k4[env, i2]
                )
            for c in range(m.shape[1]):
                for a in range(3):
                    i3 = 13 + 2 * n + 3 * c + a
                    y.tangential_deformation[env, c, a] = m[env, c, a] + w * (k1[env, i3] + scalar(2.0) * (k2[env, i3] + k3[env, i3]) + k4[env, i3])
            y.valid[env] = 1
        else:
            keep_state(env, x, y)

    def state_size(n: int, nc: int) -> int:
        """The length of x = (p, Q, s, v, sdot, m): 3 + 4 + n + 6 + n + 3 nc."""
        return 13 + 2 * n + 3 * nc

    return types.SimpleNamespace(
        quaternion_rate=quaternion_rate,
        poison=poison,
        keep_state=keep_state,
        euler_base=euler_base,
        base_state=base_state,
        euler_base_from=euler_base_from,
        write_base=write_base,
        semi_implicit_euler=semi_implicit_euler,
        semi_implicit_euler_so3=semi_implicit_euler_so3,
        slope=slope,
        rk4_stage=rk4_stage,
        rk4_combine=rk4_combine,
        state_size=state_size,
        quat4=quat4,
    )
