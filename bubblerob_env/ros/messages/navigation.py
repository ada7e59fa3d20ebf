"""A Nav env's goal (``geometry_msgs/PoseStamped``) and planned path (``nav_msgs/Path``).

Both are in ``map``: the goal is a position only (the task has no goal heading: identity
orientation); the path is the episode's shortest path (:mod:`bubblerob_env.tasks.goals`), one
pose per corner, each facing along its segment (the last as the one before it), as a global
planner's ``/plan``. Built by :meth:`~bubblerob_env.ros.messages.convert.RosConverter.goal` and
``plan`` for bags and the live node alike.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

__all__ = ["goal_pose", "path_message"]


def _pose(types: Any, x: float, y: float, yaw: float) -> Any:
    return types["geometry_msgs/msg/Pose"](
        position=types["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0),
        orientation=types["geometry_msgs/msg/Quaternion"](
            x=0.0, y=0.0, z=math.sin(yaw / 2.0), w=math.cos(yaw / 2.0)
        ),
    )


def goal_pose(types: Any, header: Any, goal: tuple[float, float]) -> Any:
    """The goal ``(x, y)`` as a ``PoseStamped`` with ``header`` (identity orientation)."""
    return types["geometry_msgs/msg/PoseStamped"](
        header=header, pose=_pose(types, goal[0], goal[1], 0.0)
    )


def path_message(types: Any, header: Callable[[], Any], points: Sequence[Sequence[float]]) -> Any:
    """The polyline ``points`` (x, y) as a ``nav_msgs/Path``; ``header()`` gives each header."""
    poses = []
    for i, (x, y) in enumerate(points):
        last = i + 1 == len(points)  # the last faces as the segment before it (none: 0)
        a, b = (points[max(i - 1, 0)], points[i]) if last else (points[i], points[i + 1])
        yaw = math.atan2(float(b[1]) - float(a[1]), float(b[0]) - float(a[0]))
        poses.append(
            types["geometry_msgs/msg/PoseStamped"](header=header(), pose=_pose(types, x, y, yaw))
        )
    return types["nav_msgs/msg/Path"](header=header(), poses=poses)
