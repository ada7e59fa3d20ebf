"""``/detections``: vision_msgs/Detection2DArray of the recogniser's finds, in every bag format.

Read back with readers that build their types from the bag itself (rosbags' AnyReader, the mcap
packages, Debian's rosbag through genpy), not with the type store that wrote it.
"""

from __future__ import annotations

import json
import textwrap
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from ros_helpers import missing_debian_ros, read_all, run_debian

from bubblerob_env.ros import replay_bag
from bubblerob_env.ros.fastpath.serializer import FrameSerializer
from bubblerob_env.ros.messages.detections import DETECTION_NUMBERS, detection_numbers
from bubblerob_env.ros.messages.distros import message_definition, serialize
from bubblerob_env.ros.messages.topics import MSGTYPES, Topics
from bubblerob_env.specs import EnvSpecs
from bubblerob_env.vision.recognise import Detection, Recogniser

SEEN = {"camera": True, "obstacle_colours": True}
"""A camera and obstacles in the palette's colours: something to recognise."""


@pytest.fixture(scope="module")
def frames_with_detections() -> tuple[Any, list[list[Detection]]]:
    """The env's specs and the recogniser's finds in 6 frames that show obstacles."""
    count = 6
    env = gym.make("BubbleRob-v0", **SEEN)
    recogniser = Recogniser.for_env(env.unwrapped)
    found: list[list[Detection]] = []
    for seed in range(100, 140):
        obs, _ = env.reset(seed=seed)
        objects = recogniser(obs["camera"])
        if any(d.kind != "wall" for d in objects):
            found.append(objects)
        if len(found) == count:
            break
    specs = EnvSpecs.from_env(env)
    env.close()
    return specs, found


@pytest.mark.parametrize("distro", ["noetic", "humble", "jazzy"])
def test_packed_detections_are_rosbags_serialisation(
    distro: str, frames_with_detections: tuple[Any, list[list[Detection]]]
) -> None:
    specs, found_in_frames = frames_with_detections
    frames = [*found_in_frames, []]  # and an image with nothing in it
    serializer = FrameSerializer(specs, distro, Topics())
    assert min(map(len, frames)) == 0 and max(map(len, frames)) >= 3  # shapes of 0 to 3+
    for seq, found in enumerate(frames):
        stamp = 1_700_000_001_999_999_999 + seq
        ((topic, log_time, data),) = serializer.detections(found, stamp, seq + 2**32)
        sec, nanosec = divmod(stamp, 10**9)
        numbers = [dict(zip(DETECTION_NUMBERS, detection_numbers(d), strict=True)) for d in found]
        message = serializer.converter.detections(
            {"sec": sec, "nanosec": nanosec, "seq": seq}, [d.kind for d in found], numbers
        )
        assert data == serialize(distro, message, MSGTYPES["detections"])
        assert (topic, log_time) == ("/detections", stamp)


def _record(tmp_path: Path, fmt: str, topics: Topics | None = None) -> Path:
    from bubblerob_env.ros import RosBagRecorder

    env = gym.make("BubbleRob-v0", max_episode_steps=12, **SEEN)
    with RosBagRecorder(env, tmp_path / fmt, format=fmt, topics=topics) as recorder:
        for seed in (100, 101):  # both show boxes and cylinders
            recorder.reset(seed=seed)
            done = False
            while not done:
                *_, terminated, truncated, _ = recorder.step(np.array([0.5, 0.3], np.float32))
                done = terminated or truncated
    return recorder.bag_paths[0]


def _stamp(header: Any) -> tuple[int, int]:
    return header.stamp.sec, header.stamp.nanosec


def _check_against_images(messages: dict[str, list[tuple[int, Any]]]) -> None:
    """Each image has one detections message, stamped as it, listing what its pixels show."""
    images, detections = messages["/camera/image_raw"], messages["/detections"]
    assert len(images) == len(detections) == 26
    env = gym.make("BubbleRob-v0", **SEEN)
    recogniser = Recogniser.for_env(env.unwrapped)
    env.close()
    classes = set()
    for (image_time, image), (log_time, found) in zip(images, detections, strict=True):
        assert log_time == image_time
        for header in (found.header, *(d.header for d in found.detections)):
            assert _stamp(header) == _stamp(image.header)
            assert header.frame_id == image.header.frame_id == "camera_optical_frame"
        pixels = np.frombuffer(bytes(image.data), np.uint8).reshape(image.height, image.width, 3)
        expected = recogniser(pixels)
        assert len(found.detections) == len(expected)
        for detection, truth in zip(found.detections, expected, strict=True):
            (result,) = detection.results
            assert result.hypothesis.class_id == truth.kind
            u_min, v_min, u_max, v_max = truth.box
            box = detection.bbox
            assert box.center.position.x - (box.size_x - 1) / 2 == u_min
            assert box.center.position.y + (box.size_y - 1) / 2 == v_max
            position = result.pose.pose.position
            bearing = np.arctan2(-position.x, position.z)
            assert bearing == pytest.approx(truth.bearing, abs=1e-12)
            classes.add(truth.kind)
    assert {"wall", "box", "cylinder"} <= classes


@pytest.mark.parametrize("fmt", ["mcap", "sqlite3", "ros1"])
def test_bags_hold_detections_stamped_as_their_images(tmp_path: Path, fmt: str) -> None:
    path = _record(tmp_path, fmt)
    _check_against_images(read_all(path))
    assert replay_bag(path).ok  # replay recognises each image again: the same bytes
    if fmt == "mcap":  # the mcap packages' own decoder, from the channel's schema
        (storage,) = path.glob("*.mcap")
        with storage.open("rb") as stream:
            reader = make_reader(stream, decoder_factories=[DecoderFactory()])
            decoded = [
                (message.log_time, found)
                for _, channel, message, found in reader.iter_decoded_messages()
                if channel.topic in ("/detections", "/camera/image_raw")
            ]
        by_topic = {
            "/camera/image_raw": [d for d in decoded if hasattr(d[1], "encoding")],
            "/detections": [d for d in decoded if hasattr(d[1], "detections")],
        }
        _check_against_images(by_topic)


def test_left_out_detections_and_bags_recorded_before_them(tmp_path: Path) -> None:
    path = _record(tmp_path, "mcap", Topics(detections=None))
    messages = read_all(path)
    assert "/detections" not in messages and len(messages["/camera/image_raw"]) == 26
    # A bag recorded before /detections existed has no such key in its episodes' topics.
    names = Topics().to_dict()
    del names["detections"]
    assert Topics.from_dict(names).detections is None
    assert replay_bag(path).ok


DEBIAN_READ = textwrap.dedent(
    """
    import json, sys
    import genpy.dynamic, rosbag

    with rosbag.Bag(sys.argv[1]) as bag:
        found = [m for _, m, _ in bag.read_messages(topics=["/detections"])]
        images = [m for _, m, _ in bag.read_messages(topics=["/camera/image_raw"])]
        connection = next(c for c in bag._connections.values() if c.topic == "/detections")
    # genpy parses the bag's full text and computes its md5sum, as a typed subscriber would.
    classes = genpy.dynamic.generate_dynamic(connection.datatype, connection.msg_def)
    print(json.dumps({
        "count": len(found),
        "stamps": all(f.header.stamp == i.header.stamp for f, i in zip(found, images)),
        "seq": all(f.header.seq == i.header.seq for f, i in zip(found, images)),
        "classes": sorted({d.results[0].hypothesis.class_id for f in found for d in f.detections}),
        "md5sum": classes[connection.datatype]._md5sum,
        "bag_md5sum": connection.md5sum,
    }))
    """
)


@pytest.mark.skipif((reason := missing_debian_ros()) is not None, reason=reason or "")
def test_debian_rosbag_reads_detections_and_genpy_agrees_on_their_md5sum(tmp_path: Path) -> None:
    path = _record(tmp_path, "ros1")
    script = tmp_path / "read.py"
    script.write_text(DEBIAN_READ)
    result = run_debian("/usr/bin/python3", str(script), str(path))
    assert result.returncode == 0, result.stderr
    report = json.loads(result.stdout)
    _, md5sum = message_definition("noetic", MSGTYPES["detections"])
    assert report == {
        "count": 26,
        "stamps": True,
        "seq": True,
        "classes": ["box", "cylinder", "wall"],
        "md5sum": md5sum,
        "bag_md5sum": md5sum,
    }
    # Debian has no vision_msgs: rosbag check can map every other type, and this one to nothing.
    check = run_debian("/usr/bin/rosbag", "check", str(path))
    assert check.returncode == 0, check.stderr
    unknown = [line for line in check.stdout.splitlines() if line.strip().startswith("* From:")]
    assert unknown and all("vision_msgs/Detection2DArray" in line for line in unknown)
