"""ROS 2 Humble's bag format: metadata.yaml version 5, QoS profiles as a string of integer enums.

``rosbags`` writes metadata versions 8 and 9 only. Humble's rosbag2 (``rosbag2_storage``'s
``yaml.hpp``/``metadata_io.cpp`` on the humble branch) decodes ``version`` and reads the fields of
versions up to 5: ``offered_qos_profiles`` with ``as<std::string>()``, so the YAML list that
version 9 writes fails with "bad conversion"; its ``rosbag2_transport/qos.cpp`` then loads that
string and reads ``history``, ``reliability``, ``durability`` and ``liveliness`` with
``as<int>()``, so version 9's enum names fail too. A Humble bag is therefore written as version 8
(the string of integer enums, in metadata.yaml, the sqlite3 ``topics`` table and the MCAP
channels) and its metadata.yaml rewritten at close as Humble's writer writes it: version 5,
without the later fields (``type_description_hash``, ``ros_distro``). ``custom_data`` (version 6)
stays: yaml-cpp reads only the keys it asks for, and it holds the episode summary.
"""

from __future__ import annotations

from pathlib import Path

from rosbags.interfaces import (
    Qos,
    QosDurability,
    QosHistory,
    QosLiveliness,
    QosReliability,
    QosTime,
)
from ruamel.yaml import YAML

__all__ = ["HUMBLE_VERSION", "humble_qos", "rewrite_metadata"]

HUMBLE_VERSION = 5
"""``BagMetadata::version`` in Humble's rosbag2."""

_UNSET = QosTime(0, 0)  # "default" durations, as rmw's RMW_DURATION_UNSPECIFIED


def humble_qos(latched: bool) -> list[Qos]:
    """What Humble's ``ros2 bag record`` stores for one rclpy/rclcpp publisher.

    Keep-last 10, reliable, volatile (the rclcpp/rclpy default), or keep-last 1 transient-local
    for a latched topic; automatic liveliness. Every topic gets a profile: Humble's player
    parses the string, and an empty one is no list of profiles.
    """
    return [
        Qos(
            QosHistory.KEEP_LAST,
            1 if latched else 10,
            QosReliability.RELIABLE,
            QosDurability.TRANSIENT_LOCAL if latched else QosDurability.VOLATILE,
            _UNSET,
            _UNSET,
            QosLiveliness.AUTOMATIC,
            _UNSET,
            False,
        )
    ]


def rewrite_metadata(path: Path) -> None:
    """Rewrite the version 8 ``metadata.yaml`` at ``path`` as Humble's version 5."""
    yaml = YAML(typ="rt")
    yaml.width = 2**16  # long strings stay on one line
    document = yaml.load(path.read_text(encoding="utf-8"))
    info = document["rosbag2_bagfile_information"]
    if info["version"] != 8:
        raise ValueError(f"{path}: expected a version 8 metadata.yaml, got {info['version']}")
    info["version"] = HUMBLE_VERSION
    info.pop("ros_distro", None)
    for topic in info["topics_with_message_count"]:
        topic["topic_metadata"].pop("type_description_hash", None)
    with path.open("w", encoding="utf-8") as stream:
        yaml.dump(document, stream)
