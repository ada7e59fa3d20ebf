"""The device laser's culling drops no hit: it reads what ``mujoco_warp.rays`` reads (issue #41).

The oracle is MuJoCo Warp's own ray cast over every geom of the model, on the same states and
the same rays (``Worlds.mujoco_rays``), on Warp's CPU device: a full circle and a forward fan,
robots driven into walls and obstacles (tilted on impact), seeds not used to build the kernel.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

pytest.importorskip("mujoco_warp")
from bubblerob_env.mjwarp import WarpVectorEnv  # noqa: E402

DEVICE = "cpu"


@pytest.mark.parametrize(
    "kwargs",
    [{}, {"laser_fov": 4.0, "laser_num_rays": 181}],
    ids=["full-circle", "fan"],
)
def test_culled_laser_reads_what_mujoco_warp_rays_reads(kwargs: dict[str, Any]) -> None:
    env = WarpVectorEnv(8, device=DEVICE, max_episode_steps=60, layout_bank=8, **kwargs)
    env.reset(seed=8100)
    rng = np.random.default_rng(8100)
    worst, hits, compared, tilted = 0.0, 0, 0, 0
    for step in range(60):
        actions = rng.uniform(-0.3, 1.0, (env.num_envs, 2)).astype(np.float32)
        env.step(actions)
        if step % 6:
            continue
        worlds = env.worlds
        culled = worlds.dist.numpy()
        reference = worlds.mujoco_rays().numpy()
        missed = reference < 0
        # A ray that hits nothing reads +inf here and -1 there; every other ray the same metres.
        assert np.array_equal(np.isinf(culled), missed)
        worst = max(worst, float(np.abs(culled[~missed] - reference[~missed]).max()))
        hits += int((~missed).sum())
        compared += culled.size
        xmat = worlds.data.site_xmat.numpy()[:, worlds.settings.laser_site]
        tilted += int((np.abs(xmat[:, 2, 2]) < 1 - 1e-6).sum())
    assert compared == 10 * env.num_envs * culled.shape[1]
    assert hits > compared // 2
    assert tilted > 0  # the culling's tilted-scanner path ran
    print(f"worst {worst:.3g} m over {hits} hits, {tilted} tilted scans")
    assert worst <= 1e-6, f"culled laser {worst} m from mujoco_warp.rays"
