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

from .bundles import bundles


@functools.cache
def kernel(scalar, with_limits: bool, with_friction: bool):
    B = bundles(scalar)
    LIMITS = wp.constant(with_limits)
    FRICTION = wp.constant(with_friction)

    @wp.kernel(module="unique")
    def resultant_torques(
        model: B.Model,
        torque_max: scalar,
        omega_th: scalar,
        omega_max: scalar,
        state: B.State,
        tau_ref: wp.array2d(dtype=scalar),
        # outputs
        tau: wp.array2d(dtype=scalar),
    ):
        """tau (N, n) from the references tau_ref (N, n); launched over (N, n). The model's joint gains,
        frictions and limits are shared or per environment (kernels/bundles.py)."""
        env, j = wp.tid()
        s = state.joint_positions[env, j]
        sd = state.joint_velocities[env, j]
        total = tau_ref[env, j]
        if FRICTION:
            sign = scalar(0.0)
            if sd > scalar(0.0):
                sign = scalar(1.0)
            elif sd < scalar(0.0):
                sign = scalar(-1.0)
            total = total - (B.joint_parameter(model.friction_static, env, j) * sign + B.joint_parameter(model.friction_viscous, env, j) * sd)
        if LIMITS:
            limits = B.position_limits_of(model, env, j)
            below = wp.min(s - limits[0], scalar(0.0))
            above = wp.max(s - limits[1], scalar(0.0))
            spring = -B.joint_parameter(model.joint_limit_spring, env, j) * (below + above)
            total = total + spring * (scalar(1.0) - B.joint_parameter(model.joint_limit_damper, env, j) * sd)
        speed = wp.abs(sd)
        limit = torque_max
        if speed > omega_max:
            limit = scalar(0.0)
        elif speed > omega_th:
            limit = torque_max * (scalar(1.0) - (speed - omega_th) / (omega_max - omega_th))
        tau[env, j] = wp.clamp(total, -limit, limit)

    return resultant_torques
