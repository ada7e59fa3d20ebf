"""Debian's C++ ``rosbag play`` replays our ROS 1 bags to a rospy subscriber: ``/tf_static`` too.

Stamped at time 0, ``rosbag play`` dropped every message ("invalid time"), the only ``/tf_static``
included; bags now start at a real time (the recording's wall-clock start, or ``start_time``).
"""

from __future__ import annotations

import json
import subprocess
import textwrap
from pathlib import Path

import gymnasium as gym
import pytest
from live_helpers import Master, requires_ros, stop

from bubblerob_env.ros import RosBagRecorder

pytestmark = requires_ros

SUBSCRIBER = textwrap.dedent(
    """
    import json, sys, time
    import rospy
    from sensor_msgs.msg import LaserScan
    from tf2_msgs.msg import TFMessage

    got = {"/tf_static": [], "/scan": []}
    def keep(topic):
        def callback(msg):
            header = msg.header if topic == "/scan" else msg.transforms[0].header
            got[topic].append(header.stamp.to_nsec())
        return callback
    rospy.init_node("play_check", anonymous=True, disable_signals=True)
    rospy.Subscriber("/tf_static", TFMessage, keep("/tf_static"))
    rospy.Subscriber("/scan", LaserScan, keep("/scan"))
    print("ready", flush=True)
    deadline = time.time() + 60
    while time.time() < deadline and len(got["/scan"]) < int(sys.argv[1]):
        time.sleep(0.05)
    time.sleep(0.5)
    print(json.dumps(got), flush=True)
    """
)


@pytest.mark.parametrize(("compression", "start_time"), [("lz4", None), ("none", 1e9)])
def test_rosbag_play_delivers_tf_static_and_every_scan(
    tmp_path, master: Master, compression, start_time
):
    with RosBagRecorder(
        gym.make("BubbleRob-v0", max_episode_steps=8),
        tmp_path / "bag",
        format="ros1",
        compression=compression,
        start_time=start_time,
    ) as recorder:
        for seed in range(2):
            recorder.reset(seed=seed)
            while not any(recorder.step(recorder.action_space.sample())[2:4]):
                pass
    bag = recorder.bag_paths[0]
    script = tmp_path / "subscriber.py"
    script.write_text(SUBSCRIBER)
    scans = 18  # two episodes of 8 steps plus their first frames
    subscriber = master.popen(
        ["/usr/bin/python3", str(script), str(scans)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        assert subscriber.stdout is not None and subscriber.stdout.readline().strip() == "ready"
        play = master.run(["/usr/lib/rosbag/play", "--quiet", str(bag)], timeout=60)
        out, err = subscriber.communicate(timeout=70)
    finally:
        stop(subscriber)
    assert play.returncode == 0, play.stdout + play.stderr
    assert "invalid time" not in play.stdout + play.stderr
    got = json.loads(out.strip().splitlines()[-1])
    start = recorder.start_time_ns
    if start_time is not None:
        assert start == 10**18
    assert got["/tf_static"] == [start]  # the one latched message, at the recording's start
    assert len(got["/scan"]) == scans and got["/scan"][0] == start, err
    assert got["/scan"] == sorted(got["/scan"])


def test_rosbag_play_is_the_cpp_player() -> None:
    head = Path("/usr/lib/rosbag/play").read_bytes()[:4]
    assert head == b"\x7fELF"  # Debian's compiled rosbag/play, not a Python script
