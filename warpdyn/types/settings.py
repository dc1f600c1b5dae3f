"""The settings of `step` that are not per-joint or per-link arrays: soft contacts and actuation limits."""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

__all__ = ["SoftContactsParams", "ActuationParams", "host_values"]


def host_values(value, name: str = "value") -> np.ndarray:
    """A parameter's values on the host (float64), from a number, a NumPy array or a Warp array; a TypeError
    naming `name` for anything else."""
    if isinstance(value, wp.array):
        value = value.numpy()
    if isinstance(value, (bool, np.bool_, str, bytes)) or value is None:
        raise TypeError(f"{name} must be a number or an array of numbers, got {value!r}")
    try:
        return np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number or an array of numbers, got {value!r}") from None


@dataclasses.dataclass(frozen=True)
class SoftContactsParams:
    """JaxSim's soft-contact parameters and defaults.

    K: stiffness [N/m^(1+p)]; D: damping [N s/m^(1+q)]; mu: Coulomb friction coefficient (stick and slip);
    p: exponent of the spring term, q: of the damper term. K, D and mu may be arrays (N,), one value per
    environment (domain randomisation). They may also be Warp arrays ((1,) or (N,), the model's dtype and
    device): `step` then reads them in place, so that with requires_grad their .grad receives the gradient
    (see `warpdyn.model.parameters_requiring_grad`); their values are read once, when the step's plan is
    built, for the checks.
    """

    K: float | np.ndarray = 1e6
    D: float | np.ndarray = 2000.0
    mu: float | np.ndarray = 0.5
    p: float = 0.5
    q: float = 0.5

    def __post_init__(self):
        for name in ("K", "D", "mu", "p", "q"):
            value = host_values(getattr(self, name), f"SoftContactsParams.{name}")
            if value.ndim > (1 if name in ("K", "D", "mu") else 0) or not np.all(np.isfinite(value)) or np.any(value < 0.0):
                shape = "a number or (N,)" if name in ("K", "D", "mu") else "a number"
                raise ValueError(f"SoftContactsParams.{name} must be finite and non-negative ({shape}), got {value}")
        if np.any(host_values(self.D) <= 0.0):
            raise ValueError("SoftContactsParams.D must be positive (the deformation relaxes with rate K/D)")


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
