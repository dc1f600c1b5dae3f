"""What a step's Jacobians cost through each contact model: `wd.autodiff.transition_matrices` (A = ∂x'/∂x, B = ∂x'/∂u)
of the legs standing in contact, by the reverse pass (exact to rounding; through the solved models' hand-written
adjoints) and by central differences, soft (JaxSim's K = 1e6), relaxed rigid and rigid.

    python benchmarks/contact_jacobians.py [--device cpu | cuda:0] [--sizes 1,64] [--dtype float64] [--repeats 5]

Scene: benchmarks/speed_accuracy.py's (the seed's ergoCub legs, 32 collidable points, joint PD, the drops' poses
lowered 2 +- 1 mm into the ground), dt = 1 ms, semi-implicit Euler, u = the PD's position targets (the actuators'
ctrl). Each row: the median time of one call over --repeats after a warm-up, per call and per environment, and the
largest difference between the two methods' A relative to its largest entry (central differences at h = 1e-6:
their own error, not the reverse pass's), over the environments where the step is smooth within +-h: in an environment
whose rigid contacts change their active set within +-h, central differences measure the jump, not the derivative
(they then disagree with themselves at h / 10 by more than 1e-3 of the largest entry; where smooth, by the solves'
tolerance over h, 2e-5 at most in 1024 environments); those environments are counted, not compared.
Writes results/contact_jacobians_<tag>.md (tag: cpu or the GPU's name).
"""

from __future__ import annotations

import argparse

import numpy as np
import warp as wp

import speed_accuracy as sa
import warpdyn as wd
from common import header, median_time, seed_model


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--device", default=None)
    parser.add_argument("--sizes", default=None, help="comma-separated N (default 1,64 on the CPU, 1,1024,4096 on a GPU)")
    parser.add_argument("--dtype", default="float64", choices=("float32", "float64"))
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    sizes = [int(n) for n in (args.sizes or ("1,1024,4096" if device.is_cuda else "1,64")).split(",")]
    base = seed_model({"float32": np.float32, "float64": np.float64}[args.dtype], device)
    init = sa.initial_state(seed_model(np.float64, device))
    lines = [
        "# A step's Jacobians through each contact model (benchmarks/contact_jacobians.py)",
        "",
        f"`python benchmarks/contact_jacobians.py{' --sizes ' + args.sizes if args.sizes else ''}`; {header(device)}.",
        f"The legs standing in contact (32 points), joint PD, dt = 1 ms, {args.dtype}; A (36 x 36) and B (36 x 12); median of {args.repeats} calls.",
        "",
        "| contact | N | reverse, call | reverse, per environment | central, call | central, per environment | max |A_reverse - A_central| / max |A| | environments at a switch |",
        "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: |",
    ]
    for setting in sa.contact_settings(["soft", "relaxed", "rigid"], [1e6]):
        model = sa.scene_model(base, sa.SIE, 1e-3, setting)
        for N in sizes:
            data = sa.batch_data(model, init, N)
            results, times = {}, {}
            for method in ("reverse", "central"):

                def call(method=method):
                    results[method] = wd.autodiff.transition_matrices(model, data, control="ctrl", method=method, h=1e-6)

                call()  # compile
                times[method] = median_time(call, device, args.repeats, min_seconds=0.0)
            A, C = results["reverse"]["A"].numpy(), results["central"]["A"].numpy()
            C_fine = wd.autodiff.transition_matrices(model, data, control="ctrl", method="central", h=1e-7)["A"].numpy()
            scale = np.abs(A).max()
            at_switch = np.abs(C - C_fine).reshape(N, -1).max(axis=1) / scale > 1e-3
            gap = float(np.abs(A - C)[~at_switch].max() / scale)
            row = (f"| {setting['label']} | {N} | {times['reverse'] * 1e3:.3g} ms | {times['reverse'] / N * 1e6:.0f} µs | "
                   f"{times['central'] * 1e3:.3g} ms | {times['central'] / N * 1e6:.0f} µs | {gap:.1e} | {int(at_switch.sum())} |")
            print(row, flush=True)
            lines.append(row)
    out = sa.RESULTS / f"contact_jacobians_{sa.device_tag(device)}.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
