"""warpdyn: multibody dynamics and massively parallel simulation of articulated robots, as Warp kernels.

The façade mirrors JaxSim's functional API: `wd.model`, `wd.data`, `wd.references`, `wd.link`,
`wd.frame`, `wd.joint`, `wd.contact`. Every function takes (model, data, *, ...) and returns Warp arrays
on the model's device: JaxSim's shapes for single-environment data, a leading environment axis when
batched. `wd.math` holds JaxSim's math helpers, host-side (NumPy) and as `@wp.func`s for kernels.
"""

# model first: it re-exports functions of modules (_centroidal, _dynamics, ...) that import it back.
from . import model  # isort: skip
from . import assets, com, contact, data, frame, joint, link, math, references, simulation, terrain, visualization
from .common import VelRepr

__all__ = [
    "VelRepr",
    "assets",
    "com",
    "contact",
    "data",
    "frame",
    "joint",
    "link",
    "math",
    "model",
    "references",
    "simulation",
    "terrain",
    "visualization",
]
__version__ = "0.1.0"
