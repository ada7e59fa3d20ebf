"""BubbleRob's sensors: callables ``(model, data) -> np.ndarray`` with frozen spec dataclasses.

The specs carry everything a consumer needs to interpret a reading without MuJoCo, for example the
ROS layer building ``sensor_msgs/LaserScan``, ``sensor_msgs/Range`` or ``sensor_msgs/CameraInfo``.
All readings are of the state in ``data`` as it is: call them after the kinematics are current.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from bubblerob_env import names

__all__ = [
    "CameraSensor",
    "CameraSpec",
    "Laser",
    "LaserSpec",
    "ProximitySensor",
    "ProximitySpec",
    "RADIATION_TYPES",
    "StaticTransform",
    "static_transforms",
]

_FULL_CIRCLE = 2.0 * math.pi


@dataclass(frozen=True)
class LaserSpec:
    """Geometry of the 2D laser scan, in ``sensor_msgs/LaserScan`` terms.

    Ray ``i`` points at ``angle_min + i * angle_increment`` (radians, counter-clockwise positive,
    0 = +x of ``frame_id``). A full circle has ``num_rays`` rays ``2*pi/num_rays`` apart and no
    duplicate ray at +pi; a smaller field of view puts its first and last rays on its edges.

    Readings are distances in metres along each ray. A ray that hits nothing within ``range_max``
    reads exactly ``range_max`` in the observation (observations stay finite); the ROS layer turns
    ``reading >= range_max`` into ``+inf`` and ``reading < range_min`` into ``-inf`` (REP 117).
    """

    num_rays: int
    fov: float
    range_min: float
    range_max: float
    noise_std: float = 0.0
    frame_id: str = names.LASER_SITE
    scan_time: float = 0.05
    caster: str = "mujoco"
    """Which caster produces the readings: ``"analytic"`` (exact rays against the scene's
    boxes and cylinders, :mod:`bubblerob_env.core.raycast`) or ``"mujoco"`` (``mj_multiRay``).
    Both give the same readings where the analytic one applies."""

    def __post_init__(self) -> None:
        if self.num_rays < 1:
            raise ValueError(f"laser num_rays must be >= 1, got {self.num_rays}")
        if not 0.0 < self.fov <= _FULL_CIRCLE + 1e-9:
            raise ValueError(f"laser fov must be in (0, 2*pi] radians, got {self.fov}")
        if self.num_rays == 1 and self.fov < _FULL_CIRCLE - 1e-9:
            raise ValueError("a laser with one ray needs fov = 2*pi (its ray then points along +x)")
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(
                f"laser needs 0 <= range_min < range_max, got {self.range_min}, {self.range_max}"
            )
        if self.noise_std < 0.0 or not math.isfinite(self.noise_std):
            raise ValueError(f"laser noise_std must be finite and >= 0, got {self.noise_std}")

    @property
    def full_circle(self) -> bool:
        """Whether the scan covers 360 degrees."""
        return self.fov >= _FULL_CIRCLE - 1e-9

    @property
    def angle_increment(self) -> float:
        """Angle between neighbouring rays (radians)."""
        if self.full_circle:
            return _FULL_CIRCLE / self.num_rays
        return self.fov / (self.num_rays - 1)

    @property
    def angle_min(self) -> float:
        """Angle of ray 0 (radians)."""
        return -math.pi if self.full_circle else -self.fov / 2.0

    @property
    def angle_max(self) -> float:
        """Angle of the last ray (radians)."""
        return self.angle_min + (self.num_rays - 1) * self.angle_increment

    def angles(self) -> NDArray[np.float64]:
        """Angle of every ray, ray 0 first (radians)."""
        return self.angle_min + self.angle_increment * np.arange(self.num_rays, dtype=np.float64)


RADIATION_TYPES = ("ULTRASOUND", "INFRARED")
"""``sensor_msgs/Range`` radiation types a :class:`ProximitySpec` can report."""


@dataclass(frozen=True)
class ProximitySpec:
    """The nose proximity sensor: one ray along +x of ``frame_id``, like the seed's ``FrontUS``.

    A reading is the distance to the nearest obstacle straight ahead, or ``range_max`` when nothing
    is within range. ``triggered`` (the seed's ``sensorTrigger``) is ``reading < trigger_distance``.
    ``field_of_view`` and ``radiation_type`` (``"ULTRASOUND"``, like the seed's ultrasonic
    ``FrontUS``, or ``"INFRARED"``) are what the ROS ``sensor_msgs/Range`` message reports for it.
    """

    range_max: float
    trigger_distance: float
    range_min: float = 0.0
    field_of_view: float = 0.05
    frame_id: str = names.PROXIMITY_SITE
    radiation_type: str = "ULTRASOUND"

    def __post_init__(self) -> None:
        if self.radiation_type not in RADIATION_TYPES:
            raise ValueError(
                f"proximity radiation_type must be one of {list(RADIATION_TYPES)}, "
                f"got {self.radiation_type!r}"
            )
        if not 0.0 <= self.range_min < self.range_max:
            raise ValueError(
                "proximity needs 0 <= range_min < range_max, "
                f"got {self.range_min}, {self.range_max}"
            )
        if not 0.0 < self.trigger_distance <= self.range_max:
            raise ValueError(
                f"proximity trigger_distance must be in (0, range_max={self.range_max}], "
                f"got {self.trigger_distance}"
            )

    def triggered(self, reading: float) -> bool:
        """The seed's ``sensorTrigger``: something is closer than ``trigger_distance``."""
        return bool(reading < self.trigger_distance)


@dataclass(frozen=True)
class CameraSpec:
    """The forward RGB camera. Images are ``uint8`` arrays of shape ``(height, width, 3)``, RGB.

    ``fovy`` is MuJoCo's vertical field of view in degrees; pixels are square, so the pinhole
    focal length is ``fy = fx = height / (2 * tan(fovy / 2))`` with the principal point at the
    image centre. ``frame_id`` is the optical frame (z forward, x right, y down; REP 103).
    """

    width: int
    height: int
    fovy: float
    shadows: bool = False
    reflections: bool = False
    frame_id: str = "camera_optical_frame"

    def __post_init__(self) -> None:
        for label, value in (("width", self.width), ("height", self.height)):
            if not 1 <= value <= 4096:
                raise ValueError(f"camera {label} must be in [1, 4096] pixels, got {value}")

    @property
    def focal_length(self) -> float:
        """Focal length in pixels (same along x and y)."""
        return self.height / (2.0 * math.tan(math.radians(self.fovy) / 2.0))

    def intrinsics(self) -> NDArray[np.float64]:
        """The 3x3 pinhole matrix K, as in ``sensor_msgs/CameraInfo``."""
        f = self.focal_length
        return np.array(
            [[f, 0.0, (self.width - 1) / 2.0], [0.0, f, (self.height - 1) / 2.0], [0.0, 0.0, 1.0]]
        )


@dataclass(frozen=True)
class StaticTransform:
    """A fixed transform ``parent -> child`` (``/tf_static``): ``child``'s pose in ``parent``.

    ``rotation_xyzw`` is a unit quaternion in ROS order (x, y, z, w).
    """

    parent: str
    child: str
    translation: tuple[float, float, float]
    rotation_xyzw: tuple[float, float, float, float]


def _vector3(values: NDArray[np.float64]) -> tuple[float, float, float]:
    # Rounded so that values like 0.049999999999999996 read as the MJCF's 0.05.
    x, y, z = (round(float(v), 9) for v in values)
    return (x, y, z)


def _rotation_to_quat_xyzw(matrix: NDArray[np.float64]) -> tuple[float, float, float, float]:
    quat_wxyz = np.empty(4)
    mujoco.mju_mat2Quat(quat_wxyz, np.ascontiguousarray(matrix).reshape(9))
    if quat_wxyz[0] < 0:  # one canonical sign, so equal frames compare equal
        quat_wxyz = -quat_wxyz
    w, x, y, z = (float(v) for v in quat_wxyz)
    return (x, y, z, w)


_SENSOR_FRAMES = (names.LASER_SITE, names.PROXIMITY_SITE, names.CAMERA_SITE)


def static_transforms(
    model: mujoco.MjModel, frames: tuple[str, ...] = _SENSOR_FRAMES
) -> tuple[StaticTransform, ...]:
    """Fixed transforms from ``base_link`` to each sensor frame (a site), from the compiled model.

    ``frames``: the robot description's sensor frames; the camera's must be among them.

    Includes ``camera_link -> camera_optical_frame`` (optical convention: z forward, x right, y
    down), derived from the MuJoCo camera, which looks along its -z with +y up.
    """
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    mujoco.mj_camlight(model, data)  # camera poses are not part of mj_kinematics
    base = model.body(names.BASE_BODY).id
    base_pos = data.xpos[base]
    base_rot = data.xmat[base].reshape(3, 3)

    def relative(
        pos: NDArray[np.float64], rot: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        return base_rot.T @ (pos - base_pos), base_rot.T @ rot

    transforms = []
    for site in frames:
        sid = model.site(site).id
        pos, rot = relative(data.site_xpos[sid], data.site_xmat[sid].reshape(3, 3))
        transforms.append(
            StaticTransform(
                names.BASE_BODY,
                site,
                _vector3(pos),
                _rotation_to_quat_xyzw(rot),
            )
        )
    cam = model.camera(names.FRONT_CAMERA).id
    cam_site = model.site(names.CAMERA_SITE).id
    site_rot = data.site_xmat[cam_site].reshape(3, 3)
    # MuJoCo camera axes (x right, y up, z back) -> optical axes (x right, y down, z forward).
    optical_rot = data.cam_xmat[cam].reshape(3, 3) @ np.diag([1.0, -1.0, -1.0])
    offset = site_rot.T @ (data.cam_xpos[cam] - data.site_xpos[cam_site])
    transforms.append(
        StaticTransform(
            names.CAMERA_SITE,
            "camera_optical_frame",
            _vector3(offset),
            _rotation_to_quat_xyzw(site_rot.T @ optical_rot),
        )
    )
    return tuple(transforms)


class Laser:
    """A planar laser scanner cast with one ``mj_multiRay`` call from the ``laser_link`` site.

    Rays see only geom group 0 (walls and obstacles): the robot's own geoms (group 2) and the floor
    (group 1) are skipped without an intersection test, and geoms whose bounding sphere is farther
    than ``range_max`` are culled by the cutoff.
    """

    def __init__(self, model: mujoco.MjModel, spec: LaserSpec) -> None:
        self.spec = spec
        self._site = model.site(names.LASER_SITE).id
        angles = spec.angles()
        self._local_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)
        self._geomgroup = np.zeros(6, dtype=np.uint8)
        self._geomgroup[names.OBSTACLE_GROUP] = 1

    def __call__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        rng: np.random.Generator | None = None,
    ) -> NDArray[np.float32]:
        """Scan once; noise (if the spec has any) is drawn from ``rng``."""
        site = self._site
        rot = data.site_xmat[site].reshape(3, 3)
        world_dirs = self._local_dirs @ rot.T
        dist = np.empty(self.spec.num_rays)
        mujoco.mj_multiRay(
            model,
            data,
            data.site_xpos[site],
            world_dirs.reshape(-1),
            self._geomgroup,
            1,
            -1,
            np.empty(self.spec.num_rays, dtype=np.int32),
            dist,
            None,
            self.spec.num_rays,
            self.spec.range_max,
        )
        return self.finish(dist, rng)

    def endpoints(
        self, data: mujoco.MjData, readings: NDArray[np.float32]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """World positions of the laser origin and of each ray's end at ``readings`` metres."""
        origin = data.site_xpos[self._site].copy()
        directions = self._local_dirs @ data.site_xmat[self._site].reshape(3, 3).T
        return origin, origin + directions * readings[:, None].astype(np.float64)

    def finish(
        self, dist: NDArray[np.float64], rng: np.random.Generator | None = None
    ) -> NDArray[np.float32]:
        """Turn raw ray distances (-1 = no hit) into readings: noise on hits, no hit = range_max."""
        spec = self.spec
        hit = (dist >= 0.0) & (dist < spec.range_max)
        reading = np.where(hit, dist, spec.range_max)
        if spec.noise_std > 0.0 and rng is not None:
            noisy = reading + rng.normal(0.0, spec.noise_std, size=reading.shape)
            # A noisy hit stays a hit: it may not reach range_max, the "no return" value.
            reading = np.where(hit, np.clip(noisy, 0.0, np.nextafter(spec.range_max, 0)), reading)
        return reading.astype(np.float32)


class ProximitySensor:
    """The nose rangefinder (MuJoCo ``rangefinder`` sensor on the ``proximity_ray`` site)."""

    def __init__(self, model: mujoco.MjModel, spec: ProximitySpec) -> None:
        self.spec = spec
        self._adr = int(model.sensor(names.PROXIMITY_SENSOR).adr[0])

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> NDArray[np.float32]:
        """Distance straight ahead, shape ``(1,)``; ``range_max`` when nothing is within range."""
        dist = float(data.sensordata[self._adr])
        if dist < 0.0 or dist > self.spec.range_max:  # -1 means the ray hit nothing
            dist = self.spec.range_max
        return np.array([dist], dtype=np.float32)


class CameraSensor:
    """The forward RGB camera, rendered offscreen with ``mujoco.Renderer``.

    Shadows and reflections are off unless the spec asks for them: on Mesa's CPU renderer they
    cost about 15x per frame. The OpenGL context is made on the first frame, not here, so an env
    can be built in a parent process that then forks (``AsyncVectorEnv``, SB3's
    ``SubprocVecEnv``): an EGL context does not survive a fork. Nor do Mesa's rendering threads
    once the parent has rendered anything: a worker forked then raises
    :class:`~bubblerob_env.rendering.ForkedAfterRenderingError`, naming the fix, instead of
    hanging on its first frame.
    """

    def __init__(self, model: mujoco.MjModel, spec: CameraSpec) -> None:
        self.spec = spec
        self._model = model
        self._renderer: mujoco.Renderer | None = None
        self._camera = model.camera(names.FRONT_CAMERA).id
        self._option = self._scene_option()

    @staticmethod
    def _scene_option() -> mujoco.MjvOption:
        # MuJoCo draws rangefinder rays by default: the camera must not see the nose sensor's.
        option = mujoco.MjvOption()
        option.flags[mujoco.mjtVisFlag.mjVIS_RANGEFINDER] = False
        return option

    def __getstate__(self) -> dict[str, object]:
        # An OpenGL context (and MjvOption) cannot be pickled or copied: the copy makes its own.
        state = {**self.__dict__, "_renderer": None}
        del state["_option"]
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        self.__dict__.update(state)
        self._option = self._scene_option()

    def _make_renderer(self) -> mujoco.Renderer:
        # A child forked after its parent rendered would hang here: one clear error instead.
        from bubblerob_env.rendering import check_fork_safe  # rendering imports no sensors

        check_fork_safe("the camera")
        renderer = mujoco.Renderer(self._model, self.spec.height, self.spec.width)
        flags = renderer.scene.flags
        flags[mujoco.mjtRndFlag.mjRND_SHADOW] = self.spec.shadows
        flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = self.spec.reflections
        flags[mujoco.mjtRndFlag.mjRND_SKYBOX] = False
        return renderer

    def __call__(self, model: mujoco.MjModel, data: mujoco.MjData) -> NDArray[np.uint8]:
        """One frame, ``(height, width, 3)`` ``uint8``."""
        if self._renderer is None:
            self._renderer = self._make_renderer()
        self._renderer.update_scene(data, camera=self._camera, scene_option=self._option)
        frame: NDArray[np.uint8] = self._renderer.render()
        return frame

    def close(self) -> None:
        """Free the OpenGL context, if one was made."""
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
