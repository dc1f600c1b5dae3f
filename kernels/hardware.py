"""JaxSim's hardware parametrisation on the device: links' masses, centres of mass and inertias from their
scaled shapes and densities, and the joint origins the scaled links move (warpdyn.types.hardware for the
metadata; JaxSim 0.9.0's `update_hw_parameters` and `HwLinkMetadata.compute_mass_and_inertia`). A tape records
both kernels, so gradients reach the scaling factors from every function of the updated model.
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .spatial import spatial

BOX, CYLINDER, SPHERE, CAPSULE = 0, 1, 2, 3
"""warpdyn.types.hardware.LinkParametrizableShape's codes (-1: unsupported)."""


@factory
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)
    B = bundles(scalar)

    @wp.func
    def scale_vector(kind: int, dims: wp.array3d(dtype=scalar), e: int, i: int):
        """The factors of link i's frame coordinates in environment e (row min(e, P - 1) of dims (P, nL, 3)): a box's
        (d0, d1, d2), a cylinder's and a capsule's (d0, d0, d1) (radius in x and y, length along z), a sphere's
        (d0, d0, d0)."""
        r = wp.min(e, dims.shape[0] - 1)
        if kind == CYLINDER or kind == CAPSULE:
            return sp.vec3(dims[r, i, 0], dims[r, i, 0], dims[r, i, 1])
        if kind == SPHERE:
            return sp.vec3(dims[r, i, 0], dims[r, i, 0], dims[r, i, 0])
        return sp.vec3(dims[r, i, 0], dims[r, i, 1], dims[r, i, 2])

    @wp.kernel(module="unique")
    def link_parameters(
        shape: wp.array(dtype=int),
        geometry: wp.array(dtype=sp.vec3),
        density: wp.array(dtype=scalar),
        L_R_G: wp.array(dtype=sp.mat33),
        L_p_G: wp.array(dtype=sp.vec3),
        dims: wp.array3d(dtype=scalar),
        density_scale: wp.array2d(dtype=scalar),
        mass_in: wp.array(dtype=scalar),
        com_in: wp.array(dtype=sp.vec3),
        inertia_in: wp.array(dtype=sp.mat33),
        # outputs
        mass: wp.array2d(dtype=scalar),
        com: wp.array2d(dtype=sp.vec3),
        inertia: wp.array2d(dtype=sp.mat33),
    ):
        """Link i's mass [kg], centre of mass [m, link frame] and inertia about it [kg m^2, link axes] from its shape's
        geometry scaled by dims[., i] (elementwise) and its density scaled by density_scale[., i]: a box's
        m = rho lx ly lz, I = m/12 diag(ly^2 + lz^2, lx^2 + lz^2, lx^2 + ly^2); a cylinder's m = rho pi r^2 l,
        I = diag(m (3 r^2 + l^2)/12, m (3 r^2 + l^2)/12, m r^2/2); a sphere's m = rho 4/3 pi r^3, I = 2/5 m r^2; a
        capsule's (MuJoCo's: a cylinder of mass mc = rho pi r^2 l and two half-spheres of total mass ms = rho 4/3 pi
        r^3 about their centres l/2 + 3 r/8 away) Izz = mc r^2/2 + 2/5 ms r^2, Ixx = Iyy = mc (r^2/4 + l^2/12) +
        ms (2/5 r^2 + l^2/4 + 3/8 l r),
        in the inertial frame's axes, rotated to the link's (L_R_G I L_R_G^T); the centre of mass L_p_G scaled by
        the shape's scale vector; environment e reads row min(e, rows - 1) of dims (1 or P, nL, 3) and of
        density_scale (1 or P, nL) and writes row e of the outputs (P, nL) (P = 1: shared). An unsupported link
        (shape -1) keeps mass_in, com_in, inertia_in. Launched over (P, nL)."""
        e, i = wp.tid()
        kind = shape[i]
        if kind < 0:
            mass[e, i] = mass_in[i]
            com[e, i] = com_in[i]
            inertia[e, i] = inertia_in[i]
            return
        d = wp.min(e, dims.shape[0] - 1)
        g0 = geometry[i][0] * dims[d, i, 0]
        g1 = geometry[i][1] * dims[d, i, 1]
        g2 = geometry[i][2] * dims[d, i, 2]
        rho = density[i] * B.link_parameter(density_scale, e, i)
        pi = scalar(3.141592653589793)
        m = scalar(0.0)
        I = sp.mat33(scalar(0.0))
        if kind == BOX:
            m = rho * g0 * g1 * g2
            I = wp.diag(sp.vec3(g1 * g1 + g2 * g2, g0 * g0 + g2 * g2, g0 * g0 + g1 * g1)) * (m / scalar(12.0))
        elif kind == CYLINDER:
            m = rho * pi * g0 * g0 * g1
            side = m * (scalar(3.0) * g0 * g0 + g1 * g1) / scalar(12.0)
            I = wp.diag(sp.vec3(side, side, m * g0 * g0 / scalar(2.0)))
        elif kind == CAPSULE:
            mc = rho * pi * g0 * g0 * g1
            ms = rho * scalar(4.0) / scalar(3.0) * pi * g0 * g0 * g0
            m = mc + ms
            side = mc * (g0 * g0 / scalar(4.0) + g1 * g1 / scalar(12.0))
            side = side + ms * (scalar(0.4) * g0 * g0 + g1 * g1 / scalar(4.0) + scalar(0.375) * g1 * g0)
            I = wp.diag(sp.vec3(side, side, mc * g0 * g0 / scalar(2.0) + scalar(0.4) * ms * g0 * g0))
        else:
            m = rho * scalar(4.0) / scalar(3.0) * pi * g0 * g0 * g0
            I = wp.identity(n=3, dtype=scalar) * (scalar(2.0) / scalar(5.0) * m * g0 * g0)
        R = L_R_G[i]
        mass[e, i] = m
        com[e, i] = wp.cw_mul(scale_vector(kind, dims, e, i), L_p_G[i])
        inertia[e, i] = R * I * wp.transpose(R)

    @wp.kernel(module="unique")
    def joint_positions(
        joint_parent: wp.array(dtype=int),
        shape: wp.array(dtype=int),
        L_R_G: wp.array(dtype=sp.mat33),
        L_p_G: wp.array(dtype=sp.vec3),
        L_p_pre: wp.array(dtype=sp.vec3),
        dims: wp.array3d(dtype=scalar),
        # outputs
        positions: wp.array3d(dtype=scalar),
    ):
        """Joint j's origin in its parent link L [m] after L's scaling: its offset from L's centre of mass, in the
        inertial frame's axes, scaled by L's scale vector, added to the scaled centre of mass (JaxSim's
        L_H_pre = L_H̄_G G_H̄_pre); unchanged below an unsupported link. The joint's rotation does not change.
        positions (Pd, nj, 3), row e environment e's (Pd: the rows of dims); launched over (Pd, nj)."""
        e, j = wp.tid()
        L = joint_parent[j]
        p = L_p_pre[j]
        kind = shape[L]
        if kind >= 0:
            s = scale_vector(kind, dims, e, L)
            R = L_R_G[L]
            G_p = wp.transpose(R) * (p - L_p_G[L])
            p = R * wp.cw_mul(s, G_p) + wp.cw_mul(s, L_p_G[L])
        for k in range(3):
            positions[e, j, k] = p[k]

    @wp.kernel(module="unique")
    def collidable_points(
        body: wp.array(dtype=int),
        point: wp.array(dtype=sp.vec3),
        shape: wp.array(dtype=int),
        geometry: wp.array(dtype=sp.vec3),
        L_R_G: wp.array(dtype=sp.mat33),
        dims: wp.array3d(dtype=scalar),
        com_in: wp.array(dtype=sp.vec3),
        com: wp.array2d(dtype=sp.vec3),
        # outputs
        points: wp.array2d(dtype=sp.vec3),
    ):
        """Collidable point c's position L_p_C [m, link frame] after its link L's scaling, JaxSim's
        `HwLinkMetadata.compute_contact_points`: its offset from L's centre of mass before (com_in) scaled in the link's
        axes, a sphere's by d0, a box's by (d0, d1, d2), a cylinder's not at all, a capsule's (warpdyn's; in its axes,
        the inertial frame's) onto the scaled capsule: across the axis by d0, along it by d1 on the cylinder and, beyond
        its end l/2, by d0 on the caps; then added to the centre of mass
        after (com (P, nL): the density does not move it); unchanged on an unsupported link. points (Pd, nc_all), row e
        environment e's (Pd: the rows of dims); launched over (Pd, nc_all)."""
        e, c = wp.tid()
        L = body[c]
        kind = shape[L]
        p = point[c]
        if kind >= 0:
            offset = p - com_in[L]
            if kind == SPHERE:
                offset = offset * scale_vector(kind, dims, e, L)[0]
            elif kind == BOX:
                offset = wp.cw_mul(offset, scale_vector(kind, dims, e, L))
            elif kind == CAPSULE:
                s = scale_vector(kind, dims, e, L)
                G = wp.transpose(L_R_G[L]) * offset
                half = scalar(0.5) * geometry[L][1]
                z = G[2] * s[2]
                if wp.abs(G[2]) > half:
                    z = wp.sign(G[2]) * (half * s[2] + (wp.abs(G[2]) - half) * s[0])
                offset = L_R_G[L] * sp.vec3(G[0] * s[0], G[1] * s[0], z)
            p = offset + com[e, L]
        points[e, c] = p

    return types.SimpleNamespace(link_parameters=link_parameters, joint_positions=joint_positions, collidable_points=collidable_points)
