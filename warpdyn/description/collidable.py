"""Collidable points: host-side (NumPy, float64) generation from the collision shapes of a lumped tree.

Contact in warpdyn, as in JaxSim, acts on points rigidly attached to links. This module turns the
collision shapes of `KinematicTree.collisions` (already moved to the kept link by lumping, with their
pose `link_H_shape`) into points `L_p_C` in the link frame:

- box: its 8 corners, in JaxSim's order (x, y, z the full extents, corners of [0, x] x [0, y] x [0, z]
  taken as (0,0,0), (x,0,0), (x,y,0), (0,y,0), (0,0,z), (x,0,z), (x,y,z), (0,y,z), then centred).
- sphere: `sphere_points` points of a Fibonacci lattice on the surface (JaxSim's construction).
- ellipsoid (radii a, b, c): the sphere's lattice of `sphere_points` points on the unit sphere, scaled by the radii
  (every point on the surface; spread apart along the longer axes, closer where the surface curves most).
- cylinder (axis z, length L): two rims of `circle_points` points at z = +-L/2, `side_rings` more rings
  evenly spaced between them, and the centre of each cap.
- capsule (axis z, cylindrical part of length L): for each hemispherical cap, `capsule_cap_rings`
  rings of `circle_points` points at elevations 0, 90/k, ..., 90 (k - 1)/k degrees (elevation 0 is the
  rim where the cap meets the cylinder) and the pole; `side_rings` more rings on the cylindrical part.
- mesh: its vertices (duplicates removed), scaled; with `mesh_max_points` set, a deterministic
  farthest-point subsample of that many vertices. MJCF meshes come with their vertices (MuJoCo loaded
  them); URDF meshes are loaded with trimesh when the file resolves (see `resolve_mesh_uri`). A mesh that
  cannot be found or read gives no points, and one `UnresolvedMeshWarning` per model lists all of them.

Points are ordered as JaxSim orders them: by shape in the description's order (its links' order, each
link's shapes in order; a lumped link's shapes keep their place, moved onto the kept link), then within
the shape as above.

Defaults: every primitive shape gives points and meshes do not (add "mesh" to `shapes`): as in JaxSim,
which uses meshes only when JAXSIM_COLLISION_MESH_ENABLED is set, since a mesh's vertices are many (the
iCub's meshes have 124,761). JaxSim has no points for cylinders and capsules; the seed's robots have none.
"""

from __future__ import annotations

import dataclasses
import os
import pathlib
import urllib.parse
import warnings

import numpy as np

__all__ = [
    "CollidablePointsOptions",
    "UnresolvedMeshWarning",
    "NoCollidablePointsWarning",
    "box_points",
    "sphere_points",
    "ellipsoid_points",
    "cylinder_points",
    "capsule_points",
    "farthest_point_subsample",
    "mesh_file_vertices",
    "resolve_mesh_uri",
    "collidable_points",
]

SHAPE_KINDS = ("box", "sphere", "ellipsoid", "cylinder", "capsule", "mesh")


class UnresolvedMeshWarning(UserWarning):
    """A collision mesh could not be found or read: it gives no collidable points."""


class NoCollidablePointsWarning(UserWarning):
    """A floating-base model has no collidable points: it does not touch the terrain."""


MESH_POINTS_SUGGESTED = 16
"""The points per mesh that the warning for a model without collidable points suggests (mesh_max_points)."""


def warn_without_points(model_name: str, tree, stacklevel: int) -> None:
    """One NoCollidablePointsWarning when no collision shape of `tree` gives points by default (a floating
    base then falls through the terrain), saying how to sample its collision meshes."""
    kinds = [shape.kind for shapes in tree.collisions for shape in shapes]
    if any(kind in CollidablePointsOptions().shapes for kind in kinds):
        return
    meshes = kinds.count("mesh")
    if meshes:
        how = (
            f"its {meshes} collision meshes give points with wd.contact.with_collidable_points(model, "
            "options=wd.contact.CollidablePointsOptions(shapes=('box', 'sphere', 'ellipsoid', 'cylinder', 'capsule', 'mesh'), "
            f"mesh_max_points={MESH_POINTS_SUGGESTED})) ({MESH_POINTS_SUGGESTED} points per mesh, farthest-point "
            "sampled; package_dirs= where package:// URIs do not resolve; enabled_links= to keep the feet)"
        )
    else:
        how = "its description has no collision shapes: add boxes, spheres, cylinders or capsules to the links that touch the ground"
    warnings.warn(
        f"model '{model_name}' has a floating base but no collidable points: it will not touch the terrain and "
        f"falls through it; {how}",
        NoCollidablePointsWarning,
        stacklevel=stacklevel + 1,
    )


@dataclasses.dataclass(frozen=True)
class CollidablePointsOptions:
    """How collision shapes become collidable points (see the module docstring for each shape).

    shapes: the kinds of shape that give points, among "box", "sphere", "ellipsoid", "cylinder", "capsule", "mesh"
        (default: all but "mesh").
    sphere_points: points on each sphere and ellipsoid (Fibonacci lattice), >= 2. JaxSim's documented default is 50.
    circle_points: points on each ring of a cylinder or capsule, >= 3.
    side_rings: extra rings on the lateral surface of cylinders and capsules, between the end rims, >= 0.
    capsule_cap_rings: rings on each hemispherical cap of a capsule, the rim included, >= 1 (plus the pole).
    mesh_max_points: at most this many points per mesh (farthest-point subsample); None keeps all vertices.
    package_dirs: directories where `package://NAME/...` URIs are looked up, before the environment
        (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH/share, GZ_SIM_RESOURCE_PATH, IGN_GAZEBO_RESOURCE_PATH,
        SDF_PATH); each may be the package directory itself or a directory that contains it.
    mesh_dirs: directories where relative mesh paths are looked up (after the description's own
        directory when it is known, before the working directory).
    """

    shapes: tuple[str, ...] = ("box", "sphere", "ellipsoid", "cylinder", "capsule")
    sphere_points: int = 50
    circle_points: int = 16
    side_rings: int = 0
    capsule_cap_rings: int = 2
    mesh_max_points: int | None = None
    package_dirs: tuple[str, ...] = ()
    mesh_dirs: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "shapes", tuple(self.shapes))
        object.__setattr__(self, "package_dirs", tuple(str(d) for d in self.package_dirs))
        object.__setattr__(self, "mesh_dirs", tuple(str(d) for d in self.mesh_dirs))
        unknown = [s for s in self.shapes if s not in SHAPE_KINDS]
        if unknown:
            raise ValueError(f"CollidablePointsOptions.shapes has unknown kinds {unknown}; known: {list(SHAPE_KINDS)}")
        for name, minimum in (("sphere_points", 2), ("circle_points", 3), ("side_rings", 0), ("capsule_cap_rings", 1)):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < minimum:
                raise ValueError(f"CollidablePointsOptions.{name} must be an integer >= {minimum}, got {value!r}")
        m = self.mesh_max_points
        if m is not None and (isinstance(m, bool) or not isinstance(m, (int, np.integer)) or m < 1):
            raise ValueError(f"CollidablePointsOptions.mesh_max_points must be None or an integer >= 1, got {m!r}")


# ------------------------------------------------------------------------------------ points of shapes


def box_points(size) -> np.ndarray:
    """(8, 3) corners of a box of full extents `size` (3,) centred at the origin, in JaxSim's order."""
    x, y, z = np.asarray(size, dtype=np.float64)
    corners = np.array(
        [[0, 0, 0], [x, 0, 0], [x, y, 0], [0, y, 0], [0, 0, z], [x, 0, z], [x, y, z], [0, y, z]], dtype=np.float64
    )
    return corners - 0.5 * np.array([x, y, z])


def sphere_points(radius: float, count: int) -> np.ndarray:
    """(count, 3) points of a Fibonacci lattice on a sphere of `radius` centred at the origin.

    Point i has y = 1 - 2 i / (count - 1) (from the top to the bottom pole) and longitude i times the
    golden angle, as JaxSim's `create_sphere_collision`.
    """
    i = np.arange(count, dtype=np.float64)
    y = 1.0 - 2.0 * i / (count - 1)
    rho = np.sqrt(np.clip(1.0 - y * y, 0.0, None))
    theta = np.pi * (3.0 - np.sqrt(5.0)) * i
    return radius * np.stack([np.cos(theta) * rho, y, np.sin(theta) * rho], axis=1)


def ellipsoid_points(radii, count: int) -> np.ndarray:
    """(count, 3) points on an ellipsoid of `radii` (3,) [m] centred at the origin, its axes along x, y, z:
    `sphere_points(1, count)` scaled by the radii."""
    return sphere_points(1.0, count) * np.asarray(radii, dtype=np.float64).reshape(3)


def _ring(radius: float, z: float, count: int) -> np.ndarray:
    angle = 2.0 * np.pi * np.arange(count) / count
    return np.stack([radius * np.cos(angle), radius * np.sin(angle), np.full(count, z)], axis=1)


def _side_heights(length: float, rims: bool, side_rings: int) -> np.ndarray:
    """Heights of the rings on a lateral surface from z = -length/2 to +length/2."""
    z = np.linspace(-0.5 * length, 0.5 * length, side_rings + 2)
    return z if rims else z[1:-1]


def cylinder_points(radius: float, length: float, circle_points: int, side_rings: int = 0) -> np.ndarray:
    """Points of a cylinder along z centred at the origin: rims and side rings (bottom to top), then the
    centres of the bottom and top caps."""
    rings = [_ring(radius, z, circle_points) for z in _side_heights(length, True, side_rings)]
    caps = np.array([[0.0, 0.0, -0.5 * length], [0.0, 0.0, 0.5 * length]])
    return np.concatenate([*rings, caps])


def capsule_points(radius: float, length: float, circle_points: int, cap_rings: int, side_rings: int = 0) -> np.ndarray:
    """Points of a capsule along z centred at the origin (cylindrical part of `length`): for the bottom
    cap, then the top cap, its rings from the rim (elevation 0) towards the pole, then the pole; then the
    side rings."""
    points = []
    for sign in (-1.0, 1.0):
        centre = sign * 0.5 * length
        for j in range(cap_rings):
            elevation = 0.5 * np.pi * j / cap_rings
            points.append(_ring(radius * np.cos(elevation), centre + sign * radius * np.sin(elevation), circle_points))
        points.append(np.array([[0.0, 0.0, centre + sign * radius]]))
    points += [_ring(radius, z, circle_points) for z in _side_heights(length, False, side_rings)]
    return np.concatenate(points)


def farthest_point_subsample(points: np.ndarray, count: int) -> np.ndarray:
    """`count` of `points` (K, 3) chosen greedily, each the farthest from those chosen before, starting
    from the lowest point along z (ties: the first). Deterministic; the chosen points keep their order."""
    points = np.asarray(points, dtype=np.float64)
    if len(points) <= count:
        return points
    chosen = [int(np.argmin(points[:, 2]))]
    distance = np.linalg.norm(points - points[chosen[0]], axis=1)
    for _ in range(count - 1):
        k = int(np.argmax(distance))
        chosen.append(k)
        distance = np.minimum(distance, np.linalg.norm(points - points[k], axis=1))
    return points[np.sort(chosen)]


# ------------------------------------------------------------------------------------- mesh files


def _env_dirs(name: str, suffix: str = "") -> list[pathlib.Path]:
    return [pathlib.Path(d) / suffix if suffix else pathlib.Path(d) for d in os.environ.get(name, "").split(os.pathsep) if d]


def resolve_mesh_uri(uri: str, *, base_dir=None, package_dirs=(), mesh_dirs=()) -> pathlib.Path | None:
    """The local file of a mesh URI, or None when it cannot be found.

    - `file://PATH` and absolute paths: the path itself.
    - `package://NAME/REST` and `model://NAME/REST`: REST under the package NAME, looked up in
      `package_dirs`, then the environment (ROS_PACKAGE_PATH, AMENT_PREFIX_PATH/share,
      GZ_SIM_RESOURCE_PATH, IGN_GAZEBO_RESOURCE_PATH, SDF_PATH), then the ancestors of `base_dir`;
      a directory matches when it is named NAME or contains NAME.
    - relative paths: under `base_dir` (the description's directory), then `mesh_dirs`, then the
      working directory.
    """
    parsed = urllib.parse.urlparse(uri)
    if parsed.scheme == "file":
        path = pathlib.Path(urllib.parse.unquote(parsed.netloc + parsed.path))
        return path if path.is_file() else None
    base = pathlib.Path(base_dir) if base_dir is not None else None
    if parsed.scheme in ("package", "model"):
        name, rest = parsed.netloc, parsed.path.lstrip("/")
        roots = [pathlib.Path(d) for d in package_dirs]
        roots += _env_dirs("ROS_PACKAGE_PATH") + _env_dirs("AMENT_PREFIX_PATH", "share")
        roots += _env_dirs("GZ_SIM_RESOURCE_PATH") + _env_dirs("IGN_GAZEBO_RESOURCE_PATH") + _env_dirs("SDF_PATH")
        if base is not None:
            roots += [base, *base.parents]
        for root in roots:
            for package in (root, root / name) if root.name == name else (root / name,):
                candidate = package / rest
                if candidate.is_file():
                    return candidate
        return None
    if len(parsed.scheme) > 1:  # another URL scheme (http, ...): not fetched (one letter: a Windows drive)
        return None
    path = pathlib.Path(uri).expanduser()
    if path.is_absolute():
        return path if path.is_file() else None
    for root in ([base] if base is not None else []) + [pathlib.Path(d) for d in mesh_dirs] + [pathlib.Path.cwd()]:
        if (root / path).is_file():
            return root / path
    return None


def mesh_file_vertices(shape, options: CollidablePointsOptions, base_dir) -> tuple[np.ndarray | None, str | None]:
    """(a mesh shape's vertices (k, 3) as its file holds them, unscaled, None) or (None, why they are missing: "not
    found", "unreadable (...)", "empty"); its own `vertices` where it has them (an MJCF mesh's). The file is found by
    `resolve_mesh_uri` (base_dir, options.package_dirs, options.mesh_dirs) and read with trimesh."""
    if shape.vertices is not None:
        vertices = np.asarray(shape.vertices, dtype=np.float64)
    else:
        path = resolve_mesh_uri(
            shape.filename or "", base_dir=base_dir, package_dirs=options.package_dirs, mesh_dirs=options.mesh_dirs
        )
        if path is None:
            return None, "not found"
        try:
            import trimesh

            mesh = trimesh.load(str(path), force="mesh", process=False)
            vertices = np.asarray(mesh.vertices, dtype=np.float64)
        except Exception as error:  # trimesh raises many kinds of errors for unreadable files
            return None, f"unreadable ({type(error).__name__}: {error})"
    vertices = vertices.reshape(-1, 3)
    if len(vertices) == 0:
        return None, "empty"
    return vertices, None


def _mesh_vertices(shape, options: CollidablePointsOptions, base_dir) -> tuple[np.ndarray | None, str | None]:
    """(vertices in the shape frame, None) or (None, why they are missing)."""
    vertices, why = mesh_file_vertices(shape, options, base_dir)
    if vertices is None:
        return None, why
    scale = np.ones(3) if shape.scale is None else np.asarray(shape.scale, dtype=np.float64)
    vertices = np.unique(vertices, axis=0) * scale
    if options.mesh_max_points is not None:
        vertices = farthest_point_subsample(vertices, options.mesh_max_points)
    return vertices, None


def _shape_points(shape, options: CollidablePointsOptions, base_dir) -> tuple[np.ndarray | None, str | None]:
    if shape.kind == "box":
        return box_points(shape.size), None
    if shape.kind == "sphere":
        return sphere_points(shape.radius, options.sphere_points), None
    if shape.kind == "ellipsoid":
        return ellipsoid_points(shape.size, options.sphere_points), None
    if shape.kind == "cylinder":
        return cylinder_points(shape.radius, shape.length, options.circle_points, options.side_rings), None
    if shape.kind == "capsule":
        return (
            capsule_points(shape.radius, shape.length, options.circle_points, options.capsule_cap_rings, options.side_rings),
            None,
        )
    if shape.kind == "mesh":
        return _mesh_vertices(shape, options, base_dir)
    return None, None


def collidable_points(tree, options: CollidablePointsOptions | None = None, base_dir=None, *, warn: bool = True):
    """(body (nc,) int, L_p_C (nc, 3) float64) of a `KinematicTree`'s collision shapes.

    With `warn`, one `UnresolvedMeshWarning` lists the meshes that gave no points.
    """
    options = CollidablePointsOptions() if options is None else options
    body, points, missing = [], [], []
    for link, k in tree.shape_order:  # the description's order of the shapes, as JaxSim's
        shape = tree.collisions[link][k]
        if shape.kind not in options.shapes:
            continue
        local, why = _shape_points(shape, options, base_dir)
        if local is None:
            if why is not None:
                missing.append((why, tree.link_names[link], str(shape.filename)))
            continue
        H = np.asarray(shape.link_H_shape, dtype=np.float64)
        points.append(local @ H[:3, :3].T + H[:3, 3])
        body += [link] * len(local)
    if missing and warn:
        groups: dict[str, dict[str, list[str]]] = {}
        for why, link_name, uri in missing:
            groups.setdefault(why, {}).setdefault(link_name, []).append(uri)
        listing = "; ".join(
            f"{why}: " + ", ".join(f"on link '{name}': {uris}" for name, uris in links.items())
            for why, links in groups.items()
        )
        warnings.warn(
            f"{len(missing)} collision mesh(es) give no collidable points ({listing}). "
            "Set CollidablePointsOptions(package_dirs=..., mesh_dirs=...) or ROS_PACKAGE_PATH to find them, or "
            "leave 'mesh' out of CollidablePointsOptions.shapes (JaxSim's default) to use the other shapes only "
            "(warpdyn.contact.with_collidable_points).",
            UnresolvedMeshWarning,
            stacklevel=4,
        )
    L_p_C = np.concatenate(points) if points else np.zeros((0, 3))
    return np.asarray(body, dtype=np.int64), L_p_C
