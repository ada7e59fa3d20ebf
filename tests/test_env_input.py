"""Bad input, episode success, fork safety and video timing of ``BubbleRob-v0`` (issue #9)."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap
import time

import gymnasium as gym
import numpy as np
import pytest

import bubblerob_env  # noqa: F401
from bubblerob_env import BubbleRobEnv
from bubblerob_env.arena import ASSETS_DIR


def test_unknown_kwarg_uses_pythons_wording_that_torchrl_retries_on():
    # torchrl's GymEnv passes frameskip and retries without it only if the TypeError contains
    # exactly this text (its ACCEPTED_TYPE_ERRORS table).
    with pytest.raises(TypeError) as raised:
        gym.make("BubbleRob-v0", frameskip=4)
    assert "unexpected keyword argument 'frameskip'" in str(raised.value)
    assert "valid keyword arguments are: xml_file" in str(raised.value)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"start_pose": (math.nan, 0.0, 0.0)}, r"start_pose must be finite"),
        ({"start_pose": (0.0, 0.0, math.inf)}, r"start_pose must be finite"),
        ({"start_pose": (100.0, 100.0, 0.0)}, r"outside the arena.*\[-1\.890, 1\.890\]"),
        ({"start_pose": (1.95, 0.0, 0.0)}, r"outside the arena or into its walls"),
        ({"start_pose": ("a", 0.0)}, r"start_pose must be \(x, y, yaw\) numbers"),
        ({"forward_reward_weight": math.nan}, r"forward_reward_weight must be a finite number"),
        ({"spin_cost_weight": math.inf}, r"spin_cost_weight must be a finite number"),
        ({"clearance_cost_weight": -math.inf}, r"clearance_cost_weight must be a finite"),
        ({"collision_penalty": math.nan}, r"collision_penalty must be a finite number"),
        ({"control_timestep": 10.0}, r"10.0 / 4 s .* <= 0.05 s: use physics_substeps >= 200"),
        ({"control_timestep": 0.2, "physics_substeps": 2}, r"physics_substeps >= 4"),
        ({"camera_width": 0}, r"camera_width must be an int >= 1 and <= 4096, got 0"),
        ({"camera_height": 2.5}, r"camera_height must be an int >= 1 and <= 4096, got 2.5"),
        ({"camera_width": 5000}, r"camera_width must be an int >= 1 and <= 4096, got 5000"),
        ({"camera_width": True}, r"camera_width must be an int"),
        ({"render_width": 0}, r"render_width must be an int >= 1 and <= 4096"),
        ({"render_height": 64.0}, r"render_height must be an int"),
        ({"num_obstacles": (0, 100_000)}, r"num_obstacles must be .* 0 <= min <= max <= 256"),
        ({"num_obstacles": (2.5, 4)}, r"num_obstacles must be \(min, max\) ints"),
        ({"obstacle_size": (0.1, math.nan)}, r"obstacle_size must be \(min, max\) numbers"),
        ({"physics_substeps": 2.0}, r"physics_substeps must be an int >= 1, got 2.0"),
    ],
)
def test_bad_values_raise_one_line_naming_value_and_allowed_range(kwargs, match):
    started = time.perf_counter()
    with pytest.raises(ValueError, match=match) as raised:
        BubbleRobEnv(**kwargs)
    assert "\n" not in str(raised.value)
    assert time.perf_counter() - started < 5.0  # (0, 100000) used to hang for minutes


def test_start_pose_inside_a_scene_wall_is_rejected_at_reset():
    # wall_test.xml: a wall's near face at x = 1.0; the robot (radius 0.11 m) at x = 0.95 overlaps.
    env = BubbleRobEnv(
        xml_file=ASSETS_DIR / "scenes" / "wall_test.xml", start_pose=(0.95, 0.0, 0.0)
    )
    with pytest.raises(ValueError, match=r"start_pose \(0.95, 0.0, 0.0\) overlaps a wall"):
        env.reset(seed=0)


def test_documented_image_sizes_work_up_to_the_limit():
    env = BubbleRobEnv(
        camera_width=1024,
        camera_height=24,
        render_mode="rgb_array",
        render_width=2048,
        render_height=16,
        num_obstacles=(0, 0),
    )
    obs, _ = env.reset(seed=0)
    assert obs["camera"].shape == (24, 1024, 3)
    frame = env.render()
    assert frame is not None and frame.shape == (16, 2048, 3)
    env.close()


def test_step_and_reset_after_close_raise():
    env = gym.make("BubbleRob-v0", camera=True)
    env.reset(seed=0)
    env.close()
    with pytest.raises(RuntimeError, match=r"step\(\) called after close\(\)"):
        env.step(np.zeros(2, np.float32))
    with pytest.raises(RuntimeError, match=r"reset\(\) called after close\(\)"):
        env.reset(seed=0)


def test_step_before_reset_is_one_line_and_the_env_still_resets():
    from bubblerob_env.env import BubbleRobEnv

    env = BubbleRobEnv()  # unwrapped: Gymnasium's OrderEnforcing would answer first
    with pytest.raises(
        RuntimeError, match=r"^step\(\) called before reset\(\): reset the env first$"
    ):
        env.step(np.zeros(2, np.float32))
    env.reset(seed=0)
    env.step(np.zeros(2, np.float32))
    env.close()


def test_diverged_physics_truncates_with_the_reason():
    env = gym.make("BubbleRob-v0")
    env.reset(seed=0)
    # Force what an unintegrable step produces: accelerations MuJoCo flags as huge.
    env.unwrapped.data.qvel[:] = 1e30
    with pytest.warns(UserWarning, match=r"mjWARN_BADQ(ACC|POS|VEL) \(the simulation diverged"):
        _, _, terminated, truncated, info = env.step(np.zeros(2, np.float32))
    assert truncated and not terminated
    assert "diverged" in info["physics_diverged"]
    assert info["is_success"] is False


def _run_until_done(env, action):
    info: dict = {}
    steps = 0
    collided = False
    while True:
        _, _, terminated, truncated, info = env.step(np.asarray(action, np.float32))
        steps += 1
        collided = collided or info["collision"]
        if terminated or truncated:
            return terminated, truncated, info, steps
        # Before the last step: whether the episode is a success so far.
        assert info["is_success"] is (not collided)


def test_is_success_time_limit_without_collision():
    env = gym.make("BubbleRob-v0", max_episode_steps=30, action_type="twist")
    env.reset(seed=0)
    terminated, truncated, info, steps = _run_until_done(env, [0.0, 0.0])
    assert (terminated, truncated, steps) == (False, True, 30)
    assert info["is_success"] is True


def test_is_success_false_after_any_collision():
    scene = ASSETS_DIR / "scenes" / "wall_test.xml"  # wall 1.0 m ahead
    env = gym.make(
        "BubbleRob-v0",
        xml_file=scene,
        start_pose=(0.0, 0.0, 0.0),
        action_type="twist",
        max_episode_steps=200,
    )
    env.reset(seed=0)
    terminated, _, info, _ = _run_until_done(env, [1.0, 0.0])
    assert terminated and info["collision"] and info["is_success"] is False
    # Without termination the episode runs to the time limit, and still is no success.
    env = gym.make(
        "BubbleRob-v0",
        xml_file=scene,
        start_pose=(0.0, 0.0, 0.0),
        action_type="twist",
        max_episode_steps=200,
        terminate_on_collision=False,
    )
    env.reset(seed=0)
    terminated, truncated, info, _ = _run_until_done(env, [1.0, 0.0])
    assert truncated and not terminated and info["is_success"] is False


def test_video_plays_at_the_control_rate(tmp_path):
    imageio = pytest.importorskip("imageio.v2")
    from policies.evaluation import write_video

    env = gym.make(
        "BubbleRob-v0",
        control_timestep=0.1,
        render_mode="rgb_array",
        render_width=64,
        render_height=64,
    )
    assert env.metadata["render_fps"] == pytest.approx(10.0)
    env.reset(seed=0)
    frames = [env.render() for _ in range(10)]
    path = tmp_path / "episode.mp4"
    write_video(path, frames, env.metadata["render_fps"])
    # ffmpeg's own reading of the file: 10 frames at 10 fps is 1 s of video.
    meta = imageio.get_reader(path).get_meta_data()
    assert meta["fps"] == pytest.approx(10.0)


_FORK_SCRIPT = """
import gymnasium as gym
import numpy as np
import bubblerob_env

def main():
{body}
    print("OK", flush=True)

if __name__ == "__main__":  # forkserver and spawn re-import the main module
    main()
"""


@pytest.mark.parametrize(
    "body",
    [
        pytest.param(
            """
envs = gym.make_vec("BubbleRob-v0", num_envs=2, vectorization_mode="async", camera=True)
obs, _ = envs.reset(seed=0)
obs, *_ = envs.step(np.zeros((2, 2), np.float32))
assert obs["camera"].shape == (2, 64, 64, 3) and obs["camera"].any()
envs.close()
""",
            id="gymnasium-async",
        ),
        pytest.param(
            """
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import SubprocVecEnv
envs = make_vec_env("BubbleRob-v0", n_envs=2, vec_env_cls=SubprocVecEnv,
                    env_kwargs={"camera": True})
obs = envs.reset()
obs, *_ = envs.step(np.zeros((2, 2), np.float32))
assert obs["camera"].shape == (2, 64, 64, 3) and obs["camera"].any()
envs.close()
""",
            id="sb3-subproc",
        ),
    ],
)
def test_camera_envs_in_subprocesses_with_the_default_start_method(body, tmp_path):
    # A fresh interpreter: this test process may already hold an EGL context from other tests.
    script = tmp_path / "user_script.py"
    script.write_text(_FORK_SCRIPT.format(body=textwrap.indent(textwrap.dedent(body), "    ")))
    result = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=180
    )
    assert result.returncode == 0 and "OK" in result.stdout, result.stderr[-3000:]


@pytest.mark.parametrize("how", ["pickle", "deepcopy"])
def test_env_with_renderers_pickles_and_the_copy_continues_bit_for_bit(how):
    import copy
    import pickle

    env = gym.make(
        "BubbleRob-v0", camera=True, render_mode="rgb_array", render_width=64, render_height=64
    )
    env.reset(seed=5)
    actions = np.random.default_rng(0).uniform(-1, 1, (20, 2)).astype(np.float32)
    for action in actions[:10]:
        env.step(action)
    env.render()  # both renderers now hold OpenGL contexts
    clone = pickle.loads(pickle.dumps(env)) if how == "pickle" else copy.deepcopy(env)
    for action in actions[10:]:
        obs_a, reward_a, *_ = env.step(action)
        obs_b, reward_b, *_ = clone.step(action)
        assert reward_a == reward_b
        for key in obs_a:
            np.testing.assert_array_equal(obs_a[key], obs_b[key])
    np.testing.assert_array_equal(env.render(), clone.render())
    env.close()
    clone.close()
