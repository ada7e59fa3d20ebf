"""``SimNode``: BubbleRob as a ROS node, with the tutorial's topics and CoppeliaSim's controls.

Every frame goes out through :class:`~bubblerob_env.ros.live.wrapper.RosLivePublisher` (the
conversion layer's topics plus ``/clock``), except the wheel-command topics, which are the node's
inputs (:mod:`~bubblerob_env.ros.live.controls`); the applied action is on ``/bubblerob/action``.
Simulation control follows CoppeliaSim's ROS helper: ``startSimulation``, ``pauseSimulation``,
``stopSimulation``, ``enableSyncMode`` and ``triggerNextStep`` in, ``simulationStepDone`` (after
every step) and ``simulationState`` (latched; 0 stopped, 1 running, 2 paused) out. In sync mode
the simulation advances one control step per ``triggerNextStep`` and never on its own; otherwise
it runs at ``rate_factor`` times real time (0: as fast as possible). When an episode ends
(collision or time limit) the next one starts at once, published like the first.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym

from bubblerob_env.mapping import DEFAULT_RESOLUTION, check_resolution
from bubblerob_env.ros.live.backend import LiveBackend
from bubblerob_env.ros.live.controls import (
    CONTROL_TYPES,
    ControlError,
    ControlState,
    ControlTopics,
    decode_control,
)
from bubblerob_env.ros.live.localizer import LOCALIZE_MODES, LiveLocalizer, LocalizerConfig
from bubblerob_env.ros.live.navigation import LiveNavigation
from bubblerob_env.ros.live.wrapper import RosLivePublisher
from bubblerob_env.ros.messages.distros import deserialize, get_distro, serialize, typestore
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.tasks.nav import BubbleRobNavEnv

__all__ = ["LAUNCH_DIR", "STOPPED", "RUNNING", "PAUSED", "NodeConfig", "SimNode", "shared_clock_ns"]

LAUNCH_DIR = Path(__file__).resolve().parent.parent / "launch"
"""``bubblerob.launch``, ``bubblerob.rviz`` and ``package.xml`` (a ROS 1 package, ``bubblerob``)."""

STOPPED, RUNNING, PAUSED = 0, 1, 2
"""Values of ``simulationState`` (``std_msgs/Int32``), as CoppeliaSim publishes them."""
COMMAND_KEYS = ("cmd_vel", "left_motor_speed", "right_motor_speed")
Driver = Callable[[Any, bool], Any]
"""``driver(obs, episode_start) -> action``: what drives the robot instead of the topics."""


@dataclass(frozen=True)
class NodeConfig:
    """How the node runs.

    Attributes:
        rate_factor: Simulated seconds per wall-clock second in free mode; 0: as fast as possible.
        sync: Start in synchronous mode (step only on ``triggerNextStep``).
        watchdog: Simulated seconds without a wheel command before the wheels stop; 0: never.
        seed: Seed of the first episode; episode ``k`` is reset with ``seed + k`` (as
            ``bubblerob record``); ``None``: unseeded.
        start: Initial state: ``"running"``, ``"paused"`` or ``"stopped"``.
        start_time: Stamp of the first frame and ``/clock`` (Unix seconds or an ISO 8601 date);
            ``None``: the wall clock when the node starts.
        map_resolution: Metres per cell of the latched ``/map`` (0.005 to 1).
        localize: Run the particle filter as AMCL (:mod:`~bubblerob_env.ros.live.localizer`):
            ``"track"`` from each episode's start pose, ``"global"``; ``None``: off.
    """

    rate_factor: float = 1.0
    sync: bool = False
    watchdog: float = 0.5
    seed: int | None = 0
    start: str = "running"
    start_time: float | str | None = None
    map_resolution: float = DEFAULT_RESOLUTION
    localize: str | None = None

    def __post_init__(self) -> None:
        check_resolution(self.map_resolution)
        if self.localize is not None and self.localize not in LOCALIZE_MODES:
            raise ValueError(
                f"--localize must be one of {', '.join(LOCALIZE_MODES)}, got {self.localize!r}"
            )
        if not (math.isfinite(self.rate_factor) and self.rate_factor >= 0):
            raise ValueError(
                f"rate_factor must be >= 0 (0: as fast as possible), got {self.rate_factor}"
            )
        if not (math.isfinite(self.watchdog) and self.watchdog >= 0):
            raise ValueError(f"watchdog must be >= 0 seconds (0: off), got {self.watchdog}")
        if self.start not in ("running", "paused", "stopped"):
            raise ValueError(f"start must be running, paused or stopped, got {self.start!r}")


TWIST_LIMIT = 1e6
"""cmd_vel components are scaled (together, keeping the turn ratio) into +-this before the
wheel speeds are computed: ``1e308 / wheel radius`` would overflow to inf, and inf to a NaN
action. The wheel speeds are then clamped to the motors' maximum as for any command."""


def _bounded_twist(linear: float, angular: float) -> tuple[float, float]:
    peak = max(abs(linear), abs(angular))
    if peak <= TWIST_LIMIT:
        return linear, angular
    scale = TWIST_LIMIT / peak
    return linear * scale, angular * scale


def shared_clock_ns(backend: LiveBackend, topic: str, timeout: float) -> int | None:
    """The first time on ``topic`` (the shared ``/clock``) within ``timeout`` s, or ``None``.

    A ``--no-clock`` robot starts its time there, so that its stamps follow the robot that
    publishes the clock instead of starting at its own wall clock.
    """
    got: list[int] = []
    arrived = threading.Event()

    def receive(raw: bytes, msgtype: str | None, sender: str) -> None:
        if arrived.is_set():
            return
        try:
            clock = deserialize(backend.distro, raw, "rosgraph_msgs/msg/Clock").clock
        except Exception:  # noqa: BLE001 - not a clock: keep waiting
            return
        got.append(int(clock.sec) * 10**9 + int(clock.nanosec))
        arrived.set()

    backend.subscribe(topic, "rosgraph_msgs/msg/Clock", receive)
    arrived.wait(timeout)
    return got[0] if got else None


class SimNode:
    """Runs a ``BubbleRob-v0`` env (``action_type="wheels"``) as a ROS node; see the module doc."""

    def __init__(
        self,
        env: gym.Env[Any, Any],
        backend: LiveBackend,
        topics: Topics | None = None,
        controls: ControlTopics | None = None,
        config: NodeConfig | None = None,
        driver: Driver | None = None,
    ) -> None:
        """Advertise every output and subscribe every input (nothing is stepped yet).

        ``driver(obs, episode_start)`` (e.g. a policy's ``predict``), if given, drives the robot
        instead of the wheel-command topics; with ``localize`` a Nav env's goal in its
        observation is seen from the pose estimate (:meth:`LiveNavigation.observed`).

        Raises:
            ValueError: The env is not in ``"wheels"`` mode.
        """
        base = env.unwrapped
        if getattr(base, "action_type", None) != "wheels":
            raise ValueError("the node drives the env's wheels: make it with action_type='wheels'")
        self.config = config or NodeConfig()
        self.backend = backend
        topics = topics or Topics()
        names = topics.resolved()
        self.command_names = {k: names[k] for k in COMMAND_KEYS if k in names}
        live_topics = topics.replace(**dict.fromkeys(COMMAND_KEYS))
        self.publisher = RosLivePublisher(
            env,
            backend,
            topics=live_topics,
            start_time=self.config.start_time,
            map_resolution=self.config.map_resolution,
            static_map_to_odom=self.config.localize is None,
        )
        self.names = (controls or ControlTopics()).resolved(topics.namespace)
        resolved = live_topics.resolved()
        self._sensor_topics = {
            "laser": [resolved[k] for k in ("scan",) if k in resolved],
            "camera": [
                resolved[k] for k in ("image", "camera_info", "detections") if k in resolved
            ],
        }
        self.state = ControlState(base.drive, self.config.watchdog)  # type: ignore[attr-defined]
        self.sync = self.config.sync
        self.sim_state = {"running": RUNNING, "paused": PAUSED, "stopped": STOPPED}[
            self.config.start
        ]
        self.steps = 0
        self._pending = 0
        self._stop_requested = False
        self.first_step_at: float | None = None
        """``time.perf_counter()`` when the first step began, and when the latest ended."""
        self.last_step_at: float | None = None
        self._encoding = get_distro(backend.distro).encoding
        self._bool = {v: self._serialize("std_msgs/msg/Bool", data=v) for v in (False, True)}
        self._step_done = backend.advertise(self.names["step_done"], "std_msgs/msg/Bool")
        self._state_out = backend.advertise(self.names["state"], "std_msgs/msg/Int32", True)
        self._subscribe_all()
        self.localizer = self._make_localizer(live_topics)
        self.navigation = None
        if isinstance(base, BubbleRobNavEnv):  # goals on /move_base_simple/goal, as move_base
            warn = lambda t, r, d: self._reject(t, r, d, every=0.2)  # noqa: E731 - goals: few
            self.navigation = LiveNavigation(base, self.publisher, live_topics, warn)
        self.driver = driver
        self._obs: Any = None
        self._episode_start = True

    def _make_localizer(self, topics: Topics) -> LiveLocalizer | None:
        config = self.config
        if config.localize is None:
            return None
        settings = LocalizerConfig(
            mode=config.localize, seed=config.seed, map_resolution=config.map_resolution
        )
        return LiveLocalizer(
            self.backend, topics, settings, warn=lambda t, r, d: self._reject(t, r, d)
        )

    # -- wiring ---------------------------------------------------------------------------------

    def _serialize(self, msgtype: str, **fields: Any) -> bytes:
        distro = self.backend.distro
        return serialize(distro, typestore(distro).types[msgtype](**fields), msgtype)

    def _subscribe_all(self) -> None:
        s = self.state
        handlers: list[tuple[str, str, Callable[[Any], None]]] = []
        if "cmd_vel" in self.command_names:
            handlers.append(
                (self.command_names["cmd_vel"], "twist", _call(s.command_twist, star=True))
            )
        for side, key in enumerate(("left_motor_speed", "right_motor_speed")):
            if key in self.command_names:
                handlers.append((self.command_names[key], "float32", _call(s.command_wheel, side)))
        for sensor in ("laser", "camera"):
            handlers.append((self.names[f"{sensor}_switch"], "bool", _call(s.set_switch, sensor)))
        for event in ("start", "pause", "stop", "enable_sync", "trigger"):
            handlers.append((self.names[event], "bool", _call(s.push, event)))
        for topic, kind, handle in handlers:
            self.backend.subscribe(topic, CONTROL_TYPES[kind], self._checked(topic, kind, handle))

    def _checked(
        self, topic: str, kind: str, handle: Callable[[Any], None]
    ) -> Callable[[bytes, str | None, str], None]:
        expected = CONTROL_TYPES[kind].replace("/msg/", "/")

        def callback(raw: bytes, msgtype: str | None, sender: str) -> None:
            if msgtype not in (None, "*", expected):
                self._reject(topic, "wrong type", f"{msgtype} from {sender}, expected {expected}")
                return
            try:
                value = decode_control(kind, raw, self._encoding)
            except ControlError as error:
                self._reject(topic, "malformed", f"{error} (from {sender})")
                return
            if kind == "twist":
                value = _bounded_twist(*value)
            elif kind == "float32":  # a wheel speed: at most the motor's
                top = self.state.drive.max_wheel_speed
                value = min(max(value, -top), top)
            try:
                handle(value)
            except Exception as error:  # noqa: BLE001 - no message may kill the node
                self._reject(topic, "unusable", f"{error!r} (from {sender})")

        return callback

    def _reject(self, topic: str, reason: str, detail: str, every: float = 2.0) -> None:
        if self.state.should_warn(topic, reason, every):
            self.backend.log("warn", f"ignoring a {reason} message on {topic}: {detail}")

    # -- simulation -----------------------------------------------------------------------------

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the first reset (the ``/clock`` time)."""
        stamp = self.publisher.stamp_ns
        return 0.0 if stamp is None else (stamp - self.publisher.start_time_ns) * 1e-9

    def _publish_state(self) -> None:
        self._state_out(self._serialize("std_msgs/msg/Int32", data=self.sim_state))

    def _new_episode(self) -> None:
        seed = self.config.seed
        episode = self.publisher.episode
        obs, info = self.publisher.reset(seed=None if seed is None else seed + episode)
        self.state.set_time(self.sim_time)
        if self.localizer is not None:
            self._localise(obs, info, reset=True)
        self._obs, self._episode_start = obs, True
        if self.navigation is not None:
            self.navigation.new_episode()

    def _localise(self, obs: Any, info: dict[str, Any], reset: bool = False) -> None:
        localizer, stamp = self.localizer, self.publisher.stamp_ns
        assert localizer is not None and stamp is not None
        if reset:
            localizer.reset(self.publisher, info, stamp)
        # The filter sees the scans a subscriber sees: none switched off, one per scan_every.
        scan = self.publisher.scan_topic
        published = scan is None or self.publisher.sink.latest_due(scan)
        localizer.step(obs, info, stamp, self.state.laser_on and published)

    def _handle(self, event: str, value: bool) -> None:
        before = self.sim_state
        if event == "start":
            if self.sim_state == STOPPED:
                self._new_episode()
            self.sim_state = RUNNING
        elif event == "pause":
            if self.sim_state == RUNNING:
                self.sim_state = PAUSED
        elif event == "stop":
            self.sim_state = STOPPED
            self._pending = 0
            self.state.stop_wheels()
        elif event == "enable_sync":
            self.sync = value
            self._pending = 0
        elif event == "trigger":
            if self.sync and self.sim_state == RUNNING:
                self._pending += 1
            elif self.state.should_warn(self.names["trigger"], "ignored"):
                why = "not in sync mode" if not self.sync else "the simulation is not running"
                self.backend.log("warn", f"ignoring triggerNextStep: {why}")
        if self.sim_state != before:
            self._publish_state()

    def _apply_switches(self) -> None:
        sink = self.publisher.sink
        sink.mute(self._sensor_topics["laser"], not self.state.laser_on)
        sink.mute(self._sensor_topics["camera"], not self.state.camera_on)

    def step_once(self) -> tuple[bool, bool]:
        """One control step with the current command; returns ``(terminated, truncated)``."""
        if self.first_step_at is None:
            self.first_step_at = time.perf_counter()
        action = self._action()
        obs, _, terminated, truncated, info = self.publisher.step(action)
        self.steps += 1
        if self.localizer is not None:
            self._localise(obs, info)
        self._obs = obs
        if self.navigation is not None:
            self.navigation.after_step(info, self.sim_time)
        if terminated or truncated:
            self._new_episode()
        self.state.set_time(self.sim_time)
        self._step_done(self._bool[True])
        self.last_step_at = time.perf_counter()
        return terminated, truncated

    def _action(self) -> Any:
        """The wheel-command topics' action, or the driver's (see ``__init__``)."""
        action = self.state.action(self.sim_time)
        if self.driver is None or self._obs is None:
            return action
        if action.any():  # a wheel command came in while a policy drives: say it is not used
            topic = self.command_names.get("cmd_vel", "the wheel-command topics")
            self._reject(topic, "wheel command", "--policy drives the robot: commands are unused")
        obs, pose = self._obs, None if self.localizer is None else self.localizer.pose
        if self.navigation is not None and pose is not None:
            obs = self.navigation.observed(obs, pose)
        start, self._episode_start = self._episode_start, False
        return self.driver(obs, start)

    def run(self, max_steps: int | None = None, duration: float | None = None) -> int:
        """Run until shut down, ``max_steps`` steps, or ``duration`` wall seconds; steps taken."""
        self._publish_state()
        if self.sim_state != STOPPED:
            self._new_episode()
        rate = self.config.rate_factor
        period = self.publisher.dt_ns * 1e-9 / rate if rate > 0 else 0.0
        end = math.inf if duration is None else time.monotonic() + duration
        deadline: float | None = None
        start_steps = self.steps
        self._stop_requested = False
        while self.backend.ok() and not self._stop_requested and time.monotonic() < end:
            if max_steps is not None and self.steps - start_steps >= max_steps:
                break
            for event, value in self.state.drain():
                self._handle(event, value)
            self._apply_switches()
            if self.navigation is not None and self.publisher.stamp_ns is not None:
                self.navigation.apply(self.localizer)  # a goal received since the last pass
            if self.sim_state != RUNNING or (self.sync and self._pending <= 0):
                deadline = None
                self.state.wait(min(0.05, max(0.0, end - time.monotonic())))
                continue
            if not self.sync and period > 0:
                now = time.monotonic()
                if deadline is None:
                    deadline = now
                if now < deadline:
                    self.state.wait(min(deadline - now, 0.1))
                    continue
                deadline = max(deadline + period, now - period)  # late: catch up one step at most
            if self.sync:
                self._pending -= 1
            self.step_once()
        return self.steps - start_steps

    def request_stop(self) -> None:
        """Make :meth:`run` return soon; safe from a signal handler (it only sets a flag)."""
        self._stop_requested = True

    def close(self) -> None:
        """Stop publishing and close the env (the backend is the caller's)."""
        self.publisher.close()


def _call(function: Callable[..., None], *first: Any, star: bool = False) -> Callable[[Any], None]:
    """``value -> function(*first, value)`` (or ``function(*first, *value)`` with ``star``)."""

    def handle(value: Any) -> None:
        if star:
            function(*first, *value)
        else:
            function(*first, value)

    return handle
