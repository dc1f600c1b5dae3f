"""Typed kernel arguments: the model, the state and the controls as `@wp.struct` bundles, one set per scalar.

A kernel takes `model: B.Model`, `state: B.State`, `controls: B.Controls` (B = bundles(scalar)) instead of
positional arrays, so that each array is named once, here, and a kernel reads `model.link_mass`,
`state.joint_positions`. The engine fills them (warpdyn.engine.bundles). Adding a per-joint parameter is a
field of `Model` (and its entry in warpdyn.types.parameters), read by the kernels that need it.

Shapes: N environments, nL links (link 0 the base; joint i moves link i + 1), nj = nL - 1 joints with nq
positions and nv velocities (DoFs) in all, nc_all collidable points. Link i's joint has its positions at
q_start[i]:q_start[i + 1] of the state's joint positions and its velocities (and forces, and per-DoF
parameters) at v_start[i]:v_start[i + 1]: kernels address joints through them (kernels/joints.py).
Model parameters are (P, nL), (P, nj), (P, nv) or (P, 1) with P = 1 (shared by the environments) or N (one row per
environment): kernels read row min(env, P - 1) (`link_parameter`, `joint_parameter`).
Absent inputs are arrays with a zero leading axis, which kernels test with `.shape[0] > 0` (Warp's tape
cannot take a struct holding a null array). The representation codes are spatial.BODY, MIXED, INERTIAL.
"""

import types

import warp as wp

from .factory import factory
from .spatial import spatial


@factory
def bundles(scalar) -> types.SimpleNamespace:
    """The bundles in `scalar` (wp.float32 or wp.float64) and the `@wp.func`s that read them."""
    sp = spatial(scalar)
    vec2 = wp.types.vector(2, scalar)
    vec4 = wp.types.vector(4, scalar)

    @wp.struct
    class Model:
        """The constants and parameters of a model that kernels read."""

        # the tree
        parent: wp.array(dtype=int)  # (nL,) parent link index, -1 for the base
        joint_type: wp.array(dtype=int)  # (nL,) spatial.REVOLUTE, PRISMATIC, BALL or FREE (0 for the base)
        q_start: wp.array(dtype=int)  # (nL + 1,) link i's joint positions are q_start[i]:q_start[i + 1]
        v_start: wp.array(dtype=int)  # (nL + 1,) its velocities (DoFs) v_start[i]:v_start[i + 1]
        # link i in its parent at joint position q (kernels/joints.py; warpdyn.types.model_constants'
        # joint_motion_terms), (P, nL): P = 1 shared, P = N per environment (wd.model.with_joint_origins), read at
        # row min(env, P - 1); a free joint's are the same in every row
        joint_Q0: wp.array2d(dtype=sp.quat)
        joint_Q1: wp.array2d(dtype=sp.quat)
        joint_t0: wp.array2d(dtype=sp.vec3)  # [m]
        joint_t1: wp.array2d(dtype=sp.vec3)  # [m, or 1 for a prismatic joint]
        joint_t2: wp.array2d(dtype=sp.vec3)  # [m]
        dof_S: wp.array(dtype=sp.vec6)  # (nv,) each DoF's motion subspace column, link frame (joints.dof_motion)
        dof_joint: wp.array(dtype=int)  # (nv,) the joint of each DoF (joint j moves link j + 1)
        qpos_spring: wp.array(dtype=scalar)  # (nq,) a ball or free joint's spring reference (its initial position)
        first_child: wp.array(dtype=int)  # (nL,) smallest-index child, -1 for none
        next_sibling: wp.array(dtype=int)  # (nL,) next larger-index child of the parent, -1 for none
        support: wp.array2d(dtype=int)  # (nL, nj) 1 where joint j moves link L
        pair_k: wp.array(dtype=int)  # (P,) with pair_j: the DoF pairs (k, j), DoF j's joint supporting DoF k's
        pair_j: wp.array(dtype=int)  # (P,) link (j == k included; within one joint, j <= k)
        zero_k: wp.array(dtype=int)  # (Z,) with zero_j: the DoF pairs where neither joint moves the
        zero_j: wp.array(dtype=int)  # (Z,) other's link (a zero in the mass matrix)
        floating_base: int  # 1 floating, 0 welded
        # actuators (na): joint_actuator[k] for k in joint_actuator_start[j] .. joint_actuator_start[j + 1] - 1
        # are joint j's
        actuator_joint: wp.array(dtype=int)  # (na,) the joint of each actuator
        joint_actuator: wp.array(dtype=int)  # (na,) the actuators sorted by joint
        joint_actuator_start: wp.array(dtype=int)  # (nj + 1,)
        # link parameters (P, nL)
        link_mass: wp.array2d(dtype=scalar)  # [kg]
        link_com: wp.array2d(dtype=sp.vec3)  # [m, link frame]
        link_inertia: wp.array2d(dtype=sp.mat33)  # [kg m^2, about the CoM, link axes]
        gravcomp_mass: wp.array2d(dtype=scalar)  # [kg] gravity compensation: the force -gravcomp_mass g
        gravcomp_com: wp.array2d(dtype=sp.vec3)  # [m, link frame] where it acts
        # joint parameters (P, nj), [P, nv] per DoF
        position_limits: wp.array2d(dtype=vec2)  # (lower, upper) [rad or m]
        joint_limit_spring: wp.array2d(dtype=scalar)  # [N m/rad or N/m]
        joint_limit_damper: wp.array2d(dtype=scalar)  # [s/rad or s/m]
        friction_static: wp.array2d(dtype=scalar)  # [P, nv] [N m or N]
        friction_viscous: wp.array2d(dtype=scalar)  # [P, nv] [N m s/rad or N s/m]
        armature: wp.array2d(dtype=scalar)  # [P, nv] [kg m^2 or kg], on the mass matrix's diagonal
        damping: wp.array2d(dtype=scalar)  # [P, nv] [N m s/rad or N s/m], MuJoCo's damper
        stiffness: wp.array2d(dtype=scalar)  # [N m/rad or N/m]
        springref: wp.array2d(dtype=scalar)  # [rad or m]
        joint_actuator_force_range: wp.array2d(dtype=vec2)  # [N m or N] clamp of the summed actuator force
        # a floating base's free joint (P, 1): MuJoCo's armature, damper and spring on its 6 DoFs (MJCF)
        base_armature: wp.array2d(dtype=scalar)  # [kg or kg m^2]
        base_damping: wp.array2d(dtype=scalar)  # [N s/m or N m s/rad]
        base_stiffness: wp.array2d(dtype=scalar)  # [N/m or N m/rad], towards base_reference
        base_reference: sp.transform  # W_H_B where the base's spring is at rest (the description's base pose)
        # actuator parameters (P, na)
        actuator_gear: wp.array2d(dtype=scalar)
        actuator_gain: wp.array2d(dtype=sp.vec3)  # (g0, g1, g2): gain = g0 + g1 length + g2 velocity
        actuator_bias: wp.array2d(dtype=sp.vec3)  # (b0, b1, b2): bias = b0 + b1 length + b2 velocity
        actuator_ctrl_range: wp.array2d(dtype=vec2)
        actuator_force_range: wp.array2d(dtype=vec2)
        # the world (P, 1)
        world_gravity: wp.array2d(dtype=sp.vec3)  # g [m/s^2, world frame]

    @wp.struct
    class State:
        """The state of N environments (warpdyn.data.Data's arrays)."""

        base_position: wp.array2d(dtype=scalar)  # (N, 3) W_p_B [m]
        base_quaternion: wp.array2d(dtype=scalar)  # (N, 4) W_Q_B (w, x, y, z)
        joint_positions: wp.array2d(dtype=scalar)  # (N, nq) [rad or m; quaternions (w, x, y, z)]
        base_velocity: wp.array2d(dtype=scalar)  # (N, 6) Mixed: [W_pdot_B; W_omega_WB]
        joint_velocities: wp.array2d(dtype=scalar)  # (N, nv)
        tangential_deformation: wp.array3d(dtype=scalar)  # (N, nc_all, 3) [m]
        valid: wp.array(dtype=wp.int32)  # (N,) 1 healthy, 0 flagged

    @wp.struct
    class Controls:
        """The forces a dynamics kernel applies (the link forces in the representation the kernel is given)."""

        joint_forces: wp.array2d(dtype=scalar)  # (N, nv) [N m or N], or (0, 0): none
        link_forces: wp.array3d(dtype=scalar)  # (N, nL, 6) [force; torque], or (0, 0, 0): none
        link_implicit: wp.array3d(dtype=scalar)  # (N, nL, 27) the contacts' implicit terms (kernels/implicit_contacts.py), or (0, 0, 0): none

    @wp.struct
    class Targets:
        """Frames rigidly attached to links (links themselves, frames, contact points): target t is the frame
        at link_H_target[t] on link link[t]."""

        link: wp.array(dtype=int)  # (T,) link index
        link_H_target: wp.array2d(dtype=sp.transform)  # (P, T) the frame's pose in its link, row min(env, P - 1)

    @wp.struct
    class Terrain:
        """The terrain z = h(x, y) (warpdyn.terrain): kind 0 flat, 1 plane, 2 heightfield."""

        kind: int
        normal: sp.vec3  # a plane's unit normal (pointing up)
        height: wp.array(dtype=scalar)  # (1,) or (N,) [m]: the height at the world's origin (flat, plane)
        heights: wp.array2d(dtype=scalar)  # (nx, ny) [m]: a heightfield's grid ((2, 2) unused otherwise)
        grid: vec4  # (origin_x, origin_y, dx, dy) [m] of the heightfield

    @wp.struct
    class Contacts:
        """The enabled collidable points, ordered by link, and the soft-contact parameters (JaxSim's)."""

        point_link: wp.array(dtype=int)  # (nc,) the link of each enabled point
        L_p_C: wp.array2d(dtype=sp.vec3)  # (P, nc) the point in its link's frame [m] (read with vec3_parameter)
        point_row: wp.array(dtype=int)  # (nc,) its index among all points (the contact state's row)
        row_point: wp.array(dtype=int)  # (nc_all,) a point's index among the enabled points, -1 if disabled
        link_first_point: wp.array(dtype=int)  # (nL,) a link's first enabled point, -1 for none
        link_point_count: wp.array(dtype=int)  # (nL,) its number of enabled points (consecutive from the first)
        K: wp.array(dtype=scalar)  # (1,) or (N,) stiffness [N/m^(1+p)]
        D: wp.array(dtype=scalar)  # (1,) or (N,) damping [N s/m^(1+q)]
        mu: wp.array(dtype=scalar)  # (1,) or (N,) friction coefficient
        p: scalar  # exponent of the spring term
        q: scalar  # exponent of the damper term
        implicit: int  # 1 where the step's contacts are linearly implicit (model.implicit_contacts): the Coulomb limit's normal force is then the one the step applies to a contact it arrests

    @wp.func
    def env_and_item(i: int, N: int, K: int, env_fastest: int):
        """(env, k) of thread i of a 1-D launch over N K threads, one per environment and item (a collidable
        point, a link): with environment-fastest arrays (env_fastest != 0, warpdyn.arrays) the environment
        varies fastest, so that the 32 threads of a warp read 32 neighbouring numbers; otherwise the item."""
        if env_fastest != 0:
            return i % N, i // N
        return i // K, i % K

    @wp.func
    def target_pose(targets: Targets, env: int, t: int):
        """Target t's pose in its link in environment env (P = 1 but for collidable points given per environment)."""
        return targets.link_H_target[wp.min(env, targets.link_H_target.shape[0] - 1), t]

    @wp.func
    def link_parameter(values: wp.array2d(dtype=scalar), env: int, i: int):
        """Link i's value of a (P, nL) scalar parameter in environment env (row min(env, P - 1))."""
        return values[wp.min(env, values.shape[0] - 1), i]

    @wp.func
    def env_parameter(values: wp.array(dtype=scalar), env: int):
        """Environment env's value of a parameter shared (1,) or per environment (N,) (element min(env, P - 1))."""
        return values[wp.min(env, values.shape[0] - 1)]

    @wp.func
    def joint_parameter(values: wp.array2d(dtype=scalar), env: int, j: int):
        """Element j's value of a (P, nj) or (P, nv) scalar parameter in environment env (row min(env, P - 1))."""
        return values[wp.min(env, values.shape[0] - 1), j]

    @wp.func
    def pair_parameter(values: wp.array2d(dtype=vec2), env: int, j: int):
        """Element j's value of a (P, count) pair parameter (limits, ranges) in environment env."""
        return values[wp.min(env, values.shape[0] - 1), j]

    @wp.func
    def vec3_parameter(values: wp.array2d(dtype=sp.vec3), env: int, j: int):
        """Element j's value of a (P, count) vec3 parameter in environment env."""
        return values[wp.min(env, values.shape[0] - 1), j]

    @wp.func
    def position_limits_of(model: Model, env: int, j: int):
        """Joint j's (lower, upper) position limits in environment env."""
        return pair_parameter(model.position_limits, env, j)

    @wp.func
    def armature_of(model: Model, env: int, d: int):
        """DoF d's armature in environment env [kg m^2 or kg]."""
        return joint_parameter(model.armature, env, d)

    @wp.func
    def mass_of(model: Model, env: int, i: int):
        """Link i's mass [kg] in environment env."""
        return model.link_mass[wp.min(env, model.link_mass.shape[0] - 1), i]

    @wp.func
    def com_of(model: Model, env: int, i: int):
        """Link i's centre of mass [m, link frame] in environment env."""
        return model.link_com[wp.min(env, model.link_com.shape[0] - 1), i]

    @wp.func
    def inertia_of(model: Model, env: int, i: int):
        """Link i's rotational inertia about its CoM [kg m^2, link axes] in environment env."""
        return model.link_inertia[wp.min(env, model.link_inertia.shape[0] - 1), i]

    @wp.func
    def spatial_inertia_of(model: Model, env: int, i: int):
        """Link i's spatial inertia about its origin, link axes, in environment env."""
        return sp.spatial_inertia(mass_of(model, env, i), com_of(model, env, i), inertia_of(model, env, i))

    @wp.func
    def spatial_inertia_times(model: Model, env: int, i: int, v: sp.vec6):
        """Link i's spatial inertia (`spatial_inertia_of`) times the motion v, without forming it."""
        return sp.inertia_times(mass_of(model, env, i), com_of(model, env, i), inertia_of(model, env, i), v)

    @wp.func
    def gravity_of(model: Model, env: int):
        """The world's gravity g [m/s^2, world frame] in environment env."""
        return vec3_parameter(model.world_gravity, env, 0)

    @wp.func
    def gravity_in(model: Model, env: int, W_H_B: sp.transform):
        """a_g, the acceleration of gravity [g; 0] of the world in environment env, as a spatial motion in the
        coordinates of the base at W_H_B (ABA's and RNEA's fictitious base acceleration is -a_g)."""
        return sp.motion_from(W_H_B, sp.stack(gravity_of(model, env), sp.vec3(scalar(0.0))))

    @wp.func
    def base_rotor(model: Model, env: int, implicit_dt: scalar):
        """What a floating base's free joint adds to the diagonal of its articulated inertia and of the mass
        matrix (Body or Mixed coordinates, the same: MuJoCo's armature acts on its 6 DoFs alike): armature
        (+ implicit_dt damping, MuJoCo's implicit damper in the Euler integrators)."""
        return joint_parameter(model.base_armature, env, 0) + implicit_dt * joint_parameter(model.base_damping, env, 0)

    @wp.func
    def base_rotor_bias(model: Model, env: int, B_v: sp.vec6, implicit_dt: scalar):
        """The velocity-product force in body coordinates of `base_rotor` (armature + implicit_dt damping),
        [r omega x v; 0] (B_v = [v; omega] the base's body twist): MuJoCo's terms multiply the acceleration of its
        free joint's coordinates (world linear velocity, body angular velocity), whose linear part in body axes
        is v_dot + omega x v."""
        r = base_rotor(model, env, implicit_dt)
        return sp.stack(r * wp.cross(sp.ang(B_v), sp.lin(B_v)), sp.vec3(scalar(0.0)))

    @wp.func
    def base_passive_wrench(model: Model, env: int, W_H_B: sp.transform, B_v: sp.vec6):
        """The floating base's free-joint damper and spring as a wrench on the base, body coordinates: -d B_v and
        MuJoCo's spring -k [R^T (p - p_ref); rotation vector of Q_ref^-1 Q] (base_reference = (p_ref, Q_ref))."""
        k = joint_parameter(model.base_stiffness, env, 0)
        Q = wp.transform_get_rotation(W_H_B)
        dp = wp.transform_get_translation(W_H_B) - wp.transform_get_translation(model.base_reference)
        rotation = sp.rotation_vector(wp.quat_inverse(wp.transform_get_rotation(model.base_reference)) * Q)
        return -joint_parameter(model.base_damping, env, 0) * B_v - k * sp.stack(wp.quat_rotate_inv(Q, dp), rotation)

    @wp.func
    def base_pose_of(base_position: wp.array2d(dtype=scalar), base_quaternion: wp.array2d(dtype=scalar), env: int):
        """W_H_B from a base position (N, 3) and quaternion (N, 4) (w, x, y, z)."""
        p = sp.vec3(base_position[env, 0], base_position[env, 1], base_position[env, 2])
        Q = base_quaternion
        return sp.transform(p, sp.quat_from_wxyz(Q[env, 0], Q[env, 1], Q[env, 2], Q[env, 3]))

    @wp.func
    def base_pose(state: State, env: int):
        """W_H_B of environment env."""
        return base_pose_of(state.base_position, state.base_quaternion, env)

    @wp.func
    def base_velocity_mixed(state: State, env: int):
        """The base velocity of environment env, Mixed: [W_pdot_B; W_omega_WB]."""
        v = state.base_velocity
        return sp.vec6(v[env, 0], v[env, 1], v[env, 2], v[env, 3], v[env, 4], v[env, 5])

    @wp.func
    def link_force(controls: Controls, env: int, i: int):
        """The external force on link i, as given."""
        f = controls.link_forces
        return sp.vec6(f[env, i, 0], f[env, i, 1], f[env, i, 2], f[env, i, 3], f[env, i, 4], f[env, i, 5])

    return types.SimpleNamespace(
        Model=Model,
        State=State,
        Controls=Controls,
        Targets=Targets,
        Terrain=Terrain,
        Contacts=Contacts,
        vec4=vec4,
        target_pose=target_pose,
        link_parameter=link_parameter,
        env_parameter=env_parameter,
        joint_parameter=joint_parameter,
        pair_parameter=pair_parameter,
        vec3_parameter=vec3_parameter,
        position_limits_of=position_limits_of,
        armature_of=armature_of,
        mass_of=mass_of,
        com_of=com_of,
        inertia_of=inertia_of,
        spatial_inertia_of=spatial_inertia_of,
        spatial_inertia_times=spatial_inertia_times,
        gravity_of=gravity_of,
        gravity_in=gravity_in,
        base_rotor=base_rotor,
        base_rotor_bias=base_rotor_bias,
        base_passive_wrench=base_passive_wrench,
        base_pose_of=base_pose_of,
        base_pose=base_pose,
        base_velocity_mixed=base_velocity_mixed,
        link_force=link_force,
        env_and_item=env_and_item,
    )
