"""The model: a robot's constants and parameters on a Warp device, in one scalar type.

Link order: breadth-first from the base, siblings by name, as JaxSim (parent index < child index). Joint i
moves link i + 1; its positions and velocities are at q_start[i + 1] and v_start[i + 1] of the joint arrays
(one each for a revolute or prismatic joint, 4 and 3 for a ball joint, 7 and 6 for a free one: nq joint
positions, nv joint velocities). Frames: sorted by name, as JaxSim.
Frame indices follow the link indices: frame k has index number_of_links() + k (as in JaxSim).

Changes and caches. Everything the engine derives from a model (kernel bundles, a step's plan, recorded
launches, workspaces) is cached on the model with `Model.cached` and rebuilt after the model changes. A
change is announced: every setter here (parameters, settings such as `terrain`, `contact_params`,
`time_step`, marking parameters for gradients) calls `notify_model_changed`, which bumps `version`. A
parameter's Warp array edited in place (`model.link_mass.assign(...)`) is read by kernels as it is then,
without a rebuild. No host check sees such an edit: every step checks the parameters' ranges on the device
instead and flags the environments out of range (data.healthy 0, their state kept:
kernels/parameter_checks.py), and `validate_parameters()` checks them on the host, naming parameter,
element, environment and value; it runs whenever a step's plan is built, after `notify_model_changed()`.
Call `notify_model_changed()` after such an edit when it switches a term on or off (a friction or limit
gain that was zero everywhere: the step compiles only the terms it needs).
"""

from __future__ import annotations

import dataclasses
import threading

import numpy as np
import warp as wp

from .. import arrays
from ..description import ModelDescription, load
from ..description.collidable import warn_without_points
from ..description.tree import KinematicTree, build_tree
from .contact_models import SoftContacts
from .enums import IntegratorType
from .hardware import hw_link_metadata
from .kin_dyn import JointModel, JointParameters, KinDynParameters, LinkParameters
from .model_constants import JOINT_TERMS, joint_motion_terms, quaternion_xyzw, sibling_chains, transforms
from .model_queries import ModelQueries
from .model_settings import ModelSettings
from .parameters import ACTUATOR_PARAMETERS, JOINT_PARAMETERS, LINK_PARAMETERS, REGISTRY, WORLD_PARAMETERS, Parameter, validate_parameters
from .settings import STANDARD_GRAVITY, ActuationParams, SoftContactsParams
from .terrain import FlatTerrain, HeightfieldTerrain, terrain_of_ground

__all__ = ["Model", "SCALARS", "STANDARD_GRAVITY", "transforms", "quaternion_xyzw"]

SCALARS = {np.dtype(np.float32): wp.float32, np.dtype(np.float64): wp.float64}
"""The NumPy dtypes a model computes in, and their Warp scalars."""




class _ParameterAttribute:
    """`model.<name>`: the Warp array of a link, joint, actuator or world parameter (read-only; set it with its
    group's setter)."""

    def __init__(self, parameter: Parameter):
        self.name = parameter.name
        count = {"link": "nL", "joint": "nj", "dof": "nv", "actuator": "na", "base": "1", "world": "1"}[parameter.element]
        self.__doc__ = f"{parameter.description} [{parameter.unit}]: ({count}{''.join(f', {k}' for k in parameter.item)}), or with a leading N when given per environment."

    def __get__(self, model, owner=None):
        if model is None:
            return self
        return model._values[self.name]


class Model(ModelSettings, ModelQueries):
    """A robot's constants on a Warp device, in one scalar type (float32 or float64).

    Build it with `warpdyn.model.Model.build_from_model_description`. The host-side tree (`model.tree`,
    NumPy float64) holds the description's constants; the Warp arrays below are what kernels read:
    parent (nL,) int, joint_type (nL,) int, q_start and v_start (nL + 1,) int (where each link's joint has its
    positions and velocities), the joints as the kernels move them (from the tree's parent_H_joint, joint_axis and
    joint_pivot: joint_Q0, joint_Q1 (P, nL) quaternion, joint_t0, joint_t1, joint_t2 (P, nL) vec3, P = 1 or N, and the motion
    subspace dof_S (nv,) vec6: `joint_motion_terms`), dof_joint (nv,) int (each DoF's joint), qpos_spring (nq,)
    (the ball and free joints' spring references: their initial positions), support (nL, nj) int, frame_parent (nF,) int,
    link_H_frame (nF,) transform, first_child and next_sibling (nL,) int (-1 for none: the sibling chains
    that backward passes sum over).

    Parameters (warpdyn.types.parameters): the links' `link_mass`, `link_com`, `link_inertia`
    (`set_link_parameters`) and the joints' `position_limits`, `joint_limit_spring`, `joint_limit_damper`,
    `friction_static`, `friction_viscous` (`set_joint_parameters`), each shared by all environments or
    given per environment (domain randomisation; then the model serves data of those N environments only);
    the world's gravity `world_gravity` [m/s^2, world frame] (`set_gravity`), (1, 3) shared or (N, 1, 3).
    Settings (warpdyn.types.model_settings, each checked when assigned): `terrain`, `contact_model`, `contact_params`,
    `actuation_params`, `integrator`, `time_step` [s], `gravity` (JaxSim's: the z component of `world_gravity` [m/s^2],
    -9.81 by default), `quaternion_tolerance`, `divergence_speed`, `implicit_damping`, `geom_contacts`, `implicit_contacts`,
    `equality_projection`, `limit_constraints`, `frictionloss_constraints`; JaxSim's `replace`, `editable`,
    `mutable_context`, `built_from` (what the model was built from), equality and hashing."""

    def __init__(
        self,
        description: ModelDescription,
        tree: KinematicTree,
        *,
        model_name: str,
        gravity,
        time_step: float,
        dtype,
        device,
    ):
        """The model of a lumped `tree` of `description`; gravity: the world's gravity W_g [m/s^2, world frame],
        (3,) shared or (N, 3) per environment (`set_gravity`)."""
        if np.dtype(dtype) not in SCALARS:
            raise TypeError(f"dtype must be np.float32 or np.float64, got {dtype!r}")
        self.description = description
        self.tree = tree
        self.model_name = model_name
        self.dtype = np.dtype(dtype)
        self.scalar = SCALARS[self.dtype]
        self.device = wp.get_device(device)
        self._lock = threading.RLock()
        self._version = 0
        self._cache: dict = {}
        self._values: dict[str, wp.array] = {}
        self._hosts: dict[str, np.ndarray] = {}
        self._per_env: dict[str, int] = {}
        self._kin_dyn, self.collidable_point_array = None, None  # KinDynParameters; a device array of the points (with_kin_dyn_parameters)
        self.joint_origins_per_env = None  # (positions (N, nj, 3), rotations (N, nj, 4)) after per-environment wd.model.with_joint_origins
        self.built_from = None
        s, d = self.scalar, self.device
        vec3 = wp.types.vector(3, s)
        self.parent = wp.array(tree.parent, dtype=int, device=d)
        self.joint_type = wp.array(tree.joint_type, dtype=int, device=d)
        terms = joint_motion_terms(tree)
        quat, vec6 = wp.types.quaternion(s), wp.types.vector(6, s)
        self.joint_Q0, self.joint_Q1 = (wp.array(terms[k][None], dtype=quat, device=d) for k in ("Q0", "Q1"))  # (1, nL): shared
        self.joint_t0, self.joint_t1, self.joint_t2 = (wp.array(terms[k][None], dtype=vec3, device=d) for k in ("t0", "t1", "t2"))
        self.dof_S = wp.array(terms["S"], dtype=vec6, device=d)
        self.dof_joint = wp.array(tree.dof_joint(), dtype=int, device=d)
        self.qpos_spring = wp.array(tree.qpos0, dtype=s, device=d)
        self.q_start = wp.array(tree.q_start, dtype=int, device=d)
        self.v_start = wp.array(tree.v_start, dtype=int, device=d)
        self.support = wp.array(tree.support().reshape(tree.number_of_links, tree.number_of_joints), dtype=int, device=d)
        self.frame_parent = wp.array(tree.frame_parent, dtype=int, device=d)
        self.link_H_frame = transforms(tree.link_H_frame, s, d)
        first_child, next_sibling = sibling_chains(tree.parent)
        self.first_child = wp.array(first_child, dtype=int, device=d)
        self.next_sibling = wp.array(next_sibling, dtype=int, device=d)
        self.all_links = wp.array(np.arange(tree.number_of_links), dtype=int, device=d)
        self.identity_offsets = transforms(np.tile(np.eye(4), (tree.number_of_links, 1, 1)), s, d)
        self._actuator_structure(tree)
        for parameter in (*LINK_PARAMETERS, *JOINT_PARAMETERS, *ACTUATOR_PARAMETERS):
            # the description's inertial values are taken as they are; what a user sets is checked
            self._store(parameter, parameter.default(tree), checked=parameter.group != "link")
        self.set_gravity(gravity)
        self.time_step = time_step
        self.terrain = terrain_of_ground(description.ground)
        self.contact_model = SoftContacts()
        self.contact_params = SoftContactsParams()
        self.integrator = IntegratorType.SemiImplicitEuler
        self.actuation_params = ActuationParams()
        self.quaternion_tolerance, self.divergence_speed, self.implicit_damping, self.geom_contacts, self.implicit_contacts, self.equality_projection = 0.1, float("inf"), False, False, False, 0
        if description.integrator is not None:
            self._follow_mujoco(description.integrator, description.disabled)

    def _actuator_structure(self, tree: KinematicTree) -> None:
        """The joint of each actuator, and each joint's actuators (sorted by joint: joint_actuator[k] for k in
        joint_actuator_start[j] .. joint_actuator_start[j + 1] - 1), on the device."""
        d = self.device
        joint_of = np.array([a.joint for a in tree.actuators], dtype=np.int32)
        order = np.argsort(joint_of, kind="stable").astype(np.int32)
        start = np.searchsorted(joint_of[order], np.arange(tree.number_of_joints + 1)).astype(np.int32)
        self.actuator_joint = wp.array(joint_of, dtype=int, device=d)
        self.joint_actuator = wp.array(order, dtype=int, device=d)
        self.joint_actuator_start = wp.array(start, dtype=int, device=d)
        self.actuators_per_joint = int(np.diff(start).max(initial=0))  # the most actuators on one joint

    @classmethod
    def build_from_model_description(
        cls,
        model_description,
        *,
        model_name: str | None = None,
        time_step: float | None = None,
        terrain=None,
        contact_model=None,
        contact_params=None,
        actuation_params=None,
        integrator=None,
        is_urdf: bool | None = None,
        considered_joints: list[str] | None = None,
        gravity: float | None = None,
        constraints=None,
        parametrized_links=None,
        fixed_base: bool | None = None,
        base_pose=None,
        dtype=np.float32,
        device=None,
    ) -> Model:
        """Build a model from a URDF, SDF or MJCF: a path, an XML string or XML bytes (any encoding its XML
        declaration names). JaxSim's keywords, and warpdyn's (fixed_base, base_pose, dtype, device).

        Fixed joints are lumped (their child links become frames); only `considered_joints` are kept
        when given (the others are locked at 0 and lumped). fixed_base: None keeps the description's base
        (welded to a `world` link, or floating); True welds the base to the world at `base_pose`, a (4, 4)
        homogeneous transform W_H_B [m] (default: the description's weld, else the identity; an MJCF free
        joint becomes a weld); False frees a base the description welds. gravity: its magnitude [m/s^2]
        (JaxSim's keyword; `model.gravity` is then -gravity, the world's z component), pulling along -z;
        without it the model takes the description's gravity vector (MJCF `<option gravity>`, SDF
        `<world><gravity>`, any direction), else (0, 0, -9.81): `model.world_gravity`. time_step [s] defaults
        to the description's, else 0.001. terrain, contact_model, contact_params, actuation_params, integrator: the settings
        (defaults: FlatTerrain, SoftContacts, SoftContactsParams(), ActuationParams(), SemiImplicitEuler or
        MuJoCo's). constraints: JaxSim's kinematic constraints (a ConstraintMap, its frames found here by name);
        parametrized_links: the links JaxSim's hardware parametrisation scales (None: all). dtype: np.float32 (the
        default) or np.float64, the scalar of every computation. device: a Warp device (default: Warp's
        default device, a GPU when there is one). `model.built_from` keeps `model_description`.

        From an MJCF, the model also takes MuJoCo's integrator (RK4 as RungeKutta4; Euler, implicit and
        implicitfast as SemiImplicitEulerSO3, MuJoCo's Euler, with the joints' damping implicit unless
        eulerdamp is disabled: MuJoCo's implicit integrators also treat velocity-dependent actuator forces
        implicitly, which warpdyn does not) and honours its disable flags: gravity (g = 0), spring and damper (their
        coefficients 0; both: no gravity compensation), actuation (actuator gains and biases 0), clampctrl
        (no control ranges), eulerdamp (explicit damping).
        """
        if np.dtype(dtype) not in SCALARS:
            raise TypeError(f"dtype must be np.float32 or np.float64, got {dtype!r}")
        description = load(model_description, is_urdf=is_urdf, fixed_base=fixed_base, base_pose=base_pose)
        model = cls.build(
            description,
            model_name=model_name,
            time_step=time_step,
            terrain=terrain,
            contact_model=contact_model,
            contact_params=contact_params,
            actuation_params=actuation_params,
            integrator=integrator,
            considered_joints=considered_joints,
            gravity=gravity,
            constraints=constraints,
            parametrized_links=parametrized_links,
            dtype=dtype,
            device=device,
        )
        model.built_from = model_description
        if model.floating_base():
            warn_without_points(model.model_name, model.tree, stacklevel=2)
        return model

    @classmethod
    def build(
        cls,
        model_description: ModelDescription,
        *,
        model_name: str | None = None,
        time_step: float | None = None,
        terrain=None,
        contact_model=None,
        contact_params=None,
        actuation_params=None,
        integrator=None,
        considered_joints: list[str] | None = None,
        gravity: float | None = None,
        constraints=None,
        parametrized_links=None,
        dtype=np.float32,
        device=None,
    ) -> Model:
        """Build a model from a parsed description (warpdyn.description.ModelDescription, as `load` returns
        it; JaxSim's `build` takes its own parsed description). Keywords: see `build_from_model_description`."""
        if not isinstance(model_description, ModelDescription):
            raise TypeError(f"model_description must be a warpdyn ModelDescription (build_from_model_description reads files), got {type(model_description).__name__}")
        tree = build_tree(model_description, considered_joints)
        disabled = model_description.disabled
        W_g = np.zeros(3) if "gravity" in disabled else model_description.gravity if model_description.gravity is not None else (0.0, 0.0, -STANDARD_GRAVITY)
        if time_step is None:
            time_step = model_description.time_step if model_description.time_step is not None else 0.001
        model = cls(
            model_description,
            tree,
            model_name=model_name if model_name is not None else model_description.name,
            gravity=W_g,
            time_step=time_step,
            dtype=dtype,
            device=device,
        )
        if gravity is not None:
            model.gravity = -float(gravity)  # JaxSim's keyword: the magnitude, along -z
        settings = {"terrain": terrain, "contact_model": contact_model, "contact_params": contact_params, "actuation_params": actuation_params, "integrator": integrator, "constraints": constraints,
                    "parametrized_links": parametrized_links}
        model.apply_settings(**{k: v for k, v in settings.items() if v is not None})
        return model

    # Changes and caches --------------------------------------------------------------------------

    @property
    def version(self) -> int:
        """A counter of announced changes (`notify_model_changed`): what the engine's caches are keyed by."""
        return self._version

    def notify_model_changed(self) -> None:
        """Say that the model changed: what the engine derived from it (plans, bundles, recorded launches,
        workspaces) is rebuilt on next use. The setters call it; call it after editing a parameter's array
        in place when the edit switches a term on or off (see the module docstring)."""
        with self._lock:
            self._version += 1

    def cached(self, key, build):
        """The value built by `build()` for `key` at the model's current version (built once per version)."""
        entry = self._cache.get(key)
        if entry is not None and entry[0] == self._version:
            return entry[1]
        with self._lock:
            entry = self._cache.get(key)
            if entry is None or entry[0] != self._version:
                entry = self._cache[key] = (self._version, build())
            return entry[1]

    def copy(self) -> Model:
        """A model sharing this one's device constants and parameter arrays, with its own parameter table,
        settings and caches: setting a parameter or a setting on either leaves the other as it is (a
        parameter array edited in place is seen by both). Also what `copy.copy(model)` makes."""
        new = object.__new__(Model)
        new.__dict__.update(self.__dict__)
        new._lock = threading.RLock()
        new._version = 0
        new._cache = {}
        new._values, new._hosts, new._per_env = dict(self._values), dict(self._hosts), dict(self._per_env)
        return new

    __copy__ = copy

    # Parameters ----------------------------------------------------------------------------------

    def set_link_parameters(self, **values) -> None:
        """Set the links' inertial parameters (keywords below; one not given keeps its value).

        mass (nL,) [kg], com (nL, 3) [m, link frame], inertia (nL, 3, 3) [kg m^2, about the CoM, link axes],
        gravcomp_mass (nL,) [kg] and gravcomp_com (nL, 3) [m, link frame] (gravity compensation: the force
        -gravcomp_mass W_g at gravcomp_com, W_g the world's gravity, MJCF's gravcomp),
        in the order of `link_names()` (lumped links included), shared by all environments; or with a
        leading axis of N environments, (N, nL), (N, nL, 3), (N, nL, 3, 3): domain randomisation, one
        row per environment, read by every dynamics function, `step` and rollouts. A model with
        per-environment parameters serves data of those N environments only (a ValueError otherwise), and
        its gradients (`parameters_requiring_grad`) come back per environment. Masses must be non-negative,
        inertias symmetric positive semi-definite (the loader's checks and tolerances,
        warpdyn.description.physical; an UnphysicalInertiaWarning for principal moments that violate the
        triangle inequality). Each value given makes a new Warp array (`model.link_mass`, ...).
        """
        self._set_group(LINK_PARAMETERS, values, "set_link_parameters")

    def set_joint_parameters(self, **values) -> None:
        """Set joint parameters of `step` (keywords below; one not given keeps its value).

        Per joint (nj,): position_limits (nj, 2) [rad or m]: (lower, upper), inf where a joint is unlimited;
        limit_spring [N m/rad or N/m] and limit_damper [s/rad or s/m]: the limit spring-damper of JaxSim (off
        where the spring is 0); stiffness [N m/rad or N/m] and springref [rad or m]: MuJoCo's joint spring
        -stiffness (s - springref) (a ball or free joint's pulls towards its initial position);
        actuator_force_range (nj, 2) [N m or N]: the clamp of the summed actuator force on the joint. Per DoF
        (nv,): friction_static [N m or N] and friction_viscous [N m s/rad or N s/m]: JaxSim's joint friction;
        armature [kg m^2 or kg]: added to the DoF's diagonal entry of the mass matrix; damping [N m s/rad or
        N s/m]: MuJoCo's damper -damping sdot. (nj = nv without ball and free joints.) Per floating base (1,):
        base_armature, base_damping, base_stiffness: its free joint's (MJCF, MuJoCo's on its 6 DoFs; the spring
        pulls towards the description's base pose). Each shared by all
        environments, or with a leading axis of N environments, one row per environment (see
        `set_link_parameters`). Each value given makes a new Warp array (`model.joint_limit_spring`, ...;
        their names in warpdyn.types.parameters). Limits and limit springs of ball and free joints are not
        read.
        """
        self._set_group(JOINT_PARAMETERS, values, "set_joint_parameters")

    def set_actuator_parameters(self, **values) -> None:
        """Set the actuators' parameters (keywords below; one not given keeps its value): gear (na,),
        gain (na, 3) and bias (na, 3) of the force (g0 + g1 L + g2 V) ctrl + b0 + b1 L + b2 V with L = gear s
        and V = gear sdot, ctrl_range (na, 2) and force_range (na, 2) (inf where unlimited); shared by all
        environments or with a leading axis of N environments (see `set_link_parameters`)."""
        self._set_group(ACTUATOR_PARAMETERS, values, "set_actuator_parameters")

    def set_gravity(self, W_g) -> None:
        """Set the world's gravity W_g [m/s^2, world frame] (`model.world_gravity`): (3,) shared by all
        environments, or (N, 3) one per environment (see `set_link_parameters`), finite. JaxSim's
        `model.gravity = g` sets (0, 0, g) shared. Makes a new Warp array."""
        name = "world_gravity"
        host = arrays.host_numbers(W_g.numpy() if isinstance(W_g, wp.array) else W_g, name)
        if host.shape == (3,) or (host.ndim == 2 and host.shape[1] == 3 and host.shape[0] >= 1):
            self._store(REGISTRY[name], host.reshape(-1, 1, 3) if host.ndim == 2 else host.reshape(1, 3), checked=True)
        else:
            raise ValueError(f"{name} has shape {host.shape}, expected (3,) (shared) or (N, 3) (per environment)")
        self.notify_model_changed()

    def _set_group(self, group: tuple, values: dict, setter: str) -> None:
        by_keyword = {p.keyword: p for p in group}
        unknown = [k for k in values if k not in by_keyword]
        if unknown:
            raise TypeError(f"{setter}() got unknown keywords {unknown}; known: {list(by_keyword)}")
        for keyword, value in values.items():
            if value is not None:
                self._store(by_keyword[keyword], value, checked=True)
        self.notify_model_changed()

    def _store(self, parameter: Parameter, value, checked: bool) -> None:
        """Store a link, joint, actuator or world parameter given shared (count, *item) or per environment (N,
        count, *item)."""
        name = parameter.name
        count = {"link": self.tree.number_of_links, "joint": self.tree.number_of_joints, "dof": self.tree.dofs,
                 "actuator": len(self.tree.actuators), "base": 1, "world": 1}[parameter.element]
        host = np.array(arrays.host_numbers(value.numpy() if isinstance(value, wp.array) else value, name))  # a copy, the table's own
        shared = (count, *parameter.item)
        if checked and parameter.check is not None and host.shape[-len(shared) :] == shared:
            parameter.check(name, host)
        dtype = self._element_dtype(parameter)
        if host.shape == shared:
            array = wp.array(host, dtype=dtype, device=self.device)
            self._per_env.pop(name, None)
        elif host.ndim == len(shared) + 1 and host.shape[1:] == shared and host.shape[0] >= 1:
            N = host.shape[0]
            self._record_per_env(name, N)
            array = arrays.empty((count,), N, dtype, self.device)
            array.assign(wp.array(host, dtype=dtype, device=self.device))
        else:
            per_env = "(N, " + ", ".join(str(k) for k in shared) + ")"
            raise ValueError(f"{name} has shape {host.shape}, expected {shared} (shared) or {per_env} (per environment)")
        self._hosts[name] = host
        self._values[name] = array

    def _element_dtype(self, parameter: Parameter):
        """The Warp dtype of one link's or joint's value: the scalar, vec2, vec3 or mat33."""
        item, s = parameter.item, self.scalar
        if item == ():
            return s
        if len(item) == 1:
            return wp.types.vector(item[0], s)
        return wp.types.matrix(item, s)

    def validate_parameters(self) -> None:
        """Check the link, joint, actuator and contact parameters as they are now, arrays edited in place
        included (warpdyn.types.parameters.validate_parameters): a ValueError naming the parameter, the link or
        joint, the environment and the value."""
        validate_parameters(self)

    def parameter_host(self, name: str) -> np.ndarray:
        """The host (float64) copy of a link or joint parameter as it was last set."""
        return self._hosts[name]

    def per_environment_parameters(self) -> dict[str, int]:
        """{name: N} of the link, joint, actuator and world parameters given per environment (empty when all are
        shared)."""
        return dict(self._per_env)

    def parameter(self, name: str):
        """The current value of the parameter `name` (warpdyn.types.parameters.REGISTRY): a Warp array, or for
        the contact parameters and the terrain's height possibly a number or NumPy array (None for a
        PlaneTerrain's)."""
        group = REGISTRY[name].group
        if group == "contact":
            return getattr(self.contact_params, name)
        if group == "terrain":
            terrain = self.terrain
            return terrain.elevation if isinstance(terrain, FlatTerrain) else terrain.heights if isinstance(terrain, HeightfieldTerrain) else None
        return self._values[name]

    def parameters_require_grad(self, groups=("link", "joint", "actuator", "world", "contact", "terrain")) -> bool:
        """Whether a parameter of these groups is a Warp array that requires gradients (attribute reads only).
        The parameters' arrays are listed once per version (a parameter becomes another object only through a
        setter, which announces it); whether each requires gradients is read at every call, since marking an
        array (`requires_grad = True`) announces nothing."""
        for value in self.cached(("parameter arrays", tuple(groups)), lambda: self._parameter_arrays(groups)):
            if value.requires_grad:
                return True
        return False

    def _parameter_arrays(self, groups) -> tuple:
        values = (self.parameter(name) for name, parameter in REGISTRY.items() if parameter.group in groups)
        terms = tuple(getattr(self, name) for name in JOINT_TERMS) if "joint" in groups else ()  # wd.model.with_joint_origins'
        return tuple(value for value in values if isinstance(value, wp.array)) + terms

    def with_parameter_arrays(self, values: dict) -> Model:
        """A copy (see `copy`) whose parameters `values` ({name: Warp array, (count,) shared, (N, count) per environment,
        (1, count) shared}) are those arrays, kept as given (a tape that made them carries gradients through them),
        checked as the setters check."""
        new = self.copy()
        for name, array in values.items():
            parameter = REGISTRY[name]
            if array.ndim == 2 and array.shape[0] == 1:
                array = array[0]
            host = np.asarray(array.numpy(), dtype=np.float64)
            if parameter.check is not None:
                parameter.check(name, host)
            new._values[name], new._hosts[name] = array, host
            if array.ndim == 2:
                new._record_per_env(name, array.shape[0])
            else:
                new._per_env.pop(name, None)
        new.notify_model_changed()
        return new

    def with_joint_terms(self, terms: dict, tree: KinematicTree, origins_per_env: tuple | None = None) -> Model:
        """A copy (see `copy`) whose kernels move the links by `terms` ({name: (P, nL) array} of JOINT_TERMS, kept as
        given: a tape that computed them carries gradients back through them) and whose host tree is `tree` (its
        parent_H_joint environment 0's joint frames); origins_per_env: (positions (N, nj, 3), rotations (N, nj, 4))
        host float64 when the terms are per environment (P = N), else None."""
        new = self.copy()
        new.tree, new.joint_origins_per_env = tree, origins_per_env
        for name in JOINT_TERMS:
            setattr(new, name, terms[name])
        new._per_env.pop("joint_origins", None)
        if origins_per_env is not None:
            new._record_per_env("joint_origins", len(origins_per_env[0]), "joint origins are")
        return new

    def mark_for_gradients(self, names) -> dict:
        """See warpdyn.model.parameters_requiring_grad: {name: Warp array requiring gradients}."""
        if isinstance(names, str):
            names = (names,)
        unknown = [n for n in names if n not in REGISTRY]
        if unknown:
            raise ValueError(f"parameters_requiring_grad: unknown names {unknown}; known: {list(REGISTRY)}")
        out, contact = {}, {}
        for name in names:
            group = REGISTRY[name].group
            if group == "contact":
                value = getattr(self.contact_params, name)
                if not isinstance(value, wp.array):
                    value = contact[name] = self._parameter_array(value)
            elif group == "terrain":
                terrain = self.terrain
                if isinstance(terrain, FlatTerrain):
                    value = terrain.elevation
                    if not isinstance(value, wp.array):
                        value = self._parameter_array(value)
                        self.terrain = FlatTerrain(value)
                elif isinstance(terrain, HeightfieldTerrain):
                    value = terrain.heights
                    if not isinstance(value, wp.array):
                        value = self._parameter_array(value)
                        self.terrain = HeightfieldTerrain(value, terrain.origin, terrain.spacing)
                else:
                    raise ValueError(
                        f"terrain_height: a {type(terrain).__name__} has no height parameter (FlatTerrain and HeightfieldTerrain have)"
                    )
            else:
                value = self._values[name]
            value.requires_grad = True
            out[name] = value
        if contact:
            self.contact_params = dataclasses.replace(self.contact_params, **contact)
        self.notify_model_changed()
        return out

    def _parameter_array(self, value) -> wp.array:
        """A number or NumPy array as a Warp array in the model's dtype and device ((1,) for a number)."""
        host = np.asarray(value, dtype=np.float64)
        return wp.array(host.reshape(-1) if host.ndim == 0 else host, dtype=self.scalar, device=self.device)

    # Collidable points ---------------------------------------------------------------------------

    @property
    def kin_dyn_parameters(self) -> KinDynParameters:
        """JaxSim's `kin_dyn_parameters` (host-side, NumPy, warpdyn.types.kin_dyn): `.contact_parameters`
        (body, point, enabled of the collidable points), `.frame_parameters`, `.link_names`, `.parent_array`,
        `.support_body_array_bool`, `.joint_model`, and `.link_parameters` and `.joint_parameters`: a
        snapshot of the model's parameters now (read from their device arrays at each access, edits in place
        included). Change them through a copy
        (`kin_dyn_parameters.set_link_mass(...)`) and `model.replace(kin_dyn_parameters=...)`, as in JaxSim,
        or with the setters.

        The collidable points are made on first use with the default `warpdyn.contact.CollidablePointsOptions`;
        see `warpdyn.contact.with_collidable_points` for other options or enabled points.
        """
        return self._kin_dyn_snapshot()

    def kin_dyn_structure(self) -> KinDynParameters:
        """The model's KinDynParameters without its parameters' snapshot (links, joints, frames, collidable points:
        what model equality and hashing compare), made once."""
        if self._kin_dyn is None:
            with self._lock:
                if self._kin_dyn is None:
                    self._kin_dyn = KinDynParameters.build(self)
        return self._kin_dyn

    def _kin_dyn_snapshot(self) -> KinDynParameters:
        """The structure with the link and joint parameters as the device arrays hold them now (edits in place
        included: each is copied to the host)."""
        hosts = {name: np.asarray(self._values[name].numpy(), dtype=np.float64) for name in (
            "link_mass", "link_com", "link_inertia", "position_limits", "friction_static", "friction_viscous",
            "joint_limit_spring", "joint_limit_damper")}
        nL, n = self.number_of_links(), self.number_of_joints()
        links = LinkParameters.build_from_inertial_parameters(np.arange(nL), hosts["link_mass"], hosts["link_inertia"], hosts["link_com"])
        limits = hosts["position_limits"]
        joints = JointParameters(
            index=np.arange(1, n + 1),
            friction_static=hosts["friction_static"].copy(),
            friction_viscous=hosts["friction_viscous"].copy(),
            position_limits_min=limits[..., 0].copy(),
            position_limits_max=limits[..., 1].copy(),
            position_limit_spring=hosts["joint_limit_spring"].copy(),
            position_limit_damper=hosts["joint_limit_damper"].copy(),
        )
        return dataclasses.replace(self.kin_dyn_structure(), joint_model=JointModel.build(self), link_parameters=links, joint_parameters=joints, constraints=self.constraints,
                                   hw_link_metadata=self.cached("hw link metadata", lambda: hw_link_metadata(self))).owned_by(self)

    def apply_kin_dyn_parameters(self, params: KinDynParameters) -> None:
        """Set the link and joint parameters `params` holds (when it has them), its constraints, and use its collidable
        points (what `replace(kin_dyn_parameters=...)` does). A ValueError when it is another model's structure."""
        if not isinstance(params, KinDynParameters):
            raise TypeError(f"kin_dyn_parameters must be a KinDynParameters, got {type(params).__name__}")
        if params.link_names != self.link_names() or params != self.kin_dyn_structure():
            raise ValueError(f"kin_dyn_parameters describe links {list(params.link_names)[:4]}..., not model '{self.name()}''s structure")
        # its collidable points, on this model's device and in its scalar (params may be another model's)
        self._kin_dyn = params.with_enabled(self, params.contact_parameters.enabled).structure_only()
        self.constraints = params.constraints
        self.collidable_point_array = None  # the points are params' now, not a kernel's
        self._per_env.pop("collidable_points", None)
        links, joints = params.link_parameters, params.joint_parameters
        if links is not None:
            self.set_link_parameters(mass=links.mass, com=links.center_of_mass, inertia=LinkParameters.inertia_tensor(links))
        if joints is not None:
            self.set_joint_parameters(
                friction_static=joints.friction_static,
                friction_viscous=joints.friction_viscous,
                position_limits=np.stack([joints.position_limits_min, joints.position_limits_max], axis=-1),
                limit_spring=joints.position_limit_spring,
                limit_damper=joints.position_limit_damper,
            )
        self.notify_model_changed()

    def with_kin_dyn_parameters(self, params: KinDynParameters, point_array: wp.array | None = None) -> Model:
        """A model like this one (its device constants and parameters shared) with other collidable points; point_array (P, nc_all)
        vec3: their positions as a kernel computed them, P = 1 or per environment (params: row 0's), which a step reads."""
        new = self.copy()
        new.collidable_point_array, new._kin_dyn = point_array, params.with_enabled(new, params.contact_parameters.enabled).structure_only()
        new._per_env.pop("collidable_points", None)
        if point_array is not None and point_array.shape[0] > 1:  # data of that N only, as per-environment parameters
            new._record_per_env("collidable_points", point_array.shape[0])
        return new

    def _record_per_env(self, name: str, N: int, subject: str | None = None) -> None:
        """Record that `name` is given for N environments; a ValueError when another per-environment parameter has
        another N (`subject`: how the message names it, "<name> is" by default)."""
        others = {k: v for k, v in self._per_env.items() if k != name and v != N}
        if others:
            raise ValueError(f"{subject or f'{name} is'} given for {N} environments but {others} for other numbers: one N per model")
        self._per_env[name] = N

    def snapshot_state(self) -> dict:
        """What `restore_state` puts back: the settings and the parameter tables (not the arrays' contents)."""
        return {"attributes": dict(self.__dict__), "values": dict(self._values), "hosts": dict(self._hosts), "per_env": dict(self._per_env)}

    def restore_state(self, saved: dict) -> None:
        """Put back the settings and parameters of `snapshot_state` (JaxSim's mutable_context on an error)."""
        with self._lock:
            attributes = {k: v for k, v in saved["attributes"].items() if k not in ("_lock", "_version", "_cache")}
            self.__dict__.update(attributes)
            self._values, self._hosts, self._per_env = saved["values"], saved["hosts"], saved["per_env"]
        self.notify_model_changed()

    def with_actuators(self, actuators: list) -> Model:
        """See warpdyn.model.add_actuators: a model like this one, its parameters and settings carried over,
        with `actuators` (ActuatorDescription) after its own (their parameters from the descriptions)."""
        names = [a.name for a in actuators]
        taken = sorted(set(names) & set(self.actuator_names())) + sorted({x for x in names if names.count(x) > 1})
        if taken:
            raise ValueError(f"actuator names must be new and distinct: {taken} (model '{self.name()}' has {list(self.actuator_names())})")
        unknown = sorted({a.joint for a in actuators} - set(self.joint_names()))
        if unknown:
            raise ValueError(f"actuators on joints that model '{self.name()}' does not have: {unknown}")
        description = dataclasses.replace(self.description, actuators=[*self.description.actuators, *actuators])
        new = self.copy()
        new.description = description
        built = build_tree(description, self.joint_names(), dict(self.tree.locked_joints))
        new.tree = dataclasses.replace(built, parent_H_joint=self.tree.parent_H_joint)  # the joints where with_joint_origins put them
        new._actuator_structure(new.tree)
        before = self.number_of_actuators()
        for parameter in ACTUATOR_PARAMETERS:
            old, added = self._hosts[parameter.name], parameter.default(new.tree)[before:]
            if parameter.name in self._per_env:  # (N, na, ...): the added actuators' values in every row
                added = np.broadcast_to(added, (old.shape[0], *added.shape))
            new._store(parameter, np.concatenate([old, added], axis=1 if parameter.name in self._per_env else 0), checked=True)
        return new

    def reduced(self, considered_joints, locked_joint_positions: dict | None = None) -> Model:
        """See warpdyn.model.reduce."""
        considered_joints = arrays.names_argument(considered_joints, "considered_joints")
        unknown = [name for name in considered_joints if name not in self.joint_names()]
        if unknown:
            raise ValueError(f"considered_joints names joints that model '{self.name()}' does not have: {unknown}")
        locked = dict(self.tree.locked_joints)
        if locked_joint_positions is not None and not isinstance(locked_joint_positions, dict):
            raise TypeError(f"locked_joint_positions must be a dict {{joint name: position}}, got {type(locked_joint_positions).__name__}")
        strangers = sorted(set(locked_joint_positions or {}) - set(self.joint_names()))
        if strangers:
            raise ValueError(f"locked_joint_positions names joints that model '{self.name()}' does not have: {strangers}")
        for name, value in (locked_joint_positions or {}).items():
            if name not in considered_joints:
                locked[name] = value  # build_tree checks it; a kept joint's position locks nothing (JaxSim's)
        tree = build_tree(self.description, considered_joints, locked)
        W_g = self.world_gravity.numpy().reshape(-1, 3)
        gravity = W_g if "world_gravity" in self._per_env else W_g[0]
        reduced = Model(self.description, tree, model_name=self.model_name, gravity=gravity, time_step=self.time_step, dtype=self.dtype, device=self.device)
        carried = ("terrain", "contact_model", "contact_params", "actuation_params", "integrator", "quaternion_tolerance", "divergence_speed", "implicit_damping", "geom_contacts", "implicit_contacts", "equality_projection", "constraints")
        kept = None if self.parametrized_links is None else tuple(n for n in self.parametrized_links if n in reduced.link_names())
        reduced.apply_settings(**{name: getattr(self, name) for name in carried}, parametrized_links=kept, built_from=self.built_from)
        self._carry_row_settings(reduced)
        return reduced


for _parameter in (*LINK_PARAMETERS, *JOINT_PARAMETERS, *ACTUATOR_PARAMETERS, *WORLD_PARAMETERS):
    setattr(Model, _parameter.name, _ParameterAttribute(_parameter))
del _parameter
