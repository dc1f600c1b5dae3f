"""JaxSim's `jaxsim.rbda.contacts`: the contact models and their parameters.

`SoftContacts` (JaxSim's default, the Hunt/Crossley law with a tangential deformation state) is
`model.contact_model`; `SoftContactsParams` its parameters. JaxSim's `RigidContacts` (a QP over friction pyramids
and an impact after each step) and `RelaxedRigidContacts` (a regularised linear solve), with `RigidContactsParams`
and `RelaxedRigidContactsParams`, solve an environment's contact forces together. `ContactModel` and
`ContactsParams` are the interfaces they implement. `MAX_STIFFNESS` and `MAX_DAMPING` bound the estimated parameters
(`warpdyn.contact.estimate_good_contact_parameters`), as JaxSim's; `compute_penetration_data` is the
geometry of one point against the terrain.
"""

from __future__ import annotations

import numpy as np
import warp as wp

from ..types.contact_models import ContactModel, RelaxedRigidContacts, RigidContacts, SoftContacts
from ..types.settings import MAX_DAMPING, MAX_STIFFNESS, ContactsParams, RelaxedRigidContactsParams, RigidContactsParams, SoftContactsParams

__all__ = [
    "ContactModel",
    "ContactsParams",
    "SoftContacts",
    "SoftContactsParams",
    "RigidContacts",
    "RigidContactsParams",
    "RelaxedRigidContacts",
    "RelaxedRigidContactsParams",
    "ContactParamsTypes",
    "MAX_STIFFNESS",
    "MAX_DAMPING",
    "compute_penetration_data",
]

ContactParamsTypes = SoftContactsParams | RigidContactsParams | RelaxedRigidContactsParams
"""The parameter classes of the contact models (JaxSim's union)."""


def compute_penetration_data(p, v, terrain) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(depth (...), depth rate (...), normal (..., 3)) of points at p (..., 3) [m] moving at v (..., 3)
    [m/s] against `terrain`, JaxSim's: the penetration delta = max(0, (h(x, y) - p_z) n_z) [m] with h and n
    the terrain's height and unit normal below the point, its rate -v.n where delta > 0 (else 0) [m/s], and
    n. A FlatTerrain of N heights reads environment e's at p[e]. Host NumPy."""
    P = np.asarray(p.numpy() if isinstance(p, wp.array) else p, dtype=np.float64)
    V = np.asarray(v.numpy() if isinstance(v, wp.array) else v, dtype=np.float64)
    n = terrain.normal(P[..., 0], P[..., 1])
    delta = np.maximum(0.0, terrain.penetration(P))
    return delta, np.where(delta > 0.0, -np.sum(V * n, axis=-1), 0.0), n
