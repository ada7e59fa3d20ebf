"""Every robot of one world as its own stream of frames (``node`` and ``record --robots``).

Robot ``k``'s frames go through its own :class:`~bubblerob_env.ros.fanout.MessageFanout` (the one
conversion layer) with its own topic names and tf frame prefix ``robot_k/``
(:mod:`~bubblerob_env.ros.messages.robots`); the ``map`` frame is the world's. All robots' stamps
are the world's simulated time: an episode of the world starts one step after the last one ended,
for every robot, even one that terminated early (it publishes nothing more until then, as a
terminated agent of :func:`bubblerob_env.parallel_env` stays in the world as an obstacle).
Each episode's metadata record names the world (``robots``, ``robot``, ``env_kwargs``) so that a
recording can be re-simulated (:func:`~bubblerob_env.ros.world_record.replay_robots`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import SimpleNamespace
from typing import TYPE_CHECKING, Any

import numpy as np

from bubblerob_env.mapping import Grid, episode_grid, has_arena
from bubblerob_env.ros.episodes import EpisodeStream, jsonable
from bubblerob_env.ros.fanout import MessageFanout
from bubblerob_env.ros.messages.robots import robot_frame_prefix
from bubblerob_env.ros.messages.topics import Topics
from bubblerob_env.ros.sink import Sink

if TYPE_CHECKING:  # PettingZoo (the [multi] extra) is imported only where a world is made
    from bubblerob_env.multi.parallel import MultiRobotEnv

__all__ = ["RobotStream", "WorldStreams", "world_kwargs"]

Step = tuple[dict[str, Any], dict[str, float], dict[str, bool], dict[str, bool], dict[str, Any]]


def world_kwargs(env: MultiRobotEnv, kwargs: Mapping[str, Any]) -> dict[str, Any]:
    """How to make ``env`` again: ``parallel_env(**world_kwargs(env, the single env's kwargs))``."""
    return {
        "num_robots": env.num_robots,
        "robot": env.config.robot.name,
        "scenario": env.scenario,
        "max_episode_steps": env.max_episode_steps,
        **jsonable(dict(kwargs)),
    }


@dataclass
class RobotStream:
    """One robot's names and path to its sinks."""

    agent: str
    topics: Topics
    fanout: MessageFanout
    stream: EpisodeStream
    live: bool = False


class WorldStreams:
    """Resets and steps a world, sending each robot's frames through its own fan-out.

    Args:
        env: The world (:func:`bubblerob_env.parallel_env`, Dict observations).
        topics: Each robot's topics, in agent order (``/clock`` left out: it is the world's).
        epoch_ns: Stamp of the first frame.
        map_resolution: Metres per cell of each robot's ``/map`` (the world's ground truth).
        kwargs: The single env's kwargs the world was made with (for the metadata).
        batch_frames: The fan-outs' batching; 0 (the default): frames of all robots are written
            step by step, interleaved in time.
    """

    def __init__(
        self,
        env: MultiRobotEnv,
        topics: Sequence[Topics],
        epoch_ns: int,
        map_resolution: float,
        kwargs: Mapping[str, Any] | None = None,
        batch_frames: int = 0,
    ) -> None:
        if env.config.obs_mode != "dict":
            raise ValueError("ROS messages are made of Dict observations: obs_mode='dict'")
        if len(topics) != env.num_robots:
            raise ValueError(f"one Topics per robot: {env.num_robots}, got {len(topics)}")
        self.env = env
        self.dt_ns = round(env.config.control_timestep * 1e9)
        self.epoch_ns = epoch_ns
        self.map_resolution = map_resolution
        self.kwargs = world_kwargs(env, kwargs or {})
        specs = env.world.scene.specs
        self.robots = [
            RobotStream(
                agent,
                named.replace(detections=None),  # the recogniser is one robot's
                fanout := MessageFanout(specs, named.replace(detections=None), batch_frames),
                EpisodeStream(fanout, self.dt_ns, epoch_ns, map_resolution),
            )
            for agent, named in zip(env.possible_agents, topics, strict=True)
        ]
        self.episodes = 0
        self.last_ns: int | None = None
        self._offset_ns = 0

    def add_sink(self, k: int, sink: Sink, distro: str, static_map_to_odom: bool = True) -> None:
        """Send robot ``k``'s frames to ``sink`` (its converter gets the robot's frame prefix)."""
        fanout = self.robots[k].fanout
        converter = fanout.serializer(distro).converter
        converter.frame_prefix = robot_frame_prefix(k)
        converter.shared_map = True
        converter.static_map_to_odom = static_map_to_odom
        fanout.add_sink(sink)

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the first frame."""
        return 0.0 if self.last_ns is None else (self.last_ns - self.epoch_ns) * 1e-9

    def reset(self, seed: int | None, facts: Mapping[str, Any]) -> tuple[dict[str, Any], Any]:
        """A new episode of the world: every robot's metadata, ``/map`` and first frame."""
        observations, infos = self.env.reset(seed=seed)
        start = self.epoch_ns if self.last_ns is None else self.last_ns + self.dt_ns
        grid = self._grid()
        for k, robot in enumerate(self.robots):
            if robot.stream.last_ns is not None:
                robot.stream.last_ns = start - self.dt_ns  # done early: restart with the world
            metadata = {
                "episode": self.episodes,
                "seed": seed,
                "env_id": "parallel_env",
                "env_kwargs": self.kwargs,
                "robots": self.env.num_robots,
                "robot": robot.agent,
                "frame_prefix": robot_frame_prefix(k),
                "start_time_ns": start,
                "first_seq": robot.stream.seq,
                "dt": self.env.config.control_timestep,
                **jsonable(dict(facts)),
                "topics": robot.topics.to_dict(),
            }
            obs = _as_dict(observations[robot.agent])
            robot.stream.begin(obs, infos[robot.agent], metadata, grid)
            robot.live = True
        self._offset_ns = start - round(float(infos[self.robots[0].agent]["sim_time"]) * 1e9)
        self.last_ns = start
        self.episodes += 1
        return observations, infos

    def _grid(self) -> Grid | None:
        if self.robots[0].topics.map is None:
            return None
        scene = self.env.world.scene
        view = SimpleNamespace(
            model=scene.model, layout=self.env.layout, arena_size=self.env.config.arena_size
        )
        shim = SimpleNamespace(unwrapped=view)
        return episode_grid(shim, self.map_resolution) if has_arena(shim) else None

    def step(self, actions: Mapping[str, Any]) -> Step:
        """One step of every live robot (``actions`` per live agent) and their frames."""
        live = [robot for robot in self.robots if robot.live]
        chosen = {r.agent: np.asarray(actions[r.agent], dtype=np.float32) for r in live}
        observations, rewards, terminations, truncations, infos = self.env.step(chosen)
        for robot in live:
            agent = robot.agent
            done = bool(terminations[agent] or truncations[agent])
            robot.stream.step(
                _as_dict(observations[agent]), infos[agent], chosen[agent], rewards[agent],
                bool(terminations[agent]), bool(truncations[agent]),
            )  # fmt: skip
            robot.live = not done
        sim_time = float(infos[live[0].agent]["sim_time"])
        self.last_ns = self._offset_ns + round(sim_time * 1e9)
        return observations, rewards, terminations, truncations, infos

    def flush(self) -> None:
        """Write every robot's gathered frames."""
        for robot in self.robots:
            robot.fanout.flush()


def _as_dict(obs: Any) -> dict[str, Any]:
    """A Dict observation (``__init__`` refused ``obs_mode='flat'``)."""
    assert isinstance(obs, dict)
    return obs
