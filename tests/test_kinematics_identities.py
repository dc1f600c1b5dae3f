"""Kinematic identities: Jacobians against link velocities and against finite differences of FK.

Robots: random trees (robots.random_tree_urdf, floating and fixed base, revolute, prismatic, continuous
and lumped fixed joints), iCub's legs (icub-models) and the seed's ergoCub model (its leg joints). Each
identity runs in float64 (tight) and float32 (loose). The references are
- J·ν = v: the Jacobian kernel (a sum over the supporting joints) against the velocity kernel (a forward
  recursion over the tree), two independent code paths;
- central finite differences of forward kinematics, computed in float64 with all perturbations as the
  environments of one batched launch, converted between representations on the host with the 6x6
  transforms of Traversaro and Saccon (tests/robots.py: to_mixed / from_mixed);
- host-side conversions of the base velocity;
- the single-environment result of the same state (batched equals per environment).
"""

from __future__ import annotations

import functools

import numpy as np
import pytest

import robots
import warpdyn as wd
from warpdyn import VelRepr

REPRS = (VelRepr.Body, VelRepr.Mixed, VelRepr.Inertial)
MODELS = ("tree0", "tree3", "tree7", "fixed2", "fixed9", "icub_legs", "ergocub_seed")


@functools.cache
def _description(name: str) -> tuple[str, list[str] | None]:
    """(URDF text, considered joints) of a test robot."""
    if name.startswith("tree"):
        return robots.random_tree_urdf(int(name[4:])), None
    if name.startswith("fixed"):
        return robots.random_tree_urdf(int(name[5:]), fixed_base=True), None
    if name == "icub_legs":
        urdf = robots.icub_urdf()
        full = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        return urdf, robots.icub_leg_joints(full.joint_names())
    if name == "ergocub_seed":
        urdf = robots.ergocub_urdf()
        full = wd.model.Model.build_from_model_description(urdf, dtype=np.float64)
        return urdf, robots.seed_joints(full.joint_names())
    raise KeyError(name)


@functools.cache
def _model(name: str, dtype) -> wd.model.Model:
    urdf, considered = _description(name)
    return wd.model.Model.build_from_model_description(urdf, considered_joints=considered, dtype=dtype)


def _seed(name: str, salt: int) -> int:
    """A fixed seed per (robot, test): fresh states for every test, reproducible runs."""
    return MODELS.index(name) * 1000 + salt


def _scale_tol(dtype, reference: np.ndarray, f64: float, f32: float) -> float:
    """Absolute tolerance: f64 or f32 times the largest magnitude of the reference (at least 1)."""
    return (f64 if np.dtype(dtype) == np.float64 else f32) * max(1.0, float(np.max(np.abs(reference))))


def _vee(W: np.ndarray) -> np.ndarray:
    return 0.5 * np.array([W[..., 2, 1] - W[..., 1, 2], W[..., 0, 2] - W[..., 2, 0], W[..., 1, 0] - W[..., 0, 1]]).T


def _quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of quaternions (w, x, y, z)."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array(
        [
            w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
            w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
            w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
            w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
        ]
    )


def _frame_indices(model, count: int, rng) -> list[int]:
    """Up to `count` frame indices (all of them for small models), drawn with rng."""
    nF, nL = model.number_of_frames(), model.number_of_links()
    rows = np.arange(nF) if nF <= count else np.sort(rng.choice(nF, size=count, replace=False))
    return [nL + int(k) for k in rows]


def _random_state(model, rng, num_envs=None):
    """Host arrays of a random state: base pose (welded for a fixed base), joints, velocities."""
    N = 1 if num_envs is None else num_envs
    n = model.dofs()
    if model.floating_base():
        p = rng.uniform(-1.0, 1.0, size=(N, 3))
        q = rng.normal(size=(N, 4))
        q /= np.linalg.norm(q, axis=1, keepdims=True)
        lin, ang = rng.uniform(-1.0, 1.0, size=(N, 3)), rng.uniform(-1.0, 1.0, size=(N, 3))
    else:
        H = model.description.world_H_base
        p = np.tile(H[:3, 3], (N, 1))
        q = np.tile(wd.data._quaternion_wxyz(H[:3, :3]), (N, 1))
        lin, ang = np.zeros((N, 3)), np.zeros((N, 3))
    low, high = model.tree.position_limits.T
    s = rng.uniform(np.where(np.isfinite(low), low, -np.pi), np.where(np.isfinite(high), high, np.pi), size=(N, n))
    sdot = rng.uniform(-1.0, 1.0, size=(N, n))
    state = dict(base_position=p, base_quaternion=q, joint_positions=s, base_linear_velocity=lin,
                 base_angular_velocity=ang, joint_velocities=sdot)
    if num_envs is None:
        state = {k: v[0] for k, v in state.items()}
    return state


# --------------------------------------------------------------------------------------- J·ν = v


@pytest.mark.parametrize("name", MODELS)
def test_jacobian_times_generalized_velocity_equals_velocity(name, dtype):
    """J(in, out)·ν(in) equals the link and frame velocities in `out`, for all 3 x 3 representations.

    Reference: wd.link.velocity / wd.frame.velocity, computed by the forward velocity recursion, a code
    path independent of the Jacobian kernel (sum over supporting joints). Also checks that
    wd.link.jacobian and wd.frame.jacobian agree with the rows of generalized_free_floating_jacobian, and
    that switching the data's representation (switch_velocity_representation) gives the same results as
    data built in it. Tolerance: float64 1e-13 and float32 2e-5 relative to the largest velocity; both
    sides sum the same ~(6 + n) terms with lever arms up to a few metres, so only rounding differs
    (observed: ~1e-18 and ~4e-8 relative).
    """
    model = _model(name, dtype)
    rng = np.random.default_rng(_seed(name, 1))
    N = 3
    frames = _frame_indices(model, 6, rng)
    for in_repr in REPRS:
        data = wd.data.Data.build(model, **_random_state(model, rng, N), velocity_representation=in_repr, num_envs=N)
        nu = data.generalized_velocity.numpy()
        assert nu.shape == (N, 6 + model.dofs())
        for out_repr in REPRS:
            J = wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=out_repr).numpy()
            assert J.shape == (N, model.number_of_links(), 6, 6 + model.dofs())
            Jnu = np.einsum("elrc,ec->elr", J, nu)
            v = np.stack(
                [wd.link.velocity(model, data, link_index=L, output_vel_repr=out_repr).numpy()
                 for L in range(model.number_of_links())],
                axis=1,
            )
            tol = _scale_tol(dtype, v, 1e-13, 2e-5)
            np.testing.assert_allclose(Jnu, v, rtol=0, atol=tol, err_msg=f"links, in={in_repr.name} out={out_repr.name}")
            for L in (0, model.number_of_links() - 1):
                JL = wd.link.jacobian(model, data, link_index=L, output_vel_repr=out_repr).numpy()
                np.testing.assert_array_equal(JL, J[:, L], err_msg=f"link {L} Jacobian, {in_repr.name}->{out_repr.name}")
            for F in frames:
                JF = wd.frame.jacobian(model, data, frame_index=F, output_vel_repr=out_repr).numpy()
                vF = wd.frame.velocity(model, data, frame_index=F, output_vel_repr=out_repr).numpy()
                assert JF.shape == (N, 6, 6 + model.dofs()) and vF.shape == (N, 6)
                np.testing.assert_allclose(
                    np.einsum("erc,ec->er", JF, nu), vF, rtol=0, atol=tol,
                    err_msg=f"frame {F}, in={in_repr.name} out={out_repr.name}",
                )
        # The output representation defaults to the data's; a switched data reads the same state.
        for other in REPRS:
            with data.switch_velocity_representation(other):
                J_default = wd.model.generalized_free_floating_jacobian(model, data).numpy()
                J_explicit = wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=other).numpy()
                v_default = wd.link.velocity(model, data, link_index=model.number_of_links() - 1).numpy()
                nu_other = data.generalized_velocity.numpy()
            np.testing.assert_array_equal(J_default, J_explicit)
            Jnu = np.einsum("erc,ec->er", J_default[:, -1], nu_other)
            np.testing.assert_allclose(Jnu, v_default, rtol=0, atol=_scale_tol(dtype, v_default, 1e-13, 2e-5))


# ------------------------------------------------------------------------------- FK finite differences


def _fd_jacobians_mixed(model64, state, frames, h=1e-6):
    """Central differences of FK: (T, 6, 6 + n) Mixed-input, Mixed-output Jacobians of all links, then frames.

    Column c < 3 moves the base position along world axis c; 3 <= c < 6 rotates the base about world
    axis c - 3 (q <- exp(±h/2 e) ⊗ q), i.e. W_omega_WB = e with W_pdot_B = 0; c >= 6 moves joint c - 6.
    All 2 (6 + n) perturbed states run as the environments of one batched launch. Returns also the
    unperturbed poses (T, 4, 4).
    """
    n = model64.dofs()
    K = 6 + n
    p0, q0, s0 = state["base_position"], state["base_quaternion"], state["joint_positions"]
    P, Q, S = np.tile(p0, (2 * K + 1, 1)), np.tile(q0, (2 * K + 1, 1)), np.tile(s0, (2 * K + 1, 1))
    for c in range(K):
        for k, sign in ((2 * c, 1.0), (2 * c + 1, -1.0)):
            if c < 3:
                P[k, c] += sign * h
            elif c < 6:
                half = 0.5 * sign * h
                Q[k] = _quat_mul(np.concatenate([[np.cos(half)], np.sin(half) * np.eye(3)[c - 3]]), q0)
            else:
                S[k, c - 6] += sign * h
    data = wd.data.Data.build(model64, base_position=P, base_quaternion=Q, joint_positions=S, num_envs=2 * K + 1)
    H_links = wd.model.forward_kinematics(model64, data).numpy()  # (2K + 1, nL, 4, 4)
    tree = model64.tree
    H_frames = np.einsum("elij,ljk->elik", H_links[:, tree.frame_parent[np.array(frames, dtype=int) - tree.number_of_links]],
                         tree.link_H_frame[np.array(frames, dtype=int) - tree.number_of_links]) if frames else H_links[:, :0]
    H = np.concatenate([H_links, H_frames], axis=1)
    plus, minus, H0 = H[0:2 * K:2], H[1:2 * K:2], H[2 * K]  # (K, T, 4, 4)
    dH = (plus - minus) / (2.0 * h)
    lin = dH[:, :, :3, 3]  # (K, T, 3)
    ang = _vee(np.einsum("ctij,tmj->ctim", dH[:, :, :3, :3], H0[:, :3, :3]).reshape(-1, 3, 3)).reshape(K, -1, 3)
    J = np.concatenate([lin, ang], axis=2).transpose(1, 2, 0)  # (T, 6, K)
    return J, H0


@pytest.mark.parametrize("name", MODELS)
def test_jacobian_columns_equal_finite_differences_of_fk(name, dtype):
    """Every Jacobian column (links and frames, 3 input x 3 output representations) equals FD of FK.

    Reference: central differences (step 1e-6) of wd.model.forward_kinematics in float64 w.r.t. each joint
    position, the base position and small world-frame rotations of the base quaternion, giving the
    Mixed/Mixed Jacobian (linear rows d W_p_L/ds, angular rows vee(dR/ds R^T)); the other representations
    follow on the host: from_mixed(out, W_H_F) · J · blockdiag(to_mixed(in, W_H_B), I). FK itself is checked
    against MuJoCo elsewhere. Tolerance: float64 1e-8 relative to the largest entry (FD truncation
    ~h^2·|d3 FK| ~1e-11, rounding ~1e-16·|p|/h ~1e-9; observed ≤ 6e-10); float32 1e-5 relative (float32
    rounding accumulated along chains of up to ~20 links; observed ≤ 4e-7).
    """
    model, model64 = _model(name, dtype), _model(name, np.float64)
    rng = np.random.default_rng(_seed(name, 2))
    state = _random_state(model64, rng)
    frames = _frame_indices(model64, 8, rng)
    J_fd, H0 = _fd_jacobians_mixed(model64, state, frames)
    n, nL = model.dofs(), model.number_of_links()
    R_B, p_B = H0[0, :3, :3], H0[0, :3, 3]
    for in_repr in REPRS:
        data = wd.data.Data.build(model, **state, velocity_representation=in_repr)
        T_in = np.eye(6 + n)
        T_in[:6, :6] = robots.to_mixed(in_repr.name, R_B, p_B)
        for out_repr in REPRS:
            J_links = wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=out_repr).numpy()
            J_frames = [wd.frame.jacobian(model, data, frame_index=F, output_vel_repr=out_repr).numpy() for F in frames]
            J = np.concatenate([J_links, np.array(J_frames).reshape(len(frames), 6, 6 + n)], axis=0)
            ref = np.array(
                [robots.from_mixed(out_repr.name, H[:3, :3], H[:3, 3]) @ Jt @ T_in for H, Jt in zip(H0, J_fd)]
            )
            tol = _scale_tol(dtype, ref, 1e-8, 1e-5)
            for t in range(len(ref)):
                what = f"link {t}" if t < nL else f"frame {frames[t - nL]}"
                np.testing.assert_allclose(
                    J[t], ref[t], rtol=0, atol=tol, err_msg=f"{what}, in={in_repr.name} out={out_repr.name}"
                )


@pytest.mark.parametrize("name", ("tree3", "icub_legs"))
def test_frame_pose_is_parent_link_pose_times_fixed_offset(name, dtype):
    """wd.frame.transform equals wd.link.transform of its parent link times the lumped offset.

    Reference: the host composition W_H_L @ L_H_F with L_H_F from the lumping (model.tree.link_H_frame)
    and the parent from wd.frame.idx_of_parent_link. Tolerance: float64 1e-13, float32 2e-6 relative to
    the largest entry (one extra product of transforms after FK; observed ~1e-15 and ~5e-7).
    """
    model = _model(name, dtype)
    rng = np.random.default_rng(_seed(name, 3))
    data = wd.data.Data.build(model, **_random_state(model, rng, 2), num_envs=2)
    W_H_L = wd.model.forward_kinematics(model, data).numpy()
    for F in _frame_indices(model, 10, rng):
        L = wd.frame.idx_of_parent_link(model, frame_index=F)
        ref = W_H_L[:, L] @ model.tree.link_H_frame[F - model.number_of_links()]
        got = wd.frame.transform(model, data, frame_index=F).numpy()
        np.testing.assert_allclose(got, ref, rtol=0, atol=_scale_tol(dtype, ref, 1e-13, 2e-6), err_msg=f"frame {F}")
        np.testing.assert_allclose(
            wd.link.transform(model, data, link_index=L).numpy(), W_H_L[:, L], rtol=0, atol=0, err_msg=f"link {L}"
        )


# ------------------------------------------------------------------------------ data properties


@pytest.mark.parametrize("name", ("tree0", "tree7", "icub_legs", "ergocub_seed"))
def test_base_velocity_round_trips_through_every_representation(name, dtype):
    """A base velocity given in one representation reads back in it, and converts like the 6x6 transforms.

    Reference: the input itself (round trip), and on the host robots.to_mixed / from_mixed with the base
    pose, for the stored Mixed state and for every representation read through
    switch_velocity_representation; generalized_velocity must be [base_velocity; joint_velocities].
    Tolerance: float64 1e-13, float32 1e-6 relative to the largest value plus the lever arm |p| ≤ √3
    (two conversions, each one cross product and a rotation).
    """
    model = _model(name, dtype)
    rng = np.random.default_rng(_seed(name, 4))
    N = 4
    for given in REPRS:
        state = _random_state(model, rng, N)
        data = wd.data.Data.build(model, **state, velocity_representation=given, num_envs=N)
        v_given = np.concatenate([state["base_linear_velocity"], state["base_angular_velocity"]], axis=1)
        tol = _scale_tol(dtype, v_given, 1e-13, 1e-6) * 3.0
        np.testing.assert_allclose(data.base_velocity.numpy(), v_given, rtol=0, atol=tol)
        R = np.array([robots.rotation_wxyz(q) for q in state["base_quaternion"]])
        p = state["base_position"]
        mixed = np.einsum("eij,ej->ei", np.array([robots.to_mixed(given.name, R[e], p[e]) for e in range(N)]), v_given)
        np.testing.assert_allclose(data.base_velocity_state.numpy(), mixed, rtol=0, atol=tol)
        for read in REPRS:
            ref = np.einsum("eij,ej->ei", np.array([robots.from_mixed(read.name, R[e], p[e]) for e in range(N)]), mixed)
            with data.switch_velocity_representation(read):
                base = data.base_velocity.numpy()
                nu = data.generalized_velocity.numpy()
            np.testing.assert_allclose(base, ref, rtol=0, atol=tol, err_msg=f"{given.name} -> {read.name}")
            np.testing.assert_array_equal(nu[:, :6], base)
            np.testing.assert_array_equal(nu[:, 6:], data.joint_velocities.numpy())
            # Built in `read` from the converted velocity, the data holds the same Mixed state.
            again = wd.data.Data.build(
                model, **{**state, "base_linear_velocity": ref[:, :3], "base_angular_velocity": ref[:, 3:]},
                velocity_representation=read, num_envs=N,
            )
            np.testing.assert_allclose(again.base_velocity_state.numpy(), mixed, rtol=0, atol=tol)
        assert data.velocity_representation == given


@pytest.mark.parametrize("name", ("fixed2", "fixed9"))
def test_fixed_base_generalized_velocity_has_zero_base(name, dtype):
    """A fixed-base model's ν is [0_6; sdot] in every representation, at the welded base pose.

    Reference: exact zeros and the joint velocities given (copied, no arithmetic), so the comparison is
    exact in both dtypes up to the representation conversion of zero (exactly zero).
    """
    model = _model(name, dtype)
    rng = np.random.default_rng(_seed(name, 5))
    state = _random_state(model, rng, 2)
    for repr_ in REPRS:
        data = wd.data.Data.build(model, **state, velocity_representation=repr_, num_envs=2)
        nu = data.generalized_velocity.numpy()
        np.testing.assert_array_equal(nu[:, :6], 0.0)
        np.testing.assert_array_equal(nu[:, 6:], state["joint_velocities"].astype(model.dtype))


# ------------------------------------------------------------------------- batched vs single environment


def _outputs(model, data, frame):
    """Every kinematic output of the façade for `data`, by name."""
    last = model.number_of_links() - 1
    return {
        "forward_kinematics": wd.model.forward_kinematics(model, data),
        "relative_link_transforms": wd.model.relative_link_transforms(model, data),
        "generalized_free_floating_jacobian": wd.model.generalized_free_floating_jacobian(model, data),
        "jacobian_body_output": wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=VelRepr.Body),
        "link.transform": wd.link.transform(model, data, link_index=last),
        "link.velocity": wd.link.velocity(model, data, link_index=last),
        "link.jacobian": wd.link.jacobian(model, data, link_index=last, output_vel_repr=VelRepr.Inertial),
        "frame.transform": wd.frame.transform(model, data, frame_index=frame),
        "frame.velocity": wd.frame.velocity(model, data, frame_index=frame, output_vel_repr=VelRepr.Body),
        "frame.jacobian": wd.frame.jacobian(model, data, frame_index=frame),
        "base_transform": data.base_transform,
        "base_orientation": data.base_orientation,
        "base_velocity": data.base_velocity,
        "base_position": data.base_position,
        "base_quaternion": data.base_quaternion,
        "joint_positions": data.joint_positions,
        "joint_velocities": data.joint_velocities,
        "generalized_velocity": data.generalized_velocity,
    }


def _single_shapes(model) -> dict:
    """JaxSim's shapes of single-environment results."""
    nL, n = model.number_of_links(), model.dofs()
    return {
        "forward_kinematics": (nL, 4, 4),
        "relative_link_transforms": (n, 4, 4),
        "generalized_free_floating_jacobian": (nL, 6, 6 + n),
        "jacobian_body_output": (nL, 6, 6 + n),
        "link.transform": (4, 4),
        "link.velocity": (6,),
        "link.jacobian": (6, 6 + n),
        "frame.transform": (4, 4),
        "frame.velocity": (6,),
        "frame.jacobian": (6, 6 + n),
        "base_transform": (4, 4),
        "base_orientation": (4,),
        "base_velocity": (6,),
        "base_position": (3,),
        "base_quaternion": (4,),
        "joint_positions": (n,),
        "joint_velocities": (n,),
        "generalized_velocity": (6 + n,),
    }


@pytest.mark.parametrize("name", ("tree3", "fixed2", "icub_legs"))
@pytest.mark.parametrize("repr_", REPRS, ids=lambda r: r.name)
def test_batched_results_equal_single_environment_results(name, repr_, dtype, layout):
    """Batched data (N = 4) gives, in each environment, what single-environment data of that state gives.

    Reference: the same façade call on num_envs=None data built from that environment's host state
    (same inputs, same kernel, one thread per environment), so the results must be bit-identical.
    Also checks shapes: a single environment returns JaxSim's shapes, batched data a leading N, and
    num_envs=1 a leading 1.
    """
    model = _model(name, dtype)
    rng = np.random.default_rng(_seed(name, 6) + int(repr_))
    N = 4
    frame = _frame_indices(model, 1, rng)[0]
    state = _random_state(model, rng, N)
    batched = _outputs(model, wd.data.Data.build(model, **state, velocity_representation=repr_, num_envs=N), frame)
    shapes = _single_shapes(model)
    for key, array in batched.items():
        assert tuple(array.shape) == (N, *shapes[key]), key
        assert array.dtype == model.scalar, key
    for env in range(N):
        one = {k: v[env] for k, v in state.items()}
        single = _outputs(model, wd.data.Data.build(model, **one, velocity_representation=repr_), frame)
        for key, array in single.items():
            assert tuple(array.shape) == shapes[key], key
            np.testing.assert_array_equal(array.numpy(), batched[key].numpy()[env], err_msg=f"{key}, env {env}")
    one_env = _outputs(model, wd.data.Data.build(model, **{k: v[:1] for k, v in state.items()},
                                                  velocity_representation=repr_, num_envs=1), frame)
    for key, array in one_env.items():
        assert tuple(array.shape) == (1, *shapes[key]), key
        np.testing.assert_array_equal(array.numpy()[0], batched[key].numpy()[0], err_msg=f"{key}, num_envs=1")


@pytest.mark.parametrize("name", ("tree0", "ergocub_seed"))
def test_float32_and_float64_agree(name):
    """The float32 model computes what the float64 one does, to float32 accuracy.

    Reference: the float64 model on the same state. Tolerance 1e-5 relative to the largest entry:
    float32's 6e-8 unit rounding accumulated along chains of up to ~20 transforms (observed ~1e-6).
    """
    m32, m64 = _model(name, np.float32), _model(name, np.float64)
    rng = np.random.default_rng(_seed(name, 7))
    state = _random_state(m64, rng, 3)
    frame = _frame_indices(m64, 1, rng)[0]
    for repr_ in REPRS:
        out32 = _outputs(m32, wd.data.Data.build(m32, **state, velocity_representation=repr_, num_envs=3), frame)
        out64 = _outputs(m64, wd.data.Data.build(m64, **state, velocity_representation=repr_, num_envs=3), frame)
        for key in out64:
            ref = out64[key].numpy()
            np.testing.assert_allclose(out32[key].numpy(), ref, rtol=0, atol=1e-5 * max(1.0, np.abs(ref).max()),
                                       err_msg=f"{key}, {repr_.name}")


def test_single_rigid_body_without_joints(dtype):
    """A model of one free-floating body (no joints): every kinematic call works and has the right shapes.

    Reference: with no joints, the base link's Jacobian maps the base velocity to itself (identity in
    matching input and output representations), its velocity is the base velocity, ν is the base velocity,
    and relative_link_transforms is empty, (0, 4, 4) or (N, 0, 4, 4). Tolerance: float64 1e-14, float32 1e-6
    (a representation round trip of the base velocity).
    """
    model = wd.model.Model.build_from_model_description(robots.random_tree_urdf(1, num_links=1), dtype=dtype)
    assert model.dofs() == 0 and model.number_of_links() == 1
    rng = np.random.default_rng(_seed("tree0", 9))
    tol = 1e-14 if np.dtype(dtype) == np.float64 else 1e-6
    for num_envs in (None, 2):
        lead = () if num_envs is None else (num_envs,)
        for repr_ in REPRS:
            data = wd.data.Data.build(model, **_random_state(model, rng, num_envs), velocity_representation=repr_,
                                      num_envs=num_envs)
            assert tuple(wd.model.forward_kinematics(model, data).shape) == (*lead, 1, 4, 4)
            J = wd.model.generalized_free_floating_jacobian(model, data).numpy()
            assert J.shape == (*lead, 1, 6, 6)
            np.testing.assert_allclose(J[..., 0, :, :], np.broadcast_to(np.eye(6), (*lead, 6, 6)), rtol=0, atol=tol)
            v = wd.link.velocity(model, data, link_index=0).numpy()
            np.testing.assert_allclose(v, data.base_velocity.numpy(), rtol=0, atol=tol)
            np.testing.assert_array_equal(data.generalized_velocity.numpy(), data.base_velocity.numpy())
            assert tuple(wd.model.relative_link_transforms(model, data).shape) == (*lead, 0, 4, 4)
