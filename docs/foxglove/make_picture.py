"""README's picture of what docs/foxglove/bubblerob.json shows, drawn from a run (no Foxglove app).

Not a screenshot: no Foxglove app ran where this was made. The same run's data, laid out as the
layout lays out its panels: the 3D panel (from above: the arena, the laser, the robot), the camera
image, the plot (forward and turning speed from ``/odom``, ``/reward``) and the Teleop panel's
arrows. The ``laser`` policy drives 120 steps of seed 3 with the camera on.
Run: ``python docs/foxglove/make_picture.py`` (writes ``docs/foxglove/layout.png``; needs
matplotlib, in the ``dev`` extra).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers the env ids)
from bubblerob_env.topdown import TopDownRenderer
from policies import load_policy

OUT = Path(__file__).resolve().parent / "layout.png"
SEED, STEPS = 3, 120


def run() -> dict[str, np.ndarray]:
    """The run's last top-down view and camera image, and its speeds and rewards per step."""
    env = gym.make("BubbleRob-v0", camera=True, camera_width=128, camera_height=96)
    obs, _ = env.reset(seed=SEED)
    policy = load_policy("laser", env)
    rows = []
    for _ in range(STEPS):
        action, _ = policy.predict(obs)
        obs, reward, *_, info = env.step(action)
        rows.append((*info["body_twist"], reward))
    top = np.asarray(TopDownRenderer.for_env(env, 480, 480).render(obs["laser"]))
    env.close()
    return {"top": top, "camera": obs["camera"], "series": np.array(rows)}


def main() -> None:
    """Draw the four panels into OUT."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = run()
    figure = plt.figure(figsize=(11, 6), dpi=100)
    grid = figure.add_gridspec(3, 2, width_ratios=(62, 38), height_ratios=(40, 33, 27))
    panels = {
        "3D: /map, /scan, robot, /odom, tf": figure.add_subplot(grid[:, 0]),
        "Image: /camera/image_raw": figure.add_subplot(grid[0, 1]),
        "Plot: /odom speeds, /reward": figure.add_subplot(grid[1, 1]),
        "Teleop: /cmd_vel": figure.add_subplot(grid[2, 1]),
    }
    for title, axes in panels.items():
        axes.set_title(title, loc="left", fontsize=9)
    top, camera, plot, teleop = panels.values()
    top.imshow(data["top"])
    camera.imshow(data["camera"])
    for axes in (top, camera, teleop):
        axes.set_xticks([])
        axes.set_yticks([])
    seconds = np.arange(1, STEPS + 1) * 0.05
    series = data["series"]
    for column, label in enumerate(("forward speed (m/s)", "turning speed (rad/s)", "reward")):
        plot.plot(seconds, series[:, column], label=label, linewidth=1)
    plot.set_xlabel("simulated s", fontsize=8)
    plot.tick_params(labelsize=7)
    plot.legend(fontsize=7, loc="upper right")
    for (x, y), text in {
        (0.5, 0.8): "^",
        (0.5, 0.2): "v",
        (0.3, 0.5): "<",
        (0.7, 0.5): ">",
    }.items():
        teleop.text(x, y, text, ha="center", va="center", fontsize=16, transform=teleop.transAxes)
    teleop.text(0.5, 0.5, "stop", ha="center", va="center", fontsize=9, transform=teleop.transAxes)
    figure.suptitle(
        "What docs/foxglove/bubblerob.json shows (drawn from a run, not a Foxglove screenshot)",
        fontsize=10,
    )
    figure.tight_layout()
    figure.savefig(OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
