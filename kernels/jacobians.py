"""Free-floating Jacobians of frames rigidly attached to links.

For a frame F on link L, in the Inertial representation of both the input and the output,
    W_v_WF = W_v_WB + sum_{j in path(L)} W_X_{L_j} S_j sdot_j,
so the Jacobian is [I_6 | W_X_{L_j} S_j where joint j supports L, else 0]. Input and output
representations are applied to its columns: the base columns are the unit vectors of the input
representation mapped to Inertial; every column is then mapped to the output representation of F.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)
    B = bundles(scalar)

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
        """J (N, T, 6, 6 + n): the Jacobian of target t, launched over (N, T); W_H_L (N, nL) the link poses."""
        env, t = wp.tid()
        L = targets.link[t]
        W_H_F = W_H_L[env, L] * targets.link_H_target[t]
        W_H_B = W_H_L[env, 0]
        for c in range(6):
            e = sp.vec6(scalar(0.0))
            e[c] = scalar(1.0)
            col = sp.inertial_to_repr(output_repr, W_H_F, sp.repr_to_inertial(input_repr, W_H_B, e))
            for r in range(6):
                J[env, t, r, c] = col[r]
        for j in range(model.support.shape[1]):
            col_j = sp.vec6(scalar(0.0))
            if model.support[L, j] != 0:
                S = B.motion_subspace_of(model, j + 1)
                col_j = sp.inertial_to_repr(output_repr, W_H_F, sp.motion_to(W_H_L[env, j + 1], S))
            for r in range(6):
                J[env, t, r, 6 + j] = col_j[r]

    return types.SimpleNamespace(jacobians=jacobians)
