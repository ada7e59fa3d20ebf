"""Async vector envs with cameras after the parent rendered: one clear error, never a hang.

Mesa's llvmpipe renders with threads that a fork does not copy; a worker forked after its parent
rendered waited forever on its first frame (issue #22, item 3). Each case runs in a fresh process
under a timeout, in one script: forking before any rendering, after it, and with 'forkserver'.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

SCRIPT = """
import json
import gymnasium as gym
import bubblerob_env

def camera_shape(**vector_kwargs):
    kwargs = {"vector_kwargs": vector_kwargs} if vector_kwargs else {}
    envs = gym.make_vec("BubbleRob-v0", 2, vectorization_mode="async", camera=True, **kwargs)
    try:
        obs, _ = envs.reset(seed=0)
        obs, *_ = envs.step(envs.action_space.sample())
        return list(obs["camera"].shape)
    except Exception as error:
        return f"{type(error).__name__}: {error}"
    finally:
        envs.close(terminate=True)

if __name__ == "__main__":
    result = {"fork before rendering": camera_shape()}
    env = gym.make("BubbleRob-v0", camera=True)
    env.reset(seed=0)  # the parent renders a camera frame
    env.close()
    result["fork after rendering"] = camera_shape()
    result["forkserver after rendering"] = camera_shape(context="forkserver")
    print(json.dumps(result))
"""


def test_async_camera_workers_after_the_parent_rendered(tmp_path) -> None:
    script = tmp_path / "fork_after_rendering.py"  # a file: 'forkserver' re-imports __main__
    script.write_text(SCRIPT)
    env = {key: value for key, value in os.environ.items() if key != "LP_NUM_THREADS"}
    result = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=240, env=env
    )
    assert result.returncode == 0, result.stderr[-3000:]
    shapes = json.loads(result.stdout.strip().splitlines()[-1])
    assert shapes["fork before rendering"] == [2, 64, 64, 3]
    assert shapes["forkserver after rendering"] == [2, 64, 64, 3]
    error = shapes["fork after rendering"]
    assert isinstance(error, str) and error.startswith("ForkedAfterRenderingError: the camera")
    assert "'context': 'forkserver'" in error and "LP_NUM_THREADS=0" in error
    assert "\n" not in error
