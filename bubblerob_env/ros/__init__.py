"""ROS-typed messages, bags and a live node for BubbleRob (the ``ros`` extra).

The env never imports it. The public interface: :class:`RosBagRecorder` (record any loop into
a ROS 1 or ROS 2 bag), :func:`recorded_env_fns` (one bag per sub-env of a vector env),
:class:`RosLivePublisher` (publish any loop on a live ROS graph; :class:`FoxglovePublisher`:
to Foxglove, no ROS), :func:`replay_bag`
(re-simulate a bag and compare: a :class:`ReplayReport` of :class:`Divergence` s, or a
:class:`ReplayError`), :func:`read_summary` (what a bag holds) and :class:`Topics`
(topic names). The rest is plumbing, in subpackages by job (``docs/ARCHITECTURE.md``):
``messages`` (what the messages are), ``fastpath`` (frames -> bytes), ``bags`` (where bytes go),
``readback`` (bags -> summary, replay) and ``live`` (the node).
"""

from __future__ import annotations

from bubblerob_env.ros.live.foxglove_publisher import FoxglovePublisher
from bubblerob_env.ros.live.wrapper import RosLivePublisher
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.readback.replay import Divergence, ReplayError, ReplayReport, replay_bag
from bubblerob_env.ros.readback.summary import BagSummary, read_summary
from bubblerob_env.ros.recorder import RosBagRecorder, recorded_env_fns

__all__ = [
    "BagSummary",
    "Divergence",
    "FoxglovePublisher",
    "ReplayError",
    "ReplayReport",
    "RosBagRecorder",
    "RosLivePublisher",
    "Topics",
    "read_summary",
    "recorded_env_fns",
    "replay_bag",
]
