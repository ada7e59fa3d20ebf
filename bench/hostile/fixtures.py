"""The files the hostile campaign's cases name: short bags as users record them, policy files.

Made once per work folder by ``python bench/hostile/fixtures.py DIR`` (the runner calls it): each
bag is 12 steps of seeded random actions from seed 0, stamped from 2023-11-14, so the same
folder is made on every run. A case names a fixture as ``{name}`` in its argv or snippet.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

START = 1_700_000_000.0

BAGS: dict[str, dict[str, Any]] = {
    "bag": {},
    "bag_vrep": {"preset": "vrep"},
    "bag_ns": {"namespace": "robot2"},
    "bag_norays": {"kwargs": {"laser_num_rays": 0}},
    "bag_noscan": {"drop": "scan"},
    "bag_noise": {"kwargs": {"odometry_noise": 0.1}},
    "bag_noise_notruth": {"kwargs": {"odometry_noise": 0.1}, "drop": "base_pose_ground_truth"},
    "bag_cam1": {"kwargs": {"camera_width": 1, "camera_height": 1}},
    "bag_cam": {"kwargs": {"camera": True, "obstacle_colours": True}},
    "bag_res1": {"map_resolution": 1.0},
    "bag_pioneer": {"env_id": "PioneerP3DX-v0"},
    "bag_nomap": {"drop": "map"},
    "bag_ros1": {"format": "ros1"},
    "bag_empty_arena": {"kwargs": {"num_obstacles": [0, 0]}},
}
"""Each bag fixture: env id and kwargs, topic preset or namespace, a topic left out, format."""


def _record(path: Path, spec: dict[str, Any]) -> None:
    import gymnasium as gym

    import bubblerob_env  # noqa: F401 - registers the env ids
    from bubblerob_env.ros import RosBagRecorder
    from bubblerob_env.ros.messages.topics import topics_preset

    topics = topics_preset(spec.get("preset", "default"), spec.get("namespace", ""))
    if "drop" in spec:
        topics = topics.replace(**{spec["drop"]: None})
    env = gym.make(spec.get("env_id", "BubbleRob-v0"), **spec.get("kwargs", {}))
    recorder = RosBagRecorder(
        env,
        path,
        format=spec.get("format", "mcap"),
        topics=topics,
        start_time=START,
        map_resolution=spec.get("map_resolution", 0.05),
    )
    recorder.reset(seed=0)
    recorder.action_space.seed(0)
    for _ in range(12):
        recorder.step(recorder.action_space.sample())
    recorder.close()


def _bare_zip(path: Path, env_id: str, **kwargs: Any) -> None:
    import gymnasium as gym
    from stable_baselines3 import PPO

    env = gym.make(env_id, **kwargs)
    PPO("MultiInputPolicy", env, n_steps=8, batch_size=8, device="cpu", seed=0).save(path)


def make_fixtures(folder: Path) -> dict[str, str]:
    """Make every fixture in ``folder`` (those already there are kept); name -> path."""
    folder.mkdir(parents=True, exist_ok=True)
    paths: dict[str, str] = {}
    for name, spec in BAGS.items():
        path = folder / (name + (".bag" if spec.get("format") == "ros1" else ""))
        if not path.exists():
            _record(path, spec)
        paths[name] = str(path)
    for name, env_id, kwargs in (
        ("zip_twist", "BubbleRob-v0", {"action_type": "twist", "laser_num_rays": 36}),
        ("zip_pioneer", "PioneerP3DX-v0", {"laser_num_rays": 36}),
    ):
        path = folder / f"{name}.zip"
        if not path.exists():
            _bare_zip(path, env_id, **kwargs)
        paths[name] = str(path)
    junk = {"not_a_bag": b"hello", "junk_zip": b"not a zip", "junk_onnx": b"not onnx\x00"}
    for name, data in junk.items():
        path = folder / {"not_a_bag": "x.mcap", "junk_zip": "j.zip", "junk_onnx": "j.onnx"}[name]
        path.write_bytes(data)
        paths[name] = str(path)
    (folder / "empty_dir").mkdir(exist_ok=True)
    paths["empty_dir"] = str(folder / "empty_dir")
    paths["bag_mcap_file"] = str(next((folder / "bag").glob("*.mcap")))
    paths["dir"] = str(folder)
    return paths


if __name__ == "__main__":
    import json

    print(json.dumps(make_fixtures(Path(sys.argv[1]))))
