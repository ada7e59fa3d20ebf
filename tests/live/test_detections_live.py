"""``/detections`` on a live ROS 1 graph (issue #28 item 4): real rosmaster, a rospy subscriber.

Debian has no vision_msgs, so the probe (Debian's rospy) subscribes the raw message
(``rospy.AnyMsg``) and keeps its bytes and the connection header the node sent; the test decodes
the bytes with the project's ROS 1 deserialiser and checks the advertised type, md5sum and
definition against the vendored vision_msgs. The oracle for the contents: the recogniser run
again on the images the probe received.
"""

from __future__ import annotations

import base64
import json
import textwrap

import numpy as np
import pytest
from live_helpers import requires_ros

pytestmark = requires_ros

DETECTIONS = "vision_msgs/msg/Detection2DArray"
ENV_KWARGS = {"obstacle_colours": True}
PROBE = textwrap.dedent(
    """
    import base64, json, threading, time
    import rospy
    from sensor_msgs.msg import Image

    rospy.init_node("detections_probe", anonymous=True, disable_signals=True)
    lock = threading.Lock()
    images, found, headers = {}, [], []

    def on_image(m):
        with lock:
            images[m.header.stamp.to_nsec()] = base64.b64encode(bytes(m.data)).decode()

    def on_detections(m):
        with lock:
            found.append(base64.b64encode(m._buff).decode())
            if not headers:
                headers.append(dict(m._connection_header))

    rospy.Subscriber("/camera/image_raw", Image, on_image, queue_size=None, tcp_nodelay=True)
    rospy.Subscriber("/detections", rospy.AnyMsg, on_detections, queue_size=None, tcp_nodelay=True)
    deadline = time.monotonic() + 40
    while time.monotonic() < deadline and len(found) < 30:
        time.sleep(0.05)
    time.sleep(0.3)  # the image of the last detection
    with lock:
        print(json.dumps({"images": images, "detections": found, "header": headers[0]}))
    rospy.signal_shutdown("done")
    """
)


@pytest.fixture(scope="module")
def received(master, start_node):
    node = start_node(
        "--camera", "--seed", "100", "--watchdog", "0", "--env-kwargs", json.dumps(ENV_KWARGS)
    )
    probe = master.run(["/usr/bin/python3", "-c", PROBE], timeout=90)
    assert probe.returncode == 0, probe.stderr
    assert node.alive(), node.output
    return json.loads(probe.stdout.strip().splitlines()[-1])


def decoded(received):
    from bubblerob_env.ros.messages.distros import deserialize

    return [
        deserialize("noetic", base64.b64decode(raw), DETECTIONS) for raw in received["detections"]
    ]


def stamp(header):
    return header.stamp.sec * 10**9 + header.stamp.nanosec


def test_the_node_advertises_vision_msgs_detection2darray(received):
    from bubblerob_env.ros.messages.distros import message_definition

    text, md5sum = message_definition("noetic", DETECTIONS)
    header = received["header"]
    assert header["type"] == "vision_msgs/Detection2DArray"
    assert header["md5sum"] == md5sum
    assert header["message_definition"] == text


def test_one_detection_array_per_image_stamped_and_framed_as_it(received):
    arrays = decoded(received)
    assert len(arrays) >= 30
    stamps = [stamp(a.header) for a in arrays]
    assert stamps == sorted(set(stamps))  # one per frame, in order
    images = sorted(int(s) for s in received["images"])
    window = [s for s in images if stamps[0] <= s <= stamps[-1]]
    assert window == stamps  # every image between the first and last detections has one
    assert {a.header.frame_id for a in arrays} == {"camera_optical_frame"}
    assert all(stamp(d.header) == stamp(a.header) for a in arrays for d in a.detections)


def test_the_detections_are_the_recognisers_on_the_received_images(received):
    import gymnasium as gym

    import bubblerob_env  # noqa: F401
    from bubblerob_env.vision.recognise import Recogniser

    env = gym.make("BubbleRob-v0", camera=True, **ENV_KWARGS)
    recognise = Recogniser.for_env(env.unwrapped)
    spec = env.unwrapped.camera_spec
    env.close()
    classes, compared = set(), 0
    for array in decoded(received):
        pixels = received["images"].get(str(stamp(array.header)))
        if pixels is None:
            continue
        image = np.frombuffer(base64.b64decode(pixels), np.uint8)
        expected = recognise(image.reshape(spec.height, spec.width, 3))
        got = [
            (d.results[0].hypothesis.class_id, d.bbox.center.position.x, d.bbox.size_x)
            for d in array.detections
        ]
        want = [(e.kind, (e.box[0] + e.box[2]) / 2.0, e.box[2] - e.box[0] + 1.0) for e in expected]
        assert got == want
        classes.update(kind for kind, *_ in got)
        compared += 1
    assert compared >= 25
    assert "wall" in classes and len(classes) >= 2  # obstacles too, not only the walls
