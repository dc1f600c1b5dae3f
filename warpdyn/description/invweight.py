"""MuJoCo's dof_invweight0 of a lumped tree: the diagonal of the inverse mass matrix at the joints' zero positions
(MuJoCo's qpos0 for a URDF or SDF, whose joints have no `ref`), the scale of a limit or friction row's regularisation
R (`LimitConstraint`, `FrictionConstraint`) where no MuJoCo model gives it (an MJCF's comes from MuJoCo's compile).

MuJoCo's mj_setConst takes M^-1's diagonal at qpos0, armature included, a ball joint's three entries averaged and a free
joint's translational and rotational three each. M is summed here link by link, M = sum_k J_k^T I_k J_k (J_k: link k's
twist Jacobian at the world origin, [v; w]; I_k its spatial inertia there), each DoF's column MuJoCo's motion: a free
joint's translation along the world's axes and rotation about its body's axes through its origin (a floating base's
six DoFs as world unit twists: its entries are not returned, and a joint's entry (M^-1)_ii = 1 / (the Schur complement
of the other DoFs' block) depends only on the span of the others' motions). Computed once per model build on the host
in float64 (a model's kernels compute M for steps; this is a constant of the description, like MuJoCo's).
"""

from __future__ import annotations

import numpy as np

SINGULAR = 1e14
"""The condition number of M from which it counts as singular (float64 keeps no digit of its inverse beyond it)."""


def _cross(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


def inertia_in_frame(mass, com, inertia, H):
    """Mass, CoM and inertia about the CoM of a body, expressed in the frame where it sits at H."""
    return mass, H[:3, :3] @ com + H[:3, 3], H[:3, :3] @ inertia @ H[:3, :3].T


def _spatial_inertia(mass: float, com: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """(6, 6) a body's inertia for twists [v; w] at the world origin: com (3,) its world CoM [m], inertia (3, 3) about
    the CoM in world axes [kg m^2]: [[m 1, -m [c]x], [m [c]x, I - m [c]x [c]x]] (kinetic energy m |v + w x c|^2 / 2 +
    w^T I w / 2)."""
    c = _cross(com)
    return np.block([[mass * np.eye(3), -mass * c], [mass * c, inertia - mass * c @ c]])


def dof_invweight0(parent, joint_kind, parent_H_joint, joint_axis, joint_pivot, mass, com, inertia, v_start, armature,
                   floating: bool) -> np.ndarray:  # fmt: skip
    """(nv,) MuJoCo's dof_invweight0 of a tree's joint DoFs at their zero positions: the lumped tree's arrays (see
    `KinematicTree`: parent (nL,), parent_H_joint (nL, 4, 4), joint_axis and joint_pivot (nL, 3) in
    the link's frame, mass (nL,), com (nL, 3), inertia (nL, 3, 3), v_start (nL + 1,), armature (nv,)), floating: a
    floating base (its six DoFs in M, not in the result); joint_kind (nL,): each link's joint's description type
    ("revolute", "prismatic", "ball" or "free"; the base's ignored). A ball's or free joint's entries averaged as
    MuJoCo's; NaN where M is singular (a massless chain) or an entry is not positive."""
    nL, nv = len(parent), int(v_start[-1])
    base = 6 if floating else 0
    world_H = [np.eye(4)] * nL
    S = np.zeros((nL, 6, base + nv))  # each link's own joint's columns, at the world origin
    if floating:
        S[0, :, :6] = np.eye(6)
    for i in range(1, nL):
        world_H[i] = world_H[parent[i]] @ parent_H_joint[i]
        R, first = world_H[i][:3, :3], base + int(v_start[i])
        pivot = world_H[i][:3, :3] @ joint_pivot[i] + world_H[i][:3, 3]
        if joint_kind[i] == "revolute":
            w = R @ joint_axis[i]
            S[i, :, first] = np.concatenate([np.cross(pivot, w), w])
        elif joint_kind[i] == "prismatic":
            S[i, :3, first] = R @ joint_axis[i]
        elif joint_kind[i] == "ball":
            for k in range(3):
                w = R[:, k]
                S[i, :, first + k] = np.concatenate([np.cross(pivot, w), w])
        elif joint_kind[i] == "free":  # MuJoCo's: the origin's velocity in world axes, then the body's angular velocity
            S[i, :3, first : first + 3] = np.eye(3)
            for k in range(3):
                w = R[:, k]
                S[i, :, first + 3 + k] = np.concatenate([np.cross(world_H[i][:3, 3], w), w])
    J = S.copy()  # link k's twist Jacobian: its own columns and its ancestors'
    for i in range(1, nL):
        J[i] += J[parent[i]]
    M = np.zeros((base + nv, base + nv))
    for i in range(nL):
        I = _spatial_inertia(*inertia_in_frame(mass[i], com[i], inertia[i], world_H[i]))
        M += J[i].T @ I @ J[i]
    M[base:, base:] += np.diag(np.asarray(armature, dtype=np.float64).reshape(nv))
    if not np.linalg.cond(M) < SINGULAR:  # a massless chain: no inverse weight (a step refuses the rows, naming them)
        return np.full(nv, np.nan)
    diagonal = np.diag(np.linalg.inv(M))[base:].copy()
    diagonal[~(diagonal > 0.0)] = np.nan
    for i in range(1, nL):
        first = int(v_start[i])
        if joint_kind[i] == "ball":
            diagonal[first : first + 3] = diagonal[first : first + 3].mean()
        elif joint_kind[i] == "free":
            diagonal[first : first + 3] = diagonal[first : first + 3].mean()
            diagonal[first + 3 : first + 6] = diagonal[first + 3 : first + 6].mean()
    return diagonal
