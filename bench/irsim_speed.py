"""Steps/s of IR-SIM (``ir-sim``) or IR-SIM-X (``irsim-x``) in BubbleRob's setting, for env_speed.

Usage: ``python bench/irsim_speed.py [--steps N] [--repeats R] [--batch N ...]``; prints one JSON
line: ``{"package": ..., "version": ..., "single": steps/s, "batch": {N: robot-steps/s}}``.

Both packages install a top-level ``irsim``, so one process can hold only one of them:
``bench/env_speed.py`` runs this script once per package, each from its own install folder on
``PYTHONPATH`` (``pip install --target DIR --no-deps ir-sim`` plus the shared dependencies, see
docs/BENCHMARKS.md). The world is BubbleRob's: a 4 x 4 m walled arena, a differential-drive
circle robot of radius 0.11 m, a 360-beam 2D lidar of range 5 m over 360 degrees, 7 cylinders and
boxes (0.08-0.25 m) at seeded positions, a 0.05 s step, seeded random [v, w] actions, and one
lidar scan read per step, as a Gymnasium observation would. Episodes are not reset (IR-SIM's
robot stops at a collision and keeps stepping). ``--batch`` adds irsim-x's own batch mode
(``BatchEnvBase``: one C++ call steps and scans every robot), where it exists.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ARENA = 4.0
RAYS = 360
RANGE_MAX = 5.0
OBSTACLES = 7


def _obstacles(seed: int) -> list[dict[str, Any]]:
    rng = np.random.default_rng(seed)
    found: list[dict[str, Any]] = []
    while len(found) < OBSTACLES:
        size = float(rng.uniform(0.08, 0.25))
        x, y = (float(v) for v in rng.uniform(0.6, ARENA - 0.6, 2))
        if abs(x - ARENA / 2) < 0.6 and abs(y - ARENA / 2) < 0.6:
            continue  # the robot starts in the middle
        if rng.random() < 0.5:
            found.append({"shape": {"name": "circle", "radius": size}, "state": [x, y, 0]})
        else:
            yaw = float(rng.uniform(-np.pi, np.pi))
            shape = {"name": "rectangle", "length": 2 * size, "width": 2 * size}
            found.append({"shape": shape, "state": [x, y, yaw]})
    return found


def world_yaml(seed: int) -> str:
    """The YAML world file, written to a temporary folder; returns its path."""
    world = {
        "world": {"height": ARENA, "width": ARENA, "step_time": 0.05, "sample_time": 0.05},
        "robot": {
            "kinematics": {"name": "diff"},
            "shape": {"name": "circle", "radius": 0.11},
            "state": [ARENA / 2, ARENA / 2, 0],
            "vel_min": [-0.3, -4.0],
            "vel_max": [0.3, 4.0],
            "sensors": [
                {
                    "name": "lidar2d",
                    "range_min": 0.05,
                    "range_max": RANGE_MAX,
                    "angle_range": 2 * np.pi,
                    "number": RAYS,
                }
            ],
        },
        "obstacle": _obstacles(seed),
    }
    path = Path(tempfile.mkdtemp()) / "bubblerob_world.yaml"
    path.write_text(yaml.safe_dump(world))
    return str(path)


def _walls() -> list[dict[str, Any]]:
    return [
        {"type": "rect", "x": x, "y": y, "half_w": length / 2, "half_h": width / 2}
        for x, y, length, width in (
            (ARENA / 2, -0.05, ARENA + 0.2, 0.1),
            (ARENA / 2, ARENA + 0.05, ARENA + 0.2, 0.1),
            (-0.05, ARENA / 2, 0.1, ARENA + 0.2),
            (ARENA + 0.05, ARENA / 2, 0.1, ARENA + 0.2),
        )
    ]


def single(path: str, steps: int, repeats: int, seed: int) -> float:
    """Best steps/s of ``irsim.make`` stepped with random actions, one scan read per step."""
    import irsim

    env = irsim.make(path, display=False, log_level="ERROR")
    actions = np.random.default_rng(seed).uniform([-0.3, -4.0], [0.3, 4.0], size=(steps, 2))
    best = 0.0
    for _ in range(repeats):
        start = time.perf_counter()
        for action in actions:
            env.step(action.reshape(2, 1))
            env.get_lidar_scan()
        best = max(best, steps / (time.perf_counter() - start))
    env.end(0)
    return best


def batch(path: str, size: int, steps: int, repeats: int, seed: int) -> float | None:
    """Best robot-steps/s of irsim-x's ``BatchEnvBase`` (None where the package has none)."""
    try:
        from irsim.env.batch_env_base import BatchEnvBase
    except ImportError:
        return None
    env = BatchEnvBase(path, batch_size=size)
    for obstacle in _obstacles(seed):
        shape, (x, y, yaw) = obstacle["shape"], obstacle["state"]
        if shape["name"] == "circle":
            env.add_obstacle({"type": "circle", "x": x, "y": y, "radius": shape["radius"]})
        else:
            env.add_obstacle(
                {"type": "polygon", "x": 0, "y": 0, "vertices": _box(x, y, yaw, shape)}
            )
    for wall in _walls():
        env.add_obstacle(wall)
    rng = np.random.default_rng(seed)
    count = max(4, steps * 8 // size)
    actions = rng.uniform([-0.3, -4.0], [0.3, 4.0], size=(count, size, 2)).astype(np.float32)
    best = 0.0
    for _ in range(repeats):
        start = time.perf_counter()
        for action in actions:
            env.step(action)
            env.get_lidar_scan()
        best = max(best, count * size / (time.perf_counter() - start))
    env.close()
    return best


def _box(x: float, y: float, yaw: float, shape: dict[str, Any]) -> list[list[float]]:
    """A rotated box's corners (the C++ batch's rects are axis-aligned)."""
    half_l, half_w = shape["length"] / 2, shape["width"] / 2
    c, s = np.cos(yaw), np.sin(yaw)
    corners = ((-half_l, -half_w), (half_l, -half_w), (half_l, half_w), (-half_l, half_w))
    return [[float(x + c * u - s * v), float(y + s * u + c * v)] for u, v in corners]


def main(argv: list[str] | None = None) -> int:
    """Measure and print one JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--steps", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--batch", type=int, nargs="*", default=[])
    args = parser.parse_args(argv)
    package = "irsim-x" if _has("irsim-x") else "ir-sim"
    path = world_yaml(args.seed)
    result: dict[str, Any] = {
        "package": package,
        "version": metadata.version(package),
        "single": single(path, args.steps, args.repeats, args.seed),
        "batch": {n: batch(path, n, args.steps, args.repeats, args.seed) for n in args.batch},
    }
    print(json.dumps(result))
    sys.stdout.flush()
    return 0


def _has(distribution: str) -> bool:
    try:
        metadata.version(distribution)
    except metadata.PackageNotFoundError:
        return False
    return True


if __name__ == "__main__":
    sys.exit(main())
