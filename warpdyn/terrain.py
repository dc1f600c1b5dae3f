"""JaxSim's `jaxsim.terrain`: the terrains the collidable points touch, flat, an inclined plane, and a
heightfield grid (warpdyn.types.terrain holds them and their conventions)."""

from .types.terrain import FlatTerrain, HeightfieldTerrain, PlaneTerrain, Terrain

__all__ = ["Terrain", "FlatTerrain", "PlaneTerrain", "HeightfieldTerrain"]
