"""JaxSim's `jaxsim.api.kin_dyn_parameters`: a model's kinematic and dynamic parameters, host-side (NumPy).

`model.kin_dyn_parameters` is a `KinDynParameters`: the links' and joints' parameters (a snapshot of the
model's), the joint model, the tree's arrays, the collidable points and the frames. Change parameters as in
JaxSim, through copies applied with `model.replace(kin_dyn_parameters=...)`, or with the model's setters
(`Model.set_link_parameters`, `set_joint_parameters`), which also take one row per environment. JaxSim's
hardware parametrisation: `HwLinkMetadata` (`hw_link_metadata(model)`), `ScalingFactors` and
`LinkParametrizableShape` here, `wd.model.update_hw_parameters` (boxes, cylinders and spheres; not meshes).
JaxSim's kinematic constraints: `ConstraintMap` and `ConstraintType` (welds between frames, warpdyn.types.constraints),
set as `model.kin_dyn_parameters.constraints`, `model.constraints` or `build_from_model_description(constraints=...)`.
"""

from .types.constraints import ConstraintMap, ConstraintType
from .types.hardware import HwLinkMetadata, LinkParametrizableShape, ScalingFactors, hw_link_metadata
from .types.kin_dyn import ContactParameters, FrameParameters, JointModel, JointParameters, KinDynParameters, LinkParameters

__all__ = [
    "KinDynParameters",
    "LinkParameters",
    "JointParameters",
    "ContactParameters",
    "FrameParameters",
    "JointModel",
    "HwLinkMetadata",
    "LinkParametrizableShape",
    "ScalingFactors",
    "hw_link_metadata",
    "ConstraintMap",
    "ConstraintType",
]
