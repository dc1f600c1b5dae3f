"""The physical checks of a robot's values: one set, applied by the loader to every link, joint and actuator
of a description, naming the element (`check_description`), and by the model's setters to the arrays a
user sets (warpdyn.types.parameters, naming the array and the index).

Errors (a ValueError): values no computation can use, or that make the dynamics NaN: non-finite values,
negative masses, an inertia without mass, an inertia that is not symmetric positive semi-definite, joint
limits with NaN or lower > upper, negative joint damping, friction, armature, stiffness, effort or velocity
limits, a zero or non-finite joint axis. A warning (`UnphysicalInertiaWarning`): an inertia that is
positive semi-definite, so that every algorithm computes with it, but that no rigid body has: principal
moments that violate the triangle inequality (e0 + e1 < e2), or a rotational inertia without mass. MuJoCo
refuses both; icub-models ships both (iCubNancy01's ankles, iCubGenova03's torso_1 and torso_2), and
warpdyn keeps them as given, as it keeps whatever a setter is given.

Tolerances, from what real descriptions hold: icub-models' URDFs write the zero inertia of a point mass
as entries of 1e-35 to 1e-18 of either sign, and files rounded to 6 digits leave principal moments off by
about 1e-6 of the largest. For inertias I_k (3, 3) with principal moments e0 <= e1 <= e2:
    symmetric:    |I - I^T| <= 1e-9 scale
    semi-definite: e0 >= -tol,    triangle inequality: e0 + e1 >= e2 - tol,    tol = 1e-6 e2 + 1e-9 scale
where scale is the largest entry of all the inertias checked together (a description's links, or the
array a setter gets), so that the rounding noise of a zero inertia passes beside the robot's real ones.
"""

from __future__ import annotations

import warnings

import numpy as np

from .model import caller_stacklevel

__all__ = [
    "UnphysicalInertiaWarning",
    "INERTIA_RTOL",
    "INERTIA_ATOL",
    "inertia_faults",
    "check_description",
]

INERTIA_RTOL = 1e-6
"""Tolerance on principal moments, relative to the inertia's largest principal moment."""
INERTIA_ATOL = 1e-9
"""Tolerance on principal moments and symmetry, relative to the largest entry of the inertias checked together."""


class UnphysicalInertiaWarning(UserWarning):
    """An inertia's principal moments violate the triangle inequality (e0 + e1 >= e2): no rigid body has
    them. The inertia is positive semi-definite, so warpdyn computes with it as given."""


def inertia_faults(inertia: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(asymmetric, indefinite, triangle, moments) of finite inertias (..., 3, 3): boolean masks (...) of the
    matrices that are not symmetric, not positive semi-definite, or violate the triangle inequality (each
    within the module's tolerances), and their principal moments (..., 3), ascending."""
    I = np.asarray(inertia, dtype=np.float64)
    scale = float(np.abs(I).max(initial=0.0))
    asymmetric = np.abs(I - np.swapaxes(I, -1, -2)).max(axis=(-1, -2), initial=0.0) > INERTIA_ATOL * scale
    moments = np.linalg.eigvalsh(0.5 * (I + np.swapaxes(I, -1, -2))) if I.size else np.zeros((*I.shape[:-2], 3))
    tol = INERTIA_RTOL * np.maximum(moments[..., 2], 0.0) + INERTIA_ATOL * scale
    indefinite = moments[..., 0] < -tol
    triangle = ~indefinite & (moments[..., 0] + moments[..., 1] < moments[..., 2] - tol)
    return asymmetric, indefinite, triangle, moments


def _moments(e: np.ndarray) -> str:
    return "(" + ", ".join(f"{v:.6g}" for v in e) + ")"


def _number_faults(label: str, what: str, value: float, unit: str = "", non_negative: bool = True) -> list[str]:
    unit = f" {unit}" if unit else ""
    if not np.isfinite(value):
        return [f"{label}: {what} {value}{unit} is not finite"]
    if non_negative and value < 0.0:
        return [f"{label}: {what} {value:g}{unit} is negative"]
    return []


def _range_faults(label: str, what: str, pair) -> list[str]:
    lower, upper = (float(v) for v in np.asarray(pair, dtype=np.float64).reshape(2))
    if np.isnan(lower) or np.isnan(upper):
        return [f"{label}: {what} ({lower}, {upper}) holds NaN"]
    if lower > upper:
        return [f"{label}: {what} has lower {lower:g} above upper {upper:g}"]
    return []


def _finite_faults(label: str, what: str, value) -> list[str]:
    value = np.asarray(value, dtype=np.float64)
    if not np.all(np.isfinite(value)):
        return [f"{label}: {what} {np.round(value, 6).tolist()} is not finite"]
    return []


def _link_faults(links) -> tuple[list[str], list[str]]:
    """(errors, warnings) of the links' inertial values."""
    errors, unphysical = [], []
    finite = []
    for link in links:
        label = f"link '{link.name}'"
        found = _number_faults(label, "mass", float(link.mass), "kg")
        found += _finite_faults(label, "centre of mass", link.com)
        found += _number_faults(label, "gravcomp", float(link.gravcomp), non_negative=False)
        if not np.all(np.isfinite(link.inertia)):
            found.append(f"{label}: inertia has non-finite entries {np.asarray(link.inertia).tolist()}")
        else:
            finite.append(link)
        errors += found
    if finite:
        asymmetric, indefinite, violates, moments = inertia_faults(np.array([link.inertia for link in finite]))
        for k, link in enumerate(finite):
            label = f"link '{link.name}'"
            if asymmetric[k]:
                errors.append(f"{label}: inertia {np.asarray(link.inertia).tolist()} is not symmetric")
            elif indefinite[k]:
                errors.append(f"{label}: inertia has a negative principal moment {moments[k, 0]:.6g} kg m^2 (principal moments {_moments(moments[k])})")
            elif violates[k]:
                unphysical.append(f"{label}: principal moments {_moments(moments[k])} kg m^2 violate the triangle inequality")
            elif float(link.mass) == 0.0 and moments[k, 2] > 0.0:
                unphysical.append(f"{label}: principal moments {_moments(moments[k])} kg m^2 without mass")
    return errors, unphysical


def _joint_faults(joints) -> list[str]:
    errors = []
    for joint in joints:
        label = f"joint '{joint.name}'"
        if not np.all(np.isfinite(joint.origin)):
            errors.append(f"{label}: origin (the joint frame in the parent link) has non-finite entries")
        if joint.type not in ("revolute", "prismatic"):
            continue
        axis = np.asarray(joint.axis, dtype=np.float64)
        if not np.all(np.isfinite(axis)) or np.linalg.norm(axis) < 1e-12:
            errors.append(f"{label}: axis {axis.tolist()} is not a finite non-zero vector")
        errors += _finite_faults(label, "pivot", joint.pivot)
        errors += _range_faults(label, "position limits", (joint.lower, joint.upper))
        for what, value, unit in (
            ("effort limit", joint.effort, "N m or N"),
            ("velocity limit", joint.velocity, "rad/s or m/s"),
        ):
            if np.isnan(value) or value < 0.0:
                errors.append(f"{label}: {what} {value} [{unit}] must be non-negative (inf: none)")
        for what, value in (
            ("damping", joint.damping),
            ("friction", joint.friction),
            ("armature", joint.armature),
            ("passive damping", joint.passive_damping),
            ("stiffness", joint.stiffness),
        ):
            errors += _number_faults(label, what, float(value))
        errors += _number_faults(label, "spring reference", float(joint.springref), non_negative=False)
        errors += _range_faults(label, "actuator force range", joint.actuator_force_range)
    return errors


def _actuator_faults(actuators) -> list[str]:
    errors = []
    for actuator in actuators:
        label = f"actuator '{actuator.name}'"
        errors += _number_faults(label, "gear", float(actuator.gear), non_negative=False)
        errors += _finite_faults(label, "gain", actuator.gain)
        errors += _finite_faults(label, "bias", actuator.bias)
        if actuator.ctrl_limited:
            errors += _range_faults(label, "ctrl range", actuator.ctrl_range)
        if actuator.force_limited:
            errors += _range_faults(label, "force range", actuator.force_range)
    return errors


def check_description(description, where: str) -> None:
    """A ValueError listing the links, joints and actuators of `description` (a ModelDescription) whose
    values are not physical (see the module docstring), prefixed by `where` (the file); one
    UnphysicalInertiaWarning listing the links whose inertia violates the triangle inequality or comes
    without mass."""
    errors, unphysical = _link_faults(description.links)
    errors += _joint_faults(description.joints)
    errors += _actuator_faults(description.actuators)
    if errors:
        shown = "; ".join(errors[:10]) + (f"; and {len(errors) - 10} more" if len(errors) > 10 else "")
        raise ValueError(f"{where}: {shown}")
    if unphysical:
        warnings.warn(
            f"{where}: inertias that no rigid body has (warpdyn computes with them as given): {'; '.join(unphysical)}",
            UnphysicalInertiaWarning,
            stacklevel=caller_stacklevel(),
        )
