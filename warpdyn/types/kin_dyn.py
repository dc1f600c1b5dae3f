"""The collidable points and frames of a model as JaxSim's `KinDynParameters` (host-side, NumPy), and the
enabled points' constants on the model's device (what the contact kernels read).

The points themselves are made from the tree's collision shapes by warpdyn.description.collidable.
"""

from __future__ import annotations

import dataclasses
import pathlib

import numpy as np
import warp as wp

from ..description.collidable import CollidablePointsOptions, collidable_points

__all__ = ["ContactParameters", "FrameParameters", "KinDynParameters"]


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


@dataclasses.dataclass(frozen=True, eq=False)
class KinDynParameters:
    """Part of JaxSim's `KinDynParameters`, host-side (NumPy): what scripts ported from JaxSim read.

    contact_parameters: the collidable points (`ContactParameters`).
    frame_parameters: the frames (`FrameParameters`).
    link_names: (nL,) names; parent_array: (nL,) int, -1 for the base.
    support_body_array_bool: (nL, nL) bool, [L, j] true when link j is on the path from the base to L
    (L and the base included).
    options: the `CollidablePointsOptions` the points were made with.
    The enabled points' link indices, offsets and positions also live on the model's device (`enabled_link`,
    `enabled_link_H_point`, `enabled_point`: (nc,) int, (nc,) transform and (nc,) vec3 L_p_C [m]), for
    the contact kernels.
    """

    contact_parameters: ContactParameters
    frame_parameters: FrameParameters
    link_names: tuple[str, ...]
    parent_array: np.ndarray
    support_body_array_bool: np.ndarray
    options: CollidablePointsOptions
    enabled_link: wp.array = dataclasses.field(repr=False)
    enabled_link_H_point: wp.array = dataclasses.field(repr=False)
    enabled_point: wp.array = dataclasses.field(repr=False)

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
        link, link_H_point, L_p_C = _device_targets(contact, model.scalar, model.device)
        return KinDynParameters(
            contact_parameters=contact,
            frame_parameters=frames,
            link_names=tuple(tree.link_names),
            parent_array=np.asarray(tree.parent, dtype=np.int64),
            support_body_array_bool=support,
            options=options,
            enabled_link=link,
            enabled_link_H_point=link_H_point,
            enabled_point=L_p_C,
        )

    def with_enabled(self, model, enabled) -> KinDynParameters:
        """The same parameters with another enabled mask (over all points)."""
        contact = _contact_parameters(np.asarray(self.contact_parameters.body, dtype=np.int64), self.contact_parameters.point, enabled)
        link, link_H_point, L_p_C = _device_targets(contact, model.scalar, model.device)
        return dataclasses.replace(
            self, contact_parameters=contact, enabled_link=link, enabled_link_H_point=link_H_point, enabled_point=L_p_C
        )


def _contact_parameters(body: np.ndarray, point: np.ndarray, enabled) -> ContactParameters:
    count = len(body)
    if enabled is None:
        mask = np.ones(count, dtype=bool)
    else:
        mask = np.asarray(enabled)
        if mask.dtype != bool:
            raise TypeError(f"enabled must be a boolean mask over all {count} collidable points, got dtype {mask.dtype}")
        if mask.shape != (count,):
            raise ValueError(f"enabled has shape {mask.shape}, expected ({count},): one flag per collidable point")
    point = np.array(point, dtype=np.float64).reshape(count, 3)
    point.setflags(write=False)
    return ContactParameters(
        body=tuple(int(b) for b in body), point=point, enabled=tuple(bool(e) for e in mask)
    )


def _device_targets(contact: ContactParameters, scalar, device):
    """(link (nc,) int, link_H_point (nc,) transform, L_p_C (nc,) vec3) of the enabled points on `device`."""
    idx = contact.indices_of_enabled_collidable_points
    L_p_C = contact.point[idx]
    rows = np.zeros((len(idx), 7))
    rows[:, :3] = L_p_C
    rows[:, 6] = 1.0  # identity rotation, (x, y, z, w)
    link = wp.array(np.asarray(contact.body, dtype=np.int32)[idx], dtype=int, device=device)
    link_H_point = wp.array(rows, dtype=wp.types.transformation(scalar), device=device)
    points = wp.array(L_p_C, dtype=wp.types.vector(3, scalar), device=device)
    return link, link_H_point, points
