"""Topic names and message types of a recording, with presets.

Every topic has a stable *key* (``"scan"``, ``"cmd_vel"``, ...) that the rest of the ROS layer uses;
:class:`Topics` maps keys to names. A name of ``None`` leaves that topic out of a recording. A
namespace prefixes every relative-looking name except the global ones (``/tf``, ``/tf_static``,
``/clock``), as ``ROS_NAMESPACE`` does for a ROS node.
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Mapping
from dataclasses import dataclass

__all__ = [
    "ADDED_TOPICS",
    "GLOBAL_TOPICS",
    "LATCHED_TOPICS",
    "MSGTYPES",
    "NAV_TOPICS",
    "PRESETS",
    "Topics",
    "check_ros_name",
    "namespace_prefix",
    "topics_preset",
]

MSGTYPES: dict[str, str] = {
    "scan": "sensor_msgs/msg/LaserScan",
    "proximity": "sensor_msgs/msg/Range",
    "sensor_trigger": "std_msgs/msg/Bool",
    "image": "sensor_msgs/msg/Image",
    "camera_info": "sensor_msgs/msg/CameraInfo",
    "cmd_vel": "geometry_msgs/msg/Twist",
    "left_motor_speed": "std_msgs/msg/Float32",
    "right_motor_speed": "std_msgs/msg/Float32",
    "odom": "nav_msgs/msg/Odometry",
    "tf": "tf2_msgs/msg/TFMessage",
    "tf_static": "tf2_msgs/msg/TFMessage",
    "clock": "rosgraph_msgs/msg/Clock",
    "simulation_time": "std_msgs/msg/Float32",
    "reward": "std_msgs/msg/Float64",
    "terminated": "std_msgs/msg/Bool",
    "truncated": "std_msgs/msg/Bool",
    "action": "std_msgs/msg/Float64MultiArray",
    "episode": "std_msgs/msg/String",
    "map": "nav_msgs/msg/OccupancyGrid",
    "base_pose_ground_truth": "nav_msgs/msg/Odometry",
    "detections": "vision_msgs/msg/Detection2DArray",
    "goal": "geometry_msgs/msg/PoseStamped",
    "plan": "nav_msgs/msg/Path",
}
"""Message type of each topic key (ROS 2 style names, as ``rosbags`` spells them)."""

LATCHED_TOPICS = ("tf_static", "episode", "map", "goal", "plan")
"""Keys written latched (ROS 1) / transient-local (ROS 2): a late subscriber still gets them."""

ADDED_TOPICS = ("detections",)
"""Keys added after the first recordings: absent from their metadata, so not in their bags."""

NAV_TOPICS = {"goal": "/move_base/current_goal", "plan": "/plan"}
"""Keys of a Nav env's (``BubbleRobNav-v0``) goal and planned path, with their default names
(move_base's ``current_goal``; Nav2's planner's ``/plan``). Left out (``None``) in
:class:`Topics` by default and in the metadata of bags without them, so that other envs' bags
stay as they were; :meth:`Topics.for_nav` turns them on."""

GLOBAL_TOPICS = ("tf", "tf_static", "clock")
"""Keys whose names a namespace does not change (tf and the clock are shared by all robots)."""


_TOKEN = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


def check_ros_name(label: str, name: object) -> str:
    """A topic name or namespace that both ROS 1 and ROS 2 accept; ``ValueError`` otherwise.

    The rules both share (ROS 1 graph resource names, ROS 2 topic names): tokens of letters,
    digits and underscores that start with a letter, separated by single slashes (one leading slash
    allowed, none trailing), and no repeated underscores (ROS 2). Substitutions (``{node}``) and
    private names (``~``) are not names a recorder can write.
    """
    text = name if isinstance(name, str) else ""
    tokens = text[1:].split("/") if text.startswith("/") else text.split("/")
    ok = bool(text) and all(_TOKEN.fullmatch(t) and "__" not in t for t in tokens)
    if not ok:
        raise ValueError(
            f"{label} {name!r} is not a valid ROS name: use letters, digits and '_' in "
            "'/'-separated parts that each start with a letter (e.g. 'robot_2/scan'), with no "
            "'//', '__' or trailing '/'"
        )
    return text


def namespace_prefix(namespace: str) -> str:
    """What goes before a relative name: ``"/robot2"`` for namespace ``robot2``, ``""`` for none.

    The one place that applies a namespace (topics, tf frames, control topics, backends).
    """
    name = namespace.strip("/")
    return "/" + name if name else ""


@dataclass(frozen=True)
class Topics:
    """Topic name of each key; ``None`` leaves the topic out.

    The defaults are REP-style names plus the tutorial's BubbleRob topics
    (``/sensorTrigger``, ``/leftMotorSpeed``, ``/rightMotorSpeed``, ``/simulationTime``).
    Camera topics are written only when the env has its camera on. ``/map`` is the episode's
    ground-truth ``nav_msgs/OccupancyGrid``, once per episode (latched). With the env's
    ``odometry_noise`` > 0, ``/odom`` drifts and ``/base_pose_ground_truth`` has the true pose
    (``nav_msgs/Odometry`` in ``map``, as Stage's ROS driver names it); without, ``/odom`` is the
    truth and that topic is not written. ``/detections`` (``vision_msgs/Detection2DArray``) has
    what the recogniser (:mod:`bubblerob_env.vision`) finds in each camera image, stamped with the
    image's stamp and frame; ``None`` turns the recogniser off. ``goal`` and ``plan``
    (:data:`NAV_TOPICS`) are a Nav env's goal (``geometry_msgs/PoseStamped``) and shortest path
    (``nav_msgs/Path``) in ``map``, latched, at every reset and every new goal.
    """

    scan: str | None = "/scan"
    proximity: str | None = "/proximity"
    sensor_trigger: str | None = "/sensorTrigger"
    image: str | None = "/camera/image_raw"
    camera_info: str | None = "/camera/camera_info"
    cmd_vel: str | None = "/cmd_vel"
    left_motor_speed: str | None = "/leftMotorSpeed"
    right_motor_speed: str | None = "/rightMotorSpeed"
    odom: str | None = "/odom"
    tf: str | None = "/tf"
    tf_static: str | None = "/tf_static"
    clock: str | None = "/clock"
    simulation_time: str | None = "/simulationTime"
    reward: str | None = "/reward"
    terminated: str | None = "/terminated"
    truncated: str | None = "/truncated"
    action: str | None = "/bubblerob/action"
    episode: str | None = "/bubblerob/episode"
    map: str | None = "/map"
    base_pose_ground_truth: str | None = "/base_pose_ground_truth"
    detections: str | None = "/detections"
    goal: str | None = None
    plan: str | None = None
    namespace: str = ""

    def __post_init__(self) -> None:
        for key in MSGTYPES:
            name = getattr(self, key)
            if name is not None and (not isinstance(name, str) or not name.strip("/")):
                raise ValueError(f"topic {key!r} needs a non-empty name or None, got {name!r}")
            if name is not None:
                check_ros_name(f"topic {key!r}:", name)
        if self.namespace and not self.namespace.strip("/"):
            raise ValueError(f"namespace must name something, got {self.namespace!r}")
        if self.namespace:  # "/robot2/" as "robot2" (namespace_prefix strips the slashes)
            check_ros_name("namespace", self.namespace.strip("/"))
        if self.action is None or self.episode is None:
            raise ValueError(
                "the 'action' and 'episode' topics cannot be left out: replay needs them"
            )
        names = [n for n in self.resolved().values()]
        duplicated = sorted({n for n in names if names.count(n) > 1})
        if duplicated:
            raise ValueError(f"topic names must be distinct, repeated: {duplicated}")

    @property
    def frame_prefix(self) -> str:
        """Prefix of this robot's tf frame ids: ``"robot2/"`` under namespace ``robot2``.

        Empty without a namespace. ``/tf`` is shared by every robot in a graph, so namespaced
        robots need frames of their own.
        """
        prefix = namespace_prefix(self.namespace)
        return prefix[1:] + "/" if prefix else ""

    def resolved(self) -> dict[str, str]:
        """Full name of every recorded key, namespace applied, in :data:`MSGTYPES` order."""
        prefix = namespace_prefix(self.namespace)
        names = {}
        for key in MSGTYPES:
            name = getattr(self, key)
            if name is None:
                continue
            name = "/" + name.strip("/")
            names[key] = name if key in GLOBAL_TOPICS else prefix + name
        return names

    def to_dict(self) -> dict[str, str | None]:
        """Plain dict (for episode metadata); :meth:`from_dict` rebuilds it.

        The Nav keys are left out where ``None``: the metadata of other envs' bags stays as it was.
        """
        names = dataclasses.asdict(self)
        return {k: v for k, v in names.items() if not (k in NAV_TOPICS and v is None)}

    def for_nav(self) -> Topics:
        """These topics with a Nav env's goal and plan (:data:`NAV_TOPICS`) where not named."""
        unnamed = {k: name for k, name in NAV_TOPICS.items() if getattr(self, k) is None}
        return self.replace(**unnamed) if unnamed else self

    @classmethod
    def from_dict(cls, names: Mapping[str, str | None]) -> Topics:
        """The topics of a :meth:`to_dict` dict, as recorded in an episode's metadata.

        Keys that recordings made before a topic existed lack are that topic left out (``None``),
        so that such a bag is read as what it holds.
        """
        absent = {key: None for key in ADDED_TOPICS if key not in names}
        return cls(**{**names, **absent})  # type: ignore[arg-type]

    def replace(self, **changes: str | None) -> Topics:
        """A copy with some names changed, e.g. ``replace(image=None)``."""
        return dataclasses.replace(self, **changes)  # type: ignore[arg-type]


PRESETS: dict[str, Topics] = {
    "default": Topics(),
    # The V-REP Pioneer tutorial (tutorial 002): /vrep/... sensor and command topics, /simTime.
    "vrep": Topics(
        scan="/vrep/scan",
        image="/vrep/image",
        camera_info="/vrep/camera_info",
        cmd_vel="/vrep/cmd_vel",
        simulation_time="/simTime",
    ),
}
"""Named topic sets: ``default`` and ``vrep`` (the tutorials' Pioneer names)."""


def topics_preset(name: str, namespace: str = "", detections: bool = True) -> Topics:
    """The preset ``name`` (see :data:`PRESETS`), optionally under ``namespace``.

    ``detections=False`` leaves ``/detections`` out (the recogniser does not run).
    """
    try:
        preset = PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown topic preset {name!r}; known: {sorted(PRESETS)}") from None
    if not detections:
        preset = preset.replace(detections=None)
    return dataclasses.replace(preset, namespace=namespace)
