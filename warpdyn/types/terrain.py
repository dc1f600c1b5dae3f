"""Terrains the collidable points touch: flat, an inclined plane, and a heightfield grid, with JaxSim's
interface (`Terrain`: `height(x, y)`, `normal(x, y)`; `FlatTerrain.build(height)`, `PlaneTerrain.build(height,
normal=...)`; equality and hashing by value).

Conventions (as JaxSim's terrain): the terrain is the graph z = h(x, y) of the world's (x, y); its unit
normal n(x, y) points out of the ground. A point p penetrates by delta = max(0, (h(p_x, p_y) - p_z) n_z),
the distance to the plane tangent at (p_x, p_y) (exact for flat and plane terrains).

- `FlatTerrain(height)`: h = height, n = (0, 0, 1); one height for all environments, or one per
  environment (N,) (`elevation` holds it; `height(x, y)` is JaxSim's method).
- `PlaneTerrain(normal, point)`: the plane through `point` with `normal` (n_z > 0, normalised here;
  `unit_normal` holds it, `normal(x, y)` is JaxSim's method); `PlaneTerrain.build(height, normal=n)`: the
  plane through (0, 0, height), as JaxSim's.
- `HeightfieldTerrain(heights, origin, spacing)`: heights[i, j] at (origin_x + i dx, origin_y + j dy),
  bilinear in between, n from the gradient of that bilinear height; outside the grid, the nearest edge
  value (clamped).
The host-side methods take x and y of any (broadcast) shape and return NumPy arrays of it ((..., 3) normals);
a per-environment height is read for environment `env` (default 0).

Differentiable terrain: FlatTerrain's height and HeightfieldTerrain.heights may be Warp arrays in the model's
dtype and device ((1,) or (N,), and (nx, ny)), which the contact kernels read in place, so that with
requires_grad their .grad receives tape gradients (`warpdyn.model.parameters_requiring_grad(model,
("terrain_height",))` makes them). The host-side methods copy them to the host.

Checks: every value is checked when a terrain is made (finite heights, origin and spacing, positive
spacing; a Warp array is copied to the host once for that). Values written into a Warp array afterwards
(`terrain.heights.assign(...)`, a kernel's output) are read by the next step as they are, unchecked: a check
there would synchronise the host at every step. A NaN height at a corner of the cell under a collidable
point gives it a NaN contact force (kernels/soft_contacts.py), so `step` flags its environment (Data.healthy) and keeps its state;
an infinite one gives an infinite or NaN force, flagged likewise. A finite but wrong height is not detected.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .settings import host_values

__all__ = ["Terrain", "FlatTerrain", "PlaneTerrain", "HeightfieldTerrain"]

FLAT, PLANE, HEIGHTFIELD = 0, 1, 2


def _shape(x, y) -> tuple:
    return np.broadcast(np.asarray(x), np.asarray(y)).shape


def _same(a, b) -> bool:
    """Whether two parameter values are equal: the same Warp array (edited in place, it is one value), or
    equal numbers / NumPy arrays."""
    if isinstance(a, wp.array) or isinstance(b, wp.array):
        return a is b
    return np.array_equal(np.asarray(a), np.asarray(b))


def _key(value):
    """A hashable key of a parameter value: a Warp array's identity, a NumPy array's bytes, a number."""
    if isinstance(value, wp.array):
        return ("array", id(value))
    host = np.asarray(value, dtype=np.float64)
    return (host.shape, host.tobytes())


def _frozen(host: np.ndarray) -> np.ndarray:
    """A read-only float64 copy of host values (a terrain keeps its own: editing the caller's array changes
    nothing). A Warp array, a differentiable parameter the step reads in place, is kept as it is."""
    copy = np.array(host, dtype=np.float64)
    copy.setflags(write=False)
    return copy


class Terrain:
    """JaxSim's base class of terrains: `height(x, y)` [m] and `normal(x, y)`, the unit normal by central
    differences of the height with step `delta` [m] (the subclasses give theirs exactly). Terrains are
    immutable (a model reads its terrain when its step's plan is built: assign a new one to `model.terrain`)."""

    delta = 0.010
    kind = -1

    def __setattr__(self, name, value):
        raise AttributeError(f"{type(self).__name__} is immutable: make a new one and assign it to model.terrain")

    def _set(self, **values) -> None:
        for name, value in values.items():
            object.__setattr__(self, name, value)

    def height(self, x, y, env: int = 0) -> np.ndarray:
        raise NotImplementedError(f"{type(self).__name__} does not say its height")

    def normal(self, x, y, env: int = 0) -> np.ndarray:
        d = self.delta
        dhdx = (self.height(np.asarray(x) + d, y, env) - self.height(np.asarray(x) - d, y, env)) / (2 * d)
        dhdy = (self.height(x, np.asarray(y) + d, env) - self.height(x, np.asarray(y) - d, env)) / (2 * d)
        n = np.stack([-dhdx, -dhdy, np.ones_like(dhdx)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def for_env(self, env: int) -> Terrain:
        """The terrain of environment env: this one (shared by all) unless it has per-environment values."""
        return self

    def environments(self) -> int:
        """How many environments' values the terrain holds: 1 when it is shared."""
        return 1

    def height_under(self, points) -> np.ndarray:
        """h(x, y) (...) [m] under points (..., 3). A terrain of N per-environment values reads environment e's
        under points[e] (the points need a leading axis of N). Host NumPy."""
        P = np.asarray(points, dtype=np.float64)
        count = self.environments()
        if count == 1:
            return self.height(P[..., 0], P[..., 1])
        if P.ndim < 2 or P.shape[0] != count:
            raise ValueError(f"the terrain has {count} heights (one per environment): the points need shape ({count}, ..., 3), got {P.shape}")
        return np.stack([self.height(P[e, ..., 0], P[e, ..., 1], env=e) for e in range(count)])

    def penetration(self, points) -> np.ndarray:
        """delta = (h(x, y) - z) n_z(x, y) of points (..., 3) [m] (h: `height_under`): the depth the soft contacts
        use where it is positive (below the terrain), zero on it, negative above. Host NumPy."""
        P = np.asarray(points, dtype=np.float64)
        return (self.height_under(P) - P[..., 2]) * self.normal(P[..., 0], P[..., 1])[..., 2]


class FlatTerrain(Terrain):
    """The plane z = height [m]: a number, or one height per environment (N,) (a sequence or NumPy array, kept
    as a read-only copy, or a Warp array, kept as it is: a parameter the step reads in place), as `elevation`."""

    kind = FLAT

    def __init__(self, height=0.0):
        h = host_values(height, "FlatTerrain.height")
        if h.ndim > 1 or h.size == 0 or not np.all(np.isfinite(h)):
            raise ValueError(f"FlatTerrain.height must be a finite number or (N,) array, got {height!r}")
        self._set(elevation=height if isinstance(height, wp.array) else float(h) if h.ndim == 0 else _frozen(h))

    @staticmethod
    def build(height=0.0) -> FlatTerrain:
        """JaxSim's constructor: the plane z = height [m]."""
        return FlatTerrain(height)

    def __repr__(self) -> str:
        return f"FlatTerrain(height={self.elevation!r})"

    def __eq__(self, other) -> bool:
        return type(other) is FlatTerrain and _same(self.elevation, other.elevation)

    def __hash__(self) -> int:
        return hash(("FlatTerrain", _key(self.elevation)))

    def height_of(self, env: int = 0) -> float:
        """The height [m] in environment env (the only one when it is shared)."""
        h = np.atleast_1d(host_values(self.elevation))
        if not 0 <= env < h.size and h.size > 1:
            raise IndexError(f"FlatTerrain has {h.size} heights, no environment {env}")
        return float(h[env if h.size > 1 else 0])

    def height(self, x, y, env: int = 0) -> np.ndarray:
        return np.full(_shape(x, y), self.height_of(env))

    def normal(self, x=0.0, y=0.0, env: int = 0) -> np.ndarray:
        return np.broadcast_to(np.array([0.0, 0.0, 1.0]), (*_shape(x, y), 3)).copy()

    def for_env(self, env: int) -> FlatTerrain:
        """The terrain of environment env alone (its height a number)."""
        return self if np.ndim(self.elevation) == 0 else FlatTerrain(self.height_of(env))

    def environments(self) -> int:
        return int(np.atleast_1d(host_values(self.elevation)).size)

    def plane(self) -> tuple[np.ndarray, float]:
        """(unit normal, height at the origin) of environment 0."""
        return np.array([0.0, 0.0, 1.0]), self.height_of(0)


class PlaneTerrain(Terrain):
    """The plane through `point` (3,) [m] with `normal` (3,) (pointing up: n_z > 0), kept as `unit_normal`."""

    kind = PLANE

    def __init__(self, normal=(0.0, 0.0, 1.0), point=(0.0, 0.0, 0.0)):
        n = host_values(normal, "PlaneTerrain.normal")
        p = host_values(point, "PlaneTerrain.point")
        if n.shape != (3,) or p.shape != (3,) or not (np.all(np.isfinite(n)) and np.all(np.isfinite(p))):
            raise ValueError(f"PlaneTerrain needs a finite normal (3,) and point (3,), got {normal!r}, {point!r}")
        norm = np.linalg.norm(n)
        if norm < 1e-12 or n[2] / norm < 1e-6:
            raise ValueError(f"PlaneTerrain normal {n.tolist()} must point up (positive z component)")
        self._set(unit_normal=tuple(float(v) for v in n / norm), point=tuple(float(v) for v in p))

    @staticmethod
    def build(height=0.0, *, normal) -> PlaneTerrain:
        """JaxSim's constructor: the plane through (0, 0, height) [m] with `normal` (3,)."""
        return PlaneTerrain(normal=normal, point=(0.0, 0.0, float(host_values(height, "PlaneTerrain height"))))

    def __repr__(self) -> str:
        return f"PlaneTerrain(normal={self.unit_normal}, point={self.point})"

    def __eq__(self, other) -> bool:
        return type(other) is PlaneTerrain and self.plane_key() == other.plane_key()

    def __hash__(self) -> int:
        return hash(("PlaneTerrain", self.plane_key()))

    def plane_key(self) -> tuple:
        """(unit normal, height at the origin): what makes two descriptions the same plane."""
        n, h0 = self.plane()
        return tuple(n.tolist()), h0

    def plane(self) -> tuple[np.ndarray, float]:
        n = np.asarray(self.unit_normal)
        p = np.asarray(self.point)
        return n, float(p[2] + (n[0] * p[0] + n[1] * p[1]) / n[2])

    def height(self, x, y, env: int = 0) -> np.ndarray:
        n, h0 = self.plane()
        return np.broadcast_to(h0 - (n[0] * np.asarray(x) + n[1] * np.asarray(y)) / n[2], _shape(x, y)).copy()

    def normal(self, x=0.0, y=0.0, env: int = 0) -> np.ndarray:
        return np.broadcast_to(np.asarray(self.unit_normal), (*_shape(x, y), 3)).copy()


def _pair(name: str, value) -> tuple[float, float]:
    """Two finite numbers [m], or an error naming HeightfieldTerrain.{name}."""
    host = host_values(value, f"HeightfieldTerrain.{name}")
    if host.shape != (2,):
        raise ValueError(f"HeightfieldTerrain.{name} must be two numbers (x, y) [m], got {value!r}")
    if not np.all(np.isfinite(host)):
        raise ValueError(f"HeightfieldTerrain.{name} must be two finite numbers [m], got {value!r}")
    return float(host[0]), float(host[1])


class HeightfieldTerrain(Terrain):
    """A grid of heights (nx, ny) [m], heights[i, j] at origin + (i dx, j dy), bilinear in between."""

    kind = HEIGHTFIELD

    def __init__(self, heights, origin=(0.0, 0.0), spacing=(0.1, 0.1)):
        h = host_values(heights, "HeightfieldTerrain.heights")
        if h.ndim != 2 or h.shape[0] < 2 or h.shape[1] < 2:
            raise ValueError(f"HeightfieldTerrain.heights must be a (nx >= 2, ny >= 2) grid, got shape {h.shape}")
        bad = np.argwhere(~np.isfinite(h))
        if bad.size:
            raise ValueError(f"HeightfieldTerrain.heights has non-finite values, first at {tuple(bad[0].tolist())}: {h[tuple(bad[0])]}")
        if min(_pair("spacing", spacing)) <= 0.0:
            raise ValueError(f"HeightfieldTerrain.spacing must be two finite positive numbers [m], got {spacing!r}")
        self._set(spacing=_pair("spacing", spacing), origin=_pair("origin", origin), heights=heights if isinstance(heights, wp.array) else _frozen(h))

    def __repr__(self) -> str:
        return f"HeightfieldTerrain(heights=<{tuple(self.heights.shape)} grid>, origin={self.origin}, spacing={self.spacing})"

    def __eq__(self, other) -> bool:
        return type(other) is HeightfieldTerrain and (self.origin, self.spacing) == (other.origin, other.spacing) and _same(self.heights, other.heights)

    def __hash__(self) -> int:
        return hash(("HeightfieldTerrain", self.origin, self.spacing, _key(self.heights)))

    def _cell(self, x, y):
        nx, ny = self.heights.shape
        u = np.clip((np.asarray(x, dtype=np.float64) - self.origin[0]) / self.spacing[0], 0.0, nx - 1.0)
        v = np.clip((np.asarray(y, dtype=np.float64) - self.origin[1]) / self.spacing[1], 0.0, ny - 1.0)
        i = np.minimum(np.floor(u).astype(int), nx - 2)
        j = np.minimum(np.floor(v).astype(int), ny - 2)
        return i, j, u - i, v - j

    def height(self, x, y, env: int = 0) -> np.ndarray:
        i, j, a, b = self._cell(x, y)
        h = host_values(self.heights)
        return (1 - a) * (1 - b) * h[i, j] + a * (1 - b) * h[i + 1, j] + (1 - a) * b * h[i, j + 1] + a * b * h[i + 1, j + 1]

    def normal(self, x, y, env: int = 0) -> np.ndarray:
        i, j, a, b = self._cell(x, y)
        h = host_values(self.heights)
        dhdx = ((1 - b) * (h[i + 1, j] - h[i, j]) + b * (h[i + 1, j + 1] - h[i, j + 1])) / self.spacing[0]
        dhdy = ((1 - a) * (h[i, j + 1] - h[i, j]) + a * (h[i + 1, j + 1] - h[i + 1, j])) / self.spacing[1]
        n = np.stack([-dhdx, -dhdy, np.ones_like(dhdx)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)


def terrain_of_ground(ground) -> Terrain:
    """A model's terrain from its description's ground (ModelDescription.ground: (unit normal, point) [world, m] or
    None): FlatTerrain at the point's height where the normal is +z, else the PlaneTerrain through the point;
    FlatTerrain(0) without a ground."""
    if ground is None:
        return FlatTerrain()
    normal, point = ground
    if np.allclose(normal, (0.0, 0.0, 1.0), rtol=0.0, atol=1e-12):
        return FlatTerrain(float(point[2]))
    return PlaneTerrain(normal, point)

