"""``backend="warp"`` robot-steps/s against the number of worlds, with its anchors in the same run.

Usage: ``python bench/warp_speed.py [--device cuda:0] [--sizes 1024,4096,16384,65536]
[--steps 50] [--json FILE]`` (prints Markdown). Needs the ``[warp]`` extra.
``python bench/warp_speed.py --split --sizes 65536``: where the floor's time goes (physics
alone, the laser alone) and physics under MuJoCo Warp's sweep-and-prune broadphases.
``python bench/warp_speed.py --resets 65536``: only the host's part of a seeded reset of that many
worlds (the arenas' table rows), by the numba draw and by the CPU env's own placement seed by seed
(as before issue #41), and whether the two agree on every row.

Rows, per N: the env's ``step`` with numpy outputs (what a CPU learner gets: observations,
rewards and the full ``info`` on the host), with ``outputs="warp"`` (observations stay on the
device), and MuJoCo Warp's floor for the same worlds: 4 x (``step2`` + ``step1``) and the env's
laser (the culled cast of ``bubblerob_env/mjwarp/laser.py``) with its readings, nothing else.
Anchor: the CPU native batch (``BubbleRobVectorEnv``, N=64, every core) in the same run. The
device is named in the output; on a CPU device (``--device cpu``) the numbers only show that the
path runs: MuJoCo Warp is built for GPUs. Issue #29's target: >= 1M robot-steps/s with the
360-ray laser on one H100.
"""

from __future__ import annotations

import argparse
import datetime
import functools
import json
import os
import platform
import time
from typing import Any

import mujoco_warp as mjw
import numpy as np
import warp as wp
from gymnasium.utils import seeding

import bubblerob_env  # noqa: F401  (registers the env ids)
from bubblerob_env.env import BubbleRobEnv
from bubblerob_env.mjwarp import WarpVectorEnv
from bubblerob_env.mjwarp.layouts import layout_rows, slot_geoms
from bubblerob_env.vector import BubbleRobVectorEnv


def _rate(step: Any, n: int, steps: int) -> float:
    step()  # the first call loads kernels
    wp.synchronize()
    start = time.perf_counter()
    for _ in range(steps):
        step()
    wp.synchronize()
    return n * steps / (time.perf_counter() - start)


def _warp_rows(n: int, steps: int, device: str | None) -> dict[str, float]:
    started = time.perf_counter()
    env = WarpVectorEnv(n, device=device, max_episode_steps=1000)
    env.reset(seed=0)
    reset_s = time.perf_counter() - started
    actions = np.random.default_rng(0).uniform(-1, 1, (n, 2)).astype(np.float32)
    numpy_rate = _rate(lambda: env.step(actions), n, steps)
    device_env = WarpVectorEnv(n, device=device, max_episode_steps=1000, outputs="warp")
    device_env.reset(seed=0)
    device_actions = wp.array(actions, device=env.device)
    device_rate = _rate(lambda: device_env.step(device_actions), n, steps)
    worlds = env.worlds

    def floor() -> None:
        worlds.physics()
        worlds.sense(active=None, resetting=np.zeros(n, dtype=bool))

    return {
        "numpy": numpy_rate,
        "device": device_rate,
        "floor": _rate(floor, n, steps),
        "reset_s": reset_s,
    }


def _split_rows(n: int, steps: int, device: str | None) -> list[str]:
    """Where the floor's time goes at ``n`` worlds: physics alone (under each of MuJoCo Warp's
    broadphases, each its own env), the env's laser and readings (``sense``: the culled cast),
    and ``mujoco_warp.rays`` over every geom for the same rays (what the culled cast replaced)."""
    rows = []
    for name, broadphase in (
        ("nxn (ours)", None),
        ("sap_tile", mjw.BroadphaseType.SAP_TILE),
        ("sap_segmented", mjw.BroadphaseType.SAP_SEGMENTED),
    ):
        env = WarpVectorEnv(n, device=device, max_episode_steps=1000)
        env.reset(seed=0)
        worlds = env.worlds
        if broadphase is not None:
            worlds.model.opt.broadphase = broadphase
        rows.append(
            f"| {n} | physics, broadphase {name} | {_rate(worlds.physics, n, steps):,.0f} |"
        )
        if broadphase is None:
            still = np.zeros(n, dtype=bool)
            sense = functools.partial(worlds.sense, active=None, resetting=still)
            rows.append(
                f"| {n} | laser + readings (env's culled cast) | {_rate(sense, n, steps):,.0f} |"
            )
            with wp.ScopedDevice(worlds.device):
                out = wp.zeros_like(worlds.dist)
                rays = functools.partial(
                    mjw.rays,
                    worlds.model,
                    worlds.data,
                    worlds.pnt,
                    worlds.vec,
                    worlds.geomgroup,
                    True,
                    worlds.bodyexclude,
                    out,
                    worlds.geomid,
                    worlds.normal,
                )
                rows.append(
                    f"| {n} | mujoco_warp.rays alone (every geom) | {_rate(rays, n, steps):,.0f} |"
                )
        env.close()
    return rows


def _cpu_batch(steps: int) -> float:
    env = BubbleRobVectorEnv(64)
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (64, 2)).astype(np.float32)
    rate = _rate(lambda: env.step(actions), 64, steps * 10)
    env.close()
    return rate


def _reset_rows(n: int) -> str:
    """Host seconds (CPU time) for the table rows of ``n`` seeds, numba against the CPU env."""
    scene = BubbleRobEnv().scene
    layout_rows(scene, range(8))  # numba's compilation, cached on disk after the first run
    start = time.process_time()
    pos, _, size, rbound, root = layout_rows(scene, range(n))
    fast = time.process_time() - start
    cpu = BubbleRobEnv().scene  # the CPU env's placement, one seed at a time
    model, data, adr = cpu.model, cpu.data, cpu.root_qpos
    geoms = slot_geoms(cpu)
    columns = {geom: column for column, geom in enumerate(geoms.tolist())}
    placed, sizes = [], np.zeros((n, geoms.size, 3), np.float32)
    rbounds, roots = np.zeros((n, geoms.size), np.float32), np.zeros((n, 7), np.float32)
    cpu_pos = np.zeros_like(pos)
    start = time.process_time()
    for k in range(n):
        cpu.place_layout(seeding.np_random(k)[0])
        cpu_pos[k], sizes[k], rbounds[k] = (
            data.mocap_pos,
            model.geom_size[geoms],
            model.geom_rbound[geoms],
        )
        roots[k] = data.qpos[adr : adr + 7]
        placed.append([columns[geom] for geom in cpu.slots.placed])
    slow = time.process_time() - start
    same = sum(
        np.array_equal(pos[k], cpu_pos[k])
        and np.array_equal(size[k, used], sizes[k, used])
        and np.array_equal(rbound[k, used], rbounds[k, used])
        and np.array_equal(root[k], roots[k])
        for k, used in enumerate(placed)
    )
    return f"| {n} | {slow:.1f} s | {fast:.2f} s | {slow / fast:.0f}x | {same}/{n} rows equal |"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--sizes", default="1024,4096,16384,65536", help="N, comma-separated")
    parser.add_argument("--steps", type=int, default=50, help="timed steps per row")
    parser.add_argument("--json", default=None, help="also write the numbers to this file")
    parser.add_argument("--resets", type=int, help="only time the rows of this many seeds")
    parser.add_argument(
        "--split",
        action="store_true",
        help="only split the floor: physics (each broadphase), the culled laser, mujoco_warp.rays",
    )
    args = parser.parse_args()
    if args.split:
        device = wp.get_device(args.device)
        print(
            f"# MuJoCo Warp floor split, {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC"
        )
        print(f"device: {device.alias} ({device.name}); load {os.getloadavg()[0]:.1f}\n")
        print("| N | part | robot-steps/s |")
        print("|---|---|---|")
        for n in (int(size) for size in args.sizes.split(",")):
            for row in _split_rows(n, args.steps, args.device):
                print(row, flush=True)
        return
    if args.resets:
        print(
            f"# seeded reset's host part, {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC"
        )
        print(
            f"host: {platform.machine()}, {os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}\n"
        )
        print("| worlds | CPU env, seed by seed | numba draw | faster | same arenas |")
        print("|---|---|---|---|---|")
        print(_reset_rows(args.resets))
        return
    sizes = [int(size) for size in args.sizes.split(",")]
    device = wp.get_device(args.device)
    cpu = _cpu_batch(args.steps)
    rows = {n: _warp_rows(n, args.steps, args.device) for n in sizes}
    print(f"# backend='warp', {datetime.datetime.now(datetime.UTC):%Y-%m-%d %H:%M} UTC")
    print(
        f"device: {device.alias} ({device.name}); host: {platform.machine()}, "
        f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}"
    )
    print(f"anchor: CPU native batch, N=64: {cpu:,.0f} robot-steps/s\n")
    print(
        "| N | step, numpy outputs | step, outputs='warp' | MuJoCo Warp floor | "
        "vs CPU batch | reset(seed) s |"
    )
    print("|---|---|---|---|---|---|")
    for n, row in rows.items():
        print(
            f"| {n} | {row['numpy']:,.0f} | {row['device']:,.0f} | {row['floor']:,.0f} | "
            f"{row['device'] / cpu:.2f}x | {row['reset_s']:.1f} |"
        )
    if args.json:
        with open(args.json, "w") as out:
            json.dump({"device": device.name, "cpu_batch": cpu, "rows": rows}, out, indent=1)


if __name__ == "__main__":
    main()
