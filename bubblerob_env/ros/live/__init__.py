"""BubbleRob live on a ROS graph: the ``bubblerob node`` and the ``RosLivePublisher`` wrapper.

- :mod:`~bubblerob_env.ros.live.backend`: what a ROS client library must offer; errors.
- :mod:`~bubblerob_env.ros.live.connect`: ``load_backend``, starting the backend of ROS 1 or 2.
- :mod:`~bubblerob_env.ros.live.ros1` (``rospy``), :mod:`~bubblerob_env.ros.live.ros2`
  (``rclpy``): the backends, publishing pre-serialised bytes.
- :mod:`~bubblerob_env.ros.live.ros2_msgs`: builds ``tf2_msgs`` (no wheel) into a pip-installed
  ROS 2.
- :mod:`~bubblerob_env.ros.live.sink`: ``LiveSink``, the bag-sink interface on live topics.
- :mod:`~bubblerob_env.ros.live.wrapper`: ``RosLivePublisher``, publishing any RL loop.
- :mod:`~bubblerob_env.ros.live.controls`: wheel commands, watchdog, switches, sim control input.
- :mod:`~bubblerob_env.ros.live.node`: ``SimNode``, the simulation loop of ``bubblerob node``.
- :mod:`~bubblerob_env.ros.live.foxglove` (``foxglove-sdk``): the third backend, a Foxglove
  WebSocket server, no ROS; ``foxglove_json`` (JSON from clients), ``foxglove_services``
  (reset, pause, resume, step), ``foxglove_publisher`` (``FoxglovePublisher``, any RL loop).

Nothing here imports ``rospy``/``rclpy`` until a backend is started.
"""

from __future__ import annotations

from bubblerob_env.ros.live.backend import (
    BackendError,
    LiveBackend,
    MasterUnreachableError,
    RosUnavailableError,
)
from bubblerob_env.ros.live.connect import load_backend
from bubblerob_env.ros.live.controls import ControlState
from bubblerob_env.ros.live.foxglove import FoxgloveBackend
from bubblerob_env.ros.live.foxglove_publisher import FoxglovePublisher
from bubblerob_env.ros.live.node import NodeConfig, SimNode
from bubblerob_env.ros.live.wrapper import RosLivePublisher

__all__ = [
    "BackendError",
    "ControlState",
    "FoxgloveBackend",
    "FoxglovePublisher",
    "LiveBackend",
    "MasterUnreachableError",
    "NodeConfig",
    "RosLivePublisher",
    "RosUnavailableError",
    "SimNode",
    "load_backend",
]
