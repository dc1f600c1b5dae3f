"""The geom pairs of a model: the description's `GeomPair`s (warpdyn.description.collision_pairs) on the lumped
tree's links, with what the narrow phase reads (kernels/collisions.py), fixed when the model is built so that a
step's collision work has one size.

Each pair has slots for the most contacts its types give (1 with a sphere or an ellipsoid, 2 for capsule-capsule and
capsule-box, 8 for box-box, 4 for the other pairs with a cylinder or a mesh where MuJoCo's multiCCD acts and their
meshes' hull polygons are known, else 1: kernels/collision_primitives.py, kernels/collision_box.py,
kernels/collision_convex.py, kernels/collision_polygons.py), consecutive, pair after pair.
"""

from __future__ import annotations

import dataclasses
import pathlib
from dataclasses import dataclass

import numpy as np

from ..description.collidable import CollidablePointsOptions, mesh_file_vertices
from ..description.collision_pairs import COLLIDED_TYPES, CONVEX_TYPES, MULTICCD_TYPES
from ..description.mjcf import hull_polygons
from ..description.model import GeomPair
from ..kernels.collision_polygons import CONTACTS
from ..kernels.geom_types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE

__all__ = ["GeomPairs", "geom_pairs", "self_collision", "MUJOCO_TYPES", "SLOTS"]

MUJOCO_TYPES = {"sphere": SPHERE, "capsule": CAPSULE, "ellipsoid": ELLIPSOID, "cylinder": CYLINDER, "box": BOX, "mesh": MESH}
"""A collision shape's kind -> MuJoCo's mjtGeom value (the narrow phase's type)."""

SLOTS = {(SPHERE, SPHERE): 1, (SPHERE, CAPSULE): 1, (SPHERE, CYLINDER): 1, (SPHERE, BOX): 1, (CAPSULE, CAPSULE): 2, (CAPSULE, BOX): 2, (BOX, BOX): 8, **dict.fromkeys(CONVEX_TYPES, 1)}
"""(type1, type2) -> the most contacts of such a pair without multiCCD (GJK and EPA's pairs: one)."""


@dataclass(frozen=True)
class GeomPairs:
    """The nP geom pairs of a model, in the description's order (host NumPy).

    names: (geom1, geom2) names; link1, link2 (nP,) int: the lumped links that carry them, -1 for a geom that does not
    move (the description's world_geoms); type1, type2 (nP,) int: MuJoCo's geom types (type1 <= type2); link_H_geom1,
    link_H_geom2 (nP, 4, 4): the geoms' poses in their links (in the world for link -1);
    size1, size2 (nP, 3) [m]: MuJoCo's geom_size (a sphere's radius; a capsule's or cylinder's radius and half
    length; an ellipsoid's radii; a box's half sizes; a mesh's bounding radius, MuJoCo's geom_rbound, then 0, 0); margin, gap (nP,) [m];
    friction (nP, 5); condim (nP,) int; first (nP,) int: each pair's first slot; slots (nP,) int: its number of slots;
    contacts: the slots of all pairs; vertices (V, 3) [m]: the meshes' vertices, each in its geom's frame, mesh after
    mesh; vertices1, vertices2 (nP, 2) int: a pair's geom's (first, count) in them ((0, 0) but for a mesh);
    polygon_normals (Q, 3): the meshes' hull polygons' unit outward normals, each in its geom's frame, mesh after mesh;
    polygon_vertices (Q, 2) int: a polygon's (first, count) in polygon_vertex (W,) int, its vertices' rows in `vertices`
    (counterclockwise about its normal); polygons1, polygons2 (nP, 2) int: a pair's geom's (first, count) of polygons
    ((0, 0) but for a mesh whose polygons are known: an MJCF's, or a URDF's or SDF's compiled by MuJoCo).
    """

    names: tuple
    link1: np.ndarray
    link2: np.ndarray
    type1: np.ndarray
    type2: np.ndarray
    link_H_geom1: np.ndarray
    link_H_geom2: np.ndarray
    size1: np.ndarray
    size2: np.ndarray
    margin: np.ndarray
    gap: np.ndarray
    friction: np.ndarray
    condim: np.ndarray
    first: np.ndarray
    slots: np.ndarray
    vertices: np.ndarray
    vertices1: np.ndarray
    vertices2: np.ndarray
    polygon_normals: np.ndarray
    polygon_vertices: np.ndarray
    polygon_vertex: np.ndarray
    polygons1: np.ndarray
    polygons2: np.ndarray

    @property
    def contacts(self) -> int:
        return int(self.slots.sum())

    def __len__(self) -> int:
        return len(self.names)


def mesh_vertices(shape) -> np.ndarray:
    """A mesh shape's vertices (k, 3) [m] in its frame, scaled."""
    return np.asarray(shape.vertices, dtype=np.float64) * np.asarray(shape.scale if shape.scale is not None else 1.0, dtype=np.float64)


def _mujoco_size(shape) -> np.ndarray:
    """MuJoCo's geom_size of a collision shape (a mesh's: (its geom_rbound, 0, 0), the norm of |its box's centre| +
    its half sizes, as MuJoCo bounds a mesh geom)."""
    if shape.kind == "mesh":
        v = mesh_vertices(shape)
        hi, lo = v.max(axis=0), v.min(axis=0)
        return np.array([np.linalg.norm(np.abs(hi + lo) / 2 + (hi - lo) / 2), 0.0, 0.0])
    if shape.kind == "box":
        return 0.5 * np.asarray(shape.size, dtype=np.float64)
    if shape.kind == "sphere":
        return np.array([shape.radius, 0.0, 0.0])
    if shape.kind == "ellipsoid":
        return np.asarray(shape.size, dtype=np.float64).reshape(3)
    return np.array([shape.radius, 0.5 * shape.length, 0.0])


def geom_pairs(model) -> GeomPairs:
    """The model's geom pairs (cached per model version). A pair whose two geoms a reduced model lumps into one link
    is dropped (MuJoCo does not collide geoms welded together)."""
    description = model.description
    return model.cached("geom pairs", lambda: _build(model.tree, description.geom_pairs, description.world_geoms, description.multiccd))


def _polygons_known(shape) -> bool:
    """Whether the narrow phase has the shape's faces: a mesh's where its hull's polygons are known."""
    return shape.kind != "mesh" or shape.polygons is not None


def _build(tree, pairs, world_geoms, multiccd: bool) -> GeomPairs:
    where = {shape.geom: (link, shape) for link, shapes in enumerate(tree.collisions) for shape in shapes if shape.geom >= 0}
    where.update({shape.geom: (-1, shape) for shape in world_geoms})  # they do not move, whichever link carries them
    rows = []
    for pair in pairs:
        (l1, s1), (l2, s2) = where[pair.geom1], where[pair.geom2]
        if l1 != l2:
            rows.append((pair, l1, s1, l2, s2))
    t1 = np.array([MUJOCO_TYPES[s1.kind] for _, _, s1, _, _ in rows], dtype=np.int32)
    t2 = np.array([MUJOCO_TYPES[s2.kind] for _, _, _, _, s2 in rows], dtype=np.int32)
    multi = [multiccd and (a, b) in MULTICCD_TYPES and _polygons_known(r[2]) and _polygons_known(r[4]) for a, b, r in zip(t1, t2, rows)]
    slots = np.array([CONTACTS if m else SLOTS[(a, b)] for a, b, m in zip(t1, t2, multi)], dtype=np.int32)
    first = np.concatenate([[0], np.cumsum(slots)[:-1]]).astype(np.int32) if len(rows) else np.zeros(0, dtype=np.int32)

    def stack(values, shape):
        return np.array(values, dtype=np.float64).reshape((len(rows), *shape))

    meshes, first_vertex = {}, 0  # each mesh geom's vertices once
    for _, _, s1, _, s2 in rows:
        for shape in (s1, s2):
            if shape.kind == "mesh" and id(shape) not in meshes:
                meshes[id(shape)] = (first_vertex, mesh_vertices(shape))
                first_vertex += len(meshes[id(shape)][1])

    def vertex_range(shape):
        return (meshes[id(shape)][0], len(meshes[id(shape)][1])) if shape.kind == "mesh" else (0, 0)

    normals, ranges, polygon_vertex, polygons = [], [], [], {}  # each mesh's polygons once, their vertices' rows
    for shape_id, (first_row, _) in meshes.items():
        shape = next(s for r in rows for s in (r[2], r[4]) if id(s) == shape_id)
        if shape.polygons is not None:
            polygons[shape_id] = (len(normals), len(shape.polygons[0]))
            for normal, indices in zip(*shape.polygons):
                normals.append(normal)
                ranges.append((len(polygon_vertex), len(indices)))
                polygon_vertex.extend(first_row + np.asarray(indices))

    def polygon_range(shape):
        return polygons.get(id(shape), (0, 0))

    return GeomPairs(
        names=tuple((s1.name, s2.name) for _, _, s1, _, s2 in rows),
        link1=np.array([r[1] for r in rows], dtype=np.int32),
        link2=np.array([r[3] for r in rows], dtype=np.int32),
        type1=t1,
        type2=t2,
        link_H_geom1=stack([r[2].link_H_shape for r in rows], (4, 4)),
        link_H_geom2=stack([r[4].link_H_shape for r in rows], (4, 4)),
        size1=stack([_mujoco_size(r[2]) for r in rows], (3,)),
        size2=stack([_mujoco_size(r[4]) for r in rows], (3,)),
        margin=stack([r[0].margin for r in rows], ()),
        gap=stack([r[0].gap for r in rows], ()),
        friction=stack([r[0].friction for r in rows], (5,)),
        condim=np.array([r[0].condim for r in rows], dtype=np.int32),
        first=first,
        slots=slots,
        vertices=np.concatenate([v for _, v in meshes.values()]) if meshes else np.zeros((0, 3)),
        vertices1=np.array([vertex_range(r[2]) for r in rows], dtype=np.int32).reshape(len(rows), 2),
        vertices2=np.array([vertex_range(r[4]) for r in rows], dtype=np.int32).reshape(len(rows), 2),
        polygon_normals=np.array(normals, dtype=np.float64).reshape(-1, 3),
        polygon_vertices=np.array(ranges, dtype=np.int32).reshape(-1, 2),
        polygon_vertex=np.array(polygon_vertex, dtype=np.int32),
        polygons1=np.array([polygon_range(r[2]) for r in rows], dtype=np.int32).reshape(len(rows), 2),
        polygons2=np.array([polygon_range(r[4]) for r in rows], dtype=np.int32).reshape(len(rows), 2),
    )


def self_collision(model, exclude=(), options=None) -> tuple:
    """(model, uncollided): a copy of a URDF or SDF model whose links' collision shapes collide with each other as
    MuJoCo collides those of the same URDF (every geom's contype and conaffinity 1, fixed joints fused): every pair of
    shapes on two links, but a link and its parent (MuJoCo's filterparent; not where the parent is a fixed base, which
    MuJoCo welds to the world) and the link pairs of `exclude` ((name, name), ...); MuJoCo's default friction, no
    margin. Its shapes are numbered (`CollisionShape.geom`, link after link) and named "{link}/{k}" where unnamed; its
    meshes carry their files' vertices (convex meshes to the narrow phase, as MuJoCo takes a URDF's meshes), found as
    collidable points find them (`options`: a CollidablePointsOptions' package_dirs and mesh_dirs; the description's
    directory), and their hulls' polygons as MuJoCo compiles them (multiCCD's faces; none without MuJoCo installed:
    description.mjcf.hull_polygons). uncollided: {"type1-type2": count} of the pairs whose types the narrow phase does not collide (a mesh
    whose file was not found or read)."""
    if model.description.source == "mjcf":
        raise ValueError(f"model '{model.name()}' is MJCF: its geom pairs are MuJoCo's (edit contype, conaffinity, <exclude> and <pair> in the file)")
    tree, names = model.tree, model.link_names()
    excluded = set()
    for pair in exclude:
        if isinstance(pair, str) or len(pair) != 2:
            raise ValueError(f"exclude takes pairs of link names, got {pair!r}")
        a, b = (names.index(n) if n in names else None for n in pair)
        if a is None or b is None:
            raise ValueError(f"exclude names links {list(pair)}; the model's links: {names}")
        excluded.add(frozenset((a, b)))
    options = CollidablePointsOptions() if options is None else options
    path = getattr(model.description, "path", None)
    base_dir = pathlib.Path(path).parent if path else None
    numbered, shapes = [], []
    for link, links_shapes in enumerate(tree.collisions):
        row = []
        for k, shape in enumerate(links_shapes):
            shape = dataclasses.replace(shape, geom=len(shapes), name=shape.name or f"{names[link]}/{k}")
            if shape.kind == "mesh" and shape.vertices is None:
                vertices = mesh_file_vertices(shape, options, base_dir)[0]
                if vertices is not None:
                    shape = dataclasses.replace(shape, vertices=np.unique(vertices, axis=0))
                    shape = dataclasses.replace(shape, polygons=hull_polygons(mesh_vertices(shape)))
            row.append(shape)
            shapes.append((link, shape))
        numbered.append(row)
    fixed_base = not model.floating_base()
    pairs, uncollided = [], {}
    default = (1.0, 1.0, 0.005, 0.0001, 0.0001)  # MuJoCo's geom friction (sliding, torsional, rolling) unpacked to 5
    for i, (a, s1) in enumerate(shapes):
        for b, s2 in shapes[i + 1 :]:
            parent = tree.parent[b] == a or tree.parent[a] == b
            if a == b or frozenset((a, b)) in excluded or (parent and not (fixed_base and 0 in (a, b))):
                continue
            t1, t2 = (99 if s.kind == "mesh" and s.vertices is None else MUJOCO_TYPES.get(s.kind, 99) for s in (s1, s2))  # a mesh not read: none
            g1, g2 = (s2, s1) if t1 > t2 else (s1, s2)
            if (min(t1, t2), max(t1, t2)) in COLLIDED_TYPES:
                pairs.append(GeomPair(g1.geom, g2.geom, 0.0, 0.0, default, 3))
            else:
                key = f"{g1.kind}-{g2.kind}"
                uncollided[key] = uncollided.get(key, 0) + 1
    new = model.copy()
    new.tree = dataclasses.replace(tree, collisions=numbered)
    new.description = dataclasses.replace(model.description, geom_pairs=pairs, world_geoms=[])
    return new, uncollided
