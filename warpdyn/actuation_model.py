"""JaxSim's `jaxsim.api.actuation_model`: the joint torques of JaxSim's actuation model.

    tau = clip(tau_ref - (kc sign(sdot) + kv sdot) + tau_limits, -tau_lim(|sdot|), tau_lim(|sdot|))

with the joints' static and viscous friction (when `model.actuation_params.enable_friction`), the limit
spring-damper and JaxSim's torque-speed curve (kernels/actuation.py has the formulas). `step` applies these
torques, plus MuJoCo's passive joint forces and actuators where the model has them
(`warpdyn.model.free_floating_passive_forces`, `actuator_forces`).
"""

from __future__ import annotations

import warp as wp

from . import arrays
from .engine import evaluations

__all__ = ["compute_resultant_torques", "tn_curve_fn"]


def compute_resultant_torques(model, data, *, joint_force_references=None) -> wp.array:
    """tau (n,) or (N, n) [N m or N]: the torques of JaxSim's actuation model from the joint force references
    (n,) or (N, n) (None: zero) at the data's state."""
    tau = evaluations.resultant_torques(model, data, joint_force_references, jaxsim_only=True)
    return arrays.squeeze_env(tau, data.num_envs)


def tn_curve_fn(model, data) -> wp.array:
    """tau_lim (n,) or (N, n) [N m or N]: the bound of each joint's torque at its velocity, JaxSim's
    torque-speed curve (`model.actuation_params`: torque_max up to omega_th, falling linearly to 0 at
    omega_max)."""
    return arrays.squeeze_env(evaluations.torque_limits(model, data), data.num_envs)
