"""The robot's body in Foxglove's 3D panel: a latched ``visualization_msgs/Marker`` on base_link.

There is no URDF of the robot to serve, and a tf frame alone is three small axes; a cylinder of
the robot's bounding radius (``robot.radius``: BubbleRob's 0.1 m, the Pioneer's 0.3 m),
frame-locked to its ``base_link``, shows where it is and how much room it takes. It goes out
once, latched, on ``<namespace>/bubblerob/robot_model`` (a Foxglove server sends it again to each
new subscriber).
"""

from __future__ import annotations

import json
from typing import Any

import gymnasium as gym

from bubblerob_env.ros.live.backend import LiveBackend
from bubblerob_env.ros.live.foxglove_json import json_to_cdr
from bubblerob_env.ros.messages.topics import Topics, namespace_prefix

__all__ = ["MARKER_TYPE", "publish_marker", "publish_robot_model", "robot_model_topic"]

MARKER_TYPE = "visualization_msgs/msg/Marker"
_CYLINDER, _HEIGHT = 3, 0.12


def robot_model_topic(topics: Topics) -> str:
    """``<namespace>/bubblerob/robot_model``."""
    return f"{namespace_prefix(topics.namespace)}/bubblerob/robot_model"


def publish_robot_model(backend: LiveBackend, env: gym.Env[Any, Any], topics: Topics) -> str:
    """Publish ``env``'s robot as a cylinder on base_link (latched); returns the topic."""
    radius = float(env.unwrapped.robot.radius)  # type: ignore[attr-defined]
    topic = robot_model_topic(topics)
    publish_marker(backend, radius, topics.frame_prefix, topic)
    return topic


def publish_marker(backend: LiveBackend, radius: float, frame_prefix: str, topic: str) -> None:
    """Publish a robot of ``radius`` as a cylinder on ``<frame_prefix>base_link``, latched."""
    marker = {
        "header": {"frame_id": frame_prefix + "base_link"},
        "ns": "bubblerob",
        "type": _CYLINDER,
        "pose": {"position": {"z": _HEIGHT / 2}, "orientation": {"w": 1.0}},
        "scale": {"x": 2 * radius, "y": 2 * radius, "z": _HEIGHT},
        "color": {"r": 0.95, "g": 0.55, "b": 0.1, "a": 0.8},
        "frame_locked": True,
    }
    publish = backend.advertise(topic, MARKER_TYPE, latched=True)
    publish(json_to_cdr(backend.distro, MARKER_TYPE, json.dumps(marker).encode()))
