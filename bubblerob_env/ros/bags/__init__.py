"""Bag files: bag sinks, their writers, crash safety.

Sinks (:class:`~bubblerob_env.ros.sink.Sink`) write ROS 1 ``.bag`` and ROS 2 MCAP and sqlite3 bags
with the ``rosbags`` writers they use (``ros1``, ``ros2``: on ``rosbags`` internals, listed in
``writers``); ``safety`` finishes them on signals and exit.
"""
