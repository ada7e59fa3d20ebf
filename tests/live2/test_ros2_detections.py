"""``/detections`` on a live ROS 2 graph: typed ``vision_msgs`` subscribers get one per image.

The node and the probe are real rclpy processes (``.venv-ros2``, with vision_msgs' typesupport
built by ``bubblerob_env.ros.live.ros2_msgs``), DDS kept on the loopback in this session's domain.
"""

from __future__ import annotations

import json
import subprocess
import textwrap

from ros2_helpers import ROS2_PYTHON, ros2_env

PROBE = textwrap.dedent(
    """
    import json, time
    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import Image
    from vision_msgs.msg import Detection2DArray

    rclpy.init()
    node = rclpy.create_node("detections_probe")
    images, found = {}, {}
    stamp = lambda m: (m.header.stamp.sec, m.header.stamp.nanosec)
    node.create_subscription(
        Image, "/camera/image_raw", lambda m: images.setdefault(stamp(m), m.header.frame_id),
        qos_profile_sensor_data)
    node.create_subscription(
        Detection2DArray, "/detections",
        lambda m: found.setdefault(stamp(m), (m.header.frame_id, [
            (d.results[0].hypothesis.class_id, d.bbox.size_x, d.bbox.size_y, stamp(d))
            for d in m.detections])), 10)
    deadline = time.time() + 40
    while time.time() < deadline and len(found) < 30:
        rclpy.spin_once(node, timeout_sec=0.1)
    both = sorted(set(images) & set(found))
    print(json.dumps({
        "detections": len(found), "matched": len(both),
        "frames": sorted({found[s][0] for s in both} | {images[s] for s in both}),
        "classes": sorted({c for s in both for c, *_ in found[s][1]}),
        "own_stamps": all(d[3] == s for s in both for d in found[s][1]),
    }))
    """
)


def test_a_typed_vision_msgs_subscriber_gets_detections_stamped_as_images(start_node):
    node = start_node(
        "--camera", "--seed", "100", "--env-kwargs", '{"obstacle_colours": true}', "--watchdog", "0"
    )
    probe = subprocess.run(
        [str(ROS2_PYTHON), "-c", PROBE],
        env=ros2_env(),
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
    )
    assert probe.returncode == 0, probe.stderr
    assert node.alive(), node.output
    report = json.loads(probe.stdout.strip().splitlines()[-1])
    assert report["detections"] >= 30
    assert report["matched"] >= 20  # best-effort images may drop a few
    assert report["frames"] == ["camera_optical_frame"]
    assert "wall" in report["classes"] and len(report["classes"]) >= 2
    assert report["own_stamps"]
