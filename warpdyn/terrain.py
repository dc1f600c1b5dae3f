"""Terrains the collidable points touch: flat, an inclined plane, and a heightfield grid (warpdyn.types.terrain
holds them and their conventions)."""

from .types.terrain import FlatTerrain, HeightfieldTerrain, PlaneTerrain

__all__ = ["FlatTerrain", "PlaneTerrain", "HeightfieldTerrain"]
