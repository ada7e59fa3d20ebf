"""A world of N robots: one MuJoCo model, each robot's ids, laser windows and cameras.

Robot 0 is the scene's own robot with its plain MJCF names; robots 1 .. N-1 are the robot's
MJCF attached again (``MjSpec.attach``) under the prefix ``robot_<k>/``, so every robot
collides with every other (robot geoms have contype 1, conaffinity 3). With several robots each
one carries a laser window (:data:`WINDOW_GEOM`): a cylinder of the robot's
``laser.window`` size centred on its laser's plane, on its base body, in geom group
:data:`WINDOW_GROUP`, with no contacts and no mass (base bodies have explicit inertials). That is
what another robot's laser sees of it, as a real lidar sees another robot's lidar: nothing else
of a BubbleRob reaches the laser's plane (0.18 m; the chassis ends at 0.165 m). The windows are
added here and not in the robots' MJCF, so the single-robot envs' models stay as they were. A
world of one robot is exactly the single env's model.

The composed world is written once as an MJCF file in the temporary directory (named by its
content's hash) and built by :class:`~bubblerob_env.scene.Scene` like any scene: the arena's
walls resized, the obstacle slots added, robot 0's sensors and caster chosen as ever.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import os
import tempfile
from pathlib import Path

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names
from bubblerob_env.config import EnvConfig
from bubblerob_env.core.worlds import NO_CONTACT, OBSTACLE_CONTACT, RobotIds
from bubblerob_env.scene import Scene, resting_pose
from bubblerob_env.sensors import CameraSensor, CameraSpec

__all__ = [
    "WINDOW_GEOM",
    "WINDOW_GROUP",
    "RobotCamera",
    "WorldScene",
    "agent_name",
    "partner_name",
    "robot_prefix",
]

WINDOW_GEOM = "laser_window"
WINDOW_GROUP = 3
"""The laser windows' geom group: the laser casts against groups 0 (walls, obstacles) and 3."""
_WINDOW_RGBA = (0.1, 0.1, 0.12, 1.0)


def robot_prefix(k: int) -> str:
    """Robot ``k``'s MJCF name prefix in a world: ``""`` for robot 0, else ``robot_<k>/``."""
    return "" if k == 0 else f"robot_{k}/"


def agent_name(robot: str, k: int) -> str:
    """Robot ``k``'s agent name in a world of ``robot`` robots: ``bubblerob_0``, ..."""
    return f"{robot}_{k}"


def partner_name(partner: int, robot: str) -> str:
    """What a robot touched (:class:`~bubblerob_env.core.worlds.WorldBatch`'s ``partner``)."""
    if partner == OBSTACLE_CONTACT:
        return "obstacle"
    return "" if partner == NO_CONTACT else agent_name(robot, partner)


class RobotCamera(CameraSensor):
    """The front camera of robot ``prefix`` (another robot's than the scene's own)."""

    def __init__(self, model: mujoco.MjModel, spec: CameraSpec, prefix: str) -> None:
        super().__init__(model, spec)
        self._camera = model.camera(prefix + names.FRONT_CAMERA).id


def world_file(config: EnvConfig, num_robots: int) -> Path:
    """The scene file of ``config`` with ``num_robots`` robots (the scene's own for one)."""
    if num_robots == 1:
        return config.xml_file
    spec = mujoco.MjSpec.from_file(str(config.xml_file))
    for k in range(1, num_robots):
        robot = mujoco.MjSpec.from_file(str(config.robot.robot_file))
        spec.worldbody.add_frame().attach_body(robot.body(names.BASE_BODY), robot_prefix(k), "")
    alone = mujoco.MjModel.from_xml_path(str(config.robot.robot_file))
    laser_pos = alone.site_pos[alone.site(names.LASER_SITE).id].tolist()
    radius, half_height = config.robot.laser.window
    for k in range(num_robots):
        spec.body(robot_prefix(k) + names.BASE_BODY).add_geom(
            name=robot_prefix(k) + WINDOW_GEOM,
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[radius, half_height, 0.0],
            pos=laser_pos,
            contype=0,
            conaffinity=0,
            group=WINDOW_GROUP,
            mass=0.0,
            rgba=list(_WINDOW_RGBA),
        )
    xml = spec.to_xml()
    digest = hashlib.sha256(xml.encode()).hexdigest()[:16]
    folder = Path(tempfile.gettempdir()) / "bubblerob-worlds"
    folder.mkdir(exist_ok=True)
    path = folder / f"{config.robot.name}-{num_robots}-{digest}.xml"
    if not path.is_file():
        # Written whole, then renamed: processes building the same world at once never read
        # a partial file.
        partial = path.with_suffix(f".{os.getpid()}.part")
        partial.write_text(xml)
        partial.replace(path)
    return path


_SETTLE_APART = 10.0
"""Metres between the robots (along x) while the world's rest pose is found."""


class WorldScene:
    """``num_robots`` robots of ``config`` in one world (:class:`Scene` holds robot 0's parts).

    ``robots[k]``: robot ``k``'s ids; ``geom_robot``: each geom's robot (-1: the world's);
    ``cameras[k]``: robot ``k``'s camera (``None`` without the camera).
    """

    def __init__(self, config: EnvConfig, num_robots: int, arena_memory: int | None = None):
        self.num_robots = num_robots
        path = world_file(config, num_robots)
        self.scene = Scene(dataclasses.replace(config, xml_file=path), arena_memory)
        model = self.scene.model
        self.robots = tuple(_robot_ids(model, robot_prefix(k)) for k in range(num_robots))
        self.window_group = WINDOW_GROUP if num_robots > 1 else None
        self.geom_robot = _geom_robots(model, self.robots)
        self.dofs = tuple(_dof_range(model, robot.base_body) for robot in self.robots)
        """Each robot's ``(first, count)`` in ``qvel``."""
        if num_robots > 1:
            # The robots are compiled on top of each other: the scene's own settle saw them
            # tumble. Each robot rests as robot 0 does alone, the others moved far off first.
            data = mujoco.MjData(model)
            for k, robot in enumerate(self.robots[1:], start=1):
                data.qpos[robot.root_qpos] += _SETTLE_APART * k
            self.scene.rest_height, self.scene.rest_tilt = resting_pose(
                model, self.robots[0].root_qpos, data
            )
        self.cameras: list[CameraSensor | None] = [self.scene.camera]
        spec = self.scene.camera_spec
        for k in range(1, num_robots):
            self.cameras.append(None if spec is None else RobotCamera(model, spec, robot_prefix(k)))

    def place_robot(self, k: int, pose: tuple[float, float, float]) -> None:
        """Put robot ``k`` at ``pose`` (x, y, yaw), resting on the floor (issue #41's rest pose)."""
        scene, data = self.scene, self.scene.data
        x, y, yaw = pose
        adr = self.robots[k].root_qpos
        data.qpos[adr : adr + 3] = (x, y, scene.rest_height)
        heading = np.array([np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)])
        mujoco.mju_mulQuat(data.qpos[adr + 3 : adr + 7], heading, scene.rest_tilt)
        first, count = self.dofs[k]
        data.qvel[first : first + count] = 0.0

    def spawn(self) -> WorldScene:
        """A new world of the same config (:meth:`Scene.spawn`: call it before any reset)."""
        clone = copy.copy(self)
        clone.scene = self.scene.spawn()
        clone.cameras = [clone.scene.camera]
        spec = clone.scene.camera_spec
        model = clone.scene.model
        for k in range(1, self.num_robots):
            clone.cameras.append(
                None if spec is None else RobotCamera(model, spec, robot_prefix(k))
            )
        return clone

    def camera_image(self, k: int) -> NDArray[np.uint8] | None:
        """Robot ``k``'s camera frame, or ``None`` without the camera."""
        camera = self.cameras[k]
        if camera is None:
            return None
        return camera(self.scene.model, self.scene.data)

    def close(self) -> None:
        """Free every camera's OpenGL context."""
        for camera in self.cameras[1:]:
            if camera is not None:
                camera.close()
        self.scene.close()


def _robot_ids(model: mujoco.MjModel, prefix: str) -> RobotIds:
    first_sensor = names.PROXIMITY_SENSOR
    shift = int(model.sensor(prefix + first_sensor).adr[0] - model.sensor(first_sensor).adr[0])
    for sensor in (names.VELOCIMETER_SENSOR, names.GYRO_SENSOR, names.LEFT_WHEEL_SPEED_SENSOR):
        own = int(model.sensor(prefix + sensor).adr[0] - model.sensor(sensor).adr[0])
        if own != shift:
            raise ValueError(f"robot {prefix!r}: its sensors are not laid out as robot 0's")
    left = model.actuator(prefix + names.LEFT_MOTOR).id
    if model.actuator(prefix + names.RIGHT_MOTOR).id != left + 1:
        raise ValueError(f"robot {prefix!r}: its right motor does not follow its left motor")
    try:
        window = model.geom(prefix + WINDOW_GEOM).id
    except KeyError:
        window = -1
    return RobotIds(
        base_body=model.body(prefix + names.BASE_BODY).id,
        root_qpos=int(model.joint(prefix + names.ROOT_JOINT).qposadr[0]),
        laser_site=model.site(prefix + names.LASER_SITE).id,
        actuator=left,
        sensor_shift=shift,
        window=window,
    )


def _dof_range(model: mujoco.MjModel, base_body: int) -> tuple[int, int]:
    """``(first, count)`` of the degrees of freedom of the robot rooted at ``base_body``."""
    bodies = np.flatnonzero(model.body_rootid == base_body)
    return int(model.body_dofadr[base_body]), int(model.body_dofnum[bodies].sum())


def _geom_robots(model: mujoco.MjModel, robots: tuple[RobotIds, ...]) -> NDArray[np.int32]:
    """Each geom's robot index (the robot whose base body is its root body), -1 for the world."""
    robot_of_root = {robot.base_body: k for k, robot in enumerate(robots)}
    roots = model.body_rootid[model.geom_bodyid]
    return np.array([robot_of_root.get(int(root), -1) for root in roots], dtype=np.int32)
