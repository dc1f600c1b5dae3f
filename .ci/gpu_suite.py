"""The whole test suite on a GPU, in pytest processes side by side (kernel compilation for CUDA dominates a
run, and one call of the device tool may last 10 minutes; the device tool's README says how to stage Warp and
the test dependencies there).

    python3 .ci/gpu_suite.py [FILE ...] [--device cuda:0] [--processes 9] [--timeout 540] [--log-dir DIR]
                             [--ignore tests/test_visualization.py ...] [--split tests/test_slow.py ...]
                             [--part 1/3] [--cache DIR] [-- extra pytest arguments]

Each process runs `python3 -P -m pytest` (-P: the installed warpdyn, not the source tree, which has no
kernels/) on its share of the test files (FILE ..., default tests/test_*.py), dealt out by file size, the
largest first, to the process with the least so far. A file named by --split is dealt out test by test (its
tests collected by pytest, each weighing the file's size over their number), so that one slow file does not
hold one process past the others. --part K/M runs the K-th of M parts of that deal (the suite over several
calls of a limited length). Each process has WARPDYN_TEST_DEVICE set (tests/conftest.py) and a Warp kernel
cache (WARP_CACHE_PATH): with --cache, one folder for all, which Warp shares safely (each build is made in a
folder of its process and thread, then renamed into place) and which, kept between calls, spares the
compilations made before; otherwise one new folder each. Each writes its log into --log-dir; a process still
running at --timeout seconds (from the start, the collection of the split files included) is stopped and its log
kept. Prints each process's files, pytest's summary line and the FAILED and ERROR lines of its short summary as
the process ends, then the totals; exits 1 when a test failed or a process did not finish.
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


def shares(units: list[tuple[str, float]], count: int) -> list[list[tuple[str, float]]]:
    """`units` (pytest arguments with their weights) in `count` groups of about equal total weight (the
    heaviest first, each to the lightest group so far)."""
    groups: list[list[tuple[str, float]]] = [[] for _ in range(min(count, len(units)))]
    loads = [0.0] * len(groups)
    for unit in sorted(units, key=lambda u: u[1], reverse=True):
        lightest = loads.index(min(loads))
        groups[lightest].append(unit)
        loads[lightest] += unit[1]
    return groups


def collected(paths: list[pathlib.Path]) -> dict[pathlib.Path, list[str]]:
    """The node ids of the tests in each of `paths`, as one `pytest --collect-only -q` lists them."""
    if not paths:
        return {}
    run = subprocess.run([sys.executable, "-P", "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider", *[str(p.relative_to(ROOT)) for p in paths]],
                         cwd=ROOT, capture_output=True, text=True)
    ids = {path: [line for line in run.stdout.splitlines() if line.startswith(str(path.relative_to(ROOT)) + "::")] for path in paths}
    empty = [str(path) for path, found in ids.items() if not found]
    if empty:
        raise SystemExit(f"gpu_suite: pytest collected no tests from {', '.join(empty)} to split:\n{run.stdout[-2000:]}{run.stderr[-2000:]}")
    return ids


def units(files: list[pathlib.Path], split: set[pathlib.Path]) -> list[tuple[str, float]]:
    """Each file as one unit weighing its size, but the files in `split`: each of their tests a unit."""
    ids = collected([path for path in files if path in split])
    out = []
    for path in files:
        size = float(path.stat().st_size)
        if path in ids:
            out += [(node, size / len(ids[path])) for node in ids[path]]
        else:
            out.append((str(path.relative_to(ROOT)), size))
    return out


def names(group: list[tuple[str, float]]) -> str:
    """The files of a process's share; a split file's with the number of its tests in the share."""
    counts: dict[str, int] = {}
    for node, _ in group:
        stem = pathlib.Path(node.split("::")[0]).stem.removeprefix("test_")
        key = stem + "::" if "::" in node else stem
        counts[key] = counts.get(key, 0) + 1
    return " ".join(f"{key[:-2]}({n} tests)" if key.endswith("::") else key for key, n in counts.items())


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
    parser.add_argument("--split", action="append", default=[], help="a test file dealt out test by test (repeatable)")
    parser.add_argument("--part", default="1/1", help="K/M: run the K-th of M parts of the deal")
    parser.add_argument("--cache", help="one Warp kernel cache folder for every process (default: one new folder each)")
    argv = sys.argv[1:]
    extra = argv[argv.index("--") + 1 :] if "--" in argv else []  # pytest's own arguments, after "--"
    args = parser.parse_args(argv[: argv.index("--")] if "--" in argv else argv)
    part, parts = (int(n) for n in args.part.split("/"))
    if not 1 <= part <= parts:
        parser.error(f"--part {args.part}: K must be within 1..M")
    ignored = {(ROOT / path).resolve() for path in args.ignore}
    given = [(ROOT / path).resolve() for path in args.files] or sorted((ROOT / "tests").glob("test_*.py"))
    files = [p for p in given if p.resolve() not in ignored]
    start = time.monotonic()  # --timeout bounds the whole run, the collection of the split files included
    deal = shares(units(files, {(ROOT / path).resolve() for path in args.split}), parts)[part - 1]
    log_dir = pathlib.Path(args.log_dir)
    log_dir.mkdir(parents=True, exist_ok=True)
    caches = None if args.cache else pathlib.Path(tempfile.mkdtemp(prefix="warpdyn-gpu-suite-"))
    runs = []
    for k, group in enumerate(shares(deal, args.processes)):
        cache = args.cache or str(caches / str(k))
        env = dict(os.environ, WARPDYN_TEST_DEVICE=args.device, WARP_CACHE_PATH=cache)
        log = log_dir / f"gpu_suite_{k}.log"
        command = [sys.executable, "-P", "-m", "pytest", "-q", "-p", "no:cacheprovider", *extra, *[node for node, _ in group]]
        handle = log.open("w")
        runs.append((group, log, handle, subprocess.Popen(command, cwd=ROOT, env=env, stdout=handle, stderr=subprocess.STDOUT)))
    totals: dict = {}
    complete = True
    waiting = dict(enumerate(runs))
    while waiting:  # each process's result printed as it ends (a call cut from outside keeps those printed)
        time.sleep(1.0)
        late = time.monotonic() - start > args.timeout
        for k, (group, log, handle, process) in list(waiting.items()):
            if process.poll() is None and not late:
                continue
            if process.poll() is None:
                process.kill()
                process.wait()
            handle.close()
            del waiting[k]
            counts = summary(log.read_text(errors="replace"))
            complete &= bool(counts) and process.returncode in (0, 1)
            for kind, n in counts.items():
                totals[kind] = totals.get(kind, 0) + n
            result = ", ".join(f"{n} {kind}" for kind, n in counts.items()) or f"no summary (return code {process.returncode})"
            print(f"process {k}: {result} [{names(group)}] at {time.monotonic() - start:.0f} s", flush=True)
            for line in failures(log.read_text(errors="replace")):
                print(f"  {line}", flush=True)
    print(f"device {args.device}, {len(runs)} processes, {time.monotonic() - start:.0f} s: " + ", ".join(f"{n} {kind}" for kind, n in totals.items()))
    return 0 if complete and not totals.get("failed") and not totals.get("error") else 1


if __name__ == "__main__":
    sys.exit(main())
