"""The README's "A second robot" picture: BubbleRob and the Pioneer 3-DX, each in its own arena.

Both from above (``TopDownRenderer``) after 60 steps of the ``laser`` policy on the same seed,
the laser drawn; each panel spans its own arena (4 m and 10 m), so the robots look alike in size.
Run: ``python docs/make_pioneer_figure.py`` (writes ``docs/images/pioneer.png``).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers the env ids)
from bubblerob_env.png import write_png
from bubblerob_env.topdown import TopDownRenderer
from policies import load_policy

OUT = Path(__file__).resolve().parent / "images" / "pioneer.png"
SEED, STEPS, SIZE = 100_004, 60, 420


def panel(env_id: str) -> np.ndarray:
    """One robot from above after STEPS steps of the laser policy, its scan drawn."""
    env = gym.make(env_id)
    obs, _ = env.reset(seed=SEED)
    policy = load_policy("laser", env)
    for _ in range(STEPS):
        action, _ = policy.predict(obs)
        obs, *_ = env.step(action)
    image = np.asarray(TopDownRenderer.for_env(env, SIZE, SIZE).render(obs["laser"]))
    env.close()
    return image


def main() -> None:
    """Both panels side by side into OUT."""
    left, right = panel("BubbleRob-v0"), panel("PioneerP3DX-v0")
    gap = np.full((SIZE, 12, 3), 255, dtype=np.uint8)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    write_png(OUT, np.concatenate([left, gap, right], axis=1))
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
