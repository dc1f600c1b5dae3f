"""The state of one or many environments of a model.

State arrays (Warp, on the model's device, in the model's scalar), each with a leading environment axis
N (N = 1 for single-environment data), stored environment-fastest (see warpdyn.arrays):
- base_position_state (N, 3): W_p_B [m].
- base_quaternion_state (N, 4): W_Q_B as (w, x, y, z).
- joint_positions_state (N, n): s [rad or m], in the model's joint order.
- base_velocity_state (N, 6): the base velocity in the Mixed representation, [W_pdot_B; W_omega_WB].
- joint_velocities_state (N, n): sdot [rad/s or m/s].
- tangential_deformation_state (N, rows, 3): the soft-contact state m [m] of every collidable point, then of each
  geom pair contact slot where model.geom_contacts is set (Model.contact_state_rows).
- valid_state (N,) int32: 1 while an environment's simulation is healthy, 0 once `step` flagged it.
The public properties below give these in JaxSim's shapes (no environment axis for single-environment
data) and in the data's velocity representation.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import warp as wp

from . import arrays
from .engine import state as states
from .engine import warp_private
from .types.data_checks import check_contact_state, check_data, check_state
from .types.enums import VelRepr
from .common import ModelDataWithVelocityRepresentation
from .joint import position_slice, random_generator, random_joint_positions, velocity_slice
from .math import Quaternion, Rotation
from .description.tree import JOINT_BALL, JOINT_FREE
from .types.model import quaternion_xyzw

__all__ = ["Data", "JaxSimModelData", "random_model_data", "keyframe"]

_STATE_FIELDS = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")
_NO_GRADS = (None,) * len(_STATE_FIELDS)  # Data.requires_grad: no state array has a .grad


@dataclasses.dataclass(eq=False)
class Data(ModelDataWithVelocityRepresentation):
    """The state of `num_envs` environments (None: one environment, with JaxSim's unbatched shapes).
    JaxSim's `JaxSimModelData` (also under that name): its constructors and methods take JaxSim's arguments,
    in JaxSim's order, and warpdyn's (num_envs, requires_grad, validate, envs) as keywords."""

    base_position_state: wp.array
    base_quaternion_state: wp.array
    joint_positions_state: wp.array
    base_velocity_state: wp.array
    joint_velocities_state: wp.array
    velocity_representation: VelRepr = VelRepr.Mixed
    num_envs: int | None = None
    tangential_deformation_state: wp.array | None = None
    valid_state: wp.array | None = None

    # Construction ------------------------------------------------------------------------------

    @staticmethod
    def build(
        model,
        base_position=None,
        base_quaternion=None,
        joint_positions=None,
        base_linear_velocity=None,
        base_angular_velocity=None,
        joint_velocities=None,
        contact_state: dict | None = None,
        velocity_representation: VelRepr = VelRepr.Mixed,
        *,
        num_envs: int | None = None,
        requires_grad: bool = False,
        validate: bool = True,
    ) -> Data:
        """Data of `model` for `num_envs` environments (None: one environment).

        Each argument is shared by all environments (JaxSim's shape) or given per environment (leading
        axis N); defaults are zero, with the identity quaternion (w, x, y, z) = (1, 0, 0, 0), except the
        base pose, which defaults to where the description welds a fixed base or places a floating one
        (`description.initial_world_H_base`: an SDF model's pose, an MJCF free body's), and the joint
        positions (nq,), which default to the description's initial positions (MuJoCo's qpos0: an MJCF
        joint's `ref`, a free body's pose; an SDF joint's `<initial_position>`; else 0 and identity
        quaternions). joint_velocities: (nv,). Base velocities are read in `velocity_representation`. contact_state: JaxSim's, {"tangential_deformation":
        (rows, 3) or (N, rows, 3) [m]} (rows: model.contact_state_rows(), JaxSim's nc_all but where geom_contacts
        adds the pairs' slots; default zero). NumPy-like inputs are checked on the host
        (finite; unit quaternion within 1e-6 when `validate`); Warp arrays are copied on the device,
        and checked on the host (a synchronisation) only when `validate` is set.
        """
        num_envs = arrays.num_envs_argument(num_envs)
        velocity_representation = VelRepr(velocity_representation)
        s, d, n, nq = model.scalar, model.device, model.dofs(), model.number_of_joint_coordinates()
        N = 1 if num_envs is None else int(num_envs)

        def state(value, name, shape, default=None):
            array = states.state_array(value, name, shape, num_envs, s, d, default)
            if validate and isinstance(value, wp.array) and not np.all(np.isfinite(array.numpy())):
                raise ValueError(f"{name} has non-finite values")
            return array

        default_position, default_quaternion = np.zeros(3), np.array([1.0, 0.0, 0.0, 0.0])
        placed = model.description.initial_world_H_base if model.floating_base() else model.description.world_H_base
        if placed is not None:
            default_position, default_quaternion = placed[:3, 3], _quaternion_wxyz(placed[:3, :3])
        quaternion = state(base_quaternion, "base_quaternion", (4,), default_quaternion)
        positions = state(joint_positions, "joint_positions", (nq,), model.tree.qpos0)
        if validate:
            _check_unit(quaternion.numpy(), "base_quaternion")
            host = positions.numpy() if len(model.joint_quaternions()) else None
            for start, name in zip(model.joint_quaternions(), _quaternion_joints(model)):
                _check_unit(host[:, start : start + 4], f"joint_positions of joint '{name}' (its quaternion at {start}:{start + 4})")
        position = state(base_position, "base_position", (3,), default_position)
        linear = state(base_linear_velocity, "base_linear_velocity", (3,))
        angular = state(base_angular_velocity, "base_angular_velocity", (3,))
        if requires_grad:
            linear.requires_grad = angular.requires_grad = True
        velocity = states.base_velocity_from(position, quaternion, linear, angular, int(velocity_representation))
        data = Data(
            base_position_state=position,
            base_quaternion_state=quaternion,
            joint_positions_state=positions,
            base_velocity_state=velocity,
            joint_velocities_state=state(joint_velocities, "joint_velocities", (n,)),
            velocity_representation=velocity_representation,
            num_envs=None if num_envs is None else N,
            tangential_deformation_state=_deformation(model, contact_state, num_envs, N),
            valid_state=wp.ones(N, dtype=wp.int32, device=d),
        )
        if not model.floating_base():
            data._require_static_base(model)
        if requires_grad:
            for name in (*_STATE_FIELDS, "tangential_deformation"):
                getattr(data, f"{name}_state").requires_grad = True
        return data

    @staticmethod
    def zero(model, velocity_representation: VelRepr = VelRepr.Mixed, *, num_envs: int | None = None) -> Data:
        """Data at the zero configuration, at rest, the base where `build` places it by default."""
        return Data.build(model, velocity_representation=velocity_representation, num_envs=num_envs)

    def _require_static_base(self, model) -> None:
        if np.any(self.base_velocity_state.numpy() != 0.0):
            raise ValueError(f"model '{model.name()}' has a fixed base: base velocities must be zero")

    # Shape and storage -------------------------------------------------------------------------

    @property
    def batch_size(self) -> int:
        """N, the number of environments the arrays hold (1 for single-environment data)."""
        return self.base_position_state.shape[0]

    @property
    def scalar(self):
        return self.base_position_state.dtype

    @property
    def dtype(self) -> np.dtype:
        return np.dtype(wp.dtype_to_numpy(self.scalar))

    @property
    def device(self):
        return self.base_position_state.device

    @property
    def requires_grad(self) -> bool:
        """Whether a state array (base pose and velocity, joint positions and velocities) requires gradients
        (has a .grad: Warp's setters keep the two together)."""
        state = (self.base_position_state, self.base_quaternion_state, self.joint_positions_state, self.base_velocity_state, self.joint_velocities_state)
        return warp_private.grads(state) != _NO_GRADS

    def _out(self, array: wp.array) -> wp.array:
        return arrays.squeeze_env(array, self.num_envs)

    # JaxSim's properties -----------------------------------------------------------------------

    @property
    def joint_positions(self) -> wp.array:
        """s: (nq,) or (N, nq) [rad or m; a ball or free joint's quaternion (w, x, y, z)]; a view of the state."""
        return self._out(self.joint_positions_state)

    @property
    def joint_velocities(self) -> wp.array:
        """sdot: (nv,) or (N, nv) [rad/s or m/s]; a view of the state."""
        return self._out(self.joint_velocities_state)

    @property
    def base_position(self) -> wp.array:
        """W_p_B: (3,) or (N, 3) [m]; a view of the state."""
        return self._out(self.base_position_state)

    @property
    def base_quaternion(self) -> wp.array:
        """W_Q_B as (w, x, y, z): (4,) or (N, 4); a view of the state."""
        return self._out(self.base_quaternion_state)

    @property
    def base_orientation(self) -> wp.array:
        """W_Q_B normalised, (w, x, y, z): (4,) or (N, 4) (as JaxSim: a quaternion, not a matrix)."""
        check_state(self)
        return self._out(states.normalized_quaternion(self, self.requires_grad))

    @property
    def base_transform(self) -> wp.array:
        """W_H_B: (4, 4) or (N, 4, 4)."""
        check_state(self)
        return self._out(states.base_transform(self, self.requires_grad))

    @property
    def base_velocity(self) -> wp.array:
        """The base velocity in the data's representation: (6,) or (N, 6), [linear; angular]."""
        check_state(self)
        return self._out(states.base_velocity_in(self, int(self.velocity_representation), self.requires_grad))

    @property
    def generalized_position(self) -> tuple[wp.array, wp.array]:
        """(W_H_B (4, 4), s (n,)), with a leading N axis for batched data."""
        return self.base_transform, self.joint_positions

    @property
    def generalized_velocity(self) -> wp.array:
        """nu = [base velocity in the data's representation; sdot]: (6 + n,) or (N, 6 + n)."""
        check_state(self)
        return self._out(states.generalized_velocity(self, int(self.velocity_representation), self.requires_grad))

    @property
    def contact_state(self) -> dict[str, wp.array]:
        """JaxSim's contact state: {"tangential_deformation": (rows, 3) or (N, rows, 3) [m]} for all points (and the
        geom pairs' contact slots: Model.contact_state_rows)."""
        return {"tangential_deformation": self._out(self.tangential_deformation_state)}

    @property
    def healthy(self) -> wp.array:
        """(N,) int32 ((1,) for single-environment data): 1 where the simulation is healthy, 0 where a step
        found a non-finite state, a state whose velocity is beyond model.divergence_speed, a quaternion step too
        large or parameters out of range, and stopped changing the environment (its state kept). The array is the state's `valid_state`."""
        return self.valid_state

    def valid(self, model) -> bool:
        """Whether this data fits `model` (JaxSim's check): its arrays' shapes, dtype and device are the
        model's, and they are consistent with each other (warpdyn.types.data_checks)."""
        try:
            check_data(model, self)
            check_contact_state(model, self)
        except (TypeError, ValueError):
            return False
        return True

    def copy(self) -> Data:
        """A copy with its own state arrays (copied on the device; those that require gradients still do)."""
        fields = {f"{name}_state": _clone(getattr(self, f"{name}_state")) for name in (*_STATE_FIELDS, "tangential_deformation", "valid")}
        return dataclasses.replace(self, **fields)

    def reset(self, model, envs, source: Data | None = None) -> Data:
        """New data in which the environments `envs` (indices or a boolean mask of length N) take their
        state from `source` (default: Data.zero) and are valid again; the others are unchanged."""
        check_data(model, self)
        source = Data.zero(model, velocity_representation=self.velocity_representation, num_envs=self.batch_size) if source is None else source
        check_data(model, source)
        if source.batch_size != self.batch_size:
            raise ValueError(f"source has {source.batch_size} environments, this data {self.batch_size}")
        if self.valid_state is None or source.tangential_deformation_state is None or self.tangential_deformation_state is None:
            raise ValueError("reset needs data with a contact state and a health flag (built by wd.data.Data.build)")
        mask = arrays.env_mask(envs, self.batch_size).astype(np.int32)
        selected = wp.array(mask, dtype=wp.int32, device=self.device)
        fields = {}
        for name in (*_STATE_FIELDS, "tangential_deformation"):
            mine, theirs = getattr(self, f"{name}_state"), getattr(source, f"{name}_state")
            fields[f"{name}_state"] = states.select_rows(selected, theirs, mine)
        valid = states.select_valid(selected, self.valid_state, self.scalar)
        return dataclasses.replace(self, **fields, valid_state=valid)

    # Changes -----------------------------------------------------------------------------------

    def reset_base_quaternion(self, model, base_quaternion) -> Data:
        """A new Data with the base orientation `base_quaternion` (w, x, y, z), normalised (JaxSim's)."""
        return self.replace(model, base_quaternion=base_quaternion)

    def reset_base_pose(self, model, base_pose) -> Data:
        """A new Data with the base pose W_H_B (4, 4), or (N, 4, 4) for batched data (JaxSim's)."""
        H = arrays.host_numbers(base_pose.numpy() if isinstance(base_pose, wp.array) else base_pose, "base_pose")
        if H.shape[-2:] != (4, 4) or H.ndim > 3:
            raise ValueError(f"base_pose must be a (4, 4) homogeneous transform, or (N, 4, 4), got shape {H.shape}")
        return self.replace(model, base_position=H[..., :3, 3], base_quaternion=Quaternion.from_dcm(H[..., :3, :3]))

    def replace(
        self,
        model,
        joint_positions=None,
        joint_velocities=None,
        base_quaternion=None,
        base_linear_velocity=None,
        base_angular_velocity=None,
        base_position=None,
        *,
        contact_state: dict | None = None,
        validate: bool = True,
        envs=None,
    ) -> Data:
        """A new Data with the given fields replaced (base velocities in the data's representation), JaxSim's:
        the base quaternion is normalised (a zero or non-finite one is a ValueError), contact_state is
        {"tangential_deformation": (rows, 3) or (N, rows, 3)} (Model.contact_state_rows). validate: check the values on the host
        (warpdyn's default; JaxSim's `validate`, off by default there, checks its pytree's shapes). envs
        (warpdyn's): the environments to change (indices or a boolean mask of length N); the others keep their
        state. A base velocity given without its other half keeps that half from this data (in its
        representation); without either, the Inertial base velocity is kept, as JaxSim's (a moved base then has
        another Body or Mixed velocity).
        """
        check_data(model, self)
        if base_quaternion is not None:
            base_quaternion = _normalised(base_quaternion)
        if joint_positions is not None and len(model.joint_quaternions()):
            joint_positions = arrays.host_numbers(joint_positions.numpy() if isinstance(joint_positions, wp.array) else joint_positions, "joint_positions").copy()
            for start, name in zip(model.joint_quaternions(), _quaternion_joints(model)):
                if joint_positions.shape[-1] > start + 3:
                    joint_positions[..., start : start + 4] = _normalised(joint_positions[..., start : start + 4], f"joint_positions of joint '{name}'")
        if envs is not None:
            arrays.env_mask(envs, self.batch_size)  # checked before any work
        current_base = self.base_velocity.numpy().reshape(self.batch_size, 6)
        if base_linear_velocity is None and base_angular_velocity is not None:
            base_linear_velocity = current_base[:, :3]
        if base_angular_velocity is None and base_linear_velocity is not None:
            base_angular_velocity = current_base[:, 3:]
        values = {
            "base_position": base_position,
            "base_quaternion": base_quaternion,
            "joint_positions": joint_positions,
            "joint_velocities": joint_velocities,
        }
        current = {name: getattr(self, f"{name}_state").numpy() for name in values}
        kwargs = {}
        for name, value in values.items():
            kwargs[name] = current[name] if value is None else value
        given_in = self.velocity_representation
        if base_linear_velocity is None and base_position is None:
            given_in = VelRepr.Mixed  # the base's origin has not moved: its stored (Mixed) velocity, bit for bit
            kept = self.base_velocity_state.numpy().reshape(self.batch_size, 6)
            kwargs["base_linear_velocity"] = kept[:, :3]
            kwargs["base_angular_velocity"] = kept[:, 3:]
        elif base_linear_velocity is None:  # JaxSim's: the Inertial base velocity is kept as the base moves
            given_in = VelRepr.Inertial
            W_v = states.base_velocity_in(self, int(VelRepr.Inertial), False).numpy().reshape(self.batch_size, 6)
            kwargs["base_linear_velocity"] = W_v[:, :3]
            kwargs["base_angular_velocity"] = W_v[:, 3:]
        else:
            kwargs["base_linear_velocity"] = base_linear_velocity
            kwargs["base_angular_velocity"] = base_angular_velocity
        new = Data.build(
            model,
            **{k: _per_env(v, self.batch_size, k) for k, v in kwargs.items()},
            velocity_representation=given_in,
            num_envs=self.batch_size,
            validate=validate,
        )
        new.velocity_representation = self.velocity_representation
        if envs is not None:
            keep = ~arrays.env_mask(envs, self.batch_size)
            for name in _STATE_FIELDS:
                old, fresh = getattr(self, f"{name}_state").numpy(), getattr(new, f"{name}_state").numpy()
                fresh[keep] = old[keep]
                getattr(new, f"{name}_state").assign(wp.array(fresh, dtype=self.scalar, device=self.device))
        new.num_envs = self.num_envs
        new.tangential_deformation_state = self.tangential_deformation_state
        if contact_state is not None:
            deformation = _deformation(model, contact_state, self.num_envs, self.batch_size)
            if envs is not None:  # the other environments keep theirs
                fresh = deformation.numpy()
                fresh[keep] = self.tangential_deformation_state.numpy()[keep]
                deformation.assign(wp.array(fresh, dtype=self.scalar, device=self.device))
            new.tangential_deformation_state = deformation
        new.valid_state = self.valid_state
        return new


JaxSimModelData = Data
"""JaxSim's name of the data class."""


def keyframe(model, name: str, *, velocity_representation: VelRepr = VelRepr.Mixed, num_envs: int | None = None) -> Data:
    """Data at the description's keyframe `name` (MJCF `<key>`; `model.keyframe_names()`), in every environment:
    MuJoCo's qpos and qvel mapped by joint name, the floating base's free joint to the base (its angular
    velocity, in the body's axes in MuJoCo's qvel, converted), a ball or free joint's numbers as they are.
    Joints a reduction locked keep their locked positions (the keyframe's are not read); a ValueError names an
    unknown keyframe."""
    frames = {k.name: k for k in model.description.keyframes}
    if name not in frames:
        raise ValueError(f"model '{model.name()}' has no keyframe '{name}'; its keyframes: {list(frames)}")
    key = frames[name]
    kwargs: dict = {}
    positions = np.array(model.tree.qpos0, dtype=np.float64)
    velocities = np.zeros(model.dofs())
    index = {joint: k for k, joint in enumerate(model.joint_names())}
    for joint, kind, qposadr, dofadr in model.description.mujoco_joints:
        nq, nv = {"free": (7, 6), "ball": (4, 3)}.get(kind, (1, 1))
        q, v = key.qpos[qposadr : qposadr + nq], key.qvel[dofadr : dofadr + nv]
        if joint in index:
            positions[position_slice(model, joint_index=index[joint])] = q
            velocities[velocity_slice(model, joint_index=index[joint])] = v
        elif kind == "free" and model.floating_base():  # the base's own: MuJoCo's angular velocity is in body axes
            Q = q[3:] / np.linalg.norm(q[3:])
            kwargs.update(base_position=q[:3], base_quaternion=Q, base_linear_velocity=v[:3], base_angular_velocity=Quaternion.to_dcm(Q) @ v[3:])
    data = Data.build(model, joint_positions=positions, joint_velocities=velocities, velocity_representation=VelRepr.Mixed, num_envs=num_envs, **kwargs)
    data.velocity_representation = VelRepr(velocity_representation)
    return data


def _deformation(model, contact_state: dict | None, num_envs: int | None, N: int) -> wp.array:
    """The tangential deformation state (N, rows, 3) of JaxSim's contact_state (None: zero; rows:
    Model.contact_state_rows)."""
    rows = (model.contact_state_rows(), 3)
    if contact_state is None:
        return arrays.zeros(rows, N, model.scalar, model.device)
    if not isinstance(contact_state, dict) or set(contact_state) - {"tangential_deformation"}:
        raise ValueError(f"contact_state must be {{'tangential_deformation': (rows, 3) array}} (the soft contacts' state; rows: model.contact_state_rows()), got {contact_state!r:.200}")
    return states.state_array(contact_state.get("tangential_deformation"), "contact_state['tangential_deformation']", rows, num_envs, model.scalar, model.device)


def _normalised(quaternion, name: str = "base_quaternion") -> np.ndarray:
    """A quaternion (4,) or (N, 4) divided by its norm (JaxSim's replace); a zero or non-finite one is refused."""
    host = arrays.host_numbers(quaternion.numpy() if isinstance(quaternion, wp.array) else quaternion, name)
    norm = np.linalg.norm(host, axis=-1, keepdims=True)
    if host.shape[-1:] != (4,) or not np.all(np.isfinite(host)) or np.any(norm == 0.0):
        raise ValueError(f"{name} must be finite, non-zero (w, x, y, z) quaternions (normalised here), got {host.tolist()!r:.200}")
    return host / norm


def _check_unit(quaternions: np.ndarray, name: str) -> None:
    """A ValueError naming `name` and the environments whose quaternions (N, 4) are not of unit norm (1e-6)."""
    norms = np.linalg.norm(quaternions, axis=-1)
    bad = np.flatnonzero(np.abs(norms - 1.0) > 1e-6)
    if bad.size:
        raise ValueError(f"{name} must be a unit quaternion (w, x, y, z): environment(s) {bad[:10].tolist()} have norm {norms[bad[:10]].tolist()}")


def _quaternion_joints(model) -> list[str]:
    """The names of the ball and free joints, in the order of `model.joint_quaternions()`."""
    kinds = model.tree.joint_type[1:]
    return [name for name, kind in zip(model.joint_names(), kinds) if kind in (JOINT_BALL, JOINT_FREE)]


def _clone(array: wp.array | None) -> wp.array | None:
    """A copy of a per-environment array in the device's layout (warpdyn.arrays: environment-fastest on GPUs,
    which wp.clone, making a contiguous array, would lose)."""
    if array is None:
        return None
    copy = arrays.empty(tuple(array.shape[1:]), array.shape[0], array.dtype, array.device, requires_grad=array.requires_grad)
    wp.copy(copy, array)
    return copy


def _per_env(value, N: int, name: str) -> np.ndarray:
    """`value` (the argument `name`) as a host array with a leading environment axis of N."""
    host = value.numpy() if isinstance(value, wp.array) else arrays.host_numbers(value, name)
    return host if host.ndim == 2 and host.shape[0] == N else np.broadcast_to(host, (N, *host.shape[-1:]))


def _euler(seq: str, angles: np.ndarray) -> np.ndarray:
    """Rotation matrices (N, 3, 3) of Euler angles (N, 3) in scipy's `seq`: three of 'XYZ' (intrinsic
    rotations, about the moving axes: R = R1 R2 R3) or of 'xyz' (extrinsic, about the fixed axes:
    R = R3 R2 R1)."""
    if not isinstance(seq, str) or len(seq) != 3 or not (set(seq) <= set("XYZ") or set(seq) <= set("xyz")) or seq[0] == seq[1] or seq[1] == seq[2]:
        raise ValueError(f"base_rpy_seq must be three axes of 'XYZ' (intrinsic) or of 'xyz' (extrinsic), no axis twice in a row, got {seq!r}")
    about = {"x": Rotation.x, "y": Rotation.y, "z": Rotation.z}
    rotations = [about[axis.lower()](angles[:, k]) for k, axis in enumerate(seq)]
    if seq.isupper():
        return rotations[0] @ rotations[1] @ rotations[2]
    return rotations[2] @ rotations[1] @ rotations[0]


def _quaternion_wxyz(R: np.ndarray) -> np.ndarray:
    x, y, z, w = quaternion_xyzw(R)
    return np.array([w, x, y, z])


def random_model_data(
    model,
    *,
    key=None,
    velocity_representation: VelRepr | None = None,
    base_pos_bounds=((-1.0, -1.0, 0.5), 1.0),
    base_rpy_bounds=(-np.pi, np.pi),
    base_rpy_seq: str = "XYZ",
    joint_pos_bounds=None,
    base_vel_lin_bounds=(-1.0, 1.0),
    base_vel_ang_bounds=(-1.0, 1.0),
    joint_vel_bounds=(-1.0, 1.0),
    num_envs: int | None = None,
    requires_grad: bool = False,
) -> Data:
    """Random data, drawn uniformly within JaxSim's bounds: JaxSim's `random_model_data`, and warpdyn's
    num_envs (one draw per environment) and requires_grad.

    key: JaxSim's random key (None: seed 0), an integer seed, a NumPy Generator or a JAX PRNG key
    (`wd.joint.random_generator`): the same distributions as JaxSim, not the same numbers. The base
    orientation is drawn as Euler angles within base_rpy_bounds in scipy's `base_rpy_seq` ('XYZ':
    intrinsic). Joint positions: within the model's position limits (`wd.joint.random_joint_positions`,
    per environment when the limits are), or within `joint_pos_bounds`. The base pose and velocity are
    drawn for floating-base models only: a welded base stays where the model welds it (JaxSim also draws a
    welded base's pose); base velocities are in `velocity_representation` (default Mixed). Ball and free
    joints: `wd.joint.random_joint_positions` (joint_pos_bounds bound the one-DoF joints' positions).
    """
    num_envs = arrays.num_envs_argument(num_envs)
    rng = random_generator(key)
    N = 1 if num_envs is None else num_envs
    n, nq = model.dofs(), model.number_of_joint_coordinates()
    velocity_representation = VelRepr.Mixed if velocity_representation is None else VelRepr(velocity_representation)

    def uniform(bounds, shape):
        low, high = (np.broadcast_to(arrays.host_numbers(b, "bounds"), shape[-1:]) for b in bounds)
        return rng.uniform(low, high, size=shape)

    kwargs = {}
    if model.floating_base():
        kwargs["base_position"] = uniform(base_pos_bounds, (N, 3))
        R = _euler(base_rpy_seq, uniform(base_rpy_bounds, (N, 3)))
        kwargs["base_quaternion"] = np.array([_quaternion_wxyz(r) for r in R])
        kwargs["base_linear_velocity"] = uniform(base_vel_lin_bounds, (N, 3))
        kwargs["base_angular_velocity"] = uniform(base_vel_ang_bounds, (N, 3))
    if n > 0:
        kwargs["joint_positions"] = random_joint_positions(model, key=rng, num_envs=N)
        if joint_pos_bounds is not None:  # the bounds replace the limits of one-DoF joints (quaternions stay random)
            one_dof = np.ones(nq, dtype=bool)
            for start in model.joint_quaternions():
                one_dof[start : start + 4] = False
            for i, kind in enumerate(model.tree.joint_type):
                if kind == JOINT_FREE:
                    one_dof[model.tree.q_start[i] : model.tree.q_start[i] + 3] = False
            drawn = uniform(joint_pos_bounds, (N, int(one_dof.sum())))
            kwargs["joint_positions"][:, one_dof] = drawn
        kwargs["joint_velocities"] = uniform(joint_vel_bounds, (N, n))
    if num_envs is None:
        kwargs = {k: v[0] for k, v in kwargs.items()}
    return Data.build(
        model,
        **kwargs,
        velocity_representation=velocity_representation,
        num_envs=num_envs,
        requires_grad=requires_grad,
    )
