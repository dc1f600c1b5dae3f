"""Training curves from the examples' logs (examples/rl_*.py print one line per PPO iteration): a quantity of those
lines against wall time, one curve per log, in one figure. For runs whose machine had no matplotlib (the GPU
machine's) and to put runs side by side.

    python benchmarks/training_curves.py OUT.png LOG [LOG ...] [--quantity reached] [--labels a,b] [--first 0.5,0.9]

A LOG that is not a file may be several logs of one folder joined by "+" (`dir/part1.log+part2.log`): one run
resumed in parts (`--resume`), each part's wall time counted on from the previous part's last iteration (the
restarts between parts, imports and compilation, not counted).

--quantity: "return" (the mean return of the episodes completed in the iteration; iterations without one are
skipped) or a logged entry of the line ("reached", "success", "orientation_error", ...; default "return"). Prints
for each log its iterations, wall time, median env-steps/s, the quantity's last value and its maximum, and with
--first the wall time at which the quantity first exceeded each of those values ("never" if it did not).
"""

from __future__ import annotations

import argparse
import math
import pathlib
import re

_LINE = re.compile(r"^iteration\s+(\d+)\s+mean return\s+(\S+).*?([\d.]+) k env-steps/s.*?([\d.]+) s(?:\s|$)(.*)$")
_LOGGED = re.compile(r"(\S+)\s+(-?\d+(?:\.\d+)?(?:e[-+]?\d+)?|nan)(?=\s|$)")
"""A logged entry after the wall time: a name and its number ("reached 0.97"; "terrain level 2.38" reads as "level")."""


def read(path: pathlib.Path, quantity: str) -> tuple[list[float], list[float], list[float], float]:
    """(wall times [s] and the quantity where it is finite, env-steps/s [k] of every iteration, the last iteration's
    wall time [s]) of the log's iteration lines; logs of one folder joined by "+" read as one run in parts."""
    if "+" in path.name and not path.is_file():
        return read_parts([path.with_name(name) for name in path.name.split("+")], quantity)
    seconds, values, rates, end = [], [], [], float("nan")
    for line in path.read_text().splitlines():
        m = _LINE.match(line)
        if m is None:
            continue
        if quantity == "return":
            value = float(m.group(2))
        else:
            logged = dict(_LOGGED.findall(m.group(5)))
            if quantity not in logged:
                raise SystemExit(f"{path}: its iteration lines log {sorted(logged)}, not {quantity!r}")
            value = float(logged[quantity])
        rates.append(float(m.group(3)))
        end = float(m.group(4))
        if math.isfinite(value):
            seconds.append(end)
            values.append(value)
    if not rates:
        raise SystemExit(f"{path}: no iteration lines (examples/rl_*.py's)")
    return seconds, values, rates, end


def read_parts(paths: list[pathlib.Path], quantity: str) -> tuple[list[float], list[float], list[float], float]:
    """`read` of a run resumed in parts, one log each: each part's wall times offset by the previous parts' last
    iteration times."""
    seconds, values, rates, offset = [], [], [], 0.0
    for path in paths:
        part_seconds, part_values, part_rates, end = read(path, quantity)
        seconds += [offset + t for t in part_seconds]
        values += part_values
        rates += part_rates
        offset += end
    return seconds, values, rates, offset


def first_exceeding(seconds: list[float], values: list[float], threshold: float) -> float | None:
    """The wall time [s] at which the values first exceeded `threshold`; None if they never did."""
    return next((t for t, v in zip(seconds, values) if v > threshold), None)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("out")
    parser.add_argument("logs", nargs="+")
    parser.add_argument("--quantity", default="return")
    parser.add_argument("--labels", default=None, help="comma-separated, one per log (default: the logs' names)")
    parser.add_argument("--first", default="", help="comma-separated values: when the quantity first exceeded each")
    args = parser.parse_args()
    paths = [pathlib.Path(p) for p in args.logs]
    labels = args.labels.split(",") if args.labels else [p.name.removesuffix(".log") for p in paths]
    thresholds = [float(x) for x in args.first.split(",") if x]
    if len(labels) != len(paths):
        parser.error(f"--labels has {len(labels)} names for {len(paths)} logs")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for path, label in zip(paths, labels):
        seconds, values, rates, end = read(path, args.quantity)
        rates = sorted(rates)
        print(f"{label}: {len(rates)} iterations, {end:.1f} s, median {rates[len(rates) // 2]:.1f} k env-steps/s, "
              f"{args.quantity} last {values[-1] if values else float('nan'):.3f}, max {max(values) if values else float('nan'):.3f}"
              + "".join(f", > {th:g} at " + (f"{t:.1f} s" if (t := first_exceeding(seconds, values, th)) is not None else "never")
                        for th in thresholds))  # fmt: skip
        ax.plot(seconds, values, label=label)
    ax.set_xlabel("wall time [s]")
    ax.set_ylabel(args.quantity)
    ax.grid(True)
    ax.legend()
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
