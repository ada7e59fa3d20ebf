"""``bubblerob node --localize``: the particle filter inside the live node, in the manner of AMCL.

The node hands each frame's scan and odometry (what it publishes on ``/scan`` and as
``odom -> base_link``) to :class:`LiveLocalizer`, which keeps a
:class:`~bubblerob_env.localisation.ParticleFilter` on the episode's map (the ``/map`` it
publishes) and answers as ``amcl`` does (:mod:`~bubblerob_env.ros.live.amcl_messages`):

- ``/amcl_pose`` (latched) and ``/particlecloud`` after every filter update (the robot moved
  ``update_min_d`` or turned ``update_min_a``) and after every (re)initialisation;
- ``map -> odom`` on ``/tf`` with every frame, stamped ``transform_tolerance`` ahead (AMCL's
  parameter, 0.1 s), so that tf lookups at the newest scan's time find it; the node's
  ``/tf_static`` then leaves out its identity ``map -> odom``;
- ``/initialpose`` re-initialises the particles around the pose it gives (the callback only
  queues it: the simulation loop applies it before the next update). Malformed ones are
  reported and ignored.

Each episode starts the filter again on the new map: tracking from the odometry's start pose
(``odom`` coincides with ``map`` at a reset), or with ``global`` from particles over all the free
space (AMCL's ``global_localization``). Without the laser on (``/laser_switch``) the particles
only wait, as AMCL without scans.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from bubblerob_env.localisation.evaluation import scan_geometry
from bubblerob_env.localisation.field import LikelihoodField, compile_field_kernel
from bubblerob_env.localisation.filter import ParticleFilter
from bubblerob_env.mapping import DEFAULT_RESOLUTION, episode_grid
from bubblerob_env.ros.live.amcl_messages import (
    INITIAL_POSE,
    PARTICLE_CLOUD,
    POSE_WITH_COVARIANCE,
    InitialPoseError,
    Pose,
    amcl_pose,
    decode_initial_pose,
    particle_cloud,
    transform,
)
from bubblerob_env.ros.live.backend import LiveBackend
from bubblerob_env.ros.messages.topics import Topics, namespace_prefix

__all__ = ["LOCALIZE_MODES", "LiveLocalizer", "LocalizerConfig"]

LOCALIZE_MODES = ("track", "global")
"""``--localize`` modes: tracking from the start pose, or global localisation."""


@dataclass(frozen=True)
class LocalizerConfig:
    """How the live filter starts and stamps ``map -> odom``."""

    mode: str = "track"
    start_std: tuple[float, float, float] = (0.1, 0.1, 0.1)
    transform_tolerance: float = 0.1
    seed: int | None = 0
    map_resolution: float = DEFAULT_RESOLUTION

    def __post_init__(self) -> None:
        if self.mode not in LOCALIZE_MODES:
            raise ValueError(
                f"--localize must be one of {', '.join(LOCALIZE_MODES)}, got {self.mode!r}"
            )


class LiveLocalizer:
    """AMCL's topics for one robot (see the module docstring)."""

    def __init__(
        self,
        backend: LiveBackend,
        topics: Topics,
        config: LocalizerConfig | None = None,
        warn: Any = None,
    ) -> None:
        """Advertise the outputs and subscribe ``initialpose`` (under the robot's namespace).

        ``warn(topic, reason, detail)`` reports a rejected ``/initialpose`` (rate limited by the
        caller); default: the backend's log.
        """
        self.backend = backend
        self.config = config or LocalizerConfig()
        self.distro = backend.distro
        prefix = namespace_prefix(topics.namespace)
        self.names = {k: f"{prefix}/{k}" for k in ("amcl_pose", "particlecloud", "initialpose")}
        self.map_frame = topics.frame_prefix + "map"
        self.odom_frame = topics.frame_prefix + "odom"
        # Latched, as AMCL's (ROS 1 latch; Nav2's transient local): rviz or a late tool gets it.
        self._pose_out = backend.advertise(self.names["amcl_pose"], POSE_WITH_COVARIANCE, True)
        self._cloud_out = backend.advertise(self.names["particlecloud"], PARTICLE_CLOUD)
        tf = topics.resolved().get("tf")
        self._tf_out = backend.advertise(tf, "tf2_msgs/msg/TFMessage") if tf else None
        self._warn = warn or (
            lambda topic, reason, detail: backend.log("warn", f"{topic}: {detail}")
        )
        self._lock = threading.Lock()
        self._initial: tuple[Pose, Pose] | None = None
        self.filter: ParticleFilter | None = None
        self.pose: tuple[float, float, float] | None = None
        """The estimate (x, y, yaw) in ``map`` after the latest frame: what the node plans and
        drives on (a Nav env's goals, ``--policy``)."""
        self.episodes = 0
        self.updates = 0
        self.initial_poses = 0
        backend.subscribe(self.names["initialpose"], INITIAL_POSE, self._receive)
        compile_field_kernel()

    def _receive(self, raw: bytes, msgtype: str | None, sender: str) -> None:
        """An ``/initialpose`` (on a middleware thread): queued for the simulation loop."""
        topic, expected = self.names["initialpose"], INITIAL_POSE.replace("/msg/", "/")
        if msgtype not in (None, "*", expected):
            self._warn(topic, "wrong type", f"{msgtype} from {sender}, expected {expected}")
            return
        try:
            pose = decode_initial_pose(self.distro, raw, self.map_frame)
        except InitialPoseError as error:
            self._warn(topic, error.reason, f"{error} (from {sender})")
            return
        with self._lock:
            self._initial = pose

    def reset(self, env: gym.Env[Any, Any], info: dict[str, Any], stamp_ns: int) -> None:
        """A new episode: a filter on its map, started as configured."""
        grid = episode_grid(env, self.config.map_resolution)
        seed = None if self.config.seed is None else self.config.seed + self.episodes
        self.filter = ParticleFilter(LikelihoodField(grid), scan_geometry(env), seed=seed)
        self.episodes += 1
        if self.config.mode == "global":
            self.filter.start_global()
        else:
            odom = (float(info["odom_x"]), float(info["odom_y"]), float(info["odom_yaw"]))
            self.filter.start_at(odom, self.config.start_std)

    def step(
        self, obs: dict[str, Any], info: dict[str, Any], stamp_ns: int, laser_on: bool
    ) -> bool:
        """One frame (also a reset's first): update, publish; whether the filter updated."""
        pf = self.filter
        if pf is None:
            raise RuntimeError("LiveLocalizer.step before reset")
        with self._lock:
            initial, self._initial = self._initial, None
        if initial is not None:
            pf.start_at(*initial)
            self.initial_poses += 1
        odom = np.array([info["odom_x"], info["odom_y"], info["odom_yaw"]], dtype=np.float64)
        updated = laser_on and pf.update(odom, np.asarray(obs["laser"], dtype=np.float64))
        if updated:
            self.updates += 1
        x, y, yaw = (float(v) for v in pf.estimate(odom))
        self.pose = (x, y, yaw)
        if updated or initial is not None:
            self._publish_estimate(odom, stamp_ns)
        if self._tf_out is not None:
            ahead = stamp_ns + round(self.config.transform_tolerance * 1e9)
            x, y, yaw = (float(v) for v in pf.map_to_odom())
            self._tf_out(
                transform(self.distro, ahead, self.map_frame, self.odom_frame, (x, y, yaw))
            )
        return bool(updated)

    def _publish_estimate(self, odom: np.ndarray, stamp_ns: int) -> None:
        pf = self.filter
        assert pf is not None
        x, y, yaw = (float(v) for v in pf.estimate(odom))
        self._pose_out(
            amcl_pose(self.distro, stamp_ns, self.map_frame, (x, y, yaw), pf.covariance())
        )
        self._cloud_out(particle_cloud(self.distro, stamp_ns, self.map_frame, pf.particles))
