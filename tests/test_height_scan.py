"""wd.terrain.height_scan and grid_pattern (kernels/height_scan.py): the terrain's height under a pattern of points
in each base's yaw frame, against the terrains' analytic heights; its gradient against finite differences."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest
import warp as wp

import warpdyn as wd
from warpdyn.envs.terrain_generator import TerrainConfig, TerrainGenerator

BOX = pathlib.Path(__file__).parent / "jaxsim" / "box.sdf"


def _box(terrain):
    model = wd.model.JaxSimModel.build_from_model_description(BOX, dtype=wp.float64)
    model.terrain = terrain
    return model


def _yaw_roll(yaw: float, roll: float) -> np.ndarray:
    """(w, x, y, z) of R_z(yaw) R_x(roll)."""
    qz = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
    qx = np.array([np.cos(roll / 2), np.sin(roll / 2), 0.0, 0.0])
    w1, x1, y1, z1 = qz
    w2, x2, y2, z2 = qx
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def test_grid_pattern():
    p = wd.terrain.grid_pattern()
    assert p.shape == (187, 2)
    np.testing.assert_allclose(p.mean(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(p[0], [-0.8, -0.5])
    np.testing.assert_allclose(p[1], [-0.8, -0.4])  # y varies fastest
    np.testing.assert_allclose(p[-1], [0.8, 0.5])
    assert wd.terrain.grid_pattern((0.0, 0.0)).shape == (1, 2)
    with pytest.raises(ValueError, match="positive resolution"):
        wd.terrain.grid_pattern(resolution=0.0)


def test_flat_terrain_per_environment():
    model = _box(wd.terrain.FlatTerrain(np.array([0.1, -0.2])))
    data = wd.data.JaxSimModelData.build(model=model, num_envs=2, base_position=np.array([[0.0, 0.0, 1.0], [5.0, 1.0, 1.0]]))
    h = wd.terrain.height_scan(model, data, wd.terrain.grid_pattern((0.4, 0.2)))
    assert h.shape == (2, 15)
    np.testing.assert_array_equal(h.numpy(), np.array([[0.1], [-0.2]]) * np.ones((2, 15)))


def test_plane_in_the_yaw_frame():
    """On an inclined plane the scan equals the plane's height at base + R_z(yaw) pattern; roll does not turn the
    pattern (the yaw frame)."""
    plane = wd.terrain.PlaneTerrain(normal=(0.2, -0.1, 1.0), point=(0.0, 0.0, 0.05))
    model = _box(plane)
    pattern = np.array([[1.0, 0.0], [0.0, 1.0], [-0.3, 0.7]])
    base = np.array([1.0, -2.0, 3.0])
    for yaw, roll in ((0.0, 0.0), (np.pi / 2, 0.0), (0.7, 0.5)):
        data = wd.data.JaxSimModelData.build(model=model, base_position=base, base_quaternion=_yaw_roll(yaw, roll))
        R = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
        points = base[:2] + pattern @ R.T
        np.testing.assert_allclose(wd.terrain.height_scan(model, data, pattern).numpy(), plane.height(points[:, 0], points[:, 1]), atol=1e-12)


def test_generated_heightfield_and_its_gradient():
    """On a generated pyramid-slope tile the scan reads the slope's heights, and its gradient with respect to the
    base position is the slope's (finite differences)."""
    gen = TerrainGenerator(TerrainConfig(levels=2, kinds=("pyramid_slope_up",), tile_size=8.0, platform=2.0), seed=0)
    model = _box(gen.terrain)
    base = gen.tile_centre(1, 0) + np.array([-2.0, 0.3, 0.5])  # on the slope, 2 m before the platform's edge
    pattern = np.array([[0.0, 0.0], [0.5, 0.0]])
    data = wd.data.JaxSimModelData.build(model=model, base_position=base, requires_grad=True)
    tape = wp.Tape()
    with tape:
        h = wd.terrain.height_scan(model, data, pattern)
    inward = 4.0 - np.abs(np.array([-2.0, -1.5]))  # the points' distance from the tile's border along x
    np.testing.assert_allclose(h.numpy(), 0.4 * inward, atol=1e-9)
    tape.backward(grads={h: wp.array([1.0, 0.0], dtype=wp.float64)})
    grad = data.base_position_state.grad.numpy().reshape(3)
    np.testing.assert_allclose(grad, [0.4, 0.0, 0.0], atol=1e-9)  # dh/dx on the slope, 0 across it


def test_bad_patterns_are_named():
    model = _box(wd.terrain.FlatTerrain())
    data = wd.data.JaxSimModelData.build(model=model)
    with pytest.raises(ValueError, match=r"pattern must be finite points \(P, 2\)"):
        wd.terrain.height_scan(model, data, np.zeros((3, 3)))
    with pytest.raises(ValueError, match=r"pattern must be finite"):
        wd.terrain.height_scan(model, data, np.array([[0.0, np.nan]]))
