"""The model: the constants of a robot on a Warp device, and the functions of the whole model.

Link order: breadth-first from the base (parent index < child index). Joint i moves link i + 1.
Frame indices follow the link indices: frame k has index number_of_links() + k (as in JaxSim).
"""

from __future__ import annotations

import numpy as np
import warp as wp

from .engine import launch as launching
from . import arrays as _arrays
from .types.enums import VelRepr, output_repr  # noqa: F401  (VelRepr stays importable as wd.model.VelRepr)
from .description.collidable import warn_without_points
from .description import ModelDescription, load
from .kernels.jacobians import kernels as jacobian_kernels
from .kernels.kinematics import kernels as kinematics_kernels
from .kernels.velocities import kernels as velocity_kernels
from .description.tree import KinematicTree, build_tree

__all__ = [
    "Model",
    "reduce",
    "total_mass",
    "parameters_requiring_grad",
    "forward_kinematics",
    "joint_transforms",
    "generalized_free_floating_jacobian",
    "average_velocity",
    "average_velocity_jacobian",
    "kinetic_energy",
    "link_spatial_inertia_matrices",
    "locked_spatial_inertia",
    "mechanical_energy",
    "potential_energy",
    "total_momentum",
    "total_momentum_jacobian",
    "ActuationParams",
    "IntegratorType",
    "SoftContactsParams",
    "step",
    "free_floating_coriolis_matrix",
    "generalized_free_floating_jacobian_derivative",
    "link_bias_accelerations",
    "forward_dynamics",
    "forward_dynamics_aba",
    "forward_dynamics_crb",
    "free_floating_mass_matrix_inverse",
    "free_floating_bias_forces",
    "free_floating_gravity_forces",
    "free_floating_mass_matrix",
    "inverse_dynamics",
]

_SCALARS = {np.dtype(np.float32): wp.float32, np.dtype(np.float64): wp.float64}


def _transforms(H: np.ndarray, scalar, device) -> wp.array:
    """Warp transforms (p, quaternion xyzw) of homogeneous matrices (K, 4, 4)."""
    H = np.asarray(H, dtype=np.float64).reshape(-1, 4, 4)
    rows = np.zeros((len(H), 7))
    for k, M in enumerate(H):
        rows[k, :3] = M[:3, 3]
        rows[k, 3:] = _quaternion_xyzw(M[:3, :3])
    return wp.array(rows, dtype=wp.types.transformation(scalar), device=device)


def _quaternion_xyzw(R: np.ndarray) -> np.ndarray:
    """Unit quaternion (x, y, z, w) of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0.0:
        s = 2.0 * np.sqrt(1.0 + t)
        q = [(R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s, 0.25 * s]
    else:
        i = int(np.argmax(np.diag(R)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * np.sqrt(max(1.0 + R[i, i] - R[j, j] - R[k, k], 1e-300))
        q = [0.0, 0.0, 0.0, (R[k, j] - R[j, k]) / s]
        q[i] = 0.25 * s
        q[j] = (R[j, i] + R[i, j]) / s
        q[k] = (R[k, i] + R[i, k]) / s
    q = np.asarray(q)
    return q / np.linalg.norm(q)


def _check_finite(name: str, host: np.ndarray) -> None:
    if not np.all(np.isfinite(host)):
        raise ValueError(f"{name} has non-finite values")


def _check_non_negative(name: str, host: np.ndarray) -> None:
    _check_finite(name, host)
    if np.any(host < 0.0):
        raise ValueError(f"{name} must be non-negative, got entries {host[host < 0.0][:5].tolist()}")


def _check_inertia(name: str, host: np.ndarray) -> None:
    """Symmetric positive semi-definite (3, 3) matrices, to a relative tolerance of 1e-9."""
    _check_finite(name, host)
    scale = max(float(np.abs(host).max(initial=0.0)), 1e-300)
    if np.abs(host - np.swapaxes(host, -1, -2)).max(initial=0.0) > 1e-9 * scale:
        raise ValueError(f"{name} must hold symmetric matrices")
    if np.linalg.eigvalsh(host).min(initial=0.0) < -1e-9 * scale:
        raise ValueError(f"{name} must hold positive semi-definite matrices")


def _sibling_chains(parent: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """first_child (nL,) and next_sibling (nL,), -1 where there is none; siblings in index order."""
    first_child = np.full(len(parent), -1, dtype=np.int32)
    next_sibling = np.full(len(parent), -1, dtype=np.int32)
    for i in range(len(parent) - 1, 0, -1):
        next_sibling[i] = first_child[parent[i]]
        first_child[parent[i]] = i
    return first_child, next_sibling


class Model:
    """A robot's constants on a Warp device, in one scalar type (float32 or float64).

    Build it with `Model.build_from_model_description`. The host-side tree (`model.tree`, NumPy float64)
    holds the description's constants; the Warp arrays below are what kernels read:
    parent (nL,) int, joint_type (nL,) int, X_tree (nL,) transform (joint frame in the parent link),
    joint_axis, joint_pivot (nL,) vec3 (link frame), support (nL, n) int, link_mass (nL,) [kg],
    link_com (nL,) vec3 [m, link frame], link_inertia (nL,) mat33 [kg m^2, about the CoM, link axes],
    frame_parent (nF,) int, link_H_frame (nF,) transform, first_child and next_sibling (nL,) int
    (-1 for none: the sibling chains that backward passes sum over).

    The inertial parameters (`set_link_parameters`) and the joints' friction and limit gains
    (`set_joint_parameters`) are shared by all environments or given per environment (domain
    randomisation): then link_mass is (N, nL), link_com and link_inertia (N, nL), friction_static etc.
    (N, n), and the model serves data of N environments only.
    """

    def __init__(
        self,
        description: ModelDescription,
        tree: KinematicTree,
        *,
        model_name: str,
        gravity: float,
        time_step: float,
        dtype,
        device,
    ):
        self.description = description
        self.tree = tree
        self.model_name = model_name
        self.gravity = float(gravity)
        self.time_step = float(time_step)
        self.dtype = np.dtype(dtype)
        self.scalar = _SCALARS[self.dtype]
        self.device = wp.get_device(device)
        s, d = self.scalar, self.device
        sp_vec3 = wp.types.vector(3, s)
        self.parent = wp.array(tree.parent, dtype=int, device=d)
        self.joint_type = wp.array(tree.joint_type, dtype=int, device=d)
        self.X_tree = _transforms(tree.parent_H_joint, s, d)
        self.joint_axis = wp.array(tree.joint_axis, dtype=sp_vec3, device=d)
        self.joint_pivot = wp.array(tree.joint_pivot, dtype=sp_vec3, device=d)
        self.support = wp.array(tree.support().reshape(tree.number_of_links, tree.dofs), dtype=int, device=d)
        self._per_env_parameters: dict[str, int] = {}
        self._kernel_views: dict[str, tuple] = {}
        self._set_link_parameters(tree.link_mass, tree.link_com, tree.link_inertia, checked=False)
        self.frame_parent = wp.array(tree.frame_parent, dtype=int, device=d)
        self.link_H_frame = _transforms(tree.link_H_frame, s, d)
        first_child, next_sibling = _sibling_chains(tree.parent)
        self.first_child = wp.array(first_child, dtype=int, device=d)
        self.next_sibling = wp.array(next_sibling, dtype=int, device=d)
        self.all_links = wp.array(np.arange(tree.number_of_links), dtype=int, device=d)
        self._init_simulation()
        self.identity_offsets = _transforms(np.tile(np.eye(4), (tree.number_of_links, 1, 1)), s, d)

    def _init_simulation(self) -> None:
        """JaxSim's defaults for `step`: flat terrain at z = 0, soft contacts (K = 1e6, D = 2000, mu = 0.5,
        p = q = 0.5), semi-implicit Euler, joint friction from the description (static: <friction>,
        viscous: <damping>), joint-limit springs off (stiffness 0), JaxSim's torque-speed curve."""
        from .types.enums import IntegratorType
        from .types.settings import ActuationParams, SoftContactsParams
        from .types.terrain import FlatTerrain

        self.terrain = FlatTerrain()
        self.contact_params = SoftContactsParams()
        self.integrator = IntegratorType.SemiImplicitEuler
        self.actuation_params = ActuationParams()
        self.quaternion_tolerance = 0.1
        n = self.tree.dofs
        self.set_joint_parameters(
            position_limits=self.tree.position_limits.reshape(n, 2),
            limit_spring=np.zeros(n),
            limit_damper=np.zeros(n),
            friction_static=self.tree.friction,
            friction_viscous=self.tree.damping,
        )

    def set_joint_parameters(
        self, *, position_limits=None, limit_spring=None, limit_damper=None, friction_static=None, friction_viscous=None
    ) -> None:
        """Set joint parameters of `step`; None keeps one.

        position_limits (n, 2) [rad or m], shared. limit_spring [N m/rad or N/m] and limit_damper [s/rad or
        s/m]: the limit spring-damper of JaxSim (off where the spring is 0); friction_static [N m or N] and
        friction_viscous [N m s/rad or N s/m]: each (n,), shared by all environments, or (N, n), one row per
        environment (see `set_link_parameters` on per-environment parameters). Each value given makes a new
        Warp array (`model.joint_limit_spring`, ...; `model.<name>_host` holds its NumPy copy).
        """
        n = self.tree.dofs
        if position_limits is not None:
            host = np.asarray(position_limits, dtype=np.float64)
            if host.shape != (n, 2):
                raise ValueError(f"position_limits has shape {host.shape}, expected {(n, 2)}")
            if np.any(np.isnan(host)) or np.any(host[:, 0] > host[:, 1]):
                raise ValueError("position_limits must be (lower, upper) pairs with lower <= upper")
            self.position_limits_host = host.copy()
            self.position_limits = wp.array(host, dtype=self.scalar, device=self.device)
        values = {
            "joint_limit_spring": limit_spring,
            "joint_limit_damper": limit_damper,
            "friction_static": friction_static,
            "friction_viscous": friction_viscous,
        }
        for name, value in values.items():
            if value is not None:
                self._set_parameter(name, value, n, (), self.scalar, _check_non_negative)

    def set_link_parameters(self, *, mass=None, com=None, inertia=None) -> None:
        """Set the links' inertial parameters; None keeps one.

        mass (nL,) [kg], com (nL, 3) [m, link frame], inertia (nL, 3, 3) [kg m^2, about the CoM, link axes],
        in the order of `link_names()` (lumped links included), shared by all environments; or with a
        leading axis of N environments, (N, nL), (N, nL, 3), (N, nL, 3, 3): domain randomisation, one
        row per environment, read by every dynamics function, `step` and rollouts. A model with
        per-environment parameters serves data of those N environments only (a ValueError otherwise), and
        its gradients (`parameters_requiring_grad`) come back per environment. Masses must be non-negative,
        inertias symmetric positive semi-definite. Each value given makes a new Warp array
        (`model.link_mass`, ...; `model.<name>_host` holds its NumPy copy).
        """
        self._set_link_parameters(mass, com, inertia, checked=True)

    def _set_link_parameters(self, mass, com, inertia, checked: bool) -> None:
        """checked=False for the description's values (loading a model does not judge its inertias)."""
        nL = self.tree.number_of_links
        s = self.scalar
        values = {
            "link_mass": (mass, (), s, _check_non_negative),
            "link_com": (com, (3,), wp.types.vector(3, s), _check_finite),
            "link_inertia": (inertia, (3, 3), wp.types.matrix((3, 3), s), _check_inertia),
        }
        for name, (value, item, dtype, check) in values.items():
            if value is not None:
                self._set_parameter(name, value, nL, item, dtype, check if checked else None)

    def _set_parameter(self, name: str, value, count: int, item: tuple, dtype, check) -> None:
        """Store a parameter given shared (count, *item) or per environment (N, count, *item)."""
        try:
            host = np.array(value, dtype=np.float64)
        except (TypeError, ValueError) as error:
            raise TypeError(f"{name} must be an array of numbers: {error}") from None
        shared = (count, *item)
        if check is not None and host.shape[-len(shared) :] == shared:
            check(name, host)
        if host.shape == shared:
            array = wp.array(host, dtype=dtype, device=self.device)
            self._per_env_parameters.pop(name, None)
        elif host.ndim == len(shared) + 1 and host.shape[1:] == shared and host.shape[0] >= 1:
            N = host.shape[0]
            others = {k: v for k, v in self._per_env_parameters.items() if k != name and v != N}
            if others:
                raise ValueError(f"{name} is given for {N} environments but {others} for other numbers: one N per model")
            array = _arrays.empty((count,), N, dtype, self.device)
            array.assign(wp.array(host, dtype=dtype, device=self.device))
            self._per_env_parameters[name] = N
        else:
            per_env = "(N, " + ", ".join(str(k) for k in shared) + ")"
            raise ValueError(f"{name} has shape {host.shape}, expected {shared} (shared) or {per_env} (per environment)")
        setattr(self, f"{name}_host", host)
        setattr(self, name, array)

    def per_environment_parameters(self) -> dict[str, int]:
        """{name: N} of the link and joint parameters given per environment (empty when all are shared)."""
        return dict(self._per_env_parameters)

    def kernel_parameter(self, name: str) -> wp.array:
        """The (P, count) view of a link or joint parameter that kernels read (P = 1 shared, N per
        environment, see kernels/spatial.mass_of), with its gradient; cached until the array or its gradient
        is replaced."""
        array = getattr(self, name)
        cached = self._kernel_views.get(name)
        if cached is not None and cached[0] is array and cached[1] is array.grad:
            return cached[2]
        view = array if name in self._per_env_parameters else array.reshape((1, *array.shape))
        self._kernel_views[name] = (array, array.grad, view)
        return view

    @classmethod
    def build_from_model_description(
        cls,
        model_description,
        *,
        model_name: str | None = None,
        considered_joints: list[str] | None = None,
        is_urdf: bool | None = None,
        fixed_base: bool | None = None,
        base_pose=None,
        gravity: float = 9.81,
        time_step: float = 0.001,
        dtype=np.float32,
        device=None,
    ) -> Model:
        """Build a model from a URDF or MJCF: a path, an XML string or XML bytes (any encoding its XML
        declaration names).

        Fixed joints are lumped (their child links become frames); only `considered_joints` are kept
        when given (the others are locked at 0 and lumped). fixed_base: None keeps the description's base
        (welded to a `world` link, or floating); True welds the base to the world at `base_pose`, a (4, 4)
        homogeneous transform W_H_B [m] (default: the description's weld, else the identity; an MJCF free
        joint becomes a weld); False frees a base the description welds. gravity [m/s^2] acts along -z of
        the world. dtype: np.float32 (the default) or np.float64, the scalar of every computation.
        device: a Warp device (default: Warp's default device, a GPU when there is one).
        """
        if np.dtype(dtype) not in _SCALARS:
            raise TypeError(f"dtype must be np.float32 or np.float64, got {dtype!r}")
        if not np.isfinite(gravity):
            raise ValueError(f"gravity must be finite, got {gravity}")
        if not (np.isfinite(time_step) and time_step > 0.0):
            raise ValueError(f"time_step must be positive and finite, got {time_step}")
        description = load(model_description, is_urdf=is_urdf, fixed_base=fixed_base, base_pose=base_pose)
        tree = build_tree(description, considered_joints)
        model = cls(
            description,
            tree,
            model_name=model_name if model_name is not None else description.name,
            gravity=gravity,
            time_step=time_step,
            dtype=dtype,
            device=device,
        )
        if model.floating_base():
            warn_without_points(model.model_name, tree, stacklevel=2)
        return model

    def __repr__(self) -> str:
        return (
            f"Model(name={self.model_name!r}, links={self.number_of_links()}, joints={self.number_of_joints()}, "
            f"floating_base={self.floating_base()}, dtype={self.dtype.name}, device='{self.device}')"
        )

    # Queries, with JaxSim's names.
    def name(self) -> str:
        return self.model_name

    def number_of_links(self) -> int:
        return self.tree.number_of_links

    def number_of_joints(self) -> int:
        return self.tree.dofs

    def number_of_frames(self) -> int:
        return len(self.tree.frame_names)

    def dofs(self) -> int:
        return self.tree.dofs

    def link_names(self) -> tuple[str, ...]:
        return tuple(self.tree.link_names)

    def joint_names(self) -> tuple[str, ...]:
        return tuple(self.tree.joint_names)

    def frame_names(self) -> tuple[str, ...]:
        return tuple(self.tree.frame_names)

    def floating_base(self) -> bool:
        return not self.description.fixed_base

    def base_link(self) -> str:
        return self.tree.link_names[0]

    @property
    def kin_dyn_parameters(self):
        """JaxSim's `kin_dyn_parameters` (host-side, NumPy): `.contact_parameters` (body, point, enabled of
        the collidable points), `.frame_parameters`, `.link_names`, `.parent_array`, `.support_body_array_bool`.

        Built on first use (cached) with the default `warpdyn.contact.CollidablePointsOptions`; see
        `warpdyn.contact.with_collidable_points` for other options or enabled points.
        """
        params = self.__dict__.get("_kin_dyn_parameters")
        if params is None:
            from .types.kin_dyn import KinDynParameters

            params = self.__dict__["_kin_dyn_parameters"] = KinDynParameters.build(self)
        return params


def reduce(model: Model, considered_joints, locked_joint_positions: dict | None = None) -> Model:
    """A model keeping only `considered_joints`; the others are fixed at `locked_joint_positions` (default 0).

    Joints already locked in `model` keep their locked positions. The new model is built from the
    description (lumping changes the links): parameters set on `model` (set_link_parameters,
    set_joint_parameters, contact_params, terrain, integrator) are not carried over; set them on the result.
    """
    considered_joints = list(considered_joints)
    unknown = [name for name in considered_joints if name not in model.joint_names()]
    if unknown:
        raise ValueError(f"considered_joints names joints that model '{model.name()}' does not have: {unknown}")
    locked = dict(model.tree.locked_joints)
    for name, value in (locked_joint_positions or {}).items():
        if name not in model.joint_names() or name in considered_joints:
            raise ValueError(f"locked_joint_positions names '{name}', which is not a joint this reduction locks")
        locked[name] = float(value)
    tree = build_tree(model.description, considered_joints, locked)
    return Model(
        model.description,
        tree,
        model_name=model.model_name,
        gravity=model.gravity,
        time_step=model.time_step,
        dtype=model.dtype,
        device=model.device,
    )


def total_mass(model: Model):
    """The total mass of the model [kg]: a float, or (N,) when the masses are given per environment."""
    total = np.sum(model.link_mass.numpy(), axis=-1)  # the array (edited in place or not), not a host copy
    return float(total) if total.ndim == 0 else total


def parameters_requiring_grad(model: Model, names=("link_mass", "link_com", "link_inertia")) -> dict:
    """Mark model parameters whose gradients a wp.Tape should compute; returns {name: Warp array}.

    names, any of: "link_mass" (nL,) [kg], "link_com" (nL,) vec3 [m, link frame], "link_inertia" (nL,)
    mat33 [kg m^2, about the CoM] (see Model.set_link_parameters), "friction_static", "friction_viscous",
    "joint_limit_spring", "joint_limit_damper" (n,) (see Model.set_joint_parameters), each with a leading
    (N,) when given per environment; the contact parameters "K", "D", "mu" ((1,) or (N,)); "terrain_height":
    a FlatTerrain's height ((1,) or (N,)) or a HeightfieldTerrain's heights (nx, ny) (a PlaneTerrain has
    none: ValueError). The model's own arrays get requires_grad (their .grad allocated, zero); the contact
    parameters and the terrain's heights, when numbers or NumPy arrays, become Warp arrays with requires_grad
    that replace them in `model.contact_params` / `model.terrain` (the step's plan is rebuilt once). After
    `tape.backward(loss)` the gradient of the loss is in `arrays[name].grad`, the same shape as the
    parameter: a parameter shared by the environments gets the sum over them, a per-environment one a row
    per environment. Zero the grads in place (`tape.zero()`) between backward passes: kernels recorded on a
    tape hold views of the arrays and their gradients, so a .grad replaced by a new array afterwards is not
    the one they write. Each call returns the model's
    current arrays: replacing a parameter later (set_link_parameters, set_joint_parameters, a new
    contact_params or terrain) makes new arrays without gradients.

    What reaches them: ABA, RNEA, CRBA (and what calls them: forward/inverse dynamics, bias forces, mass
    matrix), the Coriolis matrix, the centroidal, momentum and energy functions (`warpdyn.com`, this
    module), `step`, `warpdyn.contact`'s forces and `warpdyn.simulation.Rollout` under a tape. With none marked
    a tape records the same launches as before and nothing extra is allocated. A limit gain or friction that
    requires gradients keeps its term in the step's compiled actuation kernel even where it is zero (a joint
    with a zero limit spring has its limit off: its gradient is 0 there).
    """
    import dataclasses

    from ._simulation import PARAMETERS
    from .types.terrain import FlatTerrain, HeightfieldTerrain

    if isinstance(names, str):
        names = (names,)
    unknown = [n for n in names if n not in PARAMETERS]
    if unknown:
        raise ValueError(f"parameters_requiring_grad: unknown names {unknown}; known: {list(PARAMETERS)}")
    out = {}
    contact = {}
    for name in names:
        if name in ("K", "D", "mu"):
            value = getattr(model.contact_params, name)
            if not isinstance(value, wp.array):
                value = contact[name] = _parameter_array(value, model)
            value.requires_grad = True
            out[name] = value
        elif name == "terrain_height":
            terrain = model.terrain
            if isinstance(terrain, FlatTerrain):
                field = "height"
            elif isinstance(terrain, HeightfieldTerrain):
                field = "heights"
            else:
                raise ValueError(f"terrain_height: a {type(terrain).__name__} has no height parameter (FlatTerrain and HeightfieldTerrain have)")
            value = getattr(terrain, field)
            if not isinstance(value, wp.array):
                value = _parameter_array(value, model)
                model.terrain = dataclasses.replace(terrain, **{field: value})
            value.requires_grad = True
            out[name] = value
        else:
            array = getattr(model, name)
            array.requires_grad = True
            out[name] = array
    if contact:
        model.contact_params = dataclasses.replace(model.contact_params, **contact)
    return out


def _parameter_array(value, model: Model) -> wp.array:
    """A number or NumPy array as a Warp array in the model's dtype and device ((1,) for a number)."""
    host = np.asarray(value, dtype=np.float64)
    return wp.array(host.reshape(-1) if host.ndim == 0 else host, dtype=model.scalar, device=model.device)


def _check_data(model: Model, data, parameters: bool = False) -> None:
    """Errors naming what does not match between the data and the model; parameters: the caller reads the
    link or joint parameters, which, given per environment, need data of those N environments."""
    if parameters and model._per_env_parameters and any(N != data.batch_size for N in model._per_env_parameters.values()):
        raise ValueError(
            f"the model's parameters {model.per_environment_parameters()} are given per environment, "
            f"but the data has {data.batch_size} environments"
        )
    if data.scalar != model.scalar:
        raise TypeError(f"data is in {data.dtype.name} but the model computes in {model.dtype.name}")
    if data.joint_positions_state.shape[1] != model.dofs():
        raise ValueError(f"data has {data.joint_positions_state.shape[1]} joints but the model has {model.dofs()}")
    if str(data.device) != str(model.device):
        raise ValueError(f"data is on device '{data.device}' but the model is on '{model.device}'")


def link_poses(model: Model, data) -> tuple[wp.array, wp.array]:
    """(parent_H_link, W_H_L), each (N, nL) Warp transforms: one launch of forward kinematics."""
    _check_data(model, data)
    N, nL = data.batch_size, model.number_of_links()
    transform = wp.types.transformation(model.scalar)
    parent_H_link = _arrays.empty((nL,), N, transform, model.device, data.requires_grad)
    W_H_L = _arrays.empty((nL,), N, transform, model.device, data.requires_grad)
    launching.launch(
        kinematics_kernels(model.scalar).forward_kinematics,
        dim=N,
        inputs=[
            model.parent,
            model.joint_type,
            model.X_tree,
            model.joint_axis,
            model.joint_pivot,
            data.base_position_state,
            data.base_quaternion_state,
            data.joint_positions_state,
        ],
        outputs=[parent_H_link, W_H_L],
        device=model.device,
    )
    return parent_H_link, W_H_L


def homogeneous(model: Model, poses: wp.array, target_link: wp.array, link_H_target: wp.array, requires_grad=False):
    """(N, T, 4, 4) homogeneous matrices of poses[:, target_link[t]] * link_H_target[t]."""
    N, T = poses.shape[0], target_link.shape[0]
    H = _arrays.output((T, 4, 4), N, model.scalar, model.device, requires_grad)
    launching.launch(
        kinematics_kernels(model.scalar).homogeneous_matrices,
        dim=(N, T),
        inputs=[poses, target_link, link_H_target],
        outputs=[H],
        device=model.device,
    )
    return H


def forward_kinematics(model: Model, data) -> wp.array:
    """W_H_L: the pose of every link in the world, (nL, 4, 4), or (N, nL, 4, 4) for batched data."""
    _, W_H_L = link_poses(model, data)
    H = homogeneous(model, W_H_L, model.all_links, model.identity_offsets, data.requires_grad)
    return _arrays.squeeze_env(H, data.num_envs)


def joint_transforms(model: Model, data) -> wp.array:
    """λ(i)_H_i: the pose of each joint's child link in its parent link, (n, 4, 4), or (N, n, 4, 4) batched."""
    if model.dofs() == 0:
        shape = (0, 4, 4) if data.num_envs is None else (data.batch_size, 0, 4, 4)
        return wp.empty(shape, dtype=model.scalar, device=model.device)
    parent_H_link, _ = link_poses(model, data)
    H = homogeneous(model, parent_H_link, model.all_links[1:], model.identity_offsets[1:], data.requires_grad)
    return _arrays.squeeze_env(H, data.num_envs)


def jacobians(model: Model, data, target_link: wp.array, link_H_target: wp.array, output_vel_repr) -> wp.array:
    """(N, T, 6, 6 + n) free-floating Jacobians of the targets (frames at link_H_target on target_link)."""
    output_vel_repr = output_repr(data, output_vel_repr)
    _, W_H_L = link_poses(model, data)
    N, T = data.batch_size, target_link.shape[0]
    J = _arrays.output((T, 6, 6 + model.dofs()), N, model.scalar, model.device, data.requires_grad)
    launching.launch(
        jacobian_kernels(model.scalar).jacobians,
        dim=(N, T),
        inputs=[
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            model.support,
            target_link,
            link_H_target,
            W_H_L,
            int(data.velocity_representation),
            int(output_vel_repr),
        ],
        outputs=[J],
        device=model.device,
    )
    return J


def generalized_free_floating_jacobian(model: Model, data, *, output_vel_repr=None) -> wp.array:
    """The Jacobians of all links, (nL, 6, 6 + n), or (N, nL, 6, 6 + n) batched.

    Columns act on the generalized velocity in the data's representation; rows give each link's
    velocity in `output_vel_repr` (default: the data's).
    """
    J = jacobians(model, data, model.all_links, model.identity_offsets, output_vel_repr)
    return _arrays.squeeze_env(J, data.num_envs)


def velocities(model: Model, data, target_link: wp.array, link_H_target: wp.array, output_vel_repr) -> wp.array:
    """(N, T, 6) velocities of the targets (frames at link_H_target on target_link) in output_vel_repr."""
    output_vel_repr = output_repr(data, output_vel_repr)
    _, W_H_L = link_poses(model, data)
    N, T = data.batch_size, target_link.shape[0]
    W_v_WL = _arrays.empty((model.number_of_links(),), N, wp.types.vector(6, model.scalar), model.device, data.requires_grad)
    v = _arrays.output((T, 6), N, model.scalar, model.device, data.requires_grad)
    launching.launch(
        velocity_kernels(model.scalar).link_velocities,
        dim=N,
        inputs=[
            model.parent,
            model.joint_type,
            model.joint_axis,
            model.joint_pivot,
            target_link,
            link_H_target,
            W_H_L,
            data.base_velocity_state,
            data.joint_velocities_state,
            int(output_vel_repr),
        ],
        outputs=[W_v_WL, v],
        device=model.device,
    )
    return v


from ._centroidal import (  # noqa: E402
    average_velocity,
    average_velocity_jacobian,
    kinetic_energy,
    link_spatial_inertia_matrices,
    locked_spatial_inertia,
    mechanical_energy,
    potential_energy,
    total_momentum,
    total_momentum_jacobian,
)
from ._coriolis import free_floating_coriolis_matrix  # noqa: E402
from ._derivatives import generalized_free_floating_jacobian_derivative, link_bias_accelerations  # noqa: E402
from ._dynamics import (  # noqa: E402  (the dynamics use the kinematics above)
    forward_dynamics,
    forward_dynamics_aba,
    forward_dynamics_crb,
    free_floating_mass_matrix_inverse,
    free_floating_bias_forces,
    free_floating_gravity_forces,
    free_floating_mass_matrix,
    inverse_dynamics,
)
from ._simulation import (  # noqa: E402
    ActuationParams,
    IntegratorType,
    SoftContactsParams,
    step,
)
