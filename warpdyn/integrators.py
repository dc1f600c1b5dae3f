"""JaxSim's `jaxsim.api.integrators`: one step of each integrator from given joint torques.

Each function returns the data after `model.time_step` [s] with that integrator, whatever
`model.integrator` is, from the data (its representation kept), the link forces `link_forces` (nL, 6) or
(N, nL, 6) in the Inertial representation (as JaxSim's step passes them) and the joint torques
`joint_torques` (n,) or (N, n) [N m or N]: the output of JaxSim's actuation model
(`warpdyn.actuation_model.compute_resultant_torques`), applied as they are. MuJoCo's passive joint forces and
actuators (zero controls), which JaxSim models have not, are added as in `step`. `warpdyn.model.step` is
`compute_resultant_torques` followed by the model's integrator.

RungeKutta4Fast is JaxSim's idea (contact forces evaluated once per step), not its 0.9.0 numbers: JaxSim's
function integrates the positions with the velocities of the step's start at every stage and replaces the
contact state by its rate; warpdyn's is RK4 whose stages hold the first stage's contact forces and
deformation rate (docs/porting.md).
"""

from __future__ import annotations

from .data import Data
from .engine import evaluations
from .types.enums import IntegratorType

__all__ = ["semi_implicit_euler_integration", "rk4_integration", "rk4fast_integration"]


def semi_implicit_euler_integration(model, data: Data, link_forces=None, joint_torques=None) -> Data:
    """One step of JaxSim's semi-implicit Euler (IntegratorType.SemiImplicitEuler); see the module docstring."""
    return evaluations.integrate(model, data, IntegratorType.SemiImplicitEuler, link_forces, joint_torques)


def rk4_integration(model, data: Data, link_forces=None, joint_torques=None) -> Data:
    """One step of RK4 (IntegratorType.RungeKutta4); see the module docstring."""
    return evaluations.integrate(model, data, IntegratorType.RungeKutta4, link_forces, joint_torques)


def rk4fast_integration(model, data: Data, link_forces=None, joint_torques=None) -> Data:
    """One step of RK4 with the contact forces of its first stage held (IntegratorType.RungeKutta4Fast); see
    the module docstring."""
    return evaluations.integrate(model, data, IntegratorType.RungeKutta4Fast, link_forces, joint_torques)
