"""Collidable points, their kinematics and their soft-contact forces, as JaxSim's `jaxsim.api.contact`.

The points come from the description's collision shapes (`warpdyn.description.collidable` says how each
becomes points, and in which order); a lumped link's points belong to the link it is lumped into.
`model.kin_dyn_structure().contact_parameters` lists ALL points (`body`, `point`, `enabled`), as JaxSim;
the functions below return the ENABLED points only, in that order: "nc" is their number. Change the
options or the enabled points with `with_collidable_points`.

The contact frame of a point C on link L is C = (W_p_C, [L]): origin at the point, the link's orientation,
as JaxSim's. Results are Warp arrays on the model's device: JaxSim's shapes for single-environment data,
a leading environment axis N for batched data.
"""

from __future__ import annotations

import warnings
from typing import NamedTuple

import numpy as np
import warp as wp

from . import arrays, com
from .data import Data
from .description import NotModelledWarning
from .description.collidable import CollidablePointsOptions, NoCollidablePointsWarning, UnresolvedMeshWarning, resolve_mesh_uri
from .description.collision_pairs import MULTICCD_TYPES
from .kernels.geom_types import MESH
from .engine import collisions, contact, derivatives, kinematics
from .types import names
from .types.enums import VelRepr, output_repr
from .types import geoms as geom_types
from .types.geoms import GeomPairs
from .types.kin_dyn import ContactParameters, FrameParameters, KinDynParameters
from .types.settings import STANDARD_GRAVITY, SoftContactsParams

__all__ = [
    "CollidablePointsOptions",
    "ContactParameters",
    "FrameParameters",
    "KinDynParameters",
    "NoCollidablePointsWarning",
    "UnresolvedMeshWarning",
    "resolve_mesh_uri",
    "with_collidable_points",
    "collidable_point_kinematics",
    "collidable_point_positions",
    "collidable_point_velocities",
    "in_contact",
    "link_contact_forces",
    "link_forces_from_contact_forces",
    "collidable_point_forces",
    "estimate_good_contact_parameters",
    "estimate_good_soft_contacts_parameters",
    "transforms",
    "jacobian",
    "jacobian_derivative",
    "GeomContacts",
    "geom_pairs",
    "geom_contacts",
    "with_self_collision",
]


def with_collidable_points(model, *, options: CollidablePointsOptions | None = None, enabled=None, enabled_links=None):
    """A model like `model` (sharing its device constants) with other collidable points.

    options: how shapes become points (`CollidablePointsOptions`); None keeps the model's.
    enabled: a boolean mask over all the points (after `options` are applied), or
    enabled_links: link names whose points are enabled, the others disabled.
    With neither, every point is enabled. `model` itself is left unchanged. Points that update_hw_parameters
    moved (per environment, or carrying gradients to the scaling factors) stay theirs when only the mask changes.

    Example (JaxSim's behaviour: no mesh points; only the feet in contact):
        model = wd.contact.with_collidable_points(
            model, options=wd.contact.CollidablePointsOptions(shapes=("box", "sphere")),
            enabled_links=("l_ankle_2", "r_ankle_2"))
    """
    if enabled is not None and enabled_links is not None:
        raise ValueError("give either enabled (a mask over the points) or enabled_links (link names), not both")
    if options is not None and not isinstance(options, CollidablePointsOptions):
        raise TypeError(f"options must be a CollidablePointsOptions, got {type(options).__name__}")
    kernel_points = model.collidable_point_array  # update_hw_parameters' points: kept where only the mask changes
    if options is not None and kernel_points is not None and kernel_points.shape[0] > 1:
        raise ValueError("with_collidable_points: the model's points are per environment (update_hw_parameters with per-environment "
                         "shapes) and options would make them again from the description's shapes, which are environment 0's; "
                         "choose the points' options before scaling the shapes")
    params = model.kin_dyn_structure() if options is None else KinDynParameters.build(model, options)
    if enabled_links is not None:
        if isinstance(enabled_links, str):
            enabled_links = (enabled_links,)
        links = {names.name_to_idx("link", model.link_names(), name) for name in enabled_links}
        enabled = np.array([b in links for b in params.contact_parameters.body], dtype=bool)
    if enabled is None and not all(params.contact_parameters.enabled):  # neither given: every point enabled
        enabled = np.ones(len(params.contact_parameters.body), dtype=bool)
    if enabled is not None:
        params = params.with_enabled(model, enabled)
    return model.with_kin_dyn_parameters(params, point_array=kernel_points if options is None else None)


def collidable_point_positions(model, data) -> wp.array:
    """W_p_C: the world positions of the enabled collidable points [m], (nc, 3) or (N, nc, 3)."""
    return arrays.squeeze_env(contact.positions(model, data), data.num_envs)


def collidable_point_velocities(model, data) -> wp.array:
    """W_pdot_C: the velocities of the enabled collidable points [m/s], (nc, 3) or (N, nc, 3).

    The plain time derivative of W_p_C in world coordinates (the linear part of the contact frame's
    Mixed velocity), whatever the data's velocity representation.
    """
    return arrays.squeeze_env(contact.point_velocities(model, data), data.num_envs)


def collidable_point_kinematics(model, data) -> tuple[wp.array, wp.array]:
    """(W_p_C, W_pdot_C) of the enabled collidable points: each (nc, 3) or (N, nc, 3)."""
    return collidable_point_positions(model, data), collidable_point_velocities(model, data)


def in_contact(model, data, *, link_names=None) -> wp.array:
    """Whether each link touches the terrain (`model.terrain`): any of its enabled points at or below it; and, where
    model.geom_contacts is set, whether it touches another body: a contact of one of its geom pairs (`geom_contacts`)
    at dist <= 0 (the surfaces touching or penetrating; Isaac Lab's ContactSensor and MuJoCo's touch sensor read the
    same contacts' forces, `link_contact_forces`).

    JaxSim's test: a point C is below when W_p_C.z <= h(W_p_C.x, W_p_C.y), the terrain's height above the
    point's (x, y) (equality counts). The contact force uses the depth delta = (h - z) n_z instead and acts
    only for delta > 0 strictly, so a point exactly on the terrain is "in contact" with zero force.
    link_names: the links asked about (default: all, in the model's order); a link without enabled points or
    acting geom pairs is never in contact. (nL,) or (N, nL) bool, or (k,) / (N, k) for k given names.
    """
    indices = None
    if link_names is not None:
        if isinstance(link_names, str):
            link_names = (link_names,)
        indices = [names.name_to_idx("link", model.link_names(), name) for name in link_names]
    return arrays.squeeze_env(contact.links_in_contact(model, data, indices), data.num_envs)


def link_contact_forces(
    model, data, *, link_forces=None, joint_force_references=None, joint_torques=None, output_vel_repr=VelRepr.Inertial
) -> tuple[wp.array, dict]:
    """(f_L, derivatives), JaxSim's: the contact wrench on each link, (nL, 6) or (N, nL, 6), [force; torque],
    and the rates of the contact model's state, {"m_dot": (rows, 3) or (N, rows, 3)} [m/s] for the soft
    law (0 for disabled points; rows: Model.contact_state_rows, the geom pairs' slots after the points), at the data's state (one contact evaluation). f_L in `output_vel_repr` for the link frame L (default
    Inertial, as JaxSim's, whatever the data's representation):
    - Inertial: W_f_L = sum over L's enabled points C of [f_C; W_p_C x f_C] (torque about the world origin),
      plus, where model.geom_contacts is set, the wrenches of L's geom pairs' contacts (`geom_contacts`), what
      `step` adds to the link's external force;
    - Mixed: the same force with its torque about the link origin, world axes: [f; tau_W - W_p_L x f];
    - Body: L_X*_W W_f_L, force and torque at the link origin in link axes.
    The point forces are the contact model's (`model.contact_model`, `model.contact_params`, `model.terrain`)
    at the data's state, the ones a step starting there applies. Links without enabled points get zeros.
    link_forces (in the data's representation), joint_force_references (alias joint_torques, JaxSim's name): the
    other forces acting, which JaxSim's rigid models read and the soft law does not (checked, then unused).
    """
    if joint_torques is not None:
        if joint_force_references is not None:
            raise ValueError("give joint_force_references or joint_torques (the same argument), not both")
        joint_force_references = joint_torques
    W_f_ext, tau = contact.other_forces(model, data, link_forces, joint_force_references)
    out, m_dot = contact.link_wrenches_and_rates(model, data, int(output_repr(data, output_vel_repr)), W_f_ext, tau)
    return arrays.squeeze_env(out, data.num_envs), {"m_dot": arrays.squeeze_env(m_dot, data.num_envs)}


def link_forces_from_contact_forces(model, *, contact_forces) -> wp.array:
    """W_f_L (nL, 6) or (N, nL, 6): the Inertial contact forces of the enabled points (nc, 6) or (N, nc, 6)
    [N; N m] (as `model.contact_model.compute_contact_forces` returns them) summed per link, JaxSim's.
    Inertial forces add without a transform. On the host (a NumPy sum), returned on the model's device."""
    host = arrays.host_numbers(contact_forces.numpy() if isinstance(contact_forces, wp.array) else contact_forces, "contact_forces")
    params = model.kin_dyn_structure().contact_parameters
    idx = params.indices_of_enabled_collidable_points
    if host.shape[-2:] != (len(idx), 6) or host.ndim not in (2, 3):
        raise ValueError(f"contact_forces has shape {host.shape}, expected ({len(idx)}, 6) or (N, {len(idx)}, 6): one row per enabled collidable point")
    of_link = np.asarray(params.body, dtype=np.int64)[idx][:, None] == np.arange(model.number_of_links())  # (nc, nL)
    return wp.array(np.einsum("cl,...ca->...la", of_link, host), dtype=model.scalar, device=model.device)


def collidable_point_forces(model, data, *, link_forces=None, joint_force_references=None, output_vel_repr=None) -> wp.array:
    """The contact wrench on each enabled point (`model.contact_model`'s): (nc, 6) or (N, nc, 6), as old JaxSim's
    `collidable_point_forces`, for the contact frame C = (W_p_C, [L]) in `output_vel_repr` (default: the
    data's): Inertial [f; W_p_C x f]; Mixed [f; 0] (f the force in world axes [N], what the contact model
    computes); Body [L_R_W f; 0]. Summed over a link's points (Inertial), they give `link_contact_forces`.
    link_forces, joint_force_references: as in `link_contact_forces`.
    """
    W_f_ext, tau = contact.other_forces(model, data, link_forces, joint_force_references)
    out = contact.point_wrenches(model, data, int(output_repr(data, output_vel_repr)), W_f_ext, tau)
    return arrays.squeeze_env(out, data.num_envs)


def transforms(model, data) -> wp.array:
    """W_H_C: the contact frames of the enabled points, C = (W_p_C, [L]) with L the point's link,
    (nc, 4, 4) or (N, nc, 4, 4)."""
    return arrays.squeeze_env(kinematics.poses(model, data, contact.point_targets(model)), data.num_envs)


def jacobian(model, data, *, output_vel_repr=None) -> wp.array:
    """The free-floating Jacobians of the enabled points' contact frames: (nc, 6, 6 + n) or (N, nc, 6, 6 + n).

    Columns act on the generalized velocity in the data's representation; rows give the contact
    frame's velocity in `output_vel_repr` (default: the data's): Inertial W_v_WC (= the link's), Body
    C_v_WC, Mixed C[W]_v_WC = [W_pdot_C; W_omega_WL].
    """
    J = kinematics.jacobians(model, data, contact.point_targets(model), output_vel_repr)
    return arrays.squeeze_env(J, data.num_envs)


def jacobian_derivative(model, data, *, output_vel_repr=None) -> wp.array:
    """The time derivatives of `jacobian(...)`: (nc, 6, 6 + n) or (N, nc, 6, 6 + n), same representations."""
    Jdot = derivatives.jacobian_derivatives(model, data, contact.point_targets(model), output_vel_repr)
    return arrays.squeeze_env(Jdot, data.num_envs)


def geom_pairs(model) -> GeomPairs:
    """The pairs of geoms on the model's links that may collide, as MuJoCo's mj_collision decides them before it
    looks at poses (warpdyn.description.collision_pairs: its body, weld and bit-mask filters, `<exclude>`, explicit
    `<pair>`s), fixed when the model is built: `GeomPairs` (warpdyn.types.geoms) with the geoms' names, links,
    types, sizes, margins, friction and each pair's contact slots. MJCF only; empty for URDF and SDF."""
    return collisions.geom_pairs(model)


class GeomContacts(NamedTuple):
    """The contacts of a model's geom pairs at a state (`geom_contacts`), MuJoCo's d.contact for those pairs.

    count: (nP,) or (N, nP) int, each pair's contacts; position: (C, 3) or (N, C, 3) [m, world], the point midway
    between the surfaces; frame: (C, 3, 3) or (N, C, 3, 3), MuJoCo's contact frame, its rows the normal (from geom1
    to geom2) and two tangents; distance: (C,) or (N, C) [m], between the surfaces along the normal, negative when
    they penetrate. Pair i's contacts are slots first[i] .. first[i] + count[i] - 1 (`geom_pairs(model).first`); the
    slots past a pair's count hold position 0, frame 0 and distance +inf."""

    count: wp.array
    position: wp.array
    frame: wp.array
    distance: wp.array


def with_self_collision(model, *, exclude=(), options: CollidablePointsOptions | None = None):
    """A model like a URDF or SDF `model` whose links' collision shapes collide with each other, as MuJoCo collides
    those of the same URDF (warpdyn.types.geoms.self_collision): every pair of shapes on two links but a link and its
    parent (unless the parent is a fixed base) and the link-name pairs in `exclude`; `geom_pairs` lists them. They act
    in a step where model.geom_contacts is set. Meshes collide as their files' vertices' convex hulls (found as
    collidable points find them: `options`' package_dirs and mesh_dirs, the description's directory); pairs of a mesh
    whose file was not found or read are counted in a NotModelledWarning. Their hulls' polygons, MuJoCo's multiCCD's
    faces, are those MuJoCo compiles from the same vertices (up to 4 contacts where faces meet: kernels/collision_polygons.py);
    without MuJoCo installed (or for a flat mesh) a mesh has none and its pairs get one contact, counted in a
    NotModelledWarning. An MJCF model's pairs are MuJoCo's: a ValueError."""
    new, uncollided = geom_types.self_collision(model, exclude, options)
    if uncollided:
        counts = ", ".join(f"{n} {kinds}" for kinds, n in sorted(uncollided.items()))
        warnings.warn(f"model '{model.name()}': shape pairs that warpdyn's narrow phase does not collide (meshes whose files were not found or read: "
                      f"CollidablePointsOptions' package_dirs and mesh_dirs say where to look): {counts}", NotModelledWarning, stacklevel=2)  # fmt: skip
    pairs = geom_types.geom_pairs(new)
    faceless = int(sum((int(a), int(b)) in MULTICCD_TYPES and MESH in (a, b) and n == 1 for a, b, n in zip(pairs.type1, pairs.type2, pairs.slots)))
    if faceless:
        warnings.warn(f"model '{model.name()}': {faceless} shape pairs with a mesh get one contact (GJK and EPA): the hull's polygons, on which "
                      "MuJoCo's multiCCD gives up to 4, are compiled by MuJoCo, which is not installed (pip install mujoco) or did not compile "
                      "the mesh (a flat one)", NotModelledWarning, stacklevel=2)  # fmt: skip
    return new


def geom_contacts(model, data) -> GeomContacts:
    """The contacts between the model's geom pairs at the data's state, as MuJoCo's narrow phase finds them
    (`GeomContacts`): sphere, capsule, ellipsoid, box, cylinder and convex mesh pairs (the cylinder's but sphere-cylinder,
    the ellipsoid's and the mesh's by GJK and EPA, one contact: kernels/collision_convex.py, or up to 4 by MuJoCo's
    multiCCD where their faces meet: kernels/collision_polygons.py; a pair of other types is not in `geom_pairs`;
    the loader names it in a NotModelledWarning). A contact is reported where the surfaces are
    nearer than the pair's margin + gap, as MuJoCo reports it. They act in a step where model.geom_contacts is set
    (the soft law at each contact that penetrates)."""
    count, position, frame, dist = collisions.geom_contacts(model, data)
    n = data.num_envs
    return GeomContacts(*(arrays.squeeze_env(a, n) for a in (count, position, frame, dist)))


def estimate_good_contact_parameters(
    model,
    *,
    standard_gravity: float = STANDARD_GRAVITY,
    static_friction_coefficient: float = 0.5,
    number_of_active_collidable_points_steady_state: int = 1,
    damping_ratio: float = 1.0,
    max_penetration: float | None = None,
) -> SoftContactsParams:
    """JaxSim's estimate: K so that the robot's weight shared by the active points penetrates
    max_penetration (default: 1% of the CoM height above the lowest collidable point at the zero state),
    K = m g / n / delta_max^(1 + p) clipped to 1e6, and D = damping_ratio 2 sqrt(K m) clipped to 1e4
    (`model.contact_params`' class's `build_default_from_jaxsim_model`). m is the model's current total mass
    (`model.link_mass`); with masses given per environment, K and D are one value per environment (N,)."""
    if max_penetration is None:
        masses = np.asarray(model.link_mass.numpy())
        zero = Data.build(model, num_envs=masses.shape[0] if masses.ndim == 2 else None)
        height = com.com_position(model, zero).numpy()[..., 2]
        if model.floating_base():
            points = collidable_point_positions(model, zero).numpy()
            if points.shape[-2]:
                height = height - points[..., 2].min(axis=-1)
        max_penetration = 0.01 * height
    return model.contact_model.parameters_class.build_default_from_jaxsim_model(
        model,
        standard_gravity=standard_gravity,
        static_friction_coefficient=static_friction_coefficient,
        max_penetration=max_penetration,
        number_of_active_collidable_points_steady_state=number_of_active_collidable_points_steady_state,
        damping_ratio=damping_ratio,
    )

def estimate_good_soft_contacts_parameters(*args, **kwargs) -> SoftContactsParams:
    """JaxSim's deprecated name of `estimate_good_contact_parameters` (a DeprecationWarning, then the same)."""
    warnings.warn("estimate_good_soft_contacts_parameters is deprecated (as in JaxSim): use estimate_good_contact_parameters", DeprecationWarning, stacklevel=2)
    return estimate_good_contact_parameters(*args, **kwargs)
