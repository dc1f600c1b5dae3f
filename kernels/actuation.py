"""Joint torques actually applied in a step, as JaxSim's `compute_resultant_torques`.

    tau = clip(tau_ref + tau_friction + tau_limits, -tau_lim(|sdot|), tau_lim(|sdot|)),
    tau_friction = -(kc sign(sdot) + kv sdot), sign(0) = 0 (as jnp.sign; wp.sign(0) is 1),
    tau_limits = -k (min(s - s_min, 0) + max(s - s_max, 0)), then tau_limits *= (1 - d sdot)
        (JaxSim multiplies the damping by the spring torque: zero inside the limits),
    tau_lim = tau_max for |sdot| <= omega_th, falling linearly to 0 at omega_max, 0 beyond.
Which terms exist is decided when the kernel is built (`with_limits`, `with_friction`), so a model
without limits or friction compiles none of that code.
"""

import functools

import warp as wp

from .spatial import spatial


@functools.cache
def kernel(scalar, with_limits: bool, with_friction: bool):
    sp = spatial(scalar)
    LIMITS = wp.constant(with_limits)
    FRICTION = wp.constant(with_friction)

    @wp.kernel(module="unique")
    def resultant_torques(
        # model
        position_limits: wp.array2d(dtype=scalar),
        limit_spring: wp.array2d(dtype=scalar),
        limit_damper: wp.array2d(dtype=scalar),
        friction_static: wp.array2d(dtype=scalar),
        friction_viscous: wp.array2d(dtype=scalar),
        torque_max: scalar,
        omega_th: scalar,
        omega_max: scalar,
        # state
        joint_positions: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        tau_ref: wp.array2d(dtype=scalar),
        # outputs
        tau: wp.array2d(dtype=scalar),
    ):
        """tau (N, n) from the references tau_ref (N, n); launched over (N, n). The gains and frictions are
        (P, n): P = 1 shared by the environments, or N (see spatial.mass_of); position_limits (n, 2)."""
        env, j = wp.tid()
        s = joint_positions[env, j]
        sd = joint_velocities[env, j]
        total = tau_ref[env, j]
        if FRICTION:
            sign = scalar(0.0)
            if sd > scalar(0.0):
                sign = scalar(1.0)
            elif sd < scalar(0.0):
                sign = scalar(-1.0)
            total = total - (sp.joint_parameter(friction_static, env, j) * sign + sp.joint_parameter(friction_viscous, env, j) * sd)
        if LIMITS:
            below = wp.min(s - position_limits[j, 0], scalar(0.0))
            above = wp.max(s - position_limits[j, 1], scalar(0.0))
            spring = -sp.joint_parameter(limit_spring, env, j) * (below + above)
            total = total + spring * (scalar(1.0) - sp.joint_parameter(limit_damper, env, j) * sd)
        speed = wp.abs(sd)
        limit = torque_max
        if speed > omega_max:
            limit = scalar(0.0)
        elif speed > omega_th:
            limit = torque_max * (scalar(1.0) - (speed - omega_th) / (omega_max - omega_th))
        tau[env, j] = wp.clamp(total, -limit, limit)

    return resultant_torques
