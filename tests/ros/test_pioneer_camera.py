"""The Pioneer with its camera in bags (issues #26, #28): ``/detections`` from its own recogniser.

``Recogniser.for_env`` reads the obstacles' height from the model and scales its prior for
objects cut by the frame's edge with the robot's arena; an env without obstacles (no obstacle
slots in its model) gets the recogniser an env with obstacles gets.
"""

from __future__ import annotations

import re

import gymnasium as gym
import pytest

pytest.importorskip("rosbags")

from bubblerob_cli import main as cli  # noqa: E402
from bubblerob_env.vision.recognise import CUT_HALF_WIDTH, Recogniser  # noqa: E402


def test_record_info_replay_a_pioneer_bag_with_its_camera(tmp_path, capsys):
    argv = ["record", "--env", "PioneerP3DX-v0", "--camera", "--policy", "laser"]
    argv += ["--episodes", "1", "--seed", "3", "--max-steps", "12", "--no-progress"]
    assert cli.main([*argv, "--out", str(tmp_path)]) == 0
    (bag,) = (p for p in tmp_path.iterdir() if not p.name.endswith(".lock"))
    capsys.readouterr()
    assert cli.main(["info", str(bag)]) == 0
    info = capsys.readouterr().out
    counts = dict(re.findall(r"^\s+(/\S+)\s+(\d+)\s", info, re.M))
    assert counts["/detections"] == counts["/camera/image_raw"] == "13", info
    # Replay re-makes the Pioneer from the metadata, and its recogniser from the env: every
    # /detections message is re-simulated and compared byte for byte.
    assert cli.main(["replay", str(bag)]) == 0
    assert "replay matches the recording" in capsys.readouterr().out


@pytest.mark.parametrize("env_id", ["BubbleRob-v0", "PioneerP3DX-v0"])
def test_an_env_without_obstacles_gets_the_same_recogniser(env_id):
    recognisers = []
    for kwargs in ({}, {"num_obstacles": (0, 0)}):
        env = gym.make(env_id, camera=True, **kwargs)
        recognisers.append(Recogniser.for_env(env.unwrapped))
        env.close()
    with_slots, without = recognisers
    assert without.obstacle_height == with_slots.obstacle_height
    assert without.camera_height == with_slots.camera_height
    assert without.cut_half_width == with_slots.cut_half_width
    if env_id == "BubbleRob-v0":  # the prior it was chosen for, unchanged
        assert with_slots.cut_half_width == CUT_HALF_WIDTH
        assert with_slots.obstacle_height == pytest.approx(0.3)  # common.xml's obstacle class
    else:  # the Pioneer's 0.5 m obstacles, 0.2-0.6 m across: a wider prior
        assert with_slots.obstacle_height == pytest.approx(0.5)
        assert with_slots.cut_half_width["box"] > CUT_HALF_WIDTH["box"] * 2
