"""The whole test suite on a GPU, in pytest processes side by side (kernel compilation for CUDA dominates a
run, and one call of the device tool may last 10 minutes; the device tool's README says how to stage Warp and
the test dependencies there).

    python3 .ci/gpu_suite.py [FILE ...] [--device cuda:0] [--processes 9] [--timeout 540] [--log-dir DIR]
                             [--ignore tests/test_visualization.py ...] [-- extra pytest arguments]

Each process runs `python3 -P -m pytest` (-P: the installed warpdyn, not the source tree, which has no
kernels/) on its share of the test files (FILE ..., default tests/test_*.py), dealt out by file size, the
largest first, to the process with the least so far; each has WARPDYN_TEST_DEVICE set (tests/conftest.py) and
a Warp kernel cache of its own (WARP_CACHE_PATH), so that no two compile into one folder. Each writes its log
into --log-dir; a process still running at --timeout seconds is stopped and its log kept. Prints each
process's files, pytest's summary line and the FAILED and ERROR lines of its short summary, then the totals;
exits 1 when a test failed or a process did not finish.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]
SUMMARY = re.compile(r"(\d+) (passed|failed|skipped|errors?|xfailed|xpassed|deselected)")


def shares(files: list[pathlib.Path], count: int) -> list[list[pathlib.Path]]:
    """`files` in `count` groups of about equal total size (the largest first, each to the lightest group)."""
    groups: list[list[pathlib.Path]] = [[] for _ in range(min(count, len(files)))]
    loads = [0] * len(groups)
    for path in sorted(files, key=lambda p: p.stat().st_size, reverse=True):
        lightest = loads.index(min(loads))
        groups[lightest].append(path)
        loads[lightest] += path.stat().st_size
    return groups


def summary(log: str) -> dict:
    """pytest's counts from the last summary line of a log ({} when the run did not reach one)."""
    lines = [line for line in log.splitlines() if re.search(r" in [\d.]+s", line) and SUMMARY.search(line)]
    if not lines:
        return {}
    return {kind.rstrip("s") if kind.startswith("error") else kind: int(n) for n, kind in SUMMARY.findall(lines[-1])}


def failures(log: str, width: int = 300) -> list[str]:
    """pytest's FAILED and ERROR lines of a log's short test summary, each cut to `width` characters (the
    device tool returns a few log files only, and the last lines of what a call prints)."""
    return [line[:width] for line in log.splitlines() if line.startswith(("FAILED ", "ERROR "))]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("files", nargs="*", help="test files (default: tests/test_*.py)")
    parser.add_argument("--device", default="cuda:0")
    parser.add_argument("--processes", type=int, default=9)
    parser.add_argument("--timeout", type=float, default=540.0, help="seconds before the processes still running are stopped")
    parser.add_argument("--log-dir", default=os.environ.get("OUT", "."))
    parser.add_argument("--ignore", action="append", default=[], help="a test file not to run (repeatable)")
    args, extra = parser.parse_known_args()
    extra = [a for a in extra if a != "--"]
    ignored = {(ROOT / path).resolve() for path in args.ignore}
    given = [(ROOT / path).resolve() for path in args.files] or sorted((ROOT / "tests").glob("test_*.py"))
    files = [p for p in given if p.resolve() not in ignored]
    log_dir = pathlib.Path(args.log_dir)
    log_dir.mkdir(parents=True, exist_ok=True)
    caches = pathlib.Path(tempfile.mkdtemp(prefix="warpdyn-gpu-suite-"))
    runs = []
    start = time.monotonic()
    for k, group in enumerate(shares(files, args.processes)):
        env = dict(os.environ, WARPDYN_TEST_DEVICE=args.device, WARP_CACHE_PATH=str(caches / str(k)))
        log = log_dir / f"gpu_suite_{k}.log"
        command = [sys.executable, "-P", "-m", "pytest", "-q", "-p", "no:cacheprovider", *extra, *[str(p.relative_to(ROOT)) for p in group]]
        handle = log.open("w")
        runs.append((group, log, handle, subprocess.Popen(command, cwd=ROOT, env=env, stdout=handle, stderr=subprocess.STDOUT)))
    for _, _, handle, process in runs:
        try:
            process.wait(timeout=max(1.0, args.timeout - (time.monotonic() - start)))
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        handle.close()
    totals: dict = {}
    complete = True
    for k, (group, log, _, process) in enumerate(runs):
        counts = summary(log.read_text(errors="replace"))
        complete &= bool(counts) and process.returncode in (0, 1)
        for kind, n in counts.items():
            totals[kind] = totals.get(kind, 0) + n
        names = " ".join(p.stem.removeprefix("test_") for p in group)
        result = ", ".join(f"{n} {kind}" for kind, n in counts.items()) or f"no summary (return code {process.returncode})"
        print(f"process {k}: {result} [{names}]")
        for line in failures(log.read_text(errors="replace")):
            print(f"  {line}")
    print(f"device {args.device}, {len(runs)} processes, {time.monotonic() - start:.0f} s: " + ", ".join(f"{n} {kind}" for kind, n in totals.items()))
    return 0 if complete and not totals.get("failed") and not totals.get("error") else 1


if __name__ == "__main__":
    sys.exit(main())
