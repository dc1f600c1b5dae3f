"""Throughput of each contact model on the legs standing in contact: env-steps/s of a graph-replayed rollout.

    python benchmarks/contact_throughput.py [--device cuda:0] [--sizes 4096,32768] [--steps 50] [--repeats 7]
                                            [--integrators SIE] [--dtypes float32,float64] [--tag NAME]

Scene and settings: benchmarks/speed_accuracy.py's (the seed's ergoCub legs, 32 collidable points, the joint PD,
the drops' poses lowered 2 +- 1 mm into the ground; soft K = 1e6 (JaxSim's default), relaxed rigid and rigid
with JaxSim's defaults) at dt = 1 ms. Each row: the median time per step over --repeats runs of a --steps-step
`wd.simulation.Rollout` (CUDA graph on a GPU, Warp's CPU graph on the CPU), after a warm-up. Defaults: GPU
N = 4096 and 32768, CPU N = 256.

Writes results/contact_throughput_<tag>.md, tag = cpu or the GPU's name.
"""

from __future__ import annotations

import argparse

import numpy as np
import warp as wp

import speed_accuracy as sa
from common import header, seed_model


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--sizes", default=None)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--integrators", default="SIE")
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--tag", default=None)
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    sizes = [int(n) for n in (args.sizes or ("4096,32768" if device.is_cuda else "256")).split(",")]
    tag = args.tag or sa.device_tag(device)
    base64 = seed_model(np.float64, device)
    init = sa.initial_state(base64)
    settings = sa.contact_settings(["soft", "relaxed", "rigid"], [1e6])
    lines = [
        "# Throughput of the contact models (benchmarks/contact_throughput.py)",
        "",
        f"`python benchmarks/contact_throughput.py{' --sizes ' + args.sizes if args.sizes else ''}`; {header(device)}.",
        f"The legs standing in contact (32 points), joint PD, dt = 1 ms; median over {args.repeats} graph-replayed rollouts of {args.steps} steps.",
        "",
        "| contact | integrator | dtype | N | step [ms] | env-steps/s | vs soft |",
        "| --- | --- | --- | ---: | ---: | ---: | ---: |",
    ]
    for integrator in (sa.SIE if i == "SIE" else sa.RK4 for i in args.integrators.split(",")):
        for dtype in args.dtypes.split(","):
            base = seed_model({"float32": np.float32, "float64": np.float64}[dtype], device)
            for N in sizes:
                soft = None
                for setting in settings:
                    model = sa.scene_model(base, integrator, 1e-3, setting)
                    step = sa.throughput(model, init, N, args.steps, args.repeats)
                    soft = step if soft is None else soft
                    line = f"| {setting['label']} | {sa.SHORT[integrator]} | {dtype} | {N} | {step * 1e3:.3g} | {N / step:.3g} | {step / soft:.3g} |"
                    print(line, flush=True)
                    lines.append(line)
    out = sa.RESULTS / f"contact_throughput_{tag}.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
