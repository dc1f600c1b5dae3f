"""The first call of a Stepper and of a Rollout against the later ones: what capturing their graph costs.

    python benchmarks/first_calls.py [--device cpu] [--dtype float64] [--substeps 1,10,100,1000] [--steps 2000]

The seed's ergoCub legs (common.seed_model) with their collidable points, standing on flat ground, one environment.
For each integrator (semi-implicit Euler, RK4) and each number of substeps S: a `Stepper` with use_graph "auto"
(a graph captured at its first call, replayed by the later ones) and one with use_graph False (the first call's
launches recorded, then replayed one by one); printed: the first call's wall time (the median of three new
Steppers), the median time per step of the later calls (at least --steps steps in all), and how many later calls repay the capture (the first calls'
difference over the later calls' difference). Then a `Rollout` of 1000 steps, its first and second run (graphs of
at most 256 steps, warpdyn/engine/rollout_memory.py's GRAPH_CHUNK). The kernels are compiled and loaded before
anything is timed (one `wd.model.step` per integrator).
"""

from __future__ import annotations

import argparse
import statistics

import numpy as np
import warp as wp

import warpdyn as wd
from common import header, median_time, seed_model

INTEGRATORS = {"semi-implicit Euler": wd.model.IntegratorType.SemiImplicitEuler, "RK4": wd.model.IntegratorType.RungeKutta4}


def stepper_times(model, data, substeps: int, use_graph, steps: int, device) -> tuple[float, float]:
    """(the median first call [s] of three new Steppers, the median of the later calls per step [s])."""
    firsts = []
    for _ in range(3):
        stepper = wd.simulation.Stepper(model, data, substeps=substeps, use_graph=use_graph)
        firsts.append(median_time(stepper.step, device, 1, 0.0))  # one call
    return statistics.median(firsts), median_time(stepper.step, device, max(5, steps // substeps), 0.0) / substeps


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--dtype", default="float64")
    parser.add_argument("--substeps", default="1,10,100,1000")
    parser.add_argument("--steps", type=int, default=2000)
    args = parser.parse_args()
    wp.config.quiet = True
    device = wp.get_device(args.device)
    model = wd.contact.with_collidable_points(seed_model(np.dtype(args.dtype), device))
    data = wd.data.Data.build(model, base_position=(0.0, 0.0, 0.6))
    print(header(device))
    print(f"\nergoCub legs with collidable points, one environment, {args.dtype}, dt {model.time_step * 1e3:g} ms\n")
    print("| integrator | substeps | first call, graph [s] | first call, recorded [s] | later, graph [µs/step] | later, recorded [µs/step] | calls that repay the capture |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |", flush=True)
    for name, integrator in INTEGRATORS.items():
        model.integrator = integrator
        wd.model.step(model, data)  # compiles and loads this integrator's modules, and a Stepper's
        wd.simulation.Stepper(model, data, use_graph=False).step()
        for substeps in (int(s) for s in args.substeps.split(",")):
            first_graph, later_graph = stepper_times(model, data, substeps, "auto", args.steps, device)
            first_recorded, later_recorded = stepper_times(model, data, substeps, False, args.steps, device)
            saved, cost = (later_recorded - later_graph) * substeps, first_graph - first_recorded
            repay = "never" if saved <= 0 else ("at once" if cost <= 0 else f"{cost / saved:.0f}")
            print(f"| {name} | {substeps} | {first_graph:.3f} | {first_recorded:.3f} | {later_graph * 1e6:.1f} | {later_recorded * 1e6:.1f} | {repay} |", flush=True)
    model.integrator = INTEGRATORS["semi-implicit Euler"]
    rollout = wd.simulation.Rollout(model, steps=1000, record=())
    runs = [median_time(lambda: rollout.run(data), device, 1, 0.0) for _ in range(2)]
    print(f"\n`Rollout` of 1000 steps, semi-implicit Euler: first run {runs[0]:.3f} s, second {runs[1]:.3f} s")


if __name__ == "__main__":
    main()
