"""What a training example's checkpoint holds about its trainer's state: the iteration, the action distribution and
networks its infos name, the learning rate in its optimizer's state, and for a Gaussian policy the standard
deviations of its actions (rsl-rl's `distribution.std_param`, in action units; the environments clip actions to
[-1, 1]). Reads the checkpoints examples/rl_*.py save (their --out holds policy.pt); needs torch only.

    python benchmarks/checkpoint_summary.py POLICY.pt [POLICY.pt ...]
"""

from __future__ import annotations

import argparse
import pathlib

import torch


def summary(path: pathlib.Path) -> str:
    """One line: the checkpoint's iteration, distribution, layers, schedule, learning rate and Gaussian deviations."""
    saved = torch.load(path, map_location="cpu", weights_only=False)
    infos = saved.get("infos") or {}
    rate = float(saved["optimizer_state_dict"]["param_groups"][0]["lr"])
    line = (f"{path}: iteration {saved['iter']}, {infos.get('action_distribution', 'gaussian (no infos)')} policy, "
            f"layers {infos.get('hidden_dims', 'not recorded')}, schedule {infos.get('schedule', 'not recorded')}, learning rate {rate:.3g}")  # fmt: skip
    std = saved["actor_state_dict"].get("distribution.std_param")
    if std is not None:
        line += f", Gaussian standard deviations {float(std.min()):.3g} to {float(std.max()):.3g} (median {float(std.median()):.3g}) over {std.numel()} actions"
    return line


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("policies", nargs="+", type=pathlib.Path)
    args = parser.parse_args(argv)
    missing = [str(p) for p in args.policies if not p.is_file()]
    if missing:
        parser.error(f"no such checkpoint: {', '.join(missing)}")
    for path in args.policies:
        print(summary(path))


if __name__ == "__main__":
    main()
