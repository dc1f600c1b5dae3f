"""Train the seed's ergoCub legs to stand under pushes (or walk on command) with rsl-rl's PPO on warpdyn.envs.

    pip install -e ".[rl,viz,examples]"
    python examples/rl_ergocub.py --task stand --iterations 300 --out runs/stand       # a GPU: N = 4096
    python examples/rl_ergocub.py --task stand --replay runs/stand/policy.pt --out runs/stand   # a recording

Environment (`warpdyn.envs.LeggedEnv`): the ergoCub legs (12 joints, floating base, the 32 corners of the foot
boxes on flat ground), a position servo per joint (kp 300 N m/rad, joint damping 5 N m s/rad, implicit), the
policy at 50 Hz over 10 simulation steps of 2 ms (soft contacts K = 1e5), actions = joint targets around the
straight stance (0.25 rad per unit). Episodes of 20 s, ended by a fall; each reset draws a yaw, joint offsets
(0.1 rad), link masses (x 0.9..1.1) and friction (0.5..1.0). `stand`: zero commands, a push of up to 0.5 m/s
every 4 s. `walk`: forward commands of 0..0.5 m/s. Trainer: rsl-rl-lib's PPO (the one Isaac Lab and mjlab
use): 24 steps per environment and iteration, 5 epochs of 4 mini-batches, MLP (256, 128, 64) actor and
critic with observation normalisation.

Prints, per iteration: the mean return and length of the episodes completed in it, env-steps/s (policy
steps x N and simulation steps, collection and update included) and the wall time; writes
`<out>/policy.pt` (rsl-rl's checkpoint), `<out>/rewards.png` (mean return per iteration) and, with
--replay, `<out>/policy.rrd` (rerun: one environment for 10 s under the trained policy).
"""

from __future__ import annotations

import argparse
import pathlib
import time

import numpy as np
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.envs.rsl_rl import RslRlVecEnv

TASKS = {
    "stand": dict(push_velocity=0.5, push_seconds=4.0),
    "walk": dict(lin_vel_x=(0.0, 0.5), push_velocity=0.2),
}


def make_env(task: str, num_envs: int, device, seed: int) -> envs.LeggedEnv:
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), device=device)
    legs = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    cfg = envs.LeggedEnvConfig(mass_scale=(0.9, 1.1), friction=(0.5, 1.0), **TASKS[task])
    return envs.LeggedEnv(legs, num_envs=num_envs, cfg=cfg, seed=seed)


def train_config(iterations: int) -> dict:
    mlp = dict(hidden_dims=[256, 128, 64], activation="elu", obs_normalization=True)
    return {
        "num_steps_per_env": 24,
        "save_interval": max(1, iterations),
        "obs_groups": {"actor": ["policy"], "critic": ["policy"]},
        "algorithm": dict(
            class_name="PPO", learning_rate=1e-3, num_learning_epochs=5, num_mini_batches=4, clip_param=0.2, gamma=0.99,
            lam=0.95, value_loss_coef=1.0, entropy_coef=0.005, max_grad_norm=1.0, schedule="adaptive", desired_kl=0.01,
        ),  # fmt: skip
        "actor": dict(class_name="MLPModel", distribution_cfg=dict(class_name="GaussianDistribution", init_std=1.0), **mlp),
        "critic": dict(class_name="MLPModel", **mlp),
        "multi_gpu": None,
    }


def train(env: envs.LeggedEnv, iterations: int, out: pathlib.Path, torch_device: str) -> list:
    """rsl-rl's PPO for `iterations`; returns [(iteration, mean return, env-steps/s, seconds)]."""
    from rsl_rl.runners import OnPolicyRunner

    vec = RslRlVecEnv(env)
    cfg = train_config(iterations)
    runner = OnPolicyRunner(vec, cfg, log_dir=None, device=torch_device)
    alg = runner.alg
    alg.train_mode()
    obs = vec.get_observations().to(torch_device)
    history, start = [], time.perf_counter()
    steps = cfg["num_steps_per_env"]
    for it in range(iterations):
        t0 = time.perf_counter()
        with torch.inference_mode():
            for _ in range(steps):
                actions = alg.act(obs)
                obs, rewards, dones, extras = vec.step(actions.to(env.device))
                obs, rewards, dones = obs.to(torch_device), rewards.to(torch_device), dones.to(torch_device)
                alg.process_env_step(obs, rewards, dones, extras)
            alg.compute_returns(obs)
        alg.update()
        stats = env.episode_statistics()
        seconds = time.perf_counter() - t0
        rate = steps * env.num_envs / seconds
        history.append((it, stats["mean_return"], rate, time.perf_counter() - start))
        print(
            f"iteration {it:4d}  mean return {stats['mean_return']:8.3f}  mean length {stats['mean_length']:7.1f}  "
            f"{rate / 1e3:8.1f} k env-steps/s ({rate * env.decimation / 1e6:6.2f} M sim steps/s)  {history[-1][3]:7.1f} s",
            flush=True,
        )
    out.mkdir(parents=True, exist_ok=True)
    runner.save(str(out / "policy.pt"))
    return history


def plot(history: list, path: pathlib.Path, title: str) -> None:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot")
        return
    it, ret, _, seconds = (np.array(x, dtype=float) for x in zip(*history))
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(seconds, ret)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("mean episode return")
    ax.set_title(title)
    ax.grid(True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def replay(task: str, policy_path: pathlib.Path, out: pathlib.Path, device, seed: int, seconds: float = 10.0) -> None:
    """Run the trained policy on one environment and record it with rerun."""
    from rsl_rl.runners import OnPolicyRunner

    import warpdyn.visualization as viz

    env = make_env(task, 1, device, seed)
    vec = RslRlVecEnv(env)
    runner = OnPolicyRunner(vec, train_config(1), log_dir=None, device=str(env.device))
    runner.load(str(policy_path))
    policy = runner.get_inference_policy(device=str(env.device))
    obs = vec.get_observations()
    path = out / "policy.rrd"
    with viz.RerunRecorder(env.model, path=path, meshes=False) as recorder:  # the seed's URDF comes without its meshes
        for k in range(int(seconds / env.cfg.policy_dt)):
            with torch.inference_mode():
                obs, _, _, _ = vec.step(policy(obs))
            recorder.log(env.stepper.data, time=k * env.cfg.policy_dt)
    print(f"wrote {path}")


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--task", choices=sorted(TASKS), default="stand")
    parser.add_argument("--device", default=None, help="Warp device (default: a GPU if there is one)")
    parser.add_argument("--num-envs", type=int, default=None, help="default: 4096 on a GPU, 64 on the CPU")
    parser.add_argument("--iterations", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="runs/ergocub")
    parser.add_argument("--replay", default=None, help="a policy.pt to record instead of training")
    args = parser.parse_args(argv)
    wp.config.quiet = True
    device = wp.get_device(args.device)
    out = pathlib.Path(args.out)
    torch.manual_seed(args.seed)
    if args.replay:
        replay(args.task, pathlib.Path(args.replay), out, device, args.seed)
        return None
    N = args.num_envs or (4096 if device.is_cuda else 64)
    env = make_env(args.task, N, device, args.seed)
    print(f"{args.task}: {N} environments on {device.name}, {env.single_observation_space.shape[0]} observations, "
          f"{env.single_action_space.shape[0]} actions, policy at {1 / env.cfg.policy_dt:g} Hz over {env.decimation} steps")  # fmt: skip
    history = train(env, args.iterations, out, str(env.device))
    plot(history, out / "rewards.png", f"ergoCub legs, {args.task}: {N} environments on {device.name}")
    return history


if __name__ == "__main__":
    main()
