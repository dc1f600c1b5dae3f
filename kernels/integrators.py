"""Integrators of the state, as JaxSim's (which integrate in the Inertial representation).

State x = (W_p_B, W_Q_B (w, x, y, z), s, W_v_WB (Inertial), sdot, m); the data stores the base velocity
Mixed, [W_pdot_B; W_omega], converted here at each end. Its derivative:
    W_pdot_B = v + omega x W_p_B,  W_Qdot_B = 1/2 (0, omega) (x) Q,  sdot,  W_vdot_WB,  sddot,  mdot.
Semi-implicit Euler (JaxSim's default): velocities first, then positions with the new velocities,
    nu+ = nu + dt nu_dot;  p+ = p + dt (v+ + omega+ x p);  Q+ = normalise(Q + dt 1/2 (0, omega+) (x) Q);
    s+ = s + dt sdot+;  m+ = m + dt mdot.
RK4: the classic four stages, contacts evaluated at each, the quaternion normalised at each stage.

Health: an environment whose new state is not finite, or whose quaternion needed a normalisation by more
than `quaternion_tolerance` (|Q+| - 1 before normalising), is flagged (valid = 0) and keeps its state;
an environment already flagged does not change.
"""

import functools
import types

import warp as wp

from .spatial import spatial


@functools.cache
def kernels(scalar):
    sp = spatial(scalar)
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
    def keep_state(
        env: int,
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        m: wp.array3d(dtype=scalar),
        base_position_next: wp.array2d(dtype=scalar),
        base_quaternion_next: wp.array2d(dtype=scalar),
        joint_positions_next: wp.array2d(dtype=scalar),
        base_velocity_next: wp.array2d(dtype=scalar),
        joint_velocities_next: wp.array2d(dtype=scalar),
        m_next: wp.array3d(dtype=scalar),
        valid_next: wp.array(dtype=wp.int32),
    ):
        """A flagged environment: its next state is its state, and valid_next = 0."""
        for a in range(3):
            base_position_next[env, a] = base_position[env, a]
            base_velocity_next[env, a] = base_velocity[env, a]
            base_velocity_next[env, 3 + a] = base_velocity[env, 3 + a]
        for a in range(4):
            base_quaternion_next[env, a] = base_quaternion[env, a]
        for j in range(joint_positions.shape[1]):
            joint_positions_next[env, j] = joint_positions[env, j]
            joint_velocities_next[env, j] = joint_velocities[env, j]
        for c in range(m.shape[1]):
            for a in range(3):
                m_next[env, c, a] = m[env, c, a]
        valid_next[env] = 0

    @wp.kernel(module="unique")
    def semi_implicit_euler(
        dt: scalar,
        quaternion_tolerance: scalar,
        # state at t
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        m: wp.array3d(dtype=scalar),
        valid: wp.array(dtype=wp.int32),
        # derivatives at t
        nu_dot: wp.array2d(dtype=scalar),
        m_dot: wp.array3d(dtype=scalar),
        # outputs: state at t + dt
        base_position_next: wp.array2d(dtype=scalar),
        base_quaternion_next: wp.array2d(dtype=scalar),
        joint_positions_next: wp.array2d(dtype=scalar),
        base_velocity_next: wp.array2d(dtype=scalar),
        joint_velocities_next: wp.array2d(dtype=scalar),
        m_next: wp.array3d(dtype=scalar),
        valid_next: wp.array(dtype=wp.int32),
    ):
        """One semi-implicit Euler step; nu_dot (N, 6 + n) is [W_vdot_WB (Inertial); sddot]."""
        env = wp.tid()
        p = sp.vec3(base_position[env, 0], base_position[env, 1], base_position[env, 2])
        Q = quat4(base_quaternion[env, 0], base_quaternion[env, 1], base_quaternion[env, 2], base_quaternion[env, 3])
        Q = Q / wp.length(Q)
        pdot = sp.vec3(base_velocity[env, 0], base_velocity[env, 1], base_velocity[env, 2])
        omega = sp.vec3(base_velocity[env, 3], base_velocity[env, 4], base_velocity[env, 5])
        v_inertial = pdot - wp.cross(omega, p)
        v_next = v_inertial + dt * sp.vec3(nu_dot[env, 0], nu_dot[env, 1], nu_dot[env, 2])
        omega_next = omega + dt * sp.vec3(nu_dot[env, 3], nu_dot[env, 4], nu_dot[env, 5])
        p_next = p + dt * (v_next + wp.cross(omega_next, p))
        Q_step = Q + dt * quaternion_rate(Q, omega_next)
        Q_norm = wp.length(Q_step)
        Q_next = Q_step / Q_norm
        pdot_next = v_next + wp.cross(omega_next, p_next)
        ok = valid[env] != 0 and wp.abs(Q_norm - scalar(1.0)) <= quaternion_tolerance
        ok = ok and finite3(p_next) and finite3(pdot_next) and finite3(omega_next) and wp.isfinite(Q_norm)
        n = joint_positions.shape[1]
        for j in range(n):
            sd_next = joint_velocities[env, j] + dt * nu_dot[env, 6 + j]
            ok = ok and wp.isfinite(sd_next) and wp.isfinite(joint_positions[env, j] + dt * sd_next)
        for c in range(m.shape[1]):
            for a in range(3):
                ok = ok and wp.isfinite(m[env, c, a] + dt * m_dot[env, c, a])
        if ok:
            for a in range(3):
                base_position_next[env, a] = p_next[a]
                base_velocity_next[env, a] = pdot_next[a]
                base_velocity_next[env, 3 + a] = omega_next[a]
            for a in range(4):
                base_quaternion_next[env, a] = Q_next[a]
            for j in range(n):
                sd_next = joint_velocities[env, j] + dt * nu_dot[env, 6 + j]
                joint_velocities_next[env, j] = sd_next
                joint_positions_next[env, j] = joint_positions[env, j] + dt * sd_next
            for c in range(m.shape[1]):
                for a in range(3):
                    m_next[env, c, a] = m[env, c, a] + dt * m_dot[env, c, a]
            valid_next[env] = 1
        else:
            keep_state(
                env,
                base_position,
                base_quaternion,
                joint_positions,
                base_velocity,
                joint_velocities,
                m,
                base_position_next,
                base_quaternion_next,
                joint_positions_next,
                base_velocity_next,
                joint_velocities_next,
                m_next,
                valid_next,
            )

    @wp.func
    def read3(a: wp.array2d(dtype=scalar), env: int, offset: int):
        return sp.vec3(a[env, offset], a[env, offset + 1], a[env, offset + 2])

    @wp.kernel(module="unique")
    def slope(
        # state of a stage
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        m: wp.array3d(dtype=scalar),
        # its accelerations
        base_acceleration: wp.array2d(dtype=scalar),
        joint_accelerations: wp.array2d(dtype=scalar),
        m_dot: wp.array3d(dtype=scalar),
        # outputs
        k: wp.array2d(dtype=scalar),
    ):
        """k (N, 13 + 2n + 3 nc) = d/dt (p, Q, s, v (Inertial), sdot, m), in that order."""
        env = wp.tid()
        n = joint_positions.shape[1]
        Q = quat4(base_quaternion[env, 0], base_quaternion[env, 1], base_quaternion[env, 2], base_quaternion[env, 3])
        Qdot = quaternion_rate(Q / wp.length(Q), read3(base_velocity, env, 3))
        for a in range(3):
            k[env, a] = base_velocity[env, a]
            k[env, 7 + n + a] = base_acceleration[env, a]
            k[env, 10 + n + a] = base_acceleration[env, 3 + a]
        for a in range(4):
            k[env, 3 + a] = Qdot[a]
        for j in range(n):
            k[env, 7 + j] = joint_velocities[env, j]
            k[env, 13 + n + j] = joint_accelerations[env, j]
        for c in range(m.shape[1]):
            for a in range(3):
                k[env, 13 + 2 * n + 3 * c + a] = m_dot[env, c, a]

    @wp.kernel(module="unique")
    def rk4_stage(
        h: scalar,
        # state at t
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        m: wp.array3d(dtype=scalar),
        k: wp.array2d(dtype=scalar),
        # outputs: the stage x(t) + h k, quaternion normalised, base velocity Mixed
        stage_position: wp.array2d(dtype=scalar),
        stage_quaternion: wp.array2d(dtype=scalar),
        stage_joint_positions: wp.array2d(dtype=scalar),
        stage_velocity: wp.array2d(dtype=scalar),
        stage_joint_velocities: wp.array2d(dtype=scalar),
        stage_m: wp.array3d(dtype=scalar),
    ):
        env = wp.tid()
        n = joint_positions.shape[1]
        p = read3(base_position, env, 0)
        omega = read3(base_velocity, env, 3)
        v = read3(base_velocity, env, 0) - wp.cross(omega, p)
        p_h = p + h * read3(k, env, 0)
        v_h = v + h * read3(k, env, 7 + n)
        omega_h = omega + h * read3(k, env, 10 + n)
        Q = quat4(base_quaternion[env, 0], base_quaternion[env, 1], base_quaternion[env, 2], base_quaternion[env, 3])
        Q_h = Q / wp.length(Q) + h * quat4(k[env, 3], k[env, 4], k[env, 5], k[env, 6])
        Q_h = Q_h / wp.length(Q_h)
        pdot_h = v_h + wp.cross(omega_h, p_h)
        for a in range(3):
            stage_position[env, a] = p_h[a]
            stage_velocity[env, a] = pdot_h[a]
            stage_velocity[env, 3 + a] = omega_h[a]
        for a in range(4):
            stage_quaternion[env, a] = Q_h[a]
        for j in range(n):
            stage_joint_positions[env, j] = joint_positions[env, j] + h * k[env, 7 + j]
            stage_joint_velocities[env, j] = joint_velocities[env, j] + h * k[env, 13 + n + j]
        for c in range(m.shape[1]):
            for a in range(3):
                stage_m[env, c, a] = m[env, c, a] + h * k[env, 13 + 2 * n + 3 * c + a]

    @wp.kernel(module="unique")
    def rk4_combine(
        dt: scalar,
        quaternion_tolerance: scalar,
        # state at t
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        joint_positions: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        m: wp.array3d(dtype=scalar),
        valid: wp.array(dtype=wp.int32),
        # slopes of the four stages
        k1: wp.array2d(dtype=scalar),
        k2: wp.array2d(dtype=scalar),
        k3: wp.array2d(dtype=scalar),
        k4: wp.array2d(dtype=scalar),
        # outputs: state at t + dt
        base_position_next: wp.array2d(dtype=scalar),
        base_quaternion_next: wp.array2d(dtype=scalar),
        joint_positions_next: wp.array2d(dtype=scalar),
        base_velocity_next: wp.array2d(dtype=scalar),
        joint_velocities_next: wp.array2d(dtype=scalar),
        m_next: wp.array3d(dtype=scalar),
        valid_next: wp.array(dtype=wp.int32),
    ):
        """x(t + dt) = x(t) + dt (k1 + 2 k2 + 2 k3 + k4) / 6, quaternion normalised; health as in
        semi_implicit_euler."""
        env = wp.tid()
        n = joint_positions.shape[1]
        w = dt / scalar(6.0)
        p = read3(base_position, env, 0)
        omega = read3(base_velocity, env, 3)
        v = read3(base_velocity, env, 0) - wp.cross(omega, p)
        p_next = p + w * (read3(k1, env, 0) + scalar(2.0) * (read3(k2, env, 0) + read3(k3, env, 0)) + read3(k4, env, 0))
        v_next = v + w * (read3(k1, env, 7 + n) + scalar(2.0) * (read3(k2, env, 7 + n) + read3(k3, env, 7 + n)) + read3(k4, env, 7 + n))
        omega_next = omega + w * (
            read3(k1, env, 10 + n) + scalar(2.0) * (read3(k2, env, 10 + n) + read3(k3, env, 10 + n)) + read3(k4, env, 10 + n)
        )
        Q = quat4(base_quaternion[env, 0], base_quaternion[env, 1], base_quaternion[env, 2], base_quaternion[env, 3])
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
        ok = valid[env] != 0 and wp.abs(Q_norm - scalar(1.0)) <= quaternion_tolerance
        ok = ok and finite3(p_next) and finite3(pdot_next) and finite3(omega_next) and wp.isfinite(Q_norm)
        for j in range(n):
            ok = ok and wp.isfinite(k1[env, 7 + j] + k2[env, 7 + j] + k3[env, 7 + j] + k4[env, 7 + j])
            ok = ok and wp.isfinite(k1[env, 13 + n + j] + k2[env, 13 + n + j] + k3[env, 13 + n + j] + k4[env, 13 + n + j])
        for c in range(3 * m.shape[1]):
            i = 13 + 2 * n + c
            ok = ok and wp.isfinite(k1[env, i] + k2[env, i] + k3[env, i] + k4[env, i])
        if ok:
            for a in range(3):
                base_position_next[env, a] = p_next[a]
                base_velocity_next[env, a] = pdot_next[a]
                base_velocity_next[env, 3 + a] = omega_next[a]
            for a in range(4):
                base_quaternion_next[env, a] = Q_next[a]
            for j in range(n):
                i = 7 + j
                joint_positions_next[env, j] = joint_positions[env, j] + w * (k1[env, i] + scalar(2.0) * (k2[env, i] + k3[env, i]) + k4[env, i])
                i2 = 13 + n + j
                joint_velocities_next[env, j] = joint_velocities[env, j] + w * (
                    k1[env, i2] + scalar(2.0) * (k2[env, i2] + k3[env, i2]) + k4[env, i2]
                )
            for c in range(m.shape[1]):
                for a in range(3):
                    i3 = 13 + 2 * n + 3 * c + a
                    m_next[env, c, a] = m[env, c, a] + w * (k1[env, i3] + scalar(2.0) * (k2[env, i3] + k3[env, i3]) + k4[env, i3])
            valid_next[env] = 1
        else:
            keep_state(
                env,
                base_position,
                base_quaternion,
                joint_positions,
                base_velocity,
                joint_velocities,
                m,
                base_position_next,
                base_quaternion_next,
                joint_positions_next,
                base_velocity_next,
                joint_velocities_next,
                m_next,
                valid_next,
            )

    def state_size(n: int, nc: int) -> int:
        """The length of x = (p, Q, s, v, sdot, m): 3 + 4 + n + 6 + n + 3 nc."""
        return 13 + 2 * n + 3 * nc

    return types.SimpleNamespace(
        quaternion_rate=quaternion_rate,
        semi_implicit_euler=semi_implicit_euler,
        slope=slope,
        rk4_stage=rk4_stage,
        rk4_combine=rk4_combine,
        state_size=state_size,
        quat4=quat4,
    )
