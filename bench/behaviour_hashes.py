"""Hash a fixed set of seeded runs, so that two checkouts can be compared for byte-identity.

Issue #35 (the house redesign) promised that the same seeds give byte-identical episodes and
bags before and after it. This script runs, through the public surfaces only (``gym.make``,
``gym.make_vec`` and the ``bubblerob`` command), a fixed set of seeded runs and prints one sha256
per run as JSON:

- ``episodes/<env id>``: BubbleRob-v0 and PioneerP3DX-v0, three seeded episodes of seeded random
  actions (observations, rewards, ends and every info value); also ``flat`` and camera variants;
- ``batch``: the native CPU batch (8 worlds, through autoresets);
- ``bag/<format>``: ``bubblerob record`` (laser policy, 2 episodes) as ROS 1, MCAP and sqlite3,
  every file of the bag folder;
- ``bag/camera``: a camera recording with ``/detections``;
- ``ray``: ``bubblerob evaluate --ray local`` per-episode results (run inside ``unshare -n``
  with only loopback up, as every Ray run here; skipped where that is not possible).

Run it from each checkout (``PYTHONPATH=CHECKOUT python bench/behaviour_hashes.py``); the command
is ``python -m bubblerob_cli`` where that package exists, else the older ``bubblerob_env.cli``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import bubblerob_env  # noqa: F401  (registers the env ids)

START_TIME = "1700000000"


def _update(digest: Any, value: Any) -> None:
    if isinstance(value, dict):
        for key in sorted(value):
            digest.update(str(key).encode())
            _update(digest, value[key])
    elif isinstance(value, (list, tuple)):
        for item in value:
            _update(digest, item)
    elif isinstance(value, np.ndarray):
        digest.update(str(value.dtype).encode() + str(value.shape).encode())
        digest.update(np.ascontiguousarray(value).tobytes())
    else:
        digest.update(repr(value).encode())


def episodes(env_id: str, steps: int = 300, **kwargs: Any) -> str:
    """sha256 of three seeded episodes of seeded random actions."""
    digest = hashlib.sha256()
    env = gym.make(env_id, **kwargs)
    for seed in (11, 12, 13):
        obs, info = env.reset(seed=seed)
        env.action_space.seed(seed)
        _update(digest, (obs, info))
        for _ in range(steps):
            step = env.step(env.action_space.sample())
            _update(digest, step)
            if step[2] or step[3]:
                break
    env.close()
    return digest.hexdigest()


def batch(worlds: int = 8, steps: int = 300) -> str:
    """sha256 of the native CPU batch through autoresets."""
    digest = hashlib.sha256()
    envs = gym.make_vec("BubbleRob-v0", num_envs=worlds, vectorization_mode="vector_entry_point")
    _update(digest, envs.reset(seed=5))
    envs.action_space.seed(5)
    for _ in range(steps):
        _update(digest, envs.step(envs.action_space.sample()))
    envs.close()
    return digest.hexdigest()


def _command() -> list[str]:
    # The checkout that bubblerob_env was imported from decides (PYTHONPATH=CHECKOUT).
    checkout = Path(bubblerob_env.__file__).resolve().parents[1]
    module = "bubblerob_cli" if (checkout / "bubblerob_cli").is_dir() else "bubblerob_env.cli"
    return [sys.executable, "-m", module]


def _folder_hash(folder: Path) -> str:
    digest = hashlib.sha256()
    for path in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(str(path.relative_to(folder)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


def bag(work: Path, name: str, *options: str) -> str:
    """sha256 of every file of a ``bubblerob record`` bag folder."""
    out = work / name
    subprocess.run(
        [*_command(), "record", "--policy", "laser", "--episodes", "2", "--seed", "0",
         "--start-time", START_TIME, "--no-progress", "--max-steps", "150", *options,
         "--out", str(out)],
        check=True, capture_output=True, text=True,
    )  # fmt: skip
    return _folder_hash(out)


def ray_run(work: Path) -> str | None:
    """sha256 of ``evaluate --ray local``'s per-episode JSON, in a loopback-only namespace."""
    if shutil.which("unshare") is None:
        return None
    out = work / "ray.json"
    command = " ".join(
        [*_command(), "evaluate", "--policy", "laser", "--episodes", "6", "--seed", "1000",
         "--ray", "local", "--per-episode", str(out)]
    )  # fmt: skip
    done = subprocess.run(
        ["unshare", "-n", "bash", "-c", f"ip link set lo up && {command}"],
        capture_output=True, text=True, env={**os.environ, "RAY_USAGE_STATS_ENABLED": "0"},
    )  # fmt: skip
    if done.returncode != 0:
        print(done.stderr[-2000:], file=sys.stderr)
        return None
    records = json.loads(out.read_text())
    # Wall-clock figures differ from run to run; everything else is the episode's.
    return hashlib.sha256(json.dumps(_without_times(records), sort_keys=True).encode()).hexdigest()


def _without_times(value: Any) -> Any:
    if isinstance(value, dict):
        timed = ("time", "fps")
        return {k: _without_times(v) for k, v in value.items() if not any(t in k for t in timed)}
    if isinstance(value, list):
        return [_without_times(v) for v in value]
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-ray", action="store_true", help="skip the Ray run")
    args = parser.parse_args()
    hashes: dict[str, str | None] = {}
    for env_id in ("BubbleRob-v0", "PioneerP3DX-v0"):
        hashes[f"episodes/{env_id}"] = episodes(env_id)
        hashes[f"episodes/{env_id}/flat+odometry_noise"] = episodes(
            env_id, obs_mode="flat", odometry_noise=0.1
        )
    hashes["episodes/BubbleRob-v0/camera"] = episodes("BubbleRob-v0", steps=60, camera=True)
    hashes["batch"] = batch()
    # A fixed folder: the bags' metadata records the command line, --out included.
    work = Path(tempfile.gettempdir()) / "bubblerob-behaviour-hashes"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir()
    try:
        for fmt in ("ros1", "mcap", "sqlite3"):
            hashes[f"bag/{fmt}"] = bag(work, fmt, "--format", fmt)
        hashes["bag/camera"] = bag(work, "camera", "--camera")
        hashes["bag/pioneer-mcap"] = bag(work, "pioneer", "--env", "PioneerP3DX-v0")
        if not args.no_ray:
            hashes["ray"] = ray_run(work)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print(json.dumps(hashes, indent=2))


if __name__ == "__main__":
    main()
