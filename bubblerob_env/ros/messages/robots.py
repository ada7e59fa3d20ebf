"""Topic names and tf frames of robot ``i`` among several in one world (``--robots N``).

Two conventions (:data:`ROBOT_NAMING`):

- ``namespace`` (Stage's, the ROS way): robot ``i``'s topics under ``/robot_i/`` (``/robot_0/scan``,
  ``/robot_0/cmd_vel``) and its frames prefixed ``robot_i/`` (``robot_0/odom``,
  ``robot_0/base_link``) on the shared ``/tf`` and ``/tf_static``.
- ``tutorial`` (the first tutorial's, ``../shared/SEEDS.md`` 000): each robot's topic names carry a
  unique suffix appended to the name, as the tutorial's script appends the system time
  (``'leftMotorSpeed'..sysTime``); here the suffix is the robot's index, so that names are
  reproducible: ``/leftMotorSpeed0``, ``/rightMotorSpeed0``, ``/sensorTrigger0``, ``/simTime0``
  (the tutorial's name for the simulation time), ``/scan0``. Frames are still ``robot_i/...``:
  ``/tf`` is shared and tf2 needs distinct frame ids.

``/clock`` is never a robot's: the node publishes it once for the world. A lone robot is not
renamed at all (the single-robot node's names).
"""

from __future__ import annotations

from bubblerob_env.ros.messages.topics import GLOBAL_TOPICS, MSGTYPES, Topics

__all__ = ["ROBOT_NAMING", "robot_frame_prefix", "robot_name", "robot_topics"]

ROBOT_NAMING = ("namespace", "tutorial")
"""How robot ``i``'s topics are told apart: a namespace, or the tutorial's name suffix."""


def robot_name(index: int) -> str:
    """``robot_<index>``: the robot's namespace and frame prefix (Stage's names)."""
    return f"robot_{index}"


def robot_frame_prefix(index: int) -> str:
    """``robot_<index>/``: what goes before each of the robot's tf frame ids."""
    return robot_name(index) + "/"


def robot_topics(base: Topics, index: int, naming: str = "namespace") -> Topics:
    """Robot ``index``'s topics: ``base``'s names renamed by ``naming``, without ``/clock``.

    Raises:
        ValueError: ``naming`` is not one of :data:`ROBOT_NAMING`, or ``base`` already has a
            namespace (robots get theirs here).
    """
    if naming not in ROBOT_NAMING:
        raise ValueError(f"robot topic naming must be one of {ROBOT_NAMING}, got {naming!r}")
    if base.namespace:
        raise ValueError(
            f"several robots get a namespace each (robot_0, ...): drop namespace {base.namespace!r}"
        )
    if naming == "namespace":
        return base.replace(namespace=robot_name(index), clock=None)
    renamed: dict[str, str | None] = {"clock": None}
    if base.simulation_time is not None:
        renamed["simulation_time"] = "/simTime"  # the tutorial's name (simulationTime: ours)
    for key in MSGTYPES:
        name = renamed.get(key, getattr(base, key))
        if key not in GLOBAL_TOPICS and name is not None:
            renamed[key] = f"{name}{index}"
    return base.replace(**renamed)
