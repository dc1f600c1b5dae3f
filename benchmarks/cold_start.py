"""The first step of a new model: with an empty kernel cache (Warp compiles warpdyn's kernels) and with a warm
one (it loads them), each in a fresh interpreter.

    python benchmarks/cold_start.py [--device cuda:0] [--dtypes float32,float64] [--repeats 3]

Each run is a new Python process that imports warpdyn, loads the seed's ergoCub legs with collidable points
(warpdyn.assets), and makes one `wd.model.step` of one environment standing on flat ground, then a
100-step `Rollout` (graph captured). Printed per dtype: the median wall time of the import, of loading the
model, of the first step and of the first rollout; "cold" runs each get a new, empty kernel cache, "warm"
runs reuse the cache the first cold run filled. Issue 12's targets: first step <= 15 s on the CPU, <= 10 s on
a GPU cold, <= 1 s warm.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

RUN = """
import json, sys, time
t0 = time.perf_counter()
import numpy as np
import warp as wp
wp.config.kernel_cache_dir = sys.argv[1]
wp.config.quiet = True
import warpdyn as wd
t1 = time.perf_counter()
sys.path.insert(0, sys.argv[4])
from common import seed_model
model = wd.contact.with_collidable_points(seed_model(np.dtype(sys.argv[3]), sys.argv[2]))
data = wd.data.Data.build(model, base_position=(0.0, 0.0, 0.6))
t2 = time.perf_counter()
stepped = wd.model.step(model, data)
stepped.base_position_state.numpy()
t3 = time.perf_counter()
final, _ = wd.simulation.Rollout(model, steps=100, record=()).run(data)
final.base_position_state.numpy()
t4 = time.perf_counter()
print(json.dumps({"import": t1 - t0, "model": t2 - t1, "step": t3 - t2, "rollout": t4 - t3, "dofs": model.dofs()}))
"""


def run(cache: str, device: str, dtype: str) -> dict:
    here = os.path.dirname(os.path.abspath(__file__))
    out = subprocess.run([sys.executable, "-c", RUN, cache, device, dtype, here], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"device: {args.device}; Python {sys.version.split()[0]}; medians of {args.repeats} fresh interpreters per row\n")
    print("| dtype | kernel cache | import [s] | load the model [s] | first step [s] | first 100-step rollout [s] |")
    print("| --- | --- | ---: | ---: | ---: | ---: |", flush=True)
    for dtype in args.dtypes.split(","):
        caches = [tempfile.mkdtemp(prefix="warpdyn-cold-") for _ in range(args.repeats)]
        for kind, dirs in (("empty", caches), ("warm", [caches[0]] * args.repeats)):
            runs = [run(cache, args.device, dtype) for cache in dirs]
            cells = " | ".join(f"{statistics.median(r[k] for r in runs):.2f}" for k in ("import", "model", "step", "rollout"))
            print(f"| {dtype} | {kind} | {cells} |", flush=True)


if __name__ == "__main__":
    main()
