"""Recognised objects -> ``vision_msgs/Detection2DArray`` (``/detections``): which field holds what.

One ``Detection2D`` per object the recogniser (:mod:`bubblerob_env.vision`) finds in a camera
image, in its order (largest first); the array's and every detection's header is the image's
(stamp, frame ``camera_optical_frame``, ROS 1 sequence number):

- ``bbox``: the object's pixels' box, in pixels as ``sensor_msgs/Image`` counts them (x right from
  the left column, y down from the top row, pixel centres at whole numbers): ``center`` the box's
  middle, ``size_x``/``size_y`` its width and height (an inclusive box ``u_min..u_max`` is
  ``u_max - u_min + 1`` wide), ``theta`` 0 (boxes are upright).
- ``results``: one hypothesis, ``class_id`` the class (``"cylinder"``, ``"box"`` or ``"wall"``),
  ``score`` 1 (the classical recogniser has no confidence), ``pose`` the object's estimated
  position in the optical frame (z forward, x right): the point of its axis (a wall's: its
  nearest point) at the camera's height, from the estimated bearing and horizontal distance;
  orientation identity, covariance zeros (not estimated).
- ``id``: empty (the recogniser does not track objects).

The message's fields are built here once, from numbers or
:class:`~bubblerob_env.ros.messages.values.Slot` placeholders, so that
:mod:`~bubblerob_env.ros.fastpath.detections` compiles its packers from the same code.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from bubblerob_env.ros.messages.values import Slot

__all__ = [
    "DETECTION_NUMBERS",
    "Recognised",
    "detection_array",
    "detection_numbers",
    "detection_slots",
]

DETECTION_NUMBERS = ("cx", "cy", "size_x", "size_y", "x", "z")
"""The numbers of one detection, in packing order: box centre and size (pixels), position (m)."""


class Recognised(Protocol):
    """What a detection needs of a recognised object (the recogniser's ``Detection`` has it)."""

    @property
    def kind(self) -> str:
        """``"cylinder"``, ``"box"`` or ``"wall"``."""

    @property
    def box(self) -> tuple[int, int, int, int]:
        """``(u_min, v_min, u_max, v_max)``, inclusive pixel indices."""

    @property
    def bearing(self) -> float:
        """Radians from the optical axis, positive to the left."""

    @property
    def distance(self) -> float:
        """Horizontal metres from the camera."""


def detection_numbers(found: Recognised) -> tuple[float, ...]:
    """The :data:`DETECTION_NUMBERS` of one recognised object."""
    u_min, v_min, u_max, v_max = found.box
    # Bearing is positive to the left (REP 103); the optical frame's x points right.
    return (
        (u_min + u_max) / 2.0,
        (v_min + v_max) / 2.0,
        float(u_max - u_min + 1),
        float(v_max - v_min + 1),
        -found.distance * math.sin(found.bearing),
        found.distance * math.cos(found.bearing),
    )


def detection_slots(count: int) -> list[dict[str, Slot]]:
    """Placeholders for ``count`` detections' numbers: slot ``d<i>_<name>``."""
    return [{name: Slot(f"d{i}_{name}") for name in DETECTION_NUMBERS} for i in range(count)]


def detection_array(
    types: Mapping[str, Any],
    header: Any,
    classes: Sequence[str],
    numbers: Sequence[Mapping[str, Any]],
) -> Any:
    """The ``Detection2DArray`` of detections of ``classes`` with ``numbers`` (values or slots).

    ``types`` is a ``rosbags`` type store's classes; ``header`` the image's header.
    """
    t = types
    detections = []
    for class_id, n in zip(classes, numbers, strict=True):
        centre = t["vision_msgs/msg/Pose2D"](
            position=t["vision_msgs/msg/Point2D"](x=n["cx"], y=n["cy"]), theta=0.0
        )
        position = t["geometry_msgs/msg/Point"](x=n["x"], y=0.0, z=n["z"])
        orientation = t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        pose = t["geometry_msgs/msg/PoseWithCovariance"](
            pose=t["geometry_msgs/msg/Pose"](position=position, orientation=orientation),
            covariance=np.zeros(36),
        )
        hypothesis = t["vision_msgs/msg/ObjectHypothesis"](class_id=class_id, score=1.0)
        detections.append(
            t["vision_msgs/msg/Detection2D"](
                header=header,
                results=[
                    t["vision_msgs/msg/ObjectHypothesisWithPose"](hypothesis=hypothesis, pose=pose)
                ],
                bbox=t["vision_msgs/msg/BoundingBox2D"](
                    center=centre, size_x=n["size_x"], size_y=n["size_y"]
                ),
                id="",
            )
        )
    return t["vision_msgs/msg/Detection2DArray"](header=header, detections=detections)
