"""Soft-contact results in the façade's representations, and contact with the terrain.

- `link_wrenches`: the contact wrench on each link, the sum of its points' Inertial wrenches that the contact
  kernel (soft_contacts.point_contact_forces) writes, as the step sums them into the link's external force
  (soft_contacts.link_contact_wrench). Then written in `repr` (link frame L as the body frame): Inertial
  [f; W_p x f summed], Body L_X*_W W_f, Mixed the force at the link origin, world axes.
- `point_wrenches`: each enabled point's wrench in `repr` for the contact frame C = (W_p_C, [L]); in Body
  and Mixed the torque about C is zero: Mixed is [W_f; 0], Body [L_R_W W_f; 0].
- `links_below_terrain`: JaxSim's `in_contact`: a link touches the terrain when one of its enabled points
  has W_p_C.z <= h(W_p_C.x, W_p_C.y) (at or below the terrain height above its (x, y), JaxSim's test).
"""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .soft_contacts import kernels as soft_contact_kernels
from .spatial import INERTIAL, spatial


@factory
def kernels(scalar) -> types.SimpleNamespace:
    sp = spatial(scalar)
    B = bundles(scalar)
    terrain_height = soft_contact_kernels(scalar).terrain_height
    height_parameter = soft_contact_kernels(scalar).height_parameter
    link_contact_wrench = soft_contact_kernels(scalar).link_contact_wrench

    @wp.kernel(module="unique")
    def link_wrenches(
        contacts: B.Contacts,
        # the links' poses and the contact kernel's point wrenches (N, P, 6), Inertial
        W_H_L: wp.array2d(dtype=sp.transform),
        W_f_C: wp.array3d(dtype=scalar),
        repr: int,
        # outputs
        f_L: wp.array3d(dtype=scalar),
    ):
        """f_L (N, nL, 6): the contact wrench of each link in `repr`, launched over (N, nL)."""
        env, L = wp.tid()
        f = sp.inertial_to_force_repr(repr, W_H_L[env, L], link_contact_wrench(contacts, W_f_C, env, L))
        for a in range(6):
            f_L[env, L, a] = f[a]

    @wp.kernel(module="unique")
    def point_wrenches(
        contacts: B.Contacts,
        point_out: wp.array(dtype=int),
        # the links' poses and the contact kernel's point wrenches
        W_H_L: wp.array2d(dtype=sp.transform),
        W_f_C: wp.array3d(dtype=scalar),
        repr: int,
        # outputs
        f_C: wp.array3d(dtype=scalar),
    ):
        """f_C (N, nc, 6): each point's contact wrench in `repr` for C = (W_p_C, [L]), launched over (N, nc);
        point_out[c] is where the contact kernel's point c goes in the output (the points' own order)."""
        env, c = wp.tid()
        X = W_H_L[env, contacts.point_link[c]] * sp.transform(B.vec3_parameter(contacts.L_p_C, env, c), wp.quat_identity(dtype=scalar))
        W_f = sp.vec6(W_f_C[env, c, 0], W_f_C[env, c, 1], W_f_C[env, c, 2], W_f_C[env, c, 3], W_f_C[env, c, 4], W_f_C[env, c, 5])
        f = sp.inertial_to_force_repr(repr, X, W_f)
        if repr != INERTIAL:  # a pure force at C: its moment about C is zero, exactly (not a rounded difference)
            f = sp.stack(sp.lin(f), sp.vec3(scalar(0.0)))
        k = point_out[c]
        for a in range(6):
            f_C[env, k, a] = f[a]

    @wp.kernel(module="unique")
    def links_below_terrain(
        # points
        point_link: wp.array(dtype=int),
        W_p_C: wp.array3d(dtype=scalar),
        # query
        links: wp.array(dtype=int),
        terrain: B.Terrain,
        # outputs
        out: wp.array2d(dtype=wp.bool),
    ):
        """out (N, K): whether a point of links[k] has z <= h(x, y), launched over (N, K)."""
        env, k = wp.tid()
        below = int(0)
        for c in range(point_link.shape[0]):
            if point_link[c] == links[k]:
                h = terrain_height(terrain, height_parameter(terrain, env), W_p_C[env, c, 0], W_p_C[env, c, 1])
                if W_p_C[env, c, 2] <= h:
                    below = 1
        out[env, k] = below != 0

    return types.SimpleNamespace(link_wrenches=link_wrenches, point_wrenches=point_wrenches, links_below_terrain=links_below_terrain)
