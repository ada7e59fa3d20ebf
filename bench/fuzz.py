"""Long property-based and fuzzing run of issue #23's tests: many more, fresh random, examples.

Usage: ``python bench/fuzz.py [--scale N] [--quick]``

Runs ``tests/test_properties.py`` (env kwargs, actions, CLI arguments),
``tests/ros/test_cli_properties.py`` (record, replay and map arguments, valid ones run) and
``tests/ros/test_bag_fuzz.py`` (byte flips and truncations of every bag format through ``info``,
``replay``, ``recover`` and ``map``) with ``BUBBLEROB_FUZZ_SCALE=N``: every Hypothesis budget
``N`` times CI's, and random instead of derandomised, so each run tries examples CI never did.
Prints one table (test, examples passing, failing), the time, and exits 1 if any failed;
Hypothesis prints each failure's smallest example, which replays alone. ``--quick`` is scale 2
(860 examples, 89 s on the 2-core development machine); scale 8 took 644 s for 3440 examples, so
the default scale 20 takes about 27 minutes.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TESTS = [
    "tests/test_properties.py",
    "tests/ros/test_cli_properties.py",
    "tests/ros/test_bag_fuzz.py",
]
_STATS = re.compile(
    r"^(?P<test>\S+::\S+):\n(?:.*\n)*?\s+- (?P<passing>\d+) passing, (?P<failing>\d+) failing",
    re.MULTILINE,
)


def main(argv: list[str] | None = None) -> int:
    """Run the fuzz tests at ``--scale`` and print their table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", type=int, default=20, help="times CI's example budget")
    parser.add_argument("--quick", action="store_true", help="scale 2: a short check")
    args = parser.parse_args(argv)
    scale = 2 if args.quick else args.scale
    if scale < 1:
        parser.error(f"--scale must be >= 1, got {scale}")
    env = {**os.environ, "BUBBLEROB_FUZZ_SCALE": str(scale)}
    started = time.perf_counter()
    result = subprocess.run(
        [sys.executable, "-m", "pytest", *TESTS, "-q", "-p", "no:cacheprovider"]
        + ["--hypothesis-show-statistics"],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        check=False,
    )
    seconds = time.perf_counter() - started
    rows = [
        (m["test"].split("::", 1)[1], int(m["passing"]), int(m["failing"]))
        for m in _STATS.finditer(result.stdout)
    ]
    width = max((len(name) for name, _, _ in rows), default=10)
    print(f"fuzz at {scale}x CI's budget (random examples), {seconds:.0f} s in all")
    print(f"| {'test':<{width}} | passing | failing |")
    print(f"|{'-' * (width + 2)}|---------|---------|")
    for name, passing, failing in rows:
        print(f"| {name:<{width}} | {passing:>7} | {failing:>7} |")
    total = sum(p + f for _, p, f in rows)
    print(f"examples: {total}; pytest exit {result.returncode}")
    if result.returncode != 0:
        tail = "\n".join(result.stdout.splitlines()[-60:])
        print(tail, file=sys.stderr)
        print("FAILED", flush=True)
        return 1
    print("PASSED")
    return 0


if __name__ == "__main__":
    sys.exit(main())
