"""Terrains the collidable points touch: flat, an inclined plane, and a heightfield grid.

Conventions (as JaxSim's terrain): the terrain is the graph z = h(x, y) of the world's (x, y); its unit
normal n(x, y) points out of the ground. A point p penetrates by delta = max(0, (h(p_x, p_y) - p_z) n_z),
the distance to the plane tangent at (p_x, p_y) (exact for flat and plane terrains).

- `FlatTerrain(height)`: h = height, n = (0, 0, 1); one height for all environments, or one per
  environment (N,).
- `PlaneTerrain(normal, point)`: the plane through `point` with `normal` (n_z > 0, normalised here).
- `HeightfieldTerrain(heights, origin, spacing)`: heights[i, j] at (origin_x + i dx, origin_y + j dy),
  bilinear in between, n from the gradient of that bilinear height; outside the grid, the nearest edge
  value (clamped).

Differentiable terrain: FlatTerrain.height and HeightfieldTerrain.heights may be Warp arrays in the model's
dtype and device ((1,) or (N,), and (nx, ny)), which the contact kernels read in place, so that with
requires_grad their .grad receives tape gradients (`warpdyn.model.parameters_requiring_grad(model,
("terrain_height",))` makes them). Host-side methods (`height_at`, `normal_at`) copy them to the host.

Checks: every value is checked when a terrain is made (finite heights, origin and spacing, positive
spacing; a Warp array is copied to the host once for that). Values written into a Warp array afterwards
(`terrain.heights.assign(...)`, a kernel's output) are read by the next step as they are, unchecked: a check
there would synchronise the host at every step. A NaN height at a corner of the cell under a collidable
point gives it a NaN contact force (kernels/soft_contacts.py), so `step` flags its environment (Data.valid) and keeps its state;
an infinite one gives an infinite or NaN force, flagged likewise. A finite but wrong height is not detected.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from .settings import host_values

__all__ = ["FlatTerrain", "PlaneTerrain", "HeightfieldTerrain"]

FLAT, PLANE, HEIGHTFIELD = 0, 1, 2




@dataclasses.dataclass(frozen=True, eq=False)
class FlatTerrain:
    """The plane z = height [m]: a number, or one height per environment (N,) (NumPy or Warp array)."""

    height: float | np.ndarray | wp.array = 0.0

    kind = FLAT

    def __post_init__(self):
        h = host_values(self.height, "FlatTerrain.height")
        if h.ndim > 1 or h.size == 0 or not np.all(np.isfinite(h)):
            raise ValueError(f"FlatTerrain.height must be a finite number or (N,) array, got {self.height!r}")

    def height_of(self, env: int = 0) -> float:
        """The height [m] in environment env (the only one when it is shared)."""
        h = np.atleast_1d(host_values(self.height))
        if not 0 <= env < h.size and h.size > 1:
            raise IndexError(f"FlatTerrain has {h.size} heights, no environment {env}")
        return float(h[env if h.size > 1 else 0])

    def height_at(self, x, y, env: int = 0) -> np.ndarray:
        return np.full(np.broadcast(np.asarray(x), np.asarray(y)).shape, self.height_of(env))

    def for_env(self, env: int) -> FlatTerrain:
        """The terrain of environment env alone (its height a number)."""
        return self if np.ndim(self.height) == 0 else FlatTerrain(height=self.height_of(env))

    def normal_at(self, x, y) -> np.ndarray:
        shape = np.broadcast(np.asarray(x), np.asarray(y)).shape
        return np.broadcast_to(np.array([0.0, 0.0, 1.0]), (*shape, 3)).copy()

    def plane(self) -> tuple[np.ndarray, float]:
        """(unit normal, height at the origin) of environment 0."""
        return np.array([0.0, 0.0, 1.0]), self.height_of(0)


@dataclasses.dataclass(frozen=True)
class PlaneTerrain:
    """The plane through `point` (3,) [m] with `normal` (3,) (pointing up: n_z > 0)."""

    normal: tuple = (0.0, 0.0, 1.0)
    point: tuple = (0.0, 0.0, 0.0)

    kind = PLANE

    def __post_init__(self):
        n = np.asarray(self.normal, dtype=np.float64)
        p = np.asarray(self.point, dtype=np.float64)
        if n.shape != (3,) or p.shape != (3,) or not (np.all(np.isfinite(n)) and np.all(np.isfinite(p))):
            raise ValueError(f"PlaneTerrain needs a finite normal (3,) and point (3,), got {self.normal!r}, {self.point!r}")
        norm = np.linalg.norm(n)
        if norm < 1e-12 or n[2] / norm < 1e-6:
            raise ValueError(f"PlaneTerrain normal {n.tolist()} must point up (positive z component)")
        object.__setattr__(self, "normal", tuple(n / norm))
        object.__setattr__(self, "point", tuple(p))

    def plane(self) -> tuple[np.ndarray, float]:
        n = np.asarray(self.normal)
        p = np.asarray(self.point)
        return n, float(p[2] + (n[0] * p[0] + n[1] * p[1]) / n[2])

    def height_at(self, x, y) -> np.ndarray:
        n, h0 = self.plane()
        return h0 - (n[0] * np.asarray(x) + n[1] * np.asarray(y)) / n[2]

    def normal_at(self, x, y) -> np.ndarray:
        shape = np.broadcast(np.asarray(x), np.asarray(y)).shape
        return np.broadcast_to(np.asarray(self.normal), (*shape, 3)).copy()

    def for_env(self, env: int) -> PlaneTerrain:
        """The terrain of environment env: this one (a plane is shared by all)."""
        return self


def _pair(name: str, value) -> tuple[float, float]:
    """Two finite numbers [m], or an error naming HeightfieldTerrain.{name}."""
    host = host_values(value, f"HeightfieldTerrain.{name}")
    if host.shape != (2,):
        raise ValueError(f"HeightfieldTerrain.{name} must be two numbers (x, y) [m], got {value!r}")
    if not np.all(np.isfinite(host)):
        raise ValueError(f"HeightfieldTerrain.{name} must be two finite numbers [m], got {value!r}")
    return float(host[0]), float(host[1])


@dataclasses.dataclass(frozen=True, eq=False)
class HeightfieldTerrain:
    """A grid of heights (nx, ny) [m], heights[i, j] at origin + (i dx, j dy), bilinear in between."""

    heights: np.ndarray | wp.array
    origin: tuple = (0.0, 0.0)
    spacing: tuple = (0.1, 0.1)

    kind = HEIGHTFIELD

    def __post_init__(self):
        h = host_values(self.heights, "HeightfieldTerrain.heights")
        if h.ndim != 2 or h.shape[0] < 2 or h.shape[1] < 2:
            raise ValueError(f"HeightfieldTerrain.heights must be a (nx >= 2, ny >= 2) grid, got shape {h.shape}")
        bad = np.argwhere(~np.isfinite(h))
        if bad.size:
            raise ValueError(f"HeightfieldTerrain.heights has non-finite values, first at {tuple(bad[0].tolist())}: {h[tuple(bad[0])]}")
        spacing = _pair("spacing", self.spacing)
        if min(spacing) <= 0.0:
            raise ValueError(f"HeightfieldTerrain.spacing must be two finite positive numbers [m], got {self.spacing!r}")
        origin = _pair("origin", self.origin)
        if not isinstance(self.heights, wp.array):
            object.__setattr__(self, "heights", h)
        object.__setattr__(self, "origin", origin)
        object.__setattr__(self, "spacing", spacing)

    def _cell(self, x, y):
        nx, ny = self.heights.shape
        u = np.clip((np.asarray(x, dtype=np.float64) - self.origin[0]) / self.spacing[0], 0.0, nx - 1.0)
        v = np.clip((np.asarray(y, dtype=np.float64) - self.origin[1]) / self.spacing[1], 0.0, ny - 1.0)
        i = np.minimum(np.floor(u).astype(int), nx - 2)
        j = np.minimum(np.floor(v).astype(int), ny - 2)
        return i, j, u - i, v - j

    def height_at(self, x, y) -> np.ndarray:
        i, j, a, b = self._cell(x, y)
        h = host_values(self.heights)
        return (1 - a) * (1 - b) * h[i, j] + a * (1 - b) * h[i + 1, j] + (1 - a) * b * h[i, j + 1] + a * b * h[i + 1, j + 1]

    def normal_at(self, x, y) -> np.ndarray:
        i, j, a, b = self._cell(x, y)
        h = host_values(self.heights)
        dhdx = ((1 - b) * (h[i + 1, j] - h[i, j]) + b * (h[i + 1, j + 1] - h[i, j + 1])) / self.spacing[0]
        dhdy = ((1 - a) * (h[i, j + 1] - h[i, j]) + a * (h[i + 1, j + 1] - h[i + 1, j])) / self.spacing[1]
        n = np.stack([-dhdx, -dhdy, np.ones_like(dhdx)], axis=-1)
        return n / np.linalg.norm(n, axis=-1, keepdims=True)

    def for_env(self, env: int) -> HeightfieldTerrain:
        """The terrain of environment env: this one (the grid is shared by all)."""
        return self
