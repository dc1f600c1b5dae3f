"""The seed notebook ("JaxSim as a multibody dynamics library") as a test: examples/tour.py's `run_tour`,
which ports every cell, on the seed's ergoCub and on the iCub, float64, one environment.

The test imports the example (examples/ on sys.path), so the example and the test cannot drift. It
asserts the notebook's relations again, with the tolerances below, and the shapes the notebook prints
(ergoCub: M (18, 18), J (13, 6, 18), 32 contact points, G_Xf_C (32, 6, 6), Ψ (96, 96), W_p̈_C (32, 3);
the iCub's legs have the same links and joints but 16 contact points, 8 box corners per foot).

Beyond the notebook, two cells whose results it only prints are checked against central finite
differences along the motion (float64, ε = 1e-5: truncation O(ε²) ~ 1e-10, roundoff ~ 1e-16/ε ~ 1e-11,
both relative, so 1e-6 is safe and a wrong formula is off by O(1)):
- G_ḣ (cell 17): the time derivative of the centroidal momentum G_h = J_CMM ν when the cell's contact
  forces (and any joint torques) act: d/dt G[W]_h = m g + Σ_c G_X*_C C_f. This is what shows the two
  fixes of the notebook's text (the force transform, the einsum) right.
- W_p̈_C (cell 18): the time derivative of the contact points' velocities W_ṗ_C under the forward
  dynamics of the references' forces.

Tolerances are relative: max |lhs - rhs| <= tol * max(1, max |rhs|).
- 1e-12 for the velocity relations W_v = J ν and G_h = J_CMM ν (sums of 18 products of O(1) terms
  computed by different kernels: observed <= 4e-16).
- 1e-10 for h == C ν + g (C from its own algorithm: observed <= 1e-15).
- 1e-8 for ν̇_eom == ν̇_aba, τ_rnea == τ and f_B == link_forces[0]: ABA and RNEA against pinv(M) of the
  CRBA's M, whose light feet and heavy base make it ill-conditioned and the accelerations reach 1e3
  (observed <= 1.3e-13 over 1000 random states of each robot).
"""

from __future__ import annotations

import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest

import robots
import warpdyn as wd
from warpdyn import VelRepr

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "examples"))

import tour  # noqa: E402


def icub_path() -> pathlib.Path:
    import icub_models

    return pathlib.Path(icub_models.get_model_file("iCubGazeboV2_5"))


# name: (description path, number of contact points)
ROBOTS = {"ergoCub": (robots.ERGOCUB, 32), "iCub": (None, 16)}


@pytest.fixture(scope="module", params=list(ROBOTS))
def run(request):
    path, _ = ROBOTS[request.param]
    path = icub_path() if path is None else path
    result = tour.run_tour(path, dtype="float64", verbose=False)
    result["name"], result["expected_points"] = request.param, ROBOTS[request.param][1]
    return result


def assert_rel(lhs, rhs, tol, what=""):
    lhs, rhs = np.asarray(lhs, dtype=np.float64), np.asarray(rhs, dtype=np.float64)
    assert lhs.shape == rhs.shape, f"{what}: shapes {lhs.shape} != {rhs.shape}"
    error = np.max(np.abs(lhs - rhs), initial=0.0) / max(1.0, np.max(np.abs(rhs), initial=0.0))
    assert error <= tol, f"{what}: relative error {error:.3g} > {tol:g}"


def test_model_cells(run):
    """Cells 3-5: the seed's joint filter keeps the 12 leg joints of both robots; 13 links."""
    model, full = run["model"], run["full_model"]
    assert model.name() == run["name"]
    assert model.joint_names() == tuple(robots.seed_joints(full.joint_names()))
    assert sorted(model.joint_names()) == sorted(robots.icub_leg_joints(full.joint_names()))
    assert (model.number_of_links(), model.number_of_joints(), model.dofs()) == (13, 12, 12)
    assert model.floating_base()


def test_data_and_references(run):
    """Cells 6-7: the state and the references have JaxSim's single-environment shapes."""
    assert run["W_H_B"].shape == (4, 4) and run["s"].shape == (12,) and run["ν"].shape == (18,)
    model, data, references = run["model"], run["data"], run["references"]
    assert references.link_forces(model, data).shape == (13, 6)
    assert references.joint_force_references(model).shape == (12,)
    # The references (Mixed, as the data) give back the raw forces they were built from.
    assert_rel(run["f_L"], run["link_forces"], 1e-12, "f_L == link_forces")
    assert_rel(run["τ"], run["joint_force_references"], 0.0, "τ == joint_force_references")


def test_link_cells(run):
    """Cells 8-10: W_v_WL == W_J_WL_B @ B_ν, and the three representations agree on the angular part."""
    assert run["link_name"] == "l_ankle_2" and run["W_H_L"].shape == (4, 4)
    assert_rel(run["W_v_WL"], run["W_J_WL_B"] @ run["B_ν"], 1e-12, "W_v_WL == W_J_WL_B @ B_ν")
    R = run["W_H_L"][:3, :3]
    assert_rel(run["LW_v_WL"][3:], run["W_v_WL"][3:], 1e-12, "mixed and inertial angular velocity")
    assert_rel(R @ run["L_v_WL"][3:], run["W_v_WL"][3:], 1e-12, "body angular velocity")


def test_frame_cells(run):
    """Cells 11-13: W_v_WF == W_J_WF_B @ B_ν (the seed's l_foot_front; the iCub has l_sole instead)."""
    assert run["frame_name"] == {"ergoCub": "l_foot_front", "iCub": "l_sole"}[run["name"]]
    assert run["W_H_F"].shape == (4, 4)
    assert_rel(run["W_v_WF"], run["W_J_WF_B"] @ run["B_ν"], 1e-12, "W_v_WF == W_J_WF_B @ B_ν")


def test_eom_cell(run):
    """Cell 14: shapes of M, h, g, C, B, J, τ, f_L and h == C ν + g (tolerance 1e-10, see the module)."""
    shapes = {k: run[k].shape for k in ("M", "h", "g", "C", "B", "J", "τ", "f_L")}
    assert shapes == {
        "M": (18, 18),
        "h": (18,),
        "g": (18,),
        "C": (18, 18),
        "B": (18, 12),
        "J": (13, 6, 18),
        "τ": (12,),
        "f_L": (13, 6),
    }
    assert_rel(run["h"], run["C"] @ run["ν"] + run["g"], 1e-10, "h == C @ ν + g")
    assert_rel(run["M"], run["M"].T, 1e-12, "M symmetric")


def test_forward_dynamics_cell(run):
    """Cell 15: ν̇_eom (pinv(M) of the EoM) == ν̇_aba (tolerance 1e-8, see the module)."""
    assert run["ν̇_aba"].shape == (18,)
    assert_rel(run["ν̇_eom"], run["ν̇_aba"], 1e-8, "ν̇_eom == ν̇_aba")


def test_inverse_dynamics_cell(run):
    """Cell 16: RNEA undoes ABA: τ_rnea == τ and f_B == link_forces[0] (tolerance 1e-8)."""
    assert run["f_B"].shape == (6,) and run["τ_rnea"].shape == (12,)
    assert_rel(run["τ_rnea"], run["τ"], 1e-8, "τ_rnea == τ")
    assert_rel(run["f_B"], run["link_forces"][0], 1e-8, "f_B == link_forces[0]")


def test_centroidal_cell(run):
    """Cell 17: n_cp, G_h == J_CMM ν == centroidal_momentum, G_Xf_C a force transform, G_ḣ's shape."""
    nc = run["expected_points"]
    model, data = run["model"], run["data"]
    assert run["n_cp"] == nc == len(model.kin_dyn_parameters.contact_parameters.body)
    assert run["J_CMM"].shape == (6, 18) and run["G_h"].shape == (6,) and run["G_ḣ"].shape == (6,)
    assert run["G_Xf_C"].shape == (nc, 6, 6) and run["C_fl"].shape == (nc, 3)
    assert_rel(run["G_h"], wd.com.centroidal_momentum(model, data).numpy(), 1e-12, "G_h == centroidal_momentum")
    # G_Xf_C = G_X*_C = C_X_G^T: it moves the torque of a force to G, [f; τ_G] = [f; τ_C + G_p_C × f].
    W_H_C = run["W_H_C"]
    G_p_C = W_H_C[:, :3, 3] - run["W_p_CoM"]
    f_C = np.concatenate([run["C_fl"], np.zeros_like(run["C_fl"])], axis=-1)
    W_f = np.einsum("cij,cj->ci", W_H_C[:, :3, :3], run["C_fl"])
    expected = np.concatenate([W_f, np.cross(G_p_C, W_f)], axis=-1)
    assert_rel(np.einsum("cij,cj->ci", run["G_Xf_C"], f_C), expected, 1e-12, "G_Xf_C @ C_f")


def test_contact_cell_shapes(run):
    """Cell 18: Ψ (3nc, 3nc), W_H_C (nc, 4, 4), W_ṗ_C and W_p̈_C (nc, 3); Ψ symmetric positive semidefinite;
    W_ṗ_C == Jl_WC ν (tolerance 1e-12)."""
    nc = run["expected_points"]
    assert run["Ψ"].shape == (3 * nc, 3 * nc)
    assert run["W_H_C"].shape == (nc, 4, 4)
    assert run["W_ṗ_B"].shape == (nc, 3) and run["W_p̈_C"].shape == (nc, 3)
    assert run["Jl_WC"].shape == run["J̇l_WC"].shape == (nc, 3, 18)
    Ψ = run["Ψ"]
    assert_rel(Ψ, Ψ.T, 1e-10, "Ψ symmetric")
    assert np.min(np.linalg.eigvalsh(0.5 * (Ψ + Ψ.T))) >= -1e-10 * np.max(np.abs(Ψ))
    assert_rel(run["W_ṗ_B"], run["Jl_WC"] @ run["BW_ν"], 1e-12, "W_ṗ_C == Jl_WC ν")


# ------------------------------------------------------------------ finite differences along the motion


def advanced(model, data, ε, ν̇):
    """Data (Mixed) at q + ε q̇ and ν + ε ν̇, with ν and ν̇ the Mixed [W_ṗ_B; W_ω_WB; ṡ] and its derivative."""
    ν = data.generalized_velocity.numpy()
    p, q, s = data.base_position.numpy(), data.base_quaternion.numpy(), data.joint_positions.numpy()
    ν_ε = ν + ε * ν̇
    return wd.data.Data.build(
        model,
        base_position=p + ε * ν[:3],
        base_quaternion=wd.math.Quaternion.integration(q, ε, ν[3:6]),
        joint_positions=s + ε * ν[6:],
        base_linear_velocity=ν_ε[:3],
        base_angular_velocity=ν_ε[3:6],
        joint_velocities=ν_ε[6:],
        velocity_representation=VelRepr.Mixed,
    )


def time_derivative(model, data, ν̇, f, ε=1e-5):
    """d/dt f(model, data) along the motion with acceleration ν̇, by central differences."""
    plus, minus = advanced(model, data, ε, ν̇), advanced(model, data, -ε, ν̇)
    return (f(model, plus).numpy() - f(model, minus).numpy()) / (2.0 * ε)


def test_centroidal_dynamics_fd(run):
    """G_ḣ (cell 17) == d/dt G_h under the cell's contact forces C_fl and the references' joint torques
    (central differences, tolerance 1e-6: see the module)."""
    model, data = run["model"], run["data"]
    assert data.velocity_representation == VelRepr.Mixed
    # The contact forces as Mixed link forces L[W]_f_L = [W_f; (W_p_C - W_p_L) × W_f], summed per link.
    W_H_C, W_H_L = run["W_H_C"], wd.model.forward_kinematics(model, data).numpy()
    params = model.kin_dyn_parameters.contact_parameters
    links = np.asarray(params.body)[np.asarray(params.enabled, dtype=bool)]
    W_f = np.einsum("cij,cj->ci", W_H_C[:, :3, :3], run["C_fl"])
    torques = np.cross(W_H_C[:, :3, 3] - W_H_L[links, :3, 3], W_f)
    f_L = np.zeros((model.number_of_links(), 6))
    np.add.at(f_L, links, np.concatenate([W_f, torques], axis=-1))
    ν̇ = np.concatenate(
        [x.numpy() for x in wd.model.forward_dynamics_aba(model, data, joint_forces=run["τ"], link_forces=f_L)]
    )
    G_ḣ = time_derivative(model, data, ν̇, wd.com.centroidal_momentum)
    assert_rel(run["G_ḣ"], G_ḣ, 1e-6, "G_ḣ == d/dt G_h")


def test_contact_acceleration_fd(run):
    """W_p̈_C (cell 18) == d/dt W_ṗ_C under the forward dynamics BW_ν̇ (central differences, tolerance 1e-6)."""
    model, data = run["model"], run["data"]
    W_p̈_C = time_derivative(model, data, run["BW_ν̇"], wd.contact.collidable_point_velocities)
    assert_rel(run["W_p̈_C"], W_p̈_C, 1e-6, "W_p̈_C == d/dt W_ṗ_C")


# ------------------------------------------------------------------ batched, float32, and the script


def test_batched_tour():
    """--num-envs: every cell runs batched (leading axis 3) and the tour's own checks hold in every environment."""
    r = tour.run_tour(robots.ERGOCUB, dtype="float64", num_envs=3, verbose=False)
    assert r["M"].shape == (3, 18, 18) and r["J"].shape == (3, 13, 6, 18) and r["C"].shape == (3, 18, 18)
    assert r["G_Xf_C"].shape == (3, 32, 6, 6) and r["G_ḣ"].shape == (3, 6)
    assert r["Ψ"].shape == (3, 96, 96) and r["W_p̈_C"].shape == (3, 32, 3)
    assert_rel(r["ν̇_eom"], r["ν̇_aba"], 1e-8, "ν̇_eom == ν̇_aba (batched)")
    assert_rel(r["f_B"], r["link_forces"][:, 0], 1e-8, "f_B == link_forces[0] (batched)")


def test_float32_tour():
    """--dtype float32: the tour's checks hold within its float32 tolerance (tour.TOLERANCE)."""
    r = tour.run_tour(robots.ERGOCUB, dtype="float32", verbose=False)
    assert r["M"].dtype == np.float32 and r["Ψ"].shape == (96, 96)


@pytest.mark.parametrize("robot", ["ergoCub (default)", "iCub"])
def test_script(robot):
    """`python examples/tour.py [iCub path]` exits 0, prints the notebook's model name and shapes, each quantity
    with a line on what it is, long name lists truncated, and its first and second run times."""
    args = [] if robot.startswith("ergoCub") else [robots.icub_path()]
    env = dict(os.environ, PYTHONIOENCODING="utf-8")
    proc = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "tour.py"), *args],
        capture_output=True,
        text=True,
        encoding="utf-8",
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    name, nc = ("ergoCub", 32) if robot.startswith("ergoCub") else ("iCub", 16)
    lines = [" ".join(line.split()) for line in proc.stdout.splitlines()]
    for expected in (
        f"Model name: {name}",
        "M: shape=(18, 18) the mass matrix (CRBA)",
        "J: shape=(13, 6, 18) the Jacobians of all links",
        f"Number of contact points: {nc}",
        f"G_Xf_C: shape=({nc}, 6, 6)",
        f"Ψ: shape=({3 * nc}, {3 * nc})",
        f"W_p̈_C: shape=({nc}, 3)",
        "The tour took",
    ):
        assert any(line.startswith(expected) for line in lines), f"{expected!r} not printed"
    frames = next(line for line in lines if line.startswith("Frames"))
    assert ", ..., " in frames and len(frames) < 200, frames  # a long list, truncated
