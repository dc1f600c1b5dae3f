"""Rough terrain for legged locomotion: sub-terrains of graded difficulty tiled into one heightfield, and the
game-inspired curriculum of Rudin et al. (2021) that moves environments between difficulty levels.

    gen = TerrainGenerator(TerrainConfig(levels=10, kinds=("flat", "pyramid_slope_up", "stairs_down")), seed=0)
    model.terrain = gen.terrain                  # a wd.terrain.HeightfieldTerrain
    curriculum = TerrainCurriculum(gen, num_envs=4096, seed=0)
    origins = curriculum.origins                 # (N, 3) [m]: where each environment starts, its tile's centre
    curriculum.update(done, distance, commanded_distance)   # after episodes: promote or demote those environments

The grid has `levels` rows of tiles (difficulty d = level / (levels - 1), 0 to 1) and one column per entry of
`kinds` (repeated `columns_per_kind` times), each tile `tile_size` m square, sampled every `resolution` m (a tile's
last row and column of samples are its neighbours' first; the grid's last ones are its own). Each
tile has a flat platform of `platform` m at its centre, where an environment starts. Heights in metres, world
frame; tile (level, column) covers x in [level, level + 1) tile_size and y in [column, column + 1) tile_size. The
kinds and how d sets them:
- "flat": height 0;
- "pyramid_slope_up", "pyramid_slope_down": a square pyramid whose sides rise (or fall) with slope
  d max_slope [m/m] from the tile's border to the platform;
- "random_rough": heights uniform in +-(rough_min + d (rough_max - rough_min)) [m] on a grid of `rough_cell` m,
  bilinear in between (the platform flat);
- "stairs_up", "stairs_down": square stairs of `stair_width` m steps rising (or falling) by
  stair_min + d (stair_max - stair_min) [m] each towards the platform;
- "discrete_obstacles": `obstacles` rectangles of 1 to 2 m, each raised or lowered by up to
  obstacle_min + d (obstacle_max - obstacle_min) [m], outside the platform;
- "stepping_stones": square stones of stone_size (1.05 - d) m at stone_gap (0.05 + 0.1 d) m apart, the gaps
  `pit_depth` m deep.
NumPy, on the host, once: the heightfield is then a terrain like any other (its heights a differentiable parameter
of a step, warpdyn.terrain).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..terrain import HeightfieldTerrain

__all__ = ["KINDS", "TerrainConfig", "TerrainGenerator", "TerrainCurriculum"]

KINDS = ("flat", "pyramid_slope_up", "pyramid_slope_down", "random_rough", "stairs_up", "stairs_down", "discrete_obstacles", "stepping_stones")
"""The sub-terrain kinds (the module docstring)."""


@dataclasses.dataclass(frozen=True)
class TerrainConfig:
    """The grid and each kind's parameters (the module docstring); lengths in metres."""

    levels: int = 10
    kinds: tuple = KINDS
    columns_per_kind: int = 1
    tile_size: float = 8.0
    resolution: float = 0.1
    platform: float = 3.0
    max_slope: float = 0.4
    rough_min: float = 0.01
    rough_max: float = 0.06
    rough_cell: float = 0.2
    stair_width: float = 0.31
    stair_min: float = 0.05
    stair_max: float = 0.23
    obstacles: int = 20
    obstacle_min: float = 0.05
    obstacle_max: float = 0.25
    stone_size: float = 1.5
    stone_gap: float = 0.1
    pit_depth: float = 1.0

    def __post_init__(self):
        unknown = [k for k in self.kinds if k not in KINDS]
        if unknown or not self.kinds:
            raise ValueError(f"TerrainConfig.kinds must be a non-empty tuple of {KINDS}, got {self.kinds!r}")
        for name in ("levels", "columns_per_kind", "obstacles"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < (0 if name == "obstacles" else 1):
                raise ValueError(f"TerrainConfig.{name} must be an integer >= {0 if name == 'obstacles' else 1}, got {value!r}")
        for field in dataclasses.fields(self):
            value = getattr(self, field.name)
            if field.type == "float" and not (np.isfinite(value) and value >= 0.0):
                raise ValueError(f"TerrainConfig.{field.name} must be finite and non-negative [m or m/m], got {value!r}")
        if self.resolution <= 0.0 or self.tile_size < 2 * self.resolution:
            raise ValueError(f"TerrainConfig needs resolution > 0 and tile_size >= 2 resolutions, got {self.resolution}, {self.tile_size}")
        if not self.platform < self.tile_size:
            raise ValueError(f"TerrainConfig.platform ({self.platform} m) must be smaller than tile_size ({self.tile_size} m)")


class TerrainGenerator:
    """The heightfield of a TerrainConfig, drawn from `seed` (an integer or a NumPy Generator): `terrain` (a
    HeightfieldTerrain at origin (0, 0)), `heights` (nx, ny) [m], `tile_kind` (columns,) the kind of each column,
    `difficulty(level)`, `tile_centre(level, column)` [m]."""

    def __init__(self, config: TerrainConfig = TerrainConfig(), seed=0):
        self.config = c = config
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self.samples = int(round(c.tile_size / c.resolution))  # per tile side
        self.tile_kind = tuple(kind for kind in c.kinds for _ in range(c.columns_per_kind))
        self.levels, self.columns = c.levels, len(self.tile_kind)
        n = self.samples
        heights = np.zeros((self.levels * n + 1, self.columns * n + 1))
        for level in range(self.levels):
            for column, kind in enumerate(self.tile_kind):
                heights[level * n : (level + 1) * n + 1, column * n : (column + 1) * n + 1] = self.tile(kind, self.difficulty(level), rng)
        self.heights = heights
        self.terrain = HeightfieldTerrain(heights, origin=(0.0, 0.0), spacing=(c.resolution, c.resolution))

    def difficulty(self, level: int) -> float:
        """d in [0, 1] of a level (0 with a single level)."""
        return level / (self.levels - 1) if self.levels > 1 else 0.0

    def tile_centre(self, level, column) -> np.ndarray:
        """(..., 3) [m]: the centre of tiles (level, column) on their platform, its height the terrain's there
        (a pyramid's platform is raised or lowered; integer arrays broadcast)."""
        level, column = np.broadcast_arrays(np.asarray(level, dtype=int), np.asarray(column, dtype=int))
        n = self.samples
        height = self.heights[level * n + n // 2, column * n + n // 2]
        size = self.config.tile_size
        return np.stack([(level + 0.5) * size, (column + 0.5) * size, height], axis=-1)

    def tile(self, kind: str, d: float, rng: np.random.Generator) -> np.ndarray:
        """(n + 1, n + 1) [m]: one tile's heights of `kind` at difficulty d (the module docstring), its samples at
        x, y = 0, resolution, ..., tile_size from its corner."""
        c = self.config
        s = np.arange(self.samples + 1) * c.resolution
        x, y = np.meshgrid(s, s, indexing="ij")
        half = c.tile_size / 2.0
        edge = np.maximum(np.abs(x - half), np.abs(y - half))  # the square distance from the centre
        inward = np.clip(half - edge, 0.0, half - c.platform / 2.0)  # from the border to the platform's edge
        on_platform = edge <= c.platform / 2.0
        if kind == "flat":
            return np.zeros_like(x)
        if kind in ("pyramid_slope_up", "pyramid_slope_down"):
            sign = 1.0 if kind.endswith("up") else -1.0
            return sign * d * c.max_slope * inward
        if kind in ("stairs_up", "stairs_down"):
            sign = 1.0 if kind.endswith("up") else -1.0
            step = c.stair_min + d * (c.stair_max - c.stair_min)
            return sign * step * np.floor(inward / c.stair_width)
        if kind == "random_rough":
            amplitude = c.rough_min + d * (c.rough_max - c.rough_min)
            coarse = int(np.ceil(c.tile_size / c.rough_cell)) + 1
            grid = rng.uniform(-amplitude, amplitude, (coarse, coarse))
            heights = _bilinear(grid, x / c.rough_cell, y / c.rough_cell)
            return np.where(on_platform, 0.0, heights)
        if kind == "discrete_obstacles":
            height = c.obstacle_min + d * (c.obstacle_max - c.obstacle_min)
            heights = np.zeros_like(x)
            for _ in range(c.obstacles):
                w, l = rng.uniform(1.0, 2.0, 2)
                x0, y0 = rng.uniform(0.0, c.tile_size - w), rng.uniform(0.0, c.tile_size - l)
                inside = (x >= x0) & (x <= x0 + w) & (y >= y0) & (y <= y0 + l)
                heights[inside] = rng.choice([-1.0, 1.0]) * rng.uniform(0.5, 1.0) * height
            return np.where(on_platform, 0.0, heights)
        # stepping stones: a square lattice of stones, the gaps pits
        stone = c.stone_size * (1.05 - d)
        gap = 0.05 + c.stone_gap * d
        pitch = stone + gap
        on_stone = (np.mod(x, pitch) < stone) & (np.mod(y, pitch) < stone)
        return np.where(on_platform | on_stone, 0.0, -c.pit_depth)


def _bilinear(grid: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """`grid` (a, b) read at fractional indices (u, v), bilinear."""
    i = np.minimum(np.floor(u).astype(int), grid.shape[0] - 2)
    j = np.minimum(np.floor(v).astype(int), grid.shape[1] - 2)
    a, b = u - i, v - j
    return (1 - a) * (1 - b) * grid[i, j] + a * (1 - b) * grid[i + 1, j] + (1 - a) * b * grid[i, j + 1] + a * b * grid[i + 1, j + 1]


class TerrainCurriculum:
    """Rudin et al.'s curriculum over a TerrainGenerator's tiles for `num_envs` environments: each starts at a level
    below `max_start_level` (default: a fifth of the levels, at least 1 level) drawn from `seed`, on a column dealt
    round-robin. `update(done, distance, commanded_distance)` (`done`: a boolean mask (N,) or indices of the
    environments whose episode ended; the distances every environment walked (N,) [m] and was commanded over its
    episode (N,) or one number [m], NumPy): an environment that walked farther than half a
    tile goes one level up (past the top it starts again at a random level), one that walked less than half its
    commanded distance one level down (not below 0). `levels` (N,) and `columns` (N,) int; `origins` (N, 3) [m]
    the tiles' centres; `mean_level` what a training log shows. (LeggedEnv runs the same rule on the device.)"""

    def __init__(self, generator: TerrainGenerator, num_envs: int, max_start_level: int | None = None, seed=0):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        self.generator = generator
        self.rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        top = max(1, generator.levels // 5) if max_start_level is None else int(max_start_level)
        if not 1 <= top <= generator.levels:
            raise ValueError(f"max_start_level must be in [1, {generator.levels}], got {max_start_level!r}")
        self.levels = self.rng.integers(0, top, num_envs)
        self.columns = np.arange(num_envs) % generator.columns

    @property
    def origins(self) -> np.ndarray:
        """(N, 3) [m]: each environment's tile centre, on its platform (height 0)."""
        return self.generator.tile_centre(self.levels, self.columns)

    @property
    def mean_level(self) -> float:
        return float(np.mean(self.levels))

    def update(self, done, distance, commanded_distance) -> None:
        """Promote or demote the environments `done` (the class docstring)."""
        N = len(self.levels)
        selected = np.zeros(N, dtype=bool)
        selected[np.asarray(done)] = True
        walked, commanded = (np.broadcast_to(np.asarray(a, dtype=np.float64), (N,)) for a in (distance, commanded_distance))
        up = selected & (walked > self.generator.config.tile_size / 2.0)
        down = selected & ~up & (walked < 0.5 * commanded)
        levels = self.levels + up.astype(int) - down.astype(int)
        beyond = levels >= self.generator.levels
        levels[beyond] = self.rng.integers(0, self.generator.levels, int(beyond.sum()))
        self.levels = np.maximum(levels, 0)
