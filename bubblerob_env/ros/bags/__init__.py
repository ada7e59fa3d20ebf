"""Where bytes go: bag sinks, their writers, the fan-out of frames to sinks, crash safety.

Sinks write ROS 1 ``.bag`` and ROS 2 MCAP and sqlite3 bags with the ``rosbags`` writers
they use (``ros1``, ``ros2``: on ``rosbags`` internals, listed in ``writers``), the fan-out of
frames to sinks, crash safety.
"""
