"""The settings of `step` that are not per-joint or per-link arrays: soft contacts and actuation limits."""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from .. import arrays

__all__ = ["ContactsParams", "SoftContactsParams", "ActuationParams", "STANDARD_GRAVITY", "host_values", "check_contact_value", "CONTACT_UNITS", "MAX_STIFFNESS", "MAX_DAMPING"]


def host_values(value, name: str = "value") -> np.ndarray:
    """A parameter's values on the host (float64), from a number, a NumPy array or a Warp array (copied to the
    host); a TypeError naming `name` for anything else: a string, None, a bool, or an array that is not real
    numbers (complex, bool, object, ...: warpdyn.arrays.host_numbers, the one conversion of users' numbers)."""
    if isinstance(value, wp.array):
        value = value.numpy()
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        raise TypeError(f"{name} must be a number or an array of numbers, got {value!r}")
    return arrays.host_numbers(value, name)


STANDARD_GRAVITY = 9.81
"""JaxSim's standard gravity [m/s^2] (warpdyn.math.STANDARD_GRAVITY): the magnitude of a model's gravity
unless its description or the builder says otherwise, and the gravity of JaxSim's contact-parameter estimate."""

CONTACT_UNITS = {"K": "N/m^(1+p)", "D": "N s/m^(1+q)", "mu": "", "p": "", "q": ""}
"""The units of SoftContactsParams' fields."""

_POSITIVE = {
    "K": "K = 0 is no ground at all: the collidable points fall through the terrain",
    "D": "the deformation relaxes with rate K/D",
}


def check_contact_value(name: str, value) -> None:
    """A TypeError or ValueError naming `SoftContactsParams.<name>` and the first offending value (and its
    environment, for per-environment values): K, D and mu a number or (N,), p and q a number; all finite and
    non-negative (JaxSim 0.9.0's SoftContactsParams.valid() asks K, D, mu, p, q >= 0), and K and D positive
    (K = 0 is no ground; D = 0 makes the deformation's rate K/D infinite). A Warp array is copied to the host."""
    field = f"SoftContactsParams.{name}"
    host = host_values(value, field)
    per_env = name in ("K", "D", "mu")
    shape = "a number or (N,)" if per_env else "a number"
    if host.ndim > (1 if per_env else 0):
        raise ValueError(f"{field} must be finite and non-negative ({shape}), got {value}")
    flat = np.atleast_1d(host)

    def shown(bad: np.ndarray) -> str:
        k = int(np.argmax(bad))
        return f"{flat[k]}" + (f" (environment {k})" if host.ndim == 1 else "")

    bad = ~(np.isfinite(flat) & (flat >= 0.0))
    if bad.any():
        raise ValueError(f"{field} must be finite and non-negative ({shape}), got {shown(bad)}")
    if name in _POSITIVE and np.any(flat <= 0.0):
        raise ValueError(f"{field} must be positive [{CONTACT_UNITS[name]}] ({_POSITIVE[name]}), got {shown(flat <= 0.0)}")


MAX_STIFFNESS = 1e6
"""The largest stiffness K [N/m^(1 + p)] of `build_default_from_jaxsim_model`, JaxSim's."""

MAX_DAMPING = 1e4
"""The largest damping D [N s/m^(1 + q)] of `build_default_from_jaxsim_model`, JaxSim's."""


class ContactsParams:
    """JaxSim's base class of a contact model's parameters: `build`, `build_default_from_jaxsim_model`,
    `valid`."""

    @classmethod
    def build(cls, **kwargs):
        """Parameters with the given fields (the others at their defaults), checked."""
        return cls(**kwargs)

    @classmethod
    def build_default_from_jaxsim_model(
        cls,
        model,
        *,
        stiffness=None,
        damping=None,
        standard_gravity: float = STANDARD_GRAVITY,
        static_friction_coefficient: float = 0.5,
        max_penetration=0.001,
        number_of_active_collidable_points_steady_state: int = 1,
        damping_ratio: float = 1.0,
        p: float = 0.5,
        q: float = 0.5,
        **kwargs,
    ):
        """JaxSim's estimate for `model` (its total mass m [kg], the current `model.link_mass`, per
        environment when given so): K = m g / nc / max_penetration^(1 + p) clipped to [0, MAX_STIFFNESS]
        (unless `stiffness` is given), D = damping_ratio 2 sqrt(K m) clipped to [0, MAX_DAMPING] (unless
        `damping` is given), mu the static friction coefficient."""
        nc = number_of_active_collidable_points_steady_state
        if isinstance(nc, (bool, np.bool_)) or int(nc) != nc or nc < 1:
            raise ValueError(f"number_of_active_collidable_points_steady_state must be an integer >= 1, got {nc!r}")
        delta = host_values(max_penetration, "max_penetration")
        if not np.all((delta > 0.0) & np.isfinite(delta)):
            raise ValueError(f"max_penetration must be positive and finite [m], got {max_penetration}")
        m = np.asarray(model.link_mass.numpy(), dtype=np.float64).sum(axis=-1)
        K = np.clip(m * standard_gravity / nc / delta ** (1.0 + p), 0.0, MAX_STIFFNESS) if stiffness is None else host_values(stiffness, "stiffness")
        D = np.clip(damping_ratio * 2.0 * np.sqrt(K * m), 0.0, MAX_DAMPING) if damping is None else host_values(damping, "damping")
        return cls.build(K=_number_or_array(K), D=_number_or_array(D), mu=static_friction_coefficient, p=p, q=q, **kwargs)

    def valid(self) -> bool:
        """Whether the parameters are in range (each model's class says)."""
        raise NotImplementedError(f"{type(self).__name__} does not say which of its values are valid")


def _number_or_array(x: np.ndarray):
    """A float for a 0-d array (a value shared by the environments), the array otherwise."""
    return float(x) if np.ndim(x) == 0 else x


@dataclasses.dataclass(frozen=True)
class SoftContactsParams(ContactsParams):
    """JaxSim's soft-contact parameters and defaults.

    K: stiffness [N/m^(1+p)]; D: damping [N s/m^(1+q)]; mu: Coulomb friction coefficient (stick and slip);
    p: exponent of the spring term, q: of the damper term. K, D and mu may be arrays (N,), one value per
    environment (domain randomisation). They may also be Warp arrays ((1,) or (N,), the model's dtype and
    device): `step` then reads them in place, so that with requires_grad their .grad receives the gradient
    (see `warpdyn.model.parameters_requiring_grad`).

    Checks (`check_contact_value`), when made: K and D positive and finite (K = 0 is no ground at all), mu,
    p and q finite and non-negative (at least JaxSim 0.9.0's SoftContactsParams.valid(): all >= 0); a
    TypeError or ValueError naming the field and the value. A Warp array's values are copied to the host for
    these checks here, once. Values written into a Warp array later (`K.assign(...)`, a randomisation on the
    device) no host check sees without a synchronisation: the step checks them on the device and flags the
    environments whose K, D or mu is out of range, or whose dt K / D is unstable where their points can reach
    the terrain (data.healthy 0, their state kept: warpdyn.kernels.parameter_checks); the host checks them
    again when the step's plan is next built (warpdyn.types.parameters.validate_parameters).
    """

    K: float | np.ndarray = 1e6
    D: float | np.ndarray = 2000.0
    mu: float | np.ndarray = 0.5
    p: float = 0.5
    q: float = 0.5

    def __post_init__(self):
        for name in ("K", "D", "mu", "p", "q"):
            check_contact_value(name, getattr(self, name))

    @classmethod
    def build(cls, *, K=1e6, D=2000.0, mu=0.5, p=0.5, q=0.5, **kwargs) -> SoftContactsParams:
        """JaxSim's constructor: the parameters, checked; other keywords are a TypeError naming them (JaxSim
        logs and ignores them)."""
        if kwargs:
            raise TypeError(f"SoftContactsParams.build() takes K, D, mu, p and q, got {sorted(kwargs)}")
        return cls(K=K, D=D, mu=mu, p=p, q=q)

    def valid(self) -> bool:
        """JaxSim's check: K, D, mu, p, q >= 0, read as they are now (a Warp array edited in place included);
        warpdyn's checks when made are stricter (K, D > 0; all finite)."""
        values = [np.asarray(host_values(getattr(self, name), name)) for name in ("K", "D", "mu", "p", "q")]
        return all(bool(np.all(v >= 0.0)) for v in values)


@dataclasses.dataclass(frozen=True)
class ActuationParams:
    """JaxSim's torque-speed curve and whether joint friction applies.

    torque_max [N m]: the bound up to omega_th [rad/s], falling linearly to 0 at omega_max.
    """

    torque_max: float = 3000.0
    omega_th: float = 30.0
    omega_max: float = 100.0
    enable_friction: bool = True

    def __post_init__(self):
        for name, unit in (("torque_max", "N m"), ("omega_th", "rad/s"), ("omega_max", "rad/s")):
            value = host_values(getattr(self, name), f"ActuationParams.{name}")
            if value.ndim != 0:
                raise TypeError(f"ActuationParams.{name} must be a number [{unit}], got {getattr(self, name)!r}")
            if not np.isfinite(value):
                raise ValueError(f"ActuationParams.{name} must be finite [{unit}], got {float(value)}")
            object.__setattr__(self, name, float(value))
        if self.torque_max < 0.0:
            raise ValueError(f"ActuationParams.torque_max must be non-negative [N m], got {self.torque_max}")
        if not 0.0 < self.omega_th < self.omega_max:
            raise ValueError(f"ActuationParams needs 0 < omega_th < omega_max [rad/s], got omega_th {self.omega_th}, omega_max {self.omega_max}")
        if not isinstance(self.enable_friction, (bool, np.bool_)):
            raise TypeError(f"ActuationParams.enable_friction must be True or False, got {self.enable_friction!r}")
