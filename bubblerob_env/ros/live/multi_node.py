"""``MultiSimNode``: several robots of one world as one ROS node (``bubblerob node --robots N``).

One process, one world (:func:`bubblerob_env.parallel_env`), one physics step for every robot,
and exactly one ``/clock``, as Stage runs several robots. Each robot has its own topics and tf
frames (:func:`~bubblerob_env.ros.messages.robots.robot_topics`: ``/robot_0/scan`` with frames
``robot_0/odom`` ... on the shared ``/tf``, or the tutorial's suffixed names), its own wheel
commands with their own watchdog (:class:`~bubblerob_env.ros.live.controls.ControlState`) and its
own sensor switches. Simulation control (start, pause, stop, sync mode, triggers,
``simulationStepDone``, ``simulationState``) is the world's, on the global topics, as in
:class:`~bubblerob_env.ros.live.node.SimNode`.

Every robot's frames go through its own :class:`~bubblerob_env.ros.fanout.MessageFanout` (the
one conversion layer) into a :class:`~bubblerob_env.ros.live.sink.LiveSink`: the robot's names and
frame prefix are all that differ. The ``map`` frame is the world's, shared by all. A robot that
terminates stays in the world as an obstacle and publishes nothing until every robot is done;
then the next episode (seed + k) starts for all, its stamps one step after the last.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from bubblerob_env.ros.episodes import start_time_ns
from bubblerob_env.ros.live.backend import LiveBackend, Publish, RawCallback
from bubblerob_env.ros.live.controls import (
    CONTROL_TYPES,
    ControlError,
    ControlState,
    ControlTopics,
    decode_control,
)
from bubblerob_env.ros.live.node import (
    COMMAND_KEYS,
    PAUSED,
    RUNNING,
    STOPPED,
    TWIST_LIMIT,
    NodeConfig,
)
from bubblerob_env.ros.live.sink import LiveSink
from bubblerob_env.ros.messages.distros import deserialize, get_distro, serialize, typestore
from bubblerob_env.ros.messages.robots import robot_topics
from bubblerob_env.ros.messages.topics import MSGTYPES, Topics, namespace_prefix
from bubblerob_env.ros.world_streams import WorldStreams

if TYPE_CHECKING:  # PettingZoo (the [multi] extra) is imported only where a world is made
    from bubblerob_env.multi.parallel import MultiRobotEnv

__all__ = ["MultiSimNode", "RobotChannel"]

Driver = Callable[[str, Any, bool], Any]
"""``driver(agent, obs, episode_start) -> action``: drives a robot instead of its topics."""
_GLOBAL_EVENTS = ("start", "pause", "stop", "enable_sync", "trigger")


class _SharedStatic:
    """One latched ``/tf_static`` for every robot, as tf2's static broadcaster keeps one.

    A ROS 1 latched topic keeps only the last message of a node's publisher: robots publishing
    their own static transforms on it would hide each other's from late subscribers.
    """

    def __init__(self, backend: LiveBackend, topic: str) -> None:
        self.distro = backend.distro
        self._publish = backend.advertise(topic, MSGTYPES["tf_static"], True)
        self._by_robot: dict[int, list[Any]] = {}

    def publisher(self, robot: int) -> Publish:
        """What robot ``robot``'s sink publishes its ``/tf_static`` with."""

        def publish(data: bytes) -> None:
            msgtype = MSGTYPES["tf_static"]
            self._by_robot[robot] = list(deserialize(self.distro, data, msgtype).transforms)
            transforms = [t for k in sorted(self._by_robot) for t in self._by_robot[k]]
            message = typestore(self.distro).types[msgtype](transforms=transforms)
            self._publish(serialize(self.distro, message, msgtype))

        return publish


class _RobotBackend(LiveBackend):
    """The node's backend as one robot's sink sees it: ``/tf_static`` goes to the shared one."""

    def __init__(self, backend: LiveBackend, static: _SharedStatic, static_topic: str, k: int):
        self.ros_version, self.distro = backend.ros_version, backend.distro
        self._backend, self._static, self._topic, self._k = backend, static, static_topic, k

    def advertise(self, topic: str, msgtype: str, latched: bool = False) -> Publish:
        if topic == self._topic:
            return self._static.publisher(self._k)
        return self._backend.advertise(topic, msgtype, latched)

    def subscribe(self, topic: str, msgtype: str, callback: RawCallback) -> None:
        self._backend.subscribe(topic, msgtype, callback)

    def ok(self) -> bool:
        return self._backend.ok()

    def shutdown(self, reason: str = "done") -> None:
        """The node's backend is its owner's: nothing to do per robot."""

    def log(self, level: str, text: str) -> None:
        self._backend.log(level, text)


@dataclass
class RobotChannel:
    """One robot's sink and inputs (its frames: a ``WorldStreams`` robot)."""

    agent: str
    controls: dict[str, str]
    sink: LiveSink
    state: ControlState
    sensor_topics: dict[str, list[str]] = field(default_factory=dict)
    episode_start: bool = True
    obs: Any = None


class MultiSimNode:
    """Runs a :class:`~bubblerob_env.multi.parallel.MultiRobotEnv` as one ROS node (module doc)."""

    def __init__(
        self,
        env: MultiRobotEnv,
        backend: LiveBackend,
        topics: Topics | None = None,
        naming: str = "namespace",
        config: NodeConfig | None = None,
        driver: Driver | None = None,
    ) -> None:
        """Advertise every robot's outputs and subscribe every input (nothing is stepped yet)."""
        if env.config.action_type != "wheels":
            raise ValueError("the node drives the wheels: make the env with action_type='wheels'")
        if env.config.obs_mode != "dict":
            raise ValueError("the node makes ROS messages of Dict observations: obs_mode='dict'")
        self.env, self.backend = env, backend
        self.config = config or NodeConfig()
        if self.config.localize is not None:
            raise ValueError("--localize runs for one robot: leave it out with --robots")
        base = (topics or Topics()).replace(detections=None)  # the recogniser: one robot's
        self.clock_topic = base.resolved().get("clock")
        self.start_time_ns = start_time_ns(self.config.start_time)
        drive = env.world.scene.limits.drive
        self.events = ControlState(drive, watchdog=0.0)  # the world's controls and warnings
        self._encoding = get_distro(backend.distro).encoding
        self._static = _SharedStatic(backend, base.resolved().get("tf_static", "/tf_static"))
        named = [robot_topics(base, k, naming) for k in range(env.num_robots)]
        published = [t.replace(**dict.fromkeys(COMMAND_KEYS)) for t in named]  # inputs here
        self.world = WorldStreams(
            env, published, self.start_time_ns, self.config.map_resolution, kwargs=None
        )
        self.channels = [self._channel(k, named[k], naming) for k in range(env.num_robots)]
        self.names = ControlTopics().resolved()
        self._clock = (
            None
            if self.clock_topic is None
            else backend.advertise(self.clock_topic, MSGTYPES["clock"])
        )
        self._bool = {v: self._serialize("std_msgs/msg/Bool", data=v) for v in (False, True)}
        self._step_done = backend.advertise(self.names["step_done"], "std_msgs/msg/Bool")
        self._state_out = backend.advertise(self.names["state"], "std_msgs/msg/Int32", True)
        self._subscribe_world()
        self.driver = driver
        self.sync = self.config.sync
        self.sim_state = {"running": RUNNING, "paused": PAUSED, "stopped": STOPPED}[
            self.config.start
        ]
        self.steps = self._pending = 0
        self._stop_requested = False
        self.first_step_at: float | None = None
        self.last_step_at: float | None = None

    # -- wiring ---------------------------------------------------------------------------------

    def _channel(self, k: int, named: Topics, naming: str) -> RobotChannel:
        robot = self.world.robots[k]
        commands = {key: name for key, name in named.resolved().items() if key in COMMAND_KEYS}
        resolved = robot.topics.resolved()
        sink = LiveSink(_RobotBackend(self.backend, self._static, resolved.get("tf_static", ""), k))
        specs = self.env.world.scene.specs
        if "scan" in resolved and specs.laser is not None:
            sink.publish_every(resolved["scan"], specs.scan_every)
        self.world.add_sink(k, sink, self.backend.distro)
        prefix = namespace_prefix(named.namespace)
        controls = {
            key: prefix + "/" + name.strip("/") + ("" if naming == "namespace" else str(k))
            for key, name in ControlTopics().__dict__.items()
            if key.endswith("_switch")
        }
        state = ControlState(self.env.world.scene.limits.drive, self.config.watchdog)
        channel = RobotChannel(robot.agent, controls, sink, state)
        channel.sensor_topics = {
            "laser": [resolved[k] for k in ("scan",) if k in resolved],
            "camera": [resolved[k] for k in ("image", "camera_info") if k in resolved],
        }
        self._subscribe_robot(channel, commands)
        return channel

    def _serialize(self, msgtype: str, **fields: Any) -> bytes:
        distro = self.backend.distro
        return serialize(distro, typestore(distro).types[msgtype](**fields), msgtype)

    def _subscribe_robot(self, channel: RobotChannel, commands: dict[str, str]) -> None:
        s = channel.state
        if "cmd_vel" in commands:
            self._listen(commands["cmd_vel"], "twist", lambda v: s.command_twist(*v), s)
        for side, key in enumerate(("left_motor_speed", "right_motor_speed")):
            if key in commands:
                self._listen(commands[key], "float32", _wheel(s, side), s)
        for sensor in ("laser", "camera"):
            topic = channel.controls[f"{sensor}_switch"]
            self._listen(topic, "bool", _switch(s, sensor), s)

    def _subscribe_world(self) -> None:
        for event in _GLOBAL_EVENTS:
            handle = _event(self.events, event)
            self._listen(self.names[event], "bool", handle, self.events)

    def _listen(
        self, topic: str, kind: str, handle: Callable[[Any], None], state: ControlState
    ) -> None:
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
                peak = max(abs(value[0]), abs(value[1]), TWIST_LIMIT)
                value = (value[0] * TWIST_LIMIT / peak, value[1] * TWIST_LIMIT / peak)
            elif kind == "float32":
                top = state.drive.max_wheel_speed
                value = min(max(value, -top), top)
            handle(value)

        self.backend.subscribe(topic, CONTROL_TYPES[kind], callback)

    def _reject(self, topic: str, reason: str, detail: str) -> None:
        if self.events.should_warn(topic, reason):
            self.backend.log("warn", f"ignoring a {reason} message on {topic}: {detail}")

    # -- simulation -----------------------------------------------------------------------------

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the first reset (the ``/clock`` time)."""
        return self.world.sim_time

    @property
    def published(self) -> int:
        """Messages published by every robot's sink (``/clock`` and the controls' not counted)."""
        return sum(channel.sink.published for channel in self.channels)

    def _publish_clock(self) -> None:
        stamp_ns = self.world.last_ns
        if self._clock is not None and stamp_ns is not None:
            sec, nanosec = divmod(stamp_ns, 10**9)
            time_type = typestore(self.backend.distro).types["builtin_interfaces/msg/Time"]
            stamp = time_type(sec=sec, nanosec=nanosec)
            self._clock(self._serialize(MSGTYPES["clock"], clock=stamp))

    def _new_episode(self) -> None:
        seed = self.config.seed
        seed = None if seed is None else seed + self.world.episodes
        facts = {"distro": self.backend.distro, "format": "live"}
        observations, _ = self.world.reset(seed, facts)
        self._publish_clock()
        for channel in self.channels:
            channel.obs, channel.episode_start = observations[channel.agent], True
            channel.state.set_time(self.sim_time)

    def _action(self, channel: RobotChannel) -> Any:
        action = channel.state.action(self.sim_time)
        if self.driver is None:
            return action
        start, channel.episode_start = channel.episode_start, False
        return self.driver(channel.agent, channel.obs, start)

    def step_once(self) -> None:
        """One physics step of every live robot, each robot's frame, ``/clock`` and step done."""
        if self.first_step_at is None:
            self.first_step_at = time.perf_counter()
        live = [c for c, r in zip(self.channels, self.world.robots, strict=True) if r.live]
        observations = self.world.step({c.agent: self._action(c) for c in live})[0]
        self.steps += 1
        for channel in live:
            channel.obs = observations[channel.agent]
        self._publish_clock()
        if not self.env.agents:
            self._new_episode()
        for channel in self.channels:
            channel.state.set_time(self.sim_time)
        self._step_done(self._bool[True])
        self.last_step_at = time.perf_counter()

    def _publish_state(self) -> None:
        self._state_out(self._serialize("std_msgs/msg/Int32", data=self.sim_state))

    def _handle(self, event: str, value: bool) -> None:
        before = self.sim_state
        if event == "start":
            if self.sim_state == STOPPED:
                self._new_episode()
            self.sim_state = RUNNING
        elif event == "pause" and self.sim_state == RUNNING:
            self.sim_state = PAUSED
        elif event == "stop":
            self.sim_state, self._pending = STOPPED, 0
            for channel in self.channels:
                channel.state.stop_wheels()
        elif event == "enable_sync":
            self.sync, self._pending = value, 0
        elif event == "trigger":
            if self.sync and self.sim_state == RUNNING:
                self._pending += 1
            elif self.events.should_warn(self.names["trigger"], "ignored"):
                why = "not in sync mode" if not self.sync else "the simulation is not running"
                self.backend.log("warn", f"ignoring triggerNextStep: {why}")
        if self.sim_state != before:
            self._publish_state()

    def _apply_switches(self) -> None:
        for channel in self.channels:
            channel.sink.mute(channel.sensor_topics["laser"], not channel.state.laser_on)
            channel.sink.mute(channel.sensor_topics["camera"], not channel.state.camera_on)

    def run(self, max_steps: int | None = None, duration: float | None = None) -> int:
        """Run until shut down, ``max_steps`` steps, or ``duration`` wall seconds; steps taken."""
        self._publish_state()
        if self.sim_state != STOPPED:
            self._new_episode()
        rate = self.config.rate_factor
        period = self.world.dt_ns * 1e-9 / rate if rate > 0 else 0.0
        end = math.inf if duration is None else time.monotonic() + duration
        deadline: float | None = None
        first = self.steps
        self._stop_requested = False
        while self.backend.ok() and not self._stop_requested and time.monotonic() < end:
            if max_steps is not None and self.steps - first >= max_steps:
                break
            for event, value in self.events.drain():
                self._handle(event, value)
            self._apply_switches()
            if self.sim_state != RUNNING or (self.sync and self._pending <= 0):
                deadline = None
                self.events.wait(min(0.05, max(0.0, end - time.monotonic())))
                continue
            if not self.sync and period > 0:
                now = time.monotonic()
                deadline = now if deadline is None else deadline
                if now < deadline:
                    self.events.wait(min(deadline - now, 0.1))
                    continue
                deadline = max(deadline + period, now - period)
            if self.sync:
                self._pending -= 1
            self.step_once()
        return self.steps - first

    def request_stop(self) -> None:
        """Make :meth:`run` return soon; safe from a signal handler (it only sets a flag)."""
        self._stop_requested = True

    def close(self) -> None:
        """Stop publishing and close the env (the backend is the caller's)."""
        for channel in self.channels:
            channel.sink.close()
        self.env.close()


def _wheel(state: ControlState, side: int) -> Callable[[Any], None]:
    return lambda speed: state.command_wheel(side, speed)


def _switch(state: ControlState, sensor: str) -> Callable[[Any], None]:
    return lambda on: state.set_switch(sensor, on)


def _event(state: ControlState, event: str) -> Callable[[Any], None]:
    return lambda value: state.push(event, value)
