"""Draw README's crowd picture: circle crossings of the hand-written navigator and ``crowd``.

Each panel is one test seed's circle crossing (``parallel_env(task="nav", scenario="circle",
circle_jitter=0.1)``, no obstacles): every robot's start (circle), goal (star, the antipode) and
driven path in its own colour, and a cross where a robot touched another. One column per
policy, one row per robot count. Run ``python docs/make_crowd_figure.py [--out OUT.png]``; the
default output is ``docs/images/crowd_circle.png``. Needs matplotlib (the [dev] extra).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib import patches  # noqa: E402

from policies.multi_evaluation import world_env  # noqa: E402
from policies.protocol import TEST  # noqa: E402

DEFAULT_OUT = Path(__file__).resolve().parent / "images" / "crowd_circle.png"
JITTER = 0.1  # m along the circle, as the README's evaluation


def crossing(name: str, robots: int, seed: int, max_steps: int) -> dict[str, Any]:
    """One circle crossing of policy ``name`` on every robot: paths, goals, outcomes."""
    import gymnasium as gym

    from policies import load_policy

    kwargs: dict[str, Any] = {"num_obstacles": (0, 0), "max_episode_steps": max_steps}
    world = world_env(robots, "circle", "BubbleRobNav-v0", kwargs, JITTER)
    single = gym.make("BubbleRobNav-v0", **kwargs, arena_size=world.config.arena_size)
    policy = load_policy(name, single)
    agents = list(world.possible_agents)
    obs, infos = world.reset(seed=seed)
    paths = {a: [(infos[a]["x"], infos[a]["y"])] for a in agents}
    goals = {a: infos[a]["goal"] for a in agents}
    ends: dict[str, str] = {}
    starting = np.ones(len(agents), dtype=bool)
    latest = dict(obs)
    while world.agents:
        batch = {key: np.stack([latest[a][key] for a in agents]) for key in latest[agents[0]]}
        actions, _ = policy.predict(batch, episode_start=starting, deterministic=True)
        starting[:] = False
        live = list(world.agents)
        obs, _, done, cut, infos = world.step({a: actions[agents.index(a)] for a in live})
        for a in live:
            latest[a] = obs[a]
            paths[a].append((infos[a]["x"], infos[a]["y"]))
            if done[a] or cut[a]:
                success = infos[a]["is_success"]
                ends[a] = "success" if success else infos[a].get("collided_with", "timeout")
    world.close()
    single.close()
    return {
        "paths": {a: np.array(p) for a, p in paths.items()},
        "goals": goals,
        "ends": ends,
        "arena": world.config.arena_size,
    }


def panel(ax: Any, run: dict[str, Any], title: str) -> None:
    """One crossing from above: arena, starts, goals, paths and where robots touched."""
    half = run["arena"] / 2
    ax.add_patch(patches.Rectangle((-half, -half), 2 * half, 2 * half, fill=False, lw=2))
    colours = plt.get_cmap("hsv")
    count = len(run["paths"])
    for k, (agent, path) in enumerate(run["paths"].items()):
        colour = colours(k / count)
        ax.plot(*path.T, color=colour, lw=1.2)
        ax.plot(*path[0], "o", color=colour, ms=4)
        ax.plot(*run["goals"][agent], "*", color=colour, ms=7)
        if run["ends"].get(agent) not in ("success", "timeout", None):
            ax.plot(*path[-1], "x", color="k", ms=7, mew=2)
    reached = sum(end == "success" for end in run["ends"].values())
    ax.set(xlim=(-half - 0.1, half + 0.1), ylim=(-half - 0.1, half + 0.1), aspect="equal")
    ax.set(xticks=[], yticks=[])
    ax.set_title(f"{title}: {reached}/{count} reached", fontsize=9)


def main(argv: list[str] | None = None) -> None:
    """Draw one row per robot count, one column per policy."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    parser.add_argument("--robots", type=int, nargs="+", default=[8, 20])
    parser.add_argument("--policy", nargs="+", default=["navigator", "crowd"])
    parser.add_argument("--max-steps", type=int, default=1000)
    args = parser.parse_args(argv)
    rows, cols = len(args.robots), len(args.policy)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 4.4 * rows), squeeze=False)
    for r, robots in enumerate(args.robots):
        for c, name in enumerate(args.policy):
            run = crossing(name, robots, TEST.start, args.max_steps)
            panel(axes[r][c], run, f"{name}, {robots} robots")
    fig.suptitle(
        f"Circle crossings, test seed {TEST.start} (start o, goal *, x: touched another robot)",
        fontsize=10,
    )
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.out, dpi=80)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
