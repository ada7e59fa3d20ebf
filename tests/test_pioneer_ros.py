"""The Pioneer on the ROS paths (issue #26): record, info, replay and map read it from EnvSpecs."""

from __future__ import annotations

import pytest

pytest.importorskip("rosbags")

from bubblerob_cli import main as cli  # noqa: E402


def test_record_info_replay_and_map_a_pioneer_bag(tmp_path, capsys):
    argv = ["record", "--policy", "laser", "--episodes", "1", "--seed", "3", "--max-steps", "20"]
    argv += ["--env", "PioneerP3DX-v0", "--format", "mcap", "--no-progress"]
    assert cli.main([*argv, "--out", str(tmp_path)]) == 0
    (bag,) = (p for p in tmp_path.iterdir() if not p.name.endswith(".lock"))
    capsys.readouterr()
    assert cli.main(["info", str(bag)]) == 0
    info = capsys.readouterr().out
    assert "env PioneerP3DX-v0" in info and "/scan" in info
    # Replay re-makes the Pioneer from the bag's metadata and re-simulates every message: the
    # 901-ray scans, the frames of its description, its twist.
    assert cli.main(["replay", str(bag)]) == 0
    assert "replay matches the recording" in capsys.readouterr().out
    png = tmp_path / "map.png"
    assert cli.main(["map", str(bag), "--out", str(png)]) == 0
    assert png.stat().st_size > 0
    observed = next(line for line in capsys.readouterr().out.splitlines() if "observed" in line)
    assert float(observed.rsplit(" ", 1)[1]) > 0.7  # the 10 m arena's walls and obstacles


def test_the_pioneer_scan_and_frames_in_a_bag_are_its_own(tmp_path):
    import gymnasium as gym
    import numpy as np

    from bubblerob_env.ros import RosBagRecorder

    env = RosBagRecorder(gym.make("PioneerP3DX-v0"), tmp_path / "p.bag", format="ros1")
    env.reset(seed=1)
    env.step(np.zeros(2, np.float32))
    env.close()
    from rosbags.highlevel import AnyReader

    with AnyReader([tmp_path / "p.bag"]) as reader:
        by_topic = {c.topic: c for c in reader.connections}
        scan = next(
            reader.deserialize(raw, c.msgtype)
            for c, _, raw in reader.messages(connections=[by_topic["/scan"]])
        )
        tf_static = next(
            reader.deserialize(raw, c.msgtype)
            for c, _, raw in reader.messages(connections=[by_topic["/tf_static"]])
        )
    assert len(scan.ranges) == 901 and scan.range_max == pytest.approx(50.0)
    assert scan.angle_increment == pytest.approx(np.radians(0.2), rel=1e-6)
    laser = next(t for t in tf_static.transforms if t.child_frame_id == "laser_link")
    assert laser.header.frame_id == "base_link"
    assert (laser.transform.translation.x, laser.transform.translation.z) == pytest.approx(
        (0.10, 0.2125)
    )
