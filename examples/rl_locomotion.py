"""Train a legged robot to stand under pushes or walk on command with rsl-rl's PPO on warpdyn.envs: the seed's
ergoCub legs (shipped) or the Unitree Go1 quadruped (from the pip package example-robot-data). The PPO is
warpdyn.envs.rsl_rl.GraphedPPO (rsl-rl's, replayed as CUDA graphs on a GPU; `--ppo rsl-rl`: rsl-rl's own), in one
process or several.

    pip install -e ".[rl,viz,examples]"
    python examples/rl_locomotion.py --robot ergocub --task stand --iterations 300 --out runs/stand   # a GPU: N = 4096
    python examples/rl_locomotion.py --robot go1 --task walk --max-minutes 4 --evaluate 0.5 --out runs/go1
    python examples/rl_locomotion.py --robot go1 --task walk --replay runs/go1/policy.pt --out runs/go1   # a recording
    python examples/rl_locomotion.py --robot anymal_c --task walk --max-minutes 2 --evaluate 1.0 --out runs/anymal   # also go2
    python examples/rl_locomotion.py --robot anymal_c --task rough --iterations 100000 --max-minutes 10 --out runs/rough

On K GPUs of one host (data parallel, torch.distributed with NCCL):

    torchrun --standalone --nproc_per_node K examples/rl_locomotion.py --task stand --iterations 300 --out runs/stand

Rank r simulates its own `--num-envs` environments (the number is PER RANK: K x N in all; pass N / K to keep
the total batch) on Warp device and torch device `cuda:<LOCAL_RANK>`, seeded with `--seed + r` (the
environments' resets and the torch generator, hence the actions' noise); rank 0's initial parameters are
broadcast, the PPO (GraphedPPO inside its graphs, or rsl-rl's with `--ppo rsl-rl`) averages the gradients, the KL
divergence (adaptive learning rate) and the observation normaliser's statistics over the ranks, so every rank holds the same policy (checked at the end:
the run fails if the ranks' parameters differ by more than 1e-5). Only rank 0 prints, saves and plots. On
the CPU (`--device cpu`) the same runs with the gloo backend, e.g. `torchrun --standalone --nproc_per_node 2
examples/rl_locomotion.py --device cpu --num-envs 8 --iterations 2` (tests/test_rl_distributed.py). The process
group is initialised here (nccl on GPUs, gloo on the CPU) and the PPO built with rsl-rl's
`PPO.construct_algorithm` and its `multi_gpu` configuration: rsl-rl's OnPolicyRunner would initialise NCCL
itself and accepts only `cuda:<LOCAL_RANK>`.

Environments (`warpdyn.envs.LeggedEnv`, the robots warpdyn.envs.robots' presets, the tasks' settings in TASKS): flat ground, soft contacts K = 1e5, the policy at
50 Hz, actions = joint targets around a default posture (0.25 rad per unit) for a position servo per joint
with implicit joint damping; episodes of 20 s, ended by a fall; each reset draws a yaw, joint offsets (0.1
rad), link masses (x 0.9..1.1) and friction. ergoCub legs: 12 joints, the 32 corners of the foot boxes, kp
300 N m/rad, damping 5 N m s/rad, 10 steps of 2 ms per action, straight stance. Go1: 12 joints, the lower
halves of the four foot spheres (9 points each), kp 20, damping 0.5, servo torques clipped at 23.7 N m, 10
steps of 2 ms per action, GO1_STANDING_POSE, Rudin et al.'s flat-ground rewards (velocity tracking, feet air
time, penalties on vertical and roll/pitch velocity, torque and action rate). `stand`: zero commands, a push
of up to 0.5 m/s every 4 s of each episode. `walk`: ergoCub: forward commands of 0..0.5 m/s, feet air time
rewarded; Go1: vx in [-1, 1], vy in [-0.5, 0.5] m/s, yaw rate in [-1, 1] rad/s, redrawn every 10 s. `rough` (the ANYmal C):
vx and vy in [-1, 1] m/s and no yaw rate (the curriculum promotes by the distance walked from the origin: at
1 m/s and 1 rad/s a robot walks a circle 2 m across; legged_gym commands a heading instead, which
LeggedEnvConfig.heading_command offers) on Rudin et al.'s
curriculum over ROUGH_TERRAIN, ROUGH_OBSERVATIONS (the height
scan), ROUGH_REWARDS (thighs touching penalised: ROUGH_LINKS touch the terrain too), falls judged above the terrain
under the base at 0.4 x the standing height; each iteration prints the mean terrain level. `--evaluate
SPEED` then commands SPEED m/s straight ahead and prints the forward speed reached. Trainer: rsl-rl-lib's PPO (the one Isaac Lab and mjlab
use): 24 steps per environment and iteration, 5 epochs of 4 mini-batches (per rank), learning rate 1e-3 (adaptive),
MLP (256, 128, 64) actor and critic with observation normalisation, discount 0.99, entropy coefficient 0.005;
--steps-per-env, --epochs, --mini-batches, --learning-rate, --gamma, --entropy-coef and --clipped-value-loss (on: rsl-rl's
clipped value loss) change them (PPO_DEFAULTS).

Prints, per iteration: the mean return and length of the episodes completed in it (on all ranks), env-steps/s
(policy steps x N x K and simulation steps, collection and update included, over rank 0's wall time of the
iteration), the env-steps so far (all ranks) and the wall time since training started; at the end the total
env-steps. `--target-return R` stops at the first iteration whose mean return reaches R and prints that time
(time-to-reward; the compilation and set-up before the first iteration are not counted), `--max-minutes M`
after M minutes. Writes `<out>/policy.pt` (rsl-rl's checkpoint: OnPolicyRunner.load reads it),
`<out>/rewards.png` (mean return against wall time) and, with --replay (one process), `<out>/policy.rrd`
(rerun: one environment for 10 s under the trained policy).
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import io
import math
import os
import pathlib
import sys
import time

import numpy as np
import torch
import warp as wp

import warpdyn as wd
import warpdyn.envs as envs
from warpdyn.envs.rsl_rl import GraphedPPO, RslRlVecEnv

ERGOCUB_WALK_REWARDS = dict(
    envs.DEFAULT_REWARDS,
    feet_air_time=(envs.terms.feet_air_time, 1.0),
    angular_velocity_xy=(envs.terms.angular_velocity_xy_squared, -0.05),
)
ROBOTS = {"ergocub": envs.robots.ergocub_legs, "go1": envs.robots.go1, "anymal_c": envs.robots.anymal_c, "go2": envs.robots.go2}
"""The robots (warpdyn.envs.robots' presets: their description, feet, posture, gains and common settings)."""
TASKS = {
    "ergocub": dict(
        stand=dict(push_velocity=0.5, push_seconds=4.0),
        walk=dict(lin_vel_x=(0.0, 0.5), push_velocity=0.2, air_time_target=0.4, rewards=ERGOCUB_WALK_REWARDS),
    ),
    "go1": dict(
        stand=dict(push_velocity=0.5, push_seconds=4.0),
        walk=dict(lin_vel_x=(-1.0, 1.0), lin_vel_y=(-0.5, 0.5), yaw_rate=(-1.0, 1.0), push_velocity=0.5, push_seconds=8.0),
    ),
}
ROUGH_TERRAIN = envs.terrain_generator.TerrainConfig(
    levels=10, columns_per_kind=2,
    kinds=("pyramid_slope_up", "pyramid_slope_down", "random_rough", "stairs_up", "stairs_down", "discrete_obstacles"),
)  # fmt: skip
"""Rudin et al.'s rough terrain: 10 levels of slopes, rough ground, stairs and obstacles (8 m tiles, 12 columns)."""
ROUGH_OBSERVATIONS = (*(entry for entry in envs.DEFAULT_OBSERVATIONS if entry[0] is not envs.terms.base_height), (envs.terms.height_scan, 1.0))
"""The flat tasks' observations, the height scan (187 points) instead of the base's height above its origin."""
ROUGH_REWARDS = {
    **{name: term for name, term in envs.robots.GO1_REWARDS.items() if name not in ("upright", "height_error")},
    "torque": (envs.terms.torque_squared, -1e-5),
    "undesired_contacts": (envs.terms.undesired_contacts, -1.0),
}
"""Rudin et al.'s rough-terrain rewards: the flat ones without the height and tilt terms (slopes and stairs tilt
and lift the base), legged_gym's torque weight for the ANYmal (-1e-5: the flat tasks' -2e-4 on its torques cancels
the tracking terms, and a policy then learns to end its episodes), a penalty on thighs touching the terrain; each
step's total clipped at 0 (legged_gym's only_positive_rewards)."""
ROUGH_LINKS = {"anymal_c": ("LF_THIGH", "RF_THIGH", "LH_THIGH", "RH_THIGH")}
"""Per robot with a rough task, the links besides the feet that touch the terrain (their box corners)."""
TASKS["go2"] = TASKS["go1"]  # the quadrupeds share Rudin et al.'s flat-ground tasks
TASKS["anymal_c"] = dict(
    TASKS["go1"],
    rough=dict(
        terrain=ROUGH_TERRAIN, height_scan=((1.6, 1.0), 0.1), observations=ROUGH_OBSERVATIONS, rewards=ROUGH_REWARDS,
        undesired_contacts=ROUGH_LINKS["anymal_c"], lin_vel_x=(-1.0, 1.0), lin_vel_y=(-1.0, 1.0), yaw_rate=(0.0, 0.0),
        push_velocity=0.5, push_seconds=8.0, termination_height=0.4, only_positive_rewards=True,
    ),
)  # fmt: skip
"""Per robot, the LeggedEnvConfig settings of each task, over the preset's."""


def robot_model(robot: str, device) -> wd.model.Model:
    """The preset's model (warpdyn.envs.robots): the ergoCub legs, the ANYmal C and the Go2 (shipped), or the Go1 of
    example-robot-data; the quadrupeds with the lower halves of their four foot spheres as contacts."""
    return ROBOTS[robot]().model(device=device)


def make_env(task: str, num_envs: int, device, seed: int, robot: str = "ergocub", **overrides) -> envs.LeggedEnv:
    """`robot`'s LeggedEnv for `task` (the preset's settings, the task's, then `overrides`; on rough terrain the
    robot's ROUGH_LINKS touch it too)."""
    if task not in TASKS[robot]:
        raise ValueError(f"{robot} has no task {task!r} (its tasks: {', '.join(TASKS[robot])})")
    preset = ROBOTS[robot]()
    if task == "rough":
        preset = dataclasses.replace(preset, other_links=ROUGH_LINKS.get(robot, ()))
    model = preset.model(device=device)
    return envs.LeggedEnv(model, num_envs=num_envs, cfg=preset.config(model, **{**TASKS[robot][task], **overrides}), seed=seed)


PPO_DEFAULTS = dict(steps_per_env=24, epochs=5, mini_batches=4, learning_rate=1e-3, gamma=0.99, entropy_coef=0.005, clipped_value_loss=True)
"""The trainer's settings that set its time per iteration, its step size, its horizon, its exploration and whether a
value's update is clipped (rsl-rl's: at clip_param 0.2 per iteration, whatever the returns' scale; Brax's PPO does not
clip) (the CLI's --steps-per-env, --epochs, --mini-batches, --learning-rate, --gamma, --entropy-coef,
--clipped-value-loss on|off): Rudin et al.'s."""


ACTION_DISTRIBUTIONS = {
    "gaussian": dict(class_name="GaussianDistribution", init_std=1.0),
    "beta": dict(class_name="BetaDistribution", action_range=(-1.0, 1.0)),
}
"""The policy's action distributions (rsl-rl's): a Gaussian (Rudin et al.'s; its samples unbounded, the environments
clip them to [-1, 1]), or a Beta rescaled to [-1, 1] (bounded: its mean cannot drift past the clip, where a clipped
Gaussian's exploration no longer reaches the other end of the range; Chou et al. 2017)."""

SCHEDULES = ("adaptive", "fixed")
"""rsl-rl's learning-rate schedules: "adaptive" (Rudin et al.'s: the rate divided by 1.5 after an update whose KL
exceeded twice 0.01, multiplied by 1.5 below half of it, within [1e-5, 1e-2]) or "fixed" (Brax's PPO, which
Playground trains with, keeps its rate)."""

HIDDEN_DIMS = (256, 128, 64)
"""The actor's and the critic's MLP layers (Rudin et al.'s; --hidden-dims)."""


def check_layer_widths(widths) -> None:
    """A ValueError naming hidden_dims unless `widths` is a non-empty sequence of positive integers."""
    if not widths or not all(isinstance(w, int) and not isinstance(w, bool) and w > 0 for w in widths):
        raise ValueError(f"hidden_dims must be positive integer layer widths, got {widths!r}")


def train_config(
    iterations: int, distribution: str = "gaussian", graphed: bool = False, schedule: str = "adaptive", hidden_dims: tuple = HIDDEN_DIMS, **ppo
) -> dict:
    """rsl-rl's configuration: PPO_DEFAULTS' settings, those given in `ppo` replacing them, the actor's action
    `distribution` (ACTION_DISTRIBUTIONS), the learning rate's `schedule` (SCHEDULES), the actor's and the critic's MLP
    layers `hidden_dims`, the rest Rudin et al.'s (observation normalisation, an adaptive schedule's KL of 0.01); `graphed`:
    the algorithm is warpdyn.envs.rsl_rl.GraphedPPO (rsl-rl's PPO replayed as CUDA graphs on a GPU), else rsl-rl's PPO."""
    if distribution not in ACTION_DISTRIBUTIONS:
        raise ValueError(f"the action distribution is one of {sorted(ACTION_DISTRIBUTIONS)}, got {distribution!r}")
    if schedule not in SCHEDULES:
        raise ValueError(f"the learning-rate schedule is one of {list(SCHEDULES)}, got {schedule!r}")
    check_layer_widths(hidden_dims)
    unknown = sorted(set(ppo) - set(PPO_DEFAULTS))
    if unknown:
        raise TypeError(f"train_config takes the settings {sorted(PPO_DEFAULTS)}, got {unknown}")
    steps_per_env, epochs, mini_batches, learning_rate, gamma, entropy_coef, clipped = ({**PPO_DEFAULTS, **ppo}[name] for name in PPO_DEFAULTS)
    mlp = dict(hidden_dims=list(hidden_dims), activation="elu", obs_normalization=True)
    return {
        "num_steps_per_env": steps_per_env,
        "save_interval": max(1, iterations),
        "obs_groups": {"actor": ["policy"], "critic": ["policy"]},
        "algorithm": dict(
            class_name=GraphedPPO if graphed else "PPO", learning_rate=learning_rate, num_learning_epochs=epochs, num_mini_batches=mini_batches, clip_param=0.2, gamma=gamma,
            lam=0.95, value_loss_coef=1.0, entropy_coef=entropy_coef, max_grad_norm=1.0, schedule=schedule, desired_kl=0.01, use_clipped_value_loss=clipped,
        ),  # fmt: skip
        "actor": dict(class_name="MLPModel", distribution_cfg=dict(ACTION_DISTRIBUTIONS[distribution]), **mlp),
        "critic": dict(class_name="MLPModel", **mlp),
        "multi_gpu": None,
    }


def torchrun_ranks() -> tuple[int, int, int]:
    """(world size, rank, local rank) from torchrun's environment variables; (1, 0, 0) without torchrun."""
    return int(os.getenv("WORLD_SIZE", "1")), int(os.getenv("RANK", "0")), int(os.getenv("LOCAL_RANK", "0"))


def placement(N: int, device, world: int) -> str:
    """Where the environments run, for the printed header and the plot's title: "N environments on DEVICE", or
    under torchrun "K ranks x N environments on cuda:<LOCAL_RANK> (nccl)"."""
    if world == 1:
        return f"{N} environments on {device.name}"
    return f"{world} ranks x {N} environments on {'cuda:<LOCAL_RANK>' if device.is_cuda else device.name} ({torch.distributed.get_backend()})"


@contextlib.contextmanager
def torchrun_device(parser: argparse.ArgumentParser, name: str | None, seed: int):
    """Yields (the Warp device, world size, rank) of this process, torch seeded with `seed` + rank, Warp quiet. Under
    torchrun (world > 1): rank r runs on cuda:<LOCAL_RANK> (`name` None or "cuda"; another CUDA device is an error
    on `parser`) in an NCCL process group, or on the CPU (`name` "cpu", or no GPU) in a gloo one; the group is
    destroyed on leaving. Without torchrun: the device `name` (None: Warp's default)."""
    world, rank, local_rank = torchrun_ranks()
    wp.config.quiet = True
    if world > 1 and (name is None or name.startswith("cuda")) and wp.is_cuda_available():
        if name not in (None, "cuda", f"cuda:{local_rank}"):
            parser.error(f"under torchrun rank r runs on cuda:<LOCAL_RANK> (here cuda:{local_rank}): pass --device cuda, not {name}")
        name = f"cuda:{local_rank}"
    device = wp.get_device(name)
    torch.manual_seed(seed + rank)
    if world > 1:
        if device.is_cuda:
            wp.set_device(device)
            torch.cuda.set_device(device.ordinal)
            torch.distributed.init_process_group("nccl", device_id=torch.device(f"cuda:{device.ordinal}"))
        else:
            torch.distributed.init_process_group("gloo")  # the CPU: the same collectives, e.g. for tests
    try:
        yield device, world, rank
    finally:
        if world > 1:
            torch.distributed.destroy_process_group()


def _group() -> tuple[int, int]:
    """(world size, rank) of the initialised process group, (1, 0) without one."""
    if torch.distributed.is_available() and torch.distributed.is_initialized():
        return torch.distributed.get_world_size(), torch.distributed.get_rank()
    return 1, 0


def parameters_difference(alg) -> float:
    """The largest difference between this rank's actor and critic state (parameters and normaliser
    statistics) and rank 0's, over all ranks (collective: every rank calls it)."""
    saved = alg.save()
    tensors = [*saved["actor_state_dict"].values(), *saved["critic_state_dict"].values()]
    mine = torch.cat([t.detach().reshape(-1).to(torch.float64) for t in tensors])
    reference = mine.clone()
    torch.distributed.broadcast(reference, src=0)
    difference = (mine - reference).abs().max()
    torch.distributed.all_reduce(difference, op=torch.distributed.ReduceOp.MAX)
    return float(difference)


def train(
    env: envs.LeggedEnv,
    iterations: int,
    out: pathlib.Path,
    torch_device: str,
    target_return: float | None = None,
    max_minutes: float | None = None,
    ppo: dict | None = None,
    log_names: tuple = (),
    distribution: str = "gaussian",
    graphed: bool = True,
    resume: pathlib.Path | None = None,
    schedule: str = "adaptive",
    hidden_dims: tuple | None = None,
    random_episode_start: bool = False,
) -> list:
    """rsl-rl's PPO for `iterations` (fewer when `target_return` is reached or `max_minutes` pass; `ppo`: PPO_DEFAULTS'
    settings to change; `log_names`: entries of the environment's info["log"] whose mean over the iteration's steps
    each iteration's line prints, rank 0's; `distribution`: the actions', ACTION_DISTRIBUTIONS, kept in the
    checkpoint's infos for `load_policy`; `graphed`: GraphedPPO, else rsl-rl's own PPO; either
    averages over the ranks of a process group; `resume`: a policy.pt `train` saved, whose models, normalisers,
    optimizer state and learning rate the training continues from (with a fixed `schedule`, the rate is the `ppo`
    learning_rate instead), its iterations numbered on from the saved one: a long run split into several processes;
    `schedule`: the learning rate's, SCHEDULES; `hidden_dims`: the MLPs' layers (None: the checkpoint's on a resume,
    else HIDDEN_DIMS), kept with the distribution and the schedule in the checkpoint's infos; `random_episode_start`:
    the environments' episode counters drawn uniformly in [0, max_episode_length) first, so that their episodes end
    at different iterations (rsl-rl's OnPolicyRunner's init_at_random_ep_len, which legged_gym sets; the first
    episodes' lengths then count from the drawn start)); returns
    [(iteration, mean return, env-steps/s, seconds, mean terrain level or NaN)], the returns, rates and levels over all ranks when a process
    group is initialised (then every rank calls this with its own environments and rank 0 saves)."""
    from rsl_rl.algorithms import PPO

    world, rank = _group()
    vec = RslRlVecEnv(env)
    saved = None if resume is None else torch.load(resume, map_location=torch_device, weights_only=False)
    if saved is not None:
        kind, dims = saved_policy_kind(saved)
        if kind != distribution:
            raise ValueError(f"{resume}: its policy is {kind}, not the --action-distribution {distribution} asked for")
        if hidden_dims is not None and tuple(hidden_dims) != dims:
            raise ValueError(f"{resume}: its networks' layers are {dims}, not the --hidden-dims {tuple(hidden_dims)} asked for")
        hidden_dims = dims
    hidden_dims = HIDDEN_DIMS if hidden_dims is None else tuple(hidden_dims)
    cfg = train_config(iterations, distribution, graphed, schedule, hidden_dims, **(ppo or {}))
    cfg["obs_groups"] = vec.obs_groups
    if world > 1:  # the PPO then averages gradients, KL and normaliser statistics over the ranks
        cfg["multi_gpu"] = {"global_rank": rank, "local_rank": torchrun_ranks()[2], "world_size": world}
    quiet = contextlib.redirect_stdout(io.StringIO()) if rank else contextlib.nullcontext()
    with quiet:  # construct_algorithm prints the models
        alg = PPO.construct_algorithm(vec.get_observations(), vec, cfg, torch_device)  # as OnPolicyRunner does
    alg.train_mode()
    first = 0
    if saved is not None:
        if schedule == "fixed":  # the rate asked for, not the one an adaptive schedule left in the optimizer's state
            for group in saved["optimizer_state_dict"]["param_groups"]:
                group["lr"] = cfg["algorithm"]["learning_rate"]
        alg.load(saved, None, strict=True)
        first = int(saved["iter"]) + 1
    if random_episode_start:
        vec.episode_length_buf = torch.randint_like(env.episode_length_buf, high=int(env.max_episode_length))
    if world > 1:
        alg.broadcast_parameters()  # rank 0's initial parameters everywhere (as OnPolicyRunner.learn does)
    obs = vec.get_observations().to(torch_device)
    history, start, total_steps, reached = [], time.perf_counter(), 0, None
    steps = cfg["num_steps_per_env"]
    for it in range(first, first + iterations):
        t0 = time.perf_counter()
        logged = {name: 0.0 for name in log_names}
        with torch.inference_mode():
            for _ in range(steps):
                actions = alg.act(obs)
                obs, rewards, dones, extras = vec.step(actions.to(env.device))
                for name in log_names:
                    logged[name] = logged[name] + extras["log"][name]
                obs, rewards, dones = obs.to(torch_device), rewards.to(torch_device), dones.to(torch_device)
                alg.process_env_step(obs, rewards, dones, extras)
            alg.compute_returns(obs)
        alg.update()
        stats = env.episode_statistics()
        episodes = stats["episodes"]
        out_of_time = max_minutes is not None and time.perf_counter() - start > 60.0 * max_minutes
        counts = [steps * env.num_envs, episodes, stats["mean_return"] * episodes if episodes else 0.0,
                  stats["mean_length"] * episodes if episodes else 0.0, float(out_of_time), *terrain_level_counts(env)]  # fmt: skip
        if world > 1:  # one small all-reduce per iteration
            reduced = torch.tensor(counts, dtype=torch.float64, device=torch_device)
            torch.distributed.all_reduce(reduced)
            counts = reduced.tolist()
        new_steps, episodes, return_sum, length_sum, out_of_time, level_sum, on_top, rough_envs = counts
        level = f"  terrain level {level_sum / rough_envs:5.2f} ({on_top / rough_envs:6.1%} on the hardest)" if rough_envs else ""
        total_steps += int(new_steps)
        mean_return = return_sum / episodes if episodes else float("nan")
        mean_length = length_sum / episodes if episodes else float("nan")
        seconds = time.perf_counter() - t0
        rate = new_steps / seconds
        history.append((it, mean_return, rate, time.perf_counter() - start, level_sum / rough_envs if rough_envs else float("nan")))
        if rank == 0:
            print(
                f"iteration {it:4d}  mean return {mean_return:8.3f}  mean length {mean_length:7.1f}  "
                f"{rate / 1e3:8.1f} k env-steps/s ({rate * env.decimation / 1e6:6.2f} M sim steps/s)  "
                f"{total_steps:11d} env-steps  {history[-1][3]:7.1f} s{level}"
                + "".join(f"  {name.strip('/')} {float(value) / steps:.3f}" for name, value in logged.items()),
                flush=True,
            )
        if target_return is not None and reached is None and mean_return >= target_return:  # NaN: not reached
            reached = history[-1][3]
            if rank == 0:
                print(f"reached mean return {target_return:g} at iteration {it} after {reached:.1f} s and {total_steps} env-steps", flush=True)  # fmt: skip
            break
        if out_of_time:
            if rank == 0:
                print(f"stopping after {max_minutes:g} minutes (--max-minutes)", flush=True)
            break
    elapsed = time.perf_counter() - start
    if rank == 0:
        if target_return is not None and reached is None:
            print(f"mean return {target_return:g} not reached", flush=True)
        print(f"total: {total_steps} env-steps on {world} rank(s) in {elapsed:.1f} s ({total_steps / elapsed / 1e3:.1f} k env-steps/s)", flush=True)  # fmt: skip
    if world > 1:
        difference = parameters_difference(alg)
        if difference > 1e-5:
            raise RuntimeError(f"rank {rank}: the ranks' policies differ (by up to {difference:.3g}): not synchronised")
        if rank == 0:
            print(f"policy identical on {world} ranks (largest difference {difference:.3g})", flush=True)
    if rank == 0:
        out.mkdir(parents=True, exist_ok=True)
        infos = {"action_distribution": distribution, "hidden_dims": list(hidden_dims), "schedule": schedule}
        torch.save({**alg.save(), "iter": first + len(history) - 1, "infos": infos}, out / "policy.pt")  # OnPolicyRunner.save's format
    return history


def terrain_level_counts(env) -> tuple[float, float, float]:
    """(sum of the environments' terrain levels, how many are on the hardest level, how many environments) on
    generated terrain; zeros on flat ground and for environments without terrain (examples/rl_manipulation.py's)."""
    gen = getattr(env, "terrain_generator", None)
    if gen is None:
        return 0.0, 0.0, 0.0
    levels = env.terrain_levels
    level_sum, on_top = torch.stack([levels.sum(), (levels == gen.levels - 1).sum()]).tolist()  # one host synchronisation
    return float(level_sum), float(on_top), float(env.num_envs)


def plot(history: list, path: pathlib.Path, title: str) -> None:
    """The mean return (and the mean terrain level where there is one) against wall time, written to `path`; none
    without matplotlib or without iterations (--iterations 0: a checkpoint resumed and saved back)."""
    if not history:
        print("no iterations: no plot")
        return
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("matplotlib is not installed: no plot")
        return
    it, ret, _, seconds, level = (np.array(x, dtype=float) for x in zip(*history))
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(seconds, ret)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel("mean episode return")
    if np.isfinite(level).any():
        levels = ax.twinx()
        levels.plot(seconds, level, color="tab:orange")
        levels.set_ylabel("mean terrain level", color="tab:orange")
    ax.set_title(title)
    ax.grid(True)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    print(f"wrote {path}")


def add_ppo_argument(parser: argparse.ArgumentParser) -> None:
    """--ppo: which PPO `train` runs (its `graphed`)."""
    parser.add_argument("--ppo", choices=("graphed", "rsl-rl"), default="graphed",
                        help="graphed (default): rsl-rl's PPO replayed as CUDA graphs on a GPU (warpdyn.envs.rsl_rl.GraphedPPO); rsl-rl: its own")  # fmt: skip


def add_resume_argument(parser: argparse.ArgumentParser) -> None:
    """--resume: `train`'s resume."""
    parser.add_argument("--resume", type=pathlib.Path, default=None, metavar="POLICY",
                        help="continue training from a policy.pt this example saved (its models, normalisers, optimizer and learning rate)")  # fmt: skip


def task_arguments(
    description: str, ppo: dict, default_envs: str, out: str, iterations: int, distribution: str = "gaussian", schedule: str = "adaptive"
) -> argparse.ArgumentParser:
    """The command line the manipulation examples share (rl_manipulation.py, rl_reorient.py): --device, --num-envs
    (per rank under torchrun; `default_envs` says the default), --iterations, --seed (rank r: seed + r), --max-minutes, `ppo`'s settings as flags with its values
    as defaults, --action-distribution (ACTION_DISTRIBUTIONS, default `distribution`), --schedule (SCHEDULES, default
    `schedule`), --hidden-dims, --random-episode-start, --resume, --ppo, --evaluate,
    --evaluate-envs and --out; `task_setup` parses it."""
    parser = argparse.ArgumentParser(description=description, epilog="On K GPUs: torchrun --standalone --nproc_per_node K ... (rank r on cuda:<LOCAL_RANK>)")
    parser.add_argument("--device", default=None, help="Warp device (default: a GPU if there is one; under torchrun as rl_locomotion.py's)")
    parser.add_argument("--num-envs", type=int, default=None, help=f"environments PER RANK; default: {default_envs}")
    parser.add_argument("--iterations", type=int, default=iterations, help="at most this many PPO iterations")
    parser.add_argument("--seed", type=int, default=0, help="rank r uses seed + r")
    parser.add_argument("--max-minutes", type=float, default=None, help="stop after this many minutes of training")
    add_ppo_flags(parser, ppo)
    parser.add_argument("--action-distribution", choices=sorted(ACTION_DISTRIBUTIONS), default=distribution, help=f"the policy's (default {distribution})")
    parser.add_argument("--schedule", choices=SCHEDULES, default=schedule, help=f"the learning rate's (default {schedule})")
    parser.add_argument("--hidden-dims", type=layer_widths, default=None,
                        help=f"the actor's and critic's MLP layers (default {','.join(map(str, HIDDEN_DIMS))}, or --resume's)")  # fmt: skip
    parser.add_argument("--random-episode-start", action="store_true", help="start the environments' episode counters at random (rsl-rl's init_at_random_ep_len)")
    add_resume_argument(parser)
    add_ppo_argument(parser)
    parser.add_argument("--evaluate", action="store_true", help="after training, evaluate the policy in --evaluate-envs fresh environments")
    parser.add_argument("--evaluate-envs", type=int, default=256, help="environments of --evaluate (default 256)")
    parser.add_argument("--out", default=out)
    return parser


def add_ppo_flags(parser: argparse.ArgumentParser, ppo: dict, note: str = "") -> None:
    """A flag per PPO setting of `ppo` (PPO_DEFAULTS' names), its value the default: --clipped-value-loss takes on or off."""
    for name, value in ppo.items():
        kind, shown = (on_off, "on" if value else "off") if isinstance(value, bool) else (type(value), f"{value:g}")
        parser.add_argument(f"--{name.replace('_', '-')}", type=kind, default=value, metavar="{on,off}" if kind is on_off else None,
                            help=f"PPO's {name.replace('_', ' ')} (default {shown}{note})")  # fmt: skip


def on_off(text: str) -> bool:
    """A flag's "on" or "off" as True or False; an argparse error naming the text otherwise."""
    if text not in ("on", "off"):
        raise argparse.ArgumentTypeError(f"on or off, got {text!r}")
    return text == "on"


def layer_widths(text: str) -> tuple:
    """--hidden-dims' "512,256,128" as (512, 256, 128); an argparse error naming the text otherwise."""
    try:
        dims = tuple(int(x) for x in text.split(","))
        check_layer_widths(dims)
    except ValueError:
        raise argparse.ArgumentTypeError(f"comma-separated positive layer widths, got {text!r}") from None
    return dims


def check_run_arguments(parser: argparse.ArgumentParser, args) -> None:
    """A parser error naming the flag unless --num-envs is a positive number (or not given), --iterations >= 0 (0:
    a --resume'd checkpoint saved back), --max-minutes positive and finite (or not given), --resume (and --replay) an existing file,
    and, where the example has them, --evaluate-envs positive and --evaluate-seconds positive and finite: none of them
    is replaced or ignored, and nothing is built before they are checked."""
    if args.num_envs is not None and args.num_envs < 1:
        parser.error(f"--num-envs must be a positive number of environments, got {args.num_envs}")
    if args.iterations < 0:
        parser.error(f"--iterations must be >= 0, got {args.iterations}")
    if args.max_minutes is not None and not (math.isfinite(args.max_minutes) and args.max_minutes > 0):
        parser.error(f"--max-minutes must be a positive number of minutes, got {args.max_minutes}")
    if getattr(args, "evaluate_envs", 1) < 1:
        parser.error(f"--evaluate-envs must be a positive number of environments, got {args.evaluate_envs}")
    seconds = getattr(args, "evaluate_seconds", 1.0)
    if not (math.isfinite(seconds) and seconds > 0):
        parser.error(f"--evaluate-seconds must be a positive number of seconds, got {seconds}")
    for flag in ("resume", "replay"):  # rl_locomotion.py's --replay too
        path = getattr(args, flag, None)
        if path is not None and not pathlib.Path(path).is_file():
            parser.error(f"--{flag} {path}: no such file (a policy.pt this example saved)")


def task_setup(parser: argparse.ArgumentParser, argv, ppo: dict) -> tuple:
    """(args, the output folder, `ppo`'s settings as given): the command line parsed (`task_arguments`', or
    rl_locomotion.py's own), each PPO setting checked positive and the run's (`check_run_arguments`);
    `torchrun_device(parser, args.device, args.seed)` then gives the device (and the rank)."""
    args = parser.parse_args(argv)
    for name in (n for n, value in ppo.items() if not isinstance(value, bool)):
        if not getattr(args, name) > 0:
            parser.error(f"--{name.replace('_', '-')} must be positive, got {getattr(args, name)}")
    check_run_arguments(parser, args)
    return args, pathlib.Path(args.out), {name: getattr(args, name) for name in ppo}


def run_task(parser, argv, ppo: dict, counts: tuple, make, name: str, describe, title: str, log_names: tuple, report) -> list:
    """A manipulation example's run (rl_manipulation.py, rl_reorient.py), under torchrun too: `task_arguments`'
    command line (`task_setup`), this rank's device (`torchrun_device`), its `make(N, device, seed, args)` environments (args: the parsed command line, for the example's own flags; N:
    --num-envs, else counts[0] on a GPU and counts[1] on the CPU; seed: --seed + rank), `train`; rank 0 prints the
    header ("`name`: where, `describe(env)`, actions, policy rate"), plots the returns ("`title`: where"), with
    --evaluate prints "evaluation: " + `report(args, policy.pt's path, device, env)`, and the phases' times. Returns
    `train`'s history."""
    started = time.perf_counter()
    args, out, ppo = task_setup(parser, argv, ppo)
    with torchrun_device(parser, args.device, args.seed) as (device, world, rank):
        N = args.num_envs or (counts[0] if device.is_cuda else counts[1])
        env = make(N, device, args.seed + rank, args)
        where = placement(N, device, world)
        if rank == 0:
            print(f"{name}: {where}, {describe(env)}, {env.single_action_space.shape[0]} actions, "
                  f"policy at {1 / env.cfg.policy_dt:g} Hz over {env.decimation} steps", flush=True)  # fmt: skip
        phases = {"environment": time.perf_counter() - started}
        history = train(
            env, args.iterations, out, str(env.device), max_minutes=args.max_minutes, ppo=ppo, log_names=log_names, distribution=args.action_distribution,
            graphed=args.ppo == "graphed", resume=args.resume, schedule=args.schedule, hidden_dims=args.hidden_dims,
            random_episode_start=args.random_episode_start,
        )  # fmt: skip
        phases["training"] = time.perf_counter() - started - sum(phases.values())
        if rank == 0:
            plot(history, out / "rewards.png", f"{title}: {where}")
            if args.evaluate:
                print("evaluation: " + report(args, out / "policy.pt", device, env), flush=True)
            print("phases after the imports: " + ", ".join(f"{k} {v:.1f} s" for k, v in phases.items()), flush=True)
    return history


def saved_policy_kind(saved: dict) -> tuple[str, tuple]:
    """(action distribution, hidden layers) of a checkpoint `train` saved (earlier ones: a Gaussian, HIDDEN_DIMS)."""
    infos = saved.get("infos") or {}
    return infos.get("action_distribution", "gaussian"), tuple(infos.get("hidden_dims", HIDDEN_DIMS))


def load_policy(env: envs.LeggedEnv, policy_path: pathlib.Path):
    """(rsl-rl VecEnv of `env`, the deterministic policy of a policy.pt on env's device). Built as `train`
    builds it (not by OnPolicyRunner, which would start a process group of its own under torchrun); a policy
    trained on a GPU loads on the CPU too."""
    from rsl_rl.algorithms import PPO

    vec = RslRlVecEnv(env)
    saved = torch.load(policy_path, map_location=str(env.device), weights_only=False)
    kind, dims = saved_policy_kind(saved)
    cfg = train_config(1, kind, hidden_dims=dims)
    cfg["obs_groups"] = vec.obs_groups
    with contextlib.redirect_stdout(io.StringIO()):  # construct_algorithm prints the models
        alg = PPO.construct_algorithm(vec.get_observations(), vec, cfg, str(env.device))
    alg.load(saved, load_cfg={"actor": True, "critic": True}, strict=True)
    alg.eval_mode()
    return vec, alg.get_policy()


def replay(robot: str, task: str, policy_path: pathlib.Path, out: pathlib.Path, device, seed: int, seconds: float = 10.0) -> None:
    """Run the trained policy on one environment and record it with rerun."""
    import warpdyn.visualization as viz

    env = make_env(task, 1, device, seed, robot)
    vec, policy = load_policy(env, policy_path)
    obs = vec.get_observations()
    path = out / "policy.rrd"
    with viz.RerunRecorder(env.model, path=path, meshes=False) as recorder:  # the collision-point view: no meshes
        for k in range(int(seconds / env.cfg.policy_dt)):
            with torch.inference_mode():
                obs, _, _, _ = vec.step(policy(obs))
            recorder.log(env.stepper.data, time=k * env.cfg.policy_dt)
    print(f"wrote {path}")


def evaluate(robot: str, task: str, policy_path: pathlib.Path, device, seed: int, speed: float, num_envs: int = 256, seconds: float = 5.0) -> dict:
    """The trained policy commanded to walk straight ahead at `speed` [m/s] (no pushes) in `num_envs` fresh
    environments for `seconds`: {"speed": mean forward velocity over the environments and the last
    seconds - 1 s (base frame x) [m/s], "spread": its standard deviation over the environments, "falls":
    the environments that ended early}."""
    env = make_env(task, num_envs, device, seed, robot, lin_vel_x=(speed, speed), lin_vel_y=(0.0, 0.0), yaw_rate=(0.0, 0.0),
                   push_velocity=0.0, command_seconds=2 * seconds)  # fmt: skip
    vec, policy = load_policy(env, policy_path)
    obs = vec.get_observations()
    steps, settle = int(round(seconds / env.cfg.policy_dt)), int(round(1.0 / env.cfg.policy_dt))
    forward = torch.zeros(num_envs, device=env.device, dtype=torch.float64)
    fell = torch.zeros(num_envs, device=env.device, dtype=torch.bool)
    with torch.inference_mode():
        for k in range(steps):
            obs, _, dones, _ = vec.step(policy(obs))
            fell |= dones.bool()
            if k >= settle:
                forward += env.state.base_linear_velocity[:, 0].to(torch.float64)
    forward /= steps - settle
    kept = forward[~fell]
    return {"speed": float(kept.mean()) if kept.numel() else float("nan"), "spread": float(kept.std()) if kept.numel() > 1 else 0.0,
            "falls": int(fell.sum()), "environments": num_envs}  # fmt: skip


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0],
        epilog="On K GPUs: torchrun --standalone --nproc_per_node K examples/rl_locomotion.py ... (rank r on cuda:<LOCAL_RANK>)",
    )
    parser.add_argument("--robot", choices=sorted(ROBOTS), default="ergocub", help="ergocub: the shipped legs; anymal_c, go2: shipped from MuJoCo Menagerie; go1: example-robot-data's")
    parser.add_argument("--task", choices=("stand", "walk", "rough"), default="stand", help="rough: anymal_c on Rudin et al.'s curriculum")
    parser.add_argument(
        "--device", default=None,
        help="Warp device (default: a GPU if there is one); under torchrun 'cuda' or none gives rank r cuda:<LOCAL_RANK>, "
        "'cpu' runs every rank on the CPU (gloo)",
    )  # fmt: skip
    parser.add_argument(
        "--num-envs", type=int, default=None,
        help="environments PER RANK (under torchrun K x this in all); default: 4096 on a GPU, 64 on the CPU",
    )  # fmt: skip
    parser.add_argument("--iterations", type=int, default=300, help="at most this many PPO iterations")
    parser.add_argument("--seed", type=int, default=0, help="rank r uses seed + r")
    parser.add_argument("--target-return", type=float, default=None, help="stop when an iteration's mean return reaches this; prints the time")  # fmt: skip
    parser.add_argument("--max-minutes", type=float, default=None, help="stop after this many minutes of training")
    add_ppo_flags(parser, PPO_DEFAULTS, ", Rudin et al.'s")
    add_resume_argument(parser)
    add_ppo_argument(parser)
    parser.add_argument("--evaluate", type=float, default=None, metavar="SPEED",
                        help="after training, command SPEED m/s straight ahead in 256 fresh environments for 5 s and print the speed reached")  # fmt: skip
    parser.add_argument("--out", default="runs/locomotion")
    parser.add_argument("--replay", default=None, help="a policy.pt to record instead of training (one process)")
    args, out, ppo = task_setup(parser, argv, PPO_DEFAULTS)
    started = time.perf_counter()  # the phases' times below count from here (after the imports)
    if torchrun_ranks()[0] > 1 and args.replay:
        parser.error("--replay runs in one process: python examples/rl_locomotion.py --replay ..., not torchrun")
    with torchrun_device(parser, args.device, args.seed) as (device, world, rank):
        if args.replay:
            replay(args.robot, args.task, pathlib.Path(args.replay), out, device, args.seed)
            return None
        N = args.num_envs or (4096 if device.is_cuda else 64)
        env = make_env(args.task, N, device, args.seed + rank, args.robot)
        where = placement(N, device, world)
        if rank == 0:
            print(f"{args.robot} {args.task}: {where}, {env.single_observation_space.shape[0]} observations, "
                  f"{env.single_action_space.shape[0]} actions, policy at {1 / env.cfg.policy_dt:g} Hz over {env.decimation} steps")  # fmt: skip
        phases = {"environment": time.perf_counter() - started}
        history = train(env, args.iterations, out, str(env.device), args.target_return, args.max_minutes, ppo, graphed=args.ppo == "graphed", resume=args.resume)
        phases["training"] = time.perf_counter() - started - sum(phases.values())
        if rank == 0:
            plot(history, out / "rewards.png", f"{args.robot}, {args.task}: {where}")
            phases["plot"] = time.perf_counter() - started - sum(phases.values())
            if args.evaluate is not None:
                result = evaluate(args.robot, args.task, out / "policy.pt", device, args.seed + 1000, args.evaluate)
                phases["evaluation"] = time.perf_counter() - started - sum(phases.values())
                print(f"evaluation: commanded {args.evaluate:g} m/s straight ahead, {result['environments']} environments, 5 s: "
                      f"forward speed {result['speed']:.3f} m/s (std over environments {result['spread']:.3f}), "
                      f"{result['falls']} ended early", flush=True)  # fmt: skip
            print("phases after the imports: " + ", ".join(f"{k} {v:.1f} s" for k, v in phases.items()), flush=True)
    return history


if __name__ == "__main__":
    if main() is not None:  # trained (not --replay, whose recording rerun flushes at exit)
        # The interpreter's teardown of torch, Warp and their contexts takes seconds (benchmarks/RESULTS.md, the Go1 in
        # 30 s), and everything written is closed: the process ends without it, for the seconds-to-a-policy runs.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
