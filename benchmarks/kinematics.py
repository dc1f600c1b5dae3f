"""Forward kinematics plus all-link Jacobians of the seed's ergoCub (legs), for N environments.

    python benchmarks/kinematics.py [--device cuda:0] [--max-envs 65536] [--layouts env-fastest,env-major]

Times `wd.model.generalized_free_floating_jacobian(model, data)` (one FK launch and one Jacobian launch,
output (N, 13, 6, 18)) after a warm-up; compile time (first call, empty kernel cache) is reported apart.
The layout column compares the two physical layouts of per-environment arrays (warpdyn.arrays):
environment-fastest (the default on GPUs: threads of a warp touch neighbouring addresses) and
environment-major (the default on the CPU: one thread walks contiguous memory).
Prints a Markdown table: median time per call, per environment, and Jacobians per second.
"""

from __future__ import annotations

import argparse
import time

import warp as wp

import warpdyn as wd
from common import header, init_warp, median_time, np_dtype, seed_model, sizes


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--max-envs", type=int, default=65536)
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--layouts", default="env-fastest,env-major")
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    init_warp()
    device = wp.get_device(args.device)
    print(header(device))
    print()
    print("| dtype | layout | N | compile [s] | median per call [ms] | per env [µs] | envs/s |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for dtype_name in args.dtypes.split(","):
        model = seed_model(np_dtype[dtype_name], device)
        t = time.perf_counter()
        wd.model.generalized_free_floating_jacobian(model, wd.data.Data.zero(model))
        wp.synchronize_device(device)
        compile_s = time.perf_counter() - t
        for layout in args.layouts.split(","):
            wd.config.env_fastest = layout == "env-fastest"
            for N in sizes(args.max_envs):
                data = wd.data.random_model_data(model, num_envs=N)
                wd.model.generalized_free_floating_jacobian(model, data)
                seconds = median_time(lambda: wd.model.generalized_free_floating_jacobian(model, data), device, args.repeats)
                print(
                    f"| {dtype_name} | {layout} | {N} | {compile_s:.2f} | {seconds * 1e3:.3f} | "
                    f"{seconds / N * 1e6:.3f} | {N / seconds:.3g} |",
                    flush=True,
                )
                compile_s = float("nan")
    wd.config.env_fastest = None


if __name__ == "__main__":
    main()
