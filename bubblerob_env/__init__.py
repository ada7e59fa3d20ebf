"""BubbleRob in MuJoCo as a Gymnasium environment: ``gym.make("BubbleRob-v0")``.

Importing this package registers one env id per robot (:data:`bubblerob_env.robots.ROBOTS`):
``BubbleRob-v0`` and ``PioneerP3DX-v0``, and its goal-reaching task (:mod:`bubblerob_env.tasks`):
``BubbleRobNav-v0`` and ``PioneerP3DXNav-v0``. Without a display, and unless ``MUJOCO_GL`` is
already set, it selects MuJoCo's headless EGL backend, so that the camera and
``render_mode="rgb_array"`` work on servers.
"""

from __future__ import annotations

from bubblerob_env._headless import use_egl_without_display

use_egl_without_display()

from typing import Any  # noqa: E402

from gymnasium.envs.registration import register  # noqa: E402

from bubblerob_env.arena import ArenaLayout, Obstacle  # noqa: E402
from bubblerob_env.env import ACTION_TYPES, OBS_MODES, BubbleRobEnv  # noqa: E402
from bubblerob_env.kinematics import DiffDrive  # noqa: E402
from bubblerob_env.robots import ROBOTS, RobotDescription  # noqa: E402
from bubblerob_env.sensors import (  # noqa: E402
    CameraSpec,
    LaserSpec,
    ProximitySpec,
    StaticTransform,
)
from bubblerob_env.specs import EnvSpecs  # noqa: E402
from bubblerob_env.topdown import TopDownRenderer  # noqa: E402
from bubblerob_env.vector import BubbleRobVectorEnv  # noqa: E402
from bubblerob_env.wrappers import EpisodeSuccess, LaserPooling, TopDownView  # noqa: E402

__all__ = [
    "ACTION_TYPES",
    "OBS_MODES",
    "ArenaLayout",
    "BubbleRobEnv",
    "BubbleRobVectorEnv",
    "CameraSpec",
    "DiffDrive",
    "EnvSpecs",
    "EpisodeSuccess",
    "LaserPooling",
    "LaserSpec",
    "Obstacle",
    "ProximitySpec",
    "RobotDescription",
    "StaticTransform",
    "TopDownRenderer",
    "TopDownView",
    "parallel_env",
]
__version__ = "0.1.0"


def parallel_env(num_robots: int = 2, robot: str = "bubblerob", **kwargs: Any) -> Any:
    """Several robots in one world, a PettingZoo ``ParallelEnv`` (the ``multi`` extra).

    See :func:`bubblerob_env.multi.parallel_env`; imported on call, so the package needs no
    PettingZoo.
    """
    try:
        from bubblerob_env.multi import parallel_env as make_parallel_env
    except ModuleNotFoundError as error:
        if error.name != "pettingzoo":
            raise
        raise ModuleNotFoundError(
            "bubblerob_env.parallel_env needs the [multi] extra: pip install 'bubblerob[multi]'",
            name="pettingzoo",
        ) from None
    return make_parallel_env(num_robots, robot, **kwargs)


for _robot in ROBOTS.values():
    register(
        id=_robot.env_id,
        entry_point="bubblerob_env.env:BubbleRobEnv",
        # gym.make_vec(..., vectorization_mode="vector_entry_point"): N robots stepped per call
        # (backend="cpu", the default, or backend="warp": bubblerob_env.backends).
        vector_entry_point="bubblerob_env.backends:make_vector_env",
        max_episode_steps=1000,
        # The env's default robot takes no kwarg: BubbleRob-v0's spec (and the env_kwargs its
        # bags record) stay {}.
        kwargs={} if _robot.name == "bubblerob" else {"robot": _robot.name},
    )
    # The goal-reaching task on the same robot (issue #37): BubbleRobNav-v0, PioneerP3DXNav-v0.
    _name, _version = _robot.env_id.rsplit("-", 1)
    register(
        id=f"{_name}Nav-{_version}",
        entry_point="bubblerob_env.tasks.nav:BubbleRobNavEnv",
        max_episode_steps=1000,
        kwargs={} if _robot.name == "bubblerob" else {"robot": _robot.name},
    )
