"""README's MuJoCo Warp picture: the same random drives on the CPU env and on ``backend="warp"``.

Six held-out seeds (7000-7005), the same random wheel actions for both backends, 200 steps: each
panel draws the arena, its obstacles, the CPU env's path (blue) and the Warp backend's (orange,
dashed), and a cross where each first touched something. Where the paths part, float32 and
MuJoCo Warp's solver have made them drift (docs/BENCHMARKS.md).
Run: ``python docs/make_warp_figure.py [--out PNG] [--steps N]`` (Warp's CPU device).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.patches import Circle, Rectangle  # noqa: E402

import bubblerob_env  # noqa: E402, F401  (registers the env ids)
from bubblerob_env.arena import ArenaLayout  # noqa: E402
from bubblerob_env.mjwarp import WarpVectorEnv  # noqa: E402
from bubblerob_env.mjwarp.compare import drive_actions  # noqa: E402

OUT = Path(__file__).resolve().parent / "images" / "warp_vs_cpu.png"
SEEDS = list(range(7000, 7006))

Path2D = tuple[list[float], list[float], bool]


def _cpu_path(seed: int, actions: np.ndarray) -> tuple[Path2D, ArenaLayout]:
    env = gym.make("BubbleRob-v0")
    _, info = env.reset(seed=seed)
    xs, ys = [info["x"]], [info["y"]]
    for action in actions:
        _, _, terminated, truncated, info = env.step(action)
        xs.append(info["x"])
        ys.append(info["y"])
        if terminated or truncated:
            return (xs, ys, bool(terminated)), env.unwrapped.layout
    return (xs, ys, False), env.unwrapped.layout


def _warp_paths(actions: np.ndarray) -> list[Path2D]:
    env = WarpVectorEnv(len(SEEDS), device="cpu", max_episode_steps=len(actions), layout_bank=8)
    _, info = env.reset(seed=SEEDS)
    paths: list[Path2D] = [([x], [y], False) for x, y in zip(info["x"], info["y"], strict=True)]
    running = np.ones(len(SEEDS), dtype=bool)
    for action in actions:
        _, _, terminated, truncated, info = env.step(action)
        for i in np.flatnonzero(running):
            paths[i][0].append(float(info["x"][i]))
            paths[i][1].append(float(info["y"][i]))
            if terminated[i] or truncated[i]:
                paths[i] = (paths[i][0], paths[i][1], bool(terminated[i]))
                running[i] = False
    return paths


def _draw_arena(axis: plt.Axes, layout: ArenaLayout, half: float) -> None:
    axis.add_patch(Rectangle((-half, -half), 2 * half, 2 * half, fill=False, color="0.3", lw=2))
    for obstacle in layout.obstacles:
        if obstacle.kind == "cylinder":
            patch = Circle((obstacle.x, obstacle.y), obstacle.size[0], color="0.6")
        else:
            w, h = obstacle.size
            corner = np.array([obstacle.x, obstacle.y]) - np.array(
                [[np.cos(obstacle.yaw), -np.sin(obstacle.yaw)],
                 [np.sin(obstacle.yaw), np.cos(obstacle.yaw)]]
            ) @ np.array([w, h])  # fmt: skip
            patch = Rectangle(tuple(corner), 2 * w, 2 * h, angle=np.degrees(obstacle.yaw),
                              color="0.6")  # fmt: skip
        axis.add_patch(patch)


def main() -> None:
    """Draw the six panels into ``--out``."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=OUT)
    parser.add_argument("--steps", type=int, default=200)
    args = parser.parse_args()
    actions = drive_actions("random", len(SEEDS), args.steps, seed=SEEDS[0])
    warp = _warp_paths(actions)
    figure, axes = plt.subplots(2, 3, figsize=(12, 8))
    half = bubblerob_env.robots.BUBBLEROB.arena.size / 2
    for i, (seed, axis) in enumerate(zip(SEEDS, axes.ravel(), strict=True)):
        cpu, layout = _cpu_path(seed, actions[:, i])
        _draw_arena(axis, layout, half)
        for (xs, ys, touched), style, label in ((cpu, "-", "CPU"), (warp[i], "--", "MuJoCo Warp")):
            colour = "tab:blue" if label == "CPU" else "tab:orange"
            axis.plot(xs, ys, style, color=colour, lw=1.6, label=label)
            if touched:
                axis.plot(xs[-1], ys[-1], "x", color=colour, ms=10, mew=2.5)
        axis.set_title(f"seed {seed}: CPU {len(cpu[0]) - 1} steps, Warp {len(warp[i][0]) - 1}")
        axis.set_xlim(-half - 0.1, half + 0.1)
        axis.set_ylim(-half - 0.1, half + 0.1)
        axis.set_aspect("equal")
        axis.set_xticks([])
        axis.set_yticks([])
    axes[0, 0].legend(loc="lower left")
    figure.suptitle(
        "The same random drives on the CPU env and on backend='warp' (x: first contact)"
    )
    figure.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
