"""warpdyn: multibody dynamics and massively parallel simulation of articulated robots, as Warp kernels.

The façade mirrors JaxSim's functional API, so that `import jaxsim.api as js` code ports as `import warpdyn
as wd`: `wd.model`, `wd.data`, `wd.references`, `wd.link`, `wd.frame`, `wd.joint`, `wd.com`, `wd.contact`,
`wd.ode`, `wd.integrators`, `wd.actuation_model`, `wd.kin_dyn_parameters`, `wd.common`; `jaxsim.math`,
`jaxsim.terrain` and `jaxsim.rbda.contacts` are `wd.math`, `wd.terrain` and `wd.rbda.contacts`
(docs/porting.md lists every name). Every function takes (model, data, *, ...) and returns Warp arrays on the
model's device: JaxSim's shapes for single-environment data, a leading environment axis when batched.
`wd.math` holds JaxSim's math helpers, host-side (NumPy) and as `@wp.func`s for kernels.
"""

import os as _os

import warp as _wp


def set_verbose(verbose: bool = True) -> None:
    """Show (True) or hide (False, warpdyn's default) Warp's own messages: its banner when it initialises and
    a line for every kernel module it loads. Also set by the environment variable WARPDYN_VERBOSE=1 at import.
    warpdyn's own notice that it is compiling kernels (warpdyn.engine.launch) shows either way."""
    _wp.config.log_level = _wp.LOG_INFO if verbose else _wp.LOG_WARNING


if _os.environ.get("WARPDYN_VERBOSE", "") in ("", "0") and _wp.config.log_level == _wp.LOG_INFO:
    set_verbose(False)  # Warp's default level: quiet; a level the user chose is kept

# model first: it re-exports functions of modules (_centroidal, _dynamics, ...) that import it back.
from . import model  # isort: skip
from . import assets, com, contact, data, frame, joint, link, math, references, simulation, terrain, visualization
from . import actuation_model, autodiff, common, integrators, kin_dyn_parameters, ode, rbda
from .types.enums import VelRepr

__all__ = [
    "VelRepr",
    "set_verbose",
    "actuation_model",
    "assets",
    "autodiff",
    "common",
    "integrators",
    "kin_dyn_parameters",
    "ode",
    "rbda",
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
