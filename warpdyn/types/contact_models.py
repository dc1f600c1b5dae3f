"""Contact models, as JaxSim's `jaxsim.rbda.contacts`: the interface (`ContactModel`) and its soft
(Hunt/Crossley) implementation (`SoftContacts`), the value of `Model.contact_model`.

A contact model says which parameters it takes (`parameters_class`: `SoftContactsParams` for the soft law),
what state it adds to the data (`zero_state_variables`: the soft law's tangential deformation of every
collidable point) and how it computes the contact forces. The law itself is written once, in the kernels
(kernels/soft_contacts.py); the whole-model computation (`compute_contact_forces`: kinematics of the points,
then the law) is the engine's, which registers it here for each model class (`register_forces`) when
warpdyn.engine.contact is imported, as `import warpdyn` does. JaxSim's rigid and relaxed-rigid models are not
in warpdyn yet (docs/porting.md: planned).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import warp as wp

from ..kernels.soft_contacts import points_kernel
from .settings import SoftContactsParams

__all__ = ["ContactModel", "SoftContacts", "register_forces"]

_FORCES: dict[type, Callable] = {}


def register_forces(model_class: type, compute: Callable) -> None:
    """Make `compute(model, data, link_forces, joint_force_references)` the whole-model force computation of
    `model_class` (what its `compute_contact_forces` returns): the engine's seam for a contact law."""
    _FORCES[model_class] = compute


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
    the formulas). Parameters: `SoftContactsParams`; state: {"tangential_deformation": (nc_all, 3) [m]}."""

    parameters_class = SoftContactsParams

    @staticmethod
    def zero_state_variables(model) -> dict[str, np.ndarray]:
        """{"tangential_deformation": zeros (nc_all, 3)}: one row per collidable point, enabled or not."""
        return {"tangential_deformation": np.zeros((len(model.kin_dyn_structure().contact_parameters.body), 3))}

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
