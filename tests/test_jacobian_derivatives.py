"""Jacobian derivatives J̇ and bias accelerations J̇ν: against MuJoCo, finite differences, and tape gradients.

Robots: random trees (robots.random_tree_urdf: floating and fixed base, revolute, prismatic, continuous and
lumped fixed joints), iCub's legs (icub-models) and the seed's ergoCub model (its leg joints). Targets: every
link and (some of) the frames, the links lumped into their parents. Every comparison runs the 3 x 3
combinations of input representation (the data's) and output representation.

References:
- MuJoCo's mj_jacDot (C, float64) at the target's origin on its body, with its velocity conventions converted
  explicitly (`mujoco_reference`), the time derivatives of the conversions included;
- central finite differences of warpdyn's own Jacobian (itself checked against MuJoCo's mj_jac and against
  finite differences of forward kinematics in the kinematics tests) along the state's motion;
- J̇ν from the J̇ kernel against the bias-acceleration kernel (a forward recursion over the tree);
- central finite differences of the kernels' outputs against their `wp.Tape` gradients (float64).
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest
import warp as wp

import robots
import warpdyn as wd
from robots import from_mixed, rotation_wxyz, skew, to_mixed
from warpdyn import VelRepr
from warpdyn.engine import derivatives as engine_derivatives
from warpdyn.engine import kinematics as engine_kinematics
from warpdyn.engine.kinematics import targets
from warpdyn.types.model import transforms

REPRS = (VelRepr.Body, VelRepr.Mixed, VelRepr.Inertial)
MODELS = ("tree0", "tree3", "tree7", "tree11", "fixed2", "fixed9", "icub_legs", "ergocub_seed")


# ------------------------------------------------------------------------------------------------ robots


@functools.cache
def _description(name: str) -> tuple[str, tuple[str, ...] | None]:
    """(URDF text, considered joints or None) of a test robot."""
    if name.startswith("tree"):
        return robots.random_tree_urdf(int(name[4:])), None
    if name.startswith("fixed"):
        return robots.random_tree_urdf(int(name[5:]), fixed_base=True), None
    if name == "icub_legs":
        urdf, select = robots.icub_urdf(), robots.icub_leg_joints
    elif name == "ergocub_seed":
        urdf, select = robots.ergocub_urdf(), robots.seed_joints
    else:
        raise KeyError(name)
    joints = [j.name for j in wd.description.load(urdf).joints if j.type != "fixed"]
    return urdf, tuple(select(joints))


@functools.cache
def _model(name: str, dtype) -> wd.model.Model:
    urdf, considered = _description(name)
    return wd.model.Model.build_from_model_description(urdf, considered_joints=considered, dtype=dtype)


@functools.cache
def _mujoco(name: str):
    urdf, considered = _description(name)
    return robots.mujoco_model(urdf, considered, floating=_model(name, np.float64).floating_base())


def _rng(name: str, salt: int) -> np.random.Generator:
    """A fixed generator per (robot, test): fresh states for every test, reproducible runs."""
    return np.random.default_rng(MODELS.index(name) * 1000 + salt)


def _random_state(model, rng, num_envs: int) -> dict:
    """Host arrays (N, ...) of a random state; the base velocity is Mixed. A fixed base stays where it is welded."""
    n = model.dofs()
    if model.floating_base():
        p = rng.uniform(-1.0, 1.0, (num_envs, 3)) + [0.0, 0.0, 0.5]
        q = rng.normal(size=(num_envs, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        v = rng.uniform(-1.0, 1.0, (num_envs, 6))
    else:
        H = model.description.world_H_base
        p = np.tile(H[:3, 3], (num_envs, 1))
        q = np.tile(wd.data._quaternion_wxyz(H[:3, :3]), (num_envs, 1))
        v = np.zeros((num_envs, 6))
    return dict(
        base_position=p,
        base_quaternion=q,
        joint_positions=rng.uniform(-2.0, 2.0, (num_envs, n)),
        base_linear_velocity=v[:, :3],
        base_angular_velocity=v[:, 3:],
        joint_velocities=rng.uniform(-1.0, 1.0, (num_envs, n)),
    )


def _data(model, state: dict, **kwargs) -> wd.data.Data:
    """Data of a host state (base velocity Mixed), num_envs = its leading axis."""
    N = len(state["joint_positions"])
    return wd.data.Data.build(model, **state, velocity_representation=VelRepr.Mixed, num_envs=N, **kwargs)


def _frame_targets(model, count: int, rng) -> list[int]:
    """Up to `count` frame rows (indices into model.frame_names()), drawn with rng."""
    nF = model.number_of_frames()
    return list(range(nF)) if nF <= count else sorted(rng.choice(nF, size=count, replace=False).tolist())


def _targets(model, frame_rows) -> tuple[wp.array, wp.array, np.ndarray, np.ndarray]:
    """Targets (every link, then the given frames) as Warp arrays, and on the host (link, link_H_target)."""
    tree = model.tree
    nL = model.number_of_links()
    rows = np.asarray(frame_rows, dtype=int)
    links = np.concatenate([np.arange(nL), tree.frame_parent[rows]]).astype(int)
    offsets = np.concatenate([np.tile(np.eye(4), (nL, 1, 1)), tree.link_H_frame[rows].reshape(-1, 4, 4)])
    link_H_target = transforms(offsets, model.scalar, model.device)
    return wp.array(links, dtype=int, device=model.device), link_H_target, links, offsets


def _tol(dtype, reference, f64: float, f32: float) -> float:
    """Absolute tolerance: f64 or f32 times the largest magnitude of the reference (at least 1)."""
    return (f64 if np.dtype(dtype) == np.float64 else f32) * max(1.0, float(np.max(np.abs(reference), initial=0.0)))


# ------------------------------------------------------------------------------- MuJoCo's J̇ and its conversion


def _to_mixed_rate(repr_: VelRepr, R: np.ndarray, v_mixed: np.ndarray) -> np.ndarray:
    """d/dt robots.to_mixed(repr_, R, p) along a frame's motion with Mixed velocity v_mixed = [pdot; omega].

    Body: to_mixed = blockdiag(R, R), Rdot = omega^ R. Inertial: to_mixed = [[I, -p^], [0, I]]. Mixed: I.
    """
    out = np.zeros((6, 6))
    if repr_ == VelRepr.Body:
        out[:3, :3] = out[3:, 3:] = skew(v_mixed[3:]) @ R
    elif repr_ == VelRepr.Inertial:
        out[:3, 3:] = -skew(v_mixed[:3])
    return out


def _from_mixed_rate(repr_: VelRepr, R: np.ndarray, v_mixed: np.ndarray) -> np.ndarray:
    """d/dt robots.from_mixed(repr_, R, p): Body blockdiag(R^T, R^T) -> -blockdiag(R^T omega^, ...);
    Inertial [[I, p^], [0, I]] -> [[0, pdot^], [0, 0]]; Mixed: 0."""
    out = np.zeros((6, 6))
    if repr_ == VelRepr.Body:
        out[:3, :3] = out[3:, 3:] = -R.T @ skew(v_mixed[3:])
    elif repr_ == VelRepr.Inertial:
        out[:3, 3:] = skew(v_mixed[:3])
    return out


class MujocoReference:
    """J and J̇ of points on MuJoCo bodies, Mixed in and out (warpdyn's Mixed ν), from one warpdyn state.

    MuJoCo's mj_jac/mj_jacDot at a world point p_F fixed to body b give jacp = d(p_F)/d(qvel) and jacr (the
    world angular velocity): the Mixed output at F. Its qvel differs from the Mixed ν in the free joint's
    angular part only, qvel = M ν with M = blockdiag(I_3, W_R_B^T, I_n), so
        J_MM = J_mj M,    J̇_MM = J̇_mj M + J_mj Ṁ,    Ṁ = blockdiag(0, -W_R_B^T ω^, 0),
    (d/dt W_R_B^T = -W_R_B^T ω^, ω the world angular velocity of the base).
    """

    def __init__(self, model, mj_model, state: dict):
        self.floating = model.floating_base()
        self.n = model.dofs()
        self.st = robots.MujocoState(mj_model, model.joint_names(), self.floating)
        self.p_B, self.q_B = state["base_position"], state["base_quaternion"]
        self.R_B = rotation_wxyz(self.q_B)
        self.v_B = np.concatenate([state["base_linear_velocity"], state["base_angular_velocity"]])
        self.st.set(self.p_B, self.q_B, state["joint_positions"], self.v_B, state["joint_velocities"])
        self.nu = np.concatenate([self.v_B, state["joint_velocities"]])

    def pose(self, link_name: str) -> tuple[np.ndarray, np.ndarray]:
        """(W_R_L, W_p_L) from MuJoCo; a fixed base, fused into MuJoCo's world, sits where it is welded."""
        if self.st.has_body(link_name):
            p, R = self.st.body_pose(link_name)
            return R, p
        return self.R_B, self.p_B

    def mixed(self, link_name: str, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(J_MM, J̇_MM), each (6, 6 + n), of the point fixed to the body (zeros for a body welded to the world)."""
        K = 6 + self.n
        if not self.st.has_body(link_name):
            return np.zeros((6, K)), np.zeros((6, K))
        m, d = self.st.m, self.st.d
        b = m.body(link_name).id
        jacp, jacr, dp, dr = (np.zeros((3, m.nv)) for _ in range(4))
        mujoco.mj_jac(m, d, jacp, jacr, np.asarray(point, dtype=np.float64), b)
        mujoco.mj_jacDot(m, d, dp, dr, np.asarray(point, dtype=np.float64), b)
        J_mj, Jd_mj = np.vstack([jacp, jacr]), np.vstack([dp, dr])
        J, Jd = np.zeros((6, K)), np.zeros((6, K))
        J[:, 6:], Jd[:, 6:] = J_mj[:, self.st.dof_adr], Jd_mj[:, self.st.dof_adr]
        if self.floating:
            Rt = self.R_B.T
            J[:, :3], Jd[:, :3] = J_mj[:, 0:3], Jd_mj[:, 0:3]
            J[:, 3:6] = J_mj[:, 3:6] @ Rt
            Jd[:, 3:6] = Jd_mj[:, 3:6] @ Rt - J_mj[:, 3:6] @ Rt @ skew(self.v_B[3:])
        return J, Jd

    def converted(self, J: np.ndarray, Jd: np.ndarray, R_F: np.ndarray, p_F: np.ndarray, X: VelRepr, Y: VelRepr):
        """J̇ with input X and output Y of the target F at (R_F, p_F), from its Mixed J and J̇:
        J_XY = P J Q with P = from_mixed(Y, F), Q = blockdiag(to_mixed(X, B), I_n), so
        J̇_XY = Ṗ J Q + P J̇ Q + P J Q̇, the rates from the Mixed velocities of F (J ν) and B."""
        v_F = J @ self.nu
        P, Pd = from_mixed(Y.name, R_F, p_F), _from_mixed_rate(Y, R_F, v_F)
        Q, Qd = np.eye(6 + self.n), np.zeros((6 + self.n, 6 + self.n))
        Q[:6, :6] = to_mixed(X.name, self.R_B, self.p_B)
        Qd[:6, :6] = _to_mixed_rate(X, self.R_B, self.v_B)
        return Pd @ J @ Q + P @ Jd @ Q + P @ J @ Qd


# ------------------------------------------------------------------------------------------------ tests


@pytest.mark.parametrize("name", MODELS)
def test_jacobian_derivatives_match_mujoco(name, dtype):
    """J̇ of every link and of up to 8 frames, 3 input x 3 output representations, vs MuJoCo's mj_jacDot.

    Reference: mj_jacDot at the target's origin on its (fused) MuJoCo body, converted to warpdyn's
    representations with the time derivatives of the conversions (MujocoReference). MuJoCo reads the state
    warpdyn stores (read back, so float32 rounding is in the reference as well). For a fixed base MuJoCo has
    no base columns: the joint columns are compared. Also checked: link.jacobian_derivative and
    frame.jacobian_derivative equal the batched results, and output_vel_repr=None is the data's representation.
    Tolerance relative to the largest entry (at least 1): float64 1e-10 (observed ~1e-15: only rounding of
    ~30 composed transforms differs; a wrong term is O(1)); float32 3e-5 (float32 epsilon times the same
    accumulation, lever arms of metres and products of two velocities: observed <= 1e-6).
    """
    model = _model(name, dtype)
    rng = _rng(name, 1)
    n, nL = model.dofs(), model.number_of_links()
    data = _data(model, _random_state(model, rng, 1))
    state = {key: getattr(data, f"{key}_state").numpy()[0].astype(np.float64) for key in
             ("base_position", "base_quaternion", "joint_positions", "joint_velocities")}
    v_B = data.base_velocity_state.numpy()[0].astype(np.float64)
    state.update(base_linear_velocity=v_B[:3], base_angular_velocity=v_B[3:])
    ref = MujocoReference(model, _mujoco(name), state)
    rows = _frame_targets(model, 8, rng)
    target_link, link_H_target, links, offsets = _targets(model, rows)

    names = model.link_names()
    mixed = []  # (R_F, p_F, J_MM, J̇_MM) per target, from MuJoCo's poses only
    for L, L_H_F in zip(links, offsets):
        R_L, p_L = ref.pose(names[L])
        R_F, p_F = R_L @ L_H_F[:3, :3], p_L + R_L @ L_H_F[:3, 3]
        mixed.append((R_F, p_F, *ref.mixed(names[L], p_F)))
    columns = slice(0, 6 + n) if model.floating_base() else slice(6, 6 + n)
    tol = 1e-10 if np.dtype(dtype) == np.float64 else 3e-5
    for X in REPRS:
        with data.switch_velocity_representation(X):
            for Y in REPRS:
                Jd = engine_derivatives.jacobian_derivatives(model, data, targets(model, target_link, link_H_target), Y).numpy()[0]
                assert Jd.shape == (len(links), 6, 6 + n)
                expected = np.array([ref.converted(J, Jdot, R_F, p_F, X, Y) for R_F, p_F, J, Jdot in mixed])
                scale = max(1.0, np.abs(expected).max(), np.abs(Jd).max())
                err = np.abs(Jd - expected)[..., columns].max(axis=(1, 2))
                worst = int(np.argmax(err))
                what = names[links[worst]] if worst < nL else f"frame {model.frame_names()[rows[worst - nL]]}"
                assert err[worst] <= tol * scale, (
                    f"J̇ of {what}, input {X.name}, output {Y.name}: error {err[worst]:.3e} > {tol:.0e} * {scale:.3g}"
                )
                # The public functions of one link / one frame are rows of the same computation.
                L = nL - 1
                np.testing.assert_array_equal(
                    wd.link.jacobian_derivative(model, data, link_index=L, output_vel_repr=Y).numpy()[0], Jd[L]
                )
                if rows:
                    got = wd.frame.jacobian_derivative(model, data, frame_index=nL + rows[0], output_vel_repr=Y)
                    np.testing.assert_array_equal(got.numpy()[0], Jd[nL])
            default = wd.model.generalized_free_floating_jacobian_derivative(model, data).numpy()
            explicit = wd.model.generalized_free_floating_jacobian_derivative(model, data, output_vel_repr=X)
            explicit = explicit.numpy()
            np.testing.assert_array_equal(default, explicit)


def _integrate(state: dict, t: float) -> dict:
    """The configuration at time t moving with the state's velocity, held constant in Mixed form:
    W_p_B(t) = W_p_B + t W_pdot_B, W_R_B(t) = exp(t omega^) W_R_B, s(t) = s + t sdot (exact, any t)."""
    p = state["base_position"] + t * state["base_linear_velocity"]
    w = state["base_angular_velocity"]
    angle = np.linalg.norm(w, axis=1, keepdims=True) * t
    axis = np.divide(w, np.linalg.norm(w, axis=1, keepdims=True), out=np.zeros_like(w), where=angle != 0)
    dq = np.concatenate([np.cos(angle / 2), np.sin(angle / 2) * axis], axis=1)
    q = np.array([robots.qmul(a, b) for a, b in zip(dq, state["base_quaternion"])])
    s = state["joint_positions"] + t * state["joint_velocities"]
    return {**state, "base_position": p, "base_quaternion": q, "joint_positions": s}


@pytest.mark.parametrize("name", MODELS)
def test_jacobian_derivatives_equal_finite_differences_along_the_motion(name, dtype):
    """J̇ (links and frames, 3 x 3 representations, N = 3 states) equals (J(t + h) − J(t − h)) / 2h.

    J(t) is warpdyn's Jacobian (float64) at the configuration reached moving with the state's velocity held
    constant in Mixed form (`_integrate`, exact for any step). J depends on the configuration only, and in a
    non-Inertial input representation the base columns change with the base pose: that is part of J̇. Any
    smooth motion with the state's velocity at t gives the same derivative. The representations of the
    perturbed data are those of the unperturbed one (the velocity stored there does not enter J).
    Tolerance relative to the largest entry: float64 1e-8 (step h = 1e-5: truncation h^2 |d3 J/dt3| ~1e-10,
    rounding 1e-16 |J| / h ~1e-11; observed <= 3e-10); float32 3e-5 (float32 rounding of J̇ against the float64
    reference: observed <= 1e-6).
    """
    model, model64 = _model(name, dtype), _model(name, np.float64)
    rng = _rng(name, 2)
    N, h = 3, 1e-5
    state = _random_state(model64, rng, N)
    rows = _frame_targets(model64, 6, rng)
    target_link, link_H_target, _, _ = _targets(model, rows)
    target_link64, link_H_target64, _, _ = _targets(model64, rows)
    moved = [_integrate(state, t) for t in (h, -h)]
    moved = _data(model64, {k: np.concatenate([m[k] for m in moved]) for k in state})
    data = _data(model, state)
    for X in REPRS:
        with data.switch_velocity_representation(X), moved.switch_velocity_representation(X):
            for Y in REPRS:
                J = engine_kinematics.jacobians(model64, moved, targets(model64, target_link64, link_H_target64), Y).numpy()
                fd = (J[:N] - J[N:]) / (2 * h)
                Jd = engine_derivatives.jacobian_derivatives(model, data, targets(model, target_link, link_H_target), Y).numpy()
                tol = _tol(dtype, fd, 1e-8, 3e-5)
                np.testing.assert_allclose(Jd, fd, rtol=0, atol=tol, err_msg=f"input {X.name}, output {Y.name}")


@pytest.mark.parametrize("name", MODELS)
def test_bias_accelerations_equal_jacobian_derivative_times_velocity(name, dtype):
    """J̇ν (bias_accelerations, link_bias_accelerations, link.bias_acceleration) equals J̇ @ ν, 3 x 3 reprs.

    Reference: the J̇ kernel (a sum over supporting joints) times the generalized velocity in the data's
    representation, on the host; the bias kernels walk the tree (forward recursion), an independent path.
    Tolerance relative to the largest entry: float64 1e-12, float32 3e-5 (the same ~(6 + n) products of
    velocities and lever arms, summed in different orders: observed <= 2e-15 and <= 7e-7).
    """
    model = _model(name, dtype)
    rng = _rng(name, 3)
    N = 3
    rows = _frame_targets(model, 6, rng)
    target_link, link_H_target, _, _ = _targets(model, rows)
    data = _data(model, _random_state(model, rng, N))
    nL = model.number_of_links()
    for X in REPRS:
        with data.switch_velocity_representation(X):
            nu = data.generalized_velocity.numpy()
            for Y in REPRS:
                Jd = engine_derivatives.jacobian_derivatives(model, data, targets(model, target_link, link_H_target), Y).numpy()
                a = engine_derivatives.bias_accelerations(model, data, targets(model, target_link, link_H_target), Y).numpy()
                expected = np.einsum("etrc,ec->etr", Jd, nu)
                assert a.shape == (N, nL + len(rows), 6)
                np.testing.assert_allclose(
                    a, expected, rtol=0, atol=_tol(dtype, expected, 1e-12, 3e-5),
                    err_msg=f"input {X.name}, output {Y.name}",
                )
                if Y == X:
                    links = wd.model.link_bias_accelerations(model, data).numpy()
                    np.testing.assert_array_equal(links, a[:, :nL])
                    one = wd.link.bias_acceleration(model, data, link_index=nL - 1).numpy()
                    np.testing.assert_array_equal(one, a[:, nL - 1])


def test_shapes_single_and_batched():
    """Single-environment data gives JaxSim's shapes; batched data a leading N, each environment equal to its
    own single-environment result (same kernel, same inputs: bit-identical); bad indices raise.

    Reference: the shapes of jaxsim.api (model.generalized_free_floating_jacobian_derivative (nL, 6, 6 + n),
    model.link_bias_accelerations (nL, 6), link.jacobian_derivative (6, 6 + n), link.bias_acceleration (6,),
    frame.jacobian_derivative (6, 6 + n)).
    """
    model = _model("tree3", np.float64)
    nL, n = model.number_of_links(), model.dofs()
    frame = nL
    state = _random_state(model, _rng("tree3", 4), 2)

    def outputs(data):
        return {
            "J̇": wd.model.generalized_free_floating_jacobian_derivative(model, data, output_vel_repr=VelRepr.Body),
            "J̇ν": wd.model.link_bias_accelerations(model, data),
            "link J̇": wd.link.jacobian_derivative(model, data, link_index=nL - 1),
            "link J̇ν": wd.link.bias_acceleration(model, data, link_index=nL - 1),
            "frame J̇": wd.frame.jacobian_derivative(model, data, frame_index=frame, output_vel_repr=VelRepr.Inertial),
        }

    shapes = {"J̇": (nL, 6, 6 + n), "J̇ν": (nL, 6), "link J̇": (6, 6 + n), "link J̇ν": (6,), "frame J̇": (6, 6 + n)}
    batched = outputs(_data(model, state))
    for env in range(2):
        one = {k: v[env] for k, v in state.items()}
        single = wd.data.Data.build(model, **one, velocity_representation=VelRepr.Mixed)
        for key, array in outputs(single).items():
            assert tuple(array.shape) == shapes[key], key
            assert tuple(batched[key].shape) == (2, *shapes[key]), key
            np.testing.assert_array_equal(array.numpy(), batched[key].numpy()[env], err_msg=key)
    data = _data(model, state)
    with pytest.raises(IndexError):
        wd.link.jacobian_derivative(model, data, link_index=nL)
    with pytest.raises(IndexError):
        wd.frame.jacobian_derivative(model, data, frame_index=0)


# ------------------------------------------------------------------------------------------ tape gradients


_STATE_ARRAYS = ("base_position", "base_quaternion", "joint_positions", "base_velocity", "joint_velocities")


@pytest.mark.parametrize("name", ("tree3", "fixed9"))
def test_tape_gradients_equal_finite_differences(name):
    """The wp.Tape gradient of Σ W ⊙ J̇ + Σ V ⊙ J̇ν (random weights, links and frames) w.r.t. every state array
    (base position, quaternion and Mixed velocity; joint positions and velocities) equals central finite
    differences, float64, for the 3 x 3 representations.

    Reference: central differences (step 1e-6) of the same float64 kernels, each perturbed state an environment
    of one batched launch (the quaternion is perturbed off unit norm, which the kernels read as given, so both
    sides differentiate the same function). Tolerance 1e-7 relative to the largest gradient entry: truncation
    ~h^2 |d3f| ~1e-11 and rounding ~1e-16 |f| / h ~1e-9 for |f| ~ 1e2.
    """
    model = _model(name, np.float64)
    rng = _rng(name, 5)
    rows = _frame_targets(model, 4, rng)
    target_link, link_H_target, _, _ = _targets(model, rows)
    base = _random_state(model, rng, 1)
    data = _data(model, base, requires_grad=True)
    host = {key: getattr(data, f"{key}_state").numpy().copy() for key in _STATE_ARRAYS}
    sizes = {key: host[key].shape[1] for key in _STATE_ARRAYS}
    K = sum(sizes.values())
    h = 1e-6
    # 2 K perturbed states: +h then -h for each entry of each state array.
    perturbed = {key: np.repeat(value, 2 * K, axis=0) for key, value in host.items()}
    k = 0
    for key in _STATE_ARRAYS:
        for i in range(sizes[key]):
            perturbed[key][2 * k, i] += h
            perturbed[key][2 * k + 1, i] -= h
            k += 1
    fd_data = wd.data.Data.build(model, **_random_state(model, rng, 2 * K), num_envs=2 * K, validate=False)
    for key in _STATE_ARRAYS:
        getattr(fd_data, f"{key}_state").assign(wp.array(perturbed[key], dtype=wp.float64))
    T = target_link.shape[0]
    for X in REPRS:
        for Y in REPRS:
            W = rng.normal(size=(T, 6, 6 + model.dofs()))
            V = rng.normal(size=(T, 6))
            data.velocity_representation = fd_data.velocity_representation = X
            for key in _STATE_ARRAYS:
                getattr(data, f"{key}_state").grad.zero_()
            tape = wp.Tape()
            with tape:
                Jd = engine_derivatives.jacobian_derivatives(model, data, targets(model, target_link, link_H_target), Y)
                a = engine_derivatives.bias_accelerations(model, data, targets(model, target_link, link_H_target), Y)
            tape.backward(grads={Jd: wp.array(W[None], dtype=wp.float64), a: wp.array(V[None], dtype=wp.float64)})
            gradient = np.concatenate([getattr(data, f"{key}_state").grad.numpy()[0] for key in _STATE_ARRAYS])
            tape.zero()
            Jd_fd = engine_derivatives.jacobian_derivatives(model, fd_data, targets(model, target_link, link_H_target), Y).numpy()
            a_fd = engine_derivatives.bias_accelerations(model, fd_data, targets(model, target_link, link_H_target), Y).numpy()
            f = np.einsum("etrc,trc->e", Jd_fd, W) + np.einsum("etr,tr->e", a_fd, V)
            fd = (f[0::2] - f[1::2]) / (2 * h)
            np.testing.assert_allclose(
                gradient, fd, rtol=0, atol=1e-7 * max(1.0, np.abs(fd).max()), err_msg=f"input {X.name}, output {Y.name}"
            )
