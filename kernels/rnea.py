"""Recursive Newton-Euler: inverse dynamics, bias and gravity forces, one thread per environment.

Featherstone's RNEA in link coordinates, gravity entering as a fictitious base acceleration -a_g:
    v_i = iX_lambda v_lambda + v_J,i,   a_i = iX_lambda a_lambda + S_i qdd_i + c_i,
    f_i = I_i a_i + v_i x* I_i v_i - f_ext_i + sum_children lambdaX*_c f_c,   tau_d = S_d^T f_i + armature_d qdd_d
for each DoF d of link i's joint (v_J,i = S_i qd_i and c_i = v_i x v_J,i + Sdot_i qd_i: kernels/bundles.py's
`joint_motion_of` and `velocity_product`).
The sum over children is a sibling chain, so that every element is written once (tape-safe):
    acc_c = lambdaX*_c f_c + acc_{next sibling of c},   and a link adds acc_{first child}.
The base acceleration and the base wrench are converted from and to the requested representation.
Scratch is one scalar record per link (kernels/scratch.py); iX_lambda is recomputed, not stored.
"""

import types

import warp as wp

from .aba import inertia_funcs
from .bundles import bundles
from .joints import joints
from .registers import tuned
from .scratch import scratch
from .spatial import MIXED, spatial

# Columns of the RNEA's per-link scratch record (N, nL, RNEA_RECORD[+ TRANSFORM with link forces]).
_V = 0  # v_i (6)
_A = 6  # a_i (6)
_ACC = 12  # the sibling chain's sum of lambdaX*_c f_c (6)
_WHL = 18  # W_H_L (7), only with link forces
RNEA_RECORD = _WHL
"""Scratch numbers per link without link forces (with them: RNEA_RECORD + 7)."""


MAX_REGISTERS = {wp.float32: None, wp.float64: 128}
"""Register cap per thread on CUDA by scalar, measured on an H200 at N = 65536 (benchmarks/results/dynamics_h200_run2.md):
float64 218 -> 128 registers: kernel 0.111 -> 0.092 ms; float32 already uses 127."""


@tuned(MAX_REGISTERS)
def kernels(scalar, max_registers, multi_dof: bool):
    """RNEA (inverse dynamics, bias and gravity forces) in `scalar`, its registers per thread capped on CUDA by `max_registers` (kernels/registers.py),
    for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp, sc, B = spatial(scalar), scratch(scalar), bundles(scalar)
    jm = joints(scalar, multi_dof)
    F = inertia_funcs(scalar)
    external_force, link_acceleration, bias_force = F.external_force, F.link_acceleration, F.bias_force

    @wp.kernel(module="unique", cuda_max_registers=max_registers)
    def rnea(
        model: B.Model,
        state: B.State,
        # inputs (an array with a zero leading axis means zero)
        base_acceleration: wp.array2d(dtype=scalar),
        joint_accelerations: wp.array2d(dtype=scalar),
        controls: B.Controls,
        repr: int,
        with_velocity: scalar,
        with_gravity: scalar,
        # scratch
        s: wp.array3d(dtype=scalar),
        # outputs
        f_B: wp.array2d(dtype=scalar),
        tau: wp.array2d(dtype=scalar),
    ):
        """f_B (N, 6), tau (N, nv): the generalized forces that produce the given accelerations.

        base_acceleration (N, 6): the derivative of the base velocity in `repr`; joint_accelerations (N, nv);
        controls.link_forces (N, nL, 6): external link forces in `repr` (its joint forces are not read).
        with_velocity and with_gravity scale the velocities and gravity (0 or 1). f_B is the base wrench as
        the generalized force dual to the base velocity in `repr`. s (N, nL, RNEA_RECORD, + 7 with link forces): scratch, columns named
        at the top of this file.
        """
        env = wp.tid()
        nL = model.parent.shape[0]
        forces = controls.link_forces.shape[0] > 0
        W_H_B = B.base_pose(state, env)
        B_v = sp.motion_from(W_H_B, sp.repr_to_inertial(MIXED, W_H_B, B.base_velocity_mixed(state, env) * with_velocity))
        B_a_g = B.gravity_in(model, env, W_H_B) * with_gravity
        a_in = sp.vec6(scalar(0.0))
        if base_acceleration.shape[0] > 0:
            a_in = sc.row6(base_acceleration, env, 0)
        B_a = sp.base_acceleration_to_body(repr, W_H_B, B_v, a_in) - B_a_g
        sc.put6(s, env, 0, _V, B_v)
        sc.put6(s, env, 0, _A, B_a)
        if forces:
            sc.put_transform(s, env, 0, _WHL, W_H_B)
        # velocities and accelerations, from the base
        for i in range(1, nL):
            X = jm.joint_transform(model, i, state.joint_positions, env)
            vJ = jm.joint_motion_of(model, i, X, state.joint_velocities, env) * with_velocity
            v_i = jm.link_velocity(X, sc.get6(s, env, model.parent[i], _V), vJ)
            a_i = link_acceleration(X, sc.get6(s, env, model.parent[i], _A), jm.velocity_product(model, i, v_i, vJ))
            if joint_accelerations.shape[0] > 0:
                a_i = a_i + jm.joint_motion_of(model, i, X, joint_accelerations, env)
            sc.put6(s, env, i, _V, v_i)
            sc.put6(s, env, i, _A, a_i)
            if forces:
                sc.put_transform(s, env, i, _WHL, sc.get_transform(s, env, model.parent[i], _WHL) * X)
        # forces, from the leaves
        for k in range(nL - 1):
            i = nL - 1 - k
            X = jm.joint_transform(model, i, state.joint_positions, env)
            f_ext = sp.vec6(scalar(0.0))
            if forces:
                f_ext = external_force(controls, repr, s, _WHL, env, i)
            v_i = sc.get6(s, env, i, _V)
            f_i = B.spatial_inertia_times(model, env, i, sc.get6(s, env, i, _A)) + bias_force(v_i, B.spatial_inertia_times(model, env, i, v_i)) - f_ext
            if model.first_child[i] >= 0:
                f_i = f_i + sc.get6(s, env, model.first_child[i], _ACC)
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, i):
                    d = jm.dof_address(model, i) + k_dof
                    rotor = scalar(0.0)
                    if joint_accelerations.shape[0] > 0:
                        rotor = B.armature_of(model, env, d) * joint_accelerations[env, d]
                    tau[env, d] = wp.dot(jm.dof_motion(model, i, d, X), f_i) + rotor
            up = sp.force_to(X, f_i)
            if model.next_sibling[i] >= 0:
                up = up + sc.get6(s, env, model.next_sibling[i], _ACC)
            sc.put6(s, env, i, _ACC, up)
        f_ext = sp.vec6(scalar(0.0))
        if forces:
            f_ext = external_force(controls, repr, s, _WHL, env, 0)
        # a floating base's free-joint armature acts on its true acceleration (B_a less the fictitious gravity's)
        f_0 = F.base_inertia(model, env, scalar(0.0)) * B_a + F.base_bias_force(model, env, scalar(0.0), B_v, B_a_g) - f_ext
        if model.first_child[0] >= 0:
            f_0 = f_0 + sc.get6(s, env, model.first_child[0], _ACC)
        base = sp.base_force_from_body(repr, W_H_B, f_0)
        for r in range(6):
            f_B[env, r] = base[r]

    return types.SimpleNamespace(rnea=rnea)
