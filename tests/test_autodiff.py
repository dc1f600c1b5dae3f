"""warpdyn.autodiff: a step's A, B and the Jacobians of functions, by one batched backward pass, against central
finite differences (float64) and MuJoCo's mjd_transitionFD on the same MJCF.

Finite differences here move the state along the tangent of kernels/tangent.py (the base rotation in world axes
for the Mixed representation, in base axes for Body) and read the new state's tangent the same way. The soft
contacts' damper, D δ^q δ̇ with q = 1/2, curves sharply 1.5 mm into the ground: there h = 1e-6 is off by 5e-2 of the
largest entry, h = 1e-7 by 3e-9 (round-off eps |x'| / h stays below that), so h = 1e-7 and the tolerance 1e-7 of the
largest entry (entries reach ~1e3 with the contacts' stiffness).
"""

import dataclasses

import mujoco
import numpy as np
import pytest
import warp as wp

import mjcf_models
import warpdyn as wd
from mjcf_compare import mujoco_to_warpdyn_state
from mjcf_fixtures import BALL, FLOATING_HUMANOID
from test_fused_step import FREE_TREES


def quat_mul(a, b):
    w1, v1, w2, v2 = a[0], a[1:], b[0], b[1:]
    return np.concatenate([[w1 * w2 - v1 @ v2], w1 * v2 + w2 * v1 + np.cross(v1, v2)])


def quat_exp(theta):
    angle = np.linalg.norm(theta)
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * theta / angle])


def conj(Q):
    return Q * np.array([1.0, -1.0, -1.0, -1.0])


def legs(contacts: bool):
    """The ergoCub legs (float64), their lowest point 3 mm into the ground (soft contacts) or in the air."""
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=np.float64)
    model = wd.model.reduce(full, considered_joints=wd.assets.ERGOCUB_LEG_JOINTS)
    if not contacts:
        model = wd.contact.with_collidable_points(model, enabled_links=())
    return model


def random_state(model, N, repr, rng, height):
    n = model.dofs()
    Q = rng.normal(size=(N, 4)) * np.array([0.1, 0.05, 0.05, 0.3]) + np.array([1.0, 0.0, 0.0, 0.0])
    Q /= np.linalg.norm(Q, axis=1, keepdims=True)
    data = wd.data.Data.build(model, num_envs=N, base_quaternion=Q, joint_positions=rng.uniform(-0.2, 0.2, (N, n)), velocity_representation=repr)
    lowest = wd.contact.collidable_point_positions(model, data).numpy()[..., 2].min(axis=1, initial=0.0)
    return data.replace(model, base_position=np.stack([np.zeros(N), np.zeros(N), height - lowest], axis=1), base_linear_velocity=rng.normal(0, 0.1, (N, 3)),
                        base_angular_velocity=rng.normal(0, 0.3, (N, 3)), joint_velocities=rng.normal(0, 0.5, (N, n)),
                        contact_state={"tangential_deformation": rng.normal(0, 1e-4, (N, 32, 3))})


def host_state(data, e):
    return [a.numpy()[e] for a in (data.base_position, data.base_quaternion, data.joint_positions, data.base_velocity, data.joint_velocities)]


def fd_transition(model, data, e, tau, body_axes, h=1e-7):
    """(A, B) of environment e by central differences in the tangent of kernels/tangent.py (one-DoF joints)."""
    p0, Q0, s0, v0, sd0 = host_state(data, e)
    n = model.dofs()
    deformation = data.contact_state["tangential_deformation"].numpy()[e]

    def stepped(dx, u):
        turn = quat_exp(dx[3:6])
        Q = quat_mul(Q0, turn) if body_axes else quat_mul(turn, Q0)
        v = v0 + dx[6 + n : 12 + n]
        one = wd.data.Data.build(model, base_position=p0 + dx[:3], base_quaternion=Q, joint_positions=s0 + dx[6 : 6 + n], base_linear_velocity=v[:3],
                                 base_angular_velocity=v[3:], joint_velocities=sd0 + dx[12 + n :], velocity_representation=data.velocity_representation,
                                 contact_state={"tangential_deformation": deformation}, num_envs=1)
        return host_state(wd.model.step(model, one, joint_force_references=u), 0)

    reference = stepped(np.zeros(2 * (6 + n)), tau)

    def tangent(x):
        p, Q, s, v, sd = x
        e = quat_mul(conj(reference[1]), Q) if body_axes else quat_mul(Q, conj(reference[1]))
        return np.concatenate([p, 2 * e[1:], s, v, sd])

    nx = 2 * (6 + n)
    A = np.zeros((nx, nx))
    for k in range(nx):
        dx = np.zeros(nx)
        dx[k] = h
        A[:, k] = (tangent(stepped(dx, tau)) - tangent(stepped(-dx, tau))) / (2 * h)
    B = np.zeros((nx, n))
    for k in range(n):
        du = np.zeros(n)
        du[k] = h
        B[:, k] = (tangent(stepped(np.zeros(nx), tau + du)) - tangent(stepped(np.zeros(nx), tau - du))) / (2 * h)
    return A, B


@pytest.mark.parametrize("repr", [wd.VelRepr.Mixed, wd.VelRepr.Body])
def test_transition_matrices_of_the_legs_in_contact_equal_finite_differences(repr, layout):
    """The floating-base legs, 3 mm into the soft ground (some points in contact, a deformation state held), in the
    Mixed and Body representations and both layouts of per-environment arrays (the GPU's env-fastest too): A and B
    of two environments equal central differences."""
    model = legs(contacts=True)
    rng = np.random.default_rng(1)
    N, n = 2, model.dofs()
    data = random_state(model, N, repr, rng, height=-0.003)
    assert (wd.contact.collidable_point_positions(model, data).numpy()[..., 2] < 0).sum(axis=1).min() >= 1
    tau = rng.normal(0, 5.0, (N, n))
    out = wd.autodiff.transition_matrices(model, data, joint_force_references=tau)
    A, B = out["A"].numpy(), out["B"].numpy()
    assert A.shape == (N, 2 * (6 + n), 2 * (6 + n)) and B.shape == (N, 2 * (6 + n), n)
    for e in range(N):
        A_fd, B_fd = fd_transition(model, data, e, tau[e], body_axes=repr == wd.VelRepr.Body)
        assert np.abs(A[e] - A_fd).max() <= 1e-7 * np.abs(A_fd).max(), e
        assert np.abs(B[e] - B_fd).max() <= 1e-7 * np.abs(B_fd).max(), e
        assert np.abs(A_fd).max() > 10.0  # the contacts' stiffness is in it
    central = wd.autodiff.transition_matrices(model, data, joint_force_references=tau, method="central", h=1e-7)
    for name, exact in (("A", A), ("B", B)):
        assert np.abs(central[name].numpy() - exact).max() <= 1e-7 * np.abs(exact).max()


def mujoco_transition(mj, qpos, qvel, ctrl):
    """MuJoCo's (A, B) by centred differences (mjd_transitionFD, eps 1e-6)."""
    d = mujoco.MjData(mj)
    d.qpos[:], d.qvel[:], d.ctrl[:] = qpos, qvel, ctrl
    mujoco.mj_forward(mj, d)
    A = np.zeros((2 * mj.nv, 2 * mj.nv))
    B = np.zeros((2 * mj.nv, mj.nu))
    mujoco.mjd_transitionFD(mj, d, 1e-6, 1, A, B, None, None)
    return A, B


def tangent_map(T, free, data):
    """MuJoCo's tangent [dq; dv] from warpdyn's (Mixed): T (MuJoCo's dofs from warpdyn's velocities, of
    mujoco_to_warpdyn_state) with, for a floating base (its free joint's first dof `free`), the rotation's block Rᵀ
    at data's state and the angular velocity's dependence on the rotation: ω_b = Rᵀ ω_w, so δω_b = Rᵀ δω_w + Rᵀ
    [ω_w]x δθ_w."""
    nv, m = T.shape
    Tx = T.copy()
    J = np.zeros((2 * nv, 2 * m))
    if free is not None:
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, data.base_quaternion.numpy())
        R = R.reshape(3, 3)
        Tx[free + 3 : free + 6, 3:6] = R.T
        w = data.base_velocity.numpy()[3:]
        J[nv + free + 3 : nv + free + 6, 3:6] = R.T @ np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    J[:nv, :m] = Tx
    J[nv:, m:] = Tx
    return J


def random_mujoco_state(mj, rng):
    d = mujoco.MjData(mj)
    d.qpos[:] = mj.qpos0
    mujoco.mj_integratePos(mj, d.qpos, rng.normal(0, 0.3, mj.nv), 1.0)
    return d.qpos.copy(), rng.normal(0, 0.5, mj.nv), rng.uniform(-0.5, 0.5, mj.nu)


@pytest.mark.parametrize("method", ["reverse", "central"])
@pytest.mark.parametrize("name", ["floating humanoid", "ball", "free trees"])
def test_transition_matrices_equal_mujocos(name, method):
    """A and B (with respect to ctrl) equal MuJoCo's mjd_transitionFD on the same MJCF without contacts: a floating
    humanoid with motors, position and velocity servos (its base's tangent converted: MuJoCo's rotation and angular
    velocity are in base axes, the Mixed representation's in world axes), a ball joint, and two free trees below the
    world (free joints' tangents are MuJoCo's); by the exact reverse pass and by warpdyn's own central differences.
    MuJoCo's differences (eps 1e-6) are exact to ~1e-9 of the entries."""
    xml = {"floating humanoid": FLOATING_HUMANOID, "ball": BALL, "free trees": FREE_TREES}[name]
    mj = mjcf_models.reference_model(mjcf_models.load(xml), extra_disable=int(mujoco.mjtDisableBit.mjDSBL_CONTACT))
    model = wd.model.Model.build_from_model_description(xml, dtype=np.float64)
    model = wd.contact.with_collidable_points(model, enabled_links=())
    qpos, qvel, ctrl = random_mujoco_state(mj, np.random.default_rng(3))
    A_mj, B_mj = mujoco_transition(mj, qpos, qvel, ctrl)
    state = mujoco_to_warpdyn_state(model, mj, qpos, qvel)
    data = wd.data.Data.build(model, **state.data_kwargs)
    actuators = [mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in model.actuator_names()]
    u = np.zeros(model.number_of_actuators())
    u[:] = ctrl[actuators] if actuators else u
    out = wd.autodiff.transition_matrices(model, data, control="ctrl", ctrl=u, method=method)
    A, B = out["A"].numpy(), out["B"].numpy()
    free = None
    if model.floating_base():
        free = int(mj.jnt_dofadr[mj.body_jntadr[mujoco.mj_name2id(mj, mujoco.mjtObj.mjOBJ_BODY, model.base_link())]])
    after = wd.model.step(model, data, ctrl=u)
    J0, J1 = tangent_map(state.T, free, data), tangent_map(state.T, free, after)
    A_w = J1 @ A @ np.linalg.inv(J0)
    B_w = J1 @ B
    B_mj = B_mj[:, actuators] if actuators else B_mj[:, :0]
    assert np.abs(A_w - A_mj).max() <= 1e-7 * max(1.0, np.abs(A_mj).max()), np.abs(A_w - A_mj).max()
    assert B.shape == (A.shape[0], model.number_of_actuators()) and B_mj.shape == B_w.shape
    assert np.abs(B_w - B_mj).max(initial=0.0) <= 1e-7 * max(1.0, np.abs(B_mj).max(initial=0.0))


def test_jacobian_of_forward_dynamics_equals_finite_differences():
    """∂ν̇/∂(x, τ, link masses, centres of mass) of forward_dynamics_aba for two environments with per-environment masses (the
    model is replicated per copy): central differences of the function itself (h = 1e-6; no contacts, so the
    function is smooth: their error, mostly round-off eps |ν̇| / h, stays below 1e-7 of the block's largest entry)."""
    model = legs(contacts=False)
    rng = np.random.default_rng(5)
    N, n, nL = 2, model.dofs(), model.number_of_links()
    model.set_link_parameters(mass=model.link_mass.numpy() * rng.uniform(0.9, 1.1, (N, nL)))
    data = random_state(model, N, wd.VelRepr.Mixed, rng, height=0.5)
    tau = rng.normal(0, 5.0, (N, n))

    def accelerations(model, data, joint_forces):
        base, joints = wd.model.forward_dynamics_aba(model, data, joint_forces=joint_forces)
        return joints

    out = wd.autodiff.jacobian(accelerations, model, data, controls={"joint_forces": tau}, wrt=("state", "joint_forces"), parameters=("link_mass", "link_com"))
    J_x, J_tau, J_m, J_c = (out[k].numpy() for k in ("state", "joint_forces", "link_mass", "link_com"))
    assert J_x.shape == (N, n, 2 * (6 + n)) and J_tau.shape == (N, n, n) and J_m.shape == (N, n, nL) and J_c.shape == (N, n, 3 * nL)
    h = 1e-6
    masses = model.link_mass.numpy()
    p0, Q0, s0, v0, sd0 = (np.array([host_state(data, e)[k] for e in range(N)]) for k in range(5))

    coms = model.link_com.numpy()

    def at(dx=None, dtau=None, dmass=None, dcom=None):
        dx = np.zeros(2 * (6 + n)) if dx is None else dx
        Q = np.array([quat_mul(quat_exp(dx[3:6]), Q0[e]) for e in range(N)])
        v = v0 + dx[6 + n : 12 + n]
        moved = wd.data.Data.build(model, num_envs=N, base_position=p0 + dx[:3], base_quaternion=Q, joint_positions=s0 + dx[6 : 6 + n],
                                   base_linear_velocity=v[:, :3], base_angular_velocity=v[:, 3:], joint_velocities=sd0 + dx[12 + n :])
        varied = model
        if dmass is not None or dcom is not None:
            varied = model.copy()
            varied.set_link_parameters(mass=masses + (0.0 if dmass is None else dmass), com=coms + (0.0 if dcom is None else dcom))
        return accelerations(varied, moved, tau + (0.0 if dtau is None else dtau)).numpy()

    for k in range(2 * (6 + n)):
        dx = np.zeros(2 * (6 + n))
        dx[k] = h
        fd = (at(dx=dx) - at(dx=-dx)) / (2 * h)
        assert np.abs(J_x[:, :, k] - fd).max() <= 1e-7 * np.abs(J_x).max(), k
    for k in range(n):
        du = np.zeros(n)
        du[k] = h
        fd = (at(dtau=du) - at(dtau=-du)) / (2 * h)
        assert np.abs(J_tau[:, :, k] - fd).max() <= 1e-7 * np.abs(J_tau).max(), k
    for k in range(1, nL):
        dm = np.zeros((N, nL))
        dm[:, k] = h
        fd = (at(dmass=dm) - at(dmass=-dm)) / (2 * h)
        assert np.abs(J_m[:, :, k] - fd).max() <= 1e-7 * np.abs(J_m).max(), k
    for link, axis in ((3, 1), (7, 0)):
        dc = np.zeros((nL, 3))
        dc[link, axis] = h
        fd = (at(dcom=dc) - at(dcom=-dc)) / (2 * h)
        assert np.abs(J_c[:, :, 3 * link + axis] - fd).max() <= 1e-7 * np.abs(J_c).max(), (link, axis)
    assert model.per_environment_parameters() == {"link_mass": N} and not model.link_mass.requires_grad  # the user's model untouched


def test_a_parameters_gradient_the_user_holds_is_kept():
    """A parameter the user marked for gradients (with a gradient in it) keeps its gradient through a Jacobian."""
    model = legs(contacts=False)
    marked = wd.model.parameters_requiring_grad(model, names=("link_inertia",))["link_inertia"]
    marked.grad.fill_(0.25)
    data = wd.data.Data.build(model, num_envs=2, base_position=(0.0, 0.0, 1.0))
    A = wd.autodiff.transition_matrices(model, data)["A"].numpy()
    assert np.isfinite(A).all()
    np.testing.assert_array_equal(marked.grad.numpy(), np.full(marked.shape + (3, 3), 0.25))


def test_single_environment_shapes_and_bad_arguments():
    """Single-environment data gives JaxSim's shapes (no N axis); bad arguments raise naming them."""
    model = legs(contacts=False)
    data = wd.data.Data.build(model, base_position=(0.0, 0.0, 1.0))
    n = model.dofs()
    out = wd.autodiff.transition_matrices(model, data)
    assert out["A"].shape == (2 * (6 + n), 2 * (6 + n)) and out["B"].shape == (2 * (6 + n), n)
    jac = wd.autodiff.jacobian(lambda model, data: wd.model.total_momentum(model, data), model, data)
    assert jac["state"].shape == (6, 2 * (6 + n))
    with pytest.raises(ValueError, match="method must be"):
        wd.autodiff.transition_matrices(model, data, method="forward")
    with pytest.raises(ValueError, match="central.*state and the controls only"):
        wd.autodiff.transition_matrices(model, data, method="central", parameters=("link_mass",))
    with pytest.raises(ValueError, match="control must be"):
        wd.autodiff.transition_matrices(model, data, control="tau")
    with pytest.raises(ValueError, match=r"parameters \['gravity_vector'\] are not model parameters"):
        wd.autodiff.transition_matrices(model, data, parameters=("gravity_vector",))
    with pytest.raises(ValueError, match=r"wrt names \['tau'\]"):
        wd.autodiff.jacobian(lambda model, data: wd.model.total_momentum(model, data), model, data, wrt=("tau",))
    with pytest.raises(TypeError, match="must return a Warp array"):
        wd.autodiff.jacobian(lambda model, data: 1.0, model, data)


@pytest.mark.parametrize("method", ["reverse", "central"])
def test_a_flagged_environment_gets_nan_and_the_others_stay_exact(method):
    """An environment whose step diverges (joint speeds of 1e200 rad/s overflow) is flagged by the step: its A and B
    are NaN; the other environment's equal those of a batch without it."""
    model = legs(contacts=False)
    n = model.dofs()
    speeds = np.zeros((2, n))
    speeds[1] = 1e200
    data = wd.data.Data.build(model, num_envs=2, base_position=(0.0, 0.0, 1.0), joint_velocities=speeds)
    out = wd.autodiff.transition_matrices(model, data, method=method)
    alone = wd.autodiff.transition_matrices(model, wd.data.Data.build(model, num_envs=1, base_position=(0.0, 0.0, 1.0)), method=method)
    for name in ("A", "B"):
        value = out[name].numpy()
        assert np.isnan(value[1]).all()
        np.testing.assert_array_equal(value[0], alone[name].numpy()[0])


def test_parameter_jacobians_of_a_step_equal_finite_differences():
    """∂x'/∂(world_gravity, friction_viscous, K) of a step of the legs in soft contact (gravity per environment,
    the other two shared: each comes back per environment) equal central differences of the step (h = 1e-6 of
    each parameter's scale)."""
    model = legs(contacts=True)
    rng = np.random.default_rng(7)
    N, n = 2, model.dofs()
    model.set_gravity(np.array([[0.3, -0.2, -9.81], [0.0, 0.5, -9.7]]))
    model.set_joint_parameters(friction_viscous=np.full(n, 0.3))
    data = random_state(model, N, wd.VelRepr.Mixed, rng, height=-0.002)
    out = wd.autodiff.transition_matrices(model, data, parameters=("world_gravity", "friction_viscous", "K"))
    assert out["world_gravity"].shape == (N, 2 * (6 + n), 3) and out["friction_viscous"].shape == (N, 2 * (6 + n), n) and out["K"].shape == (N, 2 * (6 + n), 1)

    def stepped(varied, e):
        reference = host_state(wd.model.step(model, data), e)
        x = host_state(wd.model.step(varied, data), e)
        rotation = quat_mul(x[1], conj(reference[1]))
        return np.concatenate([x[0], 2 * rotation[1:], x[2], x[3], x[4]])

    gravity = model.world_gravity.numpy().reshape(N, 3)
    for e in range(N):
        for k in range(3):
            columns = []
            for sign in (1.0, -1.0):
                varied = model.copy()
                g = gravity.copy()
                g[e, k] += sign * 1e-6
                varied.set_gravity(g)
                columns.append(stepped(varied, e))
            fd = (columns[0] - columns[1]) / 2e-6
            np.testing.assert_allclose(out["world_gravity"].numpy()[e, :, k], fd, rtol=0, atol=1e-7 * np.abs(fd).max())
        columns = []
        for sign in (1.0, -1.0):
            varied = model.copy()
            varied.set_joint_parameters(friction_viscous=np.full(n, 0.3) + sign * 1e-6 * (np.arange(n) == 4))
            columns.append(stepped(varied, e))
        fd = (columns[0] - columns[1]) / 2e-6
        np.testing.assert_allclose(out["friction_viscous"].numpy()[e, :, 4], fd, rtol=0, atol=1e-7 * np.abs(fd).max())
        columns = []
        K = model.contact_params.K
        for sign in (1.0, -1.0):
            varied = model.copy()
            varied.contact_params = dataclasses.replace(model.contact_params, K=K * (1.0 + sign * 1e-6))
            columns.append(stepped(varied, e))
        fd = (columns[0] - columns[1]) / (2e-6 * K)
        np.testing.assert_allclose(out["K"].numpy()[e, :, 0], fd, rtol=0, atol=1e-6 * np.abs(fd).max())
        assert np.abs(fd).max() > 0.0


def test_the_linearisation_of_a_rollout_is_the_product_of_its_steps():
    """steps = 5 (a taped rollout) in the air: ∂x_5/∂x_0 = A_4 A_3 A_2 A_1 A_0 and ∂x_5/∂u_t = A_4 .. A_t+1 B_t for
    per-step torques, with each (A_t, B_t) one step's linearisation at x_t (the chain rule, to rounding); for a
    torque held over the steps B is their sum, and central differences give the same to 1e-7."""
    model = legs(contacts=False)
    rng = np.random.default_rng(11)
    N, n, T = 2, model.dofs(), 5
    data = random_state(model, N, wd.VelRepr.Mixed, rng, height=0.5)
    tau = rng.normal(0.0, 5.0, (T, N, n))
    whole = wd.autodiff.transition_matrices(model, data, joint_force_references=tau, steps=T)
    A_T, B_T = whole["A"].numpy(), whole["B"].numpy()
    assert B_T.shape == (N, 2 * (6 + n), T, n)
    A_chain = np.broadcast_to(np.eye(2 * (6 + n)), A_T.shape).copy()
    B_each, x = [], data
    for t in range(T):
        one = wd.autodiff.transition_matrices(model, x, joint_force_references=tau[t])
        A_t, B_t = one["A"].numpy(), one["B"].numpy()
        B_each = [A_t @ B for B in B_each] + [B_t]
        A_chain = A_t @ A_chain
        x = wd.model.step(model, x, joint_force_references=tau[t])
    np.testing.assert_allclose(A_T, A_chain, rtol=0, atol=1e-10 * np.abs(A_chain).max())
    for t in range(T):
        np.testing.assert_allclose(B_T[:, :, t], B_each[t], rtol=0, atol=1e-10 * np.abs(B_each[t]).max())
    held = wd.autodiff.transition_matrices(model, data, joint_force_references=tau[0], steps=T)
    held_chain = sum(wd.autodiff.transition_matrices(model, data, joint_force_references=np.broadcast_to(tau[0], (T, N, n)), steps=T)["B"].numpy()[:, :, t] for t in range(T))
    np.testing.assert_allclose(held["B"].numpy(), held_chain, rtol=0, atol=1e-10 * np.abs(held_chain).max())
    central = wd.autodiff.transition_matrices(model, data, joint_force_references=tau[0], steps=T, method="central")
    for name in ("A", "B"):
        exact = held[name].numpy()
        assert np.abs(central[name].numpy() - exact).max() <= 1e-7 * np.abs(exact).max(), name
    with pytest.raises(ValueError, match="per-step controls need method='reverse'"):
        wd.autodiff.transition_matrices(model, data, joint_force_references=tau, steps=T, method="central")
    with pytest.raises(ValueError, match="steps must be a positive integer"):
        wd.autodiff.transition_matrices(model, data, steps=0)


def test_an_environment_flagged_before_gets_nan():
    """An environment the data already flags (a diverged state frozen by an earlier step) gets NaN from both
    functions; the other's Jacobians stay finite."""
    model = legs(contacts=False)
    n = model.dofs()
    speeds = np.zeros((2, n))
    speeds[0] = 1e200
    data = wd.model.step(model, wd.data.Data.build(model, num_envs=2, base_position=(0.0, 0.0, 1.0), joint_velocities=speeds))
    assert data.healthy.numpy().tolist() == [0, 1]
    for out in (wd.autodiff.transition_matrices(model, data), wd.autodiff.jacobian(lambda model, data: wd.model.total_momentum(model, data), model, data)):
        for value in out.values():
            assert np.isnan(value.numpy()[0]).all() and np.isfinite(value.numpy()[1]).all()


def test_warp_controls_are_replicated_on_the_device_with_the_same_result():
    """Controls given as Warp arrays (per environment (N, n), shared (n,)) are replicated on the device; A and B equal
    those of the same controls given as NumPy arrays (to the bit), by both methods."""
    model = legs(contacts=False)
    rng = np.random.default_rng(4)
    N, n = 2, model.dofs()
    data = random_state(model, N, wd.VelRepr.Mixed, rng, height=0.5)
    tau = rng.normal(0.0, 5.0, (N, n))
    for method in ("reverse", "central"):
        for given in (tau, tau[0]):
            host = wd.autodiff.transition_matrices(model, data, joint_force_references=given, method=method)
            device = wd.autodiff.transition_matrices(model, data, joint_force_references=wp.array(given, dtype=wp.float64), method=method)
            for name in ("A", "B"):
                np.testing.assert_array_equal(device[name].numpy(), host[name].numpy())
