"""Functions of joints, as JaxSim's `jaxsim.api.joint`. Joint i moves link i + 1.

The position limits are the model's (`model.position_limits`, set with `Model.set_joint_parameters`), as
the step reads them: the description's until changed. A joint has one position and one velocity, but a ball
joint (4 positions, a unit quaternion (w, x, y, z); 3 velocities) and a free joint (7 and 6, MuJoCo's):
`position_slice` and `velocity_slice` say where a joint's are in `joint_positions` and `joint_velocities`.
"""

from __future__ import annotations

import numpy as np

from .description.tree import JOINT_BALL, JOINT_FREE, JOINT_REVOLUTE
from .types import names as _names

__all__ = [
    "name_to_idx",
    "idx_to_name",
    "names_to_idxs",
    "idxs_to_names",
    "position_slice",
    "velocity_slice",
    "position_limit",
    "position_limits",
    "random_joint_positions",
    "random_generator",
]


def name_to_idx(model, *, joint_name: str) -> int:
    return _names.name_to_idx("joint", model.joint_names(), joint_name)


def idx_to_name(model, *, joint_index: int) -> str:
    return model.joint_names()[_names.check_idx("joint", model.number_of_joints(), joint_index)]


def names_to_idxs(model, *, joint_names) -> np.ndarray:
    return np.array([name_to_idx(model, joint_name=name) for name in joint_names], dtype=int)


def idxs_to_names(model, *, joint_indices) -> tuple[str, ...]:
    return tuple(idx_to_name(model, joint_index=int(i)) for i in np.asarray(joint_indices).ravel())


def position_slice(model, *, joint_index: int) -> slice:
    """Where joint `joint_index`'s positions are in `data.joint_positions` (MuJoCo's jnt_qposadr): 1 number, 4
    for a ball joint (its quaternion (w, x, y, z)), 7 for a free one (position, then quaternion)."""
    i = _names.check_idx("joint", model.number_of_joints(), joint_index) + 1
    return slice(int(model.tree.q_start[i]), int(model.tree.q_start[i + 1]))


def velocity_slice(model, *, joint_index: int) -> slice:
    """Where joint `joint_index`'s velocities (DoFs) are in `data.joint_velocities`, the joint forces and the
    generalized velocity's joint part (MuJoCo's jnt_dofadr): 1, 3 for a ball joint (its angular velocity in the
    child's axes), 6 for a free one (MuJoCo's: the linear velocity in the parent's axes, then the angular
    velocity in the child's)."""
    i = _names.check_idx("joint", model.number_of_joints(), joint_index) + 1
    return slice(int(model.tree.v_start[i]), int(model.tree.v_start[i + 1]))


def _limits(model) -> np.ndarray:
    """The model's position limits (n, 2), or (N, n, 2) when given per environment [rad or m]."""
    return model.parameter_host("position_limits")


def position_limit(model, *, joint_index: int):
    """(lower, upper) position limit of one joint [rad or m]; -inf/inf where it has none. Floats, or (N,)
    arrays when the limits are given per environment."""
    limits = _limits(model)[..., _names.check_idx("joint", model.number_of_joints(), joint_index), :]
    lower, upper = limits[..., 0], limits[..., 1]
    return (float(lower), float(upper)) if limits.ndim == 1 else (lower.copy(), upper.copy())


def position_limits(model, *, joint_names=None) -> tuple[np.ndarray, np.ndarray]:
    """(lower (k,), upper (k,)) position limits of the named joints (all when None) [rad or m]; (N, k) each
    when the limits are given per environment; -inf/inf for ball and free joints."""
    idxs = np.arange(model.number_of_joints()) if joint_names is None else names_to_idxs(model, joint_names=joint_names)
    limits = _limits(model)[..., idxs, :]
    return limits[..., 0].copy(), limits[..., 1].copy()


def random_generator(key) -> np.random.Generator:
    """A NumPy generator from JaxSim's `key`: None (seed 0, as JaxSim), an integer seed, a NumPy Generator
    (used as it is), or a JAX PRNG key (its bits seed the generator). warpdyn draws from the same
    distributions as JaxSim, not the same numbers (JAX's generator is not NumPy's)."""
    if key is None:
        return np.random.default_rng(0)
    if isinstance(key, np.random.Generator):
        return key
    if isinstance(key, (bool, np.bool_)):
        raise TypeError(f"key must be an integer seed, a NumPy Generator or a JAX PRNG key, got {key!r}")
    if isinstance(key, (int, np.integer)):
        return np.random.default_rng(int(key))
    bits = np.asarray(key)  # a JAX PRNG key from jax.random.PRNGKey: unsigned 32-bit words
    if bits.dtype.kind not in "iu" or bits.size == 0:
        raise TypeError(
            f"key must be an integer seed, a NumPy Generator or a JAX PRNG key (uint32 words; a typed key: pass "
            f"jax.random.key_data(key)), got {type(key).__name__}"
        )
    return np.random.default_rng([int(b) for b in bits.reshape(-1)])


def random_joint_positions(model, *, joint_names=None, key=None, num_envs: int | None = None) -> np.ndarray:
    """Random positions of the named joints (all when None), concatenated in their order: (k,) for k positions
    (one per revolute or prismatic joint, 4 per ball joint, 7 per free one) [rad or m], JaxSim's draw: uniform
    within the model's position limits; a revolute joint whose range spans 2 pi or more is drawn from an
    interval of 2 pi inside its range ([-pi, pi] when that fits); a prismatic joint without limits from
    [-1, 1] m (JaxSim's draws infinities there), limited on one side only from 2 m beside that limit. A ball
    joint's quaternion is drawn uniformly over the rotations, a free joint's position in [-1, 1]^3 m and its
    quaternion likewise. key: see `random_generator`. num_envs: (N, k), one draw per environment (each within
    its limits when they are given per environment)."""
    idxs = np.arange(model.number_of_joints()) if joint_names is None else names_to_idxs(model, joint_names=joint_names)
    low, high = position_limits(model, joint_names=joint_names)
    if num_envs is not None:
        low, high = np.broadcast_to(low, (num_envs, len(idxs))), np.broadcast_to(high, (num_envs, len(idxs)))
    elif low.ndim > 1:
        raise ValueError("random_joint_positions: the model's limits are given per environment: pass num_envs")
    kinds = model.tree.joint_type[1:][idxs]
    revolute = kinds == JOINT_REVOLUTE
    full = revolute & (high - low >= 2 * np.pi)
    inside = full & (low <= -np.pi) & (high >= np.pi)
    low, high = np.where(inside, -np.pi, low), np.where(inside, np.pi, high)
    low = np.where(full & ~inside & (high < np.pi), high - 2 * np.pi, low)
    high = np.where(full & ~inside & (low > -np.pi), low + 2 * np.pi, high)
    low, high = np.where(np.isfinite(low), low, np.where(np.isfinite(high), high - 2.0, -1.0)), np.where(np.isfinite(high), high, np.where(np.isfinite(low), low + 2.0, 1.0))
    rng = random_generator(key)
    one = rng.uniform(low, high)  # every joint's draw as a one-DoF joint; a ball or free joint's is replaced
    if not np.any((kinds == JOINT_BALL) | (kinds == JOINT_FREE)):
        return one
    shape = one.shape[:-1]
    parts = []
    for k, kind in enumerate(kinds):
        if kind == JOINT_BALL:
            parts.append(_random_quaternions(rng, shape))
        elif kind == JOINT_FREE:
            parts += [rng.uniform(-1.0, 1.0, (*shape, 3)), _random_quaternions(rng, shape)]
        else:
            parts.append(one[..., k : k + 1])
    return np.concatenate(parts, axis=-1)


def _random_quaternions(rng: np.random.Generator, shape: tuple) -> np.ndarray:
    """Unit quaternions (w, x, y, z) (*shape, 4) uniform over the rotations (normalised Gaussian draws)."""
    q = rng.standard_normal((*shape, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)
