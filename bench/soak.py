"""Soak test: many random-action steps of ``BubbleRob-v0``, every one checked by a geometry oracle.

Usage: ``python bench/soak.py [--steps N] [--seed S] [--warmup W] [--quick]``

One env (``action_type="twist"``, every other setting the default: random start poses, 4-10
obstacles, episodes that end on collision) is driven by seeded random actions, each held for 1-20
steps, mostly forward and mostly turning gently, so that it hits walls and obstacles often.
Episode ``k`` is reset with seed ``S + k``, so any failure it prints can be replayed alone. After
every reset and every step it checks:

- observations and info hold no NaN or infinity, and observations are inside the observation space;
- the start pose is free (the robot's footprint clear of every obstacle and wall);
- no undetected penetration: while ``info["collision"]`` is False the robot's footprint overlaps no
  obstacle and no wall by more than ``CONTACT_TOL``;
- no phantom collision: when ``info["collision"]`` is True the footprint came within
  ``CONTACT_TOL`` of an obstacle or a wall after one of the step's physics steps (the env reports a
  contact seen after any of them; the step is replayed from its saved state to get those poses);
- the robot's centre (base_link) is never inside an obstacle, and a reported collision is never
  deeper than ``DEEP_COLLISION`` (a robot that deep is driving through);
- memory stays flat: resident memory after ``--warmup`` steps and at the end differ by at most
  ``--max-growth-mib``.

The oracle is written here, independent of the env's geometry: the robot seen from above is the
chassis sphere's disc (r 0.075 m at (-0.015, 0) in base_link) and the two wheels' rectangles
(0.08 x 0.02 m at y = +-0.09), placed with the free joint's pose from ``info``; obstacles are the
layout's circles and rotated rectangles; the walls' inner faces are at +-arena_size / 2.
``tests/test_solid_world.py`` checks it against that file's own oracle.

It prints progress to stderr, then one table of results, and exits 1 if any check failed.
``--quick`` (20000 steps) is what CI runs.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import sys
import time
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)

CHASSIS_XY = (-0.015, 0.0)
CHASSIS_Z = 0.05
CHASSIS_RADIUS = 0.075
WHEEL_Y = 0.09
WHEEL_HALF = (0.04, 0.01)  # half extents of a wheel's footprint along base_link x and y
ROBOT_BOUND = 0.11  # a circle about base_link that holds the whole footprint
CONTACT_TOL = 0.002  # metres
DEEP_COLLISION = 0.015  # metres

Shape = tuple  # ("circle", x, y, r) or ("box", x, y, yaw, half_x, half_y)


def footprint(position: Any, quat_wxyz: Any) -> list[Shape]:
    """The robot's parts seen from above, for a free-joint pose."""
    w, x, y, z = (float(v) for v in quat_wxyz)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    w, x, y, z = w / n, x / n, y / n, z / n
    r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
    r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
    px, py = float(position[0]), float(position[1])
    cx, cy = CHASSIS_XY
    chassis_x = px + r00 * cx + r01 * cy + r02 * CHASSIS_Z
    chassis_y = py + r10 * cx + r11 * cy + r12 * CHASSIS_Z
    parts: list[Shape] = [("circle", chassis_x, chassis_y, CHASSIS_RADIUS)]
    yaw = math.atan2(r10, r00)
    for side in (1.0, -1.0):
        parts.append(
            ("box", px + r01 * side * WHEEL_Y, py + r11 * side * WHEEL_Y, yaw, *WHEEL_HALF)
        )
    return parts


def _corners(box: Shape) -> list[tuple[float, float]]:
    _, x, y, yaw, hx, hy = box
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (x + c * a - s * b, y + s * a + c * b)
        for a, b in ((hx, hy), (-hx, hy), (-hx, -hy), (hx, -hy))
    ]


def _box_sdf(box: Shape, px: float, py: float) -> float:
    _, x, y, yaw, hx, hy = box
    c, s = math.cos(yaw), math.sin(yaw)
    qx = abs(c * (px - x) + s * (py - y)) - hx
    qy = abs(-s * (px - x) + c * (py - y)) - hy
    return math.hypot(max(qx, 0.0), max(qy, 0.0)) + min(max(qx, qy), 0.0)


def sdf(shape: Shape, px: float, py: float) -> float:
    """Signed distance from a point to a shape (negative inside)."""
    if shape[0] == "circle":
        return math.hypot(px - shape[1], py - shape[2]) - shape[3]
    return _box_sdf(shape, px, py)


def separation(a: Shape, b: Shape) -> float:
    """Distance between two convex shapes, or minus their penetration depth."""
    if a[0] == "circle":
        return sdf(b, a[1], a[2]) - a[3]
    if b[0] == "circle":
        return sdf(a, b[1], b[2]) - b[3]
    ca, cb = _corners(a), _corners(b)
    depth = math.inf
    for yaw in (a[3], a[3] + math.pi / 2, b[3], b[3] + math.pi / 2):
        ux, uy = math.cos(yaw), math.sin(yaw)
        pa = [ux * x + uy * y for x, y in ca]
        pb = [ux * x + uy * y for x, y in cb]
        depth = min(depth, min(max(pa), max(pb)) - max(min(pa), min(pb)))
    if depth > 0.0:
        return -depth
    return min(min(_box_sdf(b, *p) for p in ca), min(_box_sdf(a, *p) for p in cb))


def wall_separation(part: Shape, half: float) -> float:
    """Distance from a part to the nearest wall's inner face (negative: into it)."""
    if part[0] == "circle":
        return half - max(abs(part[1]), abs(part[2])) - part[3]
    return half - max(max(abs(x), abs(y)) for x, y in _corners(part))


def obstacle_shape(obstacle: Any) -> Shape:
    if obstacle.kind == "cylinder":
        return ("circle", obstacle.x, obstacle.y, obstacle.size[0])
    return ("box", obstacle.x, obstacle.y, obstacle.yaw, *obstacle.size)


def clearance(
    x: float, y: float, parts: list[Shape], shapes: list[tuple[Shape, float]], half: float
) -> tuple[float, str]:
    """Separation of the footprint (base_link at x, y) from the nearest wall or obstacle, and
    which of the two that is (``"wall"`` or ``"obstacle"``).

    Obstacles more than 1 cm beyond the robot's bounding circle are not measured: the result is
    exact when below 1 cm, and at least 1 cm otherwise.
    """
    gap, nearest = min(wall_separation(part, half) for part in parts), "wall"
    for shape, bound in shapes:
        if math.hypot(x - shape[1], y - shape[2]) < ROBOT_BOUND + bound + 0.01:
            here = min(separation(part, shape) for part in parts)
            if here < gap:
                gap, nearest = here, "obstacle"
    return gap, nearest


STATE = mujoco.mjtState.mjSTATE_INTEGRATION


def substep_poses(env: Any, state: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    """Base (position, quaternion wxyz) after each physics step of the control step just taken.

    ``state`` is ``mj_getState(..., STATE)`` from before the step. The step is replayed on a scratch
    ``MjData`` the way the env steps (mj_step1, then mj_step2 and mj_step1 per substep) with the
    wheel commands the env applied; the last pose is the env's own.
    """
    base = env.unwrapped
    model, data = base.model, mujoco.MjData(base.model)
    data.mocap_pos[:], data.mocap_quat[:] = base.data.mocap_pos, base.data.mocap_quat
    mujoco.mj_setState(model, data, state, STATE)
    data.ctrl[:] = base.data.ctrl
    mujoco.mj_step1(model, data)
    adr = int(model.joint("root").qposadr[0])
    poses = []
    for _ in range(base.physics_substeps):
        mujoco.mj_step2(model, data)
        mujoco.mj_step1(model, data)
        poses.append((data.qpos[adr : adr + 3].copy(), data.qpos[adr + 3 : adr + 7].copy()))
    return poses


def resident_mib() -> float:
    """Resident memory now (Linux /proc), else the peak so far, in MiB."""
    try:
        with open(f"/proc/{os.getpid()}/statm") as statm:
            return int(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE") / 2**20
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def finite(value: Any) -> bool:
    if isinstance(value, np.ndarray):
        return not np.issubdtype(value.dtype, np.number) or bool(np.isfinite(value).all())
    if isinstance(value, (float, np.floating)):
        return math.isfinite(value)
    return True


class Soak:
    """Counts, extremes and the first few failures of one soak run."""

    def __init__(self) -> None:
        self.steps = self.episodes = self.collisions = self.obstacle_collisions = 0
        self.non_finite = self.outside_space = self.bad_starts = 0
        self.undetected = self.phantoms = self.centre_inside = self.deep = 0
        self.max_hidden_depth = 0.0  # deepest overlap while no collision was reported
        self.max_collision_depth = 0.0
        self.examples: list[str] = []

    def fail(self, counter: str, message: str) -> None:
        setattr(self, counter, getattr(self, counter) + 1)
        if len(self.examples) < 10:
            self.examples.append(message)


def run(args: argparse.Namespace) -> int:
    env = gym.make("BubbleRob-v0", action_type="twist")
    robot: Any = env.unwrapped
    half = robot.arena_size / 2
    space = env.observation_space
    rng = np.random.default_rng(args.seed)
    soak = Soak()
    action = np.zeros(2, dtype=np.float32)
    hold = 0
    rss_start = rss_end = resident_mib()
    began = time.perf_counter()

    def new_episode() -> tuple[int, list[tuple[Shape, float]]]:
        seed = args.seed + soak.episodes
        soak.episodes += 1
        obs, info = env.reset(seed=seed)
        check(obs, info, seed, shapes_of(), step=0)
        return seed, shapes_of()

    def shapes_of() -> list[tuple[Shape, float]]:
        shapes = []
        for obstacle in robot.layout.obstacles:
            shape = obstacle_shape(obstacle)
            bound = shape[3] if shape[0] == "circle" else math.hypot(shape[4], shape[5])
            shapes.append((shape, bound))
        return shapes

    def substep_gap(shapes: list) -> float:
        """The closest the footprint came to anything during the step just taken."""
        gaps = []
        for position, quat in substep_poses(env, state):
            parts = footprint(position, quat)
            gaps.append(clearance(position[0], position[1], parts, shapes, half)[0])
        return min(gaps)

    def check(obs: dict, info: dict, seed: int, shapes: list, step: int) -> None:
        where = f"episode seed {seed} step {step}"
        if not all(finite(v) for v in obs.values()) or not all(finite(v) for v in info.values()):
            soak.fail("non_finite", f"{where}: NaN or inf in obs or info")
            return
        if not space.contains(obs):
            soak.fail("outside_space", f"{where}: observation outside the observation space")
        parts = footprint(info["position"], info["quaternion_wxyz"])
        gap, nearest = clearance(info["x"], info["y"], parts, shapes, half)
        if step == 0:
            if gap < 0.0:
                soak.fail("bad_starts", f"{where}: start pose overlaps by {-1000 * gap:.1f} mm")
            return
        if any(sdf(shape, info["x"], info["y"]) <= 0.0 for shape, _ in shapes):
            soak.fail("centre_inside", f"{where}: robot centre inside an obstacle")
        if info["collision"]:
            soak.collisions += 1
            soak.obstacle_collisions += nearest == "obstacle"
            soak.max_collision_depth = max(soak.max_collision_depth, -gap)
            if gap > CONTACT_TOL and substep_gap(shapes) > CONTACT_TOL:
                soak.fail("phantoms", f"{where}: collision {1000 * gap:.1f} mm from everything")
            if -gap > DEEP_COLLISION:
                soak.fail("deep", f"{where}: collision {-1000 * gap:.1f} mm deep")
        else:
            soak.max_hidden_depth = max(soak.max_hidden_depth, -gap)
            if -gap > CONTACT_TOL:
                soak.fail("undetected", f"{where}: {-1000 * gap:.1f} mm deep, no collision")

    state = np.empty(mujoco.mj_stateSize(robot.model, STATE))
    seed, shapes = new_episode()
    step_in_episode = 0
    progress_at = args.progress_every
    for step in range(1, args.steps + 1):
        if hold == 0:
            # Mostly forward with mostly gentle turns, so that walls and obstacles get hit often.
            hold = int(rng.integers(1, 21))
            turn = rng.uniform(-1.0, 1.0) * rng.uniform(0.0, 1.0) ** 2
            action = np.array([rng.uniform(-0.2, 1.0), turn], dtype=np.float32)
        hold -= 1
        mujoco.mj_getState(robot.model, robot.data, state, STATE)
        obs, _, terminated, truncated, info = env.step(action)
        soak.steps = step
        step_in_episode += 1
        check(obs, info, seed, shapes, step_in_episode)
        if terminated or truncated:
            seed, shapes = new_episode()
            step_in_episode = 0
            hold = 0
        if step == args.warmup:
            rss_start = resident_mib()
        if step >= progress_at:
            progress_at += args.progress_every
            rate = step / (time.perf_counter() - began)
            print(
                f"soak: {step}/{args.steps} steps, {soak.episodes} episodes, "
                f"{soak.collisions} collisions, {rate:.0f} steps/s, RSS {resident_mib():.1f} MiB",
                file=sys.stderr,
                flush=True,
            )
    rss_end = resident_mib()
    elapsed = time.perf_counter() - began
    env.close()

    growth = rss_end - rss_start
    rows = [
        ("steps", f"{soak.steps}", "", True),
        ("episodes (resets)", f"{soak.episodes}", "", True),
        (
            "collisions reported",
            f"{soak.collisions} ({soak.obstacle_collisions} with obstacles, "
            f"{soak.collisions - soak.obstacle_collisions} with walls)",
            "",
            True,
        ),
        ("NaN / inf in obs or info", f"{soak.non_finite}", "0", soak.non_finite == 0),
        ("obs outside the space", f"{soak.outside_space}", "0", soak.outside_space == 0),
        ("start pose not free", f"{soak.bad_starts}", "0", soak.bad_starts == 0),
        (
            "undetected penetration",
            f"{soak.undetected} (deepest {1000 * soak.max_hidden_depth:.2f} mm)",
            f"0 deeper than {1000 * CONTACT_TOL:.0f} mm",
            soak.undetected == 0,
        ),
        (
            "phantom collisions",
            f"{soak.phantoms}",
            f"0 farther than {1000 * CONTACT_TOL:.0f} mm",
            soak.phantoms == 0,
        ),
        (
            "penetration at a collision",
            f"max {1000 * soak.max_collision_depth:.2f} mm",
            f"{1000 * DEEP_COLLISION:.0f} mm",
            soak.deep == 0,
        ),
        ("centre inside an obstacle", f"{soak.centre_inside}", "0", soak.centre_inside == 0),
        (
            "memory growth after warm-up",
            f"{growth:+.1f} MiB ({rss_start:.1f} -> {rss_end:.1f} MiB)",
            f"{args.max_growth_mib:.0f} MiB",
            growth <= args.max_growth_mib,
        ),
        ("speed", f"{soak.steps / elapsed:.0f} steps/s ({elapsed:.1f} s)", "", True),
    ]
    if args.steps <= args.warmup:
        rows[-2] = ("memory growth after warm-up", "not measured (steps <= warmup)", "", True)
    header = ("check", "result", "limit")
    widths = [max(len(row[i]) for row in [header, *rows]) for i in range(3)]
    print(f"BubbleRob-v0 soak, seed {args.seed}")
    print("| " + " | ".join(h.ljust(w) for h, w in zip(header, widths, strict=True)) + " | ok  |")
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|-----|")
    for name, value, limit, ok in rows:
        cells = " | ".join(c.ljust(w) for c, w in zip((name, value, limit), widths, strict=True))
        print(f"| {cells} | {'yes' if ok else 'NO '} |")
    for example in soak.examples:
        print(f"  {example}")
    failed = [name for name, _, _, ok in rows if not ok]
    print("FAILED: " + ", ".join(failed) if failed else "PASSED")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=200_000, help="control steps in all")
    parser.add_argument("--seed", type=int, default=0, help="actions' seed; episode k uses S+k")
    parser.add_argument("--warmup", type=int, default=None, help="steps before memory is measured")
    parser.add_argument("--max-growth-mib", type=float, default=8.0)
    parser.add_argument("--progress-every", type=int, default=None)
    parser.add_argument("--quick", action="store_true", help="20000 steps (CI)")
    args = parser.parse_args(argv)
    if args.quick:
        args.steps = 20_000
    if args.warmup is None:
        args.warmup = min(5_000, args.steps // 10)
    if args.progress_every is None:
        args.progress_every = max(args.steps // 10, 1)
    return run(args)


if __name__ == "__main__":
    sys.exit(main())
