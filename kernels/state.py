"""State bookkeeping on the device: copying inputs into the state, and base-velocity representations.

The state keeps the base velocity in the Mixed representation, [W_pdot_B; W_omega_WB].
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .scratch import scratch
from .spatial import MIXED, spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)
    base_pose = bundles(scalar).base_pose_of
    row6 = scratch(scalar).row6
    vec4 = wp.types.vector(4, scalar)

    @wp.kernel(module="unique")
    def broadcast_rows(
        # inputs
        src: wp.array2d(dtype=scalar),
        # outputs
        dst: wp.array2d(dtype=scalar),
    ):
        """dst[env, k] = src[env, k], or src[0, k] for every env when src has one row; launched over dst."""
        env, k = wp.tid()
        row = env
        if src.shape[0] == 1:
            row = 0
        dst[env, k] = src[row, k]

    @wp.kernel(module="unique")
    def base_velocity_to_repr(
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        repr: int,
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 6): the state's Mixed base velocity in representation `repr`."""
        env = wp.tid()
        W_H_B = base_pose(base_position, base_quaternion, env)
        v = sp.change_repr(MIXED, repr, W_H_B, row6(base_velocity, env, 0))
        for r in range(6):
            out[env, r] = v[r]

    @wp.kernel(module="unique")
    def base_velocity_from_repr(
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        linear: wp.array2d(dtype=scalar),
        angular: wp.array2d(dtype=scalar),
        repr: int,
        # outputs
        base_velocity: wp.array2d(dtype=scalar),
    ):
        """base_velocity (N, 6) in Mixed, from its linear (N, 3) and angular (N, 3) parts in `repr`."""
        env = wp.tid()
        W_H_B = base_pose(base_position, base_quaternion, env)
        given = sp.vec6(
            linear[env, 0], linear[env, 1], linear[env, 2], angular[env, 0], angular[env, 1], angular[env, 2]
        )
        v = sp.change_repr(repr, MIXED, W_H_B, given)
        for r in range(6):
            base_velocity[env, r] = v[r]

    @wp.kernel(module="unique")
    def generalized_velocity(
        # state
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        base_velocity: wp.array2d(dtype=scalar),
        joint_velocities: wp.array2d(dtype=scalar),
        repr: int,
        # outputs
        nu: wp.array2d(dtype=scalar),
    ):
        """nu (N, 6 + n): the base velocity in `repr`, then the joint velocities."""
        env = wp.tid()
        W_H_B = base_pose(base_position, base_quaternion, env)
        v = sp.change_repr(MIXED, repr, W_H_B, row6(base_velocity, env, 0))
        for r in range(6):
            nu[env, r] = v[r]
        for j in range(joint_velocities.shape[1]):
            nu[env, 6 + j] = joint_velocities[env, j]

    @wp.kernel(module="unique")
    def normalized_quaternion(
        # state
        base_quaternion: wp.array2d(dtype=scalar),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 4): base_quaternion (w, x, y, z) divided by its norm."""
        env = wp.tid()
        q = wp.normalize(
            vec4(base_quaternion[env, 0], base_quaternion[env, 1], base_quaternion[env, 2], base_quaternion[env, 3])
        )
        for k in range(4):
            out[env, k] = q[k]

    @wp.kernel(module="unique")
    def actuated_minus(
        # inputs
        tau: wp.array2d(dtype=scalar),
        Q: wp.array2d(dtype=scalar),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 6 + n) = [0; tau] - Q: the joint forces (N, n) less the generalized forces Q (N, 6 + n)."""
        env = wp.tid()
        for r in range(6):
            out[env, r] = -Q[env, r]
        for j in range(tau.shape[1]):
            out[env, 6 + j] = tau[env, j] - Q[env, 6 + j]

    @wp.kernel(module="unique")
    def passive_from_parts(
        # inputs: RNEA's forces against the compensation, and the joints' springs and dampers
        f_B: wp.array2d(dtype=scalar),
        tau: wp.array2d(dtype=scalar),
        joints: wp.array2d(dtype=scalar),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, 6 + n) = [-f_B; joints - tau]: the passive generalized forces (see engine.dynamics)."""
        env = wp.tid()
        for r in range(6):
            out[env, r] = -f_B[env, r]
        for j in range(tau.shape[1]):
            out[env, 6 + j] = joints[env, j] - tau[env, j]

    @wp.kernel(module="unique")
    def join_columns(
        # inputs
        a: wp.array2d(dtype=scalar),
        b: wp.array2d(dtype=scalar),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out (N, ka + kb) = [a (N, ka), b (N, kb)]."""
        env = wp.tid()
        ka = a.shape[1]
        for k in range(ka):
            out[env, k] = a[env, k]
        for k in range(b.shape[1]):
            out[env, ka + k] = b[env, k]

    @wp.kernel(module="unique")
    def select_rows(
        # inputs
        selected: wp.array(dtype=wp.int32),
        chosen: wp.array2d(dtype=scalar),
        other: wp.array2d(dtype=scalar),
        # outputs
        out: wp.array2d(dtype=scalar),
    ):
        """out[env] = chosen[env] where selected[env] != 0, else other[env]."""
        env = wp.tid()
        for k in range(out.shape[1]):
            if selected[env] != 0:
                out[env, k] = chosen[env, k]
            else:
                out[env, k] = other[env, k]

    @wp.kernel(module="unique")
    def select_rows_3d(
        # inputs
        selected: wp.array(dtype=wp.int32),
        chosen: wp.array3d(dtype=scalar),
        other: wp.array3d(dtype=scalar),
        # outputs
        out: wp.array3d(dtype=scalar),
    ):
        """out[env] = chosen[env] where selected[env] != 0, else other[env]."""
        env = wp.tid()
        for k in range(out.shape[1]):
            for a in range(out.shape[2]):
                if selected[env] != 0:
                    out[env, k, a] = chosen[env, k, a]
                else:
                    out[env, k, a] = other[env, k, a]

    @wp.kernel(module="unique")
    def select_valid(
        # inputs
        selected: wp.array(dtype=wp.int32),
        valid: wp.array(dtype=wp.int32),
        # outputs
        out: wp.array(dtype=wp.int32),
    ):
        """out[env] = 1 where selected (reset), else valid[env]."""
        env = wp.tid()
        if selected[env] != 0:
            out[env] = 1
        else:
            out[env] = valid[env]

    return types.SimpleNamespace(
        select_rows=select_rows,
        select_rows_3d=select_rows_3d,
        select_valid=select_valid,
        passive_from_parts=passive_from_parts,
        join_columns=join_columns,
        actuated_minus=actuated_minus,
        normalized_quaternion=normalized_quaternion,
        broadcast_rows=broadcast_rows,
        base_velocity_to_repr=base_velocity_to_repr,
        base_velocity_from_repr=base_velocity_from_repr,
        generalized_velocity=generalized_velocity,
    )
