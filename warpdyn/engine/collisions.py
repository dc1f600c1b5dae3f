"""Contacts between geoms: the model's geom pairs (warpdyn.types.geoms) on the device, their contacts at a state
(kernels/collisions.py's `geom_contacts`) and, in a step where model.geom_contacts is set, their soft-law wrenches
added to the links' and their deformation rates (`geom_contact_wrenches`, `geom_contact_rates`, launched by the soft contact
stage: warpdyn.engine.contact_stage).
Results have a leading N axis.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .. import arrays
from ..description.collision_pairs import CONVEX_TYPES
from ..description.tree import JOINT_FREE
from ..kernels import collision_polygons
from ..kernels.collisions import kernels as collision_kernels
from ..kernels.collisions import narrow_phase
from ..types.geoms import geom_pairs
from ..types.model_constants import transforms
from .bundles import empty_like_input
from .kinematics import link_poses
from .launch import Launch, run

__all__ = ["geom_pairs", "pair_arrays", "contact_buffers", "contact_launch", "force_launches", "geom_contacts", "mark_links_touching"]


def pair_arrays(model) -> dict:
    """The geom pairs' device arrays as kernels/collisions.py takes them, with "scalar", "pairs" (nP), "contacts"
    (C, their slots) and "convex" (whether a pair needs kernels/collision_convex.py) (cached per model version)."""

    def build():
        pairs, s, d = geom_pairs(model), model.scalar, model.device
        vec3 = wp.types.vector(3, s)
        lone = _lone_free_bodies(model.tree, model.floating_base())
        slot_pair, link_pair_start, link_pairs = _slot_and_link_pairs(pairs, model.number_of_links())
        return dict(
            scalar=s, device=d, pairs=len(pairs), contacts=pairs.contacts,
            link1=wp.array(pairs.link1, dtype=int, device=d),
            link2=wp.array(pairs.link2, dtype=int, device=d),
            type1=wp.array(pairs.type1, dtype=int, device=d),
            type2=wp.array(pairs.type2, dtype=int, device=d),
            link_H_geom1=transforms(pairs.link_H_geom1, s, d),
            link_H_geom2=transforms(pairs.link_H_geom2, s, d),
            size1=wp.array(pairs.size1, dtype=vec3, device=d),
            size2=wp.array(pairs.size2, dtype=vec3, device=d),
            margin=wp.array(pairs.margin + pairs.gap, dtype=s, device=d),
            mu=wp.array(np.where(pairs.condim > 1, pairs.friction[:, 0], 0.0), dtype=s, device=d),  # condim 1: frictionless
            first=wp.array(pairs.first, dtype=int, device=d),
            slots=wp.array(pairs.slots, dtype=int, device=d),
            vertices=wp.array(pairs.vertices if len(pairs.vertices) else np.zeros((1, 3)), dtype=vec3, device=d),
            vertices1=wp.array(pairs.vertices1, dtype=wp.vec2i, device=d),
            vertices2=wp.array(pairs.vertices2, dtype=wp.vec2i, device=d),
            polygons=_polygons(pairs, s, d),
            polygons1=wp.array(pairs.polygons1, dtype=wp.vec2i, device=d),
            polygons2=wp.array(pairs.polygons2, dtype=wp.vec2i, device=d),
            slot_pair=wp.array(slot_pair, dtype=int, device=d),
            link_pair_start=wp.array(link_pair_start, dtype=int, device=d),
            link_pairs=wp.array(link_pairs, dtype=int, device=d),
            guarded=wp.array(lone, dtype=int, device=d),
            any_guarded=bool(lone.any()),
            convex=any((int(t1), int(t2)) in CONVEX_TYPES for t1, t2 in zip(pairs.type1, pairs.type2)),
        )  # fmt: skip

    return model.cached("geom pair arrays", build)


def _slot_and_link_pairs(pairs, links: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(slot_pair (C,): each contact slot's pair; link_pair_start (nL + 1,), link_pairs: the pairs of each link in pair
    order, link L's at link_pairs[link_pair_start[L]:link_pair_start[L + 1]]), int32 (the world, -1, has none)."""
    slot_pair = np.repeat(np.arange(len(pairs.first), dtype=np.int32), np.asarray(pairs.slots, dtype=np.int64))
    by_link = [[] for _ in range(links)]
    for i, (a, b) in enumerate(zip(pairs.link1, pairs.link2)):
        for link in {int(a), int(b)} - {-1}:
            by_link[link].append(i)
    start = np.cumsum([0] + [len(p) for p in by_link]).astype(np.int32)
    return slot_pair, start, np.array([i for p in by_link for i in p], dtype=np.int32)


def _lone_free_bodies(tree, floating_base: bool) -> np.ndarray:
    """(nL,) int32: 1 for a link that moves as one rigid body of its own mass (a free joint's, or a floating base's,
    without child links), whose contacts' damping geom_contact_wrenches checks against that mass."""
    parent = np.asarray(tree.parent)
    free = np.asarray(tree.joint_type) == JOINT_FREE
    free[0] = floating_base
    has_child = np.zeros(len(parent), dtype=bool)
    has_child[parent[parent >= 0]] = True
    return (free & ~has_child).astype(np.int32)


def contact_buffers(a: dict, N: int, grad: bool = False) -> dict:
    """The contacts' arrays for N environments: count (N, nP) int, position (N, C, 3), frame (N, C, 3, 3), dist (N, C)
    (requiring gradients with `grad`), and the damper check's scratch damping (N, nL)."""
    s, d = a["scalar"], a["device"]
    return dict(
        damping=wp.empty((N, a["guarded"].shape[0]), dtype=s, device=d),
        count=arrays.empty((a["pairs"],), N, int, d),
        position=arrays.output((a["contacts"], 3), N, s, d, grad),
        frame=arrays.output((a["contacts"], 3, 3), N, s, d, grad),
        dist=arrays.output((a["contacts"],), N, s, d, grad),
    )


def _polygons(pairs, s, d):
    """The meshes' hull polygons as kernels/collision_polygons.py's Polygons (a row of zeros where there are none)."""
    P = collision_polygons.kernels(s).Polygons()
    P.normal = wp.array(pairs.polygon_normals if len(pairs.polygon_normals) else np.zeros((1, 3)), dtype=wp.types.vector(3, s), device=d)
    P.vertices = wp.array(pairs.polygon_vertices if len(pairs.polygon_vertices) else np.zeros((1, 2), dtype=np.int32), dtype=wp.vec2i, device=d)
    P.vertex = wp.array(pairs.polygon_vertex if len(pairs.polygon_vertex) else np.zeros(1, dtype=np.int32), dtype=int, device=d)
    return P


def contact_launch(a: dict, W_H_L: wp.array, b: dict, N: int) -> Launch:
    """The launch of the pairs' contacts at the link poses W_H_L (N, nL) into the buffers b (`contact_buffers`)."""
    inputs = [a[k] for k in ("link1", "link2", "type1", "type2", "link_H_geom1", "link_H_geom2", "size1", "size2", "margin", "first", "slots", "vertices", "vertices1", "vertices2",
                             "polygons", "polygons1", "polygons2")]  # fmt: skip
    outputs = [b[k] for k in ("count", "position", "frame", "dist")]
    order = int(arrays.env_fastest(a["device"]))
    return Launch(narrow_phase(a["scalar"], a["convex"]).geom_contacts, N * a["pairs"], [*inputs, W_H_L, order], outputs)


def force_launches(a: dict, contacts_bundle, W_H_L: wp.array, W_v_WL: wp.array, m: wp.array, b: dict, W_f_L: wp.array, m_dot: wp.array, N: int,
                  check: tuple | None = None, implicit: tuple | None = None, per_environment: bool = False) -> list:  # fmt: skip
    """The pairs' contacts at (W_H_L, W_v_WL (N, nL) Inertial, the contact state m (N, rows, 3)) and their wrenches
    added to W_f_L (N, nL, 6), their slots' deformation rates written to m_dot (N, rows, 3) (rows nc_all on), with the
    soft law's K, D, p, q of `contacts_bundle` (the kernels' Contacts); in a step, check = (rate, the kernels' Model):
    a lone free body whose contacts damp it faster than rate (the integrator's stability limit / dt, 1/s) gets a NaN
    wrench, which flags its environment (kernels/collisions.py's `damper_stability`); implicit = (dt, the links'
    implicit terms (N, nL, 27) or None): the contacts' linearly implicit terms added to those
    (kernels/implicit_contacts.py); per_environment: the slots' and links' kernels a thread per environment
    (warpdyn.engine.contact_stage's `contacts_per_environment`: under a tape, deterministic adjoints)."""
    s, d = a["scalar"], a["device"]
    h, terms = implicit if implicit is not None and implicit[1] is not None else (s(0.0), empty_like_input(s, d, 3))
    order = int(arrays.env_fastest(d))
    state = [b[k] for k in ("count", "position", "frame", "dist")] + [W_v_WL, m]
    kernels = collision_kernels(s)
    slots, links = (a["contacts"], W_f_L.shape[1]) if per_environment else (1, 1)
    rates = [contacts_bundle, a["link1"], a["link2"], a["mu"], a["first"], a["slot_pair"], *state, order, slots]
    wrenches = [contacts_bundle, a["link1"], a["link2"], a["mu"], a["first"], a["link_pair_start"], a["link_pairs"], *state, W_H_L, h, order, links]
    launches = [
        contact_launch(a, W_H_L, b, N),
        Launch(kernels.geom_contact_rates, N * a["contacts"] // slots, rates, [m_dot]),
        Launch(kernels.geom_contact_wrenches, N * W_f_L.shape[1] // links, wrenches, [W_f_L, terms]),
    ]
    if check is not None and a["any_guarded"]:
        rate, model_bundle = check
        inputs = [contacts_bundle, model_bundle, a["link1"], a["link2"], a["first"], b["count"], b["dist"], rate, a["guarded"], b["damping"]]
        launches.append(Launch(kernels.damper_stability, N, inputs, [W_f_L]))
    return launches


def geom_contacts(model, data) -> tuple[wp.array, wp.array, wp.array, wp.array]:
    """(count (N, nP) int, position (N, C, 3) [m], frame (N, C, 3, 3), dist (N, C) [m]) of the model's geom pairs
    at the data's state (kernels/collisions.py)."""
    a = pair_arrays(model)
    b = contact_buffers(a, data.batch_size)
    if a["pairs"]:
        _, W_H_L = link_poses(model, data)
        run([contact_launch(a, W_H_L, b, data.batch_size)], model.device)
    return b["count"], b["position"], b["frame"], b["dist"]


def mark_links_touching(model, W_H_L: wp.array, links: wp.array, touching: wp.array) -> None:
    """Set touching[env, k] (N, K) bool where link links[k] is in a geom pair whose contact at the link poses W_H_L
    (N, nL) has dist <= 0; the other entries are kept."""
    a = pair_arrays(model)
    if not a["pairs"]:
        return
    N = W_H_L.shape[0]
    b = contact_buffers(a, N)
    inputs = [a["link1"], a["link2"], a["first"], b["count"], b["dist"], links]
    run([contact_launch(a, W_H_L, b, N), Launch(collision_kernels(a["scalar"]).links_touching, N, inputs, [touching])], model.device)
