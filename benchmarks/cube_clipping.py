"""How far a fingertip pad that clips the cube throws it: PickCubeEnv's scene under scripted approaches, warpdyn's
soft law at several time steps, explicit and linearly implicit (model.implicit_contacts), beside MuJoCo (issue 37:
why PickCubeConfig steps at 2 ms with implicit contacts and D = 2000).

    python benchmarks/cube_clipping.py [--envs 24] [--time-steps 0.001,0.0005] [--damping D] [--seed 5]

What runs: PickCubeEnv's resets (seed --seed) put --envs cubes on the floor; from the keyframe "home" each arm's
position targets move the gripper site towards 12 cm above its cube by damped least squares on the site's position
alone (the hand tilts on the way, so that a pad often clips the cube's top edge), at most 0.04 rad per policy step,
for 22 policy steps (0.44 s), the gripper open. The controls are computed once (from the commanded joint positions:
the same for every simulator) and replayed in warpdyn (float64, PickCubeConfig's K and D (--damping: another D, as
2 ms needs for the deformation's dt K / D < 2), each --time-steps) and in
MuJoCo (the file's 1 ms, its implicit soft constraints); warpdyn's at each time step with explicit and with
implicit contacts. Prints, over the environments whose cube moved more than
1 mm in either simulator, the median and mean displacement of the cube [mm] and how many moved more than 2 cm.
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
from warpdyn.envs.manipulation import _gripper_frame

STEPS = 22


def approach_controls(N: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """(the cubes' positions (N, 3) [m], the controls (STEPS, N, 8)) of the scripted approaches."""
    env = envs.PickCubeEnv(N, dtype=np.float64, device="cpu", seed=seed)
    env.reset(seed=seed)
    model = env.model
    cubes = wp.to_torch(env.stepper.data.joint_positions_state)[:, env._cube : env._cube + 3].numpy().copy()
    data = wd.data.keyframe(model, "home", num_envs=8)
    site = wd.link.FrameMotion(model, num_envs=8, **_gripper_frame(model))
    q = wp.to_torch(data.joint_positions_state)
    arm = env._arm.numpy()
    ctrl = env._ctrl.numpy().copy()
    out = []
    for _ in range(STEPS):
        for e in range(N):  # the site's position and its Jacobian by forward differences at the commanded joints
            Q = np.tile(q[0].numpy(), (8, 1))
            Q[:, arm] = ctrl[e, :7]
            Q[np.arange(1, 8), arm] += 1e-6
            q.copy_(torch.from_numpy(Q))
            p = wp.to_torch(site(data)[0])[:, :3, 3].numpy()
            J = ((p[1:] - p[0]) / 1e-6).T
            dq = J.T @ np.linalg.solve(J @ J.T + 1e-4 * np.eye(3), cubes[e] + [0.0, 0.0, 0.12] - p[0])
            ctrl[e, :7] += np.clip(dq, -0.04, 0.04)
        ctrl[:, 7] = 0.04
        out.append(ctrl.copy())
    return cubes, np.array(out)


def warpdyn_displacements(cubes: np.ndarray, controls: np.ndarray, time_step: float, implicit: bool, seed: int, damping: float) -> np.ndarray:
    """(N,) [m]: each cube's displacement after the approach in warpdyn at `time_step`, its contacts implicit or not."""
    config = envs.PickCubeConfig(time_step=time_step, implicit_contacts=implicit, contact_damping=damping)
    env = envs.PickCubeEnv(len(cubes), config, dtype=np.float64, device="cpu", seed=seed)
    env.reset(seed=seed)
    for ctrl in controls:
        env.step(((torch.from_numpy(ctrl) - env._ctrl) / env.cfg.action_scale).clamp(-1.0, 1.0).float())
    q = wp.to_torch(env.stepper.data.joint_positions_state)[:, env._cube : env._cube + 3].numpy()
    return np.linalg.norm(q - cubes, axis=1)


def mujoco_displacements(cubes: np.ndarray, controls: np.ndarray) -> np.ndarray:
    """(N,) [m]: the same in MuJoCo, the file's time step, one environment at a time."""
    m = mujoco.MjModel.from_xml_path(str(wd.assets.franka_panda_cube_mjcf()))
    d = mujoco.MjData(m)
    substeps = int(round(envs.PickCubeConfig().policy_dt / m.opt.timestep))
    moved = []
    for e, cube in enumerate(cubes):
        mujoco.mj_resetDataKeyframe(m, d, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_KEY, "home"))
        d.qpos[9:12] = cube
        mujoco.mj_forward(m, d)
        for ctrl in controls[:, e]:
            d.ctrl[:] = ctrl
            mujoco.mj_step(m, d, substeps)
        moved.append(np.linalg.norm(d.qpos[9:12] - cube))
    return np.array(moved)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--envs", type=int, default=24)
    parser.add_argument("--time-steps", default="0.001,0.0005")
    parser.add_argument("--damping", type=float, default=envs.PickCubeConfig().contact_damping, help="the soft law's D [N s/m^1.5]")
    parser.add_argument("--seed", type=int, default=5)
    args = parser.parse_args()
    wp.config.quiet = True
    warnings.simplefilter("ignore", wd.model.NotModelledWarning)
    cubes, controls = approach_controls(args.envs, args.seed)
    reference = mujoco_displacements(cubes, controls)
    rows = [("MuJoCo (1 ms, implicit)", reference)]
    for dt in args.time_steps.split(","):
        for implicit in (False, True):
            name = f"warpdyn {float(dt) * 1e3:g} ms {'implicit' if implicit else 'explicit'}"
            rows.append((name, warpdyn_displacements(cubes, controls, float(dt), implicit, args.seed, args.damping)))
    touched = np.any([moved > 1e-3 for _, moved in rows], axis=0)
    print(f"{args.envs} scripted approaches, {touched.sum()} touched the cube (moved > 1 mm in one simulator at least)")
    for name, moved in rows:
        m = moved[touched] * 1e3
        print(f"{name:>28}: median {np.median(m):6.1f} mm, mean {m.mean():6.1f} mm, {int((moved > 0.02).sum())} moved > 2 cm")


if __name__ == "__main__":
    main()
