"""How each kind of joint moves its link: the one place of the joint models, as `@wp.func`s.

Link i's joint (i >= 1; kernels/bundles.py's Model) has its positions at q_start[i]:q_start[i + 1] of the
state's joint positions and its velocities at v_start[i]:v_start[i + 1]:
- revolute and prismatic (spatial.REVOLUTE, PRISMATIC): one of each; link i in its parent at position q is
  (t0 + alpha t1 + beta t2, c Q0 + s Q1) with the joint's coefficients (c, s, alpha, beta)
  (spatial.joint_coefficients; warpdyn.types.model_constants' joint_motion_terms), its motion subspace S the
  constant dof_S;
- ball (BALL): a unit quaternion Q (w, x, y, z), 3 velocities: the child's angular velocity in its own axes,
  about the pivot t1: (t0 - (Q0 Q) t1, Q0 Q), S = [t1 x e_k; e_k];
- free (FREE): a position r, then Q; 6 velocities (MuJoCo's): the child origin's linear velocity in the joint
  frame's axes, then its angular velocity in its own: (t0 + Q0 r, Q0 Q), S = [Q^T e_k; 0] then [0; e_k], whose
  translational columns turn with the link (`dof_motion_rate`, `joint_motion_rate`).

`joints(scalar, multi_dof)` makes them for models with ball or free joints (multi_dof) or without: a model
whose joints all have one DoF compiles none of the multi-DoF code, and its addresses are i - 1 (q_start[i] =
v_start[i] = i - 1 there) without loading q_start and v_start; the kernels that move joints take the same flag
(warpdyn's Model.multi_dof()). Where a value is carried over a joint's DoFs, the loop is of fixed length per
kind (unrolled): Warp's adjoints do not allow a value carried across a dynamic loop.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import BALL, FREE, PRISMATIC, REVOLUTE, spatial


@factory
def joints(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The joint functions in `scalar` for models with (multi_dof) or without ball and free joints."""
    sp, B = spatial(scalar), bundles(scalar)
    MULTI = multi_dof
    MAX_DOFS = 6 if multi_dof else 1  # the most DoFs of a joint: loops over a joint's DoFs run to it, unrolled

    @wp.func
    def position_address(model: B.Model, i: int):
        """Where link i's joint's positions start in the joint positions."""
        if wp.static(MULTI):
            return model.q_start[i]
        return i - 1

    @wp.func
    def dof_address(model: B.Model, i: int):
        """Where link i's joint's DoFs start in the joint velocities (and forces, and per-DoF parameters)."""
        if wp.static(MULTI):
            return model.v_start[i]
        return i - 1

    @wp.func
    def dof_count(model: B.Model, i: int):
        """How many DoFs link i's joint has."""
        if wp.static(MULTI):
            return model.v_start[i + 1] - model.v_start[i]
        return 1

    @wp.func
    def joint_of_dof(model: B.Model, d: int):
        """The joint of DoF d (joint j moves link j + 1)."""
        if wp.static(MULTI):
            return model.dof_joint[d]
        return d

    @wp.func
    def terms_row(model: B.Model, env: int):
        """The row of the joint terms (P, nL) that environment env reads: min(env, P - 1)."""
        return wp.min(env, model.joint_Q0.shape[0] - 1)

    @wp.func
    def joint_terms_of(model: B.Model, env: int, i: int):
        """Link i's one-DoF joint in environment env: (its type, Q0, Q1, t0, t1, t2), the terms that move its link
        (i >= 1)."""
        r = terms_row(model, env)
        return model.joint_type[i], model.joint_Q0[r, i], model.joint_Q1[r, i], model.joint_t0[r, i], model.joint_t1[r, i], model.joint_t2[r, i]

    @wp.func
    def transform_of_terms(k: sp.vec4, Q0: sp.quat, Q1: sp.quat, t0: sp.vec3, t1: sp.vec3, t2: sp.vec3):
        """(t0 + alpha t1 + beta t2, c Q0 + s Q1): a link in its parent from its joint's terms and coefficients
        k = (c, s, alpha, beta) (spatial.joint_coefficients)."""
        return sp.transform(t0 + k[2] * t1 + k[3] * t2, k[0] * Q0 + k[1] * Q1)

    @wp.func
    def joint_transform_from(joint_type: int, Q0: sp.quat, Q1: sp.quat, t0: sp.vec3, t1: sp.vec3, t2: sp.vec3, q: scalar):
        """lambda(i)_H_i of a one-DoF joint at position q, from its terms loaded earlier (`joint_terms_of`)."""
        return transform_of_terms(sp.joint_coefficients(joint_type, q), Q0, Q1, t0, t1, t2)

    @wp.func
    def joint_quaternion(positions: wp.array2d(dtype=scalar), env: int, a: int):
        """The unit quaternion at positions[env, a:a + 4] (w, x, y, z), normalised (as MuJoCo's kinematics)."""
        return wp.normalize(sp.quat_from_wxyz(positions[env, a], positions[env, a + 1], positions[env, a + 2], positions[env, a + 3]))

    @wp.func
    def joint_transform(model: B.Model, i: int, positions: wp.array2d(dtype=scalar), env: int):
        """lambda(i)_H_i = X_tree[i] M_i(q): link i in its parent at its joint's positions in `positions`
        (N, nq) (i >= 1). A one-DoF joint's terms are loaded once its coefficients are computed: fewer registers
        live across the sine and cosine (RNEA in float64 spilled 372 instead of 300 bytes with them loaded
        first: benchmarks/registers.py)."""
        kind = model.joint_type[i]
        a = position_address(model, i)
        r = terms_row(model, env)
        if wp.static(MULTI):
            if kind == BALL:
                Q = model.joint_Q0[r, i] * joint_quaternion(positions, env, a)
                return sp.transform(model.joint_t0[r, i] - wp.quat_rotate(Q, model.joint_t1[r, i]), Q)
            if kind == FREE:
                Q0 = model.joint_Q0[r, i]
                p = sp.vec3(positions[env, a], positions[env, a + 1], positions[env, a + 2])
                return sp.transform(model.joint_t0[r, i] + wp.quat_rotate(Q0, p), Q0 * joint_quaternion(positions, env, a + 3))
        k = sp.joint_coefficients(kind, positions[env, a])
        return transform_of_terms(k, model.joint_Q0[r, i], model.joint_Q1[r, i], model.joint_t0[r, i], model.joint_t1[r, i], model.joint_t2[r, i])

    @wp.func
    def free_joint_quaternion(model: B.Model, i: int, X: sp.transform):
        """The rotation of link i's free joint itself: Q0^-1 times that of its transform X = lambda(i)_H_i (a free
        joint's Q0 is the same in every row of the terms)."""
        return wp.quat_inverse(model.joint_Q0[0, i]) * wp.transform_get_rotation(X)

    @wp.func
    def dof_motion(model: B.Model, i: int, d: int, X: sp.transform):
        """S_d: the motion subspace column of DoF d of link i's joint, link coordinates, with X = lambda(i)_H_i
        the joint's transform. Constant (model.dof_S) but for a free joint's translations: [Q^T e_k; 0] with Q
        the joint's own rotation (Q0^-1 times X's)."""
        S = model.dof_S[d]
        if wp.static(MULTI):
            if model.joint_type[i] == FREE and d - model.v_start[i] < 3:
                Q = free_joint_quaternion(model, i, X)
                return sp.stack(wp.quat_rotate_inv(Q, sp.lin(S)), sp.vec3(scalar(0.0)))
        return S

    @wp.func
    def free_joint_rotation(model: B.Model, i: int, X: sp.transform):
        """R: the rotation of link i's free joint itself (Q0^-1 times that of its transform X = lambda(i)_H_i),
        as a matrix: its motion subspace is S_i = diag(R^T, 1) (`dof_motion`)."""
        return wp.quat_to_matrix(free_joint_quaternion(model, i, X))

    @wp.func
    def dof_motion_rate(model: B.Model, i: int, d: int, X: sp.transform, vJ: sp.vec6):
        """The time derivative of `dof_motion` in link coordinates (Featherstone's apparent derivative): 0 but for
        a free joint's translations, [-omega x S_lin; 0] with omega = ang(v_J) (vJ: the joint's velocity)."""
        if wp.static(MULTI):
            if model.joint_type[i] == FREE and d - model.v_start[i] < 3:
                return sp.stack(-wp.cross(sp.ang(vJ), sp.lin(dof_motion(model, i, d, X))), sp.vec3(scalar(0.0)))
        return sp.vec6(scalar(0.0))

    @wp.func
    def joint_frame_motion(model: B.Model, i: int, W_H_L: wp.array2d(dtype=sp.transform), env: int):
        """What `dof_motion` needs of link i's joint transform, from the link poses W_H_L (N, nL): lambda(i)_H_i
        for a free joint, the identity otherwise (which no other joint's motion subspace reads)."""
        if wp.static(MULTI):
            if model.joint_type[i] == FREE:
                return wp.transform_inverse(W_H_L[env, model.parent[i]]) * W_H_L[env, i]
        return wp.transform_identity(dtype=scalar)

    @wp.func
    def joint_motion_of(model: B.Model, i: int, X: sp.transform, values: wp.array2d(dtype=scalar), env: int):
        """S_i(q) values[env, DoFs of link i's joint]: the motion of link i relative to its parent, link
        coordinates, for the DoF values of its joint in `values` (N, nv) (velocities: v_J; accelerations: S qdd);
        X: the joint's transform."""
        a = dof_address(model, i)
        if wp.static(MULTI):
            kind = model.joint_type[i]
            if kind == BALL:
                w = sp.vec3(values[env, a], values[env, a + 1], values[env, a + 2])
                return sp.stack(wp.cross(model.joint_t1[terms_row(model, env), i], w), w)  # a rotation about the pivot t1 (child frame)
            if kind == FREE:
                Q = free_joint_quaternion(model, i, X)
                v = sp.vec3(values[env, a], values[env, a + 1], values[env, a + 2])
                return sp.stack(wp.quat_rotate_inv(Q, v), sp.vec3(values[env, a + 3], values[env, a + 4], values[env, a + 5]))
        return model.dof_S[a] * values[env, a]

    @wp.func
    def joint_motion_rate(model: B.Model, i: int, vJ: sp.vec6):
        """Sdot qdot of link i's joint (the apparent derivative of its motion subspace times its velocities, link
        coordinates; vJ: `joint_motion_of` its velocities): 0 but for a free joint, [v_lin x omega; 0] with
        (v_lin, omega) = v_J (the sum of `dof_motion_rate`)."""
        if wp.static(MULTI):
            if model.joint_type[i] == FREE:
                return sp.stack(wp.cross(sp.lin(vJ), sp.ang(vJ)), sp.vec3(scalar(0.0)))
        return sp.vec6(scalar(0.0))

    @wp.func
    def link_velocity(X: sp.transform, v_parent: sp.vec6, vJ: sp.vec6):
        """v_i = iX_lambda v_lambda + v_J,i: link i's velocity (link coordinates) from its parent's and its joint's
        motion vJ (`joint_motion_of` its velocities); X = lambda(i)_H_i its joint's transform."""
        return sp.motion_from(X, v_parent) + vJ

    @wp.func
    def velocity_product(model: B.Model, i: int, v: sp.vec6, vJ: sp.vec6):
        """c_i = v_i x v_J + Sdot qdot: link i's acceleration from its joint's velocity alone (v: the link's
        velocity, vJ: `joint_motion_of` its velocities; link coordinates; `joint_motion_rate`)."""
        if wp.static(MULTI):
            return sp.cross_motion(v, vJ) + joint_motion_rate(model, i, vJ)
        return sp.cross_motion(v, vJ)

    @wp.func
    def armature_energy(model: B.Model, env: int, i: int, velocities: wp.array2d(dtype=scalar)):
        """sum over DoFs d of link i's joint of armature_d qdot_d^2 [J] (twice the rotors' kinetic energy),
        velocities (N, nv)."""
        a = dof_address(model, i)
        total = B.armature_of(model, env, a) * velocities[env, a] * velocities[env, a]
        if wp.static(MULTI):
            kind = model.joint_type[i]
            if kind == BALL:
                for k in range(1, 3):
                    total = total + B.armature_of(model, env, a + k) * velocities[env, a + k] * velocities[env, a + k]
            elif kind == FREE:
                for k in range(1, 6):
                    total = total + B.armature_of(model, env, a + k) * velocities[env, a + k] * velocities[env, a + k]
        return total

    @wp.kernel(module="unique")
    def joint_terms_from_origins(
        joint_type: wp.array(dtype=int),
        position: wp.array3d(dtype=scalar),
        rotation: wp.array3d(dtype=scalar),
        axis: wp.array(dtype=sp.vec3),
        pivot: wp.array(dtype=sp.vec3),
        base: wp.array2d(dtype=sp.quat),
        base_t: wp.array2d(dtype=sp.vec3),
        # outputs
        Q0: wp.array2d(dtype=sp.quat),
        Q1: wp.array2d(dtype=sp.quat),
        t0: wp.array2d(dtype=sp.vec3),
        t1: wp.array2d(dtype=sp.vec3),
        t2: wp.array2d(dtype=sp.vec3),
    ):
        """Link j + 1's joint terms in row r (kernels/bundles.py's Model, (P, nL)) from joint j's frame in the parent
        link, X_tree = (p, A): position p = position[r, j] [m] and rotation A = rotation[r, j] (w, x, y, z),
        normalised here (both (P or 1, nj, 3) and (P or 1, nj, 4): row min(r, rows - 1)), with the joint's axis a and pivot d
        (child frame): warpdyn.types.model_constants.joint_motion_terms' formulas (tests/test_joint_origins.py
        holds the two equal), revolute: Q0 = A, Q1 = A (a, 0), t0 = p + A d_perp, t1 = -A d_perp, t2 = -A (a x d),
        d_perp = d - (a.d) a; prismatic: t1 = A a; ball: t0 = p + A d, t1 = d; free and the base: Q0 = A, t0 = p.
        Launched over (P, nL): link 0, the base, gets the terms base[0, 0] (Q0) and base_t[0, 0] (t0) with Q1, t1, t2
        zero (its terms are constant: the model's own)."""
        r, i = wp.tid()
        if i == 0:
            Q0[r, 0] = base[0, 0]
            Q1[r, 0] = sp.quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(0.0))
            t0[r, 0] = base_t[0, 0]
            t1[r, 0] = sp.vec3(scalar(0.0))
            t2[r, 0] = sp.vec3(scalar(0.0))
            return
        j = i - 1
        rr = wp.min(r, rotation.shape[0] - 1)
        rp = wp.min(r, position.shape[0] - 1)
        A = wp.normalize(sp.quat_from_wxyz(rotation[rr, j, 0], rotation[rr, j, 1], rotation[rr, j, 2], rotation[rr, j, 3]))
        p = sp.vec3(position[rp, j, 0], position[rp, j, 1], position[rp, j, 2])
        a = axis[i]
        d = pivot[i]
        zero = sp.vec3(scalar(0.0))
        kind = joint_type[i]
        q1 = sp.quat(scalar(0.0), scalar(0.0), scalar(0.0), scalar(0.0))
        o0 = p
        o1 = zero
        o2 = zero
        if kind == REVOLUTE:
            d_perp = d - wp.dot(a, d) * a
            q1 = A * sp.quat(a[0], a[1], a[2], scalar(0.0))
            o0 = p + wp.quat_rotate(A, d_perp)
            o1 = -wp.quat_rotate(A, d_perp)
            o2 = -wp.quat_rotate(A, wp.cross(a, d))
        elif kind == PRISMATIC:
            o1 = wp.quat_rotate(A, a)
        elif kind == BALL:
            o0 = p + wp.quat_rotate(A, d)
            o1 = d
        Q0[r, i] = A
        Q1[r, i] = q1
        t0[r, i] = o0
        t1[r, i] = o1
        t2[r, i] = o2

    return types.SimpleNamespace(
        joint_terms_from_origins=joint_terms_from_origins,
        MULTI=MULTI,
        MAX_DOFS=MAX_DOFS,
        position_address=position_address,
        dof_address=dof_address,
        dof_count=dof_count,
        joint_of_dof=joint_of_dof,
        joint_terms_of=joint_terms_of,
        joint_transform_from=joint_transform_from,
        joint_quaternion=joint_quaternion,
        joint_transform=joint_transform,
        dof_motion=dof_motion,
        free_joint_rotation=free_joint_rotation,
        dof_motion_rate=dof_motion_rate,
        joint_frame_motion=joint_frame_motion,
        joint_motion_of=joint_motion_of,
        joint_motion_rate=joint_motion_rate,
        link_velocity=link_velocity,
        velocity_product=velocity_product,
        armature_energy=armature_energy,
    )
