"""The node's inputs: wheel commands with a watchdog, sensor switches and simulation control.

ROS callbacks run on the middleware's threads; they decode and validate each message here and
put it into :class:`ControlState` under a lock. The simulation loop reads the wheel command with
:meth:`ControlState.action` and takes simulation-control events with :meth:`ControlState.drain`,
in the order they arrived. Malformed or wrongly typed messages are dropped with a warning.
"""

from __future__ import annotations

import math
import struct
import threading
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from bubblerob_env.kinematics import DiffDrive
from bubblerob_env.ros.messages.distros import deserialize
from bubblerob_env.ros.messages.topics import namespace_prefix

__all__ = [
    "CONTROL_PRESETS",
    "CONTROL_TYPES",
    "ControlError",
    "ControlState",
    "ControlTopics",
    "decode_control",
]

CONTROL_TYPES = {
    "twist": "geometry_msgs/msg/Twist",
    "float32": "std_msgs/msg/Float32",
    "bool": "std_msgs/msg/Bool",
}
"""Message type of each kind of control input."""
_ROS1_LAYOUT = {"twist": struct.Struct("<6d"), "float32": struct.Struct("<f"), "bool": None}


class ControlError(ValueError):
    """A control message that cannot be used (the message says why)."""


@dataclass(frozen=True)
class ControlTopics:
    """Names of the node's control topics (relative ones go under the node's namespace).

    The wheel commands come from :class:`~bubblerob_env.ros.messages.topics.Topics` (``cmd_vel``,
    ``left_motor_speed``, ``right_motor_speed``); the rest are the tutorials' switches and the
    CoppeliaSim helper's simulation-control topics.
    """

    laser_switch: str = "laser_switch"
    camera_switch: str = "camera_switch"
    start: str = "startSimulation"
    pause: str = "pauseSimulation"
    stop: str = "stopSimulation"
    enable_sync: str = "enableSyncMode"
    trigger: str = "triggerNextStep"
    step_done: str = "simulationStepDone"
    state: str = "simulationState"

    def resolved(self, namespace: str = "") -> dict[str, str]:
        """Full name of every control topic, namespace applied."""
        prefix = namespace_prefix(namespace)
        return {key: prefix + "/" + name.strip("/") for key, name in self.__dict__.items()}


CONTROL_PRESETS = {
    "default": ControlTopics(),
    # The third tutorial's Pioneer (../shared/SEEDS.md, seed 002): its switches under /vrep/.
    "vrep": ControlTopics(laser_switch="vrep/laser_switch", camera_switch="vrep/camera_switch"),
}
"""The control topics that go with each topic preset of
:data:`~bubblerob_env.ros.messages.topics.PRESETS` (``bubblerob node --topics``)."""


def decode_control(kind: str, raw: bytes, encoding: str) -> Any:
    """Decode a ``twist`` (-> ``(v, w)``), ``float32`` or ``bool`` control message.

    Raises:
        ControlError: Wrong size for the type, or a NaN/infinite number.
    """
    if encoding == "ros1":
        layout = _ROS1_LAYOUT[kind]
        size = 1 if layout is None else layout.size
        if len(raw) != size:
            raise ControlError(f"{len(raw)} bytes where a {CONTROL_TYPES[kind]} has {size}")
        if layout is None:
            if raw[0] not in (0, 1):
                raise ControlError(f"bool byte {raw[0]} is neither 0 nor 1")
            return bool(raw[0])
        values = layout.unpack(raw)
    else:
        try:
            msg: Any = deserialize("jazzy", raw, CONTROL_TYPES[kind])
        except Exception as error:  # noqa: BLE001 - whatever a malformed buffer raises
            raise ControlError(f"undecodable {CONTROL_TYPES[kind]} ({error})") from None
        if kind == "bool":
            return bool(msg.data)
        if kind == "float32":
            values = (msg.data,)
        else:
            lin, ang = msg.linear, msg.angular
            values = (lin.x, lin.y, lin.z, ang.x, ang.y, ang.z)
    if not all(math.isfinite(v) for v in values):
        raise ControlError(f"non-finite value in {list(values)}")
    if kind == "float32":
        return float(values[0])
    return float(values[0]), float(values[5])


class ControlState:
    """Thread-safe state of the node's inputs (see the module docstring).

    Wheel targets are in rad/s; the last command received wins: ``cmd_vel`` sets both wheels by
    differential-drive inverse kinematics, ``leftMotorSpeed``/``rightMotorSpeed`` one each. When no
    command has arrived for ``watchdog`` seconds of *simulated* time, both targets drop to 0 (the
    same in real time at rate 1; deterministic in sync mode); ``watchdog=0`` disables it.
    """

    def __init__(self, drive: DiffDrive, watchdog: float = 0.5) -> None:
        self.drive = drive
        self.watchdog = watchdog
        self._lock = threading.Condition()
        self._wheels = np.zeros(2)
        self._last_command = -math.inf
        self._sim_time = 0.0
        self._events: deque[tuple[str, bool]] = deque()
        self.laser_on = True
        self.camera_on = True
        self.watchdog_trips = 0
        self.rejected = 0
        self._warned: dict[tuple[str, str], float] = {}

    # -- from callbacks -------------------------------------------------------------------------

    def command_twist(self, linear: float, angular: float) -> None:
        """``cmd_vel``: body twist (m/s, rad/s) -> both wheel targets."""
        speeds = self.drive.wheel_speeds(linear, angular)
        with self._lock:
            self._wheels[:] = speeds
            self._last_command = self._sim_time

    def command_wheel(self, side: int, speed: float) -> None:
        """``leftMotorSpeed`` (``side=0``) or ``rightMotorSpeed`` (1): one wheel target, rad/s."""
        with self._lock:
            self._wheels[side] = speed
            self._last_command = self._sim_time

    def push(self, event: str, value: bool) -> None:
        """Queue a simulation-control event and wake the loop.

        Events: ``start``, ``pause``, ``stop``, ``enable_sync``, ``trigger``.
        """
        with self._lock:
            self._events.append((event, value))
            self._lock.notify_all()

    def set_switch(self, sensor: str, on: bool) -> None:
        """``laser_switch``/``camera_switch``."""
        with self._lock:
            setattr(self, f"{sensor}_on", on)

    def should_warn(self, topic: str, reason: str, every: float = 2.0) -> bool:
        """Rate limit for warnings about rejected messages (one per topic and reason per 2 s)."""
        with self._lock:
            self.rejected += 1
            now = time.monotonic()
            if now - self._warned.get((topic, reason), -math.inf) < every:
                return False
            self._warned[(topic, reason)] = now
            return True

    # -- from the simulation loop ---------------------------------------------------------------

    def action(self, sim_time: float) -> NDArray[np.float32]:
        """Wheels action (fractions of ``max_wheel_speed``) for a step starting at ``sim_time``."""
        with self._lock:
            self._sim_time = sim_time
            if self.watchdog > 0 and sim_time - self._last_command > self.watchdog + 1e-9:
                if np.any(self._wheels):
                    self.watchdog_trips += 1
                self._wheels[:] = 0.0
            return (self._wheels / self.drive.max_wheel_speed).astype(np.float32)

    def set_time(self, sim_time: float) -> None:
        """Current simulated time, which commands received from now on are stamped with."""
        with self._lock:
            self._sim_time = sim_time

    def stop_wheels(self) -> None:
        """Forget the wheel targets (on ``stopSimulation``)."""
        with self._lock:
            self._wheels[:] = 0.0
            self._last_command = -math.inf

    def drain(self) -> list[tuple[str, bool]]:
        """Every queued simulation-control event, oldest first."""
        with self._lock:
            events = list(self._events)
            self._events.clear()
            return events

    def wait(self, timeout: float) -> None:
        """Sleep up to ``timeout`` seconds, waking early when an event arrives."""
        with self._lock:
            if not self._events and timeout > 0:
                self._lock.wait(timeout)
