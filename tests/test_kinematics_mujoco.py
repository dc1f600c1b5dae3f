"""Kinematics against MuJoCo: link poses, Jacobians, link velocities and frames, in every representation.

Reference: C MuJoCo (float64) on the same URDF (meshes stripped, non-considered joints made fixed),
through `robots.mujoco_model` (fixed links fused, as warpdyn lumps them) and, for the frames (the links
warpdyn lumps), the same description compiled with `fusestatic` off so that every URDF link is a
MuJoCo body. Joints are mapped by name.

Representations are converted with independent NumPy transforms (`robots.to_mixed`/`from_mixed`) built
from MuJoCo's poses, never from warpdyn's:
- output side: a velocity of frame L in representation Y maps to Mixed by to_mixed(Y, W_R_L, W_p_L);
- input side: the base block of nu in representation X is from_mixed(X, W_R_B, W_p_B) times the Mixed base
  velocity: nu_X = T nu_Mixed with T = blockdiag(from_mixed(X, W_R_B, W_p_B), I), so from J_XY nu_X = J_MM nu_Mixed,
  J_MM = to_mixed(Y, W_R_L, W_p_L) @ J_XY @ T.
MuJoCo's Jacobians (mj_jacBody) and body velocities (mj_objectVelocity, mjOBJ_XBODY) are Mixed in/out
once its free-joint velocity convention is converted (robots.MujocoState).

Tolerances are relative to the size of what is compared (the largest entry of the reference or of
warpdyn's raw output, at least 1): float64 1e-10 (rounding accumulates over at most ~30 composed
transforms with entries up to tens of metres: observed 1.5e-14 at worst, so 1e-10 leaves room for other
platforms while a wrong formula, a float32 leak or a wrong representation gives errors of 1e-7 to O(1));
float32 1e-4 (epsilon 1.2e-7 times the same accumulation: observed 2.5e-6 at worst, on a 30-deep chain).

Fixed-base models: MuJoCo fuses the base into the world and has no base columns: joint columns only are
compared, and the base link's pose comes from the unfused MuJoCo model (where it is a static body).
"""

from __future__ import annotations

import dataclasses
import functools
import xml.etree.ElementTree as ET

import numpy as np
import pytest

import robots
import warpdyn as wd
from robots import from_mixed, rng_for, rotation_wxyz, skew, to_mixed, uniform_state_kwargs

REPRS = (wd.VelRepr.Body, wd.VelRepr.Mixed, wd.VelRepr.Inertial)
TOL = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 1e-4}


# ------------------------------------------------------------------------------------ robots and cases


def chain_urdf(seed: int, fixed_base: bool = False) -> str:
    """robots.random_tree_urdf(seed, 31 links, max_depth=30) rewired into a chain of depth 30: the
    parent of joint i becomes link i-1 and fixed joints become continuous, so 30 movable joints in series."""
    root = ET.fromstring(robots.random_tree_urdf(seed, num_links=31, max_depth=30, fixed_base=fixed_base))
    for joint in root.findall("joint"):
        name = joint.get("name")
        if name.startswith("joint"):
            joint.find("parent").set("link", f"link{int(name[5:]) - 1}")
            if joint.get("type") == "fixed":
                joint.set("type", "continuous")
    return ET.tostring(root, encoding="unicode")


@functools.cache
def source(case: str) -> tuple[str, tuple[str, ...] | None]:
    """(URDF text, considered joints or None) of a case."""
    kind, _, arg = case.partition("-")
    if kind == "chain":
        return chain_urdf(int(arg)), None
    if kind == "chainfixed":
        return chain_urdf(int(arg), fixed_base=True), None
    if kind == "rigid":  # every joint locked: one rigid floating body, no joints
        return robots.random_tree_urdf(int(arg)), ()
    return robots.case_source(case)


CASES = (
    [f"random-{s}" for s in range(20)]
    + [f"randomfixed-{s}" for s in range(100, 105)]
    + ["chain-7", "chain-8", "chainfixed-9", "rigid-0", "pendulum-5", "icub", "icublegs", "ergocub"]
)
BIG = ("icub", "icublegs", "ergocub")


@dataclasses.dataclass
class Case:
    model: wd.model.Model
    mj_fused: object
    mj_unfused: object


@functools.cache
def build_case(case: str, dtype) -> Case:
    text, considered = source(case)
    full = wd.model.Model.build_from_model_description(text, dtype=dtype)
    model = wd.model.reduce(full, considered) if considered is not None else full
    floating = model.floating_base()
    return Case(
        model,
        robots.mujoco_model(text, considered, floating=floating),
        robots.mujoco_model(text, considered, floating=floating, fuse_static=False),
    )


# ------------------------------------------------------------------------------------ states and references


@dataclasses.dataclass
class State:
    """One environment's state as stored by warpdyn (rounded to its dtype), in float64."""

    p: np.ndarray  # W_p_B
    q: np.ndarray  # W_Q_B (w, x, y, z)
    s: np.ndarray
    v_mixed: np.ndarray  # Mixed base velocity, converted in NumPy from what was given in `repr`
    sd: np.ndarray
    v_given: np.ndarray  # the base velocity as given, in `repr`
    repr: wd.VelRepr

    @property
    def R(self) -> np.ndarray:
        return rotation_wxyz(self.q)


def stored(model, data, kwargs, env=None) -> State:
    """The state warpdyn holds (read back, so float32 rounding is in the reference too), from the (N, ...)
    state arrays (test_model tests the public properties)."""
    dt = model.dtype

    def pick(a):
        return np.asarray(a.numpy(), dtype=np.float64)[0 if env is None else env]

    p = pick(data.base_position_state)
    q = pick(data.base_quaternion_state)
    if model.floating_base():
        v = np.concatenate([kwargs["base_linear_velocity"], kwargs["base_angular_velocity"]], axis=-1)
        v = np.asarray(v, dtype=dt).astype(np.float64)
        v = v if env is None else v[env]
        v_mixed = to_mixed(data.velocity_representation.name, rotation_wxyz(q), p) @ v
    else:
        v = v_mixed = np.zeros(6)
    s, sd = pick(data.joint_positions_state), pick(data.joint_velocities_state)
    return State(p, q, s, v_mixed, sd, v, data.velocity_representation)


class Reference:
    """MuJoCo's quantities of a body by name, Mixed; the fused model first, the unfused one otherwise."""

    def __init__(self, case: Case, state: State):
        model = case.model
        self.floating = model.floating_base()
        self.n = model.dofs()
        self.states = []
        for mj in (case.mj_fused, case.mj_unfused):
            st = robots.MujocoState(mj, model.joint_names(), self.floating)
            st.set(state.p, state.q, state.s, state.v_mixed, state.sd)
            self.states.append(st)

    def _st(self, name, unfused=False):
        if not unfused and self.states[0].has_body(name):
            return self.states[0]
        st = self.states[1]
        assert st.has_body(name), f"MuJoCo has no body '{name}'"
        return st

    def pose(self, name, unfused=False):
        """(W_R_L, W_p_L)."""
        p, R = self._st(name, unfused).body_pose(name)
        return R, p

    def jacobian(self, name, unfused=False):
        st = self._st(name, unfused)
        if not self.floating and st.m.body(name).weldid == 0:
            return np.zeros((6, 6 + self.n))  # welded to the world: no motion
        return st.body_jacobian_mixed(name)

    def velocity(self, name, unfused=False):
        return self._st(name, unfused).body_velocity_mixed(name)


def assert_close(actual, expected, tol, what, raw=None):
    """max |actual - expected| <= tol * max(1, |expected|_max, |raw|_max)."""
    actual, expected = np.asarray(actual, dtype=np.float64), np.asarray(expected, dtype=np.float64)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    assert np.all(np.isfinite(actual)), f"{what}: non-finite entries\n{actual}"
    scale = max(1.0, np.abs(expected).max(initial=0.0), 0.0 if raw is None else np.abs(raw).max(initial=0.0))
    err = np.abs(actual - expected).max(initial=0.0)
    assert err <= tol * scale, (
        f"{what}: max error {err:.3e} > {tol:.0e} * {scale:.3g}\nactual\n{actual}\nexpected\n{expected}"
    )


def base_input_map(state: State, X, n) -> np.ndarray:
    """T with nu_X = T @ nu_Mixed: blockdiag(from_mixed(X, W_R_B, W_p_B), I_n)."""
    T = np.eye(6 + n)
    T[:6, :6] = from_mixed(X.name, state.R, state.p)
    return T


def cols(J, floating):
    """The columns MuJoCo has: all for a floating base, the joint columns for a fixed base."""
    return J if floating else J[..., 6:]


def setup(case_name, dtype, test, repr=wd.VelRepr.Mixed):
    case = build_case(case_name, dtype)
    model = case.model
    kwargs = uniform_state_kwargs(model, rng_for(case_name, test, np.dtype(dtype).name))
    data = wd.data.Data.build(model, **kwargs, velocity_representation=repr)
    state = stored(model, data, kwargs)
    return case, model, data, state, Reference(case, state)


# ------------------------------------------------------------------------------------ tests


@pytest.mark.parametrize("case_name", CASES)
def test_link_poses(case_name, dtype):
    """W_H_L of every link (forward_kinematics and link.transform) vs MuJoCo's xpos/xmat.

    Reference: MuJoCo body poses (the fixed base: the unfused model's static body). Tolerance: see the
    module docstring (relative 1e-10 float64, 1e-4 float32)."""
    case, model, data, state, ref = setup(case_name, dtype, "poses")
    tol = TOL[np.dtype(dtype)]
    H = wd.model.forward_kinematics(model, data).numpy()
    assert H.shape == (model.number_of_links(), 4, 4)
    for i, name in enumerate(model.link_names()):
        R, p = ref.pose(name)
        expected = np.eye(4)
        expected[:3, :3], expected[:3, 3] = R, p
        assert_close(H[i], expected, tol, f"W_H_L of link '{name}'")
        H_i = wd.link.transform(model, data, link_index=i).numpy()
        assert_close(H_i, expected, tol, f"link.transform of '{name}'")
    if model.floating_base():
        assert_close(H[0][:3, :3], state.R, tol, "base rotation vs the given quaternion")
        assert_close(H[0][:3, 3], state.p, tol, "base position vs the given position")


@pytest.mark.parametrize("case_name", CASES)
def test_jacobians_all_representations(case_name, dtype):
    """Link Jacobians (generalized_free_floating_jacobian and link.jacobian) for the 3x3 combinations of
    the data's (input) representation and output_vel_repr, mapped to Mixed in/out with NumPy transforms,
    vs MuJoCo's mj_jacBody. Also: output_vel_repr=None means the data's representation, and data built in
    X equals data switched to X. Tolerance: module docstring."""
    case, model, data, state, ref = setup(case_name, dtype, "jacobians")
    tol, n, floating = TOL[np.dtype(dtype)], model.dofs(), model.floating_base()
    names = model.link_names()
    expected = {name: ref.jacobian(name) for name in names}
    poses = {name: ref.pose(name) for name in names}
    for X in REPRS:
        T = base_input_map(state, X, n)
        with data.switch_velocity_representation(X):
            assert data.velocity_representation == X
            J_default = wd.model.generalized_free_floating_jacobian(model, data).numpy()
            for Y in REPRS:
                J = wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=Y).numpy()
                assert J.shape == (model.number_of_links(), 6, 6 + n)
                if Y == X:
                    np.testing.assert_array_equal(J_default, J, err_msg="output_vel_repr=None is the data's repr")
                for i, name in enumerate(names):
                    R, p = poses[name]
                    J_mixed = to_mixed(Y.name, R, p) @ J[i] @ T
                    what = f"J of link '{name}', input {X.name}, output {Y.name}"
                    assert_close(cols(J_mixed, floating), cols(expected[name], floating), tol, what, raw=J[i])
                    J_link = wd.link.jacobian(model, data, link_index=i, output_vel_repr=Y).numpy()
                    assert_close(J_link, J[i], tol, "link.jacobian vs generalized_free_floating_jacobian: " + what)
        assert data.velocity_representation == wd.VelRepr.Mixed
        # The same Jacobian from data built in X rather than switched to X.
        built = wd.data.Data.build(
            model,
            base_position=state.p,
            base_quaternion=state.q,
            joint_positions=state.s,
            joint_velocities=state.sd,
            velocity_representation=X,
        )
        J_built = wd.model.generalized_free_floating_jacobian(model, built, output_vel_repr=wd.VelRepr.Body).numpy()
        with data.switch_velocity_representation(X):
            J_switched = wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=wd.VelRepr.Body).numpy()
        assert_close(J_built, J_switched, tol, f"Jacobians of data built in {X.name} vs switched to it")


@pytest.mark.parametrize("case_name", CASES)
@pytest.mark.parametrize("X", REPRS, ids=lambda r: r.name)
def test_link_velocities(case_name, X, dtype):
    """Link velocities (link.velocity) in the 3 output representations, of data whose base velocity is
    given in X, vs MuJoCo's mj_objectVelocity (mapped to Y with NumPy's from_mixed of MuJoCo's pose); the
    generalized velocity in X vs NumPy; and J_XY @ nu_X equals the velocity in Y (J·nu identity).
    Tolerance: module docstring."""
    case, model, data, state, ref = setup(case_name, dtype, "velocities", repr=X)
    tol = TOL[np.dtype(dtype)]
    nu_expected = np.concatenate([from_mixed(X.name, state.R, state.p) @ state.v_mixed, state.sd])
    nu = data.generalized_velocity.numpy()
    assert_close(nu, nu_expected, tol, f"generalized velocity in {X.name}")
    if model.floating_base():
        assert_close(data.base_velocity.numpy(), state.v_given, tol, f"base velocity read back in {X.name}")
    names = model.link_names()
    for Y in REPRS:
        J = wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=Y).numpy()
        for i, name in enumerate(names):
            R, p = ref.pose(name)
            v_mj = ref.velocity(name)
            expected = from_mixed(Y.name, R, p) @ v_mj
            v = wd.link.velocity(model, data, link_index=i, output_vel_repr=Y).numpy()
            assert_close(v, expected, tol, f"velocity of link '{name}' in {Y.name} (data in {X.name})")
            assert_close(J[i] @ nu, v, tol, f"J @ nu vs velocity of '{name}', {X.name} -> {Y.name}", raw=J[i])
            if Y == X:
                v_default = wd.link.velocity(model, data, link_index=i).numpy()
                np.testing.assert_array_equal(v_default, v, err_msg="output_vel_repr=None is the data's repr")


@pytest.mark.parametrize("case_name", CASES)
def test_frames(case_name, dtype):
    """frame.transform, frame.velocity (3 outputs) and frame.jacobian (3x3 input/output) of every frame vs
    the parent body's MuJoCo pose, Mixed velocity and Mixed Jacobian composed with the frame offset
    (model.tree.link_H_frame, frame_parent): W_H_F = W_H_L L_H_F, and Mixed quantities moved from L's
    origin to F's by [[I, -(p_F - p_L)^], [0, I]]. The frame's own pose and velocity in the unfused MuJoCo
    model (where the lumped link is a body) are checked as well. Tolerance: module docstring."""
    case, model, data, state, ref = setup(case_name, dtype, "frames")
    tol, n, nL, floating = TOL[np.dtype(dtype)], model.dofs(), model.number_of_links(), model.floating_base()
    assert model.number_of_frames() == len(model.frame_names())
    inputs = {X: base_input_map(state, X, n) for X in REPRS}
    for k, frame_name in enumerate(model.frame_names()):
        index = nL + k
        assert wd.frame.name_to_idx(model, frame_name=frame_name) == index
        parent = wd.frame.idx_of_parent_link(model, frame_index=index)
        assert parent == model.tree.frame_parent[k]
        parent_name = model.link_names()[parent]
        R_L, p_L = ref.pose(parent_name, unfused=True)
        W_H_L = np.eye(4)
        W_H_L[:3, :3], W_H_L[:3, 3] = R_L, p_L
        W_H_F = W_H_L @ model.tree.link_H_frame[k]
        R_F, p_F = W_H_F[:3, :3], W_H_F[:3, 3]
        H = wd.frame.transform(model, data, frame_index=index).numpy()
        assert_close(H, W_H_F, tol, f"W_H_F of frame '{frame_name}' (parent '{parent_name}')")
        R_mj, p_mj = ref.pose(frame_name, unfused=True)
        assert_close(H[:3, :3], R_mj, tol, f"rotation of frame '{frame_name}' vs its unfused MuJoCo body")
        assert_close(H[:3, 3], p_mj, tol, f"position of frame '{frame_name}' vs its unfused MuJoCo body")

        shift = np.eye(6)
        shift[:3, 3:] = -skew(p_F - p_L)
        v_mixed = shift @ ref.velocity(parent_name, unfused=True)
        J_mixed = shift @ ref.jacobian(parent_name, unfused=True)
        assert_close(ref.velocity(frame_name, unfused=True), v_mixed, tol, f"MuJoCo: frame '{frame_name}' velocity")
        for Y in REPRS:
            v = wd.frame.velocity(model, data, frame_index=index, output_vel_repr=Y).numpy()
            what = f"velocity of frame '{frame_name}' in {Y.name}"
            assert_close(to_mixed(Y.name, R_F, p_F) @ v, v_mixed, tol, what, raw=v)
        for X in REPRS:
            with data.switch_velocity_representation(X):
                for Y in REPRS:
                    J = wd.frame.jacobian(model, data, frame_index=index, output_vel_repr=Y).numpy()
                    what = f"J of frame '{frame_name}', input {X.name}, output {Y.name}"
                    J_m = to_mixed(Y.name, R_F, p_F) @ J @ inputs[X]
                    assert_close(cols(J_m, floating), cols(J_mixed, floating), tol, what, raw=J)
                    if Y == X:
                        J_default = wd.frame.jacobian(model, data, frame_index=index).numpy()
                        np.testing.assert_array_equal(J_default, J, err_msg="output_vel_repr=None is the data's repr")
                        v_default = wd.frame.velocity(model, data, frame_index=index).numpy()
                        v_Y = wd.frame.velocity(model, data, frame_index=index, output_vel_repr=Y).numpy()
                        np.testing.assert_array_equal(v_default, v_Y, err_msg="output_vel_repr=None is the data's repr")


@pytest.mark.parametrize("case_name", CASES)
def test_batched_equals_single(case_name, dtype):
    """Batched data (4 environments, each its own random state) gives, environment by environment, exactly
    what single-environment data of that state gives: forward kinematics, Jacobians (3x3 representations),
    link and frame velocities, frame transforms and Jacobians. Reference: the single computation, the same
    kernel code on the same numbers, so the tolerance is 0 (bitwise equality)."""
    case = build_case(case_name, dtype)
    model = case.model
    rng = rng_for(case_name, "batched", np.dtype(dtype).name)
    N, nL = 4, model.number_of_links()
    frames = list(range(nL, nL + model.number_of_frames()))
    frames = frames if len(frames) <= 6 else [frames[k] for k in rng.choice(len(frames), 6, replace=False)]
    X = REPRS[int(rng.integers(3))]
    kwargs = uniform_state_kwargs(model, rng, num_envs=N)
    batched = wd.data.Data.build(model, **kwargs, velocity_representation=X, num_envs=N)
    singles = [
        wd.data.Data.build(model, **{k: v[e] for k, v in kwargs.items()}, velocity_representation=X) for e in range(N)
    ]
    if N > 1 and model.dofs() > 0:
        assert not np.array_equal(kwargs["joint_positions"][0], kwargs["joint_positions"][1])

    def compare(fn, what, shape_single):
        out = fn(batched).numpy()
        assert out.shape == (N, *shape_single), f"{what}: batched shape {out.shape}"
        for e, single in enumerate(singles):
            one = fn(single).numpy()
            assert one.shape == tuple(shape_single), f"{what}: single shape {one.shape}"
            np.testing.assert_array_equal(out[e], one, err_msg=f"{what}, environment {e}")

    n = model.dofs()
    compare(lambda d: wd.model.forward_kinematics(model, d), "forward_kinematics", (nL, 4, 4))
    compare(lambda d: d.generalized_velocity, "generalized_velocity", (6 + n,))
    for Xin in REPRS:
        for Y in REPRS:

            def jac(d, Y=Y, Xin=Xin):
                with d.switch_velocity_representation(Xin):
                    return wd.model.generalized_free_floating_jacobian(model, d, output_vel_repr=Y)

            compare(jac, f"Jacobians {Xin.name} -> {Y.name}", (nL, 6, 6 + n))
    for i in range(nL):
        for Y in REPRS:
            compare(lambda d: wd.link.velocity(model, d, link_index=i, output_vel_repr=Y), f"velocity of link {i}", (6,))
    for f in frames:
        compare(lambda d: wd.frame.transform(model, d, frame_index=f), f"frame {f} transform", (4, 4))
        for Y in REPRS:
            compare(lambda d: wd.frame.velocity(model, d, frame_index=f, output_vel_repr=Y), f"frame {f} velocity", (6,))
            compare(lambda d: wd.frame.jacobian(model, d, frame_index=f, output_vel_repr=Y), f"frame {f} J", (6, 6 + n))
    # And environment e of the batch is MuJoCo's state e (spot check of the batched state handling).
    H = wd.model.forward_kinematics(model, batched).numpy()
    for e in range(N):
        state = stored(model, batched, kwargs, env=e)
        ref = Reference(case, state)
        for i, name in enumerate(model.link_names()):
            R, p = ref.pose(name)
            assert_close(H[e, i, :3, :3], R, TOL[np.dtype(dtype)], f"env {e}: rotation of '{name}'")
            assert_close(H[e, i, :3, 3], p, TOL[np.dtype(dtype)], f"env {e}: position of '{name}'")
