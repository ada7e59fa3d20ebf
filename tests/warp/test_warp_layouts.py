"""Seeded resets at scale (issue #41, item 4): the numba layout draw is the CPU env's, exactly.

Oracles: numpy's own ``PCG64(SeedSequence(seed))`` (the generator), CPython's ``math.hypot``
(the distances the draw compares), ``sample_layout`` on ``seeding.np_random(seed)`` (the draw)
and, for the table rows, what ``gym.make``'s env puts into MuJoCo when reset with the seed.
"""

from __future__ import annotations

import math
import time
import warnings
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

pytest.importorskip("mujoco_warp")
from bubblerob_env.arena import sample_layout  # noqa: E402
from bubblerob_env.env import BubbleRobEnv  # noqa: E402
from bubblerob_env.mjwarp.layout_draw import (  # noqa: E402
    CYLINDER,
    draw_layouts,
    hypot,
    pcg64_raw,
)
from bubblerob_env.mjwarp.layouts import layout_rows, slot_geoms  # noqa: E402


@pytest.mark.parametrize("seed", [0, 1, 5000, 2**31 - 2, 2**32, 2**40 + 3, 2**63 - 1])
def test_the_generator_is_numpys_pcg64_seeded_by_seedsequence(seed: int) -> None:
    expected = np.random.PCG64(np.random.SeedSequence(seed)).random_raw(50)
    assert pcg64_raw(seed, 50).tolist() == expected.tolist()


def test_hypot_is_cpythons_to_the_bit() -> None:
    rng = np.random.default_rng(41)
    pairs = rng.uniform(-1, 1, (50_000, 2)) * 10.0 ** rng.integers(-4, 3, (50_000, 2))
    differ = [(a, b) for a, b in pairs.tolist() if hypot(a, b) != math.hypot(a, b)]
    assert differ == []


@pytest.mark.parametrize(
    ("kwargs", "count"),
    [
        ({}, 600),
        ({"num_obstacles": (0, 20), "obstacle_size": (0.3, 0.6)}, 60),  # obstacles dropped
        ({"start_pose": (1, -1, 2.0)}, 300),
    ],
)
def test_draws_are_sample_layouts(kwargs: dict[str, Any], count: int) -> None:
    config = BubbleRobEnv(**kwargs).scene.config
    args = (config.arena_size, config.num_obstacles, config.obstacle_size, config.start_clearance)
    seeds = np.arange(9000, 9000 + count)
    drawn = draw_layouts(seeds, *args, config.start_pose, config.robot.radius)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # a crowded arena says it dropped obstacles
        for k, seed in enumerate(seeds.tolist()):
            layout = sample_layout(
                seeding.np_random(seed)[0], *args, config.start_pose, config.robot.radius
            )
            assert tuple(drawn.start[k]) == layout.start_pose
            assert drawn.count[k] == len(layout.obstacles)
            for j, obstacle in enumerate(layout.obstacles):
                kind = "cylinder" if drawn.kind[k, j] == CYLINDER else "box"
                size = drawn.size[k, j, : len(obstacle.size)]
                assert (kind, *drawn.pose[k, j], *size) == (
                    obstacle.kind, obstacle.x, obstacle.y, obstacle.yaw, *obstacle.size
                )  # fmt: skip


@pytest.mark.parametrize("kwargs", [{}, {"robot": "pioneer_p3dx"}, {"start_pose": (0.0, 0.0, 0.0)}])
def test_table_rows_are_what_the_cpu_env_resets_to(kwargs: dict[str, Any]) -> None:
    """Every mocap pose, used slot's size and bounding radius, and the start pose, in float32."""
    seeds = list(range(7000, 7150))
    pos, quat, size, rbound, root = layout_rows(BubbleRobEnv(**kwargs).scene, seeds)
    env = gym.make("BubbleRob-v0", **kwargs).unwrapped
    scene = env.scene  # type: ignore[attr-defined]
    columns = {geom: column for column, geom in enumerate(slot_geoms(scene).tolist())}
    adr = scene.root_qpos
    for k, seed in enumerate(seeds):
        env.reset(seed=seed)
        model, data = scene.model, scene.data
        used = list(scene.slots.placed)
        assert used, seed
        cols = [columns[geom] for geom in used]
        assert np.array_equal(pos[k], data.mocap_pos.astype(np.float32)), seed
        assert np.array_equal(quat[k], data.mocap_quat.astype(np.float32)), seed
        assert np.array_equal(size[k, cols], model.geom_size[used].astype(np.float32)), seed
        assert np.array_equal(rbound[k, cols], model.geom_rbound[used].astype(np.float32)), seed
        assert np.array_equal(root[k], data.qpos[adr : adr + 7].astype(np.float32)), seed


def test_65536_seeded_rows_take_under_two_seconds() -> None:
    scene = BubbleRobEnv().scene
    layout_rows(scene, range(8))  # numba's compilation (cached on disk) is not the reset's
    start = time.process_time()
    rows = layout_rows(scene, range(65_536))
    assert time.process_time() - start < 2.0
    assert rows[0].shape[0] == 65_536
