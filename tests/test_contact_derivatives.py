"""Collidable points (wd.contact): derivatives against central finite differences along the motion. Point
velocities are those of the positions, the contact Jacobian derivative (warpdyn.engine.derivatives) that
of the Jacobians, and wp.Tape gradients through the contact kernels equal finite differences and Jᵀ. On
the seed's ergoCub with its 32 points (tests/robots.py), as in tests/test_contact_geometry.py; each test
gives its tolerance.
"""

from __future__ import annotations

import numpy as np
import pytest
import warp as wp

import warpdyn as wd
from robots import ergocub_seed_with_points, random_state_kwargs
from warpdyn import VelRepr

REPRS = (VelRepr.Body, VelRepr.Mixed, VelRepr.Inertial)


def _advance(state, t):
    """The state moved along its velocity for time t (Mixed base velocity: W_pdot_B, W_omega_WB)."""
    w = state["base_angular_velocity"]
    angle = np.linalg.norm(w) * t
    axis = w / np.linalg.norm(w)
    dq = np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])
    q = state["base_quaternion"]
    w1, x1, y1, z1 = dq
    w2, x2, y2, z2 = q
    q_new = np.array([
        w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
        w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
        w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
        w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2,
    ])
    return dict(state, base_position=state["base_position"] + t * state["base_linear_velocity"], base_quaternion=q_new,
                joint_positions=state["joint_positions"] + t * state["joint_velocities"])


def test_point_velocities_equal_finite_differences_of_positions():
    """W_pdot_C equals central differences (step 1e-6) of W_p_C along the motion (base integrated exactly
    on SO(3)), in float64. Tolerance 1e-8 m/s: truncation ~h^2 |d3p/dt3| ~1e-12, rounding ~1e-16/h ~1e-10."""
    model = ergocub_seed_with_points(np.float64)
    rng = np.random.default_rng(12)
    state = random_state_kwargs(model, rng)
    h = 1e-6
    data = wd.data.Data.build(model, **state)
    v = wd.contact.collidable_point_velocities(model, data).numpy()
    plus = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, **_advance(state, h))).numpy()
    minus = wd.contact.collidable_point_positions(model, wd.data.Data.build(model, **_advance(state, -h))).numpy()
    np.testing.assert_allclose((plus - minus) / (2 * h), v, rtol=0, atol=1e-8)
    p, pv = wd.contact.collidable_point_kinematics(model, data)
    np.testing.assert_array_equal(pv.numpy(), v)
    np.testing.assert_array_equal(p.numpy(), wd.contact.collidable_point_positions(model, data).numpy())


@pytest.mark.parametrize("in_repr", REPRS)
def test_jacobian_derivative_equals_finite_differences(in_repr, dtype):
    """jacobian_derivative (warpdyn.engine.derivatives) equals central differences (step 1e-6, float64)
    of the contact Jacobians along the motion, for 3 output representations. Tolerance: float64 1e-7
    relative (FD truncation and rounding as above, on entries up to ~2); float32 1e-4 relative."""
    model = ergocub_seed_with_points(dtype)
    model64 = ergocub_seed_with_points(np.float64)
    rng = np.random.default_rng(20 + int(in_repr))
    state = random_state_kwargs(model, rng)
    data = wd.data.Data.build(model, **state)  # the motion: Mixed base velocity, as _advance reads it
    h = 1e-6
    for out_repr in REPRS:
        with data.switch_velocity_representation(in_repr):
            Jdot = wd.contact.jacobian_derivative(model, data, output_vel_repr=out_repr).numpy()
        assert Jdot.shape == (32, 6, 6 + model.dofs())

        def J_at(t):
            d = wd.data.Data.build(model64, **_advance(state, t))
            with d.switch_velocity_representation(in_repr):
                return wd.contact.jacobian(model64, d, output_vel_repr=out_repr).numpy()

        ref = (J_at(h) - J_at(-h)) / (2 * h)
        scale = max(1.0, float(np.abs(ref).max()))
        tol = (1e-7 if np.dtype(dtype) == np.float64 else 1e-4) * scale
        np.testing.assert_allclose(Jdot, ref, rtol=0, atol=tol, err_msg=f"in={in_repr.name} out={out_repr.name}")


def test_tape_gradients_equal_finite_differences_and_jacobian_transpose():
    """wp.Tape gradients through the contact kernels (float64): d(w·W_p_C)/ds equals central finite
    differences (step 1e-6; tolerance 1e-7) and d(w·W_pdot_C)/dsdot equals J[:, :3, 6:]^T w (exact up to
    rounding, 1e-10)."""
    model = ergocub_seed_with_points(np.float64)
    rng = np.random.default_rng(13)
    state = {k: v[None] for k, v in random_state_kwargs(model, rng).items()}
    weights = rng.normal(size=(1, 32, 3))

    def build(**changes):
        return wd.data.Data.build(model, **{**state, **changes}, num_envs=1, requires_grad=True)

    data = build()
    tape = wp.Tape()
    with tape:
        W_p_C = wd.contact.collidable_point_positions(model, data)
    tape.backward(grads={W_p_C: wp.array(weights, dtype=wp.float64)})
    grad = data.joint_positions_state.grad.numpy()[0]
    h = 1e-6
    fd = np.zeros(model.dofs())
    for j in range(model.dofs()):
        s = state["joint_positions"].copy()
        s[0, j] += h
        plus = wd.contact.collidable_point_positions(model, build(joint_positions=s)).numpy()
        s[0, j] -= 2 * h
        minus = wd.contact.collidable_point_positions(model, build(joint_positions=s)).numpy()
        fd[j] = np.sum(weights * (plus - minus)) / (2 * h)
    np.testing.assert_allclose(grad, fd, rtol=0, atol=1e-7)

    data = build()
    tape = wp.Tape()
    with tape:
        v = wd.contact.collidable_point_velocities(model, data)
    tape.backward(grads={v: wp.array(weights, dtype=wp.float64)})
    J = wd.contact.jacobian(model, data, output_vel_repr=VelRepr.Mixed).numpy()[0]
    ref = np.einsum("crj,cr->j", J[:, :3, 6:], weights[0])
    np.testing.assert_allclose(data.joint_velocities_state.grad.numpy()[0], ref, rtol=0, atol=1e-10)
