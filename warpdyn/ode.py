"""JaxSim's `jaxsim.api.ode`: the system's equations of motion as derivatives of its state.

The terms are JaxSim's: the given joint torques, the link forces and the contact forces of
`model.contact_model`. An MJCF model's MuJoCo terms (passive joint forces, gravity compensation,
actuators) are not in them: `warpdyn.model.step` and `warpdyn.integrators` apply them.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from . import arrays
from .data import Data
from .engine import dynamics, evaluations
from .engine.forces import forces_in
from .math import Quaternion
from .references import References
from .types.contact_models import SoftContacts
from .types.enums import VelRepr

__all__ = ["system_acceleration", "system_position_dynamics", "system_dynamics"]


def system_acceleration(model, data: Data, *, link_forces=None, joint_torques=None) -> tuple[wp.array, wp.array, dict]:
    """(base acceleration (6,), joint accelerations (n,), the contact state's rates): forward dynamics with
    the joint torques (n,) [N m or N] (None: zero), the link forces (nL, 6) in the data's representation and
    the contact forces at the data's state. The base acceleration is the derivative of the base velocity in
    the data's representation; the rates are {"tangential_deformation": (rows, 3)} [m/s] (model.contact_state_rows()) (JaxSim's
    `update_contact_state` of the contact model's rates). Leading (N,) for batched data."""
    W_f_user = None
    if link_forces is not None:
        W_f_user = References.build(model, link_forces=link_forces, data=data, velocity_representation=data.velocity_representation).link_forces_state
    tau = None
    if joint_torques is not None and not isinstance(model.contact_model, SoftContacts):  # JaxSim's rigid models read them
        tau = arrays.batched_input(joint_torques, "joint_torques", (model.dofs(),), data.num_envs, model.scalar, model.device)
    _, m_dot, W_f_L = evaluations.contact_forces(model, data, W_f_user, tau)
    f_L = W_f_L if data.velocity_representation == VelRepr.Inertial else forces_in(model, data, W_f_L, int(data.velocity_representation))
    base, joints = dynamics.forward_dynamics_aba(model, data, joint_torques, arrays.squeeze_env(f_L, data.num_envs))
    rates = model.contact_model.update_contact_state({"m_dot": arrays.squeeze_env(m_dot, data.num_envs)})
    return base, joints, rates


def system_position_dynamics(data: Data, baumgarte_quaternion_regularization: float = 1.0, *, model=None) -> tuple[wp.array, wp.array, wp.array]:
    """(W_pdot_B (3,) [m/s], W_Qdot_B (4,), sdot (nq,)): the derivatives of the base position, of the base
    quaternion (w, x, y, z), normalised first, with JaxSim's Baumgarte term K |omega| (1 - |Q|) pulling its
    norm to 1 (K = `baumgarte_quaternion_regularization`), and of the joint positions: the joint velocities,
    but a ball joint's quaternion rate 1/2 Q (x) (0, omega) (omega in child axes) and a free joint's (v, that
    rate), for which warpdyn's `model` keyword is needed (the data alone does not say where they are). Leading
    (N,) for batched data. Computed on the host (NumPy), returned on the data's device."""
    v = np.asarray(data.base_velocity_state.numpy()).reshape(data.batch_size, 6)  # stored Mixed: [W_pdot_B; W_omega_WB]
    Q = np.asarray(data.base_quaternion_state.numpy()).reshape(data.batch_size, 4)
    Q = Q / np.linalg.norm(Q, axis=-1, keepdims=True)
    Q_dot = Quaternion.derivative(Q, v[:, 3:], omega_in_body_fixed=False, K=float(baumgarte_quaternion_regularization))
    out = (v[:, :3], Q_dot)
    device, scalar = data.device, data.scalar
    p_dot, q_dot = (arrays.squeeze_env(wp.array(x, dtype=scalar, device=device), data.num_envs) for x in out)
    if data.joint_positions_state.shape[1] == data.joint_velocities_state.shape[1]:
        return p_dot, q_dot, data.joint_velocities
    if model is None:
        raise ValueError("system_position_dynamics: the data has ball or free joints (more joint positions than velocities): pass model=")
    s_dot = _joint_position_rates(model, data.joint_positions_state.numpy(), data.joint_velocities_state.numpy())
    return p_dot, q_dot, arrays.squeeze_env(wp.array(s_dot, dtype=scalar, device=device), data.num_envs)


def _joint_position_rates(model, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(N, nq): the joints' position rates (kernels/integrators.py's joint_position_rate) at positions q (N, nq)
    and velocities v (N, nv), host NumPy."""
    tree = model.tree
    out = np.zeros_like(q)
    for i in range(1, tree.number_of_links):
        a, b, d = int(tree.q_start[i]), int(tree.q_start[i + 1]), int(tree.v_start[i])
        if b - a == 1:
            out[:, a] = v[:, d]
            continue
        r = 3 if b - a == 7 else 0
        out[:, a : a + r] = v[:, d : d + r]
        Q = q[:, a + r : b] / np.linalg.norm(q[:, a + r : b], axis=-1, keepdims=True)
        out[:, a + r : b] = Quaternion.derivative(Q, v[:, d + r : d + r + 3], omega_in_body_fixed=True, K=0.0)
    return out


def system_dynamics(model, data: Data, *, link_forces=None, joint_torques=None, baumgarte_quaternion_regularization: float = 1.0) -> dict:
    """The state's derivatives as JaxSim's dict: base_position (W_pdot_B), base_quaternion, joint_positions
    (sdot), base_linear_velocity and base_angular_velocity (the Inertial base acceleration W_vdot_WB, split),
    joint_velocities (sdot_dot), contact_state ({"tangential_deformation": m_dot}). Computed, as JaxSim's,
    with the data in the Inertial representation: link_forces (nL, 6) are read as Inertial forces."""
    with data.switch_velocity_representation(VelRepr.Inertial):
        base, joints, rates = system_acceleration(model, data, link_forces=link_forces, joint_torques=joint_torques)
        p_dot, q_dot, s_dot = system_position_dynamics(data, baumgarte_quaternion_regularization, model=model)
    linear, angular = (base[0:3], base[3:6]) if base.ndim == 1 else (base[:, 0:3], base[:, 3:6])
    return dict(
        base_position=p_dot,
        base_quaternion=q_dot,
        joint_positions=s_dot,
        base_linear_velocity=linear,
        base_angular_velocity=angular,
        joint_velocities=joints,
        contact_state=rates,
    )
