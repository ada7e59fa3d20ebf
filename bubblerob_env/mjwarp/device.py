"""The worlds on the device: MuJoCo Warp's model and data, the readings, and one step's launches.

:class:`DeviceWorlds` owns every device array of a :class:`~bubblerob_env.mjwarp.WarpVectorEnv`
and launches, per control step: the wheel commands, ``physics_substeps`` times MuJoCo Warp's
``step2`` + ``step1`` (the CPU kernel's order: kinematics, contacts and sensors of the final
state) with the collision check after each, then the laser's rays and the readings, reward,
odometry and episode flags. Per-world obstacle sizes are batched model fields
(``put_model(..., batch_sizes=...)``); obstacle poses are per-world mocap state.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import mujoco
import mujoco_warp as mjw
import numpy as np
import warp as wp
from mujoco_warp._src.types import OverflowType, vec6
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.batch.common import checked_actions
from bubblerob_env.core.batch import kernel_settings
from bubblerob_env.core.kernel import CFG, ICFG, OUT, OUT_SIZE
from bubblerob_env.mjwarp import kernels as K
from bubblerob_env.mjwarp.laser import culled_laser, obstacle_geoms
from bubblerob_env.mjwarp.layouts import LayoutTable, slot_geoms
from bubblerob_env.scene import Scene

__all__ = ["CONTACTS_PER_WORLD", "CONSTRAINTS_PER_WORLD", "DeviceWorlds", "HostCopy"]

CONTACTS_PER_WORLD = 16
"""Contacts allocated per world (the CPU env's longest random runs used at most 6)."""
CONSTRAINTS_PER_WORLD = 64
"""Constraint rows allocated per world (the CPU env used at most 21)."""
_BATCHED_FIELDS = ("geom_size", "geom_rbound", "geom_aabb")
# Overflows that drop contacts or constraints (the CPU batch's full MjData arena); a solver that
# reached its iteration limit still gives a state, as CPU MuJoCo's does.
_FATAL_OVERFLOWS = int(
    OverflowType.NEFC
    | OverflowType.NJMAX_NNZ
    | OverflowType.BROADPHASE
    | OverflowType.NARROWPHASE
    | OverflowType.CCD
)


@dataclass(frozen=True)
class HostCopy:
    """What ``info`` and the numpy outputs need, copied from the device after a step."""

    out: NDArray[np.float64]
    laser: NDArray[np.float32]
    proximity: NDArray[np.float32]
    velocity: NDArray[np.float32]
    odometry: NDArray[np.float64]
    rewards: NDArray[np.float64]
    terminated: NDArray[np.bool_]
    truncated: NDArray[np.bool_]
    diverged: NDArray[np.bool_]
    collided: NDArray[np.bool_]
    clipped_actions: NDArray[np.int64]


def _settings(scene: Scene, max_episode_steps: int | None) -> K.Settings:
    """The CPU kernel's settings of ``scene`` (:mod:`bubblerob_env.core.batch`), as Warp's."""
    config = scene.config
    icfg, cfg = kernel_settings(config, scene)
    s = K.Settings()
    s.twist, s.has_laser = int(icfg[ICFG.TWIST]), int(icfg[ICFG.LASER])
    s.max_wheel, s.max_linear = float(cfg[CFG.MAX_WHEEL]), float(cfg[CFG.MAX_LINEAR])
    s.max_angular, s.wheel_radius = float(cfg[CFG.MAX_ANGULAR]), float(cfg[CFG.WHEEL_RADIUS])
    s.wheel_separation = float(cfg[CFG.WHEEL_SEPARATION])
    s.range_max = float(cfg[CFG.RANGE_MAX])
    # float32's own step below range_max: float64's rounds back up to range_max in float32.
    s.noisy_ceiling = float(np.nextafter(np.float32(s.range_max), np.float32(0)))
    s.laser_noise = scene.laser_spec.noise_std if scene.laser_spec is not None else 0.0
    s.proximity_max = float(cfg[CFG.PROXIMITY_MAX])
    s.limit_linear = float(cfg[CFG.VELOCITY_LIMIT_LINEAR])
    s.limit_angular = float(cfg[CFG.VELOCITY_LIMIT_ANGULAR])
    s.forward_weight, s.spin_weight = float(cfg[CFG.FORWARD_WEIGHT]), float(cfg[CFG.SPIN_WEIGHT])
    s.clearance_weight = float(cfg[CFG.CLEARANCE_WEIGHT])
    s.clearance_distance = float(cfg[CFG.CLEARANCE_DISTANCE])
    s.hull, s.collision_penalty = float(cfg[CFG.HULL]), float(cfg[CFG.COLLISION_PENALTY])
    s.terminate_on_collision = int(config.terminate_on_collision)
    s.max_episode_steps = max_episode_steps or 0
    s.odometry_noise = config.odometry_noise
    s.velocity_adr, s.gyro_adr = int(icfg[ICFG.VELOCITY_ADR]), int(icfg[ICFG.GYRO_ADR])
    s.left_wheel_adr = int(icfg[ICFG.WHEEL_ADR])
    s.right_wheel_adr = int(icfg[ICFG.WHEEL_ADR + 1])
    s.proximity_adr = int(icfg[ICFG.PROXIMITY_ADR])
    s.root_qpos = scene.root_qpos
    s.laser_site = int(scene.model.site(names.LASER_SITE).id)
    return s


class DeviceWorlds:
    """``n`` worlds of ``scene``'s model on ``device``, and their readings and episode state."""

    def __init__(
        self,
        scene: Scene,
        n: int,
        device: str | None,
        max_episode_steps: int | None,
        graphs: bool = True,
    ) -> None:
        try:
            self.device = wp.get_device(device)
        except ValueError:  # Warp's "Invalid device identifier" does not say what is here
            here = [d.alias for d in wp.get_devices()]
            raise ValueError(
                f"device must be one of this machine's Warp devices {here} (or None: Warp's "
                f"default), got {device!r}"
            ) from None
        self.graphs = graphs
        self._graphs: dict[str, Any] = {}
        self._seen: set[str] = set()
        self.n = n
        self.substeps = scene.config.physics_substeps
        self.settings = _settings(scene, max_episode_steps)
        spec = scene.laser_spec
        self.nray = spec.num_rays if spec is not None else 0
        model = scene.model
        groups = np.clip(model.geom_group, 0, mujoco.mjNGROUP - 1)
        with wp.ScopedDevice(self.device):
            self.model = mjw.put_model(model, batch_sizes=dict.fromkeys(_BATCHED_FIELDS, n))
            self.data = mjw.make_data(
                model, nworld=n, nconmax=CONTACTS_PER_WORLD, njmax=CONSTRAINTS_PER_WORLD
            )
            self.is_obstacle: wp.array[Any] = wp.array(
                (groups == names.OBSTACLE_GROUP).astype(np.int32)
            )
            self.slot_geoms: wp.array[Any] = wp.array(slot_geoms(scene))
            self.actions = wp.zeros((n, 2), dtype=float)
            self.collision = wp.zeros(n, dtype=int)
            self.nearest = wp.zeros(n, dtype=float)
            self.seeds = wp.zeros(n, dtype=int)
            self.state = wp.zeros((n, K.STATE_SIZE), dtype=int)
            self.odometry = wp.zeros((n, 6), dtype=float)
            self.laser = wp.zeros((n, max(self.nray, 1)), dtype=float)
            self.proximity = wp.zeros((n, 1), dtype=float)
            self.velocity = wp.zeros((n, 2), dtype=float)
            self.out = wp.zeros((n, OUT_SIZE), dtype=float)
            self.all_worlds = wp.ones(n, dtype=int)
            self.resetting = wp.zeros(n, dtype=int)
            self.active = wp.zeros(n, dtype=int)
            self.bad = wp.zeros(2, dtype=int)
            self.rows = wp.zeros(n, dtype=int)
            self._rays(spec, groups)

    def _rays(self, spec: Any, groups: NDArray[np.int32]) -> None:
        nray = max(self.nray, 1)
        local = np.zeros((nray, 3), dtype=np.float32)
        self.laser_geoms: wp.array[Any] = wp.array(obstacle_geoms(groups == names.OBSTACLE_GROUP))
        self.fan = (0.0, 1.0, 1)  # angle_min, increment, full circle: the culling's ray indices
        if spec is not None:
            self.fan = (spec.angle_min, spec.angle_increment, int(spec.full_circle))
            angles = spec.angles()
            local[:, 0], local[:, 1] = np.cos(angles), np.sin(angles)
        self.local_dirs: wp.array[Any] = wp.array(local, dtype=wp.vec3)
        self.pnt = wp.zeros((self.n, nray), dtype=wp.vec3)
        self.vec = wp.zeros((self.n, nray), dtype=wp.vec3)
        self.dist = wp.zeros((self.n, nray), dtype=float)
        self.geomid = wp.zeros((self.n, nray), dtype=int)
        self.normal = wp.zeros((self.n, nray), dtype=wp.vec3)
        self.bodyexclude = wp.full(nray, -1, dtype=int)
        group = [0] * 6
        group[names.OBSTACLE_GROUP] = 1  # the laser sees walls and obstacles only
        self.geomgroup = vec6(*group)

    def noise_seeds(self, seeds: NDArray[np.int64], chosen: NDArray[np.bool_]) -> None:
        """Each chosen world's noise stream from its seed (laser noise and wheel slip)."""
        host = self.seeds.numpy()
        host[chosen] = (seeds[chosen] % (2**31 - 1)).astype(np.int32)
        self.seeds.assign(host)

    def set_actions(self, actions: Any) -> None:
        """Copy the actions to the device, or a ``ValueError`` (nothing moves) if one is bad."""
        if isinstance(actions, np.ndarray) or not hasattr(actions, "__dlpack__"):
            self.actions.assign(checked_actions(actions, self.n).astype(np.float32))
            return
        source = actions if isinstance(actions, wp.array) else wp.from_dlpack(actions)
        assert isinstance(source, wp.array)
        if source.shape != (self.n, 2):
            raise ValueError(f"actions must have shape ({self.n}, 2), got {source.shape}")
        wp.copy(self.actions, source)
        self.bad.assign(np.array([0, self.n], dtype=np.int32))
        wp.launch(K.check_actions, self.n, inputs=[self.actions, self.bad], device=self.device)
        flag, first = self.bad.numpy().tolist()
        if flag:
            raise ValueError(
                f"actions of robot {first} contain NaN or infinity; actions must be finite "
                "numbers, and are clipped to [-1, 1]; no robot was stepped"
            )

    def physics(self) -> None:
        """Wheel commands, then the substeps with a collision check after each."""
        self._run("physics", self._physics)

    def _physics(self) -> None:
        m, d, n = self.model, self.data, self.n
        wp.launch(K.apply_command, n, inputs=[self.actions, self.settings, d.ctrl, self.out])
        self.collision.zero_()
        for _ in range(self.substeps):
            mjw.step2(m, d)
            mjw.step1(m, d)
            wp.launch(
                K.flag_collisions,
                d.naconmax,
                inputs=[d.nacon, d.contact.geom, d.contact.worldid, self.is_obstacle],
                outputs=[self.collision],
            )

    def _run(self, name: str, body: Any) -> None:
        """``body()`` on the device, replayed as a Warp graph captured on the second call.

        The first call runs it plainly (Warp loads kernels then, which a capture cannot). Warp
        captures on the CPU too (1.19): there a replay skips the Python of ~400 launches, 2.6x
        faster at 32 worlds, with identical results (tests/warp compares them).
        """
        with wp.ScopedDevice(self.device):
            graph = self._graphs.get(name)
            if graph is not None:
                wp.capture_launch(graph)
                return
            body()
            if self.graphs and name in self._seen:
                with wp.ScopedCapture(device=self.device) as capture:
                    body()
                self._graphs[name] = capture.graph
            self._seen.add(name)

    def reset(self, chosen: NDArray[np.bool_], table: LayoutTable, rows: NDArray[np.int32]) -> None:
        """Reset the chosen worlds to ``table``'s ``rows[w]`` (at rest, time 0)."""
        m, d, n = self.model, self.data, self.n
        with wp.ScopedDevice(self.device):
            self.resetting.assign(chosen.astype(np.int32))
            self.rows.assign(rows.astype(np.int32))
            mask: wp.array[Any] = wp.array(chosen, dtype=bool)
            mjw.reset_data(m, d, reset=mask)
            wp.launch(
                K.place_mocaps,
                (n, d.mocap_pos.shape[1]),
                inputs=[self.resetting, self.rows, table.pos, table.quat],
                outputs=[d.mocap_pos, d.mocap_quat],
            )
            wp.launch(
                K.place_geoms,
                (n, self.slot_geoms.shape[0]),
                inputs=[self.resetting, self.rows, self.slot_geoms, table.size, table.rbound],
                outputs=[m.geom_size, m.geom_rbound, m.geom_aabb],
            )
            wp.launch(
                K.place_robots,
                n,
                inputs=[self.resetting, self.rows, table.root, self.settings],
                outputs=[d.qpos],
            )
            # Kinematics, contacts and sensors of the new states: the other worlds' are
            # recomputed from unchanged states, to the same values.
            mjw.step1(m, d)

    def sense(self, active: NDArray[np.bool_] | None, resetting: NDArray[np.bool_]) -> None:
        """The laser, readings, reward, odometry and flags of the ``active`` worlds (None: all)."""
        with wp.ScopedDevice(self.device):
            self.resetting.assign(resetting.astype(np.int32))
            if active is None:
                self._run("sense", lambda: self._sense(self.all_worlds))
                return
            self.active.assign(active.astype(np.int32))
            self._sense(self.active)

    def _sense(self, worlds: wp.array[Any]) -> None:
        m, d, n, s = self.model, self.data, self.n, self.settings
        if self.nray:
            wp.launch(
                K.world_rays,
                (n, self.nray),
                inputs=[d.site_xpos, d.site_xmat, s.laser_site, self.local_dirs],
                outputs=[self.pnt, self.vec],
            )
            self.dist.fill_(math.inf)
            wp.launch(
                culled_laser,
                (n, self.laser_geoms.shape[0]),
                inputs=[
                    self.laser_geoms,
                    m.geom_type,
                    m.geom_size,
                    d.geom_xpos,
                    d.geom_xmat,
                    d.site_xmat,
                    s.laser_site,
                    self.pnt,
                    self.vec,
                    *self.fan,
                ],
                outputs=[self.dist],
            )
            self.nearest.fill_(math.inf)
            wp.launch(
                K.laser_readings,
                (n, self.nray),
                inputs=[self.dist, s, self.seeds, self.state, worlds],
                outputs=[self.laser, self.nearest],
            )
        wp.launch(
            K.sense,
            n,
            inputs=[
                d.sensordata,
                d.qpos,
                d.qvel,
                d.time,
                s,
                self.collision,
                self.nearest,
                self.seeds,
                worlds,
                self.resetting,
            ],
            outputs=[self.state, self.odometry, self.proximity, self.velocity, self.out],
        )

    def mujoco_rays(self) -> wp.array[Any]:
        """``mujoco_warp.rays`` for the laser's rays of the current state (-1: no hit).

        What the culled kernel replaced; the tests' reference and ``bench/warp_speed.py --split``'s.
        """
        with wp.ScopedDevice(self.device):
            out = wp.zeros_like(self.dist)
            mjw.rays(
                self.model,
                self.data,
                self.pnt,
                self.vec,
                self.geomgroup,
                True,
                self.bodyexclude,
                out,
                self.geomid,
                self.normal,
            )
        return out

    def fetch(self, rewards: NDArray[np.float64] | None = None, laser: bool = True) -> HostCopy:
        """The host's copy of the step (``rewards``: keep these, a SameStep reset's pass).

        ``laser=False`` leaves the scans on the device (an empty host array): at 64k worlds they
        are 94 MB a step, which a learner reading them on the device does not need.
        """
        overflow = self.data.overflow.numpy() & _FATAL_OVERFLOWS
        if overflow.any():
            world = int(np.flatnonzero(overflow)[0])
            kind = OverflowType(int(overflow[world]))
            raise RuntimeError(
                f"world {world}: MuJoCo Warp's buffers overflowed ({kind!r}; contacts or "
                "constraints were dropped); raise "
                "bubblerob_env.mjwarp.device.CONTACTS_PER_WORLD or CONSTRAINTS_PER_WORLD"
            )
        out = self.out.numpy().astype(np.float64)
        state = self.state.numpy()
        return HostCopy(
            out=out,
            laser=self.laser.numpy()[:, : self.nray].copy()
            if laser
            else np.zeros((0, 0), np.float32),
            proximity=self.proximity.numpy().copy(),
            velocity=self.velocity.numpy().copy(),
            odometry=self.odometry.numpy()[:, :3].astype(np.float64),
            rewards=out[:, int(OUT.REWARD)].copy() if rewards is None else rewards,
            terminated=state[:, K.TERMINATED] != 0,
            truncated=state[:, K.TRUNCATED] != 0,
            diverged=out[:, int(OUT.DIVERGED)] != 0.0,
            collided=state[:, K.COLLIDED] != 0,
            clipped_actions=state[:, K.CLIPPED_COUNT].astype(np.int64),
        )

    def device_observations(self, obs_mode: str) -> Any:
        """The observations as new device arrays: a dict, or one flat array."""
        with wp.ScopedDevice(self.device):
            if obs_mode == "flat":
                flat = wp.empty((self.n, self.nray + 3), dtype=float)
                wp.launch(
                    K.flatten_observations,
                    self.n,
                    inputs=[self.laser, self.nray, self.proximity, self.velocity],
                    outputs=[flat],
                )
                return flat
            parts = {"laser": self.laser} if self.nray else {}
            parts.update(proximity=self.proximity, velocity=self.velocity)
            return {key: wp.clone(array) for key, array in parts.items()}

    def device_results(
        self,
        rewards: NDArray[np.float64],
        terminated: NDArray[np.bool_],
        truncated: NDArray[np.bool_],
    ) -> tuple[wp.array[Any], wp.array[Any], wp.array[Any]]:
        """Rewards (float32), terminations and truncations (bool) as new device arrays.

        From the host, where the step's autoresets were settled (a SameStep reset has already
        zeroed the device's reward of a world whose episode ended).
        """
        with wp.ScopedDevice(self.device):
            return (
                wp.array(rewards.astype(np.float32), dtype=float),
                wp.array(terminated, dtype=bool),
                wp.array(truncated, dtype=bool),
            )
