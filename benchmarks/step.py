"""Simulation steps and rollouts for N environments: what a model pays for contacts, and for Python.

    python benchmarks/step.py [--device cuda:0] [--max-envs 65536 | --sizes 1,256,4096]
                              [--dtypes float32,float64] [--robots legs,legs-no-contacts,legs-lengths,legs-actuated,arm]
                              [--repeats 10] [--fresh-cache] [--block-dims 64,256] [--fused on,off,one,groups,local]

Robots:
- legs: the seed's ergoCub legs (12 joints, 13 links) with its 32 collidable points (the ankle boxes),
  standing on flat ground (feet a few mm in the ground, so the contact kernel runs its contact branches);
- legs-no-contacts: the same model with every point disabled: no FK, link-velocity or contact kernel;
- legs-lengths: the legs with each joint's origin scaled by U(0.95, 1.05) per environment (issue 38: the kernels
  read the joint terms per environment, (N, nL), instead of one shared row);
- legs-actuated: the legs with what an MJCF robot brings (issue 11): armature 0.05 kg m^2 on every joint
  and a position servo per joint (`wd.model.add_actuators`: kp 300 N m/rad, kv 5 N m s/rad, ctrl within
  +-1.5 rad, force within +-100 N m), driven by `ctrl` (N, 12) instead of joint torques;
- arm: a fixed-base arm without collidable points: the iCub (icub-models) welded to the world at its root,
  torso and left arm (10 joints); a 7-joint chain when icub-models is not installed.
Each row times, after a warm-up (compilation, graph capture) and synchronising around the timed region:
- step: one `wd.model.step(model, data, joint_force_references=tau)` call (tau a device array (N, n);
  `ctrl=` (N, na) for legs-actuated), the median over repeats: the latency of a Python loop of steps;
- rollout: `wd.simulation.Rollout.run` of T steps with per-step torques (T, N, n) recording the joint
  positions, replaying its captured graph (CUDA graph on GPUs, Warp's CPU graph on the CPU); the median
  run divided by T (the run's initial copies included);
- eager: the same rollout with use_graph=False (one Python launch per kernel).
env-steps/s = N / (seconds per step). --block-dims repeats each row with each CUDA block size
(warpdyn.config.cuda_block_dim; default: the configured one), --fused with the fused Euler step on (its
threads per environment chosen by N and device), off, or on with one thread per environment (one) or one
per group of the model's walk (groups), and on with its records in local memory instead of a GPU's shared
memory (local, one-local) (warpdyn.config.fused_step, .fused_lanes and .fused_shared_records; default: the
configured ones). Prints the header (device, versions) and a Markdown table.
"""

from __future__ import annotations

import argparse
import copy

import numpy as np
import warp as wp

import warpdyn as wd
from common import add_size_arguments, chosen_sizes, header, median_time, np_dtype, seed_model

FUSED = {
    "on": (True, None, True),
    "off": (False, None, True),
    "one": (True, False, True),
    "groups": (True, True, True),
    "local": (True, None, False),
    "one-local": (True, False, False),
}
"""--fused's settings: (warpdyn.config.fused_step, .fused_lanes, .fused_shared_records)."""

ARM_JOINTS = ("torso_pitch", "torso_roll", "torso_yaw", "l_shoulder_pitch", "l_shoulder_roll", "l_shoulder_yaw", "l_elbow", "l_wrist_prosup", "l_wrist_pitch", "l_wrist_yaw")


def _chain_urdf(n: int = 7) -> str:
    """A fixed-base chain of n revolute links (alternating axes), 0.3 m each."""
    parts = ['<robot name="chain">', '<link name="world"/>', '<link name="base"><inertial><mass value="2"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>']
    parts.append('<joint name="weld" type="fixed"><parent link="world"/><child link="base"/></joint>')
    parent = "base"
    for i in range(n):
        axis = ("0 0 1", "0 1 0", "1 0 0")[i % 3]
        parts.append(
            f'<link name="l{i}"><inertial><origin xyz="0 0 0.15"/><mass value="1"/>'
            '<inertia ixx="0.008" iyy="0.008" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>'
        )
        parts.append(
            f'<joint name="j{i}" type="revolute"><parent link="{parent}"/><child link="l{i}"/>'
            f'<origin xyz="0 0 {0.3 if i else 0.1}"/><axis xyz="{axis}"/><limit lower="-2" upper="2" effort="50" velocity="10"/></joint>'
        )
        parent = f"l{i}"
    parts.append("</robot>")
    return "\n".join(parts)


def arm_model(dtype, device):
    """(label, model): the iCub's torso and left arm welded to the world, or a 7-joint chain."""
    try:
        import icub_models
    except ImportError:
        model = wd.model.Model.build_from_model_description(_chain_urdf(), dtype=dtype, device=device)
        return "arm (7-joint chain, fixed base)", model
    W_H_B = np.eye(4)
    W_H_B[2, 3] = 1.0
    full = wd.model.Model.build_from_model_description(
        icub_models.get_model_file("iCubGazeboV2_5"), fixed_base=True, base_pose=W_H_B, dtype=dtype, device=device
    )
    model = wd.model.reduce(full, [j for j in ARM_JOINTS if j in full.joint_names()])
    cp = model.kin_dyn_parameters.contact_parameters
    model = wd.contact.with_collidable_points(model, enabled=np.zeros(len(cp.body), dtype=bool))
    return f"arm (iCub torso + left arm, {model.dofs()} joints, fixed base)", model


def robots(names, dtype, device):
    """[(label, model, standing)]: standing says whether to place the base so the feet touch the ground."""
    out = []
    if {"legs", "legs-no-contacts", "legs-actuated"} & set(names):
        legs = seed_model(dtype, device)
        count = len(legs.kin_dyn_parameters.contact_parameters.body)
        if "legs" in names:
            out.append((f"ergoCub legs, {count} points", legs, True))
        if "legs-no-contacts" in names:
            none = wd.contact.with_collidable_points(copy.copy(legs), enabled=np.zeros(count, dtype=bool))
            out.append(("ergoCub legs, no points", none, True))
        if "legs-lengths" in names:
            out.append((f"ergoCub legs, {count} points, lengths per environment", legs, True))
        if "legs-actuated" in names:
            actuated = wd.model.add_actuators(legs, "position", kp=300.0, kv=5.0, ctrl_range=(-1.5, 1.5), force_range=(-100.0, 100.0))
            actuated.set_joint_parameters(armature=np.full(legs.dofs(), 0.05))
            out.append((f"ergoCub legs, {count} points, armature + servos", actuated, True))
    if "arm" in names:
        label, model = arm_model(dtype, device)
        out.append((label, model, False))
    return out


def per_environment_lengths(model, N: int):
    """The model (shared origins) with each joint's origin scaled by U(0.95, 1.05) per environment
    (wd.model.with_joint_origins, (N, nj, 3))."""
    positions = wd.model.joint_origins(model)[0]
    scale = np.random.default_rng(N).uniform(0.95, 1.05, (N, model.number_of_joints(), 1))
    return wd.model.with_joint_origins(model, positions=positions * scale)


def initial_data(model, N: int, standing: bool, seed: int = 0):
    """States near a stance: joints within 0.05 rad of zero, small velocities; for the legs, the base at
    the height where the lowest point is 3 mm deep (+- 2 mm)."""
    rng = np.random.default_rng(seed)
    n = model.dofs()
    kwargs = dict(joint_positions=rng.uniform(-0.05, 0.05, (N, n)), joint_velocities=rng.uniform(-0.1, 0.1, (N, n)))
    if standing:
        zero = wd.data.Data.build(model, num_envs=N)
        cp = wd.contact.with_collidable_points(model)  # all points, to place the feet even without contacts
        lowest = float(wd.contact.collidable_point_positions(cp, zero).numpy()[..., 2].min())
        z = -lowest - 0.003 + rng.uniform(-0.002, 0.002, N)
        kwargs["base_position"] = np.stack([np.zeros(N), np.zeros(N), z], axis=1)
    return wd.data.Data.build(model, num_envs=N, **kwargs)


def rollout_steps(N: int, device) -> int:
    """T for the rollout rows: long enough to amortise the run's copies, short enough on a CPU."""
    budget = 2**20 if wp.get_device(device).is_cuda else 2**15
    return int(max(8, min(200, budget // N)))


def main() -> None:
    parser = argparse.ArgumentParser()
    add_size_arguments(parser, max_envs=None, max_envs_help="default: 65536 on GPUs, 4096 on the CPU")
    parser.add_argument("--robots", default="legs,legs-no-contacts,arm")
    parser.add_argument("--repeats", type=int, default=10)
    parser.add_argument("--no-eager", action="store_true", help="skip the eager rollout column")
    parser.add_argument("--fresh-cache", action="store_true", help="compile into an empty kernel cache")
    parser.add_argument("--block-dims", default=None, help="comma-separated CUDA threads per block (default: warpdyn.config.cuda_block_dim)")
    parser.add_argument("--fused", default=None, help="comma-separated on, off, one, groups, local, one-local: warpdyn.config.fused_step, .fused_lanes and .fused_shared_records (default: the configured ones)")
    args = parser.parse_args()
    if args.fresh_cache:
        from common import init_warp

        init_warp()
    else:
        wp.config.quiet = True
        wp.config.log_level = wp.LOG_WARNING
        wp.init()
    device = wp.get_device(args.device)
    Ns = chosen_sizes(args, args.max_envs or (65536 if device.is_cuda else 4096))
    names = args.robots.split(",")
    print(header(device))
    print()
    blocks = [int(b) for b in args.block_dims.split(",")] if args.block_dims else [wd.config.cuda_block_dim]
    current = next((k for k, v in FUSED.items() if v == settings()), "on")
    fused_settings = args.fused.split(",") if args.fused else [current]
    print("| robot | dtype | N | CUDA block | fused | step [ms] | step env-steps/s | rollout T | rollout per step [ms] | rollout env-steps/s | eager per step [ms] |")
    print("| --- | --- | ---: | ---: | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    summary = {}
    for dtype_name in args.dtypes.split(","):
        dtype = np_dtype[dtype_name]
        for label, shared, standing in robots(names, dtype, device):
            model = shared
            # the actuated legs take the servos' targets (ctrl, (N, na) [rad]), the others joint torques (N, n) [N m]
            control, width, scale = ("ctrl", model.number_of_actuators(), 0.1) if model.number_of_actuators() else ("joint_force_references", model.dofs(), 1.0)
            for N, block, fused in ((N, b, f) for N in Ns for b in blocks for f in fused_settings):
                wd.config.cuda_block_dim = block
                if FUSED[fused] != settings():
                    wd.config.fused_step, wd.config.fused_lanes, wd.config.fused_shared_records = FUSED[fused]
                    model.notify_model_changed()  # a new model version: `step` builds its launches and graphs again
                if "lengths per environment" in label:  # the joint terms read per environment: (N, nL) rows
                    model = per_environment_lengths(shared, N)
                data = initial_data(model, N, standing)
                rng = np.random.default_rng(1)
                tau = {control: wp.array(rng.normal(0.0, scale, (N, width)), dtype=model.scalar, device=device)}
                wd.model.step(model, data, **tau)  # compile
                step_s = median_time(lambda: wd.model.step(model, data, **tau), device, args.repeats)
                T = rollout_steps(N, device)
                taus = {control: wp.array(rng.normal(0.0, scale, (T, N, width)), dtype=model.scalar, device=device)}
                roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions",))
                roll.run(data, **taus)  # compile, capture
                roll_s = median_time(lambda: roll.run(data, **taus), device, max(3, args.repeats // 2)) / T
                eager = "-"
                if not args.no_eager:
                    eager_roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions",), use_graph=False)
                    eager_roll.run(data, **taus)
                    eager_s = median_time(lambda: eager_roll.run(data, **taus), device, 3) / T
                    eager = f"{eager_s * 1e3:.4g}"
                summary[(label, dtype_name, N, block, fused)] = (step_s, roll_s)
                print(
                    f"| {label} | {dtype_name} | {N} | {block if device.is_cuda else '-'} | {fused} | {step_s * 1e3:.4g} | {N / step_s:.3g} | {T} | {roll_s * 1e3:.4g} | "
                    f"{N / roll_s:.3g} | {eager} |",
                    flush=True,
                )
    plain = [k for k in summary if k[0].startswith("ergoCub legs,") and not any(w in k[0] for w in ("no points", "servos", "lengths"))]
    ratios(summary, "Contacts' share (ergoCub legs, rollout per step, with / without points):", plain, lambda k: "no points" in k[0])
    actuated = [k for k in summary if "servos" in k[0]]
    ratios(summary, "Armature and servos' share (ergoCub legs with points, rollout per step, with / without):", actuated, lambda k: k in plain)
    lengths = [k for k in summary if "lengths per environment" in k[0]]
    ratios(summary, "Link lengths per environment (ergoCub legs with points, rollout per step, per environment / shared):", lengths, lambda k: k in plain)


def settings() -> tuple:
    """warpdyn's fused-step settings now, as FUSED's values."""
    return wd.config.fused_step, wd.config.fused_lanes, wd.config.fused_shared_records


def ratios(summary: dict, title: str, rows: list, is_baseline) -> None:
    """Print rollout-per-step ratios of `rows` to the baseline row (is_baseline) of the same dtype, N, block and
    fused setting."""
    lines = []
    for label, dtype_name, N, block, fused in rows:
        other = [k for k in summary if is_baseline(k) and k[1:] == (dtype_name, N, block, fused)]
        if other:
            a, b = summary[(label, dtype_name, N, block, fused)][1], summary[other[0]][1]
            lines.append(f"- {dtype_name}, N = {N}, block {block}, fused {fused}: {a * 1e3:.4g} / {b * 1e3:.4g} ms = {a / b:.2f}")
    if lines:
        print()
        print(title)
        print("\n".join(lines))


if __name__ == "__main__":
    main()
