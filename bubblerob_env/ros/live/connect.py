"""How a live backend is chosen and started: :func:`load_backend`.

Kept out of :mod:`~bubblerob_env.ros.live.backend` (the interface and its errors, which the
backends import) so that the interface never imports its implementations.
"""

from __future__ import annotations

from bubblerob_env.ros.live.backend import LiveBackend

__all__ = ["load_backend"]


def load_backend(
    ros: int,
    node_name: str = "bubblerob",
    namespace: str = "",
    anonymous: bool = False,
    master_timeout: float = 3.0,
) -> LiveBackend:
    """Start a node with the client library of ROS ``ros`` (1: ``rospy``, 2: ``rclpy``).

    Raises:
        RosUnavailableError: The client library is not importable (says which package to install).
        MasterUnreachableError: ROS 1 only: no master answered within ``master_timeout`` seconds.
        ValueError: ``ros`` is neither 1 nor 2.
    """
    if ros == 1:
        from bubblerob_env.ros.live.ros1 import Ros1Backend

        return Ros1Backend(node_name, namespace, anonymous, master_timeout)
    if ros == 2:
        from bubblerob_env.ros.live.ros2 import Ros2Backend

        return Ros2Backend(node_name, namespace)
    raise ValueError(f"ros must be 1 or 2, got {ros!r}")
