"""Fails loudly when a rosbags release changes the private API our writers rely on."""

from __future__ import annotations

from importlib.metadata import version

from bubblerob_env.ros.bags.writers import RELIED_ON, rosbags_changes


def test_rosbags_still_has_every_private_name_the_writers_use():
    changes = rosbags_changes()
    assert not changes, (
        f"rosbags {version('rosbags')} changed private API that bubblerob_env/ros/bags/ros1.py and "
        f"ros2.py rely on (listed in writers.py): {changes}. Adapt those modules, "
        "check the byte-equality tests, then widen the rosbags pin in pyproject.toml."
    )
    assert sum(len(names) for names in RELIED_ON.values()) > 30


def test_rosbags_is_in_the_pinned_range():
    major, minor, *_ = (int(part) for part in version("rosbags").split(".")[:3])
    assert (major, minor) == (0, 11), "pyproject.toml pins rosbags ~=0.11.9: the tested range"
