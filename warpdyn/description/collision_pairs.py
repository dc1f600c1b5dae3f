"""The pairs of geoms MuJoCo may collide, decided as its mj_collision decides them before it looks at poses
(engine_collision_driver.c: mj_broadphase's body filter, filterCollisionPair's bit masks, `<exclude>`, the merge of
explicit `<pair>`s), and each pair's contact parameters (mj_contactParam, getMargin, getGap). Host NumPy over a
compiled mjModel; what is left per pose (MuJoCo's bounding-sphere and bounding-box tests) is the narrow phase's
(kernels/collision_primitives.py's `may_touch`).

MuJoCo's rules, kept:
- bodies: two bodies' geoms may collide unless the bodies are welded together (one `body_weldid`), both welds have
  no degrees of freedom, or (filterparent not disabled, neither weld the world) one weld is the other's parent
  weld; unless their body-level bit masks (`body_contype`, `body_conaffinity`) exclude each other; unless an
  `<exclude>` names the two bodies;
- geoms: contype1 & conaffinity2 or contype2 & conaffinity1 nonzero; a pair that an explicit `<pair>` also names is
  that pair's;
- explicit `<pair>`s collide whatever the filters, with their own margin, gap, friction and condim;
- parameters: margin and gap the sums of the geoms' (a `<pair>`'s own); friction and condim those of the geom of
  higher priority, else the maximum of each; friction unpacked to 5 (sliding twice, torsional, rolling twice).
Geoms that do not move (on the world body or on bodies welded to it: ModelDescription.world_geoms) collide with the
moving ones as MuJoCo's do, planes and heightfields aside: warpdyn's ground is its terrain.
"""

from __future__ import annotations

import numpy as np

from ..kernels.geom_types import BOX, CAPSULE, CYLINDER, ELLIPSOID, MESH, SPHERE  # MuJoCo's mjtGeom values
from .model import GeomPair

__all__ = ["COLLIDED_TYPES", "CONVEX_TYPES", "MULTICCD_TYPES", "multiccd", "mujoco_geom_pairs"]

_ELLIPSOID_PAIRS = frozenset({(t, ELLIPSOID) for t in (SPHERE, CAPSULE, ELLIPSOID)} | {(ELLIPSOID, t) for t in (CYLINDER, BOX, MESH)})
CONVEX_TYPES = frozenset({(CAPSULE, CYLINDER), (CYLINDER, CYLINDER), (CYLINDER, BOX)} | {(t, MESH) for t in (SPHERE, CAPSULE, CYLINDER, BOX, MESH)}) | _ELLIPSOID_PAIRS
"""The pairs that MuJoCo and warpdyn collide with a general convex solver (GJK and EPA; a mesh as its convex hull), one
contact a pair."""
MULTICCD_TYPES = CONVEX_TYPES - {(SPHERE, MESH)} - _ELLIPSOID_PAIRS
"""Those to which MuJoCo 4's multiCCD, on by default, gives several contacts where the two geoms meet face to face or
edge to face (a cylinder standing on a box: 4; kernels/collision_polygons.py); a sphere and an ellipsoid have no face
(MuJoCo skips them)."""
COLLIDED_TYPES = frozenset(
    {(SPHERE, SPHERE), (SPHERE, CAPSULE), (SPHERE, CYLINDER), (SPHERE, BOX), (CAPSULE, CAPSULE), (CAPSULE, BOX), (BOX, BOX)}
) | CONVEX_TYPES
"""The (type1 <= type2) pairs of geoms on bodies that warpdyn's narrow phase collides (kernels/collision_primitives.py,
kernels/collision_box.py, and CONVEX_TYPES by kernels/collision_convex.py); planes and heightfields on bodies and
signed distance fields are not collided (the loader names them)."""


def multiccd(m, mujoco) -> bool:
    """Whether MuJoCo's multiCCD acts in model m: on unless mjDSBL_MULTICCD (MuJoCo 3.8 on), off unless mjENBL_MULTICCD
    before."""
    disable = getattr(mujoco.mjtDisableBit, "mjDSBL_MULTICCD", None)
    if disable is not None:
        return not int(m.opt.disableflags) & int(disable)
    enable = getattr(mujoco.mjtEnableBit, "mjENBL_MULTICCD", None)
    return enable is not None and bool(int(m.opt.enableflags) & int(enable))


def _contact_parameters(m, g1: int, g2: int) -> tuple[tuple, int]:
    """(friction (5,), condim) of a dynamic pair: mj_contactParam's choice by priority, else the maxima."""
    p1, p2 = int(m.geom_priority[g1]), int(m.geom_priority[g2])
    if p1 != p2:
        g = g1 if p1 > p2 else g2
        friction, condim = np.array(m.geom_friction[g], dtype=np.float64), int(m.geom_condim[g])
    else:
        friction = np.maximum(m.geom_friction[g1], m.geom_friction[g2]).astype(np.float64)
        condim = max(int(m.geom_condim[g1]), int(m.geom_condim[g2]))
    return (float(friction[0]), float(friction[0]), float(friction[1]), float(friction[2]), float(friction[2])), condim


def _ordered(m, g1: int, g2: int) -> tuple[int, int]:
    """(g1, g2) with geom1's type <= geom2's (MuJoCo's pushGeomGeom)."""
    return (g2, g1) if int(m.geom_type[g1]) > int(m.geom_type[g2]) else (g1, g2)


def _weld_filtered(m, b1: int, b2: int, filterparent: bool) -> bool:
    """MuJoCo's filterBodyPair (sleep aside): True where bodies b1, b2 do not collide."""
    w1, w2 = int(m.body_weldid[b1]), int(m.body_weldid[b2])
    if w1 == w2:
        return True
    if int(m.body_dofnum[w1]) == 0 and int(m.body_dofnum[w2]) == 0:
        return True
    parent1, parent2 = int(m.body_weldid[m.body_parentid[w1]]), int(m.body_weldid[m.body_parentid[w2]])
    return filterparent and w1 != 0 and w2 != 0 and (w1 == parent2 or w2 == parent1)


def _masks_exclude(contype1: int, conaffinity1: int, contype2: int, conaffinity2: int) -> bool:
    """MuJoCo's filterBitmask: True where neither geom's contype meets the other's conaffinity."""
    return not (contype1 & conaffinity2) and not (contype2 & conaffinity1)


def mujoco_geom_pairs(m, mujoco, geom_name) -> tuple[list[GeomPair], dict[str, list[str]]]:
    """(pairs, uncollided) of MuJoCo's model m: the pairs of geoms that MuJoCo may collide (the module docstring; the
    ground's planes and heightfields aside), explicit `<pair>`s first in their order, then by body pair and geom; and
    those that warpdyn's narrow phase does not collide, {"type1-type2": ["geom1/geom2", ...]} (types outside
    COLLIDED_TYPES; "without shape": a `<pair>` of a geom whose contype and conaffinity are 0, for which the loader
    keeps no shape; "with the ground": a `<pair>` of a floor plane, whose contacts are the terrain's, with its law and
    parameters). geom_name(g): a geom's name for messages."""
    filterparent = not (int(m.opt.disableflags) & int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT))
    type_name = {int(v): k.removeprefix("mjGEOM_").lower() for k, v in mujoco.mjtGeom.__members__.items()}
    ground = (int(mujoco.mjtGeom.mjGEOM_PLANE), int(mujoco.mjtGeom.mjGEOM_HFIELD))
    terrain = [int(m.geom_type[g]) in ground and int(m.body_weldid[m.geom_bodyid[g]]) == 0 for g in range(m.ngeom)]
    shaped = [bool(m.geom_contype[g] or m.geom_conaffinity[g]) for g in range(m.ngeom)]  # the loader's shapes
    pairs, uncollided = [], {}

    def keep(g1: int, g2: int, pair: GeomPair) -> None:
        types = (int(m.geom_type[pair.geom1]), int(m.geom_type[pair.geom2]))
        if types in COLLIDED_TYPES:
            pairs.append(pair)
        else:
            uncollided.setdefault(f"{type_name[types[0]]}-{type_name[types[1]]}", []).append(f"{geom_name(g1)}/{geom_name(g2)}")

    explicit = set()
    for k in range(m.npair):
        g1, g2 = int(m.pair_geom1[k]), int(m.pair_geom2[k])
        explicit.add(frozenset((g1, g2)))
        if not (shaped[g1] and shaped[g2]):
            uncollided.setdefault("without shape", []).append(f"{geom_name(g1)}/{geom_name(g2)}")
        elif terrain[g1] or terrain[g2]:
            uncollided.setdefault("with the ground", []).append(f"{geom_name(g1)}/{geom_name(g2)}")
        else:
            o1, o2 = _ordered(m, g1, g2)
            friction = tuple(float(f) for f in m.pair_friction[k])
            keep(g1, g2, GeomPair(o1, o2, float(m.pair_margin[k]), float(m.pair_gap[k]), friction, int(m.pair_dim[k]), explicit=True))

    excluded = {int(s) for s in m.exclude_signature}
    for b1 in range(m.nbody):
        if not (m.body_contype[b1] or m.body_conaffinity[b1]):
            continue
        for b2 in range(b1 + 1, m.nbody):
            if not (m.body_contype[b2] or m.body_conaffinity[b2]):
                continue
            if _weld_filtered(m, b1, b2, filterparent) or (b1 << 16) + b2 in excluded:
                continue
            if _masks_exclude(int(m.body_contype[b1]), int(m.body_conaffinity[b1]), int(m.body_contype[b2]), int(m.body_conaffinity[b2])):
                continue
            for g1 in range(int(m.body_geomadr[b1]), int(m.body_geomadr[b1]) + int(m.body_geomnum[b1])):
                for g2 in range(int(m.body_geomadr[b2]), int(m.body_geomadr[b2]) + int(m.body_geomnum[b2])):
                    if terrain[g1] or terrain[g2] or frozenset((g1, g2)) in explicit or _masks_exclude(
                        int(m.geom_contype[g1]), int(m.geom_conaffinity[g1]), int(m.geom_contype[g2]), int(m.geom_conaffinity[g2])
                    ):
                        continue
                    o1, o2 = _ordered(m, g1, g2)
                    friction, condim = _contact_parameters(m, g1, g2)
                    margin = float(m.geom_margin[g1] + m.geom_margin[g2])
                    keep(g1, g2, GeomPair(o1, o2, margin, float(m.geom_gap[g1] + m.geom_gap[g2]), friction, condim))
    return pairs, uncollided
