"""The settings of `step` that are not per-joint or per-link arrays: soft contacts and actuation limits."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import warp as wp

from .. import arrays

__all__ = ["ContactsParams", "SoftContactsParams", "RigidContactsParams", "RelaxedRigidContactsParams", "ActuationParams", "STANDARD_GRAVITY", "host_values", "check_contact_value", "CONTACT_UNITS", "MAX_STIFFNESS", "MAX_DAMPING"]


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

    def check(self) -> None:
        """Raise a TypeError or ValueError naming the first field out of range (each model's class says)."""
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
        self.check()

    def check(self) -> None:
        """`check_contact_value` on each field, as they are now (a Warp array edited in place included)."""
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


def _checked_field(owner: str, name: str, value, per_env: bool, low: float, low_open: bool, high: float = np.inf, high_open: bool = False, why: str = "") -> None:
    """A TypeError or ValueError naming `owner.name` and its first value outside [low, high] (an open end
    excluded), or not finite; per_env: a number or (N,), else a number."""
    field = f"{owner}.{name}"
    host = host_values(value, field)
    if host.ndim > (1 if per_env else 0):
        raise ValueError(f"{field} must be {'a number or (N,)' if per_env else 'a number'}, got shape {host.shape}")
    flat = np.atleast_1d(host)
    bad = ~np.isfinite(flat) | (flat <= low if low_open else flat < low) | (flat >= high if high_open else flat > high)
    if bad.any():
        k = int(np.argmax(bad))
        where = f" (environment {k})" if host.ndim == 1 else ""
        interval = f"{'(' if low_open else '['}{low:g}, {high:g}{')' if high_open or not np.isfinite(high) else ']'}"
        raise ValueError(f"{field} must be finite and in {interval}{': ' + why if why else ''}, got {flat[k]}{where}")


@dataclasses.dataclass(frozen=True)
class RigidContactsParams(ContactsParams):
    """JaxSim's rigid-contact parameters and defaults (kernels/rigid_contacts.py has the law).

    mu: the friction pyramid's coefficient; K [1/s^2] and D [1/s]: Baumgarte's terms, the reference acceleration
    (K delta + D delta_dot) n of a penetrating point. Each a number or (N,) (one value per environment), finite and
    non-negative (JaxSim 0.9.0's valid())."""

    mu: float | np.ndarray = 0.5
    K: float | np.ndarray = 0.0
    D: float | np.ndarray = 0.0

    def __post_init__(self):
        self.check()

    def check(self) -> None:
        """Each field a number or (N,), finite and non-negative, as they are now."""
        for name in ("mu", "K", "D"):
            _checked_field("RigidContactsParams", name, getattr(self, name), True, 0.0, False)

    @classmethod
    def build(cls, *, mu=0.5, K=0.0, D=0.0, **kwargs) -> RigidContactsParams:
        """JaxSim's constructor: the parameters, checked; other keywords are a TypeError naming them."""
        if kwargs:
            raise TypeError(f"RigidContactsParams.build() takes mu, K and D, got {sorted(kwargs)}")
        return cls(mu=mu, K=K, D=D)

    def valid(self) -> bool:
        """JaxSim's check: mu, K, D >= 0."""
        return all(bool(np.all(host_values(getattr(self, name), name) >= 0.0)) for name in ("mu", "K", "D"))


_RELAXED_RANGES = {
    # name: (per environment, low, low open, high, high open, why)
    "time_constant": (False, 0.0, True, np.inf, False, "the reference acceleration's stiffness is 1 / (d_max time_constant damping_coefficient)^2 [1/s^2]"),
    "damping_coefficient": (False, 0.0, True, np.inf, False, "JaxSim's valid() asks > 0"),
    "d_min": (False, 0.0, False, 1.0, True, "an impedance"),
    "d_max": (False, 0.0, True, 1.0, True, "an impedance; at 1 the regularisation R = 2 mu^2 (1 - xi) / xi vanishes and redundant contacts make the solve singular"),
    "width": (False, 0.0, True, np.inf, False, "the impedance is a function of the penetration over width [m]"),
    "midpoint": (False, 0.0, True, 1.0, True, "the impedance sigmoid's midpoint divides width's [0, 1]"),
    "power": (False, 0.0, True, np.inf, False, "the impedance sigmoid's exponent"),
    "mu": (True, 0.0, True, np.inf, False, "the regularisation R = 2 mu^2 (1 - xi) / xi (1 + mu^2) / m vanishes at mu = 0 and redundant contacts (a foot's corners) make the solve singular"),
    "K": (False, -np.inf, False, np.inf, False, ""),
    "D": (False, -np.inf, False, np.inf, False, ""),
}


@dataclasses.dataclass(frozen=True)
class RelaxedRigidContactsParams(ContactsParams):
    """JaxSim's relaxed-rigid parameters and defaults (kernels/rigid_contacts.py has the law): the time constant
    [s] and damping coefficient of the reference acceleration, the impedance's d_min, d_max, width [m], midpoint
    and power (MuJoCo's solimp), and mu, the friction coefficient of the regularisation (a number or (N,)).
    K and D are JaxSim's fields, which its law never reads (its formula overwrites them with the time constant's
    stiffness and damping): warpdyn keeps them for JaxSim's code and warns when they are given nonzero.

    Checks (stricter than JaxSim's valid(), each saying why): time_constant, damping_coefficient, width and power
    positive; 0 <= d_min <= d_max < 1; 0 < midpoint < 1; mu > 0."""

    time_constant: float = 0.02
    damping_coefficient: float = 1.0
    d_min: float = 0.9
    d_max: float = 0.95
    width: float = 0.001
    midpoint: float = 0.5
    power: float = 2.0
    K: float = 0.0
    D: float = 0.0
    mu: float | np.ndarray = 0.005

    def __post_init__(self):
        self.check()
        unread = [name for name in ("K", "D") if float(getattr(self, name)) != 0.0]
        if unread:
            warnings.warn(
                f"RelaxedRigidContactsParams.{' and '.join(unread)} {'are' if len(unread) > 1 else 'is'} not read: JaxSim 0.9.0's relaxed-rigid "
                "law (and warpdyn's) takes its stiffness 1 / (d_max time_constant damping_coefficient)^2 and damping 2 / (d_max time_constant) "
                "from time_constant and damping_coefficient; set those instead",
                stacklevel=3,
            )

    def check(self) -> None:
        """The ranges of the class docstring, as the fields are now; an error names the field, its value and why."""
        for name, (per_env, low, low_open, high, high_open, why) in _RELAXED_RANGES.items():
            _checked_field("RelaxedRigidContactsParams", name, getattr(self, name), per_env, low, low_open, high, high_open, why)
        if float(self.d_min) > float(self.d_max):
            raise ValueError(f"RelaxedRigidContactsParams needs d_min <= d_max, got d_min {self.d_min}, d_max {self.d_max}")

    @classmethod
    def build(cls, **kwargs) -> RelaxedRigidContactsParams:
        """JaxSim's constructor: the given fields (the others at their defaults; None: the default), checked;
        an unknown keyword is a TypeError naming it."""
        unknown = sorted(set(kwargs) - set(_RELAXED_RANGES))
        if unknown:
            raise TypeError(f"RelaxedRigidContactsParams.build() takes {sorted(_RELAXED_RANGES)}, got {unknown}")
        return cls(**{k: v for k, v in kwargs.items() if v is not None})

    def valid(self) -> bool:
        """JaxSim's check: time_constant >= 0, damping_coefficient > 0, 0 <= d_min <= d_max <= 1, width, midpoint,
        power and mu >= 0."""
        v = {name: host_values(getattr(self, name), name) for name in _RELAXED_RANGES}
        return bool(
            np.all(v["time_constant"] >= 0.0) and np.all(v["damping_coefficient"] > 0.0) and np.all(v["d_min"] >= 0.0) and np.all(v["d_max"] <= 1.0)
            and np.all(v["d_min"] <= v["d_max"]) and np.all(v["width"] >= 0.0) and np.all(v["midpoint"] >= 0.0) and np.all(v["power"] >= 0.0)
            and np.all(v["mu"] >= 0.0)
        )


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
