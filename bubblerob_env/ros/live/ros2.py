"""ROS 2 backend: ``rclpy`` publishing CDR bytes, control messages received raw.

Tested against real ``rclpy`` (Jazzy, Fast DDS) from the ``ros-jazzy-*`` wheels on the Python
package index, in a virtualenv of its own: ROS 1 and ROS 2 message packages share module names
(``std_msgs``, ``rosgraph_msgs``, ...), so they cannot share an environment with Debian's
``rospy``. ``tf2_msgs`` has no wheel: :mod:`~bubblerob_env.ros.live.ros2_msgs` generates and
builds it from its ``.msg`` with the rosidl generators those wheels bring along.

Publishes the same CDR bytes a ROS 2 bag holds (``Publisher.publish`` accepts serialised bytes)
and subscribes with ``raw=True``; the distro's definitions (``humble`` or ``jazzy``) follow
``ROS_DISTRO``. DDS matches types itself, so wrongly typed publishers never reach the callback.
Each topic gets the QoS ROS 2 users expect (:func:`qos_kind`): sensor-data QoS for sensors,
reliable transient-local for latched topics (``/tf_static``, ``simulationState``), reliable for
the rest (``/clock`` included: rclpy's own time source subscribes best effort, which matches).
"""

from __future__ import annotations

import importlib
import os
import threading
from typing import Any

from bubblerob_env.ros.live.backend import (
    BackendError,
    LiveBackend,
    Publish,
    RawCallback,
    RosUnavailableError,
)
from bubblerob_env.ros.messages.topics import namespace_prefix

__all__ = ["INSTALL_HINT", "RELIABLE_DEPTH", "SENSOR_TYPES", "Ros2Backend", "qos_kind"]

INSTALL_HINT = (
    "install rclpy in a virtualenv of its own (not next to ROS 1's rospy): python3 -m venv "
    ".venv-ros2 && .venv-ros2/bin/pip install -e '.[ros2]' && .venv-ros2/bin/python -m "
    "bubblerob_env.ros.live.ros2_msgs, then run .venv-ros2/bin/bubblerob node --ros 2; or source "
    "a ROS 2 install (source /opt/ros/jazzy/setup.bash)"
)
SENSOR_TYPES = frozenset(
    {
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/Range",
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CameraInfo",
    }
)
"""Published with sensor-data QoS (best effort, keep last 5), as ROS 2 drivers do: subscribe
with ``qos_profile_sensor_data`` (a reliable subscription does not match)."""
RELIABLE_DEPTH = 100
"""History depth of reliable publishers and of every subscription (tf2's depth): a burst of
``triggerNextStep`` or of steps run flat out is not cut short."""


def qos_kind(msgtype: str, latched: bool = False) -> str:
    """``"latched"``, ``"sensor"`` or ``"reliable"``: the QoS a topic is published with."""
    if latched:
        return "latched"
    return "sensor" if msgtype in SENSOR_TYPES else "reliable"


class Ros2Backend(LiveBackend):
    """An ``rclpy`` node spun in a background thread."""

    ros_version = 2

    def __init__(self, node_name: str = "bubblerob", namespace: str = "") -> None:
        """Start the node ``/<namespace>/<node_name>``.

        Raises:
            RosUnavailableError: ``rclpy`` is not importable.
        """
        try:
            import rclpy  # type: ignore[import-not-found,unused-ignore]
            from rclpy.executors import (  # type: ignore[import-not-found,unused-ignore]
                SingleThreadedExecutor,
            )
            from rclpy.qos import (  # type: ignore[import-not-found,unused-ignore]
                DurabilityPolicy,
                HistoryPolicy,
                QoSProfile,
                ReliabilityPolicy,
                qos_profile_sensor_data,
            )
        except ImportError as error:
            raise RosUnavailableError(
                f"rclpy is not importable ({error}): {INSTALL_HINT}"
            ) from None
        self.distro = "humble" if os.environ.get("ROS_DISTRO") == "humble" else "jazzy"
        self._rclpy = rclpy
        keep_last, reliable = HistoryPolicy.KEEP_LAST, ReliabilityPolicy.RELIABLE
        self._qos = {
            "sensor": qos_profile_sensor_data,
            "reliable": QoSProfile(history=keep_last, depth=RELIABLE_DEPTH, reliability=reliable),
            "latched": QoSProfile(
                history=keep_last,
                depth=1,
                reliability=reliable,
                durability=DurabilityPolicy.TRANSIENT_LOCAL,
            ),
        }
        self._types: dict[str, Any] = {}
        domain = os.environ.get("ROS_DOMAIN_ID", "").strip()
        if domain and not (domain.isdigit() and int(domain) <= 232):
            # Fast DDS would exit the process with status 1 and a log line
            raise BackendError(f"ROS_DOMAIN_ID={domain!r}: it must be 0-232 (0-101 is safe)")
        try:
            if not rclpy.ok():
                rclpy.init(args=[])
            self._node = rclpy.create_node(node_name, namespace=namespace_prefix(namespace) or "/")
        except Exception as error:  # noqa: BLE001 - rclpy's RCLError and friends
            raise BackendError(
                f"rclpy could not start the node ({type(error).__name__}: {error}); check "
                "ROS_DOMAIN_ID, ROS_AUTOMATIC_DISCOVERY_RANGE and RMW_IMPLEMENTATION"
            ) from None
        self._executor = SingleThreadedExecutor()
        self._executor.add_node(self._node)
        self._closed = False
        self._thread = threading.Thread(target=self._spin, name="rclpy-spin", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            self._executor.spin()
        except Exception:  # noqa: BLE001 - the executor stops when the context shuts down
            return

    def _type(self, msgtype: str) -> Any:
        """The Python message class of ``msgtype`` (``pkg/msg/Type``)."""
        if msgtype not in self._types:
            package, _, name = msgtype.split("/")
            try:
                cls = getattr(importlib.import_module(f"{package}.msg"), name)
            except (AttributeError, ImportError) as error:
                hint = INSTALL_HINT
                if package == "tf2_msgs":
                    hint = (
                        "tf2_msgs has no wheel: build it into this environment with "
                        "`python -m bubblerob_env.ros.live.ros2_msgs` (or source a ROS 2 install)"
                    )
                raise RosUnavailableError(f"no ROS 2 type {msgtype} ({error}): {hint}") from None
            self._types[msgtype] = cls
        return self._types[msgtype]

    def qos(self, msgtype: str, latched: bool = False) -> Any:
        """The ``QoSProfile`` a topic of ``msgtype`` is published with (see :func:`qos_kind`)."""
        return self._qos[qos_kind(msgtype, latched)]

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        """See :meth:`LiveBackend.advertise`."""
        publisher = self._node.create_publisher(
            self._type(msgtype), topic, self.qos(msgtype, latched)
        )

        def publish(data: bytes) -> None:
            publisher.publish(data if type(data) is bytes else bytes(data))

        return publish

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        """See :meth:`LiveBackend.subscribe`; reliable, keep last :data:`RELIABLE_DEPTH`.

        Sensor types (:data:`SENSOR_TYPES`) get sensor-data QoS, which matches their publishers.
        """
        self._node.create_subscription(
            self._type(msgtype),
            topic,
            lambda raw: callback(bytes(raw), None, "?"),
            self._qos["sensor" if msgtype in SENSOR_TYPES else "reliable"],
            raw=True,
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
        self._thread.join(timeout=5.0)

    def log(self, level: str, text: str) -> None:
        """See :meth:`LiveBackend.log`."""
        logger = self._node.get_logger()
        # rclpy remembers each call site's severity and refuses another: one call per level.
        if level == "warn":
            logger.warning(text)
        else:
            logger.info(text)
