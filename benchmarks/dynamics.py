"""ABA, RNEA and CRBA of the seed's ergoCub (legs) for N environments, with MuJoCo as a yardstick.

    python benchmarks/dynamics.py [--device cuda:0] [--max-envs 65536] [--dtypes float32,float64]

Times the façade calls `forward_dynamics_aba`, `inverse_dynamics` and `free_floating_mass_matrix`
(one launch each, plus the allocation of their outputs) after a warm-up, as medians. On the CPU the same
run times MuJoCo's `mj_forward` and `mj_inverse` on the same robot (one call, one environment, all
constraints off) when mujoco is installed. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import warp as wp

import warpdyn as wd
from common import ERGOCUB, EXCLUDED, header, init_warp, median_time, np_dtype, seed_model, sizes


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


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--max-envs", type=int, default=65536)
    parser.add_argument("--dtypes", default="float32,float64")
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()
    init_warp()
    device = wp.get_device(args.device)
    print(header(device))
    print()
    print("| algorithm | dtype | N | compile [s] | median per call [ms] | per env [µs] | per second |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for dtype_name in args.dtypes.split(","):
        model = seed_model(np_dtype[dtype_name], device)
        calls = {
            "ABA": lambda m, d, tau: wd.model.forward_dynamics_aba(m, d, joint_forces=tau),
            "RNEA": lambda m, d, tau: wd.model.inverse_dynamics(m, d, joint_accelerations=tau),
            "CRBA": lambda m, d, tau: wd.model.free_floating_mass_matrix(m, d),
        }
        for name, call in calls.items():
            compile_s = float("nan")
            for N in sizes(args.max_envs):
                data = wd.data.random_model_data(model, num_envs=N)
                tau = wp.array(np.random.default_rng(1).uniform(-1, 1, (N, model.dofs())), dtype=model.scalar, device=device)
                t = time.perf_counter()
                call(model, data, tau)
                wp.synchronize_device(device)
                if N == 1:
                    compile_s = time.perf_counter() - t
                seconds = median_time(lambda: call(model, data, tau), device, args.repeats)
                print(
                    f"| {name} | {dtype_name} | {N} | {compile_s:.2f} | {seconds * 1e3:.3f} | "
                    f"{seconds / N * 1e6:.3f} | {N / seconds:.3g} |",
                    flush=True,
                )
                compile_s = float("nan")
    if not device.is_cuda:
        for name, seconds in mujoco_yardstick():
            print(f"| {name} (MuJoCo, C) | float64 | 1 | - | {seconds * 1e3:.4f} | {seconds * 1e6:.3f} | {1 / seconds:.3g} |")


if __name__ == "__main__":
    main()
