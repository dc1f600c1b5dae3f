"""ABA, RNEA and CRBA of the seed's ergoCub (legs) for N environments, with MuJoCo as a yardstick.

    python benchmarks/dynamics.py [--device cuda:0] [--max-envs 65536 | --sizes 1,4096,65536]
                                  [--dtypes float32,float64] [--algorithms ABA,RNEA,CRBA]
                                  [--single] [--sweep 64:0,128:0,256:0,128:128] [--forward-only]

Times the façade calls `forward_dynamics_aba` (with joint forces), `inverse_dynamics` (with joint
accelerations) and `free_floating_mass_matrix` on batched data (each call allocates its outputs) after a
warm-up, as medians, synchronising around every call. --single adds single-environment calls (data with
num_envs=None, NumPy inputs: the latency of a plain Python call). --sweep times each algorithm at the
largest N for CUDA settings `block_dim:max_registers` (0: Warp's default block / no register cap; rows
without --sweep use the kernels' tuned MAX_REGISTERS, see warpdyn.config.cuda_launch).
--release-threshold sets the CUDA memory pool's release threshold first (bytes, or a fraction of the
device's memory): with Warp's default, memory freed by a call goes back to the driver at the next
synchronisation and large outputs (CRBA's M) are mapped again by the next call. "kernel only" is the kernel's median device time from Warp's CUDA
activity timing (wp.timing_begin): without the façade's host work (outputs, argument packing, synchronisation). On the CPU the run also times MuJoCo's `mj_forward` and `mj_inverse` on
the same robot (one call, one environment, constraints off) and prints batched ABA per environment
against mj_forward. Prints Markdown tables.
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import ERGOCUB, EXCLUDED, add_size_arguments, chosen_sizes, header, init_warp, median_time, np_dtype, seed_model


def mujoco_yardstick(repeats: int = 2000) -> list[tuple[str, float]]:
    """Median seconds per mj_forward / mj_inverse call on the seed's robot (free joint, legs)."""
    try:
        import mujoco
    except ImportError:
        return []
    import xml.etree.ElementTree as ET

    root = ET.fromstring(ERGOCUB.read_text())
    for link in root.findall("link"):
        for tag in ("visual", "collision"):
            for element in link.findall(tag):
                link.remove(element)
    for joint in root.findall("joint"):
        if joint.get("type") not in ("fixed", "floating") and any(w in joint.get("name") for w in EXCLUDED):
            joint.set("type", "fixed")
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    spec.worldbody.first_body().add_freejoint()
    m = spec.compile()
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    d = mujoco.MjData(m)
    rng = np.random.default_rng(0)
    d.qpos[7:] = rng.uniform(-0.5, 0.5, m.nq - 7)
    d.qvel[:] = rng.uniform(-1, 1, m.nv)
    results = []
    for name, fn in (("mj_forward", mujoco.mj_forward), ("mj_inverse", mujoco.mj_inverse)):
        times = []
        for _ in range(repeats):
            t = time.perf_counter()
            fn(m, d)
            times.append(time.perf_counter() - t)
        results.append((name, float(np.median(times))))
    return results


CALLS = {
    "ABA": lambda m, d, u: wd.model.forward_dynamics_aba(m, d, joint_forces=u),
    "RNEA": lambda m, d, u: wd.model.inverse_dynamics(m, d, joint_accelerations=u),
    "CRBA": lambda m, d, u: wd.model.free_floating_mass_matrix(m, d),
}
KERNEL_NAME = {"ABA": "aba", "RNEA": "rnea", "CRBA": "crba"}


def row(name, dtype_name, N, compile_s, seconds, kernel_s=float("nan"), note="") -> str:
    return (
        f"| {name}{note} | {dtype_name} | {N} | {compile_s:.2f} | {seconds * 1e3:.4f} | "
        f"{seconds / N * 1e6:.4f} | {N / seconds:.3g} | {kernel_s * 1e3:.4f} |"
    )


def kernel_seconds(model, name: str, device, call, data, u, replays: int = 20) -> float:
    """Median device seconds of the kernel's launches over `replays` calls, from Warp's CUDA activity timing
    (wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)): the kernel without the façade's host work. NaN on the CPU."""
    if not device.is_cuda:
        return float("nan")
    call(model, data, u)
    wp.timing_begin(cuda_filter=wp.TIMING_KERNEL)
    for _ in range(replays):
        call(model, data, u)
    results = wp.timing_end()
    times = [r.elapsed for r in results if KERNEL_NAME[name] in r.name]  # milliseconds
    return statistics.median(times) / 1e3 if times else float("nan")


def main() -> None:
    parser = argparse.ArgumentParser()
    add_size_arguments(parser)
    parser.add_argument("--algorithms", default="ABA,RNEA,CRBA")
    parser.add_argument("--repeats", type=int, default=20)
    parser.add_argument("--single", action="store_true", help="also time single-environment calls")
    parser.add_argument("--sweep", default="", help="block_dim:max_registers settings to time at the largest N (CUDA)")
    parser.add_argument("--forward-only", action="store_true", help="compile no adjoints (faster sweeps)")
    parser.add_argument("--release-threshold", type=float, default=None, help="CUDA mempool release threshold")
    args = parser.parse_args()
    init_warp()
    if args.forward_only:
        wp.config.enable_backward = False
    device = wp.get_device(args.device)
    if args.release_threshold is not None and device.is_cuda:
        wp.set_mempool_release_threshold(device, args.release_threshold)
    Ns = chosen_sizes(args, args.max_envs)
    algorithms = args.algorithms.split(",")
    print(header(device))
    if device.is_cuda:
        print(f"CUDA mempool release threshold: {wp.get_mempool_release_threshold(device)} bytes")
    print()
    print("| algorithm | dtype | N | compile [s] | median per call [ms] | per env [µs] | per second | kernel only [ms] |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    largest_aba = {}
    for dtype_name in args.dtypes.split(","):
        model = seed_model(np_dtype[dtype_name], device)
        n = model.dofs()
        for name in algorithms:
            call = CALLS[name]
            first = True

            def first_call(data, u):
                """Seconds of the first call (compilation included for the algorithm's first call), else nan."""
                nonlocal first
                t = time.perf_counter()
                call(model, data, u)
                wp.synchronize_device(device)
                seconds, first = (time.perf_counter() - t if first else float("nan")), False
                return seconds

            if args.single:
                data = wd.data.random_model_data(model)
                u = np.random.default_rng(1).uniform(-1, 1, n)
                compile_s = first_call(data, u)
                seconds = median_time(lambda: call(model, data, u), device, max(args.repeats, 200))
                print(row(name, dtype_name, 1, compile_s, seconds, note=" (single env, NumPy input)"), flush=True)
            for N in Ns:
                data = wd.data.random_model_data(model, num_envs=N)
                u = wp.array(np.random.default_rng(1).uniform(-1, 1, (N, n)), dtype=model.scalar, device=device)
                compile_s = first_call(data, u)
                seconds = median_time(lambda: call(model, data, u), device, args.repeats)
                print(row(name, dtype_name, N, compile_s, seconds, kernel_seconds(model, name, device, call, data, u)), flush=True)
                if name == "ABA":
                    largest_aba[dtype_name] = (N, seconds)
    if args.sweep and device.is_cuda:
        N = max(Ns)
        print()
        print(f"CUDA settings at N = {N} (block_dim:max_registers; 0: Warp's default block, no register cap)")
        print()
        print("| algorithm | dtype | setting | compile [s] | median per call [ms] | per second | kernel only [ms] |")
        print("| --- | --- | --- | ---: | ---: | ---: | ---: |")
        for dtype_name in args.dtypes.split(","):
            model = seed_model(np_dtype[dtype_name], device)
            data = wd.data.random_model_data(model, num_envs=N)
            u = wp.array(np.random.default_rng(1).uniform(-1, 1, (N, model.dofs())), dtype=model.scalar, device=device)
            for name in algorithms:
                for setting in args.sweep.split(","):
                    block_dim, registers = (int(x) or None for x in setting.split(":"))
                    wd.config.cuda_launch[KERNEL_NAME[name]] = (block_dim, registers)
                    t = time.perf_counter()
                    CALLS[name](model, data, u)
                    wp.synchronize_device(device)
                    compile_s = time.perf_counter() - t
                    seconds = median_time(lambda: CALLS[name](model, data, u), device, args.repeats)
                    kernel_s = kernel_seconds(model, name, device, CALLS[name], data, u)
                    print(
                        f"| {name} | {dtype_name} | {setting} | {compile_s:.2f} | {seconds * 1e3:.4f} | {N / seconds:.3g} | "
                        f"{kernel_s * 1e3:.4f} |",
                        flush=True,
                    )
                wd.config.cuda_launch.pop(KERNEL_NAME[name], None)
    if not device.is_cuda:
        yardstick = mujoco_yardstick()
        for name, seconds in yardstick:
            print(f"| {name} (MuJoCo, C) | float64 | 1 | - | {seconds * 1e3:.4f} | {seconds * 1e6:.4f} | {1 / seconds:.3g} | - |")
        forward = dict(yardstick).get("mj_forward")
        if forward:
            print()
            for dtype_name, (N, seconds) in largest_aba.items():
                print(f"batched ABA per environment ({dtype_name}, N = {N}) / mj_forward per call: {seconds / N / forward:.2f}")


if __name__ == "__main__":
    main()
