"""JaxSim's kinematic constraints (`wd.kin_dyn_parameters.ConstraintMap`, `ConstraintType.Weld`): welds between frames,
solved as JaxSim 0.9 solves them (kernels/equality.py's frame weld). References: JaxSim 0.9.0's trajectories of the
same cases (tests/jaxsim/constraint_cases.py, written once in JaxSim's call form; tests/jaxsim/constraints.npz from
tests/jaxsim/generate_constraints.py), central differences for the gradients.
"""

from __future__ import annotations

import dataclasses
import pathlib
import sys

import numpy as np
import pytest

import warpdyn as wd

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent / "jaxsim"))

import constraint_cases as cc  # noqa: E402

REFERENCE = np.load(pathlib.Path(__file__).resolve().parent / "jaxsim" / "constraints.npz")
KEYS = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")


def _model(name: str, dtype=np.float64):
    return cc.build(wd, name, dtype=dtype)


@pytest.mark.parametrize("name", list(cc.CASES))
def test_welds_follow_jaxsims_trajectories(name):
    """1000 steps of 1 ms (semi-implicit Euler, float64) of each case (welded pendulums, fixed and floating; a four-bar
    closed by a weld, fixed and floating; pendulums on one axis welded by turned frames) equal JaxSim 0.9.0's with the
    three corrections tests/jaxsim/generate_constraints.py names, every 100 steps, within 1e-10 (positions [m, rad],
    velocities [m/s, rad/s])."""
    ours = cc.rollout(wd, _model(name), name)
    for key in KEYS:
        assert np.abs(ours[key] - REFERENCE[f"{name}/{key}"]).max() <= 1e-10, key


def test_where_jaxsim_as_released_differs():
    """JaxSim 0.9.0 as released (tests/jaxsim/generate_constraints.py's `released/` trajectories), against the
    corrected equations warpdyn solves: on a fixed base its solve lets the base move, so the pendulums' velocities
    differ by 0.13 rad/s and their weld closes slower (5e-6 from 0.8 to 1 s, warpdyn's 1.4e-10 at most); on a turning floating
    base its Jacobians' base columns are Body-fixed (the pendulums' base orientation 1e-3 apart after 1 s); with the
    frames turned 2 rad about z its rotation residual pushes the wrong way and the weld parts (3.14 rad), where
    warpdyn's closes as a critically damped error (K_D = 2 sqrt(K_P)): below 1e-8 rad from 0.7 s on."""

    def released(name):
        return {k[len(f"released/{name}/"):]: v for k, v in REFERENCE.items() if k.startswith(f"released/{name}/")}

    ours = {name: cc.rollout(wd, _model(name), name) for name in ("pendulums", "pendulums_floating", "coaxial_turned")}
    assert np.abs(released("pendulums")["joint_velocities"] - ours["pendulums"]["joint_velocities"]).max() > 0.1
    assert cc.weld_error(released("pendulums"), "pendulums")[-3:].max() > 1e-6 >= 1e3 * cc.weld_error(ours["pendulums"], "pendulums")[-3:].max()
    assert np.abs(released("pendulums_floating")["base_quaternion"] - ours["pendulums_floating"]["base_quaternion"]).max() > 5e-4
    assert cc.weld_error(released("coaxial_turned"), "coaxial_turned")[-1] > 3.0
    error = cc.weld_error(ours["coaxial_turned"], "coaxial_turned")
    assert error[0] == pytest.approx(np.deg2rad(5.0)) and np.all(error[7:] <= 1e-8), error


def _rotation_vector(R: np.ndarray) -> np.ndarray:
    """The axis times the angle of a rotation matrix (angle below pi)."""
    angle = np.arccos(np.clip((np.trace(R) - 1.0) / 2.0, -1.0, 1.0))
    axis = np.array([R[2, 1] - R[1, 2], R[0, 2] - R[2, 0], R[1, 0] - R[0, 1]])
    return axis * (0.5 if angle < 1e-8 else angle / (2.0 * np.sin(angle)))


@pytest.mark.parametrize("name", ["pendulums", "four_bar"])
def test_welds_on_a_fixed_base_solve_jaxsims_equations_over_the_joints(name):
    """On a fixed base a step's velocities equal JaxSim's equations solved over the joints (float64, 1e-12 of the
    largest): (J M^-1 J^T + 1e-3 I) f = -(J a_free + K_P r + K_D J nu), nu_dot = a_free + M^-1 J^T f, with the frames'
    Jacobians, the mass matrix and ABA from warpdyn's own queries. JaxSim 0.9 solves them with its floating-base mass
    matrix, a fixed base's six DoFs counted as free (J's base columns are not zero), so its forces differ (the
    pendulums' first step: joint velocities (-0.052, 0.037) rad/s where these equations give (-0.080, 0.008)) and its
    welds close slower (test_where_jaxsim_as_released_differs)."""
    model = _model(name)
    plain = model.replace(constraints=None)
    data = wd.data.Data.build(model, velocity_representation=wd.common.VelRepr.Mixed, **cc.CASES[name]["state"])
    frames = [wd.frame.name_to_idx(model, frame_name=f) for f in cc.CASES[name]["welds"][0]]
    J1, J2 = (wd.frame.jacobian(plain, data, frame_index=f, output_vel_repr=wd.common.VelRepr.Mixed).numpy().reshape(6, -1)[:, 6:] for f in frames)
    H1, H2 = (wd.frame.transform(plain, data, frame_index=f).numpy().reshape(4, 4) for f in frames)
    M = wd.model.free_floating_mass_matrix(plain, data).numpy().reshape(6 + model.dofs(), -1)[6:, 6:]
    a_free = wd.model.forward_dynamics_aba(plain, data)[1].numpy().reshape(-1)
    J, nu = J1 - J2, data.joint_velocities.numpy().reshape(-1)
    r = np.concatenate([H1[:3, 3] - H2[:3, 3], H2[:3, :3] @ _rotation_vector(H2[:3, :3].T @ H1[:3, :3])])
    K_P, K_D = model.constraints.K_P[0], model.constraints.K_D[0]
    f = np.linalg.solve(J @ np.linalg.solve(M, J.T) + 1e-3 * np.eye(6), -(J @ a_free + K_P * r + K_D * J @ nu))
    expected = nu + model.time_step * (a_free + np.linalg.solve(M, J.T @ f))
    stepped = wd.model.step(model, data).joint_velocities.numpy().reshape(-1)
    assert np.abs(stepped - expected).max() <= 1e-12 * np.abs(expected).max()


def test_the_projection_closes_a_weld_to_rounding():
    """With `equality_projection = 2` the four-bar's weld stays closed to 1e-12 m and rad over 1 s (RK4)."""
    model = _model("four_bar").replace(integrator=wd.model.IntegratorType.RungeKutta4)
    model.equality_projection = 2
    assert np.all(cc.weld_error(cc.rollout(wd, model, "four_bar"), "four_bar") <= 1e-12)


def test_welded_steps_differentiate():
    """A step's and ten steps' A and B through the welds (their rows differentiated by Warp, the solve's adjoint by
    hand) equal central differences at h = 1e-6, relative to the largest entry: A within 1e-7 (measured 3.5e-11 to
    6.7e-9), B within 1e-5 (measured 1.1e-8 to 1.7e-6: the differences' rounding, larger at h = 3e-7), on the
    four-bar and on the floating pendulums."""
    for name in ("four_bar", "pendulums_floating"):
        model = _model(name)
        data = wd.data.Data.build(model, **cc.CASES[name]["state"])
        for steps in (1, 10):
            exact = wd.autodiff.transition_matrices(model, data, steps=steps)
            central = wd.autodiff.transition_matrices(model, data, steps=steps, method="central", h=1e-6)
            for key, bound in (("A", 1e-7), ("B", 1e-5)):
                A, fd = exact[key].numpy(), central[key].numpy()
                assert np.abs(A - fd).max() <= bound * np.abs(A).max(), (name, key, steps)


def test_the_gains_follow_jaxsims_defaults_and_every_way_to_set_a_map():
    """K_P = 1000 and K_D = 2 sqrt(K_P) unless given (0 allowed, as JaxSim's); a map set through the snapshot inside
    `editable` (JaxSim's idiom), `model.constraints`, `replace(kin_dyn_parameters=...)`, `replace(constraints=...)` or
    `build_from_model_description(constraints=...)`, or made of indices alone (JaxSim's fields), gives the same model;
    a model without constraints has an empty map (JaxSim's default); model equality sees the map."""
    model = _model("four_bar")
    plain = wd.model.JaxSimModel.build_from_model_description(cc.description("four_bar"), dtype=np.float64)
    assert len(plain.constraints) == 0 and plain.kin_dyn_parameters.constraints.frame_idxs_1.shape == (0,)
    m1, m2 = (wd.frame.name_to_idx(plain, frame_name=f) for f in ("m1", "m2"))
    default = wd.kin_dyn_parameters.ConstraintMap().add_constraint(plain, m1, m2, wd.kin_dyn_parameters.ConstraintType.Weld)
    assert default.K_P.tolist() == [1000.0] and default.K_D[0] == pytest.approx(2.0 * np.sqrt(1000.0))
    assert default.parent_link_idxs_1.tolist() == [plain.link_names().index("coupler_1")]
    assert wd.kin_dyn_parameters.ConstraintMap().add_constraint(plain, m1, m2, 0, K_P=0.0).K_D.tolist() == [0.0]
    given = wd.kin_dyn_parameters.ConstraintMap().add_constraint(plain, m1, m2, wd.kin_dyn_parameters.ConstraintType.Weld, K_P=1e4)
    assert model.kin_dyn_parameters.constraints == given and model != plain
    built = wd.model.JaxSimModel.build_from_model_description(cc.description("four_bar"), constraints=given, dtype=np.float64)
    assigned = plain.copy()
    assigned.constraints = given
    replaced = plain.replace(kin_dyn_parameters=dataclasses.replace(plain.kin_dyn_parameters, constraints=given))
    beside = plain.replace(kin_dyn_parameters=plain.kin_dyn_parameters, constraints=given)  # the keyword wins
    indices = plain.replace(constraints=wd.kin_dyn_parameters.ConstraintMap(
        frame_idxs_1=[m1], frame_idxs_2=[m2], constraint_types=[0], K_P=[1e4], K_D=[200.0], parent_link_idxs_1=[3], parent_link_idxs_2=[4]))
    for other in (built, assigned, replaced, beside, indices):
        assert other.constraints == given and other == model
    assert len(plain.constraints) == 0  # the copies took it, not the model they came from
    cleared = model.copy()
    cleared.constraints = None
    assert len(cleared.constraints) == 0 and cleared == plain
    data = wd.data.Data.build(model, **cc.CASES["four_bar"]["state"])
    steps = [wd.model.step(m, data).joint_positions.numpy() for m in (model, built, indices)]
    assert np.array_equal(steps[0], steps[1]) and np.array_equal(steps[0], steps[2])


def test_reduce_finds_the_welded_frames_by_name_and_copies_share_nothing_writable():
    """A reduction that moves the welded frames' links (the crank's joint locked: the frames' links 3 and 4 become 1
    and 3) keeps the weld on the same frames: its step equals that of the reduced model given the map directly. The
    map's arrays are read-only (model copies share it); a copy made from a snapshot is not the model's (assigning its
    constraints leaves the model as it is), and a snapshot takes a ConstraintMap only."""
    model = _model("four_bar")
    reduced = wd.model.reduce(model, ["B", "C", "D"])
    assert reduced.constraints.parent_link_idxs_1.tolist() == [reduced.link_names().index("coupler_1")] != model.constraints.parent_link_idxs_1.tolist()
    direct = wd.model.reduce(model.replace(constraints=None), ["B", "C", "D"])
    direct.constraints = wd.kin_dyn_parameters.ConstraintMap().add_constraint(
        direct, *(wd.frame.name_to_idx(direct, frame_name=f) for f in ("m1", "m2")), wd.kin_dyn_parameters.ConstraintType.Weld, K_P=1e4)
    data = wd.data.Data.build(reduced, joint_velocities=np.array([0.5, -0.2, 0.1]))
    assert np.array_equal(wd.model.step(reduced, data).joint_velocities.numpy(), wd.model.step(direct, data).joint_velocities.numpy())
    with pytest.raises(ValueError, match="read-only"):
        model.constraints.K_P[0] = 1.0
    plain = model.replace(constraints=None)
    derived = plain.kin_dyn_parameters.set_link_mass(1, 2.0)
    derived.constraints = model.constraints
    assert len(plain.constraints) == 0 and derived.constraints == model.constraints
    with pytest.raises(TypeError, match="kin_dyn_parameters.constraints must be a wd.kin_dyn_parameters.ConstraintMap, got str"):
        derived.constraints = "welds"
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot delete field 'link_names'"):
        del derived.link_names


def test_bad_constraints_are_refused_by_name():
    """Indices that are not frames, another type, gains that are negative or not finite, two frames of one link, a
    map whose frames a model lacks, fields of different lengths, another type assigned, a snapshot's other fields:
    each refused, naming it."""
    model = _model("four_bar")
    empty, weld = wd.kin_dyn_parameters.ConstraintMap(), wd.kin_dyn_parameters.ConstraintType.Weld
    m1, m2 = (wd.frame.name_to_idx(model, frame_name=f) for f in ("m1", "m2"))
    with pytest.raises(IndexError, match=r"frame_index 1 is out of range \[5, 7\)"):
        empty.add_constraint(model, 1, m2, weld)
    with pytest.raises(TypeError, match="frame_index must be an integer, got 'm1'"):
        empty.add_constraint(model, "m1", m2, weld)
    with pytest.raises(ValueError, match="constraint_type must be ConstraintType.Weld"):
        empty.add_constraint(model, m1, m2, 1)
    for gains, match in (({"K_P": -1.0}, "K_P must be non-negative and finite, got -1.0"), ({"K_D": np.nan}, "K_D must be non-negative and finite"),
                         ({"K_P": [1.0, 2.0]}, r"K_P must be one number, got shape \(2,\)")):  # fmt: skip
        with pytest.raises(ValueError, match=match):
            empty.add_constraint(model, m1, m2, weld, **gains)
    lumped = wd.model.JaxSimModel.build_from_model_description(cc.description("pendulums"), dtype=np.float64)
    assert "a_tip" in lumped.frame_names()
    pendulum_map = empty.add_constraint(lumped, *(wd.frame.name_to_idx(lumped, frame_name=f) for f in ("a_tip", "b_tip")), weld)
    with pytest.raises(ValueError, match=r"frames \['a_tip', 'b_tip'\] are not frames of model 'four_bar'"):
        model.copy().constraints = pendulum_map
    with pytest.raises(TypeError, match="constraints must be a wd.kin_dyn_parameters.ConstraintMap or None, got dict"):
        model.copy().constraints = {}
    with pytest.raises(ValueError, match=r"must have one length .*'frame_idxs_1': 2, 'frame_idxs_2': 1.*make maps with add_constraint"):
        wd.kin_dyn_parameters.ConstraintMap(frame_idxs_1=[m1, m1], frame_idxs_2=[m2], constraint_types=[0], K_P=[1.0], K_D=[1.0],
                                            parent_link_idxs_1=[3], parent_link_idxs_2=[4])  # fmt: skip
    with pytest.raises(dataclasses.FrozenInstanceError, match="cannot assign to field 'link_names'"):
        model.kin_dyn_parameters.link_names = ("x",)


def test_a_weld_of_frames_on_one_link_is_refused_or_dropped_by_a_reduction():
    """Two frames of one link: nothing to hold, a ValueError naming them and the link; a reduction that locks the
    joints between two welded frames drops the weld with a NotModelledWarning naming it."""
    text = cc.description("four_bar").replace('<frame name="m2" attached_to="coupler_2">', '<frame name="m2" attached_to="coupler_1">').replace(
        '<pose relative_to="coupler_2">', '<pose relative_to="coupler_1">')
    model = wd.model.JaxSimModel.build_from_model_description(text, dtype=np.float64)
    m1, m2 = (wd.frame.name_to_idx(model, frame_name=f) for f in ("m1", "m2"))
    with pytest.raises(ValueError, match="frames 'm1' and 'm2' of model 'four_bar': both are on link 'coupler_1'"):
        wd.kin_dyn_parameters.ConstraintMap().add_constraint(model, m1, m2, wd.kin_dyn_parameters.ConstraintType.Weld)
    with pytest.warns(wd.model.NotModelledWarning, match=r"'four_bar' holds the frames of the welds \['m1 - m2'\] on one link each"):
        rigid = wd.model.reduce(_model("four_bar"), [])
    assert len(rigid.constraints) == 0


def test_welds_in_float32_and_per_environment_states():
    """float32: the floating four-bar's 1000 steps stay within 1e-4 of JaxSim's float64 joint positions; a batch of
    environments each in another state steps each as alone."""
    ours = cc.rollout(wd, _model("four_bar_floating", np.float32), "four_bar_floating")
    assert np.abs(ours["joint_positions"] - REFERENCE["four_bar_floating/joint_positions"]).max() <= 1e-4
    model = _model("four_bar")
    speeds = np.array([[1.0, 0.0, 0.0, 0.0], [-0.5, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
    batch = wd.data.Data.build(model, num_envs=3, joint_velocities=speeds)
    stepped = wd.model.step(model, batch).joint_velocities.numpy()
    for i, v in enumerate(speeds):
        alone = wd.model.step(model, wd.data.Data.build(model, joint_velocities=v)).joint_velocities.numpy()
        assert np.array_equal(stepped[i], alone.reshape(-1))
