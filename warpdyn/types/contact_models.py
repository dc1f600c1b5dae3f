"""Contact models, as JaxSim's `jaxsim.rbda.contacts`: the interface (`ContactModel`) and its soft
(Hunt/Crossley) implementation (`SoftContacts`), the value of `Model.contact_model`.

A contact model says which parameters it takes (`parameters_class`: `SoftContactsParams` for the soft law),
what state it adds to the data (`zero_state_variables`: the soft law's tangential deformation of every
collidable point) and how it computes the contact forces. The law itself is written once, in the kernels
(kernels/soft_contacts.py); the whole-model computation (`compute_contact_forces`: kinematics of the points,
then the law) is the engine's, which registers it here for each model class (`register_forces`) when
warpdyn.engine.contact is imported, as `import warpdyn` does. JaxSim's rigid (`RigidContacts`) and relaxed-rigid
(`RelaxedRigidContacts`) models solve an environment's contact forces together (kernels/rigid_contacts.py).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import warp as wp

from ..kernels.soft_contacts import points_kernel
from .settings import RelaxedRigidContactsParams, RigidContactsParams, SoftContactsParams

__all__ = ["ContactModel", "SoftContacts", "RigidContacts", "RelaxedRigidContacts", "register_forces", "register_impact"]

_FORCES: dict[type, Callable] = {}
_IMPACTS: dict[type, Callable] = {}


def register_forces(model_class: type, compute: Callable) -> None:
    """Make `compute(model, data, link_forces, joint_force_references)` the whole-model force computation of
    `model_class` (what its `compute_contact_forces` returns): the engine's seam for a contact law."""
    _FORCES[model_class] = compute


def register_impact(model_class: type, compute: Callable) -> None:
    """Make `compute(model, data)` the data after an impact of `model_class` (what its
    `update_velocity_after_impact` returns): the engine's, as `register_forces`."""
    _IMPACTS[model_class] = compute


class ContactModel:
    """A contact model (JaxSim's base class): its parameters' class, its state variables, its forces."""

    parameters_class: type = SoftContactsParams

    @property
    def _parameters_class(self) -> type:
        """JaxSim's name of `parameters_class` (its tests build parameters with it)."""
        return self.parameters_class

    @classmethod
    def build(cls, **kwargs) -> ContactModel:
        """A contact model of this class (JaxSim's constructor; the soft model takes no options)."""
        if kwargs:
            raise TypeError(f"{cls.__name__}.build() takes no options, got {sorted(kwargs)}")
        return cls()

    def __eq__(self, other) -> bool:
        return type(self) is type(other)

    def __hash__(self) -> int:
        return hash(type(self).__name__)

    def __repr__(self) -> str:
        return f"{type(self).__name__}()"

    @classmethod
    def compute_contact_forces(cls, model, data, *, link_forces=None, joint_force_references=None) -> tuple:
        """(W_f_C, derivatives): the Inertial 6D contact forces [N; N m] of the model's enabled collidable
        points ((nc, 6), or (N, nc, 6) for batched data) and a dict of the rates of the model's state
        variables (JaxSim's), at the data's state. link_forces and joint_force_references: the other forces
        acting (the soft law does not use them; JaxSim's rigid models do)."""
        compute = _FORCES.get(cls)
        if compute is None:
            raise NotImplementedError(f"{cls.__name__} has no force computation registered (import warpdyn registers the engine's)")
        return compute(model, data, link_forces, joint_force_references)

    @staticmethod
    def zero_state_variables(model) -> dict[str, np.ndarray]:
        """The model's contact state at rest: {} (a model without state)."""
        return {}

    @staticmethod
    def update_contact_state(old_contact_state: dict) -> dict:
        """The contact state of the data from what `compute_contact_forces` returned (JaxSim's step)."""
        return dict(old_contact_state)

    @staticmethod
    def update_velocity_after_impact(model, data):
        """The data after an impact: unchanged for a model whose forces act over time (the soft law)."""
        return data


class SoftContacts(ContactModel):
    """JaxSim's soft contacts: the Hunt/Crossley normal force of a point's penetration into the terrain and
    a tangential spring-damper on its deformation m, limited by Coulomb's cone (kernels/soft_contacts.py has
    the formulas). Parameters: `SoftContactsParams`; state: {"tangential_deformation": (rows, 3) [m]} (Model.contact_state_rows)."""

    parameters_class = SoftContactsParams

    @staticmethod
    def zero_state_variables(model) -> dict[str, np.ndarray]:
        """{"tangential_deformation": zeros (rows, 3)}: one row per collidable point, enabled or not, then one per geom
        pair contact slot where model.geom_contacts is set (Model.contact_state_rows)."""
        return {"tangential_deformation": np.zeros((model.contact_state_rows(), 3))}

    @staticmethod
    def update_contact_state(old_contact_state: dict) -> dict:
        """{"tangential_deformation": m_dot} of {"m_dot": m_dot} (JaxSim's: the state's rate, which its
        integrators integrate)."""
        return {"tangential_deformation": old_contact_state["m_dot"]}

    @staticmethod
    def hunt_crossley_contact_model(position, velocity, tangential_deformation, terrain, K, D, mu, p=0.5, q=0.5) -> tuple:
        """(f (..., 3) [N, world axes], m_dot (..., 3) [m/s]): the soft law at points `position` (..., 3) [m]
        moving at `velocity` (..., 3) [m/s] with deformation `tangential_deformation` (..., 3) [m] on `terrain`
        (a warpdyn.terrain terrain, read at the points), p and q the exponents. K, D and mu: numbers, or arrays
        that broadcast against the points' leading axes (one value per point, or per environment (N, 1) for
        points (N, nc, 3)). A FlatTerrain of N heights (one per environment) needs points (N, ..., 3): environment
        e's are read on its height. A host function (NumPy in and out, float64: the kernels' law, launched on the
        CPU), for scripts and checks: gradients through the law come from the functions that compute it on a
        model under a wp.Tape (warpdyn.contact, `step`)."""
        P = _points(position, "position")
        n, h = terrain.normal(P[..., 0], P[..., 1]), terrain.height_under(P)
        return _law(P, _points(velocity, "velocity"), _points(tangential_deformation, "tangential_deformation"), h, n, (K, D, mu, p, q))

    @staticmethod
    def compute_contact_force(position, velocity, tangential_deformation, parameters: SoftContactsParams, terrain) -> tuple:
        """(W_f (..., 6) [N; N m], m_dot (..., 3)): the point's force as an Inertial 6D force [f; p x f] and
        its deformation rate (`hunt_crossley_contact_model` with `parameters`)."""
        f, m_dot = SoftContacts.hunt_crossley_contact_model(
            position, velocity, tangential_deformation, terrain, parameters.K, parameters.D, parameters.mu, parameters.p, parameters.q
        )
        P = _points(position, "position")
        return np.concatenate([f, np.cross(P, f)], axis=-1), m_dot


class _SolvedContacts(ContactModel):
    """A model whose forces are solved together (JaxSim's rigid and relaxed-rigid): its solver options, a dict
    of known names (`_OPTIONS`: name -> (default, check)), and max_active_contacts (warpdyn's; None: every collidable
    point and geom pair contact slot), the most penetrating contacts an environment's solve holds, which sizes its
    dense float64 scratch ((3 n)^2 matrices per environment for n of them, two for the relaxed-rigid solve, three for the
    rigid QP: the LEAP scene's 280 points and 2600 slots would take 1.2 or 1.8 GB per environment, 48 contacts 0.33 or
    0.5 MB), as MuJoCo's nconmax; an environment with more is
    flagged (`data.healthy`), the others go on. Both are part of its equality and hash."""

    _OPTIONS: dict = {}

    def __init__(self, solver_options: dict | None = None, max_active_contacts: int | None = None):
        self.max_active_contacts = None if max_active_contacts is None else _count(f"{type(self).__name__}.max_active_contacts", max_active_contacts)
        given = dict(solver_options or {})
        unknown = sorted(set(given) - set(self._OPTIONS))
        if unknown:
            raise TypeError(f"{type(self).__name__}'s solver_options are {sorted(self._OPTIONS)}, got {unknown}")
        options = {name: default for name, (default, _) in self._OPTIONS.items()}
        for name, value in given.items():
            options[name] = self._OPTIONS[name][1](f"{type(self).__name__} solver_options['{name}']", value)
        self._options = options

    @property
    def solver_options(self) -> dict:
        """The solver's options (a copy)."""
        return dict(self._options)

    def __eq__(self, other) -> bool:
        return type(self) is type(other) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash((type(self).__name__, self._key()))

    def _key(self) -> tuple:
        return (*sorted(self._options.items()), self.max_active_contacts)

    @staticmethod
    def update_contact_state(old_contact_state: dict) -> dict:
        """{}: the model has no contact state (JaxSim's)."""
        return {}

    def __repr__(self) -> str:
        return f"{type(self).__name__}(solver_options={self._options}, max_active_contacts={self.max_active_contacts})"


def _positive(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_)) or not np.isscalar(value) or not np.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a positive finite number, got {value!r}")
    return float(value)


def _count(name: str, value) -> int:
    if isinstance(value, (bool, np.bool_)) or int(value) != value or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)


class RelaxedRigidContacts(_SolvedContacts):
    """JaxSim's relaxed-rigid contacts: the points' forces f = -(G + diag(R))^-1 (a - a_ref), G the active points'
    Delassus matrix, a_ref a MuJoCo-like reference acceleration, R a regularisation (kernels/rigid_contacts.py).
    Parameters: `RelaxedRigidContactsParams`; no state. JaxSim minimises the same quadratic by L-BFGS (its
    solver_options tol, maxiter, memory_size, scale_init_precond); warpdyn factorises it: its exact minimiser, so
    it takes those options (for JaxSim's code) and reads none of them. max_active_contacts: `_SolvedContacts`'."""

    parameters_class = RelaxedRigidContactsParams
    _OPTIONS = {
        "tol": (1e-6, _positive),
        "maxiter": (50, _count),
        "memory_size": (10, _count),
        "scale_init_precond": (False, lambda name, value: bool(value)),
    }

    def __init__(self, solver_options: dict | None = None, max_active_contacts: int | None = None):
        super().__init__(solver_options, max_active_contacts)

    @classmethod
    def build(cls, solver_options: dict | None = None, **kwargs) -> RelaxedRigidContacts:
        """JaxSim's constructor (its solver options, which the exact solve does not need; other keywords: a
        TypeError naming them)."""
        if kwargs:
            raise TypeError(f"RelaxedRigidContacts.build() takes solver_options, got {sorted(kwargs)}")
        return cls(solver_options)


class RigidContacts(_SolvedContacts):
    """JaxSim's rigid contacts: the points' forces minimise 1/2 f^T (G + eps I) f + (a - beta)^T f over the friction
    pyramids (a QP: kernels/rigid_contacts.py), and after each step the velocity jumps to the nearest (in the
    mass matrix's metric) at which the penetrating points are still (`update_velocity_after_impact`, an impact).
    Parameters: `RigidContactsParams`; no state. regularization_delassus: eps [m/s^2/N] (JaxSim's 1e-6);
    solver_options: "solver_tol", the interior point's tolerance on its residuals and complementarity (relative
    to 1 + max |a - beta|: JaxSim's qpax default is 1e-3, warpdyn's 1e-10, to which it converges in a few more of
    its at most "max_iterations" (50) iterations, in float64 whatever the model's dtype); max_active_contacts:
    `_SolvedContacts`'. With model.geom_contacts the geom pairs' contacts join the QP and the impact (each stops the
    bodies' relative motion at its point), their mu the pair's."""

    parameters_class = RigidContactsParams
    _OPTIONS = {"solver_tol": (1e-10, _positive), "max_iterations": (50, _count)}

    def __init__(self, regularization_delassus: float = 1e-6, solver_options: dict | None = None, max_active_contacts: int | None = None):
        super().__init__(solver_options, max_active_contacts)
        self.regularization_delassus = _positive("RigidContacts.regularization_delassus", regularization_delassus)

    @classmethod
    def build(cls, regularization_delassus: float | None = None, solver_options: dict | None = None, **kwargs) -> RigidContacts:
        """JaxSim's constructor (other keywords: a TypeError naming them; JaxSim logs and ignores them)."""
        if kwargs:
            raise TypeError(f"RigidContacts.build() takes regularization_delassus and solver_options, got {sorted(kwargs)}")
        return cls(1e-6 if regularization_delassus is None else regularization_delassus, solver_options)

    def _key(self) -> tuple:
        return (*super()._key(), self.regularization_delassus)

    @staticmethod
    def compute_impact_velocity(inactive_collidable_points, M, J_WC, generalized_velocity) -> np.ndarray:
        """JaxSim's host formula of the impact: the velocity nu+ (6 + n,) that solves, in the least-squares sense,
        [M, -J^T; J, 0] [nu+; lambda] = [M nu; 0] with J the linear rows of the points' Jacobians J_WC (nc, 6, 6 + n)
        whose `inactive_collidable_points` (nc,) flag is False; M (6 + n, 6 + n), J_WC and generalized_velocity in one
        representation. Host NumPy (the step's impact is the kernels', `update_velocity_after_impact`)."""
        inactive = np.asarray(inactive_collidable_points, dtype=bool)
        M, J, nu = (np.asarray(a.numpy() if isinstance(a, wp.array) else a, dtype=np.float64) for a in (M, J_WC, generalized_velocity))
        if J.ndim != 3 or J.shape[1] != 6 or J.shape[2] != M.shape[0] or inactive.shape != (J.shape[0],) or nu.shape != (M.shape[0],):
            raise ValueError(f"compute_impact_velocity takes (nc,), (K, K), (nc, 6, K), (K,); got {inactive.shape}, {M.shape}, {J.shape}, {nu.shape}")
        rows = np.where(inactive[:, None, None], 0.0, J[:, :3, :]).reshape(-1, M.shape[0])
        m = rows.shape[0]
        kkt = np.block([[M, -rows.T], [rows, np.zeros((m, m))]])
        return np.linalg.lstsq(kkt, np.concatenate([M @ nu, np.zeros(m)]), rcond=None)[0][: M.shape[0]]

    def update_velocity_after_impact(self, model, data):
        """A copy of the data whose velocities jumped to the nearest (in the mass matrix's metric) at which every
        point below the terrain is still, and with model.geom_contacts every geom pair contact that penetrates moves
        its two bodies together (JaxSim's; `step` applies it after each step). With more penetrating contacts than
        max_active_contacts an environment is flagged (data.valid_state 0; its velocities NaN where the data has no
        health flags) and its velocities are not projected."""
        return _IMPACTS[RigidContacts](model, data)

    def __repr__(self) -> str:
        return (f"RigidContacts(regularization_delassus={self.regularization_delassus}, solver_options={self._options}, "
                f"max_active_contacts={self.max_active_contacts})")


def _points(value, name: str) -> np.ndarray:
    host = np.asarray(value.numpy() if isinstance(value, wp.array) else value, dtype=np.float64)
    if host.shape[-1:] != (3,):
        raise ValueError(f"{name} must have shape (..., 3), got {host.shape}")
    return host


def _law(p, v, m, h, n, numbers: tuple) -> tuple[np.ndarray, np.ndarray]:
    """(f (..., 3), m_dot (..., 3)): kernels/soft_contacts.py's `hunt_crossley` at the points p, velocities v
    and deformations m (..., 3) on terrain heights h (...) and unit normals n (..., 3), launched on the CPU (the
    default device where Warp's build has no CPU backend) in float64; numbers: (K, D, mu, p, q), K, D and mu broadcast against the points, p and q one number each."""
    K, D, mu, pe, qe = (np.asarray(x.numpy() if isinstance(x, wp.array) else x, dtype=np.float64) for x in numbers)
    for name, value in (("p", pe), ("q", qe)):
        if value.size != 1:
            raise ValueError(f"the soft law's exponent {name} must be one number, got shape {value.shape}")
    device = "cpu" if wp.is_cpu_available() else wp.get_device()  # a Warp build without its CPU backend: the default device
    batch = np.broadcast_shapes(p.shape[:-1], v.shape[:-1], m.shape[:-1], np.shape(h), np.shape(n)[:-1], K.shape, D.shape, mu.shape)
    rows = int(np.prod(batch, dtype=int))
    vec3 = wp.types.vector(3, wp.float64)

    def flat(x, last: tuple) -> wp.array:
        host = np.broadcast_to(np.asarray(x, dtype=np.float64), (*batch, *last)).reshape(rows, *last)
        return wp.array(np.ascontiguousarray(host), dtype=vec3 if last else wp.float64, device=device)

    f, m_dot = wp.empty(rows, dtype=vec3, device=device), wp.empty(rows, dtype=vec3, device=device)
    inputs = [flat(p, (3,)), flat(v, (3,)), flat(m, (3,)), flat(h, ()), flat(n, (3,)), flat(K, ()), flat(D, ()), flat(mu, ()),
              float(pe.reshape(-1)[0]), float(qe.reshape(-1)[0])]
    wp.launch(points_kernel(wp.float64), dim=rows, inputs=inputs, outputs=[f, m_dot], device=device)
    return f.numpy().reshape(*batch, 3), m_dot.numpy().reshape(*batch, 3)
