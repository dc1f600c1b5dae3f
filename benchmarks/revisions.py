"""Two versions of warpdyn side by side, in one run on one device: ABA, RNEA and CRBA kernel times and the
step's time, before and after a change.

    python benchmarks/revisions.py --before PATH [--after PATH] [--device cuda:0] [--sizes 4096,65536]
                                   [--dtypes float32,float64] [--repeats 20]

PATH is a checkout of warpdyn (a folder holding `warpdyn/` and `kernels/`, e.g. `git worktree add PATH REV`
or `git archive REV | tar -x -C PATH`); --after defaults to this checkout. Each version runs in its own
process with an empty Warp kernel cache, on the seed's ergoCub legs (12 joints, 13 links, 32 collidable
points, float32 and float64, random states): for ABA (joint forces given), RNEA (joint accelerations
given) and CRBA, the median device time of the kernel over `--repeats` façade calls (Warp's CUDA activity
timing, wp.timing_begin; on the CPU the median call time instead); for the step, the median time per step
of a 100-step `wd.simulation.Rollout` replayed from its graph, the feet 3 mm in the ground. Prints a
Markdown table with the ratio after / before (below 1: faster).
"""

from __future__ import annotations

import argparse
import json
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile

HERE = pathlib.Path(__file__).resolve().parent

WORKER = r"""
import json, statistics, sys, time
import numpy as np
import warp as wp
wp.config.kernel_cache_dir = sys.argv[2]
wp.config.log_level = wp.LOG_WARNING
import warpdyn as wd

device, sizes, dtypes, repeats = sys.argv[3], [int(x) for x in sys.argv[4].split(",")], sys.argv[5].split(","), int(sys.argv[6])
wp.init()
dev = wp.get_device(device)
out = {"device": dev.name, "rows": []}
KERNELS = {"ABA": "aba", "RNEA": "rnea", "CRBA": "crba"}

def median_call(fn):
    fn(); wp.synchronize_device(dev)
    times = []
    for _ in range(repeats):
        t = time.perf_counter(); fn(); wp.synchronize_device(dev); times.append(time.perf_counter() - t)
    return statistics.median(times)

def kernel_time(fn, name):
    if not dev.is_cuda:
        return median_call(fn)
    fn(); wp.synchronize_device(dev)
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    for _ in range(repeats):
        fn()
    results = wp.timing_end()
    times = [r.elapsed for r in results if name in r.name]
    return statistics.median(times) / 1e3

for dtype_name in dtypes:
    dtype = np.dtype(dtype_name)
    full = wd.model.Model.build_from_model_description(wd.assets.ergocub_urdf(), dtype=dtype, device=dev)
    model = wd.model.reduce(full, wd.assets.ERGOCUB_LEG_JOINTS)
    n = model.dofs()
    for N in sizes:
        rng = np.random.default_rng(1)  # a random state through Data.build, whose keywords every revision has
        data = wd.data.Data.build(
            model, num_envs=N, joint_positions=rng.uniform(-1, 1, (N, n)), joint_velocities=rng.uniform(-1, 1, (N, n)),
            base_position=rng.uniform(-1, 1, (N, 3)), base_linear_velocity=rng.uniform(-1, 1, (N, 3)), base_angular_velocity=rng.uniform(-1, 1, (N, 3)),
        )
        u = wp.array(np.random.default_rng(1).uniform(-1, 1, (N, n)), dtype=model.scalar, device=dev)
        calls = {
            "ABA": lambda: wd.model.forward_dynamics_aba(model, data, joint_forces=u),
            "RNEA": lambda: wd.model.inverse_dynamics(model, data, joint_accelerations=u),
            "CRBA": lambda: wd.model.free_floating_mass_matrix(model, data),
        }
        for name, fn in calls.items():
            out["rows"].append([name, dtype_name, N, kernel_time(fn, KERNELS[name])])
        zero = wd.data.Data.build(model, num_envs=N)
        lowest = wd.contact.collidable_point_positions(model, zero).numpy()[..., 2].min()
        standing = wd.data.Data.build(model, num_envs=N, base_position=(0.0, 0.0, -lowest - 0.003))
        T = 100
        roll = wd.simulation.Rollout(model, steps=T, record=())
        tau = wp.zeros((N, n), dtype=model.scalar, device=dev)
        out["rows"].append(["step (rollout)", dtype_name, N, median_call(lambda: roll.run(standing, joint_force_references=tau)) / T])
print("RESULT " + json.dumps(out))
"""


def package(checkout: pathlib.Path, into: pathlib.Path) -> pathlib.Path:
    """A folder importable as warpdyn: the checkout's warpdyn/ with its kernels/ placed as warpdyn/kernels."""
    shutil.copytree(checkout / "warpdyn", into / "warpdyn")
    shutil.copytree(checkout / "kernels", into / "warpdyn" / "kernels", dirs_exist_ok=True)
    return into


def measure(checkout: pathlib.Path, args) -> dict:
    with tempfile.TemporaryDirectory(prefix="warpdyn-revision-") as tmp:
        root = package(checkout, pathlib.Path(tmp) / "pkg")
        cache = pathlib.Path(tmp) / "kernels-cache"
        command = [sys.executable, "-c", WORKER, str(root), str(cache), args.device, args.sizes, args.dtypes, str(args.repeats)]
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")]))  # this version first
        proc = subprocess.run(command, capture_output=True, text=True, env=env, cwd=tmp, timeout=3600)
    line = next((x for x in proc.stdout.splitlines() if x.startswith("RESULT ")), None)
    if proc.returncode != 0 or line is None:
        raise RuntimeError(f"{checkout} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}")
    return json.loads(line[len("RESULT "):])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", required=True, type=pathlib.Path)
    parser.add_argument("--after", type=pathlib.Path, default=HERE.parent)
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--sizes", default="4096,65536")
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    before, after = measure(args.before, args), measure(args.after, args)
    kind = "kernel [ms]" if "cuda" in args.device else "call [ms]"
    print(f"device: {after['device']}; before: {args.before}; after: {args.after}; medians of {args.repeats}")
    print()
    print(f"| algorithm | dtype | N | before {kind} | after {kind} | after / before |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    for (name, dtype, N, t0), (_, _, _, t1) in zip(before["rows"], after["rows"]):
        print(f"| {name} | {dtype} | {N} | {t0 * 1e3:.4f} | {t1 * 1e3:.4f} | {t1 / t0:.3f} |")


if __name__ == "__main__":
    main()
