"""The enumerations every layer shares: velocity representations (their codes are what kernels read, see
kernels/spatial.py) and integrators."""

from __future__ import annotations

import contextlib
import enum


class VelRepr(enum.IntEnum):
    """Velocity representations, as in JaxSim and Traversaro & Saccon, "Multibody dynamics notation" (2019).

    For a frame F on a rigid body:
    - Body: F_v_WF, the velocity of F's origin and the angular velocity, both in F's coordinates.
    - Mixed: (F[W])_v_WF, the velocity of F's origin and the angular velocity, both in world coordinates.
    - Inertial: W_v_WF, the velocity of the body point passing through the world origin, and the angular
      velocity, both in world coordinates.
    Spatial vectors are [linear; angular], spatial forces [force; torque].
    """

    Body = 1
    Mixed = 2
    Inertial = 3


def output_repr(data, output_vel_repr) -> VelRepr:
    """`output_vel_repr` as a VelRepr, or the data's representation when it is None (JaxSim's default)."""
    return VelRepr(output_vel_repr if output_vel_repr is not None else data.velocity_representation)


class IntegratorType(enum.IntEnum):
    """The integrators of `step`: JaxSim's (kernels/integrators.py, with JaxSim's values), and MuJoCo's Euler.

    SemiImplicitEuler: JaxSim's; the base's Inertial velocity integrated, the quaternion to first order
    and normalised. RungeKutta4: JaxSim's. RungeKutta4Fast: JaxSim's RK4 with the contact forces and the
    contact state's rate of the first stage held over the four stages (one contact evaluation per step;
    the contact state then advances by explicit Euler). SemiImplicitEulerSO3: MuJoCo's Euler (what MJCF
    models with integrator Euler, implicit or implicitfast start with); the base's Mixed velocity integrated
    and its orientation rotated exactly by dt omega. They take the joints alike; the two Euler methods
    differ on a floating base by O(dt^2) per step."""

    SemiImplicitEuler = 1
    RungeKutta4 = 2
    RungeKutta4Fast = 3
    SemiImplicitEulerSO3 = 4


@contextlib.contextmanager
def switched_representation(holder, velocity_representation):
    """Inside the block, `holder` (Data or References) reads and writes in `velocity_representation`."""
    original = holder.velocity_representation
    holder.velocity_representation = VelRepr(velocity_representation)
    try:
        yield holder
    finally:
        holder.velocity_representation = original
