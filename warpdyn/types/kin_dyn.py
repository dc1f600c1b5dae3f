"""A model's kinematic and dynamic parameters as JaxSim's `KinDynParameters` (host-side, NumPy): the links'
and joints' parameters, the joint model, the tree's arrays, the collidable points and frames; and the
enabled points' constants on the model's device (what the contact kernels read).

The points themselves are made from the tree's collision shapes by warpdyn.description.collidable. The link
and joint parameters are a snapshot of the model's (`Model.kin_dyn_parameters` takes it at each model
version); `set_link_mass` and `set_link_inertia` return changed copies, which `Model.replace(
kin_dyn_parameters=...)` applies (as JaxSim's `model.replace`).

Indices: link i (0 the base); joint i moves link i, i = 1..n in the arrays that have a base row (JaxSim's
convention for `joint_model`, `motion_subspaces`, `tree_transforms`, `joint_transforms`), and joint
i - 1 in the joint parameters (n,).
"""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import warp as wp

from ..description.collidable import CollidablePointsOptions, collidable_points
from ..description.model import homogeneous
from ..description.tree import JOINT_PRISMATIC, JOINT_REVOLUTE, KinematicTree
from .constraints import ConstraintMap
from .hardware import HwLinkMetadata

__all__ = ["ContactParameters", "FrameParameters", "JointModel", "JointParameters", "KinDynParameters", "LinkParameters"]

_TRIU = np.triu_indices(3)


def _adjoint(H: np.ndarray) -> np.ndarray:
    """A_X_B (..., 6, 6) of A_H_B (..., 4, 4), [linear; angular]."""
    R, p = H[..., :3, :3], H[..., :3, 3]
    P = np.zeros_like(R)
    P[..., 0, 1], P[..., 0, 2], P[..., 1, 0] = -p[..., 2], p[..., 1], p[..., 2]
    P[..., 1, 2], P[..., 2, 0], P[..., 2, 1] = -p[..., 0], -p[..., 1], p[..., 0]
    X = np.zeros((*H.shape[:-2], 6, 6))
    X[..., :3, :3] = X[..., 3:, 3:] = R
    X[..., :3, 3:] = P @ R
    return X


def _inverse(H: np.ndarray) -> np.ndarray:
    R, p = H[..., :3, :3], H[..., :3, 3]
    out = np.zeros_like(H)
    out[..., :3, :3] = np.swapaxes(R, -1, -2)
    out[..., :3, 3] = -np.einsum("...ji,...j->...i", R, p)
    out[..., 3, 3] = 1.0
    return out


def _axis_angle(axis: np.ndarray, angle) -> np.ndarray:
    """Rotation matrices (..., 3, 3) of `angle` (...) about the unit `axis` (..., 3) (Rodrigues)."""
    K = np.zeros((*axis.shape[:-1], 3, 3))
    K[..., 0, 1], K[..., 0, 2], K[..., 1, 0] = -axis[..., 2], axis[..., 1], axis[..., 2]
    K[..., 1, 2], K[..., 2, 0], K[..., 2, 1] = -axis[..., 0], -axis[..., 1], axis[..., 0]
    angle = np.asarray(angle, dtype=np.float64)[..., None, None]
    return np.eye(3) + np.sin(angle) * K + (1.0 - np.cos(angle)) * (K @ K)


@dataclasses.dataclass(frozen=True)
class LinkParameters:
    """The inertial parameters of the links, as JaxSim's (stacked over the links, NumPy float64).

    index (nL,) int; mass (nL,) [kg]; center_of_mass (nL, 3) L_p_CoM [m, link frame]; inertia_elements
    (nL, 6): the upper triangle (Ixx, Ixy, Ixz, Iyy, Iyz, Izz) of the inertia about the CoM in link axes
    [kg m^2]. A model with per-environment parameters gives them a leading (N,). The static methods take
    one link's values or stacked ones (any leading axes)."""

    index: np.ndarray
    mass: np.ndarray
    center_of_mass: np.ndarray
    inertia_elements: np.ndarray

    @staticmethod
    def build_from_spatial_inertia(index, M) -> LinkParameters:
        """The parameters of the spatial inertia M (..., 6, 6) about the link origin, [linear; angular]."""
        M = np.asarray(M, dtype=np.float64)
        m = np.trace(M[..., :3, :3], axis1=-2, axis2=-1) / 3.0
        mC = M[..., 3:, :3]  # m c^
        c = 0.5 * np.stack([mC[..., 2, 1] - mC[..., 1, 2], mC[..., 0, 2] - mC[..., 2, 0], mC[..., 1, 0] - mC[..., 0, 1]], axis=-1)
        c = c / m[..., None]
        I = M[..., 3:, 3:] - mC @ np.swapaxes(mC, -1, -2) / m[..., None, None]
        return LinkParameters.build_from_inertial_parameters(index, m, I, c)

    @staticmethod
    def build_from_inertial_parameters(index, m, I, c) -> LinkParameters:
        """The parameters of mass m [kg], inertia I (..., 3, 3) about the CoM [kg m^2] and CoM c (..., 3) [m]."""
        I = np.asarray(I, dtype=np.float64)
        return LinkParameters(
            index=np.asarray(index, dtype=np.int64),
            mass=np.asarray(m, dtype=np.float64),
            center_of_mass=np.asarray(c, dtype=np.float64),
            inertia_elements=I[..., _TRIU[0], _TRIU[1]],
        )

    @staticmethod
    def build_from_flat_parameters(index, parameters) -> LinkParameters:
        """The parameters of the flat vector (..., 10): mass, CoM (3), inertia elements (6)."""
        p = np.asarray(parameters, dtype=np.float64)
        return LinkParameters(index=np.asarray(index, dtype=np.int64), mass=p[..., 0], center_of_mass=p[..., 1:4], inertia_elements=p[..., 4:])

    @staticmethod
    def flat_parameters(params: LinkParameters) -> np.ndarray:
        """(..., 10): mass, CoM (3), inertia elements (6)."""
        return np.concatenate([np.asarray(params.mass)[..., None], params.center_of_mass, params.inertia_elements], axis=-1)

    @staticmethod
    def inertia_tensor(params: LinkParameters) -> np.ndarray:
        """The inertia (..., 3, 3) about the CoM [kg m^2]."""
        return LinkParameters.unflatten_inertia_tensor(params.inertia_elements)

    @staticmethod
    def spatial_inertia(params: LinkParameters) -> np.ndarray:
        """L_M_L (..., 6, 6) about the link origin: [[m 1, -m c^], [m c^, I - m c^ c^]]."""
        m = np.asarray(params.mass, dtype=np.float64)
        c = np.asarray(params.center_of_mass, dtype=np.float64)
        C = np.zeros((*c.shape[:-1], 3, 3))
        C[..., 0, 1], C[..., 0, 2], C[..., 1, 0] = -c[..., 2], c[..., 1], c[..., 2]
        C[..., 1, 2], C[..., 2, 0], C[..., 2, 1] = -c[..., 0], -c[..., 1], c[..., 0]
        mm = m[..., None, None]
        out = np.zeros((*C.shape[:-2], 6, 6))
        out[..., :3, :3] = mm * np.eye(3)
        out[..., :3, 3:] = -mm * C
        out[..., 3:, :3] = mm * C
        out[..., 3:, 3:] = LinkParameters.inertia_tensor(params) - mm * (C @ C)
        return out

    @staticmethod
    def flatten_inertia_tensor(I) -> np.ndarray:
        """The upper triangle (..., 6) of inertias (..., 3, 3)."""
        I = np.asarray(I, dtype=np.float64)
        return I[..., _TRIU[0], _TRIU[1]]

    @staticmethod
    def unflatten_inertia_tensor(inertia_elements) -> np.ndarray:
        """The symmetric inertias (..., 3, 3) of their upper triangles (..., 6)."""
        e = np.asarray(inertia_elements, dtype=np.float64)
        I = np.zeros((*e.shape[:-1], 3, 3))
        I[..., _TRIU[0], _TRIU[1]] = e
        I[..., _TRIU[1], _TRIU[0]] = e
        return I


@dataclasses.dataclass(frozen=True)
class JointParameters:
    """The joints' parameters of JaxSim's actuation model (stacked over the joints, NumPy float64, (n,) or
    (N, n) per environment): index (n,) int (1..n, the joint's child link), friction_static [N m or N],
    friction_viscous [N m s/rad or N s/m], position_limits_min and position_limits_max [rad or m],
    position_limit_spring [N m/rad or N/m], position_limit_damper [s/rad or s/m]."""

    index: np.ndarray
    friction_static: np.ndarray
    friction_viscous: np.ndarray
    position_limits_min: np.ndarray
    position_limits_max: np.ndarray
    position_limit_spring: np.ndarray
    position_limit_damper: np.ndarray

    @staticmethod
    def build_from_joint_description(joint_description, index: int = 1) -> JointParameters:
        """The parameters of one warpdyn JointDescription (warpdyn.description.model), its limit springs
        off (the description has none): JaxSim's takes its own JointDescription, which carries the index."""
        d = joint_description
        lower, upper = min(d.lower, d.upper), max(d.lower, d.upper)
        return JointParameters(
            index=np.asarray(index, dtype=np.int64),
            friction_static=np.asarray(d.friction, dtype=np.float64),
            friction_viscous=np.asarray(d.damping, dtype=np.float64),
            position_limits_min=np.asarray(lower, dtype=np.float64),
            position_limits_max=np.asarray(upper, dtype=np.float64),
            position_limit_spring=np.asarray(0.0),
            position_limit_damper=np.asarray(0.0),
        )


@dataclasses.dataclass(frozen=True)
class JointModel:
    """The joints' kinematics as JaxSim's `JointModel`: link i in its parent at joint position q is
    lambda_H_pre[i] @ pre_H_suc(q) @ suc_H_i[i], pre_H_suc the joint's motion (`warpdyn.math.
    supported_joint_motion`), for i = 1..n; index 0 is the world-to-base joint (identities).
    lambda_H_pre, suc_H_i (1 + n, 4, 4); joint_dofs, joint_names, joint_types (0 fixed, 1 revolute,
    2 prismatic) of 1 + n joints; joint_axis (n, 3) in the child frame. A revolute joint whose axis passes
    through a pivot d (MJCF) has lambda_H_pre = origin T(d) and suc_H_i = T(-d)."""

    lambda_H_pre: np.ndarray
    suc_H_i: np.ndarray
    joint_dofs: tuple
    joint_names: tuple
    joint_types: tuple
    joint_axis: np.ndarray

    @staticmethod
    def build(model_or_tree) -> JointModel:
        """The joint model of a warpdyn Model or its lumped tree (JaxSim's takes its parsed description)."""
        tree: KinematicTree = getattr(model_or_tree, "tree", model_or_tree)
        nL = tree.number_of_links
        pre, suc = np.tile(np.eye(4), (nL, 1, 1)), np.tile(np.eye(4), (nL, 1, 1))
        for i in range(1, nL):
            pivot = np.asarray(tree.joint_pivot[i], dtype=np.float64)
            pre[i] = np.asarray(tree.parent_H_joint[i], dtype=np.float64) @ homogeneous(np.eye(3), pivot)
            suc[i] = homogeneous(np.eye(3), -pivot)
        base_dofs = 6 if getattr(model_or_tree, "floating_base", lambda: True)() else 0
        return JointModel(
            lambda_H_pre=pre,
            suc_H_i=suc,
            joint_dofs=(base_dofs, *(int(tree.v_start[i + 1] - tree.v_start[i]) for i in range(1, nL))),
            joint_names=("world_to_base", *tree.joint_names),
            joint_types=(0, *(int(t) for t in tree.joint_type[1:])),
            joint_axis=np.asarray(tree.joint_axis[1:], dtype=np.float64).reshape(nL - 1, 3),
        )

    @property
    def λ_H_pre(self) -> np.ndarray:  # noqa: PLC2401 (JaxSim's name)
        """JaxSim's name of `lambda_H_pre`."""
        return self.lambda_H_pre

    def parent_H_predecessor(self, joint_index: int) -> np.ndarray:
        """lambda(i)_H_pre(i) (4, 4) of joint i (0 the world-to-base joint)."""
        return self.lambda_H_pre[joint_index]

    def successor_H_child(self, joint_index: int) -> np.ndarray:
        """suc(i)_H_i (4, 4) of joint i."""
        return self.suc_H_i[joint_index]


@dataclasses.dataclass(frozen=True)
class ContactParameters:
    """The collidable points of a model, as JaxSim's `ContactParameters` (host-side, NumPy).

    body: for EVERY collidable point, the index of the link it is attached to (len(body) = all points).
    point: (len(body), 3) float64, L_p_C: the point in its link's frame [m].
    enabled: for every point, whether contact functions use it. Functions of `warpdyn.contact` return
    the enabled points only, in this order ("nc" in their docstrings).
    """

    body: tuple[int, ...]
    point: np.ndarray
    enabled: tuple[bool, ...]

    @property
    def indices_of_enabled_collidable_points(self) -> np.ndarray:
        """(nc,) int: the indices, among all points, of the enabled ones."""
        return np.flatnonzero(np.asarray(self.enabled, dtype=bool))


@dataclasses.dataclass(frozen=True)
class FrameParameters:
    """The frames (lumped links) of a model, as JaxSim's: name, body (parent link index) and
    transform (nF, 4, 4) L_H_F, float64."""

    name: tuple[str, ...]
    body: tuple[int, ...]
    transform: np.ndarray


@dataclasses.dataclass(eq=False)
class KinDynParameters:
    """JaxSim's `KinDynParameters`, host-side (NumPy): what scripts ported from JaxSim read.

    contact_parameters: the collidable points (`ContactParameters`).
    frame_parameters: the frames (`FrameParameters`).
    link_names: (nL,) names; parent_array: (nL,) int, -1 for the base.
    support_body_array_bool: (nL, nL) bool, [L, j] true when link j is on the path from the base to L
    (L and the base included).
    options: the `CollidablePointsOptions` the points were made with.
    link_parameters, joint_parameters (`LinkParameters`, `JointParameters`): the model's link and joint
    parameters when this object was taken from the model (`Model.kin_dyn_parameters`); joint_model
    (`JointModel`); hw_link_metadata (`HwLinkMetadata`, JaxSim's hardware parametrisation: `hw_link_metadata(model)`);
    constraints: the model's kinematic constraints (a `ConstraintMap`, empty when none, as JaxSim's).
    Read-only (dataclasses.FrozenInstanceError) but for `constraints`: assigning it on the snapshot a model's
    `kin_dyn_parameters` returned sets the model's too, JaxSim's `with model.editable() as model:
    model.kin_dyn_parameters.constraints = constraints` (copies made from the snapshot are not the model's).
    Equality and hash, as JaxSim's: the structure (numbers of links and joints, frames, parent and support
    arrays), not the parameters' values.
    The enabled points' link indices also live on the model's device (`enabled_link`, (nc,) int), for the contact
    kernels (their positions: `Model.collidable_point_rows`).
    """

    contact_parameters: ContactParameters
    frame_parameters: FrameParameters
    link_names: tuple[str, ...]
    parent_array: np.ndarray
    support_body_array_bool: np.ndarray
    options: CollidablePointsOptions
    enabled_link: wp.array = dataclasses.field(repr=False)
    joint_model: JointModel | None = dataclasses.field(default=None, repr=False)
    link_parameters: LinkParameters | None = dataclasses.field(default=None, repr=False)
    joint_parameters: JointParameters | None = dataclasses.field(default=None, repr=False)
    hw_link_metadata: HwLinkMetadata | None = dataclasses.field(default=None, repr=False)
    constraints: ConstraintMap = dataclasses.field(default_factory=ConstraintMap)

    def __post_init__(self):
        object.__setattr__(self, "_owner", None)  # the model whose snapshot this is (`owned_by`); copies have none
        object.__setattr__(self, "_sealed", True)

    def owned_by(self, model) -> KinDynParameters:
        """This object as `model`'s snapshot: assigning its `constraints` sets the model's."""
        object.__setattr__(self, "_owner", model)
        return self

    def __setattr__(self, name: str, value) -> None:
        if not getattr(self, "_sealed", False):  # the dataclass's __init__
            object.__setattr__(self, name, value)
            return
        if name != "constraints":
            raise dataclasses.FrozenInstanceError(
                f"cannot assign to field {name!r}: KinDynParameters is read-only but for `constraints`; change parameters with "
                "its set_link_mass / set_link_inertia copies and model.replace(kin_dyn_parameters=...), or the model's setters"
            )
        if not isinstance(value, ConstraintMap):
            raise TypeError(f"kin_dyn_parameters.constraints must be a wd.kin_dyn_parameters.ConstraintMap, got {type(value).__name__}")
        if self._owner is not None:
            self._owner.constraints = value
            value = self._owner.constraints
        object.__setattr__(self, name, value)

    def __delattr__(self, name: str) -> None:
        raise dataclasses.FrozenInstanceError(f"cannot delete field {name!r}: KinDynParameters is read-only")

    def structure_only(self) -> KinDynParameters:
        """These parameters without the snapshot's parts (joint model, link and joint parameters, constraints, hardware
        metadata): what a model keeps as its structure."""
        return dataclasses.replace(self, joint_model=None, link_parameters=None, joint_parameters=None, constraints=ConstraintMap(), hw_link_metadata=None)

    def __eq__(self, other) -> bool:
        return isinstance(other, KinDynParameters) and self._structure() == other._structure()

    def __hash__(self) -> int:
        return hash(self._structure())

    def _structure(self) -> tuple:
        return (
            len(self.link_names),
            self.number_of_joints(),
            self.frame_parameters.name,
            self.frame_parameters.body,
            tuple(int(p) for p in self.parent_array),
            self.support_body_array_bool.tobytes(),
        )

    def number_of_links(self) -> int:
        return len(self.link_names)

    def number_of_joints(self) -> int:
        return len(self.link_names) - 1

    def number_of_frames(self) -> int:
        return len(self.frame_parameters.name)

    def support_body_array(self, link_index: int) -> np.ndarray:
        """kappa(i): the indices of the links from the base to link `link_index` (both included), (k,) int."""
        return np.flatnonzero(self.support_body_array_bool[link_index])

    @property
    def motion_subspaces(self) -> np.ndarray:
        """S (nL, 6, 1): each joint's motion subspace in its child link's frame, [linear; angular] (row 0, the
        base: zeros). A revolute axis a through the pivot d: [d x a; a] (JaxSim's joints have no pivot: [0; a])."""
        tree = self.joint_model
        nL = len(self.link_names)
        _one_dof_only(tree, "motion_subspaces")
        S = np.zeros((nL, 6, 1))
        for i in range(1, nL):
            a = tree.joint_axis[i - 1]
            d = -tree.suc_H_i[i][:3, 3]
            if tree.joint_types[i] == JOINT_REVOLUTE:
                S[i, :, 0] = [*np.cross(d, a), *a]
            elif tree.joint_types[i] == JOINT_PRISMATIC:
                S[i, :3, 0] = a
        return S

    @property
    def level_nodes(self) -> np.ndarray:
        """(levels, width) int: the links at each depth of the tree (0: the base), padded with 0."""
        return self._levels()[0]

    @property
    def level_mask(self) -> np.ndarray:
        """(levels, width) bool: True where `level_nodes` holds a link, False in the padding."""
        return self._levels()[1]

    def _levels(self) -> tuple[np.ndarray, np.ndarray]:
        depth = np.zeros(len(self.parent_array), dtype=int)
        for i in range(1, len(depth)):
            depth[i] = depth[self.parent_array[i]] + 1
        rows = [np.flatnonzero(depth == k) for k in range(depth.max() + 1)]
        width = max(len(r) for r in rows)
        nodes, mask = np.zeros((len(rows), width), dtype=int), np.zeros((len(rows), width), dtype=bool)
        for k, r in enumerate(rows):
            nodes[k, : len(r)], mask[k, : len(r)] = r, True
        return nodes, mask

    def links_spatial_inertia(self) -> np.ndarray:
        """L_M_L (nL, 6, 6) (or (N, nL, 6, 6)) of `link_parameters`, about each link's origin."""
        return LinkParameters.spatial_inertia(self.link_parameters)

    def tree_transforms(self) -> np.ndarray:
        """pre(i)_X_lambda(i) (nL, 6, 6): the motion adjoint from each joint's parent link to its predecessor
        frame (row 0: zeros), JaxSim's."""
        X = _adjoint(_inverse(self.joint_model.lambda_H_pre))
        X[0] = 0.0
        return X

    def joint_transforms(self, joint_positions, base_transform) -> np.ndarray:
        """i_X_lambda(i) (nL, 6, 6): the motion adjoint from each link's parent to the link at `joint_positions`
        (n,) [rad or m]; row 0: B_X_W of `base_transform` W_H_B (4, 4). JaxSim's."""
        jm = self.joint_model
        _one_dof_only(jm, "joint_transforms")
        s = np.asarray(joint_positions, dtype=np.float64).reshape(-1)
        if s.shape != (self.number_of_joints(),):
            raise ValueError(f"joint_positions has {s.size} values, the model {self.number_of_joints()} joints")
        motion = np.tile(np.eye(4), (len(self.link_names), 1, 1))
        motion[0] = np.asarray(base_transform, dtype=np.float64).reshape(4, 4)
        for i in range(1, len(self.link_names)):
            a, kind = jm.joint_axis[i - 1], jm.joint_types[i]
            if kind == JOINT_REVOLUTE:
                motion[i, :3, :3] = _axis_angle(a, s[i - 1])
            elif kind == JOINT_PRISMATIC:
                motion[i, :3, 3] = s[i - 1] * a
        return _adjoint(_inverse(jm.lambda_H_pre @ motion @ jm.suc_H_i))

    def set_link_mass(self, link_index: int, mass) -> KinDynParameters:
        """A copy with link `link_index`'s mass [kg] set (apply it with `Model.replace(kin_dyn_parameters=...)`)."""
        masses = np.array(self.link_parameters.mass, dtype=np.float64)
        masses[..., link_index] = mass
        return dataclasses.replace(self, link_parameters=dataclasses.replace(self.link_parameters, mass=masses))

    def set_link_inertia(self, link_index: int, inertia) -> KinDynParameters:
        """A copy with link `link_index`'s inertia (3, 3) about its CoM [kg m^2] set."""
        elements = np.array(self.link_parameters.inertia_elements, dtype=np.float64)
        elements[..., link_index, :] = LinkParameters.flatten_inertia_tensor(inertia)
        return dataclasses.replace(self, link_parameters=dataclasses.replace(self.link_parameters, inertia_elements=elements))

    @staticmethod
    def build(model, options: CollidablePointsOptions | None = None, enabled=None, *, warn: bool = True):
        """The parameters of `model`: points made with `options` (default `CollidablePointsOptions()`),
        `enabled` a mask over all points (default: all enabled)."""
        tree = model.tree
        options = CollidablePointsOptions() if options is None else options
        path = getattr(model.description, "path", None)
        base_dir = pathlib.Path(path).parent if path else None
        body, point = collidable_points(tree, options, base_dir, warn=warn)
        contact = _contact_parameters(body, point, enabled)
        nL = tree.number_of_links
        support = np.zeros((nL, nL), dtype=bool)
        support[:, 0] = True
        support[:, 1:] = tree.support().astype(bool)
        frames = FrameParameters(
            name=tuple(tree.frame_names),
            body=tuple(int(b) for b in tree.frame_parent),
            transform=np.asarray(tree.link_H_frame, dtype=np.float64).reshape(-1, 4, 4),
        )
        return KinDynParameters(
            contact_parameters=contact,
            frame_parameters=frames,
            link_names=tuple(tree.link_names),
            parent_array=np.asarray(tree.parent, dtype=np.int64),
            support_body_array_bool=support,
            options=options,
            enabled_link=_enabled_links(contact, model.device),
        )

    def with_points(self, model, point: np.ndarray) -> KinDynParameters:
        """The same parameters with the points at `point` (nc_all, 3) [m, link frames]."""
        contact = _contact_parameters(np.asarray(self.contact_parameters.body, dtype=np.int64), point, self.contact_parameters.enabled)
        return dataclasses.replace(self, contact_parameters=contact, enabled_link=_enabled_links(contact, model.device))

    def with_enabled(self, model, enabled) -> KinDynParameters:
        """The same parameters with another enabled mask (over all points)."""
        contact = _contact_parameters(np.asarray(self.contact_parameters.body, dtype=np.int64), self.contact_parameters.point, enabled)
        return dataclasses.replace(self, contact_parameters=contact, enabled_link=_enabled_links(contact, model.device))


def _one_dof_only(joint_model: JointModel, what: str) -> None:
    """A NotImplementedError naming the first ball or free joint: JaxSim's host helpers have one-DoF joints only
    (warpdyn.model.joint_transforms and the kernels take every joint)."""
    for name, dofs in zip(joint_model.joint_names[1:], joint_model.joint_dofs[1:]):
        if dofs != 1:
            raise NotImplementedError(f"KinDynParameters.{what} is JaxSim's, for one-DoF joints; joint '{name}' has {dofs} (use warpdyn.model.joint_transforms)")


def _contact_parameters(body: np.ndarray, point: np.ndarray, enabled) -> ContactParameters:
    count = len(body)
    if enabled is None:
        mask = np.ones(count, dtype=bool)
    else:
        mask = np.asarray(enabled)
        if mask.size == 0:
            mask = mask.astype(bool)  # an empty mask (a model without points) has no dtype of its own
        if mask.dtype != bool:
            raise TypeError(f"enabled must be a boolean mask over all {count} collidable points, got dtype {mask.dtype}")
        if mask.shape != (count,):
            raise ValueError(f"enabled has shape {mask.shape}, expected ({count},): one flag per collidable point")
    point = np.array(point, dtype=np.float64).reshape(count, 3)
    point.setflags(write=False)
    return ContactParameters(
        body=tuple(int(b) for b in body), point=point, enabled=tuple(bool(e) for e in mask)
    )


def _enabled_links(contact: ContactParameters, device) -> wp.array:
    """The links (nc,) int of the enabled points on `device`."""
    idx = contact.indices_of_enabled_collidable_points
    return wp.array(np.asarray(contact.body, dtype=np.int32)[idx], dtype=int, device=device)
