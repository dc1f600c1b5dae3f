"""Free-floating Jacobians of frames rigidly attached to links.

For a frame F on link L, in the Inertial representation of both the input and the output,
    W_v_WF = W_v_WB + sum_{j in path(L)} W_X_{L_j} S_j sdot_j,
so the Jacobian is [I_6 | W_X_{L_j} S_d for each DoF d of joint j where joint j supports L, else 0]. Input and output
representations are applied to its columns: the base columns are the unit vectors of the input
representation mapped to Inertial; every column is then mapped to the output representation of F.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .joints import joints
from .spatial import spatial


@factory
def kernels(scalar, multi_dof: bool) -> types.SimpleNamespace:
    """The kernels in `scalar` for models with (multi_dof) or without ball and free joints (kernels/joints.py)."""
    sp = spatial(scalar)
    B = bundles(scalar)
    jm = joints(scalar, multi_dof)

    @wp.kernel(module="unique")
    def jacobians(
        model: B.Model,
        targets: B.Targets,
        W_H_L: wp.array2d(dtype=sp.transform),
        input_repr: int,
        output_repr: int,
        # outputs
        J: wp.array4d(dtype=scalar),
    ):
        """J (N, T, 6, 6 + nv): the Jacobian of target t, launched over (N, T); W_H_L (N, nL) the link poses."""
        env, t = wp.tid()
        L = targets.link[t]
        W_H_F = W_H_L[env, L] * B.target_pose(targets, env, t)
        W_H_B = W_H_L[env, 0]
        for c in range(6):
            e = sp.vec6(scalar(0.0))
            e[c] = scalar(1.0)
            col = sp.inertial_to_repr(output_repr, W_H_F, sp.repr_to_inertial(input_repr, W_H_B, e))
            for r in range(6):
                J[env, t, r, c] = col[r]
        for i in range(1, model.parent.shape[0]):  # link i's joint, joint i - 1
            moves = model.support[L, i - 1] != 0
            X = wp.transform_identity(dtype=scalar)
            if moves:
                X = jm.joint_frame_motion(model, i, W_H_L, env)
            for k_dof in range(wp.static(jm.MAX_DOFS)):  # a joint's DoFs (unrolled; one in a model of one-DoF joints)
                if k_dof < jm.dof_count(model, i):
                    d = jm.dof_address(model, i) + k_dof
                    col_d = sp.vec6(scalar(0.0))
                    if moves:
                        col_d = sp.inertial_to_repr(output_repr, W_H_F, sp.motion_to(W_H_L[env, i], jm.dof_motion(model, i, d, X)))
                    for r in range(6):
                        J[env, t, r, 6 + d] = col_d[r]

    return types.SimpleNamespace(jacobians=jacobians)
