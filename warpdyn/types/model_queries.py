"""A model's queries with JaxSim's names (`name`, `number_of_links`, `dofs`, `link_names`, ...) and warpdyn's
about its joints' positions and velocities, read from its lumped tree (`self.tree`,
warpdyn.description.tree.KinematicTree) and description, and its export as URDF or MJCF text."""

from __future__ import annotations

import warnings

import numpy as np
import warp as wp

from ..description.tree import JOINT_BALL, JOINT_FREE, JOINT_PRISMATIC, JOINT_REVOLUTE
from ..description.mjcf_writer import write_mjcf
from ..description.model import NotModelledWarning, axis_angle_to_matrix, homogeneous
from ..description.urdf_writer import write_urdf
from .enums import IntegratorType
from .geoms import geom_pairs
from .terrain import FlatTerrain, PlaneTerrain

__all__ = ["ModelQueries"]


class ModelQueries:
    """The queries of warpdyn.types.model.Model (a mixin: the model holds `tree`, `description`, `model_name`)."""

    def __repr__(self) -> str:
        return (
            f"Model(name={self.model_name!r}, links={self.number_of_links()}, joints={self.number_of_joints()}, "
            f"floating_base={self.floating_base()}, dtype={self.dtype.name}, device='{self.device}')"
        )

    def name(self) -> str:
        return self.model_name

    def number_of_links(self) -> int:
        return self.tree.number_of_links

    def number_of_joints(self) -> int:
        """nj: the joints (one per link but the base)."""
        return self.tree.number_of_joints

    def number_of_frames(self) -> int:
        return len(self.tree.frame_names)

    def dofs(self) -> int:
        """nv: the joints' degrees of freedom, the length of `joint_velocities` (JaxSim's dofs; a ball joint has
        3, a free joint 6)."""
        return self.tree.dofs

    def number_of_joint_coordinates(self) -> int:
        """nq: the joints' positions, the length of `joint_positions` (a ball joint has 4, a free joint 7; equal
        to `dofs()` without them)."""
        return self.tree.coordinates

    def joint_quaternions(self) -> np.ndarray:
        """(k,) int: where each ball or free joint's unit quaternion (w, x, y, z) starts in `joint_positions`
        (4 numbers from there)."""
        tree = self.tree
        starts = [int(tree.q_start[i]) + (3 if kind == JOINT_FREE else 0) for i, kind in enumerate(tree.joint_type) if kind in (JOINT_BALL, JOINT_FREE)]
        return np.array(starts, dtype=np.int64)

    def scratch_rows(self) -> int:
        """The rows of a kernel's per-environment scratch that holds a record per link (row i) and per DoF (row
        d + 1): max(nL, nv + 1), nL for a model whose joints have one DoF each."""
        return max(self.number_of_links(), self.dofs() + 1)

    def multi_dof(self) -> bool:
        """Whether a joint has more than one DoF (a ball or free joint): which variant of the kernels moves the
        joints (kernels/joints.py)."""
        return not self.tree.one_dof_joints

    def dof_names(self) -> tuple[str, ...]:
        """A name per DoF (nv,): a revolute or prismatic joint's own name; "{joint}:rx", ":ry", ":rz" for a ball
        joint's rotations about its child's axes; "{joint}:x", ":y", ":z", ":rx", ":ry", ":rz" for a free
        joint's."""
        names = []
        for name, kind in zip(self.tree.joint_names, self.tree.joint_type[1:]):
            suffixes = {JOINT_BALL: ("rx", "ry", "rz"), JOINT_FREE: ("x", "y", "z", "rx", "ry", "rz")}.get(int(kind))
            names += [name] if suffixes is None else [f"{name}:{k}" for k in suffixes]
        return tuple(names)

    def link_names(self) -> tuple[str, ...]:
        return tuple(self.tree.link_names)

    def joint_names(self) -> tuple[str, ...]:
        return tuple(self.tree.joint_names)

    def frame_names(self) -> tuple[str, ...]:
        return tuple(self.tree.frame_names)

    def number_of_actuators(self) -> int:
        return len(self.tree.actuators)

    def actuator_names(self) -> tuple[str, ...]:
        """The MJCF actuators on kept joints, in the description's order (their ctrl order)."""
        return tuple(a.name for a in self.tree.actuators)

    def floating_base(self) -> bool:
        return not self.description.fixed_base

    def base_link(self) -> str:
        return self.tree.link_names[0]

    def keyframe_names(self) -> tuple[str, ...]:
        """The description's keyframes (MJCF `<key>`), in its order: `warpdyn.data.keyframe(model, name)`."""
        return tuple(k.name for k in self.description.keyframes)

    def collidable_point_rows(self) -> np.ndarray:
        """(P, nc_all, 3) [m, link frames] host float64: every collidable point, P = 1 but where update_hw_parameters
        scaled the links per environment (the kernel's point array, one row per environment)."""
        array = self.collidable_point_array
        if array is not None and array.shape[0] > 1:
            return array.numpy().astype(np.float64)
        return np.asarray(self.kin_dyn_structure().contact_parameters.point, dtype=np.float64).reshape(1, -1, 3)

    def contact_state_rows(self) -> int:
        """The rows of the soft contacts' state (the data's tangential deformation, (N, rows, 3)): one per collidable
        point, enabled or not (JaxSim's), then, where `geom_contacts` is set, one per contact slot of the geom pairs
        (warpdyn.types.geoms: each pair's slots in order), the deformation of the contact in that slot."""
        rows = len(self.kin_dyn_structure().contact_parameters.body)
        return rows + geom_pairs(self).contacts if self.geom_contacts else rows

    def export_updated_model(self, format: str = "urdf") -> str:
        """JaxSim's export: the text of the lumped tree with its current parameters, joint origins, collision shapes and
        frames, which loads back to the same model: URDF (JaxSim's; warpdyn.description.urdf_writer) or, with
        format="mjcf", MJCF (warpdyn.description.mjcf_writer: ball joints, armature, MuJoCo's damper and springs
        too, the equality constraints and the integrator, for MuJoCo). A ValueError for per-environment parameters
        and for what the format cannot hold; a NotModelledWarning names what it leaves out or changes (a URDF's
        equality constraints and joints' start positions, JaxSim's kinematic constraints, an integrator MuJoCo has
        not, MuJoCo's invweights of constraints on lumped links)."""
        if format not in ("urdf", "mjcf"):
            raise ValueError(f"export_updated_model: format must be 'urdf' or 'mjcf', got {format!r}")
        names = ("link_mass", "link_com", "link_inertia", "position_limits", "friction_static", "friction_viscous")
        if format == "mjcf":
            names += ("armature", "damping", "stiffness", "springref", "joint_actuator_force_range", "base_armature", "base_damping", "base_stiffness")
            names += ("actuator_gear", "actuator_gain", "actuator_bias", "actuator_ctrl_range", "actuator_force_range") if self.tree.actuators else ()
        per_env = sorted(set((*names, "joint_origins", "world_gravity" if format == "mjcf" else "")) & set(self.per_environment_parameters()))
        if per_env:
            raise ValueError(f"export_updated_model: {per_env} are given per environment; a {format.upper()} file holds one model")
        host = {name: np.asarray(self.parameter(name).numpy(), dtype=np.float64) for name in names}
        welded = None if self.floating_base() else np.asarray(self.description.world_H_base, dtype=np.float64)
        self._warn_unwritten_constraints(format)
        shapes = [(link.name, link.collisions) for link in self.description.links]
        if format == "mjcf":
            gravity = np.asarray(self.world_gravity.numpy(), dtype=np.float64).reshape(-1, 3)[0]
            return write_mjcf(self.tree, self.description, host, welded, self.time_step, gravity, self._floor(), *self._mujoco_integrator())
        return write_urdf(self.name(), self.tree, shapes, host["link_mass"], host["link_com"], host["link_inertia"], host["position_limits"],
                          host["friction_static"], host["friction_viscous"], welded)

    def _mujoco_integrator(self) -> tuple[str, frozenset]:
        """(MuJoCo's integrator name, disable flags) for the MJCF export: RungeKutta4 as RK4; SemiImplicitEulerSO3 as
        the description's Euler, implicit or implicitfast (Euler for other descriptions), eulerdamp disabled unless
        the joints' damping is implicit; JaxSim's SemiImplicitEuler as Euler (the same steps on a fixed base; on a
        floating base they differ by O(dt^2) per step) and RungeKutta4Fast as Euler, those two named in a
        NotModelledWarning (the file loads back with SemiImplicitEulerSO3)."""
        disabled = frozenset(self.description.disabled)
        if self.integrator == IntegratorType.RungeKutta4:
            return "RK4", disabled
        if self.integrator == IntegratorType.RungeKutta4Fast or (self.integrator == IntegratorType.SemiImplicitEuler and self.floating_base()):
            warnings.warn(f"export_updated_model: IntegratorType.{self.integrator.name} has no MuJoCo counterpart: the MJCF names MuJoCo's "
                          "Euler (SemiImplicitEulerSO3 when loaded back; on a floating base a step apart by O(dt^2), RungeKutta4Fast's "
                          "by its held contacts)", NotModelledWarning, stacklevel=3)  # fmt: skip
        name = self.description.integrator if self.description.integrator in ("Euler", "implicit", "implicitfast") else "Euler"
        explicit = not self.implicit_damping and "damper" not in disabled
        return name, (disabled | {"eulerdamp"}) if explicit else (disabled - {"eulerdamp"})

    def _warn_unwritten_constraints(self, format: str) -> None:
        """A NotModelledWarning naming what the exported file will not hold: a URDF's equality constraints (URDF has
        none) and joints' start positions (MuJoCo's ref), and JaxSim's kinematic constraints in either format (a
        ConstraintMap's Baumgarte welds are neither; set the map again on the loaded model)."""
        unwritten = [f"equality constraints {[e.name for e in self.tree.equalities]}"] if format == "urdf" and self.tree.equalities else []
        started = [self.tree.joint_names[i - 1] for i in range(1, self.tree.number_of_links) if self.tree.joint_type[i] in (JOINT_REVOLUTE, JOINT_PRISMATIC)
                   and self.tree.qpos0[self.tree.q_start[i]] != 0.0]  # fmt: skip
        if format == "urdf" and started:
            unwritten.append(f"joints' start positions (MuJoCo's ref, qpos0) of {started}: they load back at 0")
        if len(self.constraints):
            welds = [f"{a} - {b}" for a, b in zip(self.constraints.frame_names_1, self.constraints.frame_names_2)]
            unwritten.append(f"JaxSim's kinematic constraints (ConstraintMap welds {welds}: set the map again on the loaded model)")
        if unwritten:
            warnings.warn(f"export_updated_model: the {format.upper()} does not hold the model's {' nor its '.join(unwritten)}", NotModelledWarning, stacklevel=3)

    def _floor(self) -> np.ndarray | None:
        """The pose (4, 4) of the terrain's plane (z up in it) for the MJCF export: a flat terrain's or a plane's; None
        with a warning for a heightfield, which the export does not write; a ValueError for heights per environment."""
        terrain = self.terrain
        if isinstance(terrain, FlatTerrain):
            height = np.asarray(terrain.elevation.numpy() if isinstance(terrain.elevation, wp.array) else terrain.elevation, dtype=np.float64)
            if height.ndim and np.ptp(height) > 0.0:
                raise ValueError("export_updated_model: the terrain's height is given per environment; a MJCF file holds one model")
            return homogeneous(np.eye(3), np.array([0.0, 0.0, float(height.reshape(-1)[0])]))
        if isinstance(terrain, PlaneTerrain):
            n = np.asarray(terrain.unit_normal, dtype=np.float64)
            axis = np.cross([0.0, 0.0, 1.0], n)
            turn = np.linalg.norm(axis)
            R = np.eye(3) if turn < 1e-15 else axis_angle_to_matrix(axis / turn, float(np.arctan2(turn, n[2])))
            return homogeneous(R, np.asarray(terrain.point, dtype=np.float64))
        warnings.warn(f"export_updated_model: the {type(terrain).__name__} is not written to the MJCF (its heightfield asset is not "
                      "exported yet): the file has no ground", NotModelledWarning, stacklevel=3)
        return None
