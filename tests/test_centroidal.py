"""Centroidal quantities, momentum and energy (warpdyn.com, the model-level functions of
warpdyn._centroidal, link.spatial_inertia and link.com_position), in every velocity representation.

References:
- C MuJoCo (float64) on the same URDF (robots.mujoco_model, floating base, joints mapped by name):
  d.subtree_com[root] (the CoM); mj_subtreeVel's subtree_linvel[root] (the CoM velocity) and
  subtree_angmom[root] (the angular momentum about the CoM, world axes); d.energy[1] = 1/2 qvel^T M qvel
  (mj_energyVel, mjENBL_ENERGY) and d.energy[0] = -Σ_b m_b gravity·x_b = m 9.81 z_CoM (MuJoCo's gravity
  is (0, 0, -9.81): potential energy grows with height, as warpdyn's). The locked inertia about the CoM is
  summed in NumPy from MuJoCo's bodies (body_mass, body_inertia, ximat, xipos).
- NumPy sums over links, from warpdyn's link poses and body-output link Jacobians (both tested against
  MuJoCo in test_kinematics_mujoco) and from the tree's inertial constants: J_h = Σ_L O_X*_L L_M_L L_J_WL,
  K = 1/2 Σ_L L_v^T L_M_L L_v, L_M_L = [[m 1, -m c^], [m c^, I_c - m c^ c^]]. These check every column of
  the Jacobians, which the composite-inertia kernel builds without summing over links.
- Central finite differences (float64): tape gradients, and the CoM bias acceleration as the time
  derivative of the CoM velocity along the motion at constant ν in the data's representation.
Representation changes are independent NumPy transforms from the reference's poses: a momentum in frame F
is F_X*_G G[W]_h, an inertia F_X*_G G[W]_M G_X_F, an average velocity F_X_G G[W]_M^-1 G[W]_h, with F = W, B,
B[W] (Inertial, Body, Mixed data) or G[W], G[B] (centroidal, for Inertial/Mixed or Body data).

Tolerances are relative to the size of what is compared (its largest entry, at least 1). float64: 1e-10
(sums over up to 30 links of products of composed poses, inertias and velocities: observed <= 1e-14, so
1e-10 leaves room without hiding a wrong formula, whose errors are O(1)); float32: 1e-4 (epsilon 1.2e-7
amplified by the composed transforms and by inertias about frames metres from the CoM: observed <= 1e-5).
"""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest
import warp as wp
from scipy.linalg import expm
from scipy.spatial.transform import Rotation

import robots
import warpdyn as wd
from robots import motion_transform, rng_for, rotation_wxyz, skew, uniform_state_kwargs
from warpdyn import model as cm

REPRS = (wd.VelRepr.Body, wd.VelRepr.Mixed, wd.VelRepr.Inertial)
TOL = {np.dtype(np.float64): 1e-10, np.dtype(np.float32): 1e-4}
MUJOCO_CASES = [f"random-{s}" for s in range(6)] + ["icublegs", "ergocub"]
CASES = MUJOCO_CASES + ["randomfixed-100"]


# ------------------------------------------------------------------------------------ robots


@functools.cache
def source(case: str):
    kind, _, arg = case.partition("-")
    if kind == "small":
        return robots.random_tree_urdf(int(arg), num_links=7), None
    return robots.case_source(case)


@functools.cache
def build_model(case: str, dtype):
    text, considered = source(case)
    model = wd.model.Model.build_from_model_description(text, dtype=dtype)
    return wd.model.reduce(model, considered) if considered is not None else model


@functools.cache
def build_mujoco(case: str):
    text, considered = source(case)
    mj = robots.mujoco_model(text, considered, floating=True)
    mj.opt.enableflags |= mujoco.mjtEnableBit.mjENBL_ENERGY
    return mj


def make_data(case, dtype, test, repr=wd.VelRepr.Mixed, num_envs=None, requires_grad=False):
    model = build_model(case, dtype)
    kwargs = uniform_state_kwargs(model, rng_for(case, test, np.dtype(dtype).name, int(repr)), num_envs)
    data = wd.data.Data.build(
        model, **kwargs, velocity_representation=repr, num_envs=num_envs, requires_grad=requires_grad
    )
    return model, data, kwargs


def host(a) -> np.ndarray:
    """A float64 copy (on the CPU, .numpy() is a view of the device memory)."""
    return np.array(a.numpy(), dtype=np.float64)


def assert_close(actual, expected, tol, what):
    """max |actual - expected| <= tol * max(1, |expected|_max)."""
    actual, expected = np.asarray(actual, dtype=np.float64), np.asarray(expected, dtype=np.float64)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    assert np.all(np.isfinite(actual)), f"{what}: non-finite entries\n{actual}"
    scale = max(1.0, np.abs(expected).max(initial=0.0))
    err = np.abs(actual - expected).max(initial=0.0)
    assert err <= tol * scale, f"{what}: max error {err:.3e} > {tol:.0e} * {scale:.3g}\nactual\n{actual}\nexpected\n{expected}"


# ------------------------------------------------------------------------------------ NumPy frames


def force_transform(R, p) -> np.ndarray:
    """A_X*_B (6, 6) for A_H_B = (R, p): [[R, 0], [p^ R, R]]."""
    return np.linalg.inv(motion_transform(R, p)).T


REPR_FRAME = {wd.VelRepr.Body: "B", wd.VelRepr.Mixed: "BW", wd.VelRepr.Inertial: "W"}


def centroidal_frame(repr) -> str:
    return "GB" if repr == wd.VelRepr.Body else "GW"


def frame_pose(frame, R_B, p_B, p_G):
    """(W_R_F, W_p_F) of the frames B, B[W], W, G[W], G[B]."""
    return {
        "B": (R_B, p_B),
        "BW": (np.eye(3), p_B),
        "W": (np.eye(3), np.zeros(3)),
        "GW": (np.eye(3), p_G),
        "GB": (R_B, p_G),
    }[frame]


class Centroidal:
    """A reference's totals about the CoM, world axes, and their expressions in any frame."""

    def __init__(self, mass, p_G, I_G, h_G, R_B, p_B, K=None, U=None):
        self.mass, self.p_G, self.I_G, self.h_G, self.R_B, self.p_B, self.K, self.U = mass, p_G, I_G, h_G, R_B, p_B, K, U
        self.M_G = np.zeros((6, 6))
        self.M_G[:3, :3] = mass * np.eye(3)
        self.M_G[3:, 3:] = I_G

    def X(self, frame) -> np.ndarray:
        """F_X_G[W], motion."""
        R, p = frame_pose(frame, self.R_B, self.p_B, self.p_G)
        return np.linalg.inv(motion_transform(R, p)) @ motion_transform(np.eye(3), self.p_G)

    def Xf(self, frame) -> np.ndarray:
        """F_X*_G[W], force."""
        return np.linalg.inv(self.X(frame)).T

    def momentum(self, frame):
        return self.Xf(frame) @ self.h_G

    def inertia(self, frame):
        return self.Xf(frame) @ self.M_G @ np.linalg.inv(self.X(frame))

    def average_velocity(self, frame):
        return self.X(frame) @ np.linalg.solve(self.M_G, self.h_G)


def mujoco_reference(case, model, data) -> Centroidal:
    """MuJoCo's totals for warpdyn's stored state (single environment, read back in its dtype)."""
    mj = build_mujoco(case)
    st = robots.MujocoState(mj, model.joint_names(), True)
    st.set(
        host(data.base_position),
        host(data.base_quaternion),
        host(data.joint_positions),
        host(data.base_velocity_state)[0],
        host(data.joint_velocities),
    )
    m, d = st.m, st.d
    mujoco.mj_subtreeVel(m, d)
    root = 1
    mass = float(m.body_subtreemass[root])
    p_G = d.subtree_com[root].copy()
    I_G = np.zeros((3, 3))
    for b in range(1, m.nbody):
        R = d.ximat[b].reshape(3, 3)
        r = d.xipos[b] - p_G
        I_G += R @ np.diag(m.body_inertia[b]) @ R.T + m.body_mass[b] * (r @ r * np.eye(3) - np.outer(r, r))
    h_G = np.concatenate([mass * d.subtree_linvel[root], d.subtree_angmom[root]])
    return Centroidal(mass, p_G, I_G, h_G, d.xmat[root].reshape(3, 3).copy(), d.xpos[root].copy(), d.energy[1], d.energy[0])


def link_inertias(model) -> np.ndarray:
    """L_M_L (nL, 6, 6) from the tree's constants (float64)."""
    t = model.tree
    out = np.zeros((t.number_of_links, 6, 6))
    for i in range(t.number_of_links):
        m, c, I = t.link_mass[i], np.asarray(t.link_com[i]), np.asarray(t.link_inertia[i])
        out[i, :3, :3] = m * np.eye(3)
        out[i, :3, 3:] = -m * skew(c)
        out[i, 3:, :3] = m * skew(c)
        out[i, 3:, 3:] = I - m * skew(c) @ skew(c)
    return out


class LinkSums:
    """NumPy sums over links from warpdyn's link poses and body-output link Jacobians (one environment)."""

    def __init__(self, model, data):
        self.H = host(wd.model.forward_kinematics(model, data))
        self.J = host(wd.model.generalized_free_floating_jacobian(model, data, output_vel_repr=wd.VelRepr.Body))
        self.nu = host(data.generalized_velocity)
        self.M = link_inertias(model)
        t = model.tree
        self.mass = float(np.sum(t.link_mass))
        coms = np.einsum("lij,lj->li", self.H[:, :3, :3], np.asarray(t.link_com)) + self.H[:, :3, 3]
        self.p_G = np.einsum("l,li->i", t.link_mass, coms) / self.mass
        # W_J_h = Σ_L W_X*_L L_M_L L_J_WL, then the locked inertia W_M = Σ_L W_X*_L L_M_L L_X_W.
        self.W_Jh = sum(force_transform(H[:3, :3], H[:3, 3]) @ M @ J for H, M, J in zip(self.H, self.M, self.J))
        self.W_M = sum(
            force_transform(H[:3, :3], H[:3, 3]) @ M @ np.linalg.inv(motion_transform(H[:3, :3], H[:3, 3]))
            for H, M in zip(self.H, self.M)
        )
        self.R_B, self.p_B = self.H[0, :3, :3], self.H[0, :3, 3]
        self.K = 0.5 * sum(v @ M @ v for v, M in zip(self.J @ self.nu, self.M))

    def F_Xf_W(self, frame):
        R, p = frame_pose(frame, self.R_B, self.p_B, self.p_G)
        return motion_transform(R, p).T

    def W_X_F(self, frame):
        R, p = frame_pose(frame, self.R_B, self.p_B, self.p_G)
        return motion_transform(R, p)

    def momentum_jacobian(self, frame):
        return self.F_Xf_W(frame) @ self.W_Jh

    def locked_inertia(self, frame):
        return self.F_Xf_W(frame) @ self.W_M @ self.W_X_F(frame)

    def average_velocity_jacobian(self, frame):
        return np.linalg.solve(self.locked_inertia(frame), self.momentum_jacobian(frame))


# ------------------------------------------------------------------------------------ MuJoCo


@pytest.mark.parametrize("case", MUJOCO_CASES)
def test_against_mujoco(case, dtype):
    """CoM, momenta, locked inertias, average velocities and energies vs MuJoCo, in every representation.

    Reference: MuJoCo's subtree_com, mj_subtreeVel (subtree_linvel, subtree_angmom), energy[0:2], and its
    bodies' inertias summed about the CoM (module docstring), moved to each frame by NumPy transforms.
    Tolerance: module docstring (1e-9 float64, 5e-4 float32, relative)."""
    model = build_model(case, dtype)
    tol = TOL[np.dtype(dtype)]
    _, data, _ = make_data(case, dtype, "mujoco")
    ref = mujoco_reference(case, model, data)
    # total_mass sums the model's masses, stored in its dtype (float32: each rounded by up to 6e-8 relative)
    assert wd.model.total_mass(model) == pytest.approx(ref.mass, rel=1e-12 if np.dtype(dtype) == np.float64 else 1e-7)
    for X in REPRS:
        with data.switch_velocity_representation(X):
            F, G = REPR_FRAME[X], centroidal_frame(X)
            assert_close(host(wd.com.com_position(model, data)), ref.p_G, tol, f"com_position [{X.name}]")
            assert_close(host(cm.total_momentum(model, data)), ref.momentum(F), tol, f"total_momentum [{X.name}]")
            assert_close(host(wd.com.centroidal_momentum(model, data)), ref.momentum(G), tol, f"centroidal_momentum [{X.name}]")
            assert_close(host(cm.locked_spatial_inertia(model, data)), ref.inertia(F), tol, f"locked_spatial_inertia [{X.name}]")
            assert_close(
                host(wd.com.locked_centroidal_spatial_inertia(model, data)), ref.inertia(G), tol, f"locked centroidal [{X.name}]"
            )
            assert_close(host(cm.average_velocity(model, data)), ref.average_velocity(F), tol, f"average_velocity [{X.name}]")
            assert_close(
                host(wd.com.average_centroidal_velocity(model, data)), ref.average_velocity(G), tol, f"avg centroidal [{X.name}]"
            )
            assert_close(
                host(wd.com.com_linear_velocity(model, data)), ref.average_velocity(G)[:3], tol, f"com_linear_velocity [{X.name}]"
            )
            K = host(cm.kinetic_energy(model, data))
            U = host(cm.potential_energy(model, data))
            E = host(cm.mechanical_energy(model, data))
            assert K.shape == U.shape == E.shape == (1,)
            assert_close(K, [ref.K], tol, f"kinetic_energy [{X.name}]")
            assert_close(U, [ref.U], tol, f"potential_energy [{X.name}]")
            assert_close(E, [ref.K + ref.U], tol, f"mechanical_energy [{X.name}]")
    # The CoM velocity in G[W] is MuJoCo's subtree_linvel itself.
    with data.switch_velocity_representation(wd.VelRepr.Mixed):
        assert_close(host(wd.com.com_linear_velocity(model, data)), ref.h_G[:3] / ref.mass, tol, "com_linear_velocity vs linvel")


# ------------------------------------------------------------------------------------ NumPy sums and identities


@pytest.mark.parametrize("case", CASES)
def test_jacobians_against_link_sums(case, dtype):
    """Every (input, output) representation pair of the momentum and average-velocity Jacobians, and the
    centroidal ones, vs NumPy sums over links (J_h = Σ_L O_X*_L L_M_L L_J_WL; J_avg = O_M^-1 O_J_h),
    and the kinetic energy vs 1/2 Σ_L L_v^T L_M_L L_v.

    Reference: NumPy from warpdyn's link poses and body-output link Jacobians (MuJoCo-tested elsewhere)
    and the tree's constants. Tolerance: module docstring."""
    model = build_model(case, dtype)
    tol = TOL[np.dtype(dtype)]
    _, data, _ = make_data(case, dtype, "link sums")
    for X in REPRS:
        with data.switch_velocity_representation(X):
            ref = LinkSums(model, data)
            G = centroidal_frame(X)
            for O in REPRS:
                F = REPR_FRAME[O]
                Jh = host(cm.total_momentum_jacobian(model, data, output_vel_repr=O))
                assert_close(Jh, ref.momentum_jacobian(F), tol, f"total_momentum_jacobian [{X.name} -> {O.name}]")
                Ja = host(cm.average_velocity_jacobian(model, data, output_vel_repr=O))
                assert_close(Ja, ref.average_velocity_jacobian(F), tol, f"average_velocity_jacobian [{X.name} -> {O.name}]")
            F = REPR_FRAME[X]
            assert_close(host(cm.total_momentum_jacobian(model, data)), ref.momentum_jacobian(F), tol, "J_h default output")
            assert_close(host(cm.average_velocity_jacobian(model, data)), ref.average_velocity_jacobian(F), tol, "J_avg default")
            assert_close(host(wd.com.centroidal_momentum_jacobian(model, data)), ref.momentum_jacobian(G), tol, f"J_CMM [{X.name}]")
            assert_close(
                host(wd.com.average_centroidal_velocity_jacobian(model, data)),
                ref.average_velocity_jacobian(G),
                tol,
                f"average_centroidal_velocity_jacobian [{X.name}]",
            )
            assert_close(host(cm.locked_spatial_inertia(model, data)), ref.locked_inertia(F), tol, f"locked [{X.name}]")
            assert_close(host(cm.kinetic_energy(model, data)), [ref.K], tol, f"kinetic_energy vs link sums [{X.name}]")
            assert_close(host(wd.com.com_position(model, data)), ref.p_G, tol, "com_position vs link sums")


@pytest.mark.parametrize("case", CASES)
def test_identities(case, dtype):
    """JaxSim's defining identities, per representation: J_CMM ν = centroidal momentum; J_h ν = total
    momentum; locked_spatial_inertia = J_h[:, :6]; J_avg ν = average velocity (model and centroidal);
    locked inertia times average velocity = momentum; com_linear_velocity = average_centroidal_velocity[:3];
    the locked centroidal inertia is block diagonal; mechanical = kinetic + potential; K and U do not
    depend on the representation.

    Reference: warpdyn's own outputs (ν from data.generalized_velocity). Tolerance: module docstring."""
    model = build_model(case, dtype)
    tol = TOL[np.dtype(dtype)]
    _, data, _ = make_data(case, dtype, "identities")
    energies = []
    for X in REPRS:
        with data.switch_velocity_representation(X):
            nu = host(data.generalized_velocity)
            h = host(cm.total_momentum(model, data))
            Jh = host(cm.total_momentum_jacobian(model, data))
            assert_close(Jh @ nu, h, tol, f"J_h nu = total momentum [{X.name}]")
            M = host(cm.locked_spatial_inertia(model, data))
            assert_close(M, Jh[:, :6], tol, f"locked_spatial_inertia = J_h[:, :6] [{X.name}]")
            v = host(cm.average_velocity(model, data))
            assert_close(host(cm.average_velocity_jacobian(model, data)) @ nu, v, tol, f"J_avg nu [{X.name}]")
            assert_close(M @ v, h, tol, f"M_locked v_avg = h [{X.name}]")
            hG = host(wd.com.centroidal_momentum(model, data))
            assert_close(host(wd.com.centroidal_momentum_jacobian(model, data)) @ nu, hG, tol, f"J_CMM nu [{X.name}]")
            vG = host(wd.com.average_centroidal_velocity(model, data))
            JG = host(wd.com.average_centroidal_velocity_jacobian(model, data))
            assert_close(JG @ nu, vG, tol, f"J_avg_G nu [{X.name}]")
            MG = host(wd.com.locked_centroidal_spatial_inertia(model, data))
            assert_close(MG @ vG, hG, tol, f"M_G v_G = h_G [{X.name}]")
            assert_close(MG[:3, 3:], np.zeros((3, 3)), tol, f"M_G is block diagonal [{X.name}]")
            assert_close(host(wd.com.com_linear_velocity(model, data)), vG[:3], tol, f"com_linear_velocity [{X.name}]")
            K, U, E = (host(f(model, data)) for f in (cm.kinetic_energy, cm.potential_energy, cm.mechanical_energy))
            assert_close(E, K + U, tol, f"mechanical = kinetic + potential [{X.name}]")
            energies.append(np.concatenate([K, U]))
    for e in energies[1:]:
        assert_close(e, energies[0], tol, "energies do not depend on the representation")


def test_link_functions(dtype):
    """link_spatial_inertia_matrices, link.spatial_inertia and link.com_position vs the tree's constants
    and warpdyn's link poses (NumPy). Tolerance: module docstring."""
    case = "random-1"
    model = build_model(case, dtype)
    tol = TOL[np.dtype(dtype)]
    _, data, _ = make_data(case, dtype, "link functions")
    expected = link_inertias(model)
    all_M = host(cm.link_spatial_inertia_matrices(model))
    assert_close(all_M, expected, tol, "link_spatial_inertia_matrices")
    H = host(wd.model.forward_kinematics(model, data))
    for i in range(model.number_of_links()):
        assert_close(host(wd.link.spatial_inertia(model, link_index=i)), expected[i], tol, f"spatial_inertia {i}")
        c = np.asarray(model.tree.link_com[i])
        assert_close(host(wd.link.com_position(model, data, link_index=i)), c, tol, f"L_p_CoM {i}")
        assert_close(
            host(wd.link.com_position(model, data, link_index=i, in_link_frame=False)),
            H[i, :3, :3] @ c + H[i, :3, 3],
            tol,
            f"W_p_CoM {i}",
        )
    with pytest.raises(IndexError):
        wd.link.spatial_inertia(model, link_index=model.number_of_links())
    with pytest.raises(IndexError):
        wd.link.com_position(model, data, link_index=-1)


def test_batched_shapes_and_values(dtype, layout):
    """Batched data gives a leading N axis and, per environment, the single-environment values;
    single-environment data gives JaxSim's shapes, and (1,) for the energies (Warp has no 0-d arrays).

    Reference: the same functions on single-environment data. Tolerance: module docstring (both runs do
    the same operations per environment, so the results agree to rounding at most)."""
    case = "random-2"
    model = build_model(case, dtype)
    n, N = model.dofs(), 3
    tol = TOL[np.dtype(dtype)]
    _, batch, kwargs = make_data(case, dtype, "batched", wd.VelRepr.Body, num_envs=N)
    funcs = {
        "total_momentum": (lambda m, d: cm.total_momentum(m, d), (6,)),
        "total_momentum_jacobian": (lambda m, d: cm.total_momentum_jacobian(m, d), (6, 6 + n)),
        "locked_spatial_inertia": (lambda m, d: cm.locked_spatial_inertia(m, d), (6, 6)),
        "average_velocity": (lambda m, d: cm.average_velocity(m, d), (6,)),
        "average_velocity_jacobian": (
            lambda m, d: cm.average_velocity_jacobian(m, d, output_vel_repr=wd.VelRepr.Inertial),
            (6, 6 + n),
        ),
        "kinetic_energy": (lambda m, d: cm.kinetic_energy(m, d), (1,)),
        "potential_energy": (lambda m, d: cm.potential_energy(m, d), (1,)),
        "mechanical_energy": (lambda m, d: cm.mechanical_energy(m, d), (1,)),
        "com_position": (lambda m, d: wd.com.com_position(m, d), (3,)),
        "com_linear_velocity": (lambda m, d: wd.com.com_linear_velocity(m, d), (3,)),
        "centroidal_momentum": (lambda m, d: wd.com.centroidal_momentum(m, d), (6,)),
        "centroidal_momentum_jacobian": (lambda m, d: wd.com.centroidal_momentum_jacobian(m, d), (6, 6 + n)),
        "locked_centroidal_spatial_inertia": (lambda m, d: wd.com.locked_centroidal_spatial_inertia(m, d), (6, 6)),
        "average_centroidal_velocity": (lambda m, d: wd.com.average_centroidal_velocity(m, d), (6,)),
        "average_centroidal_velocity_jacobian": (
            lambda m, d: wd.com.average_centroidal_velocity_jacobian(m, d),
            (6, 6 + n),
        ),
        "bias_acceleration": (lambda m, d: wd.com.bias_acceleration(m, d), (3,)),
        "link.com_position": (lambda m, d: wd.link.com_position(m, d, link_index=2, in_link_frame=False), (3,)),
    }
    singles = [
        wd.data.Data.build(model, **{k: v[e] for k, v in kwargs.items()}, velocity_representation=wd.VelRepr.Body)
        for e in range(N)
    ]
    for name, (f, shape) in funcs.items():
        out = host(f(model, batch))
        batch_shape = (N,) if shape == (1,) else (N, *shape)
        assert out.shape == batch_shape, f"{name}: batched shape {out.shape} != {batch_shape}"
        for e, single in enumerate(singles):
            one = host(f(model, single))
            assert one.shape == shape, f"{name}: single-environment shape {one.shape} != {shape}"
            assert_close(out[e] if shape != (1,) else out[e : e + 1], one, tol, f"{name}, environment {e}")
    assert cm.link_spatial_inertia_matrices(model).shape == (model.number_of_links(), 6, 6)
    assert wd.link.spatial_inertia(model, link_index=0).shape == (6, 6)
    other = build_model(case, np.float32 if np.dtype(dtype) == np.float64 else np.float64)
    with pytest.raises(TypeError):
        cm.kinetic_energy(other, batch)


# ------------------------------------------------------------------------------------ finite differences


def evolve(model, kwargs, X, t) -> dict:
    """The state at time t when ν (the base velocity in representation X, and ṡ) stays constant."""
    out = dict(kwargs)
    out["joint_positions"] = kwargs["joint_positions"] + t * kwargs["joint_velocities"]
    if not model.floating_base():
        return out
    R0, p0 = rotation_wxyz(kwargs["base_quaternion"]), np.asarray(kwargs["base_position"])
    v, w = np.asarray(kwargs["base_linear_velocity"]), np.asarray(kwargs["base_angular_velocity"])
    H0 = np.eye(4)
    H0[:3, :3], H0[:3, 3] = R0, p0
    twist = np.zeros((4, 4))
    twist[:3, :3], twist[:3, 3] = skew(w), v
    if X == wd.VelRepr.Mixed:
        H = np.eye(4)
        H[:3, :3], H[:3, 3] = expm(t * skew(w)) @ R0, p0 + t * v
    elif X == wd.VelRepr.Body:
        H = H0 @ expm(t * twist)
    else:
        H = expm(t * twist) @ H0
    x, y, z, qw = Rotation.from_matrix(H[:3, :3]).as_quat()
    out["base_position"], out["base_quaternion"] = H[:3, 3], np.array([qw, x, y, z])
    return out


@pytest.mark.parametrize("case", ["random-3", "icublegs", "randomfixed-100"])
@pytest.mark.parametrize("X", REPRS, ids=lambda r: r.name)
def test_com_bias_acceleration(case, X):
    """com.bias_acceleration (float64) vs the central difference of the CoM velocity (com_linear_velocity
    with Mixed data: W_pdot_CoM, MuJoCo-tested) along the motion with ν constant in representation X,
    rotated into G's axes at t = 0 (B_R_W for Body data).

    Reference: central finite differences, step 1e-4 s (truncation ~1e-8 times the third derivative,
    rounding ~1e-12): tolerance 1e-6 relative. float32 vs the float64 result: 1e-4 (module docstring)."""
    model = build_model(case, np.float64)
    kwargs = uniform_state_kwargs(model, rng_for(case, "bias", int(X)))
    data = wd.data.Data.build(model, **kwargs, velocity_representation=X)
    a = host(wd.com.bias_acceleration(model, data))

    def com_velocity(t):
        d = wd.data.Data.build(model, **evolve(model, kwargs, X, t), velocity_representation=X)
        with d.switch_velocity_representation(wd.VelRepr.Mixed):
            return host(wd.com.com_linear_velocity(model, d))

    step = 1e-4
    fd = (com_velocity(step) - com_velocity(-step)) / (2 * step)
    if X == wd.VelRepr.Body:
        fd = host(data.base_transform)[:3, :3].T @ fd
    assert_close(a, fd, 1e-6, f"com bias acceleration [{X.name}]")
    model32 = build_model(case, np.float32)
    data32 = wd.data.Data.build(model32, **kwargs, velocity_representation=X)
    assert_close(host(wd.com.bias_acceleration(model32, data32)), a, TOL[np.dtype(np.float32)], "float32 vs float64")


def _state_arrays(data):
    return [getattr(data, f"{name}_state") for name in wd.data._STATE_FIELDS]


def _data_from_states(data, states) -> wd.data.Data:
    """Data holding the given state arrays (host, in the Data layout) with data's representation."""
    arrays = []
    for a in states:
        out = wd.arrays.empty(a.shape[1:], a.shape[0], data.scalar, data.device)
        out.assign(wp.array(np.ascontiguousarray(a), dtype=data.scalar, device=data.device))
        arrays.append(out)
    return wd.data.Data(*arrays, velocity_representation=data.velocity_representation, num_envs=data.num_envs)


def tape_gradient(f, model, data, weights):
    """d(Σ weights ⊙ f(model, data))/d(state arrays), by wp.Tape."""
    tape = wp.Tape()
    with tape:
        out = f(model, data)
    tape.backward(grads={out: wp.array(weights, dtype=model.scalar, device=model.device)})
    grads = [host(a.grad) for a in _state_arrays(data)]
    tape.zero()
    return grads


GRAD_FUNCS = {
    "kinetic_energy": cm.kinetic_energy,
    "potential_energy": cm.potential_energy,
    "mechanical_energy": cm.mechanical_energy,
    "total_momentum": cm.total_momentum,
    "total_momentum_jacobian": cm.total_momentum_jacobian,
    "locked_spatial_inertia": cm.locked_spatial_inertia,
    "average_velocity": cm.average_velocity,
    "average_velocity_jacobian": cm.average_velocity_jacobian,
    "com_position": wd.com.com_position,
    "com_linear_velocity": wd.com.com_linear_velocity,
    "centroidal_momentum": wd.com.centroidal_momentum,
    "centroidal_momentum_jacobian": wd.com.centroidal_momentum_jacobian,
    "locked_centroidal_spatial_inertia": wd.com.locked_centroidal_spatial_inertia,
    "average_centroidal_velocity": wd.com.average_centroidal_velocity,
    "average_centroidal_velocity_jacobian": wd.com.average_centroidal_velocity_jacobian,
    "bias_acceleration": wd.com.bias_acceleration,
    "link.com_position": lambda m, d: wd.link.com_position(m, d, link_index=3, in_link_frame=False),
}


@pytest.mark.parametrize("name", sorted(GRAD_FUNCS))
@pytest.mark.parametrize("X", REPRS, ids=lambda r: r.name)
def test_tape_gradients(name, X, layout):
    """wp.Tape gradients (float64, two environments) of Σ w ⊙ f for random weights w, along a random
    direction of every state array (base pose with a unit-quaternion tangent, joint positions, the stored
    Mixed base velocity, joint velocities), vs central finite differences of the same sum.

    Reference: central differences, step 1e-6 (truncation ~1e-12 times third derivatives, rounding
    ~1e-10 relative): tolerance 1e-6 relative to the largest directional derivative (at least 1)."""
    f = GRAD_FUNCS[name]
    case = "small-5"
    model = build_model(case, np.float64)
    rng = rng_for(name, int(X))
    kwargs = uniform_state_kwargs(model, rng, num_envs=2)
    data = wd.data.Data.build(model, **kwargs, velocity_representation=X, num_envs=2, requires_grad=True)
    weights = rng.normal(size=host(f(model, data)).shape)
    grads = tape_gradient(f, model, data, weights)
    states = [host(a) for a in _state_arrays(data)]
    directions = [rng.normal(size=s.shape) for s in states]
    q = states[1]
    directions[1] -= np.sum(directions[1] * q, axis=1, keepdims=True) * q  # tangent to the unit sphere

    def L(eps):
        d = _data_from_states(data, [s + eps * u for s, u in zip(states, directions)])
        return float(np.sum(weights * host(f(model, d))))

    step = 1e-6
    fd = (L(step) - L(-step)) / (2 * step)
    tape = sum(float(np.sum(g * u)) for g, u in zip(grads, directions))
    assert abs(tape - fd) <= 1e-6 * max(1.0, abs(fd)), f"{name} [{X.name}]: tape {tape!r} vs finite differences {fd!r}"
    for g in grads:
        assert np.all(np.isfinite(g))


def test_kinetic_energy_gradient_per_joint():
    """d K / d s and d K / d ṡ (float64, every joint) by wp.Tape vs central finite differences.

    Reference: central differences, step 1e-6 (error ~1e-10): tolerance 1e-6 relative (at least 1)."""
    case = "random-4"
    model = build_model(case, np.float64)
    kwargs = uniform_state_kwargs(model, rng_for(case, "ke gradient"), num_envs=1)
    data = wd.data.Data.build(model, **kwargs, velocity_representation=wd.VelRepr.Mixed, num_envs=1, requires_grad=True)
    grads = tape_gradient(cm.kinetic_energy, model, data, np.ones(1))
    states = [host(a) for a in _state_arrays(data)]
    for k, name in ((2, "joint_positions"), (4, "joint_velocities")):
        fd = np.zeros(states[k].shape[1])
        for j in range(len(fd)):
            values = []
            for eps in (1e-6, -1e-6):
                moved = [s.copy() for s in states]
                moved[k][0, j] += eps
                values.append(host(cm.kinetic_energy(model, _data_from_states(data, moved)))[0])
            fd[j] = (values[0] - values[1]) / 2e-6
        assert_close(grads[k][0], fd, 1e-6, f"dK/d{name}")
