"""JaxSim's kinematic constraints (`jaxsim.api.kin_dyn_parameters.ConstraintMap`, `ConstraintType`): welds between
two frames of a model, which close kinematic loops (four-bar linkages, parallel mechanisms) or pin a frame to another.

A step solves them as JaxSim 0.9's `compute_constraint_wrenches` does, after the contacts: with J = J_F1 - J_F2 (the
frames' Mixed Jacobians) and the residual r = [p_F1 - p_F2; rotation], the constraint forces f solve
(J M^-1 J^T + 1e-3 I) f = -(J a_free + K_P r + K_D J nu) and act on the frames' links (kernels/equality.py's frame
weld: J̇ν is left out as in JaxSim; the rotation residual is taken in world axes, see there). K_P = 1000 [1/s^2]
and K_D = 2 sqrt(K_P) [1/s] by default (JaxSim's). The map holds frame indices of the model it was made for, and
their names: a model reduced to fewer joints (`reduce`, `considered_joints`) finds the same frames by name.
"""

from __future__ import annotations

import dataclasses
import warnings
from typing import ClassVar

import numpy as np

from ..description.model import NotModelledWarning, matrix_to_quaternion_wxyz
from ..description.tree import TreeEquality
from . import names as _names

__all__ = ["ConstraintType", "ConstraintMap", "REGULARIZATION"]

REGULARIZATION = 1.0e-3
"""JaxSim's `regularization` of the constraints' solve: the diagonal added to J M^-1 J^T (each row's R)."""


@dataclasses.dataclass(frozen=True)
class ConstraintType:
    """JaxSim's constraint types: Weld (0), the frames' poses held equal (six rows)."""

    Weld: ClassVar[int] = 0


@dataclasses.dataclass(frozen=True, eq=False)
class ConstraintMap:
    """Kinematic constraints of a model (JaxSim's `ConstraintMap`): C constraints, each between frames
    frame_idxs_1[c] and frame_idxs_2[c] (frame indices: number_of_links() + k for the k-th of `frame_names()`) on
    links parent_link_idxs_1[c] and parent_link_idxs_2[c], of type constraint_types[c] (ConstraintType.Weld) with
    Baumgarte gains K_P[c] [1/s^2] and K_D[c] [1/s]; frame_names_1, frame_names_2 (C,) the frames' names (empty
    for a map made from indices alone, as JaxSim's may be: a model then reads them from the indices). Arrays (C,),
    NumPy, read-only (copies shared by model copies); `add_constraint` returns a new map."""

    frame_idxs_1: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))
    frame_idxs_2: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))
    constraint_types: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))
    K_P: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    K_D: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))
    parent_link_idxs_1: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))
    parent_link_idxs_2: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0, dtype=int))
    frame_names_1: tuple[str, ...] = ()
    frame_names_2: tuple[str, ...] = ()

    def __post_init__(self):
        sizes = {}
        for name, kind in (("frame_idxs_1", int), ("frame_idxs_2", int), ("constraint_types", int), ("K_P", float), ("K_D", float),
                           ("parent_link_idxs_1", int), ("parent_link_idxs_2", int)):  # fmt: skip
            array = np.array(getattr(self, name), dtype=kind).reshape(-1)
            array.flags.writeable = False
            object.__setattr__(self, name, array)
            sizes[name] = array.size
        for name in ("frame_names_1", "frame_names_2"):
            object.__setattr__(self, name, tuple(str(n) for n in getattr(self, name)))
            if getattr(self, name):
                sizes[name] = len(getattr(self, name))
        if len(set(sizes.values())) > 1:
            raise ValueError(f"a ConstraintMap's fields must have one length (one entry per constraint), got {sizes}; make maps with add_constraint")

    def __len__(self) -> int:
        return len(self.frame_idxs_1)

    def __eq__(self, other) -> bool:
        return isinstance(other, ConstraintMap) and self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def _key(self) -> tuple:
        """The frames by name (by index for a map of indices alone), the types and the gains."""
        frames = (self.frame_names_1, self.frame_names_2) if self.frame_names_1 else (tuple(self.frame_idxs_1.tolist()), tuple(self.frame_idxs_2.tolist()))
        return (*frames, tuple(self.constraint_types.tolist()), tuple(self.K_P.tolist()), tuple(self.K_D.tolist()))

    def add_constraint(self, model, frame_idx_1: int, frame_idx_2: int, constraint_type: int, K_P: float | None = None, K_D: float | None = None) -> ConstraintMap:
        """A new map with one more constraint between the frames of indices frame_idx_1 and frame_idx_2 of `model`
        (JaxSim's `add_constraint`): K_P = 1000 [1/s^2] and K_D = 2 sqrt(K_P) [1/s] unless given. An IndexError
        names an index that is not one of the model's frames; a ValueError an unknown type, gains that are negative or
        not finite, or two frames on one link (nothing to hold; JaxSim accepts them)."""
        if constraint_type != ConstraintType.Weld:
            raise ValueError(f"constraint_type must be ConstraintType.Weld (0), the only type JaxSim 0.9 has, got {constraint_type!r}")
        K_P = 1000.0 if K_P is None else _gain("K_P", K_P)
        K_D = 2.0 * np.sqrt(K_P) if K_D is None else _gain("K_D", K_D)  # 0 and 0: no stabilisation, as JaxSim allows
        nL = model.number_of_links()
        rows = [_names.check_idx("frame", model.number_of_frames(), _scalar(i), nL) - nL for i in (frame_idx_1, frame_idx_2)]
        names = [model.frame_names()[r] for r in rows]
        links = [int(model.tree.frame_parent[r]) for r in rows]
        if links[0] == links[1]:
            raise ValueError(
                f"a weld of frames '{names[0]}' and '{names[1]}' of model '{model.name()}': both are on link '{model.link_names()[links[0]]}', "
                "whose motion cannot change their relative pose"
            )
        return ConstraintMap(
            frame_idxs_1=np.append(self.frame_idxs_1, nL + rows[0]).astype(int),
            frame_idxs_2=np.append(self.frame_idxs_2, nL + rows[1]).astype(int),
            constraint_types=np.append(self.constraint_types, int(constraint_type)).astype(int),
            K_P=np.append(self.K_P, K_P),
            K_D=np.append(self.K_D, K_D),
            parent_link_idxs_1=np.append(self.parent_link_idxs_1, links[0]).astype(int),
            parent_link_idxs_2=np.append(self.parent_link_idxs_2, links[1]).astype(int),
            frame_names_1=(*self.frame_names_1, names[0]),
            frame_names_2=(*self.frame_names_2, names[1]),
        )

    def for_model(self, model) -> ConstraintMap:
        """This map on `model`: its frames found by name (a model reduced from the one the map was made for keeps
        its frames' names). A ValueError names a frame the model does not have; a weld whose frames the model holds
        on one link (a reduction locked the joints between them) is dropped with a NotModelledWarning naming it."""
        frames, nL = list(model.frame_names()), model.number_of_links()
        if len(self) and not self.frame_names_1:  # a map of indices alone: the frames they index on this model
            rows = [[_names.check_idx("frame", len(frames), _scalar(i), nL) - nL for i in idx] for idx in (self.frame_idxs_1, self.frame_idxs_2)]
            return dataclasses.replace(self, frame_names_1=tuple(frames[r] for r in rows[0]), frame_names_2=tuple(frames[r] for r in rows[1])).for_model(model)
        missing = sorted({n for n in (*self.frame_names_1, *self.frame_names_2) if n not in frames})
        if missing:
            raise ValueError(f"the ConstraintMap's frames {missing} are not frames of model '{model.name()}' (its frames: {frames})")
        new, rigid = ConstraintMap(), []
        for c in range(len(self)):
            rows = [frames.index(n) for n in (self.frame_names_1[c], self.frame_names_2[c])]
            if model.tree.frame_parent[rows[0]] == model.tree.frame_parent[rows[1]]:
                rigid.append(f"{self.frame_names_1[c]} - {self.frame_names_2[c]}")
                continue
            idx = [nL + r for r in rows]
            new = new.add_constraint(model, idx[0], idx[1], int(self.constraint_types[c]), float(self.K_P[c]), float(self.K_D[c]))
        if rigid:
            warnings.warn(f"model '{model.name()}' holds the frames of the welds {rigid} on one link each (their joints are locked): the welds are dropped",
                          NotModelledWarning, stacklevel=3)  # fmt: skip
        return new

    def tree_equalities(self, model) -> list[TreeEquality]:
        """The constraints as the step's frame welds (`TreeEquality` of kind "frame_weld"), on `model`'s links."""
        out = []
        for c in range(len(self)):
            poses = [model.tree.link_H_frame[int(i) - model.number_of_links()] for i in (self.frame_idxs_1[c], self.frame_idxs_2[c])]
            out.append(TreeEquality(
                name=f"weld {self.frame_names_1[c]} - {self.frame_names_2[c]}", kind="frame_weld",
                link1=int(self.parent_link_idxs_1[c]), link2=int(self.parent_link_idxs_2[c]),
                p1=poses[0][:3, 3].copy(), p2=poses[1][:3, 3].copy(),
                Q1=matrix_to_quaternion_wxyz(poses[0][:3, :3]), Q2=matrix_to_quaternion_wxyz(poses[1][:3, :3]),
                baumgarte=np.array([self.K_P[c], self.K_D[c]], dtype=np.float64), regularization=REGULARIZATION,
            ))  # fmt: skip
        return out


def _scalar(index):
    """A 0-d array (JaxSim's and NumPy's indices) as its item; anything else as it is (check_idx judges it)."""
    return index.item() if isinstance(index, np.ndarray) and index.ndim == 0 else index


def _gain(name: str, value) -> float:
    if isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name} must be a number, got {value!r}")
    array = np.asarray(value, dtype=np.float64)
    if array.size != 1:
        raise ValueError(f"{name} must be one number, got shape {array.shape}")
    gain = float(array.reshape(()))
    if not np.isfinite(gain) or gain < 0.0:
        raise ValueError(f"{name} must be non-negative and finite, got {gain}")
    return gain
