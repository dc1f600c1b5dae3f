"""A model's device constants from its lumped tree: the joints as the kernels move them (`joint_motion_terms`),
transforms and quaternions in Warp's layout, and the sibling chains the backward passes sum over."""

from __future__ import annotations

import numpy as np
import warp as wp

from ..description.tree import JOINT_BALL, JOINT_FREE, JOINT_PRISMATIC, JOINT_REVOLUTE, KinematicTree

__all__ = ["transforms", "quaternion_xyzw", "joint_motion_terms", "sibling_chains"]


def transforms(H: np.ndarray, scalar, device) -> wp.array:
    """Warp transforms (p, quaternion xyzw) of homogeneous matrices (K, 4, 4)."""
    H = np.asarray(H, dtype=np.float64).reshape(-1, 4, 4)
    rows = np.zeros((len(H), 7))
    for k, M in enumerate(H):
        rows[k, :3] = M[:3, 3]
        rows[k, 3:] = quaternion_xyzw(M[:3, :3])
    return wp.array(rows, dtype=wp.types.transformation(scalar), device=device)


def quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0.0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(max(1.0 + R[i, i] - R[j, j] - R[k, k], 1e-300))
        q = [0.0, 0.0, 0.0, (R[k, j] - R[j, k]) / s]
        q[i] = 0.25 * s
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
    q = np.asarray(q)
    return q / np.linalg.norm(q)


JOINT_TERMS = ("joint_Q0", "joint_Q1", "joint_t0", "joint_t1", "joint_t2")
"""The Model's arrays of joint terms (`joint_motion_terms`'s Q0, Q1, t0, t1, t2; kernels/bundles.py's Model)."""


def joint_motion_terms(tree: KinematicTree) -> dict[str, np.ndarray]:
    """Each link's joint as the kernels move it (kernels/bundles.py's Model): link i in its parent at joint
    position q, X_tree M(q) (warpdyn.description's joint_motion), and the joint's motion subspace, one column
    per DoF (link coordinates). With X_tree = (p, A):
    - revolute, unit axis a through the pivot d (Rodrigues' formula, d_perp = d - (a.d) a): X_tree M(q) =
      (t0 + alpha t1 + beta t2, c Q0 + s Q1) with the coefficients (c, s, alpha, beta) of kernels/spatial.py's
      joint_coefficients, Q0 = A, Q1 = A (a, 0), t0 = p + A d_perp, t1 = -A d_perp, t2 = -A (a x d); S = [d x a; a];
    - prismatic along a: the same form, Q0 = A, Q1 = 0, t0 = p, t1 = A a, t2 = 0; S = [a; 0];
    - ball about the pivot d, q the quaternion Q: X_tree M(q) = (t0 - (A Q) t1, A Q) with Q0 = A, t0 = p + A d,
      t1 = d; S = [d x e_k; e_k] for k = x, y, z (the child's angular velocity, child axes);
    - free, q = (r, Q): X_tree M(q) = (t0 + A r, A Q) with Q0 = A, t0 = p; S = [Q^T e_k; 0] (MuJoCo's linear
      velocity, in the joint frame's axes: the kernels rotate e_k, stored here, by Q^T) then [0; e_k];
    - the base: Q0 = A, t0 = p, the others 0.
    Returns per link (nL, 4) quaternions (x, y, z, w) Q0, Q1 and (nL, 3) arrays t0, t1, t2; per DoF (nv, 6) S;
    float64."""
    nL = tree.number_of_links
    terms = {name: np.zeros((nL, size)) for name, size in (("Q0", 4), ("Q1", 4), ("t0", 3), ("t1", 3), ("t2", 3))}
    S = []
    for i in range(nL):
        H = np.asarray(tree.parent_H_joint[i], dtype=np.float64)
        R, p = H[:3, :3], H[:3, 3]
        A = quaternion_xyzw(R)
        a, d = np.asarray(tree.joint_axis[i], dtype=np.float64), np.asarray(tree.joint_pivot[i], dtype=np.float64)
        terms["Q0"][i] = A
        terms["t0"][i] = p
        kind = tree.joint_type[i]
        if kind == JOINT_REVOLUTE:
            d_perp = d - (a @ d) * a
            terms["Q1"][i] = [*(A[3] * a + np.cross(A[:3], a)), -A[:3] @ a]  # A (a, 0), (x, y, z, w)
            terms["t0"][i] = p + R @ d_perp
            terms["t1"][i] = -R @ d_perp
            terms["t2"][i] = -R @ np.cross(a, d)
            S.append([*np.cross(d, a), *a])
        elif kind == JOINT_PRISMATIC:
            terms["t1"][i] = R @ a
            S.append([*a, 0.0, 0.0, 0.0])
        elif kind == JOINT_BALL:
            terms["t0"][i] = p + R @ d
            terms["t1"][i] = d
            S += [[*np.cross(d, e), *e] for e in np.eye(3)]
        elif kind == JOINT_FREE:
            S += [[*e, 0.0, 0.0, 0.0] for e in np.eye(3)] + [[0.0, 0.0, 0.0, *e] for e in np.eye(3)]
    terms["S"] = np.array(S, dtype=np.float64).reshape(len(S), 6)
    return terms


def sibling_chains(parent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """first_child (nL,) and next_sibling (nL,), -1 where there is none; siblings in index order."""
    first_child = np.full(len(parent), -1, dtype=np.int32)
    next_sibling = np.full(len(parent), -1, dtype=np.int32)
    for i in range(len(parent) - 1, 0, -1):
        next_sibling[i] = first_child[parent[i]]
        first_child[parent[i]] = i
    return first_child, next_sibling
