"""How far ``backend="warp"`` is from the CPU env, on held-out seeds, on any Warp device.

Usage: ``python bench/warp_equivalence.py [--device cuda:0] [--seeds 200] [--steps 200]
[--quick]`` (prints Markdown).

Rows (:mod:`bubblerob_env.mjwarp.compare`): the laser against ``mj_multiRay`` on the same states
(largest and 99.9th percentile error, rays compared); head-on drives into walls, cylinders and
boxes (same first-contact step or not); and, per open-loop drive over ``--seeds`` seeds from 7000
(never used to build or tune the backend), how many episodes have the CPU env's outcome
(collision or not within ``--steps`` steps) and how far apart the first contacts are.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform

import numpy as np
import warp as wp

import bubblerob_env  # noqa: F401  (registers the env ids)
from bubblerob_env.mjwarp import WarpVectorEnv
from bubblerob_env.mjwarp.compare import (
    DRIVES,
    cpu_first_contact,
    cpu_laser,
    drive_actions,
    first_contacts,
    head_on_seeds,
)

FIRST_SEED = 7000


def _laser_rows(device: str | None, worlds: int, steps: int) -> str:
    env = WarpVectorEnv(worlds, device=device, max_episode_steps=100, layout_bank=16)
    obs, _ = env.reset(seed=FIRST_SEED)
    rng = np.random.default_rng(FIRST_SEED)
    errors = []
    for step in range(steps):
        if step % 10 == 0:
            errors += [np.abs(obs["laser"][w] - cpu_laser(env, w)) for w in range(worlds)]
        obs, *_ = env.step(rng.uniform(-0.5, 1.0, (worlds, 2)).astype(np.float32))
    error = np.concatenate(errors)
    worst, tail = error.max() * 1e3, np.quantile(error, 0.999) * 1e3
    return (
        f"| laser vs mj_multiRay, same states | {error.size} rays | "
        f"max {worst:.3f} mm, 99.9th percentile {tail:.3f} mm |"
    )


def _head_on_row(device: str | None, per_kind: int) -> str:
    seeds = head_on_seeds(per_kind, first_seed=FIRST_SEED)
    kwargs = {"start_pose": (0.0, 0.0, 0.0), "max_episode_steps": 150}
    env = WarpVectorEnv(len(seeds), device=device, layout_bank=16, **kwargs)
    actions = drive_actions("straight", len(seeds), 150, seed=0)
    warp = first_contacts(env, seeds, actions)
    cpu = np.array([cpu_first_contact(s, actions[:, 0], **kwargs) for s in seeds])
    kinds = ["wall", "cylinder", "box"]
    same = [int((warp == cpu)[k * per_kind : (k + 1) * per_kind].sum()) for k in range(3)]
    parts = ", ".join(f"{kind} {n}/{per_kind}" for kind, n in zip(kinds, same, strict=True))
    return f"| head-on drives, same first-contact step | {3 * per_kind} drives | {parts} |"


def _outcome_row(device: str | None, drive: str, seeds: int, steps: int) -> str:
    actions = drive_actions(drive, seeds, steps, seed=FIRST_SEED)
    seed_list = list(range(FIRST_SEED, FIRST_SEED + seeds))
    env = WarpVectorEnv(seeds, device=device, max_episode_steps=steps, layout_bank=16)
    warp = first_contacts(env, seed_list, actions)
    cpu = np.array(
        [
            cpu_first_contact(s, actions[:, i], max_episode_steps=steps)
            for i, s in enumerate(seed_list)
        ]
    )
    both = (warp >= 0) & (cpu >= 0)
    gap = np.abs(warp[both] - cpu[both])
    return (
        f"| {drive} drives, {steps} steps | {seeds} seeds, {int((cpu >= 0).sum())} CPU "
        f"collisions | outcome equal {int(((warp >= 0) == (cpu >= 0)).sum())}/{seeds}; first "
        f"contact same step {int((gap == 0).sum())}/{int(both.sum())}, within 1 step "
        f"{int((gap <= 1).sum())}, largest gap {int(gap.max()) if gap.size else 0} steps |"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--seeds", type=int, default=200, help="seeds per drive")
    parser.add_argument("--steps", type=int, default=200, help="steps per episode")
    parser.add_argument("--quick", action="store_true", help="2 seeds, 20 steps (a smoke run)")
    args = parser.parse_args()
    seeds, steps, per_kind = (2, 20, 1) if args.quick else (args.seeds, args.steps, 5)
    device = wp.get_device(args.device)
    laser = _laser_rows(args.device, 1, 10) if args.quick else _laser_rows(args.device, 8, 60)
    rows = [laser, _head_on_row(args.device, per_kind)]
    rows += [_outcome_row(args.device, drive, seeds, steps) for drive in DRIVES]
    now = datetime.datetime.now(datetime.UTC)
    print(f"# backend='warp' against the CPU env, {now:%Y-%m-%d %H:%M} UTC")
    print(
        f"device: {device.alias} ({device.name}); host: {platform.machine()}, "
        f"{os.cpu_count()} cores, load {os.getloadavg()[0]:.1f}; seeds from {FIRST_SEED}\n"
    )
    print("| check | cases | result |")
    print("|---|---|---|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
