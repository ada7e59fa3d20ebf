"""Argument checks for ``BubbleRobEnv``: a bad value gets one line naming it and what is allowed."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bubblerob_env import names
from bubblerob_env.robots import BUBBLEROB, RobotDescription

__all__ = [
    "MAX_ARENA_SIZE",
    "MAX_IMAGE_SIZE",
    "MAX_LASER_RAYS",
    "MAX_OBSTACLES",
    "MAX_PHYSICS_SUBSTEPS",
    "MAX_PHYSICS_TIMESTEP",
    "MAX_SENSOR_RANGE",
    "MAX_SPEED",
    "MAX_WEIGHT",
    "check_bool",
    "check_bounded",
    "check_choice",
    "check_env_arguments",
    "check_finite",
    "check_image_size",
    "check_int_range",
    "check_positive",
    "check_range_pair",
    "check_scene",
    "check_start_pose",
    "unexpected_kwargs_error",
]

MAX_PHYSICS_TIMESTEP = 0.05
"""Longest physics step (``control_timestep / physics_substeps``, seconds) the env accepts. Beyond
it the robot moves more than 2 cm per step at full speed, contacts come late and deep, and a large
enough step makes MuJoCo diverge (``control_timestep=10`` does)."""
MAX_OBSTACLES = 256
"""Most obstacles per episode: each is a pre-built slot, and 100,000 slots take minutes to build."""
MAX_IMAGE_SIZE = 4096
"""Largest camera or render image side in pixels; the offscreen framebuffer is sized to fit."""
MAX_PHYSICS_SUBSTEPS = 10_000
"""Most MuJoCo steps per control step: more makes one ``step`` take seconds (a seeming hang)."""
MAX_SPEED = 1e6
"""Largest ``max_wheel_speed`` (rad/s), ``max_linear_speed`` (m/s) and ``max_angular_speed``
(rad/s). The motors' force limit decides long before (the robot drives the same from 100 rad/s
up); beyond it the wheel-speed arithmetic overflows (``max_linear_speed=1e308`` gave NaN)."""
MAX_ARENA_SIZE = 10_000.0
"""Largest ``arena_size`` (m). MuJoCo resets a simulation whose positions pass 1e10 m (1e12
truncated every episode at its first step); an episode (50 s) crosses some 20 m."""
MAX_SENSOR_RANGE = 10_000.0
"""Longest laser or proximity range (m): beyond any real sensor; ranges are float32 (ROS
``LaserScan``, the observation), which keep millimetres up to here (1e300 did not fit at all)."""
MAX_LASER_RAYS = 100_000
"""Most laser rays per scan (real scanners give a few thousand); memory and time grow with it."""
MAX_WEIGHT = 1e6
"""Largest magnitude of a reward weight or the collision penalty: rewards stay finite."""


def unexpected_kwargs_error(owner: str, unknown: Sequence[str], valid: Sequence[str]) -> TypeError:
    """Python's own wording (tools such as torchrl match on it), then the valid names."""
    first, *rest = unknown
    also = f" (and {', '.join(repr(name) for name in rest)})" if rest else ""
    return TypeError(
        f"{owner}() got an unexpected keyword argument {first!r}{also}; "
        f"valid keyword arguments are: {', '.join(valid)}"
    )


def check_choice(label: str, value: object, allowed: Sequence[object]) -> None:
    """``value`` is one of ``allowed``."""
    if value not in allowed:
        raise ValueError(f"{label} must be one of {list(allowed)}, got {value!r}")


def _is_number(value: object) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
        value, (bool, np.bool_)
    )


def check_bool(label: str, value: object) -> bool:
    """A real ``bool`` (or NumPy's): ``camera="no"`` is not false, it is a mistake."""
    if not isinstance(value, (bool, np.bool_)):
        raise ValueError(f"{label} must be True or False, got {value!r}")
    return bool(value)


def check_bounded(label: str, value: object, low: float, high: float, unit: str = "") -> float:
    """A finite number (not a bool) with ``low <= value <= high``."""
    if not (_is_number(value) and math.isfinite(value) and low <= value <= high):  # type: ignore[arg-type,operator]
        raise ValueError(
            f"{label} must be a finite number from {low:g} to {high:g}{unit}, got {value!r}"
        )
    return float(value)  # type: ignore[arg-type]


def check_finite(label: str, value: object) -> float:
    """A finite real number."""
    if not (_is_number(value) and math.isfinite(value)):  # type: ignore[arg-type]
        raise ValueError(f"{label} must be a finite number, got {value!r}")
    return float(value)  # type: ignore[arg-type]


def check_positive(label: str, value: object) -> float:
    """A finite number > 0."""
    if not (_is_number(value) and math.isfinite(value) and value > 0):  # type: ignore[arg-type,operator]
        raise ValueError(f"{label} must be a finite number > 0, got {value!r}")
    return float(value)  # type: ignore[arg-type]


def check_int_range(label: str, value: object, low: int, high: int | None = None) -> int:
    """An int (not a bool) in ``[low, high]``."""
    if (
        isinstance(value, int)
        and not isinstance(value, bool)
        and value >= low
        and (high is None or value <= high)
    ):
        return value
    upper = f" and <= {high}" if high is not None else ""
    raise ValueError(f"{label} must be an int >= {low}{upper}, got {value!r}")


def check_image_size(label: str, value: object) -> int:
    """An image side in pixels: an int in ``[1, MAX_IMAGE_SIZE]``."""
    return check_int_range(label, value, 1, MAX_IMAGE_SIZE)


def check_range_pair(label: str, value: Any, low: float, high: float, *, ints: bool) -> tuple:  # type: ignore[type-arg]
    """``(min, max)`` with ``low <= min <= max <= high``, both finite (and ints if ``ints``)."""
    try:
        first, second = value
    except (TypeError, ValueError):
        first = second = None
    kind = int if ints else (int, float)
    ok = all(
        isinstance(v, kind) and not isinstance(v, bool) and math.isfinite(v)
        for v in (first, second)
    )
    if not (ok and low <= first <= second <= high):
        raise ValueError(
            f"{label} must be (min, max) {'ints' if ints else 'numbers'} with "
            f"{low} <= min <= max <= {high}, got {value!r}"
        )
    return (int(first), int(second)) if ints else (float(first), float(second))


def check_start_pose(
    value: Any, arena_size: float, robot_radius: float
) -> tuple[float, float, float]:
    """Finite ``(x, y, yaw)`` with the robot's bounding circle inside the arena's walls."""
    try:
        x, y, yaw = (float(v) for v in value)
    except (TypeError, ValueError):
        raise ValueError(f"start_pose must be (x, y, yaw) numbers, got {value!r}") from None
    if not all(math.isfinite(v) for v in (x, y, yaw)):
        raise ValueError(f"start_pose must be finite (x, y, yaw), got {value!r}")
    limit = arena_size / 2.0 - robot_radius
    if abs(x) > limit or abs(y) > limit:
        raise ValueError(
            f"start_pose {value!r} puts the robot (radius {robot_radius} m) outside the arena or "
            f"into its walls: x and y must be in [-{limit:.3f}, {limit:.3f}] m for arena_size "
            f"{arena_size} m"
        )
    return (x, y, yaw)


def check_scene(xml_file: object, robot: RobotDescription = BUBBLEROB) -> None:
    """A scene file that MuJoCo parses and that holds a robot (every name the env uses).

    Only parsed here (no compile), so a scene without the robot is one line, not an
    ``AttributeError`` from deep in the model building.
    """
    import mujoco

    if not isinstance(xml_file, (str, Path)) or not Path(xml_file).is_file():
        raise ValueError(f"xml_file must be the path of an MJCF scene file, got {xml_file!r}")
    try:
        spec = mujoco.MjSpec.from_file(str(xml_file))
    except ValueError as error:
        first = str(error).strip().splitlines()[0] if str(error).strip() else "unreadable"
        raise ValueError(
            f"xml_file {xml_file} is not an MJCF scene MuJoCo reads: {first}"
        ) from None
    lookups = {
        "body": spec.body,
        "joint": spec.joint,
        "actuator": spec.actuator,
        "site": spec.site,
        "camera": spec.camera,
        "sensor": spec.sensor,
        "geom": spec.geom,
    }
    missing = [
        f"{kind} {name!r}"
        for kind, wanted in names.REQUIRED_NAMES.items()
        for name in wanted
        if lookups[kind](name) is None
    ]
    if spec.find_default(names.OBSTACLE_CLASS) is None:
        missing.append(f"default class {names.OBSTACLE_CLASS!r}")
    if missing:
        raise ValueError(
            f"xml_file {xml_file} is not a {robot.title} scene: it lacks "
            f"{', '.join(missing[:6])}{' and more' if len(missing) > 6 else ''} (include "
            f"{robot.robot_file.name} and common.xml from bubblerob_env/assets, as "
            f"assets/{robot.scene_file.name} does)"
        )


def _check_speeds(args: Mapping[str, Any]) -> None:
    for label in ("max_wheel_speed", "max_linear_speed", "max_angular_speed"):
        value = args[label]
        if label != "max_wheel_speed" and value is None:
            continue  # the default: what the wheels can do
        if not (_is_number(value) and math.isfinite(value) and 0 < value <= MAX_SPEED):
            default = "" if label == "max_wheel_speed" else " (or None: the wheels' limit)"
            raise ValueError(
                f"{label} must be a finite number > 0 and <= {MAX_SPEED:g}{default}, got {value!r}"
            )


def _check_sensors(args: Mapping[str, Any]) -> None:
    """Types and ranges; the sensor specs check how the values relate (min < max, fov)."""
    check_int_range("laser_num_rays", args["laser_num_rays"], 0, MAX_LASER_RAYS)
    for label in ("laser_fov", "laser_range_min", "laser_noise_std", "proximity_trigger_distance"):
        check_finite(label, args[label])
    for label in ("laser_range_max", "proximity_range_max"):
        if not check_bounded(label, args[label], 0.0, MAX_SENSOR_RANGE, " m") > 0:
            raise ValueError(f"{label} must be > 0 m, got {args[label]!r}")
    for label in ("camera", "camera_shadows"):
        check_bool(label, args[label])
    for label in ("render_width", "render_height"):
        check_image_size(label, args[label])
    for label in ("camera_width", "camera_height"):
        if args[label] is not None:
            check_image_size(label, args[label])


def _check_arena(args: Mapping[str, Any], robot: RobotDescription) -> None:
    arena_size = check_bounded("arena_size", args["arena_size"], 0.0, MAX_ARENA_SIZE, " m")
    clearance = check_finite("start_clearance", args["start_clearance"])
    radius = robot.radius
    room = arena_size / 2.0 - radius
    if room <= 0:
        raise ValueError(
            f"arena_size must be > {2 * radius:g} m (the robot's diameter), "
            f"got {args['arena_size']!r}"
        )
    if not 0.0 <= clearance < room:
        raise ValueError(
            f"start_clearance must be >= 0 m and leave the robot (radius {radius} m) room "
            f"in the arena: < {max(room, 0.0):.3f} m for arena_size {arena_size:g} m, "
            f"got {args['start_clearance']!r}"
        )
    check_range_pair("num_obstacles", args["num_obstacles"], 0, MAX_OBSTACLES, ints=True)
    check_range_pair("obstacle_size", args["obstacle_size"], 1e-3, math.inf, ints=False)
    if args["xml_file"] is not None:
        check_scene(args["xml_file"], robot)


def check_env_arguments(
    args: Mapping[str, Any],
    action_types: Sequence[str],
    radiation_types: Sequence[str],
    render_modes: Sequence[str],
    robot: RobotDescription = BUBBLEROB,
) -> None:
    """Every ``BubbleRobEnv`` keyword argument, by name: the first bad one raises ``ValueError``.

    ``args`` holds the robot's values where the caller left ``None`` (but ``xml_file``, whose
    ``None`` is the robot's own scene); ``robot`` is the robot they are for.

    The sensor specs (``LaserSpec``, ``ProximitySpec``, ``CameraSpec``) check how their fields
    relate when the env builds them; ``start_pose`` is checked by :func:`check_start_pose`.
    """
    check_choice("action_type", args["action_type"], action_types)
    check_choice("proximity_radiation_type", args["proximity_radiation_type"], radiation_types)
    check_choice("render_mode", args["render_mode"], (None, *render_modes))
    control_timestep = check_positive("control_timestep", args["control_timestep"])
    substeps = check_int_range("physics_substeps", args["physics_substeps"], 1)
    if substeps > MAX_PHYSICS_SUBSTEPS:
        raise ValueError(
            f"physics_substeps must be <= {MAX_PHYSICS_SUBSTEPS} (more makes one step take "
            f"seconds), got {substeps}"
        )
    if control_timestep / substeps > MAX_PHYSICS_TIMESTEP:
        raise ValueError(
            f"control_timestep / physics_substeps = {control_timestep} / {substeps} "
            f"s is a physics step MuJoCo cannot integrate reliably here; it must be <= "
            f"{MAX_PHYSICS_TIMESTEP} s: use physics_substeps >= "
            f"{math.ceil(control_timestep / MAX_PHYSICS_TIMESTEP - 1e-9)}"
        )
    _check_speeds(args)
    _check_sensors(args)
    for label in (
        "forward_reward_weight",
        "spin_cost_weight",
        "clearance_cost_weight",
        "collision_penalty",
    ):
        check_bounded(label, args[label], -MAX_WEIGHT, MAX_WEIGHT)
    check_bool("terminate_on_collision", args["terminate_on_collision"])
    if not check_finite("clearance_distance", args["clearance_distance"]) > robot.radius:
        raise ValueError(
            f"clearance_distance must be > the robot radius {robot.radius} m, "
            f"got {args['clearance_distance']!r}"
        )
    _check_arena(args, robot)
