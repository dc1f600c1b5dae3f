"""Typed kernel arguments: the model, the state and the controls as `@wp.struct` bundles, one set per scalar.

A kernel takes `model: B.Model`, `state: B.State`, `controls: B.Controls` (B = bundles(scalar)) instead of
positional arrays, so that each array is named once, here, and a kernel reads `model.link_mass`,
`state.joint_positions`. The engine fills them (warpdyn.engine.bundles). Adding a per-joint parameter is a
field of `Model` (and its entry in warpdyn.types.parameters), read by the kernels that need it.

Shapes: N environments, nL links (link 0 the base; joint i moves link i + 1), nj = nL - 1 joints with nq
positions and nv velocities (DoFs) in all, nc_all collidable points. Link i's joint has its positions at
q_start[i]:q_start[i + 1] of the state's joint positions and its velocities (and forces, and per-DoF
parameters) at v_start[i]:v_start[i + 1]: kernels address joints through them (`joint_transform`, `dof_motion`).
Model parameters are (P, nL), (P, nj) or (P, nv) with P = 1 (shared by the environments) or N (one row per
environment): kernels read row min(env, P - 1) (`link_parameter`, `joint_parameter`).
Absent inputs are arrays with a zero leading axis, which kernels test with `.shape[0] > 0` (Warp's tape
cannot take a struct holding a null array). The representation codes are spatial.BODY, MIXED, INERTIAL.
"""

import types

import warp as wp

from .factory import factory
from .spatial import BALL, FREE, spatial


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
        # link i in its parent at joint position q (warpdyn.types.model_constants' joint_motion_terms): a revolute
        # or prismatic joint's (t0 + alpha t1 + beta t2, c Q0 + s Q1) with its coefficients (c, s, alpha, beta)
        # (spatial.joint_coefficients); a ball joint's (t0 - (Q0 Q) t1, Q0 Q); a free joint's (t0 + Q0 r, Q0 Q)
        joint_Q0: wp.array(dtype=sp.quat)  # (nL,)
        joint_Q1: wp.array(dtype=sp.quat)  # (nL,)
        joint_t0: wp.array(dtype=sp.vec3)  # (nL,) [m]
        joint_t1: wp.array(dtype=sp.vec3)  # (nL,) [m, or 1 for a prismatic joint]
        joint_t2: wp.array(dtype=sp.vec3)  # (nL,) [m]
        dof_S: wp.array(dtype=sp.vec6)  # (nv,) each DoF's motion subspace column, link frame (`dof_motion`)
        dof_joint: wp.array(dtype=int)  # (nv,) the joint of each DoF (joint j moves link j + 1)
        qpos_spring: wp.array(dtype=scalar)  # (nq,) a ball or free joint's spring reference (its initial position)
        first_child: wp.array(dtype=int)  # (nL,) smallest-index child, -1 for none
        next_sibling: wp.array(dtype=int)  # (nL,) next larger-index child of the parent, -1 for none
        support: wp.array2d(dtype=int)  # (nL, nj) 1 where joint j moves link L
        pair_k: wp.array(dtype=int)  # (P,) with pair_j: the DoF pairs (k, j), DoF j's joint supporting DoF k's
        pair_j: wp.array(dtype=int)  # (P,) link (j == k included; within one joint, j <= k)
        zero_k: wp.array(dtype=int)  # (Z,) with zero_j: the DoF pairs where neither joint moves the
        zero_j: wp.array(dtype=int)  # (Z,) other's link (a zero in the mass matrix)
        gravity: scalar  # [m/s^2] its magnitude, pulling along -z of the world (the model's `gravity` is the z component, -9.81)
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
        gravcomp_mass: wp.array2d(dtype=scalar)  # [kg] gravity compensation: a force along +z of the world
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
        # actuator parameters (P, na)
        actuator_gear: wp.array2d(dtype=scalar)
        actuator_gain: wp.array2d(dtype=sp.vec3)  # (g0, g1, g2): gain = g0 + g1 length + g2 velocity
        actuator_bias: wp.array2d(dtype=sp.vec3)  # (b0, b1, b2): bias = b0 + b1 length + b2 velocity
        actuator_ctrl_range: wp.array2d(dtype=vec2)
        actuator_force_range: wp.array2d(dtype=vec2)

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

    @wp.struct
    class Targets:
        """Frames rigidly attached to links (links themselves, frames, contact points): target t is the frame
        at link_H_target[t] on link link[t]."""

        link: wp.array(dtype=int)  # (T,) link index
        link_H_target: wp.array(dtype=sp.transform)  # (T,) the frame's pose in its link

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
        L_p_C: wp.array(dtype=sp.vec3)  # (nc,) the point in its link's frame [m]
        point_row: wp.array(dtype=int)  # (nc,) its index among all points (the contact state's row)
        row_point: wp.array(dtype=int)  # (nc_all,) a point's index among the enabled points, -1 if disabled
        link_first_point: wp.array(dtype=int)  # (nL,) a link's first enabled point, -1 for none
        link_point_count: wp.array(dtype=int)  # (nL,) its number of enabled points (consecutive from the first)
        K: wp.array(dtype=scalar)  # (1,) or (N,) stiffness [N/m^(1+p)]
        D: wp.array(dtype=scalar)  # (1,) or (N,) damping [N s/m^(1+q)]
        mu: wp.array(dtype=scalar)  # (1,) or (N,) friction coefficient
        p: scalar  # exponent of the spring term
        q: scalar  # exponent of the damper term

    @wp.func
    def env_and_item(i: int, N: int, K: int, env_fastest: int):
        """(env, k) of thread i of a 1-D launch over N K threads, one per environment and item (a collidable
        point, a link): with environment-fastest arrays (env_fastest != 0, warpdyn.arrays) the environment
        varies fastest, so that the 32 threads of a warp read 32 neighbouring numbers; otherwise the item."""
        if env_fastest != 0:
            return i % N, i // N
        return i // K, i % K

    @wp.func
    def link_parameter(values: wp.array2d(dtype=scalar), env: int, i: int):
        """Link i's value of a (P, nL) scalar parameter in environment env (row min(env, P - 1))."""
        return values[wp.min(env, values.shape[0] - 1), i]

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
    def joint_terms_of(model: Model, i: int):
        """Link i's joint: (its type, Q0, Q1, t0, t1, t2), the terms that move its link (i >= 1)."""
        return model.joint_type[i], model.joint_Q0[i], model.joint_Q1[i], model.joint_t0[i], model.joint_t1[i], model.joint_t2[i]

    @wp.func
    def transform_of_terms(k: sp.vec4, Q0: sp.quat, Q1: sp.quat, t0: sp.vec3, t1: sp.vec3, t2: sp.vec3):
        """(t0 + alpha t1 + beta t2, c Q0 + s Q1): a link in its parent from its joint's terms and coefficients
        k = (c, s, alpha, beta) (spatial.joint_coefficients)."""
        return sp.transform(t0 + k[2] * t1 + k[3] * t2, k[0] * Q0 + k[1] * Q1)

    @wp.func
    def joint_transform_from(joint_type: int, Q0: sp.quat, Q1: sp.quat, t0: sp.vec3, t1: sp.vec3, t2: sp.vec3, q: scalar):
        """lambda(i)_H_i = X_tree[i] M_i(q): link i in its parent at joint position q, from its joint's terms
        loaded earlier (`joint_terms_of`)."""
        return transform_of_terms(sp.joint_coefficients(joint_type, q), Q0, Q1, t0, t1, t2)

    @wp.func
    def joint_quaternion(positions: wp.array2d(dtype=scalar), env: int, a: int):
        """The unit quaternion at positions[env, a:a + 4] (w, x, y, z), normalised (as MuJoCo's kinematics)."""
        return wp.normalize(sp.quat_from_wxyz(positions[env, a], positions[env, a + 1], positions[env, a + 2], positions[env, a + 3]))

    @wp.func
    def joint_transform(model: Model, i: int, positions: wp.array2d(dtype=scalar), env: int):
        """lambda(i)_H_i = X_tree[i] M_i(q): link i in its parent at its joint's positions q in `positions`
        (N, nq) (i >= 1). A revolute or prismatic joint's terms are loaded once its coefficients are computed:
        fewer registers live across the sine and cosine (RNEA in float64 spilled 372 instead of 300 bytes with
        them loaded first: benchmarks/registers.py)."""
        kind = model.joint_type[i]
        a = model.q_start[i]
        if kind == BALL:
            Q = model.joint_Q0[i] * joint_quaternion(positions, env, a)
            return sp.transform(model.joint_t0[i] - wp.quat_rotate(Q, model.joint_t1[i]), Q)
        if kind == FREE:
            Q0 = model.joint_Q0[i]
            r = sp.vec3(positions[env, a], positions[env, a + 1], positions[env, a + 2])
            return sp.transform(model.joint_t0[i] + wp.quat_rotate(Q0, r), Q0 * joint_quaternion(positions, env, a + 3))
        k = sp.joint_coefficients(kind, positions[env, a])
        return transform_of_terms(k, model.joint_Q0[i], model.joint_Q1[i], model.joint_t0[i], model.joint_t1[i], model.joint_t2[i])

    @wp.func
    def dof_motion(model: Model, i: int, d: int, X: sp.transform):
        """S_d: the motion subspace column of DoF d of link i's joint, link coordinates, with X = lambda(i)_H_i
        the joint's transform (`joint_transform`). Constant (model.dof_S) but for a free joint's translations,
        MuJoCo's linear velocity in the joint frame's axes: [Q^T e_k; 0] with Q the joint's own rotation."""
        S = model.dof_S[d]
        if model.joint_type[i] == FREE and d - model.v_start[i] < 3:
            Q = wp.quat_inverse(model.joint_Q0[i]) * wp.transform_get_rotation(X)
            return sp.stack(wp.quat_rotate_inv(Q, sp.lin(S)), sp.vec3(scalar(0.0)))
        return S

    @wp.func
    def joint_frame_motion(model: Model, i: int, W_H_L: wp.array2d(dtype=sp.transform), env: int):
        """What `dof_motion` needs of link i's joint transform, from the link poses W_H_L (N, nL): lambda(i)_H_i
        for a free joint, the identity otherwise (which no other joint's motion subspace reads)."""
        if model.joint_type[i] == FREE:
            return wp.transform_inverse(W_H_L[env, model.parent[i]]) * W_H_L[env, i]
        return wp.transform_identity(dtype=scalar)

    @wp.func
    def joint_motion_of(model: Model, i: int, X: sp.transform, values: wp.array2d(dtype=scalar), env: int):
        """S_i(q) values[env, v_start[i]:v_start[i + 1]]: the motion of link i relative to its parent, link
        coordinates, for the DoF values of its joint in `values` (N, nv) (velocities: v_J; accelerations: S qdd);
        X: the joint's transform. Written per joint kind, its loops of fixed length (unrolled: nothing is carried
        across a dynamic loop, which Warp's adjoints do not allow)."""
        kind = model.joint_type[i]
        a = model.v_start[i]
        if kind == BALL:
            w = sp.vec3(values[env, a], values[env, a + 1], values[env, a + 2])
            return sp.stack(wp.cross(model.joint_t1[i], w), w)  # a rotation about the pivot t1 (child frame)
        if kind == FREE:
            Q = wp.quat_inverse(model.joint_Q0[i]) * wp.transform_get_rotation(X)
            v = sp.vec3(values[env, a], values[env, a + 1], values[env, a + 2])
            return sp.stack(wp.quat_rotate_inv(Q, v), sp.vec3(values[env, a + 3], values[env, a + 4], values[env, a + 5]))
        return model.dof_S[a] * values[env, a]

    @wp.func
    def dof_motion_rate(model: Model, i: int, d: int, X: sp.transform, vJ: sp.vec6):
        """The time derivative of `dof_motion` in link coordinates (Featherstone's apparent derivative): 0 but for
        a free joint's translations, [-omega x S_lin; 0] with omega = ang(v_J) (vJ: the joint's velocity)."""
        if model.joint_type[i] == FREE and d - model.v_start[i] < 3:
            return sp.stack(-wp.cross(sp.ang(vJ), sp.lin(dof_motion(model, i, d, X))), sp.vec3(scalar(0.0)))
        return sp.vec6(scalar(0.0))

    @wp.func
    def armature_energy(model: Model, env: int, i: int, velocities: wp.array2d(dtype=scalar)):
        """sum over DoFs d of link i's joint of armature_d qdot_d^2 [J] (twice the rotors' kinetic energy),
        velocities (N, nv); per joint kind, its loops of fixed length (`joint_motion_of`)."""
        kind = model.joint_type[i]
        a = model.v_start[i]
        total = scalar(0.0)
        if kind == BALL:
            for k in range(3):
                total = total + armature_of(model, env, a + k) * velocities[env, a + k] * velocities[env, a + k]
        elif kind == FREE:
            for k in range(6):
                total = total + armature_of(model, env, a + k) * velocities[env, a + k] * velocities[env, a + k]
        else:
            total = armature_of(model, env, a) * velocities[env, a] * velocities[env, a]
        return total

    @wp.func
    def joint_motion_rate(model: Model, i: int, vJ: sp.vec6):
        """Sdot qdot of link i's joint (the apparent derivative of its motion subspace times its velocities, link
        coordinates; vJ: `joint_motion_of` its velocities): 0 but for a free joint, whose translational columns
        turn with the link, [v_lin x omega; 0] with (v_lin, omega) = v_J (the sum of `dof_motion_rate`)."""
        if model.joint_type[i] == FREE:
            return sp.stack(wp.cross(sp.lin(vJ), sp.ang(vJ)), sp.vec3(scalar(0.0)))
        return sp.vec6(scalar(0.0))

    @wp.func
    def velocity_product(model: Model, i: int, v: sp.vec6, vJ: sp.vec6):
        """c_i = v_i x v_J + Sdot qdot: link i's acceleration from its joint's velocity alone (v: the link's
        velocity, vJ: `joint_motion_of` its velocities; link coordinates; `joint_motion_rate`)."""
        return sp.cross_motion(v, vJ) + joint_motion_rate(model, i, vJ)

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
        link_parameter=link_parameter,
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
        joint_terms_of=joint_terms_of,
        joint_transform_from=joint_transform_from,
        joint_quaternion=joint_quaternion,
        joint_transform=joint_transform,
        dof_motion=dof_motion,
        dof_motion_rate=dof_motion_rate,
        joint_frame_motion=joint_frame_motion,
        joint_motion_of=joint_motion_of,
        joint_motion_rate=joint_motion_rate,
        armature_energy=armature_energy,
        velocity_product=velocity_product,
        base_pose_of=base_pose_of,
        base_pose=base_pose,
        base_velocity_mixed=base_velocity_mixed,
        link_force=link_force,
        env_and_item=env_and_item,
    )
