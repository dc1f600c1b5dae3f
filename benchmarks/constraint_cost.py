"""What equality constraints cost a step: MuJoCo Menagerie's Cassie (4 connects closing its leg linkages, a
floating base) with and without its constraints.

    python benchmarks/constraint_cost.py [--device cuda:0] [--sizes 1,256,4096] [--dtypes float32,float64]
                                         [--repeats 10]

The model is tests/models/menagerie/cassie.xml (Menagerie's agility_cassie, its licence beside it), its contact
points disabled (the step's dynamics alone), and the same file without its `<equality>` section. Each row times a
`wd.simulation.Stepper` of 10 substeps (median per step over `repeats` calls, after a warm-up, from MuJoCo's
qpos0 at rest). Both take the launch list (Cassie's ball joints are not the fused step's); `constrained` adds
the constraints' stage (warpdyn.engine.equality: CRBA, the anchors' Jacobians and J̇ν, the solve). Prints the
header (device, versions) and a Markdown table.
"""

from __future__ import annotations

import pathlib
import re
import warnings

import numpy as np

import warpdyn as wd
from common import header, median_time, np_dtype, side_by_side_setup

CASSIE = pathlib.Path(__file__).resolve().parents[1] / "tests" / "models" / "menagerie" / "cassie.xml"
SUBSTEPS = 10


def load(xml: str, dtype, device) -> wd.model.Model:
    """The model of `xml` with its contact points disabled."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # what Cassie holds that warpdyn does not model (its warnings name it)
        model = wd.model.Model.build_from_model_description(xml, dtype=dtype, device=device)
    points = len(model.kin_dyn_parameters.contact_parameters.body)
    return wd.contact.with_collidable_points(model, enabled=[False] * points) if points else model


def step_time(model, N: int, device, repeats: int) -> float:
    """The median seconds per step of a Stepper of SUBSTEPS substeps over N environments."""
    stepper = wd.simulation.Stepper(model, wd.data.Data.build(model, num_envs=N), substeps=SUBSTEPS)
    for _ in range(2):
        stepper.step()
    seconds = median_time(stepper.step, device, repeats) / SUBSTEPS
    if not bool(np.all(stepper.data.valid_state.numpy() == 1)):
        raise RuntimeError(f"{model.name()}: an environment was flagged")
    return seconds


def main() -> None:
    args, device, Ns = side_by_side_setup(repeats=10)
    text = CASSIE.read_text()
    free = re.sub(r"<equality>.*?</equality>", "", text, flags=re.S)
    print(header(device))
    print()
    print("| dtype | N | constrained [ms] | unconstrained [ms] | constrained / unconstrained |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for dtype_name in args.dtypes.split(","):
        dtype = np_dtype[dtype_name]
        constrained, unconstrained = load(str(CASSIE), dtype, device), load(free, dtype, device)
        assert len(constrained.tree.equalities) == 4 and not unconstrained.tree.equalities
        for N in Ns:
            t_c, t_u = step_time(constrained, N, device, args.repeats), step_time(unconstrained, N, device, args.repeats)
            print(f"| {dtype_name} | {N} | {1e3 * t_c:.4f} | {1e3 * t_u:.4f} | {t_c / t_u:.2f} |", flush=True)


if __name__ == "__main__":
    main()
