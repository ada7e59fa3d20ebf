"""Draw README's several-robots picture: four BubbleRobs in one world, and one in another's camera.

Left: the world from above (``bubblerob_env.topdown``, drawn with NumPy), each robot's laser
scan drawn in its colour from its laser to where each ray stopped; rays that end on another
robot's laser window end there. Right: robot 0's camera image, with robot 1 ahead of it.
The robots start at fixed poses in a test seed's arena (``reset(options={"start_poses": ...})``)
and drive a few steps with the gap follower (``laser``), the same policy on every robot.

Run ``python docs/make_multi_figure.py [OUT.png]``; the default output is
``docs/images/several_robots.png``. Needs matplotlib (the [dev] extra) and PettingZoo (the
[multi] extra).
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

import bubblerob_env  # noqa: E402
from bubblerob_env import names  # noqa: E402
from bubblerob_env.multi.scene import robot_prefix  # noqa: E402
from bubblerob_env.topdown import TopDownRenderer  # noqa: E402
from policies.protocol import TEST  # noqa: E402

DEFAULT_OUT = Path(__file__).resolve().parent / "images" / "several_robots.png"
SEED = TEST.start + 3
"""A test seed whose obstacles leave the poses below free, and robot 1 in robot 0's view."""
START_POSES = [(-1.2, -0.2, 0.0), (-0.35, -0.1, math.pi), (1.1, 1.0, -2.4), (0.6, -1.3, 2.0)]
STEPS = 6
COLOURS = ["tab:blue", "tab:orange", "tab:green", "tab:purple"]


def drive(size: int) -> tuple[Any, list[np.ndarray], np.ndarray]:
    """The world after ``STEPS`` gap-follower steps: env, each robot's scan, robot 0's image."""
    from policies.loading import load_policy

    kwargs: dict[str, Any] = {"camera": True, "camera_width": size, "camera_height": size * 3 // 4}
    world = bubblerob_env.parallel_env(num_robots=len(START_POSES), **kwargs)
    single = gym.make("BubbleRob-v0", **kwargs)
    policy = load_policy("laser", single)
    single.close()
    observations, _ = world.reset(seed=SEED, options={"start_poses": START_POSES})
    agents = list(world.possible_agents)
    for _ in range(STEPS):
        batch = {
            key: np.stack([observations[a][key] for a in agents]) for key in observations[agents[0]]
        }
        actions, _ = policy.predict(batch, deterministic=True)
        observations, *_ = world.step({a: actions[k] for k, a in enumerate(agents)})
    scans = [np.asarray(observations[a]["laser"], dtype=float) for a in agents]
    return world, scans, np.asarray(observations[agents[0]]["camera"])


def draw(world: Any, scans: list[np.ndarray], camera: np.ndarray, size: int) -> Any:
    """The figure: the world from above with every scan, and robot 0's camera."""
    scene = world.world.scene
    model, data = scene.model, scene.data
    view = 1.05 * (float(world.config.arena_size) + 0.3)
    top = TopDownRenderer(model, data, 3 * size, 3 * size, view).render()
    fig, (ax, cam) = plt.subplots(1, 2, figsize=(10, 5), width_ratios=[1, 1.1])
    half = view / 2
    ax.imshow(top, extent=(-half, half, -half, half))
    angles = scene.laser_spec.angles()
    for k, (scan, colour) in enumerate(zip(scans, COLOURS, strict=True)):
        site = model.site(robot_prefix(k) + names.LASER_SITE).id
        origin, frame = data.site_xpos[site], data.site_xmat[site].reshape(3, 3)
        directions = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], 1) @ frame.T
        ends = origin[:2] + directions[:, :2] * scan[:, None]
        for end in ends[::6]:
            ax.plot([origin[0], end[0]], [origin[1], end[1]], color=colour, lw=0.5, alpha=0.5)
        ax.scatter(ends[:, 0], ends[:, 1], s=2, color=colour)
        ax.annotate(str(k), origin[:2] + 0.16, color=colour, fontsize=12, weight="bold")
    ax.set(title="four robots from above, their laser scans", xlabel="x (m)", ylabel="y (m)")
    cam.imshow(camera)
    cam.set(title="robot 0's camera: robot 1 ahead", xticks=[], yticks=[])
    fig.tight_layout()
    return fig


def main(out: Path = DEFAULT_OUT, size: int = 160) -> Path:
    """Write the picture to ``out`` (``size``: camera width; the top view is ``3 * size``)."""
    world, scans, camera = drive(size)
    try:
        fig = draw(world, scans, camera, size)
    finally:
        world.close()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=100)
    plt.close(fig)
    return out


if __name__ == "__main__":
    print(f"wrote {main(Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT_OUT)}")
