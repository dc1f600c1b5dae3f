"""warpdyn: multibody dynamics and massively parallel simulation of articulated robots, as Warp kernels.

The façade mirrors JaxSim's functional API: `wd.model`, `wd.data`, `wd.references`, `wd.link`,
`wd.frame`, `wd.joint`. Every function takes (model, data, *, ...) and returns Warp arrays on the
model's device: JaxSim's shapes for single-environment data, a leading environment axis when batched.
"""

from . import com, data, frame, joint, link, model, references
from .common import VelRepr

__all__ = ["VelRepr", "com", "data", "frame", "joint", "link", "model", "references"]
__version__ = "0.1.0"
