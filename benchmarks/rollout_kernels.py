"""Where a rollout's time goes, kernel by kernel: the CUDA time of each kernel of a `wd.simulation.Rollout` of
benchmarks/speed_accuracy.py's scene (the ergoCub legs standing in contact, joint PD, dt = 1 ms, SIE) replayed from
its recording without a graph (each kernel timed by Warp's CUDA activity timing), per step, beside the wall time per
step of the same rollout replayed from its graph.

    python benchmarks/rollout_kernels.py [--device cuda:0] [--contact rigid] [--dtype float32] [--num-envs 4096]
                                         [--steps 50] [--top 8] [--block-dim 64] [--profile-steps S]
                                         [--scene legs|pick|reorient] [--explicit] [--limits on|off]
                                         [--frictionloss on|off]

--scene pick or reorient times instead the manipulation environments' scenes as they step them (envs.PickCubeEnv's
Panda and cube, envs.CubeReorientEnv's LEAP hand and cube: geom contacts, their configs' time step and implicit
contacts, or with --explicit their contacts explicit at the same time step; their configs' limit_constraints and
frictionloss_constraints, or --limits on|off and --frictionloss on|off (off: JaxSim's static friction); --contact
does not apply), from their first reset, the actuators' controls 0.

--contact: soft (JaxSim's K = 1e6), relaxed or rigid. The rollout first runs once (compilation, capture) and once
more (the state moves on: a later segment of the same landing is timed). GPU only (the kernel timing is CUDA's).
Prints the wall time per step and a Markdown table of the `--top` kernels by time per step. --block-dim sets
wd.config.cuda_block_dim (threads per CUDA block of every launch). --profile-steps S instead runs one eager rollout of
S steps from the landing's start and prints nothing: for Nsight Compute, e.g. the rigid solve at step 110:

    ncu --kernel-name regex:rigid_solve --launch-skip 110 --launch-count 1 \
        --metrics gpu__time_duration.sum,smsp__inst_executed.sum python benchmarks/rollout_kernels.py --profile-steps 113
"""

from __future__ import annotations

import argparse
import collections
import time

import numpy as np
import warp as wp

import speed_accuracy as sa
import warpdyn as wd
import warpdyn.envs as envs
from common import header, seed_model


def scene(args, device) -> tuple:
    """(model, data) of the scene `args.scene` for args.num_envs environments in args.dtype."""
    dtype = {"float32": np.float32, "float64": np.float64}[args.dtype]
    if args.scene == "legs":
        base = seed_model(dtype, device)
        init = sa.initial_state(seed_model(np.float64, device))
        model = sa.scene_model(base, sa.SIE, 1e-3, sa.contact_settings([args.contact], [1e6])[0])
        return model, sa.batch_data(model, init, args.num_envs)
    make, config = (envs.PickCubeEnv, envs.PickCubeConfig) if args.scene == "pick" else (envs.CubeReorientEnv, envs.CubeReorientConfig)
    env = make(args.num_envs, config(implicit_contacts=not args.explicit, limit_constraints=args.limits,
                                    frictionloss_constraints=args.frictionloss), device=str(device), dtype=dtype, seed=0)
    env.reset(seed=0)
    return env.model, env.stepper.data


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--contact", default="rigid", choices=("soft", "relaxed", "rigid"))
    parser.add_argument("--dtype", default="float32", choices=("float32", "float64"))
    parser.add_argument("--num-envs", type=int, default=4096)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--top", type=int, default=8)
    parser.add_argument("--block-dim", type=int, default=None, help="wd.config.cuda_block_dim (default: warpdyn's, 64)")
    parser.add_argument("--profile-steps", type=int, default=None, help="only one eager rollout of this many steps (for Nsight Compute)")
    parser.add_argument("--scene", default="legs", choices=("legs", "pick", "reorient"))
    parser.add_argument("--explicit", action="store_true", help="pick, reorient: explicit contacts (model.implicit_contacts off)")
    parser.add_argument("--limits", choices=("on", "off"), default=None, help="pick, reorient: MuJoCo's joint limits (model.limit_constraints; default: the config's)")
    parser.add_argument("--frictionloss", choices=("on", "off"), default=None,
                        help="pick, reorient: MuJoCo's frictionloss rows (model.frictionloss_constraints; default: the config's)")
    args = parser.parse_args()
    config = envs.PickCubeConfig if args.scene == "pick" else envs.CubeReorientConfig
    args.limits = config.limit_constraints if args.limits is None else args.limits == "on"
    args.frictionloss = config.frictionloss_constraints if args.frictionloss is None else args.frictionloss == "on"
    wp.config.quiet = True
    if args.block_dim is not None:
        wd.config.cuda_block_dim = args.block_dim
    device = wp.get_device(args.device)
    if not device.is_cuda:
        raise SystemExit("rollout_kernels.py times CUDA kernels: give --device cuda:N")
    model, data = scene(args, device)
    if args.profile_steps is not None:
        wd.simulation.Rollout(model, steps=args.profile_steps, record=("valid",), use_graph=False).run(data)
        wp.synchronize_device(device)
        return
    graphed = wd.simulation.Rollout(model, steps=args.steps, record=("valid",))
    graphed.run(data)
    wp.synchronize_device(device)
    start = time.perf_counter()
    graphed.run(data)
    wp.synchronize_device(device)
    wall = (time.perf_counter() - start) / args.steps
    eager = wd.simulation.Rollout(model, steps=args.steps, record=("valid",), use_graph=False)
    eager.run(data)
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    eager.run(data)
    wp.synchronize_device(device)
    per_step, count = collections.defaultdict(float), collections.Counter()
    for result in wp.timing_end():
        per_step[result.name] += result.elapsed / args.steps
        count[result.name] += 1
    block = f" --block-dim {args.block_dim}" if args.block_dim is not None else ""
    rows = f" --limits {'on' if args.limits else 'off'} --frictionloss {'on' if args.frictionloss else 'off'}"
    what = f"--scene {args.scene}{' --explicit' * args.explicit}{rows}" if args.scene != "legs" else f"--contact {args.contact}"
    print(f"`python benchmarks/rollout_kernels.py {what} --dtype {args.dtype} --num-envs {args.num_envs}{block}`; {header(device)}.")
    print(f"Graph-replayed rollout: {wall * 1e3:.3f} ms per step (wall); kernels of the recorded replay: {sum(per_step.values()):.3f} ms per step.")
    print()
    print("| kernel | launches per step | ms per step |")
    print("| --- | ---: | ---: |")
    for name, ms in sorted(per_step.items(), key=lambda item: -item[1])[: args.top]:
        print(f"| {name} | {count[name] / args.steps:g} | {ms:.3f} |")


if __name__ == "__main__":
    main()
