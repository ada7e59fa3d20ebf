"""Render README's picture: BubbleRob in its arena from above (laser drawn) beside its camera view.

Run ``python docs/make_figures.py [OUT.png]``; the default output is ``docs/images/arena.png``.
"""

from __future__ import annotations

import sys
from pathlib import Path

import gymnasium as gym
import imageio.v3 as iio
import mujoco
import numpy as np

import bubblerob_env  # noqa: F401  (registers the env, picks a headless GL backend)

DEFAULT_OUT = Path(__file__).resolve().parent / "images" / "arena.png"


def _close_up(model: mujoco.MjModel, data: mujoco.MjData, size: int) -> np.ndarray:
    camera = mujoco.MjvCamera()
    camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    camera.trackbodyid = model.body("base_link").id
    camera.distance, camera.azimuth, camera.elevation = 0.55, 210.0, -25.0
    with mujoco.Renderer(model, size, size) as renderer:
        renderer.update_scene(data, camera=camera)
        return renderer.render()


def render_figure(seed: int = 3, size: int = 480) -> np.ndarray:
    """Overhead frame with the laser, a close-up of the robot and its camera image."""
    env = gym.make(
        "BubbleRob-v0",
        render_mode="rgb_array",
        render_width=size,
        render_height=size,
        camera_width=size,
        camera_height=size,
    )
    obs, _ = env.reset(seed=seed)
    for _ in range(15):
        obs, *_ = env.step(np.array([0.6, 0.5], dtype=np.float32))
    overhead = env.render()
    close_up = _close_up(env.unwrapped.model, env.unwrapped.data, size)
    env.close()
    gap = np.full((size, 8, 3), 255, dtype=np.uint8)
    return np.concatenate([overhead, gap, close_up, gap, obs["camera"]], axis=1)


def main(argv: list[str]) -> int:
    """Write the figure to ``argv[0]`` or the default path."""
    out = Path(argv[0]) if argv else DEFAULT_OUT
    out.parent.mkdir(parents=True, exist_ok=True)
    iio.imwrite(out, render_figure())
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
