"""Draw README's navigation picture: a few test episodes of ``BubbleRobNav-v0`` from above.

Each panel shows one test seed's arena (walls, obstacles), the start, the goal and its 0.2 m
disc, the ground-truth shortest path (dashed) and the paths the ``navigator`` and ``pursuit``
controllers drove. Run ``python docs/make_nav_figure.py [OUT.png]``; the default output is
``docs/images/nav_episodes.png``. Needs matplotlib (the [dev] extra).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import gymnasium as gym
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import patches  # noqa: E402

import bubblerob_env  # noqa: E402, F401  (registers the ids)
from policies import load_policy  # noqa: E402
from policies.protocol import TEST  # noqa: E402

DEFAULT_OUT = Path(__file__).resolve().parent / "images" / "nav_episodes.png"
SEEDS = tuple(range(TEST.start, TEST.start + 4))
CONTROLLERS = {"navigator": "tab:blue", "pursuit": "tab:orange"}


def drive(env: gym.Env[Any, Any], name: str, seed: int) -> tuple[np.ndarray, dict[str, Any]]:
    """The (x, y) of every step of one episode of controller ``name``, and its last ``info``."""
    policy = load_policy(name, env)
    obs, info = env.reset(seed=seed)
    points = [(info["x"], info["y"])]
    while True:
        obs, _, terminated, truncated, info = env.step(policy.predict(obs)[0])
        points.append((info["x"], info["y"]))
        if terminated or truncated:
            return np.array(points), info


def draw_arena(ax: Any, base: Any) -> None:
    """Walls and obstacles of the current episode, as seen from above."""
    half = float(base.arena_size) / 2
    ax.add_patch(patches.Rectangle((-half, -half), 2 * half, 2 * half, fill=False, lw=3))
    for o in base.layout.obstacles:
        if o.kind == "cylinder":
            shape: Any = patches.Circle((o.x, o.y), o.size[0])
        else:
            c, s = math.cos(o.yaw), math.sin(o.yaw)
            corner = (o.x - c * o.size[0] + s * o.size[1], o.y - s * o.size[0] - c * o.size[1])
            shape = patches.Rectangle(
                corner, 2 * o.size[0], 2 * o.size[1], angle=math.degrees(o.yaw)
            )
        shape.set(color="0.45")
        ax.add_patch(shape)


def panel(ax: Any, env: gym.Env[Any, Any], seed: int) -> None:
    """One test episode: arena, start, goal, shortest path and each controller's drive."""
    outcomes = []
    for name, colour in CONTROLLERS.items():
        driven, info = drive(env, name, seed)
        ax.plot(*driven.T, color=colour, lw=1.8, label=name)
        outcome = "reached" if info["is_success"] else "failed"
        outcomes.append(f"{name} {outcome}, {info['distance_driven']:.2f} m")
    base = env.unwrapped
    draw_arena(ax, base)
    problem = base.problem
    ax.plot(*problem.path.T, "k--", lw=1.2, label=f"shortest {problem.length:.2f} m")
    start, goal = problem.start, problem.goal
    ax.plot(*start, "o", color="tab:green", ms=8, label="start")
    ax.add_patch(patches.Circle(goal, base.goal_radius, color="tab:red", alpha=0.3))
    ax.plot(*goal, "*", color="tab:red", ms=12, label="goal")
    half = float(base.arena_size) / 2 + 0.1
    ax.set(xlim=(-half, half), ylim=(-half, half), aspect="equal", xticks=[], yticks=[])
    ax.set_title(f"seed {seed}\n" + "; ".join(outcomes), fontsize=8)


def main() -> None:
    """Draw the panels into the output file."""
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_OUT
    env = gym.make("BubbleRobNav-v0")
    fig, axes = plt.subplots(1, len(SEEDS), figsize=(4 * len(SEEDS), 4.6))
    for ax, seed in zip(axes, SEEDS, strict=True):
        panel(ax, env, seed)
    axes[0].legend(loc="lower left", fontsize=7, framealpha=0.9)
    fig.suptitle("BubbleRobNav-v0, the first test seeds: shortest path (dashed) and driven paths")
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=90)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
