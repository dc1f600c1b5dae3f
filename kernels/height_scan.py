"""A height scan: the terrain's height under a pattern of points around each environment's base, the pattern in the
base's yaw frame (its heading, not its roll and pitch). Vertical rays cast down onto a terrain that is a height
function hit it at its height there, so the scan reads the terrain's height function (kernels/soft_contacts.py's
`terrain_height`: flat, plane, heightfield)."""

import types

import warp as wp

from .bundles import bundles
from .factory import factory
from .soft_contacts import kernels as soft_contact_kernels


@factory
def kernels(scalar) -> types.SimpleNamespace:
    """The height-scan kernel in `scalar`."""
    B = bundles(scalar)
    T = soft_contact_kernels(scalar)

    @wp.kernel(module="unique")
    def height_scan(
        terrain: B.Terrain,
        base_position: wp.array2d(dtype=scalar),
        base_quaternion: wp.array2d(dtype=scalar),
        pattern: wp.array2d(dtype=scalar),
        # outputs
        heights: wp.array2d(dtype=scalar),
    ):
        """heights (N, P) [m]: the terrain's height under point k of `pattern` (P, 2) [m, the base's yaw frame: x
        forward, y left] around environment env's base (position (N, 3), quaternion (N, 4) w, x, y, z); launched
        over (N, P)."""
        env, k = wp.tid()
        w = base_quaternion[env, 0]
        x = base_quaternion[env, 1]
        y = base_quaternion[env, 2]
        z = base_quaternion[env, 3]
        one = scalar(1.0)
        two = scalar(2.0)
        yaw = wp.atan2(two * (w * z + x * y), one - two * (y * y + z * z))
        c = wp.cos(yaw)
        s = wp.sin(yaw)
        px = base_position[env, 0] + c * pattern[k, 0] - s * pattern[k, 1]
        py = base_position[env, 1] + s * pattern[k, 0] + c * pattern[k, 1]
        heights[env, k] = T.terrain_height(terrain, T.height_parameter(terrain, env), px, py)

    return types.SimpleNamespace(height_scan=height_scan)
