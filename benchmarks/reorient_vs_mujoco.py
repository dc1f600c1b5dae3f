"""The LEAP scene's cube under the same open-loop actions in warpdyn's CubeReorientEnv and in MuJoCo at Playground's
settings: how much the cube turns, moves and drops, and how far the fingers pass their joints' ranges.

    python benchmarks/reorient_vs_mujoco.py --envs 32 --seconds 5

Each of --envs hands starts from the environment's reset (its bank of non-penetrating draws: the same joint positions
and targets in both) and takes the same smooth random actions (a_t = 0.8 a_{t-1} + 0.6 N(0, 1), clipped to [-1, 1],
one draw for both simulators) for --seconds of policy steps: warpdyn through CubeReorientEnv.step (its defaults: 2 ms,
the soft law, linearly implicit contacts), MuJoCo as Playground's LeapCubeReorient steps it (the same MJCF with its
timestep 10 ms and ccd_iterations 10, the targets moved by 0.5 x the action and clipped to the control ranges, 5
steps per policy step), a hand whose cube falls below z = -0.05 m restarting from its reset in both. Prints the
cube's angle turned per policy step (median, mean, 90th percentile [rad]), the fraction of hands that dropped it, its
mean height [m] and its mean horizontal distance from its start after --seconds [m]; and of the hand's 16 joints at
the policy steps, the fraction past their ranges by more than 0.01 rad and the largest excess [rad] (MuJoCo's limit
constraints act in both; --no-limits: warpdyn's off, model.limit_constraints; the joints' frictionloss MuJoCo's
friction constraints in both, --static-friction: warpdyn's JaxSim's static friction instead). A statistic, not a
trajectory: contacts make the two diverge within steps.
"""

from __future__ import annotations

import argparse
import warnings

import mujoco
import numpy as np
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs


def smooth_actions(steps: int, n: int, seed: int) -> np.ndarray:
    """(steps, n, 16) actions in [-1, 1]: a_t = 0.8 a_{t-1} + 0.6 N(0, 1), clipped."""
    noise = np.random.default_rng(seed).normal(size=(steps, n, 16))
    out, a = np.zeros_like(noise), np.zeros((n, 16))
    for t in range(steps):
        a = 0.8 * a + 0.6 * noise[t]
        out[t] = np.clip(a, -1.0, 1.0)
    return out


def warpdyn_run(env, actions: np.ndarray, cube: slice, hand: np.ndarray) -> tuple:
    """(cube poses (steps, n, 7) before each step, dropped (n,) bool, hand joint positions (steps, n, 16)) in `env`
    under `actions`; hand: the hand joints' columns of the joint positions."""
    poses, joints, dropped = [], [], np.zeros(actions.shape[1], dtype=bool)
    for a in actions:
        q = env.stepper.data.joint_positions.numpy()
        poses.append(q[:, cube].copy())
        joints.append(q[:, hand].copy())
        _, _, terminated, _, _ = env.step(torch.tensor(a, dtype=torch.float32))
        dropped |= terminated.cpu().numpy()
    return np.array(poses), dropped, np.array(joints)


def mujoco_run(m, q0: np.ndarray, ctrl0: np.ndarray, actions: np.ndarray, cube: int, hand: np.ndarray) -> tuple:
    """(cube poses (steps, n, 7), dropped (n,) bool, hand joint positions (steps, n, 16)) in MuJoCo from the qpos rows
    q0 (n, nq) and targets ctrl0 (n, nu); hand: the hand joints' qpos addresses."""
    d = mujoco.MjData(m)
    low, high = m.actuator_ctrlrange[:, 0], m.actuator_ctrlrange[:, 1]
    poses, dropped = np.zeros((*actions.shape[:2], 7)), np.zeros(actions.shape[1], dtype=bool)
    joints = np.zeros((*actions.shape[:2], len(hand)))
    for e in range(actions.shape[1]):
        d.qpos[:], d.qvel[:], d.ctrl[:] = q0[e], 0.0, ctrl0[e]
        for t, a in enumerate(actions[:, e]):
            poses[t, e] = d.qpos[cube : cube + 7]
            joints[t, e] = d.qpos[hand]
            d.ctrl[:] = np.clip(d.ctrl + 0.5 * a, low, high)
            for _ in range(5):
                mujoco.mj_step(m, d)
            if d.qpos[cube + 2] < -0.05:
                dropped[e] = True
                d.qpos[:], d.qvel[:], d.ctrl[:] = q0[e], 0.0, ctrl0[e]
    return poses, dropped, joints


def summary(poses: np.ndarray, dropped: np.ndarray, joints: np.ndarray, ranges: np.ndarray) -> str:
    """The printed statistics of cube poses (steps, n, 7) (position, quaternion w, x, y, z) and hand joint positions
    (steps, n, 16) against their ranges (16, 2)."""
    excess = np.maximum(np.maximum(joints - ranges[:, 1], ranges[:, 0] - joints), 0.0)
    dots = np.abs(np.sum(poses[1:, :, 3:] * poses[:-1, :, 3:], axis=-1)).clip(max=1.0)
    turn = 2.0 * np.arccos(dots)
    moved = np.linalg.norm(poses[-1, :, :2] - poses[0, :, :2], axis=-1).mean()
    return (f"turn per policy step median {np.median(turn):.4f} mean {turn.mean():.4f} p90 {np.quantile(turn, 0.9):.4f} rad; "
            f"dropped {dropped.mean():.2f}; mean height {poses[..., 2].mean():.4f} m; moved {moved:.4f} m; "
            f"joints past their range by > 0.01 rad {(excess > 0.01).mean():.4f}, by at most {excess.max():.3f} rad")  # fmt: skip


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", type=int, default=32)
    parser.add_argument("--seconds", type=float, default=5.0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--no-limits", action="store_true", help="warpdyn without MuJoCo's limit constraints")
    parser.add_argument("--static-friction", action="store_true", help="warpdyn's frictionloss as JaxSim's static friction")
    args = parser.parse_args(argv)
    wp.config.quiet = True
    cfg = envs.CubeReorientConfig(limit_constraints=not args.no_limits, frictionloss_constraints=not args.static_friction)
    env = envs.CubeReorientEnv(args.envs, cfg=cfg, device=args.device, seed=args.seed)
    env.reset(seed=args.seed)
    actions = smooth_actions(int(round(args.seconds / env.cfg.policy_dt)), args.envs, args.seed)
    m = mujoco.MjModel.from_xml_path(str(wd.assets.leap_hand_cube_mjcf()))
    m.opt.timestep, m.opt.ccd_iterations = 0.01, 10  # Playground's sim_dt and ccd_iterations
    model, names = env.model, env.model.joint_names()
    q = env.stepper.data.joint_positions.numpy()
    q0 = np.zeros((args.envs, m.nq))
    for j in range(m.njnt):  # warpdyn's joint positions to MuJoCo's qpos, joint by joint
        s = wd.joint.position_slice(model, joint_index=names.index(m.joint(j).name))
        q0[:, m.jnt_qposadr[j] : m.jnt_qposadr[j] + s.stop - s.start] = q[:, s]
    ctrl0 = wp.to_torch(env.stepper.ctrl).cpu().numpy().astype(np.float64)
    cube = wd.joint.position_slice(model, joint_index=names.index("cube_freejoint"))
    fingers = [j for j in range(m.njnt) if m.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    ranges = np.array([m.jnt_range[j] for j in fingers])
    hand = np.array([wd.joint.position_slice(model, joint_index=names.index(m.joint(j).name)).start for j in fingers])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ours = warpdyn_run(env, actions, cube, hand)
    theirs = mujoco_run(m, q0, ctrl0, actions, int(m.joint("cube_freejoint").qposadr[0]), np.array([m.jnt_qposadr[j] for j in fingers]))
    print(f"{args.envs} hands, {args.seconds:g} s of smooth random actions (seed {args.seed})")
    limits = "limits on" if env.model.limit_constraints else "limits off"
    friction = "friction rows" if env.model.frictionloss_constraints else "static friction"
    print(f"warpdyn ({env.cfg.time_step * 1e3:g} ms, soft law, {limits}, {friction}): {summary(*ours, ranges)}")
    print(f"MuJoCo  (10 ms, Playground's):      {summary(*theirs, ranges)}")


if __name__ == "__main__":
    main()
