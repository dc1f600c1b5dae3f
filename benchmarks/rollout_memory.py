"""Memory and time of differentiable rollouts: storage="trajectory" against storage="checkpointed".

    python benchmarks/rollout_memory.py [--device cuda:0] [--steps 100] [--envs 1024] [--dtypes float32,float64]
                                        [--integrator euler|rk4] [--every 1,4,16,auto] [--repeats 3]
                                        [--big-steps 1000] [--big-envs 4096] [--big-dtype float32] [--no-big]
                                        [--output benchmarks/results/rollout_memory_<device>.md]

Robot: the seed's ergoCub legs (12 joints, 13 links, 32 collidable points; $WARPDYN_ERGOCUB or
the one warpdyn ships: warpdyn.assets), N environments standing on flat ground (feet ~3 mm deep), per-step
joint torques (T, N, n) as a Warp array requiring gradients, the joint positions recorded, the initial
data requiring gradients, loss = sum over steps, environments and joints of s^2. A case is one rollout of
T steps under a wp.Tape, the loss, and tape.backward.

For each dtype, storage ("trajectory", and "checkpointed" with each checkpoint_every S; "auto": the
interval that keeps the fewest bytes) the report gives:
- computed: `Rollout.memory_bytes` (the buffers the rollout keeps, with their gradients: states, step
  intermediates, its copy of the controls, the records), in bytes per environment-step (total / (N T));
  it does not depend on the device, so it is exact on the CPU too;
- measured (CUDA only): the peak of Warp's memory pool during the case's forward and backward passes
  (`wp.get_mempool_used_mem_high`) minus what was in use before it (`wp.get_mempool_used_mem_current`: the
  model, the data, the user's torques), per environment-step. Warp 1.19 cannot reset the high-water mark,
  so each case runs in a fresh process; the peak also holds the loss, the user's gradients and what the
  tape allocates;
- time: forward (run + loss) and backward, medians over repeats after a warm-up run (compilation, graph
  capture), synchronised around each.
Then, computed only, the same storages for T = --big-steps and N = --big-envs (default the issue's
1000 x 4096), and a run of that case in --big-dtype: checkpointed with the default interval, forward +
backward, its peak memory (CUDA) and time, and "trajectory" where it fits (ergoCub legs, float32, semi-
implicit Euler: ~51 GiB, which an 80 GB GPU holds; RK4 needs ~219 GiB). Cases whose computed memory
exceeds 90% of the device's free memory (CUDA, or the CPU with psutil) are not run.
"""

import argparse
import functools
import json
import pathlib
import re
import statistics
import subprocess
import sys
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, np_dtype, seed_model

HERE = pathlib.Path(__file__).resolve().parent
INTEGRATORS = {"euler": wd.model.IntegratorType.SemiImplicitEuler, "rk4": wd.model.IntegratorType.RungeKutta4}


@functools.cache
def loss_kernels(scalar):
    """per_env[i] += s[t, i, j]^2 over (T + 1, N, n), then loss += per_env[i] (contention spread over N)."""

    @wp.kernel(module="unique")
    def squares(s: wp.array3d(dtype=scalar), per_env: wp.array(dtype=scalar)):
        t, i, j = wp.tid()
        wp.atomic_add(per_env, i, s[t, i, j] * s[t, i, j])

    @wp.kernel(module="unique")
    def total(per_env: wp.array(dtype=scalar), loss: wp.array(dtype=scalar)):
        i = wp.tid()
        wp.atomic_add(loss, 0, per_env[i])

    return squares, total


def standing_data(model, N: int, seed: int = 0):
    """N states near a stance (joints within 0.05 rad of zero, small velocities), the base where the lowest
    point is 3 mm deep (+- 2 mm), requiring gradients."""
    rng = np.random.default_rng(seed)
    n = model.dofs()
    zero = wd.data.Data.build(model)
    lowest = float(wd.contact.collidable_point_positions(model, zero).numpy()[:, 2].min())
    z = -lowest - 0.003 + rng.uniform(-0.002, 0.002, N)
    return wd.data.Data.build(
        model,
        num_envs=N,
        base_position=np.stack([np.zeros(N), np.zeros(N), z], axis=1),
        joint_positions=rng.uniform(-0.05, 0.05, (N, n)),
        joint_velocities=rng.uniform(-0.1, 0.1, (N, n)),
        requires_grad=True,
    )


def gib(x: float) -> str:
    return f"{x / 2**30:.3g} GiB"


def run_case(spec: dict) -> dict:
    """One case (see the module docstring) in this process: computed bytes, and where it fits, times and
    (on CUDA with a memory pool) the measured peak."""
    device = wp.get_device(spec["device"])
    dtype = np_dtype[spec["dtype"]]
    T, N = spec["steps"], spec["envs"]
    every = None if spec["every"] in (None, "auto") else int(spec["every"])
    model = seed_model(dtype, device)
    model.integrator = INTEGRATORS[spec["integrator"]]
    n, scalar = model.dofs(), model.scalar
    roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions",), storage=spec["storage"], checkpoint_every=every)
    shape = (T, N, n)
    computed = roll.memory_bytes(N, joint_force_references=np.broadcast_to(0.0, shape))
    result = {**spec, "computed": computed}
    free = device.free_memory  # 0 on a CPU without psutil
    if free and computed["total"] > 0.9 * free:
        result["skipped"] = f"needs {gib(computed['total'])} (computed), {gib(free)} free"
        return result
    data = standing_data(model, N)
    rng = np.random.default_rng(1)
    tau = wp.array(rng.normal(0.0, 1.0, shape), dtype=scalar, device=device, requires_grad=True)
    squares, total = loss_kernels(scalar)
    pool = device.is_cuda and device.is_mempool_enabled
    wp.synchronize_device(device)
    base = wp.get_mempool_used_mem_current(device) if pool else None

    def once():
        tape = wp.Tape()
        t0 = time.perf_counter()
        with tape:
            _, rec = roll.run(data, joint_force_references=tau)
            per_env = wp.zeros(N, dtype=scalar, device=device, requires_grad=True)
            loss = wp.zeros(1, dtype=scalar, device=device, requires_grad=True)
            s = rec["joint_positions"]
            wp.launch(squares, dim=s.shape, inputs=[s], outputs=[per_env], device=device)
            wp.launch(total, dim=N, inputs=[per_env], outputs=[loss], device=device)
        wp.synchronize_device(device)
        t1 = time.perf_counter()
        tape.backward(loss)
        wp.synchronize_device(device)
        t2 = time.perf_counter()
        tape.zero()
        return t1 - t0, t2 - t1

    once()  # compile, allocate, capture
    times = [once() for _ in range(spec["repeats"])]
    result["forward_s"] = statistics.median(t[0] for t in times)
    result["backward_s"] = statistics.median(t[1] for t in times)
    result["checkpoint_every"] = computed["checkpoint_every"]
    if roll.nbytes != computed["total"]:  # memory_bytes is exact (tests/test_rollout_checkpoint.py)
        raise AssertionError(f"the rollout allocated {roll.nbytes} bytes, memory_bytes computed {computed['total']}")
    if pool:
        result["measured"] = wp.get_mempool_used_mem_high(device) - base
    return result


def case(spec: dict, isolate: bool) -> dict:
    """run_case in a fresh process when `isolate` (a fresh high-water mark), else here."""
    if not isolate:
        return run_case(spec)
    out = subprocess.run([sys.executable, __file__, "--case", json.dumps(spec)], capture_output=True, text=True, cwd=HERE)
    if out.returncode != 0:
        return {**spec, "skipped": "failed: " + (out.stderr.strip().splitlines() or ["?"])[-1]}
    return json.loads(out.stdout.strip().splitlines()[-1])


def per_step(x, r) -> str:
    return "-" if x is None else f"{x / (r['envs'] * r['steps']):,.0f}"


def label(r) -> str:
    if r["storage"] == "trajectory":
        return "trajectory"
    S = r.get("checkpoint_every") or r["computed"].get("checkpoint_every")
    return f"checkpointed, S = {S}" + (" (auto)" if r["every"] in (None, "auto") else "")


def table(rows) -> list:
    lines = [
        "| dtype | storage | computed B/env-step | states | intermediates | controls | records | measured B/env-step | forward [s] | backward [s] |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for r in rows:
        c = r["computed"]
        if "skipped" in r:
            timing = ["not run: " + r["skipped"], "-", "-"]
        else:
            timing = [per_step(r.get("measured"), r), f"{r['forward_s']:.4g}", f"{r['backward_s']:.4g}"]
        parts = [per_step(c[k], r) for k in ("total", "states", "intermediates", "controls", "records")]
        lines.append(f"| {r['dtype']} | {label(r)} | " + " | ".join(parts + timing) + " |")
    return lines


def computed_table(device, integrator: str, dtypes, T: int, N: int, everies) -> list:
    """Lines of a table of `Rollout.memory_bytes` for T steps and N environments (nothing allocated)."""
    lines = [
        "",
        f"## Computed for T = {T} steps, N = {N} environments (`Rollout.memory_bytes`, nothing allocated)",
        "",
        "| dtype | storage | B/env-step | states | intermediates | controls | records | total |",
        "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for dtype in dtypes:
        model = seed_model(np_dtype[dtype], device)
        model.integrator = INTEGRATORS[integrator]
        controls = np.broadcast_to(0.0, (T, N, model.dofs()))
        for storage, every in [("trajectory", None)] + [("checkpointed", e) for e in everies if e is None or e <= T]:
            roll = wd.simulation.Rollout(model, steps=T, record=("joint_positions",), storage=storage, checkpoint_every=every)
            c = roll.memory_bytes(N, joint_force_references=controls)
            r = dict(storage=storage, every=every, steps=T, envs=N, computed=c)
            parts = [per_step(c[k], r) for k in ("total", "states", "intermediates", "controls", "records")]
            lines.append(f"| {dtype} | {label(r)} | " + " | ".join(parts) + f" | {gib(c['total'])} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--steps", type=int, default=100, help="T of the comparison table")
    parser.add_argument("--envs", type=int, default=1024, help="N of the comparison table")
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--integrator", choices=sorted(INTEGRATORS), default="euler")
    parser.add_argument("--every", default="1,4,16,auto", help="checkpoint_every values (auto: the default interval)")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--big-steps", type=int, default=1000)
    parser.add_argument("--big-envs", type=int, default=4096)
    parser.add_argument("--big-dtype", default="float32")
    parser.add_argument("--no-big", action="store_true", help="skip the issue's case")
    parser.add_argument("--output", default=None, help="Markdown report (default benchmarks/results/rollout_memory_<device>.md)")
    parser.add_argument("--case", default=None, help=argparse.SUPPRESS)  # internal: one case, JSON in and out
    args = parser.parse_args()
    wp.config.quiet = True
    wp.config.log_level = wp.LOG_WARNING
    wp.init()
    if args.case is not None:
        print(json.dumps(run_case(json.loads(args.case))))
        return
    device = wp.get_device(args.device)
    isolate = device.is_cuda and device.is_mempool_enabled
    common = dict(device=str(device), integrator=args.integrator, repeats=args.repeats)
    everies = [None if e == "auto" else int(e) for e in args.every.split(",")]
    lines = [
        "# Memory of differentiable rollouts (benchmarks/rollout_memory.py)",
        "",
        "`python benchmarks/rollout_memory.py " + " ".join(sys.argv[1:]) + "`",
        "",
        header(device),
        "",
        f"ergoCub legs (12 joints, 13 links, 32 collidable points), {args.integrator}, per-step torques (T, N, n) with "
        "gradients, joint positions recorded, loss = sum of their squares, forward + backward under a wp.Tape. "
        "Bytes per environment-step = bytes / (N T); 'computed' counts the rollout's buffers and their gradients "
        "(`Rollout.memory_bytes`), 'measured' the memory pool's peak over the case minus what was in use before it "
        "(CUDA only).",
        "",
        f"## T = {args.steps} steps, N = {args.envs} environments",
        "",
    ]
    print("\n".join(lines + table([])), flush=True)
    rows = []
    for dtype in args.dtypes.split(","):
        specs = [dict(common, dtype=dtype, steps=args.steps, envs=args.envs, storage="trajectory", every=None)]
        checkpointed = [e for e in everies if e is None or e <= args.steps]
        specs += [dict(common, dtype=dtype, steps=args.steps, envs=args.envs, storage="checkpointed", every=e) for e in checkpointed]
        for spec in specs:
            rows.append(case(spec, isolate))
            print(table([rows[-1]])[-1], flush=True)
    lines += table(rows)
    section = computed_table(device, args.integrator, args.dtypes.split(","), args.big_steps, args.big_envs, everies)
    print("\n".join(section), flush=True)
    lines += section
    if not args.no_big:
        big = dict(common, dtype=args.big_dtype, steps=args.big_steps, envs=args.big_envs)
        section = ["", f"## Run: T = {args.big_steps} steps, N = {args.big_envs} environments, {args.big_dtype}", ""]
        results = [case(dict(big, storage="checkpointed", every=None), isolate), case(dict(big, storage="trajectory", every=None), isolate)]
        section += table(results) + [""]
        for r in results:
            c, what = r["computed"], label(r)
            if "skipped" in r:
                section.append(f"- {what}: computed {gib(c['total'])}; not run ({r['skipped']}).")
                continue
            measured = f", measured peak {gib(r['measured'])}" if "measured" in r else ""
            rate = r["envs"] * r["steps"] / (r["forward_s"] + r["backward_s"])
            section.append(
                f"- {what}: computed {gib(c['total'])}{measured}; forward {r['forward_s']:.3g} s, backward "
                f"{r['backward_s']:.3g} s ({rate:.3g} env-steps/s forward + backward)."
            )
        print("\n".join(section), flush=True)
        lines += section
    text = "\n".join(lines) + "\n"
    tag = "cpu" if not device.is_cuda else re.sub(r"[^a-z0-9]+", "_", device.name.lower()).strip("_")
    output = pathlib.Path(args.output) if args.output else HERE / "results" / f"rollout_memory_{tag}.md"
    output.write_text(text)
    print(f"written to {output}")


if __name__ == "__main__":
    main()
