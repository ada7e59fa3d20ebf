"""ROS 2 backend: ``rclpy`` publishing CDR bytes (untested: no ROS 2 install in CI).

Publishes the same CDR bytes a ROS 2 bag holds (``Publisher.publish`` accepts serialised bytes)
and subscribes with ``raw=True``; the distro's definitions (``humble`` or ``jazzy``) follow
``ROS_DISTRO``. DDS matches types itself, so wrongly typed publishers never reach the callback.
"""

from __future__ import annotations

import os
import threading
from typing import Any

from bubblerob_env.ros.live.backend import LiveBackend, Publish, RawCallback, RosUnavailableError
from bubblerob_env.ros.messages.topics import namespace_prefix

__all__ = ["Ros2Backend"]

INSTALL_HINT = (
    "source a ROS 2 install (source /opt/ros/jazzy/setup.bash) so that rclpy and the message "
    "packages (sensor_msgs, nav_msgs, tf2_msgs, rosgraph_msgs, geometry_msgs, std_msgs) import"
)


class Ros2Backend(LiveBackend):
    """An ``rclpy`` node spun in a background thread."""

    ros_version = 2

    def __init__(self, node_name: str = "bubblerob", namespace: str = "") -> None:
        """Start the node.

        Raises:
            RosUnavailableError: ``rclpy`` or a message package is not importable.
        """
        try:
            import rclpy  # type: ignore[import-not-found,unused-ignore]
            from rclpy.executors import (  # type: ignore[import-not-found,unused-ignore]
                SingleThreadedExecutor,
            )
            from rclpy.qos import (  # type: ignore[import-not-found,unused-ignore]
                DurabilityPolicy,
                QoSProfile,
            )
            from rosidl_runtime_py.utilities import (  # type: ignore[import-not-found,unused-ignore]
                get_message,
            )
        except ImportError as error:
            raise RosUnavailableError(
                f"rclpy is not importable ({error}): {INSTALL_HINT}"
            ) from None
        self.distro = "humble" if os.environ.get("ROS_DISTRO") == "humble" else "jazzy"
        self._rclpy = rclpy
        self._get_message = get_message
        self._qos = QoSProfile
        self._durability = DurabilityPolicy
        if not rclpy.ok():
            rclpy.init(args=[])
        ns = namespace_prefix(namespace)
        self._node = rclpy.create_node(node_name, namespace=ns)
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self._node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()
        self._closed = False

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except Exception:  # noqa: BLE001 - the executor stops when the context shuts down
            return

    def _type(self, msgtype: str) -> Any:
        try:
            return self._get_message(msgtype)
        except (AttributeError, ModuleNotFoundError, ValueError) as error:
            raise RosUnavailableError(
                f"no ROS 2 type {msgtype} ({error}): {INSTALL_HINT}"
            ) from None

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        """See :meth:`LiveBackend.advertise`."""
        qos = self._qos(depth=1 if latched else 10)
        if latched:
            qos.durability = self._durability.TRANSIENT_LOCAL
        publisher = self._node.create_publisher(self._type(msgtype), topic, qos)

        def publish(data: bytes) -> None:
            publisher.publish(bytes(data))

        return publish

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        """See :meth:`LiveBackend.subscribe`."""
        self._node.create_subscription(
            self._type(msgtype), topic, lambda raw: callback(bytes(raw), None, "?"), 10, raw=True
        )

    def ok(self) -> bool:
        """See :meth:`LiveBackend.ok`."""
        return not self._closed and bool(self._rclpy.ok())

    def shutdown(self, reason: str = "done") -> None:
        """See :meth:`LiveBackend.shutdown`."""
        if self._closed:
            return
        self._closed = True
        self._executor.shutdown()
        self._node.destroy_node()
        if self._rclpy.ok():
            self._rclpy.shutdown()

    def log(self, level: str, text: str) -> None:
        """See :meth:`LiveBackend.log`."""
        logger = self._node.get_logger()
        (logger.warning if level == "warn" else logger.info)(text)
