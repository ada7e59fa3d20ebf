"""ROS-typed messages and bags for BubbleRob (the ``ros`` extra; the env never imports it).

- :mod:`~bubblerob_env.ros.topics`: topic names and presets.
- :mod:`~bubblerob_env.ros.convert`: env frames -> ``rosbags`` messages (pure).
- :mod:`~bubblerob_env.ros.encode`, :mod:`~bubblerob_env.ros.serialize`: fast serialisation,
  once per distro, fanned out to sinks; :mod:`~bubblerob_env.ros.batch`: bag frames converted and
  packed many at a time.
- :mod:`~bubblerob_env.ros.episodes`: episode frames stamped in simulated time.
- :mod:`~bubblerob_env.ros.sinks`: ROS 1 ``.bag`` and ROS 2 MCAP / sqlite3 bag files.
- :mod:`~bubblerob_env.ros.recorder`: the ``RosBagRecorder`` wrapper.
- :mod:`~bubblerob_env.ros.bagread`, :mod:`~bubblerob_env.ros.replay`: reading bags back, replay.
- :mod:`~bubblerob_env.ros.live`: ``bubblerob node`` and the ``RosLivePublisher`` wrapper (live
  ROS 1 through ``rospy``; ROS 2 through ``rclpy``, untested).
"""

from __future__ import annotations

from bubblerob_env.ros.convert import EnvSpecs, RosConverter
from bubblerob_env.ros.distros import DISTROS
from bubblerob_env.ros.episodes import EpisodeStream
from bubblerob_env.ros.live import LiveSink, RosLivePublisher, SimNode
from bubblerob_env.ros.recorder import RosBagRecorder, recorded_env_fns
from bubblerob_env.ros.serialize import FrameSerializer, MessageFanout
from bubblerob_env.ros.sinks import COMPRESSIONS, FORMATS, BagPathError, BagSink, open_bag
from bubblerob_env.ros.topics import PRESETS, Topics, topics_preset

__all__ = [
    "COMPRESSIONS",
    "DISTROS",
    "FORMATS",
    "PRESETS",
    "BagPathError",
    "BagSink",
    "EnvSpecs",
    "EpisodeStream",
    "FrameSerializer",
    "LiveSink",
    "MessageFanout",
    "RosBagRecorder",
    "RosConverter",
    "RosLivePublisher",
    "SimNode",
    "Topics",
    "open_bag",
    "recorded_env_fns",
    "topics_preset",
]
