"""Every robot of a world starts where a lone robot rests (issue #41's rest pose), not tangent
to the floor, and not at the tumbled pose a settle of robots compiled on top of each other gives.
"""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("pettingzoo")

import bubblerob_env  # noqa: E402
from bubblerob_env.config import EnvConfig  # noqa: E402
from bubblerob_env.scene import Scene  # noqa: E402


@pytest.mark.parametrize(("robot", "num_robots"), [("bubblerob", 4), ("pioneer_p3dx", 3)])
def test_every_robot_starts_at_a_lone_robots_rest(robot, num_robots):
    alone = Scene(EnvConfig.from_kwargs({} if robot == "bubblerob" else {"robot": robot}))
    env = bubblerob_env.parallel_env(num_robots=num_robots, robot=robot)
    env.reset(seed=3)
    world = env.unwrapped.world
    data = world.scene.data
    for ids in world.robots:
        root = data.qpos[ids.root_qpos : ids.root_qpos + 7]
        assert root[2] == pytest.approx(alone.rest_height, abs=1e-9)
        # Upright as the lone robot rests: the same tilt, up to the heading.
        up = np.array([2 * (root[4] * root[6] + root[3] * root[5]),
                       2 * (root[5] * root[6] - root[3] * root[4]),
                       1 - 2 * (root[4] ** 2 + root[5] ** 2)])  # fmt: skip
        w, x, y, _ = alone.rest_tilt
        lone_up_z = 1 - 2 * (x**2 + y**2)
        assert up[2] == pytest.approx(lone_up_z, abs=1e-9)
    # At rest: every robot sinks into its floor contacts, none falls.
    dist = [data.contact[i].dist for i in range(data.ncon)]
    assert len(dist) >= 3 * num_robots and max(dist) < -1e-5
    env.close()
