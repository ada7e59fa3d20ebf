"""Env steps/s of ``BubbleRob-v0`` against an honest raw-MuJoCo engine floor and Gymnasium's envs.

Usage: ``python bench/env_speed.py [--steps N] [--repeats R] [--quick] [--markdown]``

What is measured, all in one run and one process (steps/s = control steps per wall-clock second):

- ``BubbleRob-v0`` through ``gym.make`` (its wrappers included) with 0/180/360/720 laser rays
  and the camera off, and with 360 rays and the 64x64 camera. A seeded random action sequence
  drives the robot; episodes reset when they terminate or truncate, inside the timed loop, as in
  a training loop. Each step is one 0.05 s control step.
- The "engine floor": what MuJoCo alone must do for one env step, with no Python env around it.
  The env's own model and a copy of its data after a reset (obstacles placed: their sizes are in
  the model, their poses in the data's mocap arrays), stepped exactly as ``env.step`` steps them
  (per control step: the wheel commands into ``ctrl``, then ``physics_substeps`` = 4 times
  ``mj_step2`` + ``mj_step1`` at the env's 12.5 ms timestep), plus one ``mj_multiRay`` of the
  laser's 360 rays with the laser's own settings (directions rotated by the laser site's frame,
  geom group 0 only, ``range_max`` cutoff). It restarts from the copied data every 1000 steps, as
  the env truncates. The gap between the env and this floor is the env's own cost: Python in
  ``step``, reading sensors, reward, ``info``, the wrappers and the episode resets.
- Two extra floor lines: "physics only" (the same without the scan, to set against the env with
  no laser) and the "naive floor" that earlier versions of this bench used as the reference:
  MuJoCo's default 2 ms timestep (25 ``mj_step`` per control step) and an unfiltered 360-ray scan
  (every geom tested, only the robot's base body excluded, no cutoff). The env never runs that
  loop: it is kept only to show what the env's physics settings and laser filters save.
- Gymnasium's ``Ant-v5`` and ``HalfCheetah-v5`` with random actions (reset when done), as
  familiar anchors. A row that fails to build or run shows its error instead.

Every row warms up first; then all rows are timed ``repeats`` times, interleaved (row 1, row 2,
..., row 1, ...), and each keeps its best run, so that load from other processes, which can only
slow a run down, is filtered out as far as possible; the load average printed at the end says how
busy the machine was. ``--quick`` (50 steps, one run) is a smoke test: its numbers mean little.

Reading the ratios: ``x floor`` is a row's steps/s divided by the engine floor's (360 rays), so
the 360-ray env row's ratio is the share of its time that MuJoCo's own work takes; the target is
>= ``TARGET_FLOOR_RATIO``. (Rows with another ray count are set against the same 360-ray floor.)
``x Ant`` is steps/s divided by ``Ant-v5``'s. Both compare control steps, which here are the same
thing: a BubbleRob step, an Ant-v5 step and a HalfCheetah-v5 step are each 0.05 s of simulated
time (the anchors: frame_skip 5 x 10 ms).
"""

from __future__ import annotations

import argparse
import copy
import datetime
import os
import platform
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from vector_speed import SIZES, BatchBench, batch_label, env_speed_notes  # bench/ is on sys.path

import bubblerob_env  # registers BubbleRob-v0 and picks MUJOCO_GL=egl without a display
from bubblerob_env import names

NAIVE_TIMESTEP = 0.002  # MuJoCo's default timestep
NAIVE_RAYS = 360
NO_CUTOFF = 1e9
FLOOR_RAYS = 360
FLOOR_LABEL = f"engine floor: env's step2+step1 x4 @12.5ms + {FLOOR_RAYS} rays"
PHYSICS_FLOOR_LABEL = "engine floor, physics only (no rays)"
NAIVE_LABEL = f"naive floor: mj_step x25 @2ms + {NAIVE_RAYS} unfiltered rays"
LASER_LABEL = "BubbleRob-v0 laser 360, no camera"
NO_LASER_LABEL = "BubbleRob-v0 laser 0, no camera"
CAMERA_SIZE = 64
CAMERA_LABEL = f"BubbleRob-v0 laser 360, camera {CAMERA_SIZE}x{CAMERA_SIZE}"
ANT_LABEL = "Ant-v5"
LASER_ROWS = (0, 180, 360, 720)
TARGET_FLOOR_RATIO = 0.8
TARGET_CAMERA_RATE = 600.0


class Bench:
    """One configuration: built once, then ``run`` times ``steps`` control steps from its start."""

    def run(self, steps: int) -> float:
        """Seconds of wall-clock time for ``steps`` control steps."""
        raise NotImplementedError

    def close(self) -> None:
        """Free what the configuration holds."""


class EnvBench(Bench):
    """A Gymnasium env from ``gym.make`` stepped with a seeded random action sequence."""

    def __init__(self, env_id: str, steps: int, seed: int, **kwargs: Any) -> None:
        self.env = gym.make(env_id, **kwargs)
        self.seed = seed
        space = self.env.action_space
        assert isinstance(space, gym.spaces.Box)
        rng = np.random.default_rng(seed)
        self.actions = rng.uniform(space.low, space.high, size=(steps, *space.shape)).astype(
            space.dtype
        )

    def run(self, steps: int) -> float:
        env = self.env
        env.reset(seed=self.seed)
        step, reset = env.step, env.reset
        start = time.perf_counter()
        for action in self.actions[:steps]:
            _, _, terminated, truncated, _ = step(action)
            if terminated or truncated:
                reset()
        return time.perf_counter() - start

    def close(self) -> None:
        self.env.close()


class EngineFloorBench(Bench):
    """The env's own model and data stepped by raw MuJoCo exactly as ``env.step`` steps them.

    Built from ``gym.make("BubbleRob-v0")`` after a reset: its model (obstacle sizes written in
    by the reset) and a copy of its data (the start pose, and the obstacles' poses, which live in
    ``mocap_pos``/``mocap_quat``). Per control step: the two wheel commands into ``ctrl``, then
    ``physics_substeps`` times ``mj_step2`` + ``mj_step1`` at the env's timestep, then, unless
    ``rays`` is 0, one ``mj_multiRay`` with the laser's own settings (its directions rotated by the
    laser site's frame, geom group 0 only, no body excluded, ``range_max`` cutoff). Every
    ``episode`` steps it restarts from the copied data, as the env truncates.
    """

    def __init__(self, steps: int, seed: int, rays: int) -> None:
        self.env = gym.make("BubbleRob-v0", laser_num_rays=max(rays, 1))
        self.env.reset(seed=seed)
        inner: Any = self.env.unwrapped
        self.episode = (self.env.spec.max_episode_steps if self.env.spec else None) or 1000
        self.model: mujoco.MjModel = inner.model  # its obstacle sizes are this layout's
        self.start = copy.copy(inner.data)  # obstacle poses are mocap state, in MjData
        self.data = copy.copy(inner.data)
        self.substeps: int = inner.physics_substeps
        spec = inner.laser_spec
        self.rays = rays
        self.range_max: float = spec.range_max
        self.site = self.model.site(names.LASER_SITE).id
        angles = spec.angles()
        self.local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
        self.geomgroup = np.zeros(mujoco.mjNGROUP, dtype=np.uint8)
        self.geomgroup[names.OBSTACLE_GROUP] = 1
        self.world = np.empty(self.local.size)
        self.dist = np.empty(len(angles))
        self.geomid = np.empty(len(angles), dtype=np.int32)
        rng = np.random.default_rng(seed)
        self.commands = rng.uniform(-1.0, 1.0, size=(steps, 2)) * inner.drive.max_wheel_speed

    def run(self, steps: int) -> float:
        m, d = self.model, self.data
        mujoco.mj_copyData(d, m, self.start)
        ctrl, origin = d.ctrl, d.site_xpos[self.site]
        rot_t = d.site_xmat[self.site].reshape(3, 3).T
        local, world, world3 = self.local, self.world, self.world.reshape(-1, 3)
        geomgroup, geomid, dist = self.geomgroup, self.geomid, self.dist
        rays, range_max, substeps = self.rays, self.range_max, range(self.substeps)
        step1, step2, multi_ray, matmul = (
            mujoco.mj_step1,
            mujoco.mj_step2,
            mujoco.mj_multiRay,
            np.matmul,
        )
        start = time.perf_counter()
        for first in range(0, steps, self.episode):
            if first:
                mujoco.mj_copyData(d, m, self.start)
            for command in self.commands[first : min(first + self.episode, steps)]:
                ctrl[:] = command
                for _ in substeps:
                    step2(m, d)
                    step1(m, d)
                if rays:
                    matmul(local, rot_t, out=world3)
                    multi_ray(
                        m, d, origin, world, geomgroup, 1, -1, geomid, dist, None, rays, range_max
                    )
        return time.perf_counter() - start

    def close(self) -> None:
        self.env.close()


class NaiveFloorBench(Bench):
    """Raw MuJoCo on a copy of the env's model and data, written without care.

    MuJoCo's default 2 ms timestep (25 ``mj_step`` per 0.05 s control step) and a 360-ray
    ``mj_multiRay`` per control step that tests every geom (no group filter, only the robot's base
    body excluded, no cutoff). The env never runs this: it is kept as a labelled extra line.
    """

    def __init__(self, steps: int, seed: int) -> None:
        self.env = gym.make("BubbleRob-v0", laser_num_rays=NAIVE_RAYS)
        self.env.reset(seed=seed)
        inner: Any = self.env.unwrapped
        self.episode = (self.env.spec.max_episode_steps if self.env.spec else None) or 1000
        self.model = copy.deepcopy(inner.model)
        self.model.opt.timestep = NAIVE_TIMESTEP
        self.substeps = round(inner.dt / NAIVE_TIMESTEP)
        self.start = mujoco.MjData(self.model)
        mujoco.mj_copyData(self.start, self.model, inner.data)  # pose and mocap obstacles
        self.data = mujoco.MjData(self.model)
        self.base = self.model.body(names.BASE_BODY).id
        self.site = self.model.site(names.LASER_SITE).id
        angles = inner.laser_spec.angles()
        self.local = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
        self.world = np.empty(NAIVE_RAYS * 3)
        self.dist = np.empty(NAIVE_RAYS)
        self.geomid = np.empty(NAIVE_RAYS, dtype=np.int32)
        rng = np.random.default_rng(seed)
        self.commands = rng.uniform(-1.0, 1.0, size=(steps, 2)) * inner.drive.max_wheel_speed

    def run(self, steps: int) -> float:
        m, d = self.model, self.data
        mujoco.mj_copyData(d, m, self.start)
        ctrl = d.ctrl
        origin = d.site_xpos[self.site]
        rot_t = d.site_xmat[self.site].reshape(3, 3).T
        local, world, world3 = self.local, self.world, self.world.reshape(-1, 3)
        geomid, dist, base, substeps = self.geomid, self.dist, self.base, self.substeps
        mj_step, mj_multi_ray, matmul = mujoco.mj_step, mujoco.mj_multiRay, np.matmul
        start = time.perf_counter()
        for first in range(0, steps, self.episode):
            if first:
                mujoco.mj_copyData(d, m, self.start)
            for command in self.commands[first : min(first + self.episode, steps)]:
                ctrl[:] = command
                mj_step(m, d, substeps)
                matmul(local, rot_t, out=world3)
                mj_multi_ray(
                    m, d, origin, world, None, 1, base, geomid, dist, None, NAIVE_RAYS, NO_CUTOFF
                )
        return time.perf_counter() - start

    def close(self) -> None:
        self.env.close()


@dataclass
class Row:
    """A table row: how to build its configuration, and what was measured."""

    label: str
    build: Callable[[], Bench]
    bench: Bench | None = None
    best: float | None = None  # steps/s
    error: str | None = None


def _env_row(label: str, env_id: str, steps: int, seed: int, **kwargs: Any) -> Row:
    return Row(label, lambda: EnvBench(env_id, steps, seed, **kwargs))


def _rows(steps: int, seed: int) -> list[Row]:
    rows = [
        _env_row(
            f"BubbleRob-v0 laser {n}, no camera", "BubbleRob-v0", steps, seed, laser_num_rays=n
        )
        for n in LASER_ROWS
    ]
    size = {"camera_width": CAMERA_SIZE, "camera_height": CAMERA_SIZE}
    rows += [
        _env_row(CAMERA_LABEL, "BubbleRob-v0", steps, seed, laser_num_rays=360, **size),
        Row(FLOOR_LABEL, lambda: EngineFloorBench(steps, seed, FLOOR_RAYS)),
        Row(PHYSICS_FLOOR_LABEL, lambda: EngineFloorBench(steps, seed, 0)),
        Row(NAIVE_LABEL, lambda: NaiveFloorBench(steps, seed)),
        _env_row(ANT_LABEL, ANT_LABEL, steps, seed),
        _env_row("HalfCheetah-v5", "HalfCheetah-v5", steps, seed),
    ]
    # The native batch: steps/s are robot-steps/s (bench/vector_speed.py).
    rows += [
        Row(batch_label(n), lambda n=n: BatchBench(n, steps, seed))
        for n in (SIZES[:2] if steps < 200 else SIZES)
    ]
    return rows


def _error(exc: BaseException) -> str:
    text = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return text if len(text) <= 90 else text[:87] + "..."


def measure(rows: Sequence[Row], steps: int, warmup: int, repeats: int) -> None:
    """Build and warm up every row, then time them ``repeats`` times, interleaved; keep the best."""
    for row in rows:
        try:
            row.bench = row.build()
            row.bench.run(warmup)
        except Exception as exc:  # a row that cannot run is reported, not fatal
            row.error = _error(exc)
            row.bench = None
    for _ in range(repeats):
        for row in rows:
            if row.bench is None:
                continue
            try:
                rate = steps / row.bench.run(steps)
            except Exception as exc:
                row.error, row.bench = _error(exc), None
                continue
            row.best = max(row.best or 0.0, rate)
    for row in rows:
        if row.bench is not None:
            row.bench.close()


def _rate(rows: Sequence[Row], label: str) -> float | None:
    return next((row.best for row in rows if row.label == label), None)


def _ratio(rate: float | None, base: float | None) -> str:
    return f"{rate / base:.2f}" if rate and base else "n/a"


def table(rows: Sequence[Row], markdown: bool) -> list[str]:
    """The result table as lines, plain text with aligned columns or Markdown."""
    floor, ant = _rate(rows, FLOOR_LABEL), _rate(rows, ANT_LABEL)
    header = ("configuration", "steps/s", "us/step", "x floor", "x Ant")
    body = []
    for row in rows:
        if row.best is None:
            body.append((row.label + " (see below)", "error", "-", "-", "-"))
            continue
        body.append(
            (
                row.label,
                f"{row.best:.0f}",
                f"{1e6 / row.best:.0f}",
                _ratio(row.best, floor),
                _ratio(row.best, ant),
            )
        )
    if markdown:
        lines = ["| " + " | ".join(header) + " |", "|:--|--:|--:|--:|--:|"]
        lines += ["| " + " | ".join(cells) + " |" for cells in body]
        return lines
    width = max(len(cells[0]) for cells in (header, *body))
    fmt = f"{{:<{width}}}  {{:>8}}  {{:>8}}  {{:>8}}  {{:>6}}"
    lines = [fmt.format(*header), "-" * (width + 40)]
    lines += [fmt.format(*cells) for cells in body]
    return lines


def targets(rows: Sequence[Row]) -> list[str]:
    """The errors of rows that did not run, then one PASS/FAIL line per target, with the numbers."""
    floor = _rate(rows, FLOOR_LABEL)
    physics = _rate(rows, PHYSICS_FLOOR_LABEL)
    laser = _rate(rows, LASER_LABEL)
    no_laser = _rate(rows, NO_LASER_LABEL)
    camera = _rate(rows, CAMERA_LABEL)
    lines = [f"error in {row.label}: {row.error}" for row in rows if row.best is None]
    if floor and laser:
        verdict = "PASS" if laser / floor >= TARGET_FLOOR_RATIO else "FAIL"
        lines.append(
            f"{verdict}: 360-ray env {laser:.0f} steps/s = {laser / floor:.2f}x the engine floor "
            f"{floor:.0f} steps/s (target >= {TARGET_FLOOR_RATIO:.1f}x); the env's own time "
            f"beyond the floor: {1e6 / laser - 1e6 / floor:.0f} us/step"
        )
    else:
        lines.append("FAIL: 360-ray env vs engine floor: a row did not run")
    if physics and no_laser:
        lines.append(
            f"info: laser-0 env {no_laser:.0f} steps/s = {no_laser / physics:.2f}x the "
            f"physics-only floor {physics:.0f} steps/s"
        )
    if camera:
        verdict = "PASS" if camera >= TARGET_CAMERA_RATE else "FAIL"
        lines.append(
            f"{verdict}: camera {CAMERA_SIZE}x{CAMERA_SIZE} env {camera:.0f} steps/s "
            f"(target >= {TARGET_CAMERA_RATE:.0f} steps/s)"
        )
    else:
        lines.append("FAIL: camera env: the row did not run")
    return lines


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as cpuinfo:
            for line in cpuinfo:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def machine(steps: int, repeats: int, wall: float) -> list[str]:
    """Where and how the numbers were taken."""
    usable = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    load = " ".join(f"{v:.2f}" for v in os.getloadavg()) if hasattr(os, "getloadavg") else "n/a"
    now = datetime.datetime.now(datetime.timezone.utc).astimezone()
    return [
        f"machine: {_cpu_model()}, {os.cpu_count()} cores ({usable} usable), "
        f"load average {load} (1/5/15 min, at the end)",
        f"date: {now.isoformat(timespec='seconds')}",
        f"python {platform.python_version()}, mujoco {mujoco.__version__}, "
        f"gymnasium {gym.__version__}, numpy {np.__version__}, "
        f"bubblerob {bubblerob_env.__version__}",
        f"MUJOCO_GL={os.environ.get('MUJOCO_GL', '(unset)')}",
        f"method: best of {repeats} interleaved runs of {steps} steps per row; "
        f"bench wall time {wall:.1f} s",
    ]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmark and print the table; the exit status is 0 whatever the targets say."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--steps", type=int, default=2000, help="timed steps per run (2000)")
    parser.add_argument("--repeats", type=int, default=5, help="runs per row, best kept (5)")
    parser.add_argument("--warmup", type=int, default=200, help="untimed steps per row (200)")
    parser.add_argument("--seed", type=int, default=0, help="seed of actions and layouts (0)")
    parser.add_argument(
        "--quick", action="store_true", help="smoke test: 50 steps, 1 run, 10 warm-up steps"
    )
    parser.add_argument("--markdown", action="store_true", help="print a Markdown table")
    args = parser.parse_args(argv)
    if args.quick:
        args.steps, args.repeats, args.warmup = 50, 1, 10
    if args.steps < 1 or args.repeats < 1 or args.warmup < 0:
        parser.error("--steps and --repeats must be >= 1 and --warmup >= 0")

    start = time.perf_counter()
    rows = _rows(max(args.steps, args.warmup), args.seed)
    measure(rows, args.steps, args.warmup, args.repeats)
    wall = time.perf_counter() - start
    lines = table(rows, args.markdown)
    batch = {n: _rate(rows, batch_label(n)) for n in SIZES}
    notes = targets(rows) + env_speed_notes(
        _rate(rows, LASER_LABEL), batch, args.repeats, args.quick
    )
    notes += machine(args.steps, args.repeats, wall)
    prefix = "- " if args.markdown else ""
    print("\n".join(lines))
    print()
    print("\n".join(prefix + line for line in notes))
    sys.stdout.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main())
