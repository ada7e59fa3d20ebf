"""``bubblerob teleop --ros 1|2``: the keyboard drives a running live node over ``cmd_vel``.

Nothing is simulated here: a ROS node (``rospy`` for ROS 1, found as ``bubblerob node --ros 1``
finds it; ``rclpy`` for ROS 2, from the ``.venv-ros2`` that runs ``bubblerob node --ros 2``)
publishes ``geometry_msgs/Twist`` on the node's ``cmd_vel`` at the node's control rate, 20 Hz,
as the keys set it (:class:`~bubblerob_cli.teleop.keys.TeleopState`, fractions of the robot's
limits, scaled to m/s and rad/s here). The status lines show what the node publishes: measured
speed and pose (``/odom``), the nearest laser reading (``/scan``), the collisions
(``/terminated``) and, with a Nav env, the goal's distance and bearing from that pose
(``/move_base/current_goal``; "reached" after ``/goal_reached``). The messages are decoded with
the ROS layer's own type stores (``bubblerob_env.ros.messages``).
"""

from __future__ import annotations

import math
import threading
import time
from typing import TYPE_CHECKING, Any

import numpy as np

from bubblerob_cli.teleop.keys import Clock, TeleopState, goal_text, start_screen, status_line

if TYPE_CHECKING:
    from bubblerob_env.ros.messages.topics import Topics

__all__ = ["RATE_HZ", "RosLink", "run_ros_teleop"]

RATE_HZ = 20.0
"""``cmd_vel`` messages per second (the node's control rate; its watchdog wants a steady flow)."""


class RosLink:
    """A ROS node that publishes ``cmd_vel`` and follows ``/odom``, ``/scan`` and ``/terminated``.

    Args:
        ros: 1 (``rospy``) or 2 (``rclpy``).
        topics: The live node's topic names and namespace (its ``--topics``, ``--namespace``).
        max_linear: m/s of a full forward command; max_angular: rad/s of a full turn command.

    Raises:
        BackendError: No client library, or (ROS 1) no master: the message says what to do.
    """

    def __init__(self, ros: int, topics: Topics, max_linear: float, max_angular: float) -> None:
        from bubblerob_env.ros.live.connect import load_backend
        from bubblerob_env.ros.live.navigation import GOAL_REACHED
        from bubblerob_env.ros.messages.distros import deserialize, serialize, typestore
        from bubblerob_env.ros.messages.topics import MSGTYPES, namespace_prefix

        names = topics.resolved()
        self.topic = names["cmd_vel"]
        self.odom_topic = names["odom"]
        self.backend = load_backend(
            ros, node_name="bubblerob_teleop", namespace=topics.namespace, anonymous=True
        )
        self.distro = self.backend.distro
        self.max_linear, self.max_angular = max_linear, max_angular
        self._types = typestore(self.distro).types
        self._serialize, self._deserialize = serialize, deserialize
        self._twist_type = MSGTYPES["cmd_vel"]
        self._publish = self.backend.advertise(self.topic, self._twist_type)
        self._lock = threading.Lock()
        self.pose: tuple[float, float, float] | None = None
        """Latest ``/odom`` pose (x, y, yaw), ``None`` before the first."""
        self.speed = math.nan
        self.nearest = math.nan
        self.collisions = 0
        self.goal: tuple[float, float] | None = None
        """A Nav env's latest goal (x, y) in ``map``; ``None`` before one (or for other envs)."""
        self.reached = False
        nav = topics.for_nav().resolved()  # the node's names for a Nav env
        self.backend.subscribe(nav["goal"], MSGTYPES["goal"], self._on_goal)
        reached = namespace_prefix(topics.namespace) + GOAL_REACHED
        self.backend.subscribe(reached, "std_msgs/msg/Bool", self._on_reached)
        self.backend.subscribe(names["odom"], MSGTYPES["odom"], self._on_odom)
        self.backend.subscribe(names["scan"], MSGTYPES["scan"], self._on_scan)
        self.backend.subscribe(names["terminated"], MSGTYPES["terminated"], self._on_terminated)

    def _decode(self, raw: bytes, msgtype: str) -> Any:
        return self._deserialize(self.distro, raw, msgtype)

    def _on_odom(self, raw: bytes, _msgtype: str | None, _sender: str) -> None:
        msg = self._decode(raw, "nav_msgs/msg/Odometry")
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
        with self._lock:
            self.pose = (float(p.x), float(p.y), yaw)
            self.speed = float(msg.twist.twist.linear.x)

    def _on_scan(self, raw: bytes, _msgtype: str | None, _sender: str) -> None:
        ranges = np.asarray(self._decode(raw, "sensor_msgs/msg/LaserScan").ranges)
        finite = ranges[np.isfinite(ranges)]  # REP 117: +inf is no return
        with self._lock:
            self.nearest = float(finite.min()) if finite.size else math.inf

    def _on_goal(self, raw: bytes, _msgtype: str | None, _sender: str) -> None:
        position = self._decode(raw, "geometry_msgs/msg/PoseStamped").pose.position
        with self._lock:
            self.goal = (float(position.x), float(position.y))

    def _on_reached(self, raw: bytes, _msgtype: str | None, _sender: str) -> None:
        reached = bool(self._decode(raw, "std_msgs/msg/Bool").data)
        with self._lock:
            self.reached = reached

    def _on_terminated(self, raw: bytes, _msgtype: str | None, _sender: str) -> None:
        if self._decode(raw, "std_msgs/msg/Bool").data:
            with self._lock:
                self.collisions += 1

    def send(self, state: TeleopState) -> None:
        """Publish the twist ``state`` commands, in m/s and rad/s."""
        t = self._types
        vector = t["geometry_msgs/msg/Vector3"]
        twist = t[self._twist_type](
            linear=vector(x=state.linear * self.max_linear, y=0.0, z=0.0),
            angular=vector(x=0.0, y=0.0, z=state.angular * self.max_angular),
        )
        self._publish(self._serialize(self.distro, twist, self._twist_type))

    def status(self, state: TeleopState) -> tuple[str, str]:
        """The two status lines: command, speed, nearest, collisions; pose."""
        with self._lock:
            pose, speed, nearest, collisions = self.pose, self.speed, self.nearest, self.collisions
            goal, reached = self.goal, self.reached
        first = status_line(state, speed, nearest, collisions)
        if pose is None:
            return first, f"waiting for {self.odom_topic} from the node"
        second = f"pose x={pose[0]:+.2f} y={pose[1]:+.2f} yaw={pose[2]:+.2f} (odom)"
        if goal is not None:  # a Nav env's goal, seen from the odometry's pose
            dx, dy = goal[0] - pose[0], goal[1] - pose[1]
            bearing = math.remainder(math.atan2(dy, dx) - pose[2], math.tau)
            second += " | " + goal_text(math.hypot(dx, dy), bearing)
            second += " (reached)" if reached else ""
        return first, second

    def close(self) -> None:
        """Stop the robot (a zero twist), then shut the node down."""
        try:
            self.send(TeleopState())
            time.sleep(0.1)  # let the stop leave before the connection closes
        finally:
            self.backend.shutdown("teleop done")


def run_ros_teleop(screen: Any, link: RosLink, max_seconds: float | None = None) -> None:
    """Publish ``screen``'s keys as ``cmd_vel`` through ``link`` at :data:`RATE_HZ` until q."""
    start_screen(screen)
    state = TeleopState()
    clock = Clock(1.0 / RATE_HZ, max_seconds)
    while not state.quit and link.backend.ok():
        state.read_keys(screen)
        if state.quit:
            break
        link.send(state)
        first, second = link.status(state)
        width = max(screen.getmaxyx()[1] - 1, 1)
        screen.erase()
        title = f"BubbleRob teleop over ROS {link.backend.ros_version} ({link.topic}): "
        screen.addstr(0, 0, (title + "arrows/WASD drive, space stops, q quits")[:width])
        screen.addstr(1, 0, first[:width])
        screen.addstr(2, 0, second[:width])
        screen.refresh()
        if not clock.wait():
            break
