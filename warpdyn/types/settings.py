"""The settings of `step` that are not per-joint or per-link arrays: soft contacts and actuation limits."""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

__all__ = ["SoftContactsParams", "ActuationParams", "host_values"]


def host_values(value) -> np.ndarray:
    """A parameter's values on the host (float64), from a number, a NumPy array or a Warp array."""
    if isinstance(value, wp.array):
        value = value.numpy()
    return np.asarray(value, dtype=np.float64)


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
            value = host_values(getattr(self, name))
            if value.ndim > 1 or not np.all(np.isfinite(value)) or np.any(value < 0.0):
                raise ValueError(f"SoftContactsParams.{name} must be finite and non-negative (a number or (N,)), got {value}")
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
        values = (self.torque_max, self.omega_th, self.omega_max)
        if not all(np.isfinite(values)) or not (0.0 < self.omega_th < self.omega_max) or self.torque_max < 0.0:
            raise ValueError(f"ActuationParams needs finite torque_max >= 0 and 0 < omega_th < omega_max, got {self}")
