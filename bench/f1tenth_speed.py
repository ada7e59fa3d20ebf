"""Steps/s of f1tenth_gym in BubbleRob's setting, for env_speed.py's side-by-side rows.

Usage (in f1tenth_gym's own venv, see ../shared/anchors/README.md and docs/BENCHMARKS.md):
``python bench/f1tenth_speed.py --map DIR/arena [--beams 360] [--steps N] [--repeats R]``;
prints one JSON line ``{"package": "f1tenth_gym", "beams": B, "single": steps/s}``.

The world is the anchors' 4 x 4 m walled arena with 8 obstacles (an occupancy map at 0.05 m per
pixel), one car, its lidar set to ``--beams`` over 360 degrees (``RaceCar.__init__``'s defaults
are replaced before ``gym.make``, as the anchors' README says), seeded random [steer, speed]
actions, a reset to the start pose when an episode ends, and the scan read every step as a
Gymnasium observation would be. Its physics step is 0.01 s (BubbleRob's control step is 0.05 s
with 4 physics substeps): the ratios compare steps, not simulated seconds. Run it with one thread
(``NUMBA_NUM_THREADS=1``); env_speed.py starts it that way.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np

START = np.array([[0.6, 0.6, 0.785]])


def _make(map_path: str, beams: int):  # noqa: ANN202 - f1tenth_gym has no types
    import gym
    from f110_gym.envs.base_classes import RaceCar

    defaults = list(RaceCar.__init__.__defaults__)
    names = RaceCar.__init__.__code__.co_varnames[1 : RaceCar.__init__.__code__.co_argcount]
    offset = len(names) - len(defaults)
    defaults[names.index("num_beams") - offset] = beams
    defaults[names.index("fov") - offset] = 2 * math.pi
    RaceCar.__init__.__defaults__ = tuple(defaults)
    # gym 0.26's passive checker rejects F110Env (no action_space attribute): not ours to judge.
    return gym.make(
        "f110_gym:f110-v0",
        map=map_path,
        map_ext=".png",
        num_agents=1,
        disable_env_checker=True,
    )


def _run(env, actions: np.ndarray) -> float:  # noqa: ANN001
    env.reset(poses=START)
    start = time.perf_counter()
    for action in actions:
        obs, _, done, _ = env.step(action[None, :])
        _ = obs["scans"][0]
        if done:
            env.reset(poses=START)
    return len(actions) / (time.perf_counter() - start)


def main() -> None:
    """Measure and print the JSON line."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--map", required=True, help="map path without extension")
    parser.add_argument("--beams", type=int, default=360)
    parser.add_argument("--steps", type=int, default=3000)
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    env = _make(args.map, args.beams)
    rng = np.random.default_rng(0)
    actions = np.stack(
        [rng.uniform(-0.4, 0.4, args.steps), rng.uniform(0.5, 3.0, args.steps)], axis=1
    )
    _run(env, actions[:200])  # warm-up: numba compiles here
    rate = max(_run(env, actions) for _ in range(args.repeats))
    print(json.dumps({"package": "f1tenth_gym", "beams": args.beams, "single": rate}))


if __name__ == "__main__":
    main()
