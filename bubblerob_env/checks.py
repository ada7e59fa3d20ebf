"""Argument checks for ``BubbleRobEnv``: a bad value gets one line naming it and what is allowed."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from bubblerob_env.arena import ROBOT_RADIUS

__all__ = [
    "MAX_IMAGE_SIZE",
    "MAX_OBSTACLES",
    "MAX_PHYSICS_TIMESTEP",
    "check_choice",
    "check_env_arguments",
    "check_finite",
    "check_image_size",
    "check_int_range",
    "check_positive",
    "check_range_pair",
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
    return isinstance(value, (int, float)) and not isinstance(value, bool)


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


def check_env_arguments(
    args: Mapping[str, Any],
    action_types: Sequence[str],
    radiation_types: Sequence[str],
    render_modes: Sequence[str],
) -> None:
    """Every ``BubbleRobEnv`` keyword argument, by name: the first bad one raises ``ValueError``.

    The sensor specs (``LaserSpec``, ``ProximitySpec``, ``CameraSpec``) check their own fields
    when the env builds them; ``start_pose`` is checked by :func:`check_start_pose`.
    """
    check_choice("action_type", args["action_type"], action_types)
    check_choice("proximity_radiation_type", args["proximity_radiation_type"], radiation_types)
    check_choice("render_mode", args["render_mode"], (None, *render_modes))
    control_timestep = check_positive("control_timestep", args["control_timestep"])
    substeps = check_int_range("physics_substeps", args["physics_substeps"], 1)
    if control_timestep / substeps > MAX_PHYSICS_TIMESTEP:
        raise ValueError(
            f"control_timestep / physics_substeps = {control_timestep} / {substeps} "
            f"s is a physics step MuJoCo cannot integrate reliably here; it must be <= "
            f"{MAX_PHYSICS_TIMESTEP} s: use physics_substeps >= "
            f"{math.ceil(control_timestep / MAX_PHYSICS_TIMESTEP - 1e-9)}"
        )
    check_range_pair("num_obstacles", args["num_obstacles"], 0, MAX_OBSTACLES, ints=True)
    check_range_pair("obstacle_size", args["obstacle_size"], 1e-3, math.inf, ints=False)
    check_int_range("laser_num_rays", args["laser_num_rays"], 0)
    for label in ("max_wheel_speed", "arena_size"):
        check_positive(label, args[label])
    for label in (
        "forward_reward_weight",
        "spin_cost_weight",
        "clearance_cost_weight",
        "collision_penalty",
        "start_clearance",
    ):
        check_finite(label, args[label])
    for label in ("render_width", "render_height"):
        check_image_size(label, args[label])
    for label in ("camera_width", "camera_height"):
        if args[label] is not None:
            check_image_size(label, args[label])
    if not check_finite("clearance_distance", args["clearance_distance"]) > ROBOT_RADIUS:
        raise ValueError(
            f"clearance_distance must be > the robot radius {ROBOT_RADIUS} m, "
            f"got {args['clearance_distance']!r}"
        )
