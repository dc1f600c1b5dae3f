"""Recording simulations with rerun (https://rerun.io): link frames, collision shapes, collidable points,
contact forces and the terrain, into a `.rrd` file or a live viewer.

rerun-sdk is an optional dependency (`pip install "warpdyn[viz]"`); it is imported when a recorder is
made, not when this module is. The geometry helpers (`terrain_mesh`, `terrain_grid_lines`,
`shape_primitive`, `point_penetration`, `point_colors`, `skeleton_segments`) are NumPy only.

    final, rec = wd.visualization.record_rollout(model, data, steps=1000, path="drop.rrd")   # then: rerun drop.rrd

    recorder = wd.visualization.RerunRecorder(model, path="run.rrd")   # or spawn=True, or connect="rerun+http://..."
    recorder.log_static()                        # collision shapes in the link frames, the terrain
    recorder.log(data, time=t)                   # one frame from Data (a few small kernels and copies)
    recorder.log_trajectory(times, base_position, base_quaternion, joint_positions, point_forces)
    recorder.close()

What a frame holds (entity paths under `root`, default "world"; z up, metres):
- `robot/links/<link>`: the link frame (Transform3D from `wd.model.forward_kinematics`, with axes), and
  under it `collision/<k>_<kind>`: the link's collision shapes at their `link_H_shape` (static): boxes,
  spheres (ellipsoids), cylinders, capsules, and meshes when their files resolve (as the collidable
  points resolve them: `CollidablePointsOptions.package_dirs/mesh_dirs`, ROS_PACKAGE_PATH, ...; MJCF
  meshes, which come as vertices only, as their convex hull);
- `robot/skeleton`: segments from each link's origin to its children's;
- `contact/points`: the enabled collidable points, coloured by penetration delta = (h(x, y) - z) n_z:
  blue-grey above the terrain, yellow at it to red at `depth_scale` [m] below (JaxSim's in-contact test
  is z <= h: a link is `wd.contact.in_contact` when one of its points is yellow to red);
- `contact/forces`: an arrow per point with a nonzero contact force, force [N] times `force_scale` [m/N],
  from the point;
- `terrain/mesh` and `terrain/grid` (static): the terrain as a triangle mesh (flat and plane terrains: a
  square of `terrain_half_extent` around `terrain_center`; a heightfield: its grid) and grid lines;
- `plots/...`: scalars per frame: the base height, the number of points in contact and the total
  vertical contact force.
Time: the timeline `sim_time` (seconds) and the sequence `frame`.

Logging is host work (FK and point positions for all the frames in one launch each, then rerun calls),
done off the simulation's hot path: `record_rollout` records the base pose and joint positions (and the
points' forces) in the rollout's device arrays and logs after it. rerun versions: 0.20 and later (time,
axes and scalars are logged through whichever API the installed version has; checked with 0.20.3 and
0.41.0). A viewer reads the files of its own version (0.41 refuses 0.20's files).
"""

from __future__ import annotations

import dataclasses
import inspect
import pathlib
import re
import warnings

import numpy as np

from . import contact as _contact
from . import data as _data
from . import model as _model
from . import simulation as _simulation
from .model import VelRepr

__all__ = [
    "RerunRecorder",
    "record_rollout",
    "ShapePrimitive",
    "shape_primitive",
    "terrain_mesh",
    "terrain_grid_lines",
    "point_penetration",
    "point_colors",
    "skeleton_segments",
]

INSTALL_HINT = 'warpdyn.visualization needs rerun-sdk: pip install "warpdyn[viz]" (or pip install rerun-sdk)'

SHAPE_COLOR = (170, 180, 200, 255)
MESH_COLOR = (190, 190, 190, 255)
POINT_FREE_COLOR = np.array([110, 130, 170, 255], dtype=np.uint8)
POINT_TOUCH_COLOR = np.array([255, 220, 0, 255], dtype=np.float64)
POINT_DEEP_COLOR = np.array([230, 20, 20, 255], dtype=np.float64)
FORCE_COLOR = (255, 60, 200, 255)
TERRAIN_COLOR = (120, 150, 110, 255)
GRID_COLOR = (70, 90, 65, 255)
SKELETON_COLOR = (40, 40, 40, 255)


def _rerun():
    """The rerun module, or an ImportError that says how to install it."""
    try:
        import rerun
    except ImportError as error:
        raise ImportError(INSTALL_HINT) from error
    return rerun


# ------------------------------------------------------------------------------- geometry (NumPy)


@dataclasses.dataclass(frozen=True)
class ShapePrimitive:
    """A collision shape as rerun draws it, in the shape's frame (whose pose in the link is `link_H_shape`).

    kind: "box" (half_sizes (3,)), "sphere" (radius), "ellipsoid" (half_sizes: its radii (3,)), "cylinder" (radius, length: centred, along z),
    "capsule" (radius, length of the cylindrical part: centred, along z), "mesh" (filename, scale (3,),
    vertices (K, 3) for MJCF meshes).
    """

    kind: str
    link_H_shape: np.ndarray
    half_sizes: np.ndarray | None = None
    radius: float = 0.0
    length: float = 0.0
    filename: str | None = None
    scale: np.ndarray | None = None
    vertices: np.ndarray | None = None


def shape_primitive(shape) -> ShapePrimitive:
    """The `ShapePrimitive` of a `warpdyn.description.CollisionShape` (box: half of the full extents)."""
    H = np.asarray(shape.link_H_shape, dtype=np.float64).reshape(4, 4)
    if shape.kind == "box":
        return ShapePrimitive("box", H, half_sizes=0.5 * np.asarray(shape.size, dtype=np.float64).reshape(3))
    if shape.kind == "ellipsoid":
        return ShapePrimitive("ellipsoid", H, half_sizes=np.asarray(shape.size, dtype=np.float64).reshape(3))
    if shape.kind in ("sphere", "cylinder", "capsule"):
        return ShapePrimitive(shape.kind, H, radius=float(shape.radius), length=float(shape.length))
    if shape.kind == "mesh":
        scale = np.ones(3) if shape.scale is None else np.asarray(shape.scale, dtype=np.float64).reshape(3)
        vertices = None if shape.vertices is None else np.asarray(shape.vertices, dtype=np.float64).reshape(-1, 3)
        return ShapePrimitive("mesh", H, filename=shape.filename, scale=scale, vertices=vertices)
    raise ValueError(f"unknown collision shape kind {shape.kind!r}")


def _square(center, half_extent) -> tuple[float, float, float, float]:
    cx, cy = (float(c) for c in np.asarray(center, dtype=np.float64).reshape(-1)[:2])
    a = float(half_extent)
    if not a > 0.0:
        raise ValueError(f"half_extent must be positive, got {half_extent!r}")
    return cx - a, cx + a, cy - a, cy + a


def terrain_mesh(terrain, *, center=(0.0, 0.0), half_extent: float = 2.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(vertices (V, 3), triangles (T, 3) int32, normals (V, 3)): the terrain as a triangle mesh whose
    vertices lie on it, triangles counter-clockwise seen from above (their normals point out of the ground).

    Flat and plane terrains: the square of side 2 half_extent around `center` (x, y), two triangles.
    Heightfield: its grid (its nodes are the vertices; the bilinear patches are split in two triangles),
    whatever `center` and `half_extent` (outside the grid the terrain continues at the edge heights).
    """
    if hasattr(terrain, "heights"):
        nx, ny = terrain.heights.shape
        x = terrain.origin[0] + terrain.spacing[0] * np.arange(nx)
        y = terrain.origin[1] + terrain.spacing[1] * np.arange(ny)
    else:
        x0, x1, y0, y1 = _square(center, half_extent)
        x, y = np.array([x0, x1]), np.array([y0, y1])
        nx, ny = 2, 2
    X, Y = np.meshgrid(x, y, indexing="ij")  # vertex (i, j) at index i * ny + j
    Z = np.asarray(terrain.height(X, Y), dtype=np.float64)
    vertices = np.stack([X, Y, Z], axis=-1).reshape(-1, 3)
    normals = np.asarray(terrain.normal(X, Y), dtype=np.float64).reshape(-1, 3)
    i, j = np.meshgrid(np.arange(nx - 1), np.arange(ny - 1), indexing="ij")
    a = (i * ny + j).reshape(-1)  # (i, j)
    b = a + ny  # (i + 1, j)
    c = b + 1  # (i + 1, j + 1)
    d = a + 1  # (i, j + 1)
    triangles = np.concatenate([np.stack([a, b, c], axis=1), np.stack([a, c, d], axis=1)]).astype(np.int32)
    return vertices, triangles, normals


def terrain_grid_lines(terrain, *, center=(0.0, 0.0), half_extent: float = 2.0, spacing: float = 0.25, samples: int = 2) -> list[np.ndarray]:
    """Grid lines on the terrain, every `spacing` [m] in x and y over the square around `center`, each
    line a (samples, 3) polyline on the terrain (lines at multiples of `spacing`, so they stay put when the
    square moves). Use samples > 2 to follow a heightfield."""
    x0, x1, y0, y1 = _square(center, half_extent)
    if not spacing > 0.0 or samples < 2:
        raise ValueError(f"spacing must be positive and samples >= 2, got {spacing!r}, {samples!r}")
    lines = []
    t = np.linspace(0.0, 1.0, samples)
    for x in spacing * np.arange(np.ceil(x0 / spacing), np.floor(x1 / spacing) + 1):
        ys = y0 + t * (y1 - y0)
        lines.append(np.stack([np.full_like(ys, x), ys, terrain.height(np.full_like(ys, x), ys)], axis=1))
    for y in spacing * np.arange(np.ceil(y0 / spacing), np.floor(y1 / spacing) + 1):
        xs = x0 + t * (x1 - x0)
        lines.append(np.stack([xs, np.full_like(xs, y), terrain.height(xs, np.full_like(xs, y))], axis=1))
    return lines


def point_penetration(terrain, points) -> np.ndarray:
    """delta = (h(x, y) - z) n_z(x, y) of points (..., 3) [m]: positive below the terrain (the depth the
    soft contacts use), zero on it, negative above."""
    return terrain.penetration(points)


def point_colors(delta, depth_scale: float = 2e-3) -> np.ndarray:
    """RGBA uint8 (..., 4) for penetrations delta [m]: blue-grey where delta < 0 (above the terrain),
    yellow at delta = 0 to red at delta >= depth_scale."""
    delta = np.asarray(delta, dtype=np.float64)
    s = np.clip(delta / float(depth_scale), 0.0, 1.0)[..., None]
    touching = np.rint((1.0 - s) * POINT_TOUCH_COLOR + s * POINT_DEEP_COLOR).astype(np.uint8)
    return np.where((delta >= 0.0)[..., None], touching, POINT_FREE_COLOR)


def skeleton_segments(parent, W_H_L) -> np.ndarray:
    """(nL - 1, 2, 3): for each non-base link, the segment from its parent's origin to its own."""
    parent = np.asarray(parent)
    p = np.asarray(W_H_L, dtype=np.float64)[..., :3, 3]
    links = np.flatnonzero(parent >= 0)
    return np.stack([p[parent[links]], p[links]], axis=1)


def _entity_name(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_\-]", "_", name) or "_"


def _unique_names(names) -> list[str]:
    seen: dict[str, int] = {}
    out = []
    for name in names:
        base = _entity_name(name)
        k = seen.get(base, 0)
        seen[base] = k + 1
        out.append(base if k == 0 else f"{base}_{k}")
    return out


# --------------------------------------------------------------------------------------- recorder


class RerunRecorder:
    """Logs a model's frames to a rerun recording (see the module docstring for what and where).

    Sink: `path` (an .rrd file), `spawn=True` (starts a viewer and streams to it) or `connect` (the URL of
    a running viewer, e.g. "rerun+http://127.0.0.1:9876/proxy"; True for the default one). Exactly one.
    env: the environment logged from batched data. force_scale [m/N]: arrow length per newton.
    depth_scale [m]: the penetration drawn fully red. point_radius [m]. axis_length [m]: of the link
    frames' axes (0: none). meshes: log the mesh shapes whose files resolve. terrain_center (x, y) and
    terrain_half_extent [m]: the terrain square drawn (default: around the first logged base position).
    """

    def __init__(
        self,
        model,
        *,
        path=None,
        spawn: bool = False,
        connect=None,
        application_id: str = "warpdyn",
        recording_id=None,
        env: int = 0,
        root: str = "world",
        force_scale: float = 2e-3,
        depth_scale: float = 2e-3,
        point_radius: float = 4e-3,
        axis_length: float = 0.08,
        meshes: bool = True,
        terrain_center=None,
        terrain_half_extent: float = 2.0,
    ):
        rr = _rerun()
        sinks = (path is not None) + bool(spawn) + (connect is not None and connect is not False)
        if sinks != 1:
            raise ValueError("give exactly one sink: path (an .rrd file), spawn=True or connect (a viewer's URL)")
        if isinstance(env, (bool, np.bool_)) or not isinstance(env, (int, np.integer)) or env < 0:
            raise ValueError(f"env must be a non-negative integer, got {env!r}")
        self.rr = rr
        self.model = model
        self.env = int(env)
        self.root = root.strip("/") or "world"
        self.force_scale = float(force_scale)
        self.depth_scale = float(depth_scale)
        self.point_radius = float(point_radius)
        self.axis_length = float(axis_length)
        self.meshes = bool(meshes)
        self.terrain_center = None if terrain_center is None else np.asarray(terrain_center, dtype=np.float64)[:2]
        self.terrain_half_extent = float(terrain_half_extent)
        self.path = None if path is None else pathlib.Path(path)
        if hasattr(rr, "new_recording"):  # rerun < 0.2x: RecordingStream wraps a binding
            self.rec = rr.new_recording(application_id, recording_id=recording_id)
        else:
            self.rec = rr.RecordingStream(application_id, recording_id=recording_id)
        if path is not None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            rr.save(str(self.path), recording=self.rec)
        elif spawn:
            rr.spawn(recording=self.rec)
        else:
            url = None if connect is True else str(connect)
            if hasattr(rr, "connect_grpc"):
                rr.connect_grpc(url, recording=self.rec)
            else:  # rerun < 0.23
                rr.connect(url, recording=self.rec) if url is not None else rr.connect(recording=self.rec)
        self.link_names = list(model.link_names())
        self._link_paths = [f"{self.root}/robot/links/{name}" for name in _unique_names(self.link_names)]
        self._parent = np.asarray(model.tree.parent)
        params = model.kin_dyn_structure().contact_parameters
        idx = params.indices_of_enabled_collidable_points
        self._point_link = np.asarray(params.body, dtype=np.int64)[idx]
        self._static_logged = False
        # rerun < 0.2x draws a frame's axes from Transform3D(axis_length=), later ones from TransformAxes3D
        self._axes_in_transform = not hasattr(rr, "TransformAxes3D") and "axis_length" in inspect.signature(rr.Transform3D.__init__).parameters
        self._closed = False
        self.unresolved_meshes: list[str] = []
        self.frames = 0

    # ----------------------------------------------------------------------------------- helpers

    def _log(self, path: str, *archetypes, static: bool = False) -> None:
        self.rr.log(path, *archetypes, static=static, recording=self.rec)

    def _set_time(self, time: float, frame: int) -> None:
        rr = self.rr
        if hasattr(rr, "set_time"):  # rerun >= 0.23
            rr.set_time("sim_time", duration=float(time), recording=self.rec)
            rr.set_time("frame", sequence=int(frame), recording=self.rec)
        else:
            rr.set_time_seconds("sim_time", float(time), recording=self.rec)
            rr.set_time_sequence("frame", int(frame), recording=self.rec)

    def _scalar(self, path: str, value: float) -> None:
        rr = self.rr
        archetype = rr.Scalars([float(value)]) if hasattr(rr, "Scalars") else rr.Scalar(float(value))
        self._log(path, archetype)

    def _transform(self, H: np.ndarray, axes: bool = False):
        H = np.asarray(H, dtype=np.float64)
        kwargs = {}
        if axes and self.axis_length > 0.0 and self._axes_in_transform:
            kwargs["axis_length"] = self.axis_length
        return self.rr.Transform3D(translation=H[:3, 3].astype(np.float32), mat3x3=H[:3, :3].astype(np.float32), **kwargs)

    def _fill(self) -> dict:
        fill = getattr(getattr(self.rr, "components", None), "FillMode", None)
        return {"fill_mode": fill.Solid} if fill is not None and hasattr(fill, "Solid") else {}

    def _mesh_of(self, shape: ShapePrimitive):
        """A rerun archetype for a mesh shape, or None (and the reason kept) when it cannot be drawn."""
        rr = self.rr
        if shape.vertices is not None:  # MJCF: vertices only, drawn as their convex hull
            vertices = shape.vertices * shape.scale
            try:
                import trimesh

                hull = trimesh.Trimesh(vertices=vertices, process=False).convex_hull
                return rr.Mesh3D(
                    vertex_positions=np.asarray(hull.vertices, dtype=np.float32),
                    triangle_indices=np.asarray(hull.faces, dtype=np.uint32),
                    vertex_normals=np.asarray(hull.vertex_normals, dtype=np.float32),
                    albedo_factor=MESH_COLOR,
                )
            except Exception:  # no trimesh/scipy, or a degenerate hull: the vertices as points
                return rr.Points3D(vertices.astype(np.float32), radii=self.point_radius / 2, colors=[MESH_COLOR])
        options = self.model.kin_dyn_structure().options
        source = getattr(self.model.description, "path", None)
        base_dir = pathlib.Path(source).parent if source else None
        path = _contact.resolve_mesh_uri(shape.filename or "", base_dir=base_dir, package_dirs=options.package_dirs, mesh_dirs=options.mesh_dirs)
        if path is None:
            self.unresolved_meshes.append(f"{shape.filename} (not found)")
            return None
        try:
            import trimesh

            mesh = trimesh.load(str(path), force="mesh", process=False)
            vertices = np.asarray(mesh.vertices, dtype=np.float64) * shape.scale
            faces = np.asarray(mesh.faces, dtype=np.uint32)
            if len(faces) == 0:
                raise ValueError("no faces")
            if np.linalg.det(np.diag(shape.scale)) < 0.0:  # a mirroring scale flips the winding
                faces = faces[:, ::-1]
            normals = trimesh.Trimesh(vertices=vertices, faces=faces, process=False).vertex_normals
        except Exception as error:  # trimesh raises many kinds of errors for unreadable files
            self.unresolved_meshes.append(f"{shape.filename} (unreadable: {type(error).__name__})")
            return None
        return rr.Mesh3D(
            vertex_positions=vertices.astype(np.float32),
            triangle_indices=faces,
            vertex_normals=np.asarray(normals, dtype=np.float32),
            albedo_factor=MESH_COLOR,
        )

    def _primitive(self, shape: ShapePrimitive):
        rr = self.rr
        color = [SHAPE_COLOR]
        if shape.kind == "box":
            return rr.Boxes3D(half_sizes=[shape.half_sizes.astype(np.float32)], colors=color, **self._fill())
        if shape.kind == "sphere":
            r = shape.radius
            return rr.Ellipsoids3D(half_sizes=[[r, r, r]], colors=color, **self._fill())
        if shape.kind == "ellipsoid":
            return rr.Ellipsoids3D(half_sizes=[shape.half_sizes.astype(np.float32)], colors=color, **self._fill())
        if shape.kind == "cylinder":
            if hasattr(rr, "Cylinders3D"):  # rerun >= 0.22
                return rr.Cylinders3D(lengths=[shape.length], radii=[shape.radius], colors=color, **self._fill())
            return rr.Capsules3D(lengths=[shape.length], radii=[shape.radius], translations=[[0.0, 0.0, -0.5 * shape.length]], colors=color)
        if shape.kind == "capsule":  # rerun's capsule runs from its origin along +z
            return rr.Capsules3D(
                lengths=[shape.length], radii=[shape.radius], translations=[[0.0, 0.0, -0.5 * shape.length]], colors=color, **self._fill()
            )
        if shape.kind == "mesh":
            return self._mesh_of(shape) if self.meshes else None
        return None

    # ----------------------------------------------------------------------------------- logging

    def log_static(self, *, terrain_center=None) -> None:
        """Log what does not move: the world's axes (z up), the links' collision shapes in their frames,
        and the terrain (around `terrain_center`, else the recorder's, else the origin). Called by the
        first `log`/`log_trajectory` when not called before."""
        rr = self.rr
        self._log(self.root, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for link, shapes in enumerate(self.model.tree.collisions):
            path = self._link_paths[link]
            if self.axis_length > 0.0 and hasattr(rr, "TransformAxes3D"):
                self._log(path, rr.TransformAxes3D(self.axis_length), static=True)
            for k, shape in enumerate(shapes):
                primitive = shape_primitive(shape)
                archetype = self._primitive(primitive)
                if archetype is None:
                    continue
                shape_path = f"{path}/collision/{k}_{primitive.kind}"
                self._log(shape_path, self._transform(primitive.link_H_shape), archetype, static=True)
        if self.unresolved_meshes:
            shown = ", ".join(self.unresolved_meshes[:3]) + (", ..." if len(self.unresolved_meshes) > 3 else "")
            warnings.warn(
                f"{len(self.unresolved_meshes)} collision mesh(es) not drawn: {shown}. Set "
                "CollidablePointsOptions(package_dirs=..., mesh_dirs=...) (wd.contact.with_collidable_points) or "
                "ROS_PACKAGE_PATH to find them, or meshes=False to skip them.",
                _contact.UnresolvedMeshWarning,
                stacklevel=2,
            )
        center = terrain_center if terrain_center is not None else self.terrain_center
        self.log_terrain(center=(0.0, 0.0) if center is None else center)
        self._static_logged = True

    def log_terrain(self, *, center=(0.0, 0.0), half_extent: float | None = None) -> None:
        """Log `model.terrain` (static, the recorded environment's) as a mesh and grid lines around `center` (x, y)."""
        rr = self.rr
        terrain = self.model.terrain.for_env(self.env)
        half = self.terrain_half_extent if half_extent is None else float(half_extent)
        vertices, triangles, normals = terrain_mesh(terrain, center=center, half_extent=half)
        # The mesh sits 0.5 mm under the terrain so that points and grid lines on it stay visible.
        self._log(
            f"{self.root}/terrain/mesh",
            rr.Mesh3D(
                vertex_positions=(vertices - 5e-4 * normals).astype(np.float32),
                triangle_indices=triangles.astype(np.uint32),
                vertex_normals=normals.astype(np.float32),
                albedo_factor=TERRAIN_COLOR,
            ),
            static=True,
        )
        samples = 2 if not hasattr(terrain, "heights") else max(2, int(np.ceil(2 * half / min(terrain.spacing))) + 1)
        lines = terrain_grid_lines(terrain, center=center, half_extent=half, samples=samples)
        if lines:
            self._log(
                f"{self.root}/terrain/grid",
                rr.LineStrips3D([line.astype(np.float32) for line in lines], colors=[GRID_COLOR], radii=[1e-3]),
                static=True,
            )

    def _log_frame(self, time: float, W_H_L: np.ndarray, W_p_C: np.ndarray, W_f_C: np.ndarray | None) -> None:
        rr = self.rr
        self._set_time(time, self.frames)
        for path, H in zip(self._link_paths, W_H_L):
            self._log(path, self._transform(H, axes=True))
        segments = skeleton_segments(self._parent, W_H_L)
        if len(segments):
            self._log(f"{self.root}/robot/skeleton", rr.LineStrips3D(segments.astype(np.float32), colors=[SKELETON_COLOR], radii=[4e-3]))
        self._scalar(f"{self.root}/plots/base_height", W_H_L[0, 2, 3])
        if len(W_p_C):
            delta = point_penetration(self.model.terrain.for_env(self.env), W_p_C)
            self._log(
                f"{self.root}/contact/points",
                rr.Points3D(W_p_C.astype(np.float32), colors=point_colors(delta, self.depth_scale), radii=[self.point_radius]),
            )
            self._scalar(f"{self.root}/plots/points_in_contact", float(np.count_nonzero(delta >= 0.0)))
        if W_f_C is not None and len(W_p_C):
            active = np.linalg.norm(W_f_C, axis=1) > 0.0
            self._log(
                f"{self.root}/contact/forces",
                rr.Arrows3D(
                    vectors=(self.force_scale * W_f_C[active]).astype(np.float32).reshape(-1, 3),
                    origins=W_p_C[active].astype(np.float32).reshape(-1, 3),
                    colors=[FORCE_COLOR],
                    radii=[2e-3],
                ),
            )
            self._scalar(f"{self.root}/plots/contact_force_z", float(W_f_C[:, 2].sum()))
        self.frames += 1

    def _ensure_static(self, W_H_L: np.ndarray) -> None:
        if not self._static_logged:
            center = self.terrain_center if self.terrain_center is not None else W_H_L[0, :2, 3]
            self.log_static(terrain_center=center)

    def _env_slice(self, array: np.ndarray, batched: bool) -> np.ndarray:
        if not batched:
            return array
        if self.env >= array.shape[0]:
            raise ValueError(f"env = {self.env} but the data has {array.shape[0]} environments")
        return array[self.env]

    def log(self, data, time: float | None = None, *, contact_forces: bool = True) -> None:
        """Log one frame from Data (environment `env` of batched data) at `time` [s] (default: the frame
        number times the model's time step). contact_forces: the soft-contact forces at this state
        (`wd.contact.collidable_point_forces`), as arrows."""

        self._check_open()
        batched = data.num_envs is not None
        W_H_L = self._env_slice(_model.forward_kinematics(self.model, data).numpy(), batched).astype(np.float64)
        W_p_C = self._env_slice(_contact.collidable_point_positions(self.model, data).numpy(), batched).astype(np.float64)
        W_f_C = None
        if contact_forces and len(W_p_C):
            f = _contact.collidable_point_forces(self.model, data, output_vel_repr=VelRepr.Mixed).numpy()
            W_f_C = self._env_slice(f, batched)[:, :3].astype(np.float64)
        self._ensure_static(W_H_L)
        self._log_frame(self.frames * self.model.time_step if time is None else float(time), W_H_L, W_p_C.reshape(-1, 3), W_f_C)

    def log_trajectory(self, times, base_position, base_quaternion, joint_positions, point_forces=None, *, force_axes: str = "world") -> None:
        """Log F frames of one environment from host arrays: times (F,) [s], base_position (F, 3),
        base_quaternion (F, 4) (w, x, y, z), joint_positions (F, nq), point_forces (F, nc, 3) (the enabled
        points' forces [N] in world axes, or with force_axes="link" in the axes of each point's link: the
        linear part of `collidable_point_forces` in the Body representation) or None. FK and point
        positions for all frames run as one batch of F environments."""

        self._check_open()
        times = np.asarray(times, dtype=np.float64).reshape(-1)
        F, nq = len(times), self.model.number_of_joint_coordinates()
        if F == 0:
            return
        base_position = np.asarray(base_position, dtype=np.float64).reshape(F, 3)
        q = np.asarray(base_quaternion, dtype=np.float64).reshape(F, 4)
        q = q / np.linalg.norm(q, axis=1, keepdims=True)
        s = np.asarray(joint_positions, dtype=np.float64).reshape(F, nq)
        frames = _data.Data.build(
            self.model, base_position=base_position, base_quaternion=q, joint_positions=s, num_envs=F, validate=False
        )
        W_H_L = _model.forward_kinematics(self.model, frames).numpy().astype(np.float64).reshape(F, -1, 4, 4)
        nc = len(self._point_link)
        W_p_C = _contact.collidable_point_positions(self.model, frames).numpy().astype(np.float64).reshape(F, nc, 3)
        if force_axes not in ("world", "link"):
            raise ValueError(f"force_axes must be 'world' or 'link', got {force_axes!r}")
        if point_forces is not None:
            point_forces = np.asarray(point_forces, dtype=np.float64).reshape(F, nc, 3)
            if force_axes == "link":  # W_f = W_R_L L_f
                point_forces = np.einsum("fcij,fcj->fci", W_H_L[:, self._point_link, :3, :3], point_forces)
        self._ensure_static(W_H_L[0])
        for k in range(F):
            self._log_frame(times[k], W_H_L[k], W_p_C[k], None if point_forces is None else point_forces[k])

    def flush(self) -> None:
        """Write what is buffered to the sink (rerun < 0.21 flushes when the sink is closed only)."""
        if hasattr(self.rec, "flush"):
            self.rec.flush()

    def close(self) -> None:
        """Flush and close the sink (the .rrd file is complete after this)."""
        if self._closed:
            return
        self.flush()
        self.rr.disconnect(recording=self.rec)
        self._closed = True

    def _check_open(self) -> None:
        if self._closed:
            raise RuntimeError("this RerunRecorder is closed")

    def __enter__(self) -> RerunRecorder:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


# --------------------------------------------------------------------------------------- rollouts


def record_rollout(
    model,
    data,
    *,
    steps: int,
    path=None,
    spawn: bool = False,
    connect=None,
    every: int = 1,
    joint_force_references=None,
    link_forces=None,
    env: int = 0,
    contact_forces: bool = True,
    recorder: RerunRecorder | None = None,
    **recorder_options,
):
    """(final Data, records): `wd.simulation.rollout(model, data, steps=..., ...)` recording the base pose,
    joint positions and (with contact_forces) the points' forces on the device, then logging the frames
    t = 0, every, 2 every, ..., steps (the last one always) of environment `env` to rerun at
    t * model.time_step [s]. The sink: `path` (.rrd), `spawn` or `connect` (see `RerunRecorder`), or an
    open `recorder` (then left open). recorder_options go to `RerunRecorder`. The records are the
    rollout's ("base_position", "base_quaternion", "joint_positions", "collidable_point_forces")."""

    if isinstance(every, (bool, np.bool_)) or not isinstance(every, (int, np.integer)) or every < 1:
        raise ValueError(f"every must be a positive integer, got {every!r}")
    own = recorder is None
    if own:
        recorder = RerunRecorder(model, path=path, spawn=spawn, connect=connect, env=env, **recorder_options)
    elif path is not None or spawn or connect is not None or recorder_options:
        raise ValueError("give either an open recorder or the sink and options of a new one, not both")
    try:
        record = ["base_position", "base_quaternion", "joint_positions"]
        with_forces = contact_forces and len(recorder._point_link) > 0
        if with_forces:
            record.append("collidable_point_forces")
        final, records = _simulation.rollout(
            model, data, steps=steps, joint_force_references=joint_force_references, link_forces=link_forces, record=tuple(record)
        )
        batched = data.num_envs is not None
        host = {}
        for name, array in records.items():  # (L, N, ...) or (L, ...) -> (L, ...) of environment `env`
            values = array.numpy()
            host[name] = recorder._env_slice(np.swapaxes(values, 0, 1), True) if batched else values
        frames = np.unique(np.r_[np.arange(0, steps + 1, every), steps])
        forces = None
        if with_forces:
            # step t's record holds the forces at the state t (t < T); those at the final state are computed.
            # Both in the data's representation: their linear part is f in world axes, or in link axes (Body).
            last = recorder._env_slice(_contact.collidable_point_forces(model, final).numpy(), batched)
            recorded = host["collidable_point_forces"]
            forces = np.concatenate([recorded[frames[frames < steps]], last[None]])[..., :3]
        recorder.log_trajectory(
            frames * model.time_step,
            host["base_position"][frames],
            host["base_quaternion"][frames],
            host["joint_positions"][frames],
            forces,
            force_axes="link" if VelRepr(data.velocity_representation) == VelRepr.Body else "world",
        )
    finally:
        if own:
            recorder.close()
    return final, records
