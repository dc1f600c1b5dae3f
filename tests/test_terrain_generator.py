"""warpdyn.envs.terrain_generator: the tiled sub-terrains against their analytic heights, determinism under a seed,
the heightfield as a step's terrain, and the curriculum's promotion and demotion (Rudin et al. 2021)."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

import warpdyn as wd
from warpdyn.envs.terrain_generator import KINDS, TerrainConfig, TerrainCurriculum, TerrainGenerator


def _tile(gen: TerrainGenerator, level: int, kind: str) -> np.ndarray:
    """A tile's own samples (n, n): its last row and column are the next tiles' first."""
    n, column = gen.samples, gen.tile_kind.index(kind)
    return gen.heights[level * n : (level + 1) * n, column * n : (column + 1) * n]


def _edge(gen: TerrainGenerator) -> np.ndarray:
    """The square distance of each of a tile's own samples from its centre [m]."""
    c = gen.config
    s = np.arange(gen.samples) * c.resolution
    x, y = np.meshgrid(s, s, indexing="ij")
    return np.maximum(np.abs(x - c.tile_size / 2), np.abs(y - c.tile_size / 2))


def test_grid_shape_and_difficulties():
    config = TerrainConfig(levels=5, kinds=("flat", "stairs_up"), columns_per_kind=2, tile_size=4.0, resolution=0.1, platform=1.0)
    gen = TerrainGenerator(config, seed=0)
    assert gen.heights.shape == (5 * 40 + 1, 4 * 40 + 1)
    assert gen.tile_kind == ("flat", "flat", "stairs_up", "stairs_up")
    assert [gen.difficulty(k) for k in range(5)] == [0.0, 0.25, 0.5, 0.75, 1.0]
    # the centre of tile (2, 3), stairs at d = 0.5: on the platform, floor(1.5 / 0.31) = 4 steps of 0.14 m up
    np.testing.assert_allclose(gen.tile_centre(2, 3), [10.0, 14.0, 4 * 0.14])
    np.testing.assert_allclose(gen.tile_centre(2, 1), [10.0, 6.0, 0.0])
    assert isinstance(gen.terrain, wd.terrain.HeightfieldTerrain) and gen.terrain.spacing == (0.1, 0.1)
    np.testing.assert_array_equal(_tile(gen, 4, "flat"), 0.0)


def test_slopes_and_stairs_have_their_analytic_heights():
    """A pyramid rises with slope d max_slope from the border to the platform; stairs by whole steps of
    stair_min + d (stair_max - stair_min) every stair_width; both flat on the platform, 0 at the border."""
    c = TerrainConfig(levels=3, kinds=("pyramid_slope_up", "pyramid_slope_down", "stairs_up", "stairs_down"), tile_size=8.0, platform=3.0)
    gen = TerrainGenerator(c, seed=0)
    edge = _edge(gen)
    inward = np.clip(4.0 - edge, 0.0, 4.0 - 1.5)
    for level, d in ((1, 0.5), (2, 1.0)):
        np.testing.assert_allclose(_tile(gen, level, "pyramid_slope_up"), d * 0.4 * inward, atol=1e-12)
        np.testing.assert_allclose(_tile(gen, level, "pyramid_slope_down"), -d * 0.4 * inward, atol=1e-12)
        step = 0.05 + d * 0.18
        up = _tile(gen, level, "stairs_up")
        np.testing.assert_allclose(up, step * np.floor(inward / 0.31), atol=1e-12)
        np.testing.assert_allclose(np.unique(np.round(up / step, 9)), np.arange(9))  # 2.5 m of 0.31 m steps: 0 to 8
        np.testing.assert_allclose(_tile(gen, level, "stairs_down"), -up, atol=1e-12)
    assert np.ptp(_tile(gen, 2, "pyramid_slope_up")[edge <= 1.5]) == 0.0
    np.testing.assert_array_equal(_tile(gen, 0, "pyramid_slope_up"), 0.0)  # d = 0: flat


def test_rough_obstacles_and_stones_stay_in_their_bounds():
    c = TerrainConfig(levels=3, kinds=("random_rough", "discrete_obstacles", "stepping_stones"), tile_size=8.0, platform=3.0)
    gen = TerrainGenerator(c, seed=3)
    edge = _edge(gen)
    for level, d in enumerate((0.0, 0.5, 1.0)):
        rough = _tile(gen, level, "random_rough")
        amplitude = 0.01 + d * 0.05
        assert np.abs(rough).max() <= amplitude + 1e-12 and np.abs(rough).max() > 0.5 * amplitude
        np.testing.assert_array_equal(rough[edge <= 1.5], 0.0)
        obstacles = _tile(gen, level, "discrete_obstacles")
        assert np.abs(obstacles).max() <= 0.05 + d * 0.2 + 1e-12
        np.testing.assert_array_equal(obstacles[edge <= 1.5], 0.0)
        stones = _tile(gen, level, "stepping_stones")
        assert set(np.unique(stones)) <= {0.0, -1.0} and (stones == -1.0).any()
        np.testing.assert_array_equal(stones[edge <= 1.5], 0.0)
    # harder stones are smaller with wider gaps: more of the tile is pit
    assert (_tile(gen, 2, "stepping_stones") < 0).mean() > (_tile(gen, 0, "stepping_stones") < 0).mean()


def test_a_seed_draws_the_same_terrain():
    a, b, c = (TerrainGenerator(TerrainConfig(levels=3), seed=s).heights for s in (7, 7, 8))
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


def test_the_heightfield_is_a_steps_terrain():
    """The box's corners rest on a stairs tile's platform and on its steps: the terrain's heights under them are the
    generator's, and a step from there stays healthy."""
    gen = TerrainGenerator(TerrainConfig(levels=2, kinds=("stairs_up",), tile_size=4.0, platform=1.0), seed=0)
    for x, y in ((6.0, 2.0), (4.5, 2.0), (5.2, 0.9)):
        i, j = round(x / 0.1), round(y / 0.1)
        np.testing.assert_allclose(gen.terrain.height(x, y), gen.heights[i, j], atol=1e-12)
    model = wd.model.JaxSimModel.build_from_model_description(pathlib.Path(__file__).parent / "jaxsim" / "box.sdf")
    model.terrain = gen.terrain
    centre = gen.tile_centre(1, 0)
    data = wd.data.JaxSimModelData.build(model=model, base_position=centre + np.array([0.0, 0.0, 0.1 + gen.heights[60, 20]]))
    data = wd.model.step(model, data)
    assert bool(data.healthy.numpy().all())


def test_curriculum_promotes_demotes_and_wraps():
    gen = TerrainGenerator(TerrainConfig(levels=4, kinds=("flat", "stairs_up"), tile_size=8.0), seed=0)
    cur = TerrainCurriculum(gen, num_envs=6, max_start_level=1, seed=0)
    np.testing.assert_array_equal(cur.levels, 0)
    np.testing.assert_array_equal(cur.columns, [0, 1, 0, 1, 0, 1])
    np.testing.assert_allclose(cur.origins[:2], [[4.0, 4.0, 0.0], [4.0, 12.0, 8 * 0.05]])  # level 0's stairs: 8 steps of 5 cm
    # env 0 walked past half a tile: up; env 1 less than half its command: stays at 0 (the floor); env 2 in between;
    # env 3 not done
    cur.update(np.array([True, True, True, False, False, False]), [5.0, 1.0, 3.0, 9.0, 0.0, 0.0], 4.0)
    np.testing.assert_array_equal(cur.levels, [1, 0, 0, 0, 0, 0])
    cur.levels = np.array([3, 2, 2, 0, 0, 0])
    cur.update([0, 1], [5.0, 0.5, 0.0, 0.0, 0.0, 0.0], 4.0)
    assert 0 <= cur.levels[0] < 4  # past the top: a random level
    assert cur.levels[1] == 1 and cur.mean_level >= 0.0
    with pytest.raises(ValueError, match="max_start_level must be in \\[1, 4\\]"):
        TerrainCurriculum(gen, num_envs=2, max_start_level=5)


def test_bad_configurations_are_named():
    with pytest.raises(ValueError, match="kinds must be a non-empty tuple"):
        TerrainConfig(kinds=("lava",))
    with pytest.raises(ValueError, match="TerrainConfig.max_slope must be finite and non-negative"):
        TerrainConfig(max_slope=-0.1)
    with pytest.raises(ValueError, match="platform .* must be smaller than tile_size"):
        TerrainConfig(platform=8.0)
    with pytest.raises(ValueError, match="TerrainConfig.levels must be an integer >= 1"):
        TerrainConfig(levels=0)
    assert set(KINDS) == set(TerrainConfig().kinds)
