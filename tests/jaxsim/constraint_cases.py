"""JaxSim 0.9.0's kinematic constraints (ConstraintMap, ConstraintType.Weld) on warpdyn's own mechanisms, each case
written once in JaxSim's call form with `api` standing for `jaxsim.api` (tests/jaxsim/generate_constraints.py stores
JaxSim's trajectories in constraints.npz) or for `warpdyn` (tests/test_kinematic_constraints.py compares).

- pendulums: two pendulums on one fixed base whose tips are welded (tests/jaxsim/welded_pendulums.sdf), released
  5 degrees apart: the weld pulls them together and locks them (the welded pair cannot turn);
- pendulums_floating: the same on a floating base without gravity, moving and turning, the pendulums 5 and -3
  degrees out and swinging;
- four_bar: a four-bar linkage opened at its coupler and closed by a weld at the coupler's midpoint
  (tests/jaxsim/four_bar.sdf), under gravity from a crank speed of 1 rad/s (K_P = 1e4, as JaxSim's own four-bar test);
- coaxial_turned: two pendulums on one axis welded by frames on that axis turned 2 rad about z
  (tests/jaxsim/coaxial_pendulums.sdf), released 5 degrees apart: only the weld's rotation rows act. JaxSim's
  rotation residual, in the second frame's axes, then pushes the wrong way and its weld parts (kernels/equality.py's
  frame weld); warpdyn's, in world axes, holds.

Imports NumPy only. Paths are relative to the repository's root.
"""

from __future__ import annotations

import pathlib
import re

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[2]
FLOATING = re.compile(r' *<joint name="world_to_\w+" type="fixed">.*?</joint>\n', re.DOTALL)
"""The weld of a description's base to the world, which a floating case drops."""

CASES = {
    "pendulums": dict(path="tests/jaxsim/welded_pendulums.sdf", floating=False, welds=[("a_tip", "b_tip")], K_P=None, gravity=-9.81, steps=1000,
                      state=dict(joint_positions=np.deg2rad([5.0, 0.0]))),
    "pendulums_floating": dict(path="tests/jaxsim/welded_pendulums.sdf", floating=True, welds=[("a_tip", "b_tip")], K_P=None, gravity=0.0, steps=1000,
                               state=dict(joint_positions=np.deg2rad([5.0, -3.0]), joint_velocities=np.array([0.5, -0.2]),
                                          base_position=np.array([0.1, -0.2, 1.0]), base_linear_velocity=np.array([0.1, 0.0, 0.2]),
                                          base_angular_velocity=np.array([0.3, -0.2, 0.5]))),
    "four_bar": dict(path="tests/jaxsim/four_bar.sdf", floating=False, welds=[("m1", "m2")], K_P=1.0e4, gravity=-9.81, steps=1000,
                     state=dict(joint_velocities=np.array([1.0, 0.0, 0.0, 0.0]))),
    "four_bar_floating": dict(path="tests/jaxsim/four_bar.sdf", floating=True, welds=[("m1", "m2")], K_P=1.0e4, gravity=0.0, steps=1000,
                              state=dict(joint_velocities=np.array([1.0, 0.0, 0.0, 0.0]), base_linear_velocity=np.array([0.0, 0.1, -0.1]),
                                         base_angular_velocity=np.array([0.2, 0.4, -0.3]))),
    "coaxial_turned": dict(path="tests/jaxsim/coaxial_pendulums.sdf", floating=False, welds=[("a_tip", "b_tip")], K_P=None, gravity=-9.81, steps=1000,
                           state=dict(joint_positions=np.deg2rad([5.0, 0.0]))),
}  # fmt: skip
"""Each case: the description (floating: without its weld to the world), the welded frames, K_P (None: JaxSim's
1000), the gravity's z component [m/s^2] (model.gravity), the steps (JaxSim's default time step, 1 ms,
semi-implicit Euler) and the initial state (JaxSimModelData.build's keywords; joints in the description's order)."""

EVERY = 100
"""The trajectories keep every EVERY-th state."""


def description(name: str) -> str:
    """Case `name`'s SDF text."""
    text = (ROOT / CASES[name]["path"]).read_text()
    return FLOATING.sub("", text) if CASES[name]["floating"] else text


def build(api, name: str, **kwargs):
    """Case `name`'s model with its welds (JaxSim's ConstraintMap, set as JaxSim's tests set it) and gravity."""
    spec = CASES[name]
    model = api.model.JaxSimModel.build_from_model_description(model_description=description(name), **kwargs)
    constraints = api.kin_dyn_parameters.ConstraintMap()
    for frame_1, frame_2 in spec["welds"]:
        constraints = constraints.add_constraint(
            model=model,
            frame_idx_1=api.frame.name_to_idx(model=model, frame_name=frame_1),
            frame_idx_2=api.frame.name_to_idx(model=model, frame_name=frame_2),
            constraint_type=api.kin_dyn_parameters.ConstraintType.Weld,
            K_P=spec["K_P"],
        )
    with model.editable(validate=False) as model:
        model.kin_dyn_parameters.constraints = constraints
        model.gravity = spec["gravity"]
    return model


def _host(array) -> np.ndarray:
    """A JAX or Warp array (on any device) as a NumPy array: Warp refuses the implicit conversion of a GPU array."""
    return array.numpy() if hasattr(array, "device") and hasattr(array, "numpy") else np.asarray(array)


def rollout(api, model, name: str) -> dict:
    """The states every EVERY steps from case `name`'s initial state ((steps / EVERY + 1, ...) arrays: base position,
    base quaternion, joint positions, base velocity (Inertial), joint velocities) and the welded frames' world poses
    (W_H_F1, W_H_F2) at each."""
    spec = CASES[name]
    data = api.data.JaxSimModelData.build(model=model, velocity_representation=api.common.VelRepr.Inertial, **spec["state"])
    frames = [[api.frame.name_to_idx(model=model, frame_name=f) for f in pair] for pair in spec["welds"]]
    out = {k: [] for k in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities", "W_H_F1", "W_H_F2")}
    for step in range(spec["steps"] + 1):
        if step % EVERY == 0:
            for key in ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities"):
                out[key].append(_host(getattr(data, key)))
            out["W_H_F1"].append([_host(api.frame.transform(model=model, data=data, frame_index=f1)) for f1, _ in frames])
            out["W_H_F2"].append([_host(api.frame.transform(model=model, data=data, frame_index=f2)) for _, f2 in frames])
        if step < spec["steps"]:
            data = api.model.step(model=model, data=data)
    return {key: np.array(values) for key, values in out.items()}


def weld_error(trajectory: dict, name: str) -> np.ndarray:
    """The largest of the welded frames' origin distance [m] and relative rotation angle [rad] over the welds, at
    each kept state of `trajectory` (keys as `rollout`'s, or `<name>/<key>` as constraints.npz's)."""
    W_H_F1, W_H_F2 = (trajectory.get(k, trajectory.get(f"{name}/{k}")) for k in ("W_H_F1", "W_H_F2"))
    distance = np.linalg.norm(W_H_F1[..., :3, 3] - W_H_F2[..., :3, 3], axis=-1)
    relative = np.einsum("...ji,...jk->...ik", W_H_F2[..., :3, :3], W_H_F1[..., :3, :3])
    sine = np.stack([relative[..., 2, 1] - relative[..., 1, 2], relative[..., 0, 2] - relative[..., 2, 0], relative[..., 1, 0] - relative[..., 0, 1]], axis=-1)
    angle = np.arctan2(np.linalg.norm(sine, axis=-1) / 2.0, (np.trace(relative, axis1=-2, axis2=-1) - 1.0) / 2.0)  # exact near 0, unlike arccos
    return np.maximum(distance, angle).max(axis=-1)
