"""The stability of the soft contacts' tangential deformation, and whether a scene can have contacts at all.

`step` refuses a time step at which the deformation's explicit integration is unstable (dt K / D at or beyond
the integrator's limit, DEFORMATION_STABILITY), but only for a scene that can have contacts: enabled
collidable points and a floating base or a point that can reach the terrain (`contact_reach`). Stiff contact
parameters that never act (a fixed-base arm high above the ground) are not refused: a refusal must be right
for the scene. Both are host work, once per model version (warpdyn.engine.step's Plan); the device check of
every step (kernels/parameter_checks.py) asks the same of values written in place and of a fixed base that the
data places elsewhere.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ..description.tree import JOINT_REVOLUTE
from ..types.enums import IntegratorType
from ..types.settings import host_values
from ..types.terrain import FlatTerrain, HeightfieldTerrain, PlaneTerrain

__all__ = ["DEFORMATION_STABILITY", "check_deformation_stability", "largest_stable_step", "check_reference_stability", "ContactReach", "contact_reach"]

DEFORMATION_STABILITY = {
    IntegratorType.SemiImplicitEuler: 2.0,
    IntegratorType.SemiImplicitEulerSO3: 2.0,
    IntegratorType.RungeKutta4: 2.785,
    IntegratorType.RungeKutta4Fast: 2.0,  # the first stage's rate held: the deformation advances by explicit Euler
}
"""Stability limits of dt K / D: the tangential deformation relaxes as m_dot = -(K / D) m (out of contact,
and for p = q in contact), which explicit Euler integrates stably for dt K / D < 2 and RK4 for
dt K / D < 2.785 (its stability region on the negative real axis). Beyond, m grows geometrically while
staying finite for many steps, so no health check would catch it: `step` refuses such settings."""


def check_deformation_stability(time_step: float, K, D, integrator, scene: str | None = None) -> None:
    """A ValueError when dt K / D reaches the integrator's stability limit (DEFORMATION_STABILITY); `scene`
    says why the model's points can touch the terrain (`ContactReach.why`), for the message."""
    rate = float(np.max(host_values(K) / host_values(D)))
    integrator = IntegratorType(integrator)
    limit = DEFORMATION_STABILITY[integrator]
    if time_step * rate >= limit:
        where = f" ({scene})" if scene else ""
        raise ValueError(
            f"time_step {time_step} s with contact K/D = {rate:.4g} 1/s gives dt K/D = {time_step * rate:.3g}, "
            f"beyond the stability limit {limit} of {integrator.name} for the tangential "
            f"deformation{where}: take time_step < {limit / rate:.3g} s, or a smaller K (a larger D also lowers K/D but makes "
            "the explicit contact damping less stable: docs/simulation.md, 'Speed and accuracy')"
        )


def largest_stable_step(K: float, D: float, integrator) -> float:
    """The largest dt [s] at which the integrator keeps the oscillator e'' = -D e' - K e stable (K [1/s^2], D [1/s]):
    semi-implicit Euler while dt^2 K + 2 dt D < 4; RK4 while |R(dt lambda)| <= 1 at the roots lambda of
    lambda^2 + D lambda + K (R its stability polynomial; bisection); inf when K = D = 0."""
    if K <= 0.0 and D <= 0.0:
        return np.inf
    integrator = IntegratorType(integrator)
    if integrator in (IntegratorType.SemiImplicitEuler, IntegratorType.SemiImplicitEulerSO3, IntegratorType.RungeKutta4Fast):
        return float(4.0 / (D + np.sqrt(D * D + 4.0 * K)))  # the positive root of K dt^2 + 2 D dt - 4
    roots = np.roots([1.0, D, K])

    def stable(dt: float) -> bool:
        return all(abs(1 + z + z**2 / 2 + z**3 / 6 + z**4 / 24) <= 1.0 for z in dt * roots)

    lo, hi = 0.0, 10.0 / max(D, np.sqrt(K))
    for _ in range(60):
        lo, hi = ((lo + hi) / 2, hi) if stable((lo + hi) / 2) else (lo, (lo + hi) / 2)
    return lo


def check_reference_stability(time_step: float, K: float, D: float, integrator, what: str, remedy: str, scene: str | None = None) -> None:
    """A ValueError when a solved contact model's reference acceleration, e'' = -D e' - K e at a penetrating point
    (JaxSim's relaxed-rigid a_ref with R -> 0, the rigid model's Baumgarte terms), is unstable at this time step
    (`largest_stable_step`); `what` names the parameters, `remedy` says how to change them, `scene` why the points
    can touch the terrain (`ContactReach.why`)."""
    limit = largest_stable_step(K, D, integrator)
    if time_step >= limit:
        where = f" ({scene})" if scene else ""
        raise ValueError(
            f"time_step {time_step} s: {what} give the contacts' reference acceleration stiffness {K:.4g} 1/s^2 and damping {D:.4g} 1/s, "
            f"unstable with {IntegratorType(integrator).name} beyond dt = {limit:.3g} s{where}: take time_step < {limit:.3g} s, or {remedy}"
        )


@dataclasses.dataclass(frozen=True)
class ContactReach:
    """Whether a model's enabled collidable points can touch its terrain, which the deformation's stability
    check asks before refusing a time step (`contact_reach`).

    reach: a bound of the distance of every enabled point from the base's origin over all joint motions [m]
    (inf: unbounded); may_touch: whether a point may touch the terrain with the base where the description
    welds it (always for a floating base); why: the reason, in words."""

    reach: float
    may_touch: bool
    why: str


def contact_reach(model) -> ContactReach:
    """The model's ContactReach, computed on the host once per model version (model.cached).

    The reach bounds each point's distance from the base by the sum, along its chain, of each joint's largest
    displacement of its child's origin (|p| + 2 |d_perp| for a revolute joint of frame origin p with its axis
    through the pivot d), plus the point's distance from its link's origin: rotations keep lengths, so no
    joint motion takes the point farther. A prismatic joint makes it unbounded (its limits do not bound its
    position: JaxSim's are a spring, 0 by default). The terrain: a FlatTerrain (its highest height) or a
    PlaneTerrain is touched when the welded base's origin is within the reach of it; a HeightfieldTerrain is
    assumed touched (its heights may change in place). A floating base is assumed to reach anything. With joint
    origins or collidable points per environment, the farthest of every environment's reach counts. The base
    that a fixed-base Data puts elsewhere is checked on the device at every step (kernels/parameter_checks.py).
    """
    return model.cached("contact reach", lambda: _contact_reach(model))


def _contact_reach(model) -> ContactReach:
    cp = model.kin_dyn_structure().contact_parameters
    rows = np.asarray(cp.indices_of_enabled_collidable_points, dtype=np.int64)
    if rows.size == 0:
        return ContactReach(0.0, False, "no enabled collidable points")
    if model.floating_base():
        return ContactReach(np.inf, True, "the base floats: its collidable points can reach the terrain")
    tree = model.tree
    nL = tree.number_of_links
    # every environment's joint origins and points where they differ (per-environment origins and shapes): the farthest
    origins = model.joint_origins_per_env[0] if model.joint_origins_per_env is not None else np.asarray(tree.parent_H_joint)[None, 1:, :3, 3]
    points = model.collidable_point_rows()
    chain = np.zeros((len(origins), nL))  # the reach of each link's origin from the base's
    for i in range(1, nL):
        step = np.full(len(origins), np.inf)  # a prismatic joint (or any but a revolute one): unbounded
        if tree.joint_type[i] == JOINT_REVOLUTE:
            a = np.asarray(tree.joint_axis[i], dtype=np.float64)
            a = a / np.linalg.norm(a)
            d = np.asarray(tree.joint_pivot[i], dtype=np.float64)
            step = np.linalg.norm(np.asarray(origins[:, i - 1], dtype=np.float64), axis=1) + 2.0 * np.linalg.norm(d - (a @ d) * a)
        chain[:, i] = chain[:, tree.parent[i]] + step
    links = np.asarray(cp.body, dtype=np.int64)[rows]
    reach = float(np.max(chain[:, links] + np.linalg.norm(points[:, rows], axis=2)))  # rows: 1 or N each
    if not np.isfinite(reach):
        return ContactReach(np.inf, True, "a prismatic joint moves a collidable point without bound")
    base = np.asarray(model.description.world_H_base, dtype=np.float64)[:3, 3]
    terrain = model.terrain
    if isinstance(terrain, HeightfieldTerrain):
        return ContactReach(reach, True, f"a collidable point reaches up to {reach:.4g} m from the base, over a heightfield")
    if isinstance(terrain, FlatTerrain):
        normal, offset = np.array([0.0, 0.0, 1.0]), float(np.max(host_values(terrain.elevation)))
    elif isinstance(terrain, PlaneTerrain):
        normal = np.asarray(terrain.unit_normal, dtype=np.float64)
        offset = float(normal @ np.asarray(terrain.point, dtype=np.float64))
    else:
        return ContactReach(reach, True, f"a collidable point reaches up to {reach:.4g} m from the base")
    distance = float(normal @ base) - offset
    why = f"a collidable point reaches up to {reach:.4g} m from the base, welded {distance:.4g} m above the terrain"
    return ContactReach(reach, distance <= reach, why)
