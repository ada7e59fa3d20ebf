"""ROS 1 bags pass Debian's real ``rosbag check`` and read fully with Debian's rosbag Python API."""

from __future__ import annotations

import json
import textwrap

import pytest
from ros_helpers import missing_debian_ros, read_all, run_debian

from bubblerob_env.ros.messages.distros import message_definition
from bubblerob_env.ros.messages.topics import MSGTYPES, Topics

pytestmark = pytest.mark.skipif((reason := missing_debian_ros()) is not None, reason=reason or "")

READ_ALL = textwrap.dedent(
    """
    import json, sys
    import rosbag

    counts = {}
    with rosbag.Bag(sys.argv[1]) as bag:
        for topic, msg, stamp in bag.read_messages():
            counts[topic] = counts.get(topic, 0) + 1
            if topic == "/scan":
                scan = msg
        info = bag.get_type_and_topic_info()
        print(json.dumps({
            "counts": counts,
            "total": bag.get_message_count(),
            "types": {t: v.msg_type for t, v in info.topics.items()},
            "scan_frame": scan.header.frame_id,
            "scan_rays": len(scan.ranges),
            "end": bag.get_end_time(),
        }))
    """
)


@pytest.mark.parametrize("compression", ["none", "bz2", "lz4"])
def test_rosbag_check_needs_no_migrations(record, compression):
    # Debian has no vision_msgs: tests/ros/test_detections.py checks what rosbag check says of it.
    no_detections = Topics(detections=None)
    path = record(
        "ros1", compression, episodes=2, steps=5, env_kwargs={"camera": True}, topics=no_detections
    )
    result = run_debian("/usr/bin/rosbag", "check", str(path))
    assert result.returncode == 0, result.stderr
    assert "does not need any migrations" in result.stdout, result.stdout + result.stderr


@pytest.mark.parametrize("compression", ["none", "bz2", "lz4"])
def test_debian_rosbag_python_api_reads_every_message(record, tmp_path, compression):
    path = record("ros1", compression, episodes=2, steps=5, env_kwargs={"camera": True})
    script = tmp_path / "read_all.py"
    script.write_text(READ_ALL)
    result = run_debian("/usr/bin/python3", str(script), str(path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    ours = {topic: len(messages) for topic, messages in read_all(path).items()}
    assert report["counts"] == ours
    assert report["total"] == sum(ours.values())
    assert report["types"]["/scan"] == "sensor_msgs/LaserScan"
    assert report["types"]["/tf"] == "tf2_msgs/TFMessage"
    assert (report["scan_frame"], report["scan_rays"]) == ("laser_link", 360)


def test_vendored_definitions_are_debians():
    # Every type a bag or the live node carries: full texts from the .msg files, md5 by rosbags.
    # Less vision_msgs, which Debian lacks (tests/ros/test_detections.py checks it with genpy).
    vision = {t for t in MSGTYPES.values() if t.startswith("vision_msgs/")}
    types = sorted({*MSGTYPES.values(), "std_msgs/msg/Int32"} - vision)
    script = textwrap.dedent(
        """
        import importlib, json, sys
        out = {}
        for name in json.loads(sys.argv[1]):
            package, message = name.split("/")
            cls = getattr(importlib.import_module(package + ".msg"), message)
            out[name] = [cls._full_text, cls._md5sum]
        print(json.dumps(out))
        """
    )
    names = [t.replace("/msg/", "/") for t in types]
    result = run_debian("/usr/bin/python3", "-c", script, json.dumps(names))
    assert result.returncode == 0, result.stderr
    debian = json.loads(result.stdout)
    assert len(debian) == len(types) == 17  # with a Nav env's PoseStamped and Path
    for msgtype, name in zip(types, names, strict=True):
        text, md5sum = message_definition("noetic", msgtype)
        assert [text, md5sum] == debian[name], name
