"""A model's settings (what `step` and the dynamics read beside the link, joint and actuator parameters) and
JaxSim's ways of changing a model: `replace`, `editable`, `mutable_context`, equality and hashing.

Each setting is checked when assigned (a TypeError or ValueError naming it and the value) and announces the
change (`Model.notify_model_changed`), so the engine rebuilds what it derived from the model. JaxSim's models
are immutable pytrees edited through copies; a warpdyn model is an object whose settings may also be assigned
in place (`model.time_step = 0.002`), which JaxSim's `mutable_context` does too.
"""

from __future__ import annotations

import contextlib

import numpy as np

from .constraints import ConstraintMap
from .contact_models import RelaxedRigidContacts, RigidContacts, SoftContacts
from .enums import IntegratorType
from .settings import ActuationParams, RelaxedRigidContactsParams, RigidContactsParams, SoftContactsParams
from .terrain import FlatTerrain, HeightfieldTerrain, PlaneTerrain

__all__ = ["ModelSettings", "REPLACEABLE"]


def _setting(name: str, check, doc: str) -> property:
    """A model setting: assigning it checks the value (`check` returns it, or raises naming it) and
    announces the change (Model.notify_model_changed)."""
    attribute = f"_{name}"

    def get(model):
        return getattr(model, attribute)

    def put(model, value):
        setattr(model, attribute, check(value))
        model.notify_model_changed()

    return property(get, put, doc=doc)


def _rows_setting(name: str, rows: str, missing: str, doc: str) -> property:
    """A setting that has a step solve MuJoCo constraint rows the model's tree carries (`model.tree.<rows>`): a bool,
    False by default, True refused (a ValueError naming the model and `missing`) where the tree has none."""
    attribute = f"_{name}"

    def get(model):
        return getattr(model, attribute, False)

    def put(model, value):
        if not isinstance(value, (bool, np.bool_)):
            raise TypeError(f"{name} must be a bool, got {value!r}")
        if value and not getattr(model.tree, rows):
            raise ValueError(f"model.{name} on '{model.name()}': it has no MuJoCo {missing}")
        setattr(model, attribute, bool(value))
        model.notify_model_changed()

    return property(get, put, doc=doc)


def _number(name: str, value, positive: bool, inf: bool = False) -> float:
    """value as a float: finite (or +inf where `inf`: no bound), positive where `positive`; else a TypeError or
    ValueError naming `name`."""
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    try:
        value = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be a number, got {value!r}") from None
    if inf:
        if np.isnan(value) or value <= 0.0:
            raise ValueError(f"{name} must be positive (inf for no bound), got {value}")
    elif not np.isfinite(value) or (positive and value <= 0.0):
        raise ValueError(f"{name} must be {'positive and ' if positive else ''}finite, got {value}")
    return value


def _iterations(name: str, value) -> int:
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an integer (position passes), got {value!r}")
    if not 0 <= value <= 10:
        raise ValueError(f"{name} must be from 0 to 10 (position passes), got {value}")
    return int(value)


def _integrator(value) -> IntegratorType:
    try:
        return IntegratorType(value)
    except ValueError:
        raise ValueError(f"integrator must be one of {[f'IntegratorType.{k.name}' for k in IntegratorType]}, got {value!r}") from None


def _instance(name: str, *kinds):
    def check(value):
        if not isinstance(value, kinds):
            raise TypeError(f"{name} must be a {' or '.join(k.__name__ for k in kinds)}, got {type(value).__name__}")
        return value

    return check


def _name(value) -> str:
    if not isinstance(value, str) or not value:
        raise TypeError(f"model_name must be a non-empty string, got {value!r}")
    return value


REPLACEABLE = (
    "model_name",
    "time_step",
    "terrain",
    "gravity",
    "contact_model",
    "contact_params",
    "actuation_params",
    "integrator",
    "quaternion_tolerance",
    "divergence_speed",
    "implicit_damping",
    "geom_contacts",
    "implicit_contacts",
    "equality_projection",
    "limit_constraints",
    "frictionloss_constraints",
    "constraints",
    "parametrized_links",
    "kin_dyn_parameters",
    "built_from",
)
"""What `ModelSettings.replace` takes: JaxSim's model fields, and warpdyn's own settings."""


class ModelSettings:
    """The settings of a `Model` (its base class) and JaxSim's dataclass methods on them."""

    @property
    def gravity(self) -> float:
        """JaxSim's `model.gravity`: the z component [m/s^2] of the world's gravity `world_gravity` (-9.81 by
        default); `build_from_model_description(gravity=9.81)` takes the magnitude, as JaxSim's. Assigning g
        sets `world_gravity` to (0, 0, g), shared by the environments. Reading it is a ValueError when the
        gravity is given per environment or has a horizontal component (read `model.world_gravity`). The value
        set (not rounded to the model's dtype), or the array's after an edit in place, read once per model
        version (after such an edit, `notify_model_changed()`)."""
        return self.cached("gravity", self._gravity_along_z)

    @gravity.setter
    def gravity(self, value) -> None:
        self.set_gravity((0.0, 0.0, _number("gravity", value, positive=False)))

    def _gravity_along_z(self) -> float:
        if "world_gravity" in self.per_environment_parameters():
            raise ValueError("model.gravity: the gravity is given per environment (set_gravity); read model.world_gravity, (N, 1, 3)")
        held = self.world_gravity.numpy().reshape(3)
        W_g = self.parameter_host("world_gravity").reshape(3)  # as set (float64), unless edited in place since
        if not np.array_equal(held, W_g.astype(held.dtype)):
            W_g = held.astype(np.float64)
        if W_g[0] != 0.0 or W_g[1] != 0.0:
            raise ValueError(f"model.gravity: the gravity {W_g.tolist()} [m/s^2] does not point along z; read model.world_gravity")
        return float(W_g[2])
    time_step = _setting("time_step", lambda v: _number("time_step", v, positive=True), "The step's time step [s].")
    quaternion_tolerance = _setting(
        "quaternion_tolerance",
        lambda v: _number("quaternion_tolerance", v, positive=True),
        "A step whose base quaternion changes by more than this (a norm) flags the environment invalid.",
    )
    divergence_speed = _setting(
        "divergence_speed",
        lambda v: _number("divergence_speed", v, positive=True, inf=True),
        "A step from a state whose generalized velocity has a component beyond this in magnitude [m/s or rad/s: the "
        "base's Mixed velocity, the joints'] flags the environment as diverged (data.healthy 0, that state kept), as "
        "a non-finite state does: a divergence can stay finite (65 km/s in the LEAP scene, once). inf by default "
        "(off: how fast a scene may move is the scene's).",
    )
    integrator = _setting("integrator", _integrator, "The step's integrator (IntegratorType).")
    terrain = _setting("terrain", _instance("terrain", FlatTerrain, PlaneTerrain, HeightfieldTerrain), "The terrain (warpdyn.terrain).")
    contact_model = _setting(
        "contact_model",
        _instance("contact_model", SoftContacts, RigidContacts, RelaxedRigidContacts),
        "The contact model (warpdyn.rbda.contacts): SoftContacts (JaxSim's default), RigidContacts or "
        "RelaxedRigidContacts; assigning one without contact_params (replace, editable) sets its default parameters.",
    )
    contact_params = _setting(
        "contact_params",
        _instance("contact_params", SoftContactsParams, RigidContactsParams, RelaxedRigidContactsParams),
        "The contact model's parameters (the class its `parameters_class` names: a step refuses another).",
    )
    actuation_params = _setting("actuation_params", _instance("actuation_params", ActuationParams), "The torque-speed curve.")
    implicit_damping = _setting(
        "implicit_damping",
        _instance("implicit_damping", bool),
        "Whether the Euler integrators (SemiImplicitEuler, SemiImplicitEulerSO3) integrate the joints' `damping` "
        "implicitly, as MuJoCo's Euler, (M + dt diag(damping)) ν̇ = f; RK4 integrates it explicitly, as MuJoCo's. MJCF models start with "
        "MuJoCo's choice (its eulerdamp flag), URDF models with False.",
    )

    geom_contacts = _setting(
        "geom_contacts",
        _instance("geom_contacts", bool),
        "Whether the contacts of the model's geom pairs (wd.contact.geom_pairs: an MJCF's, as MuJoCo pairs them; a URDF's "
        "with wd.contact.with_self_collision) act in a step: with SoftContacts the soft law (SoftContactsParams' K, D, p, q) "
        "at each contact, the pair's sliding friction as mu (0 for condim 1), each contact slot's tangential deformation a "
        "row of the contact state (build the data after setting it); with RelaxedRigidContacts each penetrating contact "
        "solved with the collidable points (the pair's mu, the bodies' reduced mass); with RigidContacts each one in the QP "
        "(the pair's mu) and stopped by the impact where it penetrates after the step. False by "
        "default: robots' self-collision pairs cost a step its fused kernel and are off in most locomotion training; True "
        "for scenes whose bodies touch each other.",
    )

    implicit_contacts = _setting(
        "implicit_contacts",
        _instance("implicit_contacts", bool),
        "Whether a semi-implicit Euler step makes the soft law's contacts (the collidable points' and, with geom_contacts, "
        "the geom pairs') linearly implicit: each link's contact damping and stiffness enter its articulated inertia "
        "(kernels/implicit_contacts.py: backward Euler linearised, each link with its own block, as MuJoCo's implicitfast "
        "its dampers). Explicit (False, the default), a light body that stiff contacts press is unstable beyond "
        "h c / m or h^2 k / m of about 2 (a 0.1 kg cube under a gripper's pad at 1 ms); implicit, a link's contacts with "
        "the static world are stable at any time step (the tangential deformation's relaxation still asks dt K / D < 2; "
        "two moving bodies in contact each see their own block), at the cost of the fused kernel (the step runs as its stages). With equality constraints their solve "
        "after ABA keeps the mass matrix without the contacts' terms (the constraints hold as before; the implicit terms "
        "act on the unconstrained accelerations). Friction too: the Coulomb limit is mu min(fn, K delta^(1+p)), the normal "
        "force the step applies to a contact it arrests, for the steps and for the model's contact queries alike "
        "(wd.contact's forces). SoftContacts and the Euler integrators only (a step refuses it otherwise).",
    )

    equality_projection = _setting(
        "equality_projection",
        lambda value: _iterations("equality_projection", value),
        "The post-stabilisation's position passes after each step of a model with equality constraints, 0 to 10 "
        "(kernels/equality.py: Gauss-Newton steps in the mass metric onto the constraints, then the velocity projected "
        "onto them; every joint kind and a floating base). 0 by default: MuJoCo's soft constraints alone, whose loops part "
        "by up to millimetres. 2 closes the four-bar and the slider-crank to rounding (1e-15 m measured, the tests hold "
        "1e-12), their motion within 1e-2 of MuJoCo's stiffest constraint's over 10 s (tests/test_equality.py); a "
        "large correction (a kicked weld) may take 3. SoftContacts only (the solved contacts are refused). Prefer "
        "RungeKutta4: after a semi-implicit Euler step the projection gains energy where the constrained motion turns "
        "(tested: the undamped four-bar gains 2 % over 9 s at 1 ms; measured once: a ball pivoting at 27 rad/s diverged "
        "within 2 s at 1 ms and gained 0.5 % a second at 0.25 ms); after RK4 it loses a little (tested: the four-bar "
        "under 0.5 % over 9 s, the ball under 2 % a second).",
    )

    limit_constraints = _rows_setting(
        "limit_constraints",
        "limits",
        "limit constraints (no limited hinge, slide or ball joint)",
        """Whether a step solves the joint limits as MuJoCo does (MuJoCo's limit constraints: the description's limited
        hinge and slide joints, an MJCF's or a URDF's or SDF's with both bounds, and an MJCF's limited ball joints,
        `model.tree.limits`): a joint past its range (its `position_limits`, per environment where set so, less its
        margin; a ball's rotation angle past the larger end of its MJCF range, a constant of the description that
        position_limits do not hold) gets a soft unilateral row, its solref, solimp and dof_invweight0 (an MJCF's from
        MuJoCo's compile; a URDF's or SDF's MuJoCo's defaults and the tree's M^-1 diagonal at the zero positions,
        warpdyn.description.invweight), solved with the equality constraints after the contacts
        (kernels/equality_solve.py: pushing only, by an active set, as MuJoCo's solvers reach it). False by default: the solve costs a step its fused kernel, and most locomotion never reaches its
        limits; then the limits are JaxSim's limit springs (`actuation_params`), and a loaded MJCF names its limits in
        a NotModelledWarning. True where the joints meet their stops (a hand's fingers, a falling robot).""",
    )
    frictionloss_constraints = _rows_setting(
        "frictionloss_constraints",
        "friction_rows",
        "friction constraints (no hinge or slide joint with friction)",
        """Whether a step solves the joints' friction as MuJoCo solves frictionloss (its friction constraints: the hinge
        and slide joints with friction, an MJCF's frictionloss or a URDF's or SDF's <dynamics friction>,
        `model.tree.friction_rows`): each a soft row on the joint's velocity whose force is bounded by the joint's
        `friction_static` (per environment where set so), its dof_solref, dof_solimp and dof_invweight0 (as
        `limit_constraints`'), solved with the equality constraints and limits (kernels/equality_solve.py's active
        set: a row within its bound or saturated at it), in place of JaxSim's static friction on those joints. False
        by default (JaxSim's static friction -friction_static sign(sdot) then stands for it, as an MJCF's
        NotModelledWarning says): the solve costs a step its fused kernel.""",
    )

    def _carry_row_settings(self, reduced) -> None:
        """Set `limit_constraints` and `frictionloss_constraints` on `reduced` (a reduction of this model) where they
        are set here and it keeps rows of their kind."""
        for name, rows in (("limit_constraints", "limits"), ("frictionloss_constraints", "friction_rows")):
            if getattr(self, name) and getattr(reduced.tree, rows):
                setattr(reduced, name, True)

    _constraints = ConstraintMap()

    @property
    def constraints(self) -> ConstraintMap:
        """JaxSim's kinematic constraints (`model.kin_dyn_parameters.constraints`): a ConstraintMap of welds between
        frames (warpdyn.types.constraints), empty when none (JaxSim's default). A step solves them as JaxSim does,
        after the contacts, beside an MJCF's equality constraints; `equality_projection` closes them to rounding.
        Assigning a map made for another model (or before a reduction) finds its frames here by name; None is an
        empty map."""
        return self._constraints

    @constraints.setter
    def constraints(self, value) -> None:
        if value is not None and not isinstance(value, ConstraintMap):
            raise TypeError(f"constraints must be a wd.kin_dyn_parameters.ConstraintMap or None, got {type(value).__name__}")
        self._constraints = ConstraintMap() if value is None else value.for_model(self)
        self.notify_model_changed()

    _parametrized_links = None

    @property
    def parametrized_links(self) -> tuple[str, ...] | None:
        """JaxSim's `parametrized_links`: the links JaxSim's hardware parametrisation scales (`hw_link_metadata`
        marks the others Unsupported, so `update_hw_parameters` leaves them as they are); None: every link with a
        box, cylinder, sphere or capsule. Names of links the model lacks are dropped when a reduction lumps them."""
        return self._parametrized_links

    @parametrized_links.setter
    def parametrized_links(self, value) -> None:
        if value is not None:
            if isinstance(value, str) or not all(isinstance(name, str) for name in value):
                raise TypeError(f"parametrized_links must be link names (a tuple of str) or None, got {value!r}")
            unknown = sorted(set(value) - set(self.link_names()))
            if unknown:
                raise ValueError(f"parametrized_links names links that model '{self.name()}' does not have: {unknown}")
            value = tuple(value)
        self._parametrized_links = value
        self.notify_model_changed()

    def _follow_mujoco(self, integrator: str, disabled: frozenset) -> None:
        """MuJoCo's integrator and disable flags (see build_from_model_description)."""
        self.integrator = IntegratorType.RungeKutta4 if integrator == "RK4" else IntegratorType.SemiImplicitEulerSO3
        self.implicit_damping = integrator != "RK4" and not {"eulerdamp", "damper"} & disabled
        n, nL, na = self.dofs(), self.number_of_links(), self.number_of_actuators()
        if "spring" in disabled:
            self.set_joint_parameters(stiffness=np.zeros(n))
        if "damper" in disabled:
            self.set_joint_parameters(damping=np.zeros(n))
        if "gravity" in disabled or {"spring", "damper"} <= disabled:
            self.set_link_parameters(gravcomp_mass=np.zeros(nL))
        if "actuation" in disabled:
            self.set_actuator_parameters(gain=np.zeros((na, 3)), bias=np.zeros((na, 3)))
        if "clampctrl" in disabled:
            self.set_actuator_parameters(ctrl_range=np.tile([-np.inf, np.inf], (na, 1)))

    def apply_settings(self, **values) -> None:
        """Assign the settings in `values` (names of `REPLACEABLE`), each checked; `kin_dyn_parameters` sets
        the link and joint parameters it holds and its collidable points. A TypeError names an unknown one."""
        unknown = sorted(set(values) - set(REPLACEABLE))
        if unknown:
            raise TypeError(f"unknown model fields {unknown}; known: {list(REPLACEABLE)}")
        kin_dyn = values.pop("kin_dyn_parameters", None)
        if kin_dyn is not None:  # first: its constraints give way to a `constraints` given beside it
            self.apply_kin_dyn_parameters(kin_dyn)
        for name, value in values.items():
            setattr(self, name, _name(value) if name == "model_name" else value)
        if "contact_model" in values and "contact_params" not in values and not isinstance(self.contact_params, self.contact_model.parameters_class):
            self.contact_params = self.contact_model.parameters_class()

    def replace(self, validate: bool = True, **kwargs):
        """A copy of the model with the given fields replaced (JaxSim's `model.replace`): time_step, terrain,
        gravity, contact_model, contact_params, actuation_params, integrator, model_name, kin_dyn_parameters
        (its link and joint parameters, collidable points and constraints), constraints, built_from, and warpdyn's
        quaternion_tolerance, divergence_speed and implicit_damping. Each value is checked (`validate` is JaxSim's switch of
        its pytree's shape checks; warpdyn checks values always, so it changes nothing). The copy shares the
        device constants and parameter arrays (`Model.copy`)."""
        new = self.copy()
        new.apply_settings(**kwargs)
        return new

    @contextlib.contextmanager
    def editable(self, validate: bool = True):
        """A context manager yielding an editable copy of the model, as JaxSim's: `with model.editable() as
        model: model.time_step = ...`. (`validate`: see `replace`.)"""
        yield self.copy()

    @contextlib.contextmanager
    def mutable_context(self, mutability=None, restore_after_exception: bool = True):
        """A context manager yielding this model, to assign its settings in place (JaxSim's; a warpdyn model's
        settings are always assignable). If the block raises, the settings and parameters it changed are
        restored when `restore_after_exception` (the default). `mutability`: JaxSim's, accepted for porting;
        it changes nothing."""
        saved = self.snapshot_state()
        try:
            yield self
        except BaseException:
            if restore_after_exception:
                self.restore_state(saved)
            raise

    def __eq__(self, other) -> bool:
        """JaxSim's model equality: the same name, time step and kinematic structure (KinDynParameters' equality:
        links, joints, frames, parent and support arrays; not the parameters' values), and warpdyn's: the same
        kinematic constraints (JaxSim's leaves them out: two models that step differently are not equal here)."""
        if not isinstance(other, ModelSettings):
            return NotImplemented
        if self is other:
            return True
        same = (self.model_name, self.time_step, self.constraints) == (other.model_name, other.time_step, other.constraints)
        return same and self.kin_dyn_structure() == other.kin_dyn_structure()

    def __hash__(self) -> int:
        """The hash of the name and the kinematic structure (what does not change over a model's life; equal
        models have equal hashes)."""
        return hash((self.model_name, self.kin_dyn_structure()))

