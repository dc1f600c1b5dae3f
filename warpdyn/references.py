"""Inputs of the dynamics: joint force references and external link forces, as JaxSim's references.

Storage (Warp, leading environment axis N, environment-fastest):
- joint_force_references_state (N, n) [N m or N].
- link_forces_state (N, nL, 6): external 6D forces on the links in the Inertial representation,
  W_f_L = [W_f; W_tau about the world origin] [N, N m].
Getters and setters read and write link forces in the references' velocity representation, with each
link (or frame, for frame forces) as the body frame: Body L_f_L, Mixed L[W]_f_L, Inertial W_f_L.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from . import arrays as _arrays
from . import frame, joint, link
from .common import ModelDataWithVelocityRepresentation
from .data import Data
from .engine import forces as link_forces_engine
from .engine import state as states
from .types.enums import VelRepr
from .types.model import transforms

__all__ = ["References", "JaxSimModelReferences"]


@dataclasses.dataclass(eq=False)
class References(ModelDataWithVelocityRepresentation):
    """Joint force references and link forces of `num_envs` environments (None: one environment).
    JaxSim's `JaxSimModelReferences` (also under that name); its methods take JaxSim's arguments, in
    JaxSim's order."""

    joint_force_references_state: wp.array
    link_forces_state: wp.array
    velocity_representation: VelRepr = VelRepr.Inertial
    num_envs: int | None = None

    @staticmethod
    def zero(model, data=None, velocity_representation=VelRepr.Inertial, *, num_envs=None) -> References:
        """References with zero joint forces and zero link forces."""
        if data is not None:
            num_envs = data.num_envs
        N = 1 if num_envs is None else num_envs
        s, d = model.scalar, model.device
        tau = _arrays.empty((model.dofs(),), N, s, d)
        tau.zero_()
        forces = _arrays.empty((model.number_of_links(), 6), N, s, d)
        forces.zero_()
        return References(tau, forces, VelRepr(velocity_representation), num_envs)

    @staticmethod
    def build(
        model,
        joint_force_references=None,
        link_forces=None,
        data=None,
        velocity_representation: VelRepr | None = None,
        *,
        num_envs: int | None = None,
    ) -> References:
        """References of `model` (as many environments as `data`, or `num_envs`).

        link_forces (nL, 6) or (N, nL, 6) are read in `velocity_representation` (default: the data's,
        or Inertial without data); data is needed unless that is Inertial.
        """
        if velocity_representation is None:
            velocity_representation = data.velocity_representation if data is not None else VelRepr.Inertial
        references = References.zero(model, data, velocity_representation=velocity_representation, num_envs=num_envs)
        if joint_force_references is not None:
            references = references.set_joint_force_references(joint_force_references, model)
        if link_forces is not None:
            references = references.apply_link_forces(link_forces, model, data)
        return references

    @property
    def batch_size(self) -> int:
        return self.joint_force_references_state.shape[0]

    def valid(self, model=None) -> bool:
        """Whether these references fit `model` (JaxSim's check): n joint forces and nL link forces per
        environment (always True without a model)."""
        if model is None:
            return True
        return self.joint_force_references_state.shape[1:] == (model.dofs(),) and self.link_forces_state.shape[1:] == (model.number_of_links(), 6)

    def _needs_data(self, data) -> None:
        if data is None and self.velocity_representation != VelRepr.Inertial:
            raise ValueError(f"link forces in the {self.velocity_representation.name} representation need `data`")

    def joint_force_references(self, model=None, joint_names=None) -> wp.array:
        """The joint force references: (n,) or (N, n); only the named joints' (k,) when given."""
        tau = self.joint_force_references_state
        if joint_names is not None:
            idxs = joint.names_to_idxs(model, joint_names=joint_names)
            tau = wp.array(tau.numpy()[:, idxs], dtype=tau.dtype, device=tau.device)
        return _arrays.squeeze_env(tau, self.num_envs)

    def set_joint_force_references(self, forces, model=None, joint_names=None) -> References:
        """New references with these joint forces (all joints, or the named ones), replacing the old."""
        N, n = self.batch_size, self.joint_force_references_state.shape[1]
        s, d = self.joint_force_references_state.dtype, self.joint_force_references_state.device
        if joint_names is None:
            tau = states.state_array(forces, "joint_force_references", (n,), None if self.num_envs is None else N, s, d)
        else:
            idxs = joint.names_to_idxs(model, joint_names=joint_names)
            host = self.joint_force_references_state.numpy().copy()
            given = forces.numpy() if isinstance(forces, wp.array) else _arrays.host_numbers(forces, "joint_force_references")
            host[:, idxs] = np.broadcast_to(given, (N, len(idxs)))
            tau = states.state_array(host if self.num_envs is not None else host[0], "joint_force_references", (n,), self.num_envs, s, d)
        return dataclasses.replace(self, joint_force_references_state=tau)

    def link_forces(self, model=None, data=None, link_names=None) -> wp.array:
        """Link forces in the references' representation: (nL, 6) or (N, nL, 6); (k, 6) for named links."""
        forces = self.link_forces_state
        if self.velocity_representation != VelRepr.Inertial:
            self._needs_data(data)
            forces = link_forces_engine.forces_in(model, data, forces, int(self.velocity_representation))
        if link_names is not None:
            idxs = link.names_to_idxs(model, link_names=link_names)
            forces = wp.array(forces.numpy()[:, idxs], dtype=forces.dtype, device=forces.device)
        return _arrays.squeeze_env(forces, self.num_envs)

    def _apply(self, forces, model, data, links: np.ndarray, link_H_target, name, additive) -> References:
        """References with forces (T, 6) on T targets, target t on link links[t] (host indices) at
        link_H_target[t] (T,) transforms."""
        self._needs_data(data)
        if data is None:
            data = Data.zero(model, num_envs=self.num_envs)
        values = _arrays.batched_input(forces, name, (len(links), 6), self.num_envs, model.scalar, model.device)
        repr = int(self.velocity_representation)
        out = link_forces_engine.with_target_forces(model, data, self.link_forces_state, links, link_H_target, values, repr, additive)
        return dataclasses.replace(self, link_forces_state=out)

    def apply_link_forces(self, forces, model=None, data=None, link_names=None, additive: bool = False) -> References:
        """New references with 6D forces (k, 6) on the named links (all when None), in the references'
        representation; they replace those links' forces, or add to them when `additive`."""
        if isinstance(link_names, str):
            link_names = (link_names,)
        if link_names is None:
            links = np.arange(model.number_of_links())
        else:
            links = np.asarray(link.names_to_idxs(model, link_names=link_names))
        return self._apply(forces, model, data, links, model.identity_offsets[: len(links)], "link_forces", additive)

    def apply_frame_forces(self, forces, model, data, frame_names=None, additive: bool = False) -> References:
        """New references with 6D forces (k, 6) on the named frames (all when None), in the references'
        representation with each frame as the body frame; each is moved to the frame's parent link,
        where it replaces (or adds to, when `additive`) that link's force."""
        if isinstance(frame_names, str):
            frame_names = (frame_names,)
        rows = np.arange(model.number_of_frames())
        if frame_names is not None:
            rows = frame.names_to_idxs(model, frame_names=frame_names) - model.number_of_links()
        offset = transforms(model.tree.link_H_frame[rows], model.scalar, model.device)
        return self._apply(forces, model, data, np.asarray(model.tree.frame_parent)[rows], offset, "frame_forces", additive)


JaxSimModelReferences = References
"""JaxSim's name of the references class."""
