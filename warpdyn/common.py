"""JaxSim's `jaxsim.api.common`: the velocity representations and the base of the objects that hold them.

`ModelDataWithVelocityRepresentation` is the base of `wd.data.Data` and `wd.references.References`: a
`velocity_representation` attribute, `switch_velocity_representation` (a context manager), and JaxSim's two
static conversions of 6D quantities between the Inertial representation and another one, on the host
(NumPy, any leading batch axes; Warp arrays are copied to the host).

The conversions, for a frame O with W_H_O = (R, p) and O[W] the frame at O's origin with W's orientation:
- a velocity: O_v = O_X_W W_v (Body), O[W]_v = O[W]_X_W W_v (Mixed);
- a force: O_f = W_X_O^T W_f (Body), O[W]_f = W_X_O[W]^T W_f (Mixed);
with A_X_B = [[R, p^ R], [0, R]] the adjoint of A_H_B (warpdyn.math.Adjoint), [linear; angular].
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .arrays import host_numbers
from .math import Adjoint
from .types.enums import VelRepr, switched_representation

__all__ = ["VelRepr", "ModelDataWithVelocityRepresentation"]


def _host(value, name: str, last: tuple) -> np.ndarray:
    """`value` (NumPy-like or a Warp array) as float64 on the host, with trailing axes `last`."""
    host = host_numbers(value.numpy() if isinstance(value, wp.array) else value, name)
    if host.shape[max(host.ndim - len(last), 0) :] != last:
        raise ValueError(f"{name} must have shape (..., {', '.join(map(str, last))}), got {host.shape}")
    return host


def _frame(other_representation, transform) -> np.ndarray | None:
    """W_H_O of `transform` for Body, W_H_O[W] for Mixed, None for Inertial (nothing to convert)."""
    representation = VelRepr(other_representation)
    if representation == VelRepr.Inertial:
        return None
    H = _host(transform, "transform", (4, 4))
    if representation == VelRepr.Mixed:
        H = H.copy()
        H[..., :3, :3] = np.eye(3)
    return H


def _apply(X: np.ndarray, array: np.ndarray) -> np.ndarray:
    return np.einsum("...ij,...j->...i", X, array)


class ModelDataWithVelocityRepresentation:
    """An object whose velocities (and forces) are read and written in `velocity_representation`."""

    velocity_representation: VelRepr

    def switch_velocity_representation(self, velocity_representation: VelRepr):
        """A context manager: inside its block, this object's velocities and forces are read and written in
        `velocity_representation`; the original one is restored on leaving it, even on an exception."""
        return switched_representation(self, velocity_representation)

    @staticmethod
    def inertial_to_other_representation(array, other_representation: VelRepr, transform, *, is_force: bool) -> np.ndarray:
        """The 6D quantity `array` (..., 6), a velocity or a force (`is_force`) in the Inertial
        representation, expressed in `other_representation` of the frame O whose pose is `transform`
        W_H_O (..., 4, 4): (..., 6) NumPy, [linear; angular]."""
        W_array = _host(array, "array", (6,))
        W_H_O = _frame(other_representation, transform)
        if W_H_O is None:
            return W_array.copy()
        if is_force:
            return _apply(np.swapaxes(Adjoint.from_transform(W_H_O), -1, -2), W_array)
        return _apply(Adjoint.from_transform(W_H_O, inverse=True), W_array)

    @staticmethod
    def other_representation_to_inertial(array, other_representation: VelRepr, transform, *, is_force: bool) -> np.ndarray:
        """The inverse of `inertial_to_other_representation`: `array` (..., 6) in `other_representation` of
        the frame O with pose `transform` W_H_O (..., 4, 4), in the Inertial representation."""
        O_array = _host(array, "array", (6,))
        W_H_O = _frame(other_representation, transform)
        if W_H_O is None:
            return O_array.copy()
        if is_force:
            return _apply(np.swapaxes(Adjoint.from_transform(W_H_O, inverse=True), -1, -2), O_array)
        return _apply(Adjoint.from_transform(W_H_O), O_array)
