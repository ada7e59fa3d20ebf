"""``--distro humble`` bags as ROS 2 Humble's rosbag2 decodes them.

:func:`humble_decode` transcribes Humble's decoding rules: ``rosbag2_storage``'s ``yaml.hpp``
(``convert<BagMetadata>``, ``convert<TopicMetadata>``, ``decode_for_version``: the fields of
versions 3, 4 and 5, read with yaml-cpp's ``as<T>()``) and ``rosbag2_transport/qos.cpp``
(``convert<Rosbag2QoS>::decode``: the offered profiles string loaded again, enums and depth
``as<int>()``, durations' ``sec``/``nsec`` ``as<uint64_t>()``, ``as<bool>()``). yaml-cpp keeps
scalars as text and converts on ``as<T>()``; :func:`_as` does the same on PyYAML's node graph.
"""

from __future__ import annotations

import re
import sqlite3

import pytest
import yaml
from mcap.reader import make_reader

from bubblerob_env.ros.readback.replay import replay_bag
from bubblerob_env.ros.readback.summary import read_summary


class BadConversion(Exception):
    """yaml-cpp's ``YAML::BadConversion`` ("bad conversion")."""


_TRUE = ("y", "Y", "yes", "Yes", "YES", "true", "True", "TRUE", "on", "On", "ON")
_FALSE = ("n", "N", "no", "No", "NO", "false", "False", "FALSE", "off", "Off", "OFF")
_BOOLS = {**dict.fromkeys(_TRUE, True), **dict.fromkeys(_FALSE, False)}


def _get(node: yaml.Node | None, key: str) -> yaml.Node | None:
    """``node[key]`` (an undefined node if missing, as yaml-cpp's operator[] on a const node)."""
    if not isinstance(node, yaml.MappingNode):
        return None
    return next((v for k, v in node.value if k.value == key), None)


def _as(node: yaml.Node | None, kind: str) -> object:
    """yaml-cpp's ``node.as<kind>()``: kind is string, int, uint64, bool or seq."""
    if kind == "seq":
        if not isinstance(node, yaml.SequenceNode):
            raise BadConversion("not a sequence")
        return node.value
    if not isinstance(node, yaml.ScalarNode) or node.tag == "tag:yaml.org,2002:null":
        raise BadConversion(f"{kind} from {type(node).__name__}")  # undefined, null, list, map
    text = node.value
    if kind == "string":
        return text
    if kind == "bool":
        if text not in _BOOLS:
            raise BadConversion(f"bool from {text!r}")
        return _BOOLS[text]
    pattern = r"[0-9]+" if kind == "uint64" else r"[-+]?[0-9]+"
    if not re.fullmatch(pattern, text):
        raise BadConversion(f"{kind} from {text!r}")
    return int(text)


def decode_qos(text: str) -> list[dict[str, object]]:
    """Humble's player: ``YAML::Load(offered_qos_profiles).as<std::vector<Rosbag2QoS>>()``."""
    profiles = []
    for node in _as(yaml.compose(text), "seq"):  # type: ignore[union-attr]

        def duration(key: str, node: yaml.Node = node) -> int:
            part = _get(node, key)
            return int(_as(_get(part, "sec"), "uint64")) * 10**9 + int(
                _as(_get(part, "nsec"), "uint64")
            )  # type: ignore[call-overload]

        profile = {
            key: _as(_get(node, key), "int")
            for key in ("history", "reliability", "durability", "liveliness", "depth")
        }
        profile |= {
            key: duration(key) for key in ("deadline", "lifespan", "liveliness_lease_duration")
        }
        profile["avoid_ros_namespace_conventions"] = _as(
            _get(node, "avoid_ros_namespace_conventions"), "bool"
        )
        profiles.append(profile)
    return profiles


def humble_decode(text: str) -> dict[str, object]:
    """Humble's ``MetadataIo::read_metadata``: ``rosbag2_bagfile_information`` as BagMetadata."""
    node = _get(yaml.compose(text), "rosbag2_bagfile_information")
    version = int(_as(_get(node, "version"), "int"))  # type: ignore[call-overload]
    info: dict[str, object] = {"version": version}
    info["storage_identifier"] = _as(_get(node, "storage_identifier"), "string")
    info["duration"] = _as(_get(_get(node, "duration"), "nanoseconds"), "uint64")
    info["starting_time"] = _as(
        _get(_get(node, "starting_time"), "nanoseconds_since_epoch"), "uint64"
    )
    info["message_count"] = _as(_get(node, "message_count"), "uint64")
    topics = []
    for item in _as(_get(node, "topics_with_message_count"), "seq"):  # type: ignore[union-attr]
        meta = _get(item, "topic_metadata")
        topic = {
            key: _as(_get(meta, key), "string") for key in ("name", "type", "serialization_format")
        }
        topic["offered_qos_profiles"] = (
            _as(_get(meta, "offered_qos_profiles"), "string") if version >= 4 else ""
        )
        topic["message_count"] = _as(_get(item, "message_count"), "uint64")
        topics.append(topic)
    info["topics"] = topics
    info["relative_file_paths"] = [
        _as(p, "string") for p in _as(_get(node, "relative_file_paths"), "seq")
    ]  # type: ignore[union-attr]
    if version >= 3:
        info["compression"] = [
            _as(_get(node, k), "string") for k in ("compression_format", "compression_mode")
        ]
    if version >= 5:
        files = []
        for item in _as(_get(node, "files"), "seq"):  # type: ignore[union-attr]
            start = _get(_get(item, "starting_time"), "nanoseconds_since_epoch")
            files.append(
                {
                    "path": _as(_get(item, "path"), "string"),
                    "starting_time": _as(start, "uint64"),
                    "duration": _as(_get(_get(item, "duration"), "nanoseconds"), "uint64"),
                    "message_count": _as(_get(item, "message_count"), "uint64"),
                }
            )
        info["files"] = files
    return info


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3"])
def test_humble_bags_decode_by_humbles_rules(record, fmt):
    # With the camera: its latched /camera/camera_info is among the topics checked below.
    camera = {"camera_width": 16, "camera_height": 12}
    path = record(fmt, episodes=2, steps=4, distro="humble", env_kwargs=camera)
    info = humble_decode((path / "metadata.yaml").read_text())
    assert info["version"] == 5 and info["storage_identifier"] == fmt
    topics = {t["name"]: t for t in info["topics"]}  # type: ignore[attr-defined]
    summary = read_summary(path)
    assert {t.name: t.count for t in summary.topics} == {
        n: t["message_count"] for n, t in topics.items()
    }
    # camera_info goes with every image, volatile, as camera drivers publish it; the test once
    # listed it as latched, which a recording without a camera could never contradict.
    latched = {"/tf_static", "/bubblerob/episode", "/map"}
    assert latched | {"/camera/camera_info", "/camera/image_raw"} <= set(topics)
    for name, topic in topics.items():
        (profile,) = decode_qos(topic["offered_qos_profiles"])
        assert (profile["history"], profile["reliability"]) == (1, 1), name  # keep last, reliable
        expected = (1, 1) if name in latched else (2, 10)  # transient local, 1; volatile, 10
        assert (profile["durability"], profile["depth"]) == expected, name
        assert profile["liveliness"] == 1 and profile["avoid_ros_namespace_conventions"] is False
    (file,) = info["files"]  # type: ignore[misc]
    assert file["message_count"] == info["message_count"] == summary.message_count
    text = (path / "metadata.yaml").read_text()
    assert "type_description_hash" not in text and "ros_distro" not in text  # Iron's and later
    assert replay_bag(path).ok  # and our own readers still read it


def test_humble_storages_carry_the_same_qos_strings(record, tmp_path):
    mcap_bag = record("mcap", episodes=1, steps=2, distro="humble", name="m")
    with next(mcap_bag.glob("*.mcap")).open("rb") as stream:
        channels = make_reader(stream).get_summary().channels.values()  # type: ignore[union-attr]
    for channel in channels:
        assert "topic_type_hash" not in channel.metadata
        assert decode_qos(channel.metadata["offered_qos_profiles"])
    db_bag = record("sqlite3", episodes=1, steps=2, distro="humble", name="s")
    with sqlite3.connect(next(db_bag.glob("*.db3"))) as db:
        rows = db.execute("SELECT name, offered_qos_profiles FROM topics").fetchall()
    assert rows and all(decode_qos(qos) for _, qos in rows)


def test_jazzy_bags_are_what_humble_cannot_read(record):
    # The transcription is strict where Humble is: Jazzy's version 9 list fails as the issue saw.
    path = record("mcap", episodes=1, steps=2, distro="jazzy")
    with pytest.raises(BadConversion, match="string from SequenceNode"):
        humble_decode((path / "metadata.yaml").read_text())
    with pytest.raises(BadConversion, match="int from 'keep_last'"):
        decode_qos("- {history: keep_last, depth: 1, reliability: reliable, durability: volatile}")
