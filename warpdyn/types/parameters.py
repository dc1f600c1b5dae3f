"""The one registry of model parameters: what each is, where it lives, its shape, its checks.

Every parameter a kernel reads and a user may set, randomise per environment or differentiate is a
`Parameter` here. The registry drives the model's setters (`Model.set_link_parameters`,
`Model.set_joint_parameters`, `Model.set_gravity`), their validation, `warpdyn.model.parameters_requiring_grad` and the torch
bridge's `parameters=`. Adding a per-joint parameter is one entry in JOINT_PARAMETERS, a field in the
kernels' model bundle (kernels/bundles.py, filled by warpdyn.engine.bundles) and the kernels that read it.

Groups and where the values live:
- "link": one value per link (nL), on the model (`model.link_mass`, ...), a Warp array (nL, *item) shared
  by all environments or (N, nL, *item), one row per environment;
- "joint": one value per joint (nj) or per joint DoF (nv: friction, armature, damping; `Parameter.per`), on the
  model likewise (a model without ball or free joints has nj = nv);
- "actuator": one value per actuator (na, the MJCF actuators on kept joints), on the model likewise;
- "world": one value per model (the world's gravity), on the model likewise: (1, *item) shared, (N, 1, *item)
  per environment;
- "contact": the soft-contact K, D, mu in `model.contact_params` (a number, NumPy (N,) or a Warp array);
- "terrain": a FlatTerrain's height ((1,) or (N,)) or a HeightfieldTerrain's heights (nx, ny).

Checks. A setter checks what it is given (each Parameter's `check`; SoftContactsParams its fields). A
parameter's Warp array edited in place (`model.link_mass.assign(...)`, a randomisation through a torch view,
a Warp K or mu of the contacts written later) passes no setter: `validate_parameters(model)` checks the
arrays as they are now (a copy of each to the host) and raises naming the parameter, the link, joint or
actuator, the environment and the value; warpdyn.engine.step runs it whenever it builds a step's plan (a new
model version: after a setter or `model.notify_model_changed()`), and every step checks the ranges on the
device (kernels/parameter_checks.py), flagging the environments it finds out of range.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Callable

import numpy as np

from ..description.model import caller_stacklevel
from ..description.physical import UnphysicalInertiaWarning, inertia_faults

__all__ = [
    "Parameter",
    "LINK_PARAMETERS",
    "JOINT_PARAMETERS",
    "ACTUATOR_PARAMETERS",
    "WORLD_PARAMETERS",
    "CONTACT_PARAMETERS",
    "TERRAIN_PARAMETERS",
    "REGISTRY",
    "MODEL_ARRAYS",
    "check_finite",
    "check_non_negative",
    "check_inertia",
    "check_limits",
    "faults",
    "validate_parameters",
]


def check_finite(name: str, host: np.ndarray) -> None:
    """A ValueError naming `name` and the first offending entry if any value is NaN or infinite."""
    bad = np.argwhere(~np.isfinite(host))
    if bad.size:
        raise ValueError(f"{name} has non-finite values, first at index {tuple(bad[0].tolist())}: {host[tuple(bad[0])]}")


def check_non_negative(name: str, host: np.ndarray) -> None:
    check_finite(name, host)
    if np.any(host < 0.0):
        raise ValueError(f"{name} must be non-negative, got entries {host[host < 0.0][:5].tolist()}")


def check_inertia(name: str, host: np.ndarray) -> None:
    """Symmetric positive semi-definite (3, 3) matrices; an UnphysicalInertiaWarning for those violating the
    triangle inequality (the loader's checks and tolerances: warpdyn.description.physical)."""
    check_finite(name, host)
    asymmetric, indefinite, triangle, moments = inertia_faults(host)
    if np.any(asymmetric):
        raise ValueError(f"{name} must hold symmetric matrices: entry {tuple(np.argwhere(asymmetric)[0].tolist())} is not")
    if np.any(indefinite):
        at = tuple(np.argwhere(indefinite)[0].tolist())
        raise ValueError(
            f"{name} must hold positive semi-definite matrices: entry {at} has principal moments {moments[at].tolist()}"
        )
    if np.any(triangle):
        at = tuple(np.argwhere(triangle)[0].tolist())
        warnings.warn(
            f"{name}: entry {at} has principal moments {moments[at].tolist()} that violate the triangle inequality "
            "(e0 + e1 >= e2): no rigid body has them; warpdyn computes with them as given",
            UnphysicalInertiaWarning,
            stacklevel=caller_stacklevel(),
        )


def check_limits(name: str, host: np.ndarray) -> None:
    """(lower, upper) pairs, lower <= upper, +-inf allowed where a joint is unlimited."""
    if np.any(np.isnan(host)) or np.any(host[..., 0] > host[..., 1]):
        raise ValueError(f"{name} must be (lower, upper) pairs with lower <= upper (inf where unlimited), no NaN")


@dataclasses.dataclass(frozen=True)
class Parameter:
    """A model parameter.

    name: its name (the model attribute, the key of `parameters_requiring_grad`); group: "link", "joint",
    "actuator", "world", "contact" or "terrain" (module docstring); per: what one value belongs to, "link", "joint",
    "dof" (a joint's degree of freedom), "base" (a floating base's free joint: one value), "actuator" or "world"
    (one value) (default: the group); item: the shape of one value; keyword:
    its argument name in the group's setter; unit and description: for docs and errors; check: raises a
    ValueError naming the parameter for values that are not physical; default: the value a model starts
    with, from its description (a function of the lumped tree), for link and joint parameters.
    """

    name: str
    group: str
    item: tuple = ()
    keyword: str = ""
    unit: str = ""
    description: str = ""
    check: Callable[[str, np.ndarray], None] | None = check_finite
    default: Callable | None = None
    per: str = ""

    @property
    def element(self) -> str:
        """What one value belongs to: "link", "joint", "dof", "base", "actuator" or "world"."""
        return self.per or self.group


LINK_PARAMETERS = (
    Parameter("link_mass", "link", (), "mass", "kg", "mass", check_non_negative, lambda tree: tree.link_mass),
    Parameter("link_com", "link", (3,), "com", "m, link frame", "centre of mass", check_finite, lambda tree: tree.link_com),
    Parameter(
        "link_inertia", "link", (3, 3), "inertia", "kg m^2, about the CoM, link axes", "rotational inertia", check_inertia,
        lambda tree: tree.link_inertia,
    ),
    Parameter(
        "gravcomp_mass", "link", (), "gravcomp_mass", "kg",
        "gravity compensation: the mass m whose weight the force -m g carries, g the world's gravity (MJCF gravcomp; "
        "negative, as MuJoCo allows: added weight)",
        check_finite, lambda tree: tree.gravcomp_mass,
    ),
    Parameter(
        "gravcomp_com", "link", (3,), "gravcomp_com", "m, link frame", "where the gravity compensation acts",
        check_finite, lambda tree: tree.gravcomp_com,
    ),
)

JOINT_PARAMETERS = (
    Parameter(
        "position_limits", "joint", (2,), "position_limits", "rad or m", "(lower, upper) joint position limits", check_limits,
        lambda tree: tree.position_limits.reshape(-1, 2),
    ),
    Parameter(
        "joint_limit_spring", "joint", (), "limit_spring", "N m/rad or N/m", "stiffness of the joint-limit spring (0: off)",
        check_non_negative, lambda tree: np.zeros(tree.number_of_joints),
    ),
    Parameter(
        "joint_limit_damper", "joint", (), "limit_damper", "s/rad or s/m", "damping of the joint-limit spring",
        check_non_negative, lambda tree: np.zeros(tree.number_of_joints),
    ),
    Parameter(
        "friction_static", "joint", (), "friction_static", "N m or N", "static (Coulomb) joint friction",
        check_non_negative, lambda tree: tree.friction, "dof",
    ),
    Parameter(
        "friction_viscous", "joint", (), "friction_viscous", "N m s/rad or N s/m",
        "viscous joint friction, JaxSim's (URDF <dynamics damping>)", check_non_negative, lambda tree: tree.damping, "dof",
    ),
    Parameter(
        "armature", "joint", (), "armature", "kg m^2 or kg",
        "armature (reflected rotor inertia), added to the DoF's diagonal entry of the mass matrix (MJCF)",
        check_non_negative, lambda tree: tree.armature, "dof",
    ),
    Parameter(
        "damping", "joint", (), "damping", "N m s/rad or N s/m",
        "MuJoCo's joint damper, -damping * sdot, implicit in the semi-implicit Euler when model.implicit_damping (MJCF)",
        check_non_negative, lambda tree: tree.passive_damping, "dof",
    ),
    Parameter(
        "stiffness", "joint", (), "stiffness", "N m/rad or N/m", "joint spring, -stiffness * (s - springref) (MJCF)",
        check_non_negative, lambda tree: tree.stiffness,
    ),
    Parameter(
        "springref", "joint", (), "springref", "rad or m", "the joint spring's rest position (MJCF)",
        check_finite, lambda tree: tree.springref,
    ),
    Parameter(
        "joint_actuator_force_range", "joint", (2,), "actuator_force_range", "N m or N",
        "clamp of the summed actuator force on the joint (MJCF actuatorfrcrange; inf where none)",
        check_limits, lambda tree: tree.actuator_force_range,
    ),
    Parameter(
        "base_armature", "joint", (), "base_armature", "kg or kg m^2",
        "a floating base's free-joint armature, on each of its 6 DoFs (MJCF; MuJoCo's)",
        check_non_negative, lambda tree: np.array([tree.base_armature]), "base",
    ),
    Parameter(
        "base_damping", "joint", (), "base_damping", "N s/m or N m s/rad",
        "a floating base's free-joint damper, -damping v on each of its 6 DoFs (MJCF; implicit as the joints')",
        check_non_negative, lambda tree: np.array([tree.base_damping]), "base",
    ),
    Parameter(
        "base_stiffness", "joint", (), "base_stiffness", "N/m or N m/rad",
        "a floating base's free-joint spring towards the description's base pose (MJCF; MuJoCo's)",
        check_non_negative, lambda tree: np.array([tree.base_stiffness]), "base",
    ),
)

ACTUATOR_PARAMETERS = (
    Parameter(
        "actuator_gear", "actuator", (), "gear", "", "transmission: length = gear s, joint force = gear force",
        check_finite, lambda tree: np.array([a.gear for a in tree.actuators], dtype=np.float64),
    ),
    Parameter(
        "actuator_gain", "actuator", (3,), "gain", "",
        "force = (g0 + g1 length + g2 velocity) ctrl + bias (a fixed gain has g1 = g2 = 0)",
        check_finite, lambda tree: np.array([a.gain * (1.0, 0.0, 0.0) if a.gain_type == "fixed" else a.gain for a in tree.actuators]).reshape(-1, 3),
    ),
    Parameter(
        "actuator_bias", "actuator", (3,), "bias", "", "bias = b0 + b1 length + b2 velocity (none: 0)",
        check_finite, lambda tree: np.array([a.bias if a.bias_type == "affine" else np.zeros(3) for a in tree.actuators]).reshape(-1, 3),
    ),
    Parameter(
        "actuator_ctrl_range", "actuator", (2,), "ctrl_range", "ctrl units", "clamp of the control (inf where none)",
        check_limits, lambda tree: np.array([a.ctrl_range if a.ctrl_limited else (-np.inf, np.inf) for a in tree.actuators]).reshape(-1, 2),
    ),
    Parameter(
        "actuator_force_range", "actuator", (2,), "force_range", "N m or N per unit gear",
        "clamp of the actuator's force before the gear (inf where none)",
        check_limits, lambda tree: np.array([a.force_range if a.force_limited else (-np.inf, np.inf) for a in tree.actuators]).reshape(-1, 2),
    ),
)

WORLD_PARAMETERS = (
    Parameter(
        "world_gravity", "world", (3,), "gravity", "m/s^2, world frame",
        "the acceleration of gravity (MuJoCo's opt.gravity, SDF's <world><gravity>; JaxSim's model.gravity is its z)",
        check_finite,
    ),
)

CONTACT_PARAMETERS = (
    Parameter("K", "contact", (), "K", "N/m^(1+p)", "soft-contact stiffness", check_non_negative),
    Parameter("D", "contact", (), "D", "N s/m^(1+q)", "soft-contact damping", check_non_negative),
    Parameter("mu", "contact", (), "mu", "", "Coulomb friction coefficient", check_non_negative),
)

TERRAIN_PARAMETERS = (Parameter("terrain_height", "terrain", (), "height", "m", "terrain height", check_finite),)

REGISTRY: dict[str, Parameter] = {
    p.name: p
    for p in (*LINK_PARAMETERS, *JOINT_PARAMETERS, *ACTUATOR_PARAMETERS, *WORLD_PARAMETERS, *CONTACT_PARAMETERS, *TERRAIN_PARAMETERS)
}
"""Every model parameter by name."""

MODEL_ARRAYS = tuple(p.name for p in (*LINK_PARAMETERS, *JOINT_PARAMETERS, *ACTUATOR_PARAMETERS, *WORLD_PARAMETERS))
"""The parameters held as the model's own arrays (link, joint, actuator and world parameters, shared or per environment)."""


def faults(parameter: Parameter, host: np.ndarray) -> np.ndarray:
    """A boolean mask over the values (host's shape without the item axes) of those `parameter`'s check
    refuses: not finite (check_finite), not finite and non-negative (check_non_negative), NaN or lower > upper
    (check_limits), not finite, not symmetric or not positive semi-definite within the loader's tolerances
    (check_inertia; its triangle-inequality warning is not a fault). No warning is issued."""
    items = len(parameter.item)
    axes = tuple(range(host.ndim - items, host.ndim))
    finite = np.isfinite(host).all(axis=axes) if items else np.isfinite(host)
    check = parameter.check
    if check is check_non_negative:
        return ~(finite & (np.nan_to_num(host, nan=-1.0) >= 0.0))
    if check is check_limits:
        return np.isnan(host).any(axis=-1) | (host[..., 0] > host[..., 1])
    if check is check_inertia:
        bad = ~finite
        if finite.any():
            asymmetric, indefinite, _, _ = inertia_faults(host[finite])
            bad[finite] = asymmetric | indefinite
        return bad
    return ~finite


_REQUIREMENT = {
    check_finite: "must be finite",
    check_non_negative: "must be non-negative (and finite)",
    check_limits: "must be (lower, upper) with lower <= upper and no NaN (inf where unlimited)",
    check_inertia: "must be symmetric positive semi-definite (the loader's tolerances: warpdyn.description.physical)",
}


def validate_parameters(model) -> None:
    """A ValueError naming the parameter, its link, joint or actuator, its environment (per-environment values)
    and its value, for the first value of the model's link, joint, actuator and world arrays, or of its soft-contact
    K, D, mu, p, q, that is out of range (the setters' checks, `faults`), as the arrays are now: edits in place
    included. A fixed base's own mass, centre of mass and inertia are not checked: no dynamics reads them (a
    gradient check may probe a massless fixed base's mass below 0). Copies each array to the host (a
    synchronisation with the device)."""
    names = {"link": model.link_names(), "joint": model.joint_names(), "dof": model.dof_names(), "actuator": model.actuator_names(),
             "base": (model.base_link(),), "world": ("world",)}
    per_env = model.per_environment_parameters()
    for name in MODEL_ARRAYS:
        parameter = REGISTRY[name]
        host = np.asarray(model.parameter(name).numpy(), dtype=np.float64)
        bad = faults(parameter, host)
        if parameter.group == "link" and not model.floating_base():
            bad[..., 0] = False  # a fixed base's own inertial values enter no dynamics (the device check skips them too)
        if not bad.any():
            continue
        at = tuple(int(k) for k in np.argwhere(bad)[0])
        env, k = at if name in per_env else (None, at[0])
        value = host[at]
        shown = f"{float(value):g}" if value.ndim == 0 else str(np.round(value, 6).tolist())
        element = names[parameter.element][k]
        label = "DoF" if parameter.element == "dof" and ":" in element else "joint" if parameter.element == "dof" else parameter.element
        where = ("the world" if parameter.element == "world" else f"{label} '{element}'") + (f" in environment {env}" if env is not None else "")
        detail = ""
        if parameter.check is check_inertia and np.isfinite(value).all():
            detail = f"; principal moments {np.round(np.linalg.eigvalsh(0.5 * (value + value.T)), 9).tolist()}"
        raise ValueError(f"{name} of {where} is {shown} [{parameter.unit}]: {_REQUIREMENT[parameter.check]}{detail}")
    model.contact_params.check()
