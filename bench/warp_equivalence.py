"""How far ``backend="warp"`` is from the CPU env, on held-out seeds, on any Warp device.

Usage: ``python bench/warp_equivalence.py [--device cuda:0] [--seeds 200] [--steps 200]
[--head-on 20] [--quick]`` (prints Markdown).

Rows (:mod:`bubblerob_env.mjwarp.compare`): the laser against ``mj_multiRay`` on the same states
(largest and 99.9th percentile error, rays compared); head-on drives into walls, cylinders and
boxes (same first-contact step or not); per open-loop drive (straight, curve, random) over
``--seeds`` seeds from 30000 (never used to build or tune the backend), how many episodes have the
CPU env's outcome (collision or not within ``--steps`` steps) and how far apart the first contacts
are; and the laser against the CPU env's on the reset and each of the 40 steps after it, every
world, every ray, before the world's first contact. A ray read more than 1 mm apart counts as
grazing an edge when turning it on the CPU state, by at most twice the backends' heading
difference (at least 1e-5 rad), gives the warp reading within 1 cm
(:func:`~bubblerob_env.mjwarp.compare.grazing`); the largest error is over the other rays.
The drift row: how far the robot's pose on the two backends is apart over those steps; the last
row, the same on the first-contact step, after an impact.
"""

from __future__ import annotations

import argparse
import datetime
import os
import platform
from typing import Any

import gymnasium as gym
import numpy as np
import warp as wp
from numpy.typing import NDArray

import bubblerob_env  # noqa: F401  (registers the env ids)
from bubblerob_env.mjwarp import WarpVectorEnv
from bubblerob_env.mjwarp.compare import (
    DRIVES,
    Drives,
    cpu_drives,
    cpu_first_contact,
    cpu_laser,
    drive_actions,
    first_contacts,
    grazing,
    head_on_seeds,
    heading,
    warp_drives,
)

FIRST_SEED = 30000
LASER_STEPS = 40
TOLERANCE = 1e-3  # metres


def _mj_multiray_row(device: str | None, worlds: int, steps: int) -> str:
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
    kwargs: dict[str, Any] = {"start_pose": (0.0, 0.0, 0.0), "max_episode_steps": 150}
    env = WarpVectorEnv(len(seeds), device=device, layout_bank=16, **kwargs)
    actions = drive_actions("straight", len(seeds), 150, seed=0)
    warp = first_contacts(env, seeds, actions)
    cpu = np.array([cpu_first_contact(s, actions[:, 0], **kwargs) for s in seeds])
    kinds = ["wall", "cylinder", "box"]
    same = [int((warp == cpu)[k * per_kind : (k + 1) * per_kind].sum()) for k in range(3)]
    parts = ", ".join(f"{kind} {n}/{per_kind}" for kind, n in zip(kinds, same, strict=True))
    return f"| head-on drives, same first-contact step | {3 * per_kind} drives | {parts} |"


def _compared(warp: Drives, cpu: Drives) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """``(steps + 1, n)`` masks: the rows before either backend's first contact, and the rows
    of a first contact both had on the same step (the state after the impact)."""
    never = 10**9
    warp_first = np.where(warp.first < 0, never, warp.first)
    cpu_first = np.where(cpu.first < 0, never, cpu.first)
    rows = np.arange(warp.laser.shape[0])[:, None] - 1  # row t is after step t - 1
    before = rows < np.minimum(warp_first, cpu_first)[None, :]
    impact = (rows == warp_first[None, :]) & (warp_first == cpu_first)[None, :]
    return before, impact


def _errors(
    warp: Drives, cpu: Drives, seeds: list[int], rows: NDArray[np.bool_]
) -> tuple[NDArray[np.float32], int, int]:
    """The laser errors on ``rows`` with grazing rays zeroed; grazing and other rays over 1 mm."""
    error = np.abs(warp.laser - cpu.laser)
    error[~rows] = 0.0
    outliers = np.argwhere(error > TOLERANCE).tolist()
    scenes: dict[int, object] = {}
    grazes = 0
    for t, w, ray in outliers:
        if w not in scenes:
            env = gym.make("BubbleRob-v0")
            env.reset(seed=seeds[w])
            scenes[w] = env.unwrapped.scene  # type: ignore[attr-defined]
        if grazing(scenes[w], warp.root[t, w], cpu.root[t, w], ray, float(warp.laser[t, w, ray])):
            grazes += 1
            error[t, w, ray] = 0.0
    return error[rows], grazes, len(outliers) - grazes


def _laser_rows(warp: Drives, cpu: Drives, seeds: list[int]) -> list[str]:
    """The laser on every step before the first contact, grazing rays apart; the pose drift;
    and both on the first-contact step."""
    compared, impact = _compared(warp, cpu)
    kept, grazes, others = _errors(warp, cpu, seeds, compared)
    impact_kept, impact_grazes, impact_others = _errors(warp, cpu, seeds, impact)
    rays = int(compared.sum()) * warp.laser.shape[2]
    position = np.linalg.norm(warp.root[..., :2] - cpu.root[..., :2], axis=-1)
    turn = heading(warp.root) - heading(cpu.root)
    yaw = np.abs((turn + np.pi) % (2 * np.pi) - np.pi)
    return [
        f"| laser vs the CPU env, reset + {LASER_STEPS} steps before the first contact, every "
        f"world | {rays} rays, {len(seeds)} worlds | max {kept.max() * 1e3:.3f} mm over the "
        f"non-grazing rays (99.9th percentile {np.quantile(kept, 0.999) * 1e3:.4f} mm); "
        f"{others} non-grazing rays over 1 mm; {grazes} grazing-edge rays over 1 mm |",
        f"| pose drift over the same steps | {int(compared.sum())} states | position max "
        f"{position[compared].max() * 1e3:.4f} mm (median "
        f"{np.median(position[compared]) * 1e3:.5f} mm), heading max "
        f"{yaw[compared].max():.2e} rad (median {np.median(yaw[compared]):.1e}) |",
        f"| the same on the first-contact step, after the impact | {int(impact.sum())} worlds "
        f"| laser max {impact_kept.max(initial=0.0) * 1e3:.3f} mm over the non-grazing rays; "
        f"{impact_others} non-grazing and {impact_grazes} grazing-edge rays over 1 mm; position "
        f"max {position[impact].max(initial=0.0) * 1e3:.3f} mm, heading max "
        f"{yaw[impact].max(initial=0.0):.2e} rad |",
    ]


def _outcome_rows(device: str | None, seeds: int, steps: int) -> list[str]:
    """Every drive over the same seeds, one warp batch of ``3 * seeds`` worlds; the laser rows."""
    seed_list = list(range(FIRST_SEED, FIRST_SEED + seeds)) * len(DRIVES)
    actions = np.concatenate(
        [drive_actions(drive, seeds, steps, seed=FIRST_SEED) for drive in DRIVES], axis=1
    )
    env = WarpVectorEnv(len(seed_list), device=device, max_episode_steps=steps, layout_bank=16)
    warp = warp_drives(env, seed_list, actions, min(LASER_STEPS, steps))
    cpu = cpu_drives(seed_list, actions, min(LASER_STEPS, steps), max_episode_steps=steps)
    rows = []
    for k, drive in enumerate(DRIVES):
        part = slice(k * seeds, (k + 1) * seeds)
        warp_first, cpu_first = warp.first[part], cpu.first[part]
        both = (warp_first >= 0) & (cpu_first >= 0)
        gap = np.abs(warp_first[both] - cpu_first[both])
        equal = int(((warp_first >= 0) == (cpu_first >= 0)).sum())
        rows.append(
            f"| {drive} drives, {steps} steps | {seeds} seeds, {int((cpu_first >= 0).sum())} "
            f"CPU collisions | outcome equal {equal}/{seeds}; first contact same step "
            f"{int((gap == 0).sum())}/{int(both.sum())}, within 1 step {int((gap <= 1).sum())}, "
            f"largest gap {int(gap.max()) if gap.size else 0} steps |"
        )
    return rows + _laser_rows(warp, cpu, seed_list)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--device", default=None, help="Warp device (default: Warp's)")
    parser.add_argument("--seeds", type=int, default=200, help="seeds per drive")
    parser.add_argument("--steps", type=int, default=200, help="steps per episode")
    parser.add_argument("--head-on", type=int, default=20, help="head-on drives per kind")
    parser.add_argument("--quick", action="store_true", help="2 seeds, 20 steps (a smoke run)")
    args = parser.parse_args()
    seeds, steps, per_kind = (2, 20, 1) if args.quick else (args.seeds, args.steps, args.head_on)
    device = wp.get_device(args.device)
    laser = (
        _mj_multiray_row(args.device, 1, 10) if args.quick else _mj_multiray_row(args.device, 8, 60)
    )
    rows = [laser, _head_on_row(args.device, per_kind)]
    rows += _outcome_rows(args.device, seeds, steps)
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
