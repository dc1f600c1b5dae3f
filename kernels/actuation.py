"""Joint forces a step applies at its start: JaxSim's resultant torques, MuJoCo's passive joint forces and
the MJCF actuators.

    tau = clip(tau_ref + tau_friction + tau_limits, -tau_lim(|sdot|), tau_lim(|sdot|))      (JaxSim's)
        + tau_passive + tau_actuators,
    tau_friction = -(kc sign(sdot) + kv sdot), sign(0) = 0 (as jnp.sign; wp.sign(0) is 1),
    tau_limits = -k (min(s - s_min, 0) + max(s - s_max, 0)), then tau_limits *= (1 - d sdot)
        (JaxSim multiplies the damping by the spring torque: zero inside the limits),
    tau_lim = tau_max for |sdot| <= omega_th, falling linearly to 0 at omega_max, 0 beyond;
    tau_passive = -stiffness (s - springref) - damping sdot                                     (MuJoCo's)
    tau_actuators = clip(sum over the joint's actuators a of gear_a force_a, joint_actuator_force_range),
    force_a = clip((g0 + g1 L + g2 V) clip(ctrl_a, ctrl_range) + b0 + b1 L + b2 V, force_range),
        L = gear_a s, V = gear_a sdot                                                           (MuJoCo's)
per DoF d of joint j (one each for a revolute or prismatic joint): friction, damping and the torque-speed clip
act on each DoF; limits and actuators on one-DoF joints only; a ball or free joint's spring is MuJoCo's,
-stiffness dif towards its reference (qpos_spring: its initial position) with dif the translation (a free
joint's first 3 DoFs) and the rotation vector of Q_ref^-1 Q (mju_subQuat; the rotational DoFs).
A clip passes NaN and +-inf through (a non-finite control or reference makes the state non-finite, which the
integrator flags), where wp.clamp(NaN, a, b) would give a and an infinite reference would become a bound. Which terms exist is decided when the kernel is built
(`with_limits`, `with_friction`, `with_passive`, and the most actuators on one joint, whose loop is
unrolled): a model without them compiles none of that code. JaxSim's part is evaluated once per step, at
its start (as JaxSim); MuJoCo's part, which RK4 must see change within the step as MuJoCo's RK4 does, is
also a kernel of its own (`mujoco_kernel`), launched at each stage.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import FREE, PRISMATIC, spatial


@factory
def functions(scalar, per_joint: int):
    """clip, and actuator_force for models with at most `per_joint` actuators on a joint (its loop unrolled,
    so that its sum is differentiated by the tape)."""
    B = bundles(scalar)
    PER_JOINT = wp.constant(per_joint)

    @wp.func
    def clip(x: scalar, lower: scalar, upper: scalar):
        """x clamped to [lower, upper]; NaN and +-inf stay as they are (not values to clamp)."""
        if not wp.isfinite(x):
            return x
        return wp.min(wp.max(x, lower), upper)

    @wp.func
    def actuator_force(model: B.Model, env: int, j: int, s: scalar, sd: scalar, ctrl: wp.array2d(dtype=scalar)):
        """The summed force of joint j's actuators on the joint [N m or N], clamped to its actuator range."""
        total = scalar(0.0)
        first = model.joint_actuator_start[j]
        count = model.joint_actuator_start[j + 1] - first
        for k in range(PER_JOINT):
            if k < count:
                a = model.joint_actuator[first + k]
                gear = B.joint_parameter(model.actuator_gear, env, a)
                length = gear * s
                velocity = gear * sd
                g = B.vec3_parameter(model.actuator_gain, env, a)
                b = B.vec3_parameter(model.actuator_bias, env, a)
                ctrl_range = B.pair_parameter(model.actuator_ctrl_range, env, a)
                force_range = B.pair_parameter(model.actuator_force_range, env, a)
                u = clip(ctrl[env, a], ctrl_range[0], ctrl_range[1])
                force = (g[0] + g[1] * length + g[2] * velocity) * u + b[0] + b[1] * length + b[2] * velocity
                total = total + gear * clip(force, force_range[0], force_range[1])
        limits = B.pair_parameter(model.joint_actuator_force_range, env, j)
        return clip(total, limits[0], limits[1])

    return clip, actuator_force


@factory
def torque_speed_curve(scalar):
    """`torque_limit`, JaxSim's torque-speed curve tau_lim(|sdot|) (the module docstring), and the kernel
    `torque_limits` that evaluates it for every joint (warpdyn.actuation_model.tn_curve_fn)."""
    B = bundles(scalar)

    @wp.func
    def torque_limit(torque_max: scalar, omega_th: scalar, omega_max: scalar, sd: scalar):
        """tau_lim [N m]: torque_max up to |sd| = omega_th, falling linearly to 0 at omega_max, 0 beyond."""
        speed = wp.abs(sd)
        limit = torque_max
        if speed > omega_max:
            limit = scalar(0.0)
        elif speed > omega_th:
            limit = torque_max * (scalar(1.0) - (speed - omega_th) / (omega_max - omega_th))
        return limit

    @wp.kernel(module="unique")
    def torque_limits(
        torque_max: scalar,
        omega_th: scalar,
        omega_max: scalar,
        state: B.State,
        # outputs
        tau_lim: wp.array2d(dtype=scalar),
    ):
        """tau_lim (N, nv): each DoF's bound at its velocity; launched over (N, nv)."""
        env, j = wp.tid()
        tau_lim[env, j] = torque_limit(torque_max, omega_th, omega_max, state.joint_velocities[env, j])

    return types.SimpleNamespace(torque_limit=torque_limit, torque_limits=torque_limits)


@factory
def joint_spring(scalar, multi_dof: bool):
    """The wp.func giving the spring displacement dif of DoF d of joint j (the module docstring): s - springref_j
    for a one-DoF joint at position s, else the translation or rotation from the joint's reference (positions
    (N, nq): the state's); multi_dof: a model with ball or free joints (kernels/joints.py)."""
    sp, B, jm = spatial(scalar), bundles(scalar), joints(scalar, multi_dof)

    @wp.func
    def spring_displacement(model: B.Model, env: int, j: int, d: int, s: scalar, positions: wp.array2d(dtype=scalar)):
        if wp.static(not multi_dof):
            return s - B.joint_parameter(model.springref, env, j)
        i = j + 1
        kind = model.joint_type[i]
        if kind <= PRISMATIC:
            return s - B.joint_parameter(model.springref, env, j)
        a = model.q_start[i]
        k = d - model.v_start[i]
        if kind == FREE:
            if k < 3:
                return positions[env, a + k] - model.qpos_spring[a + k]
            a = a + 3
            k = k - 3
        Q = jm.joint_quaternion(positions, env, a)
        Q_ref = wp.normalize(sp.quat_from_wxyz(model.qpos_spring[a], model.qpos_spring[a + 1], model.qpos_spring[a + 2], model.qpos_spring[a + 3]))
        return sp.rotation_vector(wp.quat_inverse(Q_ref) * Q)[k]

    return spring_displacement


@factory
def mujoco_terms(scalar, with_passive: bool, per_joint: int, multi_dof: bool):
    """The wp.func giving MuJoCo's joint forces on DoF d of joint j at (s, sdot) (s: the joint's first position,
    positions (N, nq) the state's): the passive spring and damper (when with_passive) plus the actuators' forces
    (when per_joint > 0, on one-DoF joints); the code of an absent term is not compiled."""
    B = bundles(scalar)
    _, actuator_force = functions(scalar, max(per_joint, 1))
    spring_displacement = joint_spring(scalar, multi_dof)
    PASSIVE = wp.constant(with_passive)
    ACTUATORS = wp.constant(per_joint > 0)

    @wp.func
    def mujoco_joint_force(model: B.Model, env: int, j: int, d: int, s: scalar, sd: scalar, ctrl: wp.array2d(dtype=scalar), positions: wp.array2d(dtype=scalar)):
        out = scalar(0.0)
        if PASSIVE:
            spring = B.joint_parameter(model.stiffness, env, j) * spring_displacement(model, env, j, d, s, positions)
            out = out - spring - B.joint_parameter(model.damping, env, d) * sd
        if ACTUATORS:
            if wp.static(not multi_dof) or model.joint_type[j + 1] <= PRISMATIC:
                out = out + actuator_force(model, env, j, s, sd, ctrl)
        return out

    return mujoco_joint_force


@factory
def joint_force(scalar, with_limits: bool, with_friction: bool, with_passive: bool = False, per_joint: int = 0, multi_dof: bool = False,
                static_friction: bool = True):
    """The wp.func giving the step's force on DoF d of joint j [N m or N] at (s, sdot) (s: the joint's first
    position, positions (N, nq): the state's) from its reference tau_ref_d and the actuators' controls ctrl
    (N, na) (the module docstring's tau); per_joint: the most actuators on one joint (0: no actuator code). The
    actuation kernel and the fused step (kernels/fused_step.py: for each DoF d of link i's joint, j = i - 1) call
    it; multi_dof: a model with ball or free joints (kernels/joints.py); static_friction False: friction without its
    static term kc sign(sdot) (MuJoCo's friction constraints stand for it: `model.frictionloss_constraints`)."""
    B = bundles(scalar)
    clip, _ = functions(scalar, max(per_joint, 1))
    torque_limit = torque_speed_curve(scalar).torque_limit
    mujoco_joint_force = mujoco_terms(scalar, with_passive, per_joint, multi_dof)
    LIMITS = wp.constant(with_limits)
    FRICTION = wp.constant(with_friction)
    STATIC = wp.constant(static_friction)
    MUJOCO = wp.constant(with_passive or per_joint > 0)

    @wp.func
    def resultant_torque(
        model: B.Model, torque_max: scalar, omega_th: scalar, omega_max: scalar, env: int, j: int, d: int, s: scalar, sd: scalar,
        tau_ref_d: scalar, ctrl: wp.array2d(dtype=scalar), positions: wp.array2d(dtype=scalar)
    ):
        total = tau_ref_d
        if FRICTION:
            sign = scalar(0.0)
            if STATIC:
                if sd > scalar(0.0):
                    sign = scalar(1.0)
                elif sd < scalar(0.0):
                    sign = scalar(-1.0)
            total = total - (B.joint_parameter(model.friction_static, env, d) * sign + B.joint_parameter(model.friction_viscous, env, d) * sd)
        if LIMITS:
            if wp.static(not multi_dof) or model.joint_type[j + 1] <= PRISMATIC:
                limits = B.position_limits_of(model, env, j)
                below = wp.min(s - limits[0], scalar(0.0))
                above = wp.max(s - limits[1], scalar(0.0))
                spring = -B.joint_parameter(model.joint_limit_spring, env, j) * (below + above)
                total = total + spring * (scalar(1.0) - B.joint_parameter(model.joint_limit_damper, env, j) * sd)
        limit = torque_limit(torque_max, omega_th, omega_max, sd)
        out = clip(total, -limit, limit)
        if MUJOCO:
            out = out + mujoco_joint_force(model, env, j, d, s, sd, ctrl, positions)
        return out

    return resultant_torque


@factory
def kernel(scalar, with_limits: bool, with_friction: bool, with_passive: bool = False, per_joint: int = 0, multi_dof: bool = False,
           static_friction: bool = True):
    """The step's joint forces (`joint_force`) as a kernel over (N, nv)."""
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)
    resultant_torque = joint_force(scalar, with_limits, with_friction, with_passive, per_joint, multi_dof, static_friction)

    @wp.kernel(module="unique")
    def resultant_torques(
        model: B.Model,
        torque_max: scalar,
        omega_th: scalar,
        omega_max: scalar,
        state: B.State,
        tau_ref: wp.array2d(dtype=scalar),
        ctrl: wp.array2d(dtype=scalar),
        # outputs
        tau: wp.array2d(dtype=scalar),
    ):
        """tau (N, nv) from the references tau_ref (N, nv) and the actuators' controls ctrl (N, na); launched over
        (N, nv). The model's parameters are shared or per environment (kernels/bundles.py)."""
        env, d = wp.tid()
        j = jm.joint_of_dof(model, d)
        s = state.joint_positions[env, jm.position_address(model, j + 1)]
        sd = state.joint_velocities[env, d]
        tau[env, d] = resultant_torque(model, torque_max, omega_th, omega_max, env, j, d, s, sd, tau_ref[env, d], ctrl, state.joint_positions)

    return resultant_torques


@factory
def mujoco_kernel(scalar, with_passive: bool, per_joint: int, multi_dof: bool):
    """tau = tau_in + MuJoCo's joint forces at the state (see `mujoco_terms`): what RK4 evaluates at each stage
    on the JaxSim part held from the step's start, and, with tau_in absent, MuJoCo's qfrc_actuator
    (with_passive False) or the joints' part of qfrc_passive (per_joint 0)."""
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)
    mujoco_joint_force = mujoco_terms(scalar, with_passive, per_joint, multi_dof)

    @wp.kernel(module="unique")
    def mujoco_joint_forces(
        model: B.Model,
        state: B.State,
        tau_in: wp.array2d(dtype=scalar),
        ctrl: wp.array2d(dtype=scalar),
        # outputs
        tau: wp.array2d(dtype=scalar),
    ):
        """tau (N, nv) = tau_in (N, nv; absent, a zero leading axis: 0) + MuJoCo's joint forces; launched over
        (N, nv)."""
        env, d = wp.tid()
        j = jm.joint_of_dof(model, d)
        s = state.joint_positions[env, jm.position_address(model, j + 1)]
        out = mujoco_joint_force(model, env, j, d, s, state.joint_velocities[env, d], ctrl, state.joint_positions)
        if tau_in.shape[0] > 0:
            out = out + tau_in[env, d]
        tau[env, d] = out

    return mujoco_joint_forces
