"""JaxSim's `jaxsim.terrain`: the terrains the collidable points touch, flat, an inclined plane, and a
heightfield grid (warpdyn.types.terrain holds them and their conventions); and warpdyn's height scan of a terrain
around each environment's base (`height_scan`, `grid_pattern`), what rough-terrain policies observe."""

from __future__ import annotations

import numpy as np
import warp as wp

from . import arrays
from .engine import sensors
from .types.terrain import FlatTerrain, HeightfieldTerrain, PlaneTerrain, Terrain

__all__ = ["Terrain", "FlatTerrain", "PlaneTerrain", "HeightfieldTerrain", "grid_pattern", "height_scan"]


def grid_pattern(size=(1.6, 1.0), resolution: float = 0.1) -> np.ndarray:
    """(P, 2) [m]: a grid of points `size` (length along x, width along y) [m] centred on the base, every
    `resolution` m, x varying slowest (the default: Isaac Lab's 1.6 m x 1.0 m at 0.1 m, 17 x 11 = 187 points)."""
    length, width = (float(v) for v in np.broadcast_to(np.asarray(size, dtype=np.float64), (2,)))
    step = float(resolution)
    if not (np.isfinite(length) and np.isfinite(width) and length >= 0.0 and width >= 0.0 and np.isfinite(step) and step > 0.0):
        raise ValueError(f"grid_pattern needs a finite non-negative size and a positive resolution [m], got size {size!r}, resolution {resolution!r}")
    xs = np.arange(int(np.floor(length / step + 1e-9)) + 1) * step - length / 2.0
    ys = np.arange(int(np.floor(width / step + 1e-9)) + 1) * step - width / 2.0
    return np.stack(np.meshgrid(xs, ys, indexing="ij"), axis=-1).reshape(-1, 2)


def height_scan(model, data, pattern, *, out: wp.array | None = None) -> wp.array:
    """The terrain's height [m] under each point of `pattern` (P, 2) [m, in the base's yaw frame: x forward, y left,
    its heading only] around the base: (P,) or (N, P). A vertical ray cast down onto `model.terrain`, a height
    function, hits it at its height there. What a policy observes is usually the base's height above these (Isaac
    Lab's height scan): `data.base_position[..., 2:3] - height_scan(...)`. pattern: NumPy, or a Warp array (P, 2)
    of the model's dtype on its device (read in place); out: a Warp array (N, P) of the model's dtype on its device
    to write into (and return, with the leading axis), for scans inside a captured graph (nothing allocated)."""
    if isinstance(pattern, wp.array):
        arrays.check_device_array(pattern, "pattern", model.scalar, model.device)
        if pattern.ndim != 2 or pattern.shape[1] != 2:
            raise ValueError(f"pattern must be points (P, 2) [m], got shape {pattern.shape}")
        points = pattern
    else:
        host = arrays.host_numbers(pattern, "pattern")
        if host.ndim != 2 or host.shape[1] != 2 or not np.all(np.isfinite(host)):
            raise ValueError(f"pattern must be finite points (P, 2) [m], got shape {host.shape}")
        points = wp.array(host, dtype=model.scalar, device=model.device)
    if out is not None:
        arrays.check_device_array(out, "out", model.scalar, model.device)
        if tuple(out.shape) != (data.batch_size, points.shape[0]):
            raise ValueError(f"out must have shape {(data.batch_size, points.shape[0])} (environments, points), got {tuple(out.shape)}")
        sensors.height_scan(model, data, points, out)
        return out
    return arrays.squeeze_env(sensors.height_scan(model, data, points), data.num_envs)
