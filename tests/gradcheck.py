"""Directional gradient checks of rollouts: wp.Tape gradients against central finite differences.

For a scalar loss L of Warp arrays x_k (initial state, controls, model parameters), one taped evaluation
gives every gradient g_k = dL/dx_k at once; for each x_k a seeded random direction d_k then gives one
number to compare, g_k . d_k, against the central difference (L(x_k + h d_k) - L(x_k - h d_k)) / 2h,
two evaluations without a tape. The perturbation is applied in place (`array.assign`), so every use of the
array (a Data's state array, a control, a model parameter read by the kernels) sees it.

`Check` holds an input: its array, its direction and, where the input lives on a manifold, how a point is
perturbed (the unit quaternion: x(t) = normalise(x0 + t d) with d tangent to the sphere, whose derivative at
t = 0 is d itself, so g . d is still the quantity the differences estimate).

(No `from __future__ import annotations` here: Warp reads the kernels' annotations, which name the
closure's `scalar`, when it defines them.)
"""

import dataclasses
import functools
from typing import Callable

import numpy as np
import warp as wp


@functools.cache
def _loss_kernels(scalar):
    """out[0] += sum w * x over arrays of 1 to 4 dimensions (any strides), in `scalar`."""

    @wp.kernel(module="unique")
    def loss1(x: wp.array(dtype=scalar), w: wp.array(dtype=scalar), out: wp.array(dtype=scalar)):
        i = wp.tid()
        wp.atomic_add(out, 0, w[i] * x[i])

    @wp.kernel(module="unique")
    def loss2(x: wp.array2d(dtype=scalar), w: wp.array2d(dtype=scalar), out: wp.array(dtype=scalar)):
        i, j = wp.tid()
        wp.atomic_add(out, 0, w[i, j] * x[i, j])

    @wp.kernel(module="unique")
    def loss3(x: wp.array3d(dtype=scalar), w: wp.array3d(dtype=scalar), out: wp.array(dtype=scalar)):
        i, j, k = wp.tid()
        wp.atomic_add(out, 0, w[i, j, k] * x[i, j, k])

    @wp.kernel(module="unique")
    def loss4(x: wp.array4d(dtype=scalar), w: wp.array4d(dtype=scalar), out: wp.array(dtype=scalar)):
        i, j, k, l = wp.tid()
        wp.atomic_add(out, 0, w[i, j, k, l] * x[i, j, k, l])

    return {1: loss1, 2: loss2, 3: loss3, 4: loss4}


def weighted_sum(arrays, weights, scalar=wp.float64, out=None) -> wp.array:
    """A new (1,) array (requires_grad) holding sum_k sum(w_k * x_k), as Warp launches a tape records; added
    to `out` instead when given. weights: Warp arrays of the arrays' shapes."""
    kernels = _loss_kernels(scalar)
    device = arrays[0].device
    if out is None:
        out = wp.zeros(1, dtype=scalar, device=device, requires_grad=True)
    for x, w in zip(arrays, weights):
        if x.size:
            wp.launch(kernels[x.ndim], dim=x.shape, inputs=[x, w], outputs=[out], device=device)
    return out


def record_weights(shapes: dict, names, rng, scale: dict | None = None, env_mask=None, scalar=wp.float64, device=None) -> dict:
    """{name: Warp array}: random normal weights of shape shapes[name] (anything with .shape: the records),
    divided by scale[name] (default 1) so that quantities of different units weigh alike; env_mask (N,)
    of 0/1 zeroes the environments that the loss must not see (axis 1 of every record)."""
    out = {}
    for name in names:
        shape = tuple(shapes[name].shape)
        w = rng.normal(size=shape) / (1.0 if scale is None else scale.get(name, 1.0))
        if env_mask is not None:
            w = w * np.asarray(env_mask, dtype=np.float64).reshape((1, -1) + (1,) * (len(shape) - 2))
        out[name] = wp.array(w, dtype=scalar, device=device)
    return out


@dataclasses.dataclass
class Check:
    """One input: its Warp array, a direction d (NumPy, the array's numpy() shape) and, optionally,
    `perturb(x0, t)`, the perturbed value (default x0 + t d)."""

    array: wp.array
    direction: np.ndarray
    perturb: Callable | None = None

    def at(self, x0: np.ndarray, t: float) -> np.ndarray:
        return x0 + t * self.direction if self.perturb is None else self.perturb(x0, t)


def unit_quaternion_check(array: wp.array, rng) -> Check:
    """The quaternion rows (N, 4) of `array` moved along random directions tangent to the unit sphere and
    renormalised: x(t) = x0 + t d normalised, d . x0 = 0 per row, so dx/dt(0) = d (the tape's gradient
    with respect to the 4 raw components, dotted with d, is the derivative along the sphere)."""
    q = array.numpy()
    d = rng.normal(size=q.shape)
    d -= np.sum(d * q, axis=-1, keepdims=True) * q / np.sum(q * q, axis=-1, keepdims=True)

    def perturb(x0, t):
        x = x0 + t * d
        return x / np.linalg.norm(x, axis=-1, keepdims=True)

    return Check(array, d, perturb)


def symmetric_direction(rng, shape) -> np.ndarray:
    """Random symmetric 3x3 matrices (..., 3, 3): directions that keep an inertia symmetric."""
    a = rng.normal(size=shape)
    return 0.5 * (a + np.swapaxes(a, -1, -2))


def directional_derivatives(checks: dict, loss: Callable[[], float], h: float, richardson: bool = False) -> dict:
    """{name: central difference of loss() along the check's direction}, step h, each array restored after.

    richardson: (4 D(h/2) - D(h)) / 3 from the central differences D of steps h and h/2, which cancels
    their h^2 error term (truncation O(h^4)) at twice the evaluations: for losses with large third
    derivatives (stiff contacts), where a step small enough for O(h^2) is too small for rounding."""

    def central(check, x0, step):
        check.array.assign(check.at(x0, step))
        up = loss()
        check.array.assign(check.at(x0, -step))
        down = loss()
        return (up - down) / (2.0 * step)

    out = {}
    for name, check in checks.items():
        x0 = check.array.numpy().copy()
        try:
            d = central(check, x0, h)
            if richardson:
                d = (4.0 * central(check, x0, 0.5 * h) - d) / 3.0
        finally:
            check.array.assign(x0)
        out[name] = d
    return out


def tape_directional(checks: dict) -> dict:
    """{name: g . d} from the arrays' .grad after tape.backward."""
    out = {}
    for name, check in checks.items():
        assert check.array.grad is not None, f"{name}: no gradient array (not reached by the tape?)"
        g = check.array.grad.numpy()
        assert g.shape == check.direction.shape, (name, g.shape, check.direction.shape)
        assert np.all(np.isfinite(g)), f"{name}: non-finite gradient"
        out[name] = float(np.sum(g * check.direction))
    return out


def relative_errors(tape: dict, fd: dict, floor: float = 0.0) -> dict:
    """{name: |tape - fd| / max(|fd|, floor)}."""
    return {k: abs(tape[k] - fd[k]) / max(abs(fd[k]), floor) for k in fd}


def contact_gradient_check(run, xpos, xmat, max_contacts: int, vec3, mat33, seed: int = 2, position_and_normal: bool = True) -> dict:
    """The narrow-phase tests' directional check of a batch of geom pairs (tests/test_collision_primitives.py,
    test_collision_box.py). run(xpos, xmat) launches the pairs' kernel on the poses xpos (n, 2, 3), xmat (n, 2, 3, 3)
    and returns ([p1, R1, p2, R2] the Warp inputs requiring gradients, count (n,), pos, frame, dist (n, max_contacts)
    its outputs requiring gradients). L = sum over each pair's contacts of dist + w1.pos + w2.normal (w1, w2 random;
    zero unless position_and_normal);
    the tape's gradient along a random direction d (positions moved by h d, rotations turned by h d) against central
    differences at h = 1e-6 and 2e-6. Returns {"along": the tape's, "fd1", "fd2": the differences, "kink": the
    one-sided differences' gap at 1e-6, "count": the counts at the poses, "steps_keep_count": whether every moved
    pose has that count}, each (n,)."""
    import contextlib

    import scipy.spatial.transform

    n = len(xpos)
    rng = np.random.default_rng(seed)
    w1, w2 = rng.standard_normal((2, n, max_contacts, 3)) * position_and_normal
    direction_pos, direction_rot = rng.standard_normal((2, n, 2, 3))

    def loss(xpos, xmat, tape=None):
        with tape or contextlib.nullcontext():
            inputs, count, pos, frame, dist = run(xpos, xmat)
        valid = np.arange(max_contacts)[None] < count.numpy()[:, None]
        value = np.where(valid, dist.numpy() + np.sum(w1 * pos.numpy(), -1) + np.sum(w2 * frame.numpy()[..., 0, :], -1), 0.0).sum(1)
        if tape is not None:
            seed_frame = np.zeros((n, max_contacts, 3, 3))
            seed_frame[..., 0, :] = w2 * valid[..., None]
            tape.backward(grads={dist: wp.array(valid * 1.0, dtype=wp.float64), pos: wp.array(w1 * valid[..., None], dtype=vec3), frame: wp.array(seed_frame, dtype=mat33)})
        return value, count.numpy(), [a.grad.numpy() if tape is not None else None for a in inputs]

    def moved(h):
        turn = scipy.spatial.transform.Rotation.from_rotvec(h * direction_rot.reshape(-1, 3)).as_matrix().reshape(n, 2, 3, 3)
        return xpos + h * direction_pos, xmat @ turn

    value, count, (g_p1, g_R1, g_p2, g_R2) = loss(xpos, xmat, wp.Tape())
    skew = np.cross(np.eye(3)[None, None, :, None, :], direction_rot[:, :, None, None, :])[..., 0, :]  # skew(d) rows
    along = (np.sum(g_p1 * direction_pos[:, 0], -1) + np.sum(g_p2 * direction_pos[:, 1], -1)
             + np.sum(g_R1 * (xmat[:, 0] @ skew[:, 0]), (-2, -1)) + np.sum(g_R2 * (xmat[:, 1] @ skew[:, 1]), (-2, -1)))  # fmt: skip
    steps = {h: loss(*moved(h), None)[:2] for h in (1e-6, -1e-6, 2e-6, -2e-6)}
    return {
        "along": along,
        "fd1": (steps[1e-6][0] - steps[-1e-6][0]) / 2e-6,
        "fd2": (steps[2e-6][0] - steps[-2e-6][0]) / 4e-6,
        "kink": np.abs(steps[1e-6][0] + steps[-1e-6][0] - 2.0 * value) / 1e-6,
        "count": count,
        "steps_keep_count": np.all([c == count for _, c in steps.values()], axis=0),
    }
