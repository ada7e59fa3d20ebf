"""Goals for the live node of a Nav env (``bubblerob node --env BubbleRobNav-v0``), as move_base.

:class:`LiveNavigation` takes goals on ``/move_base_simple/goal`` (``geometry_msgs/PoseStamped``,
what rviz's "2D Nav Goal" publishes) in ``map`` or ``odom``; the position counts, the heading
does not (the task has none). The callback only checks and queues a goal; the simulation loop
applies it (:meth:`LiveNavigation.apply`): a goal in ``odom`` is moved into ``map`` by the
node's ``map -> odom`` (the identity, or the localiser's estimate with ``--localize``), the path
is planned from the robot's position (with ``--localize``, its estimate) by
:meth:`~bubblerob_env.tasks.nav.BubbleRobNavEnv.set_goal`, and goal and path go out on the
recorder's latched topics (``/move_base/current_goal``, ``/plan``: the conversion layer's
:data:`~bubblerob_env.ros.messages.topics.NAV_TOPICS`). A goal in another frame, outside the
arena, in an obstacle or out of reach is one warning naming it and what is allowed, and is
ignored. Arrival (the env's success: the robot's centre within ``goal_radius``) is
``/goal_reached`` (``std_msgs/Bool``, latched: True on arrival, False with every new goal, the
drawn goal of each episode included) and a log line.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable
from typing import Any

import numpy as np

from bubblerob_env.ros.live.backend import LiveBackend
from bubblerob_env.ros.live.localizer import LiveLocalizer
from bubblerob_env.ros.live.wrapper import RosLivePublisher
from bubblerob_env.ros.messages.distros import deserialize, serialize, typestore
from bubblerob_env.ros.messages.topics import Topics, namespace_prefix
from bubblerob_env.tasks.nav import BubbleRobNavEnv

__all__ = ["GOAL_INPUT", "GOAL_REACHED", "GOAL_TYPE", "LiveNavigation"]

GOAL_TYPE = "geometry_msgs/msg/PoseStamped"
"""Type of ``/move_base_simple/goal``."""
GOAL_INPUT, GOAL_REACHED = "/move_base_simple/goal", "/goal_reached"
"""The goal's topic in and the arrival's out, under the robot's namespace."""

Warn = Callable[[str, str, str], None]  # (topic, reason, detail)


class LiveNavigation:
    """A Nav env's goal topics for one robot (see the module docstring)."""

    def __init__(
        self, env: BubbleRobNavEnv, publisher: RosLivePublisher, topics: Topics, warn: Warn
    ) -> None:
        """Subscribe ``move_base_simple/goal`` and advertise ``goal_reached`` (namespaced)."""
        self.env = env
        self.publisher = publisher
        backend: LiveBackend = publisher.backend
        self.backend = backend
        prefix = namespace_prefix(topics.namespace)
        self.names = {
            "goal_in": prefix + GOAL_INPUT,
            "reached": prefix + GOAL_REACHED,
        }
        self.frames = {
            name: topics.frame_prefix + name for name in ("map", "odom")
        }  # what a goal may be given in
        self._warn = warn
        self._lock = threading.Lock()
        self._pending: tuple[str, float, float] | None = None
        self.goals = 0
        """Goals taken from the topic so far."""
        distro = backend.distro
        self._reached = {
            v: serialize(
                distro, typestore(distro).types["std_msgs/msg/Bool"](data=v), "std_msgs/msg/Bool"
            )
            for v in (False, True)
        }
        self._reached_out = backend.advertise(self.names["reached"], "std_msgs/msg/Bool", True)
        backend.subscribe(self.names["goal_in"], GOAL_TYPE, self._receive)

    def _receive(self, raw: bytes, msgtype: str | None, sender: str) -> None:
        """A goal (on a middleware thread): checked, then queued for the simulation loop."""
        topic, expected = self.names["goal_in"], GOAL_TYPE.replace("/msg/", "/")
        if msgtype not in (None, "*", expected):
            self._warn(topic, "wrong type", f"{msgtype} from {sender}, expected {expected}")
            return
        try:
            message = deserialize(self.backend.distro, raw, GOAL_TYPE)
            frame = str(message.header.frame_id).lstrip("/")
            x, y = float(message.pose.position.x), float(message.pose.position.y)
        except Exception as error:  # noqa: BLE001 - damaged bytes fail in many ways
            self._warn(topic, "malformed", f"{error!r} (from {sender})")
            return
        if frame not in self.frames.values():
            allowed = " or ".join(repr(f) for f in self.frames.values())
            self._warn(
                topic,
                "wrong-frame",
                f"frame_id {frame!r} (from {sender}): goals are taken in {allowed}",
            )
            return
        with self._lock:
            self._pending = (frame, x, y)

    def apply(self, localizer: LiveLocalizer | None) -> None:
        """Set the latest queued goal, if any, planned from the robot's position.

        With a ``localizer`` (``--localize``) from its estimate, and a goal in ``odom`` moved
        into ``map`` by its ``map -> odom``; without, from the truth (``odom`` is ``map``).
        """
        with self._lock:
            pending, self._pending = self._pending, None
        if pending is None:
            return
        frame, x, y = pending
        pf = None if localizer is None else localizer.filter
        estimate = None if localizer is None else localizer.pose
        pose = None if estimate is None else (estimate[0], estimate[1])
        if frame == self.frames["odom"] and pf is not None:
            tx, ty, yaw = (float(v) for v in pf.map_to_odom())
            c, s = math.cos(yaw), math.sin(yaw)
            x, y = tx + c * x - s * y, ty + s * x + c * y
        try:
            problem = self.env.set_goal((x, y), pose)
        except ValueError as error:
            self._warn(self.names["goal_in"], "bad goal", f"{error} (given in {frame})")
            return
        self.goals += 1
        self.publisher.new_goal(problem)
        self._reached_out(self._reached[False])
        self.backend.log(
            "info",
            f"new goal ({problem.goal[0]:.3f}, {problem.goal[1]:.3f}) in {self.frames['map']}: "
            f"path of {problem.length:.2f} m on {self.publisher.topics.resolved().get('plan')}",
        )

    def new_episode(self) -> None:
        """A reset drew a new goal (published with the episode): not reached yet."""
        self._reached_out(self._reached[False])

    def after_step(self, info: dict[str, Any], sim_time: float) -> None:
        """Report arrival (the env's success) on ``goal_reached`` and in the log."""
        if not info.get("is_success"):
            return
        self._reached_out(self._reached[True])
        goal = np.asarray(info["goal"], dtype=float)
        self.backend.log(
            "info",
            f"goal ({goal[0]:.3f}, {goal[1]:.3f}) reached at {sim_time:.2f} s: "
            f"{float(info['goal_distance']):.3f} m from it, driven "
            f"{float(info['distance_driven']):.2f} m "
            f"(shortest {float(info['shortest_path_length']):.2f} m)",
        )

    def observed(self, obs: Any, pose: tuple[float, float, float]) -> Any:
        """``obs`` with the goal's distance and bearing seen from ``pose`` (the estimate).

        What a policy driving the node (``--policy``) gets with ``--localize``: the goal as the
        robot believes it lies, not as the env's truth has it.
        """
        goal = self.env.goal
        dx, dy = goal[0] - pose[0], goal[1] - pose[1]
        bearing = math.remainder(math.atan2(dy, dx) - pose[2], math.tau)
        seen = np.array([math.hypot(dx, dy), bearing], dtype=np.float32)
        if isinstance(obs, dict):
            return {**obs, "goal": seen}
        flat = np.array(obs, copy=True)
        flat[self.env.observation_layout["goal"]] = seen
        return flat
