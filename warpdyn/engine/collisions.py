"""Contacts between geoms: the model's geom pairs (warpdyn.types.geoms) on the device, and one launch of
kernels/collisions.py at a state's link poses. Results have a leading N axis.
"""

from __future__ import annotations

import warp as wp

from .. import arrays
from ..kernels.collisions import kernels as collision_kernels
from ..types.geoms import geom_pairs
from ..types.model_constants import transforms
from .kinematics import link_poses
from .launch import launch

__all__ = ["geom_pairs", "pair_arrays", "geom_contacts"]


def pair_arrays(model) -> dict:
    """The geom pairs' device arrays as kernels/collisions.py's `geom_contacts` takes them (cached per model
    version)."""

    def build():
        pairs, s, d = geom_pairs(model), model.scalar, model.device
        vec3 = wp.types.vector(3, s)
        return dict(
            link1=wp.array(pairs.link1, dtype=int, device=d),
            link2=wp.array(pairs.link2, dtype=int, device=d),
            type1=wp.array(pairs.type1, dtype=int, device=d),
            type2=wp.array(pairs.type2, dtype=int, device=d),
            link_H_geom1=transforms(pairs.link_H_geom1, s, d),
            link_H_geom2=transforms(pairs.link_H_geom2, s, d),
            size1=wp.array(pairs.size1, dtype=vec3, device=d),
            size2=wp.array(pairs.size2, dtype=vec3, device=d),
            margin=wp.array(pairs.margin + pairs.gap, dtype=s, device=d),
            first=wp.array(pairs.first, dtype=int, device=d),
            slots=wp.array(pairs.slots, dtype=int, device=d),
        )

    return model.cached("geom pair arrays", build)


def geom_contacts(model, data) -> tuple[wp.array, wp.array, wp.array, wp.array]:
    """(count (N, nP) int, position (N, C, 3) [m], frame (N, C, 3, 3), dist (N, C) [m]) of the model's geom pairs
    at the data's state (kernels/collisions.py)."""
    pairs = geom_pairs(model)
    N, nP, C = data.batch_size, len(pairs), pairs.contacts
    s, d = model.scalar, model.device
    count = arrays.empty((nP,), N, int, d)
    position = arrays.output((C, 3), N, s, d)
    frame = arrays.output((C, 3, 3), N, s, d)
    dist = arrays.output((C,), N, s, d)
    if nP:
        _, W_H_L = link_poses(model, data)
        a = pair_arrays(model)
        launch(
            collision_kernels(s).geom_contacts,
            dim=(N, nP),
            inputs=[a["link1"], a["link2"], a["type1"], a["type2"], a["link_H_geom1"], a["link_H_geom2"], a["size1"], a["size2"],
                    a["margin"], a["first"], a["slots"], W_H_L],
            outputs=[count, position, frame, dist],
            device=d,
        )  # fmt: skip
    return count, position, frame, dist
