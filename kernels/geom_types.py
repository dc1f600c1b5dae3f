"""MuJoCo's mjtGeom values of the geoms warpdyn's narrow phase collides (kernels/collision_primitives.py,
kernels/collision_box.py, kernels/collision_convex.py), and a mesh's: plain integers, which the description's pair
tables (warpdyn/description/collision_pairs.py) and the model's geom pairs (warpdyn/types/geoms.py) read too."""

PLANE, SPHERE, CAPSULE, ELLIPSOID, CYLINDER, BOX, MESH = 0, 2, 3, 4, 5, 6, 7
