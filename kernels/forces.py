"""External 6D forces on links: conversion between representations and from frames to their links.

Link forces are kept in the Inertial representation W_f_L = [W_f; W_tau about the world origin]; in the
Body and Mixed representations the force acts at the link (or frame) origin, in link (or world) axes.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import MIXED, spatial


@factory
def kernels(scalar):
    sp = spatial(scalar)
    B = bundles(scalar)

    @wp.kernel(module="unique")
    def kept_forces(
        # inputs
        previous: wp.array3d(dtype=scalar),
        replaced: wp.array(dtype=int),
        # outputs
        W_f_L: wp.array3d(dtype=scalar),
    ):
        """W_f_L (N, nL, 6) = previous, or 0 for the links whose forces are replaced (replaced[L] != 0);
        launched over (N, nL, 6). `add_target_forces` then adds the targets' forces."""
        env, L, r = wp.tid()
        keep = previous[env, L, r]
        if replaced[L] != 0:
            keep = scalar(0.0)
        W_f_L[env, L, r] = keep

    @wp.kernel(module="unique")
    def difference(
        # inputs
        total: wp.array3d(dtype=scalar),
        part: wp.array3d(dtype=scalar),
        # outputs
        rest: wp.array3d(dtype=scalar),
    ):
        """rest = total - part, (N, nL, 6) each (a link's contact wrench out of its total force); launched over
        (N, nL, 6)."""
        env, L, r = wp.tid()
        rest[env, L, r] = total[env, L, r] - part[env, L, r]

    @wp.kernel(module="unique")
    def add_target_forces(
        targets: B.Targets,
        # the links' poses, and the forces on the targets
        W_H_L: wp.array2d(dtype=sp.transform),
        forces: wp.array3d(dtype=scalar),
        repr: int,
        # outputs, accumulated
        W_f_L: wp.array3d(dtype=scalar),
    ):
        """W_f_L[env, targets.link[t]] += the force forces[env, t] (6,) on target t, given in `repr` with the
        target as the body frame, made Inertial; launched over (N, T). Atomic adds: several targets may
        share a link, and their adjoints read W_f_L's gradient only (tape-safe)."""
        env, t = wp.tid()
        L = targets.link[t]
        f = sp.vec6(
            forces[env, t, 0], forces[env, t, 1], forces[env, t, 2],
            forces[env, t, 3], forces[env, t, 4], forces[env, t, 5],
        )
        w = sp.force_repr_to_inertial(repr, W_H_L[env, L] * B.target_pose(targets, env, t), f)
        for r in range(6):
            wp.atomic_add(W_f_L, env, L, r, w[r])

    @wp.kernel(module="unique")
    def convert_link_forces(
        # state
        W_H_L: wp.array2d(dtype=sp.transform),
        f_in: wp.array3d(dtype=scalar),
        repr: int,
        to_inertial: int,
        # outputs
        f_out: wp.array3d(dtype=scalar),
    ):
        """f_out (N, nL, 6): the link forces f_in (N, nL, 6) given in `repr` made Inertial (to_inertial 1), or
        given Inertial made `repr` (0); each link its body frame. Launched over (N, nL)."""
        env, L = wp.tid()
        f = sp.vec6(f_in[env, L, 0], f_in[env, L, 1], f_in[env, L, 2], f_in[env, L, 3], f_in[env, L, 4], f_in[env, L, 5])
        if to_inertial != 0:
            f = sp.force_repr_to_inertial(repr, W_H_L[env, L], f)
        else:
            f = sp.inertial_to_force_repr(repr, W_H_L[env, L], f)
        for r in range(6):
            f_out[env, L, r] = f[r]

    @wp.func
    def passive_link_wrench(model: B.Model, env: int, L: int, W_H_L: sp.transform, B_v: sp.vec6):
        """The passive force on link L at the pose W_H_L, Inertial: its gravity compensation, the force
        -gravcomp_mass g (g the world's gravity) at gravcomp_com (link frame), MJCF's gravcomp; and on a floating
        base (L = 0) its free joint's damper and spring (B.base_passive_wrench, MJCF's; B_v the base's body
        velocity, read for L = 0 alone)."""
        p = wp.transform_point(W_H_L, B.vec3_parameter(model.gravcomp_com, env, L))
        F = -B.link_parameter(model.gravcomp_mass, env, L) * B.gravity_of(model, env)
        W_f = sp.stack(F, wp.cross(p, F))
        if L == 0 and model.floating_base != 0:
            W_f = W_f + sp.force_to(W_H_L, B.base_passive_wrench(model, env, W_H_L, B_v))
        return W_f

    @wp.kernel(module="unique")
    def passive_link_forces(
        model: B.Model,
        state: B.State,
        W_H_L: wp.array2d(dtype=sp.transform),
        f_in: wp.array3d(dtype=scalar),
        repr: int,
        # outputs
        f_out: wp.array3d(dtype=scalar),
    ):
        """f_out (N, nL, 6) = f_in + the passive forces that act on links, both in representation `repr` (f_in
        absent, a zero leading axis: 0), launched over (N, nL): `passive_link_wrench`."""
        env, L = wp.tid()
        X = W_H_L[env, L]
        B_v = sp.vec6(scalar(0.0))
        if L == 0:
            B_v = sp.motion_from(X, sp.repr_to_inertial(MIXED, X, B.base_velocity_mixed(state, env)))
        f = sp.inertial_to_force_repr(repr, X, passive_link_wrench(model, env, L, X, B_v))
        for r in range(6):
            before = scalar(0.0)
            if f_in.shape[0] > 0:
                before = f_in[env, L, r]
            f_out[env, L, r] = before + f[r]

    return types.SimpleNamespace(
        passive_link_wrench=passive_link_wrench,
        passive_link_forces=passive_link_forces,
        kept_forces=kept_forces,
        difference=difference,
        add_target_forces=add_target_forces,
        convert_link_forces=convert_link_forces,
    )
