"""Kinds 2, 3 and 6 of issue #38: the env is what was asked, or refused in one line.

- Every generated arena holds what was asked: an ``obstacle_size`` too large for the arena is
  refused naming it; otherwise every layout holds at least ``num_obstacles``' low end of obstacles
  of the asked sizes, or says in a ``CrowdedArenaWarning`` that it had no room for some.
- The ground truth never loses an obstacle or a wall: at every allowed resolution each touches
  an occupied cell (oracle: points of each footprint sampled here, their cells looked up here).
- Every kwarg is honoured (seen in the env's spaces, model or config) or refused in one line.
- A bare SB3 zip is checked against the env's action and observation spaces at load (another
  robot, laser range or speed limits is refused); wheels and twist share one action space, so a
  bare zip's action type is not checked, and loading says so (``UncheckedPolicyWarning``).
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import bubblerob_env  # noqa: F401 - registers the env ids
from bubblerob_env.arena import ArenaLayout, CrowdedArenaWarning, Obstacle
from bubblerob_env.mapping import OCCUPIED, RESOLUTION_RANGE, ground_truth_grid

SIZES = st.floats(0.01, 3.0)


@settings(max_examples=25, deadline=None)
@given(
    arena=st.floats(1.0, 8.0),
    sizes=st.tuples(SIZES, SIZES).map(sorted),
    counts=st.tuples(st.integers(0, 12), st.integers(0, 12)).map(sorted),
    seed=st.integers(0, 2**16),
)
def test_every_arena_holds_what_was_asked_or_is_refused(arena, sizes, counts, seed) -> None:
    kwargs = {"arena_size": arena, "obstacle_size": sizes, "num_obstacles": counts}
    try:
        env = gym.make("BubbleRob-v0", **kwargs)
    except ValueError as error:
        assert "\n" not in str(error) and any(name in str(error) for name in kwargs)
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env.reset(seed=seed)
    layout = env.unwrapped.layout
    crowded = any(issubclass(w.category, CrowdedArenaWarning) for w in caught)
    assert crowded or len(layout.obstacles) >= counts[0]
    assert len(layout.obstacles) <= counts[1]
    for obstacle in layout.obstacles:
        assert all(sizes[0] - 1e-9 <= s <= sizes[1] + 1e-9 for s in obstacle.size)
    env.close()


def test_an_obstacle_too_large_for_the_arena_is_refused_naming_it() -> None:
    with pytest.raises(
        ValueError, match=r"^obstacle_size \(5, 5\): a box of half side 5 m cannot be placed"
    ):
        gym.make("BubbleRob-v0", obstacle_size=[5, 5])


def _footprint_points(obstacle: Obstacle) -> np.ndarray:
    """Points of the footprint, computed here: polar samples of a disc or a rotated rectangle."""
    if obstacle.kind == "cylinder":
        r, a = np.meshgrid(np.linspace(0, obstacle.size[0], 7), np.linspace(0, 2 * np.pi, 24))
        local = np.stack([r * np.cos(a), r * np.sin(a)], axis=-1).reshape(-1, 2)
    else:
        u, v = np.meshgrid(np.linspace(-1, 1, 9), np.linspace(-1, 1, 9))
        local = np.stack([u * obstacle.size[0], v * obstacle.size[1]], axis=-1).reshape(-1, 2)
        c, s = math.cos(obstacle.yaw), math.sin(obstacle.yaw)
        local = local @ np.array([[c, s], [-s, c]])
    return local + (obstacle.x, obstacle.y)


def _cells(grid: Any, points: np.ndarray) -> set[tuple[int, int]]:
    j = np.floor((points[:, 0] - grid.origin[0]) / grid.resolution).astype(int)
    i = np.floor((points[:, 1] - grid.origin[1]) / grid.resolution).astype(int)
    rows, cols = grid.data.shape
    keep = (i >= 0) & (i < rows) & (j >= 0) & (j < cols)
    return set(zip(i[keep].tolist(), j[keep].tolist(), strict=True))


obstacles = st.builds(
    Obstacle,
    kind=st.sampled_from(["cylinder", "box"]),
    x=st.floats(-1.5, 1.5),
    y=st.floats(-1.5, 1.5),
    yaw=st.floats(-math.pi, math.pi),
    size=st.tuples(st.floats(0.01, 0.4), st.floats(0.01, 0.4)),
).map(lambda o: o if o.kind == "box" else Obstacle(o.kind, o.x, o.y, 0.0, o.size[:1]))


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    layout=st.lists(obstacles, max_size=4),
    resolution=st.floats(*RESOLUTION_RANGE),
    thickness=st.floats(0.01, 0.3),
)
def test_every_obstacle_and_wall_touches_an_occupied_cell(layout, resolution, thickness) -> None:
    grid = ground_truth_grid(ArenaLayout(tuple(layout), (0, 0, 0)), 4.0, thickness, resolution)
    occupied = {tuple(cell) for cell in np.argwhere(grid.data == OCCUPIED).tolist()}
    for obstacle in layout:
        assert _cells(grid, _footprint_points(obstacle)) & occupied, obstacle
    along = np.linspace(-2.0, 2.0, 41)
    depths = np.linspace(2.0 + 1e-9, 2.0 + thickness - 1e-9, 5)
    across, length = (a.ravel() for a in np.meshgrid(depths, along))
    for side in (-1, 1):  # each of the four walls: its points' cells hold an occupied one
        for points in (np.c_[side * across, length], np.c_[length, side * across]):
            assert _cells(grid, points) & occupied


def test_camera_false_beside_a_camera_size_is_refused() -> None:
    with pytest.raises(ValueError, match="camera=False contradicts camera_width=32"):
        gym.make("BubbleRob-v0", camera=False, camera_width=32)
    obs, _ = gym.make("BubbleRob-v0", camera_width=32).reset(seed=0)
    assert obs["camera"].shape[1] == 32


HONOURED = {
    "laser_num_rays": (
        st.integers(1, 500),
        lambda env, v: env.observation_space["laser"].shape == (v,),
    ),
    "camera_height": (
        st.integers(8, 40),
        lambda env, v: env.observation_space["camera"].shape[0] == v,
    ),
    "action_type": (
        st.sampled_from(["wheels", "twist"]),
        lambda env, v: env.unwrapped.action_type == v,
    ),
    "obs_mode": (
        st.sampled_from(["dict", "flat"]),
        lambda env, v: isinstance(env.observation_space, gym.spaces.Dict) == (v == "dict"),
    ),
    "arena_size": (st.floats(1.0, 9.0), lambda env, v: math.isclose(env.unwrapped.arena_size, v)),
    "max_wheel_speed": (
        st.floats(0.5, 50.0),
        lambda env, v: env.unwrapped.config.max_wheel_speed == v,
    ),
    "num_obstacles": (
        st.tuples(st.integers(0, 3), st.integers(3, 6)),
        lambda env, v: tuple(env.unwrapped.config.num_obstacles) == v,
    ),
    "odometry_noise": (
        st.floats(0.0, 1.0),
        lambda env, v: env.unwrapped.config.odometry_noise == v,
    ),
}


@settings(max_examples=40, deadline=None)
@given(data=st.data(), name=st.sampled_from(sorted(HONOURED)))
def test_every_drawn_kwarg_is_honoured_or_refused(data, name) -> None:
    values, honoured = HONOURED[name]
    value = data.draw(values)
    try:
        env = gym.make("BubbleRob-v0", **{name: value})
    except ValueError as error:
        assert name in str(error) and "\n" not in str(error)
        return
    assert honoured(env, value), (name, value)
    env.close()


@pytest.fixture(scope="module")
def bare_twist_zip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """An SB3 PPO zip made on a twist env, saved without the run's config.yml."""
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import PPO

    env = gym.make("BubbleRob-v0", action_type="twist", laser_num_rays=36)
    path = tmp_path_factory.mktemp("bare") / "twist.zip"
    PPO("MultiInputPolicy", env, n_steps=8, batch_size=8, device="cpu").save(path)
    return path


@pytest.mark.parametrize(
    ("env_id", "kwargs", "refused"),
    [
        ("BubbleRob-v0", {"action_type": "twist", "laser_num_rays": 36}, None),
        ("BubbleRob-v0", {"laser_num_rays": 36}, "unchecked"),
        (
            "BubbleRob-v0",
            {"action_type": "twist", "laser_num_rays": 36, "max_linear_speed": 0.1},
            "velocity in",
        ),
        (
            "BubbleRob-v0",
            {"action_type": "twist", "laser_num_rays": 36, "laser_range_max": 3.0},
            "laser in",
        ),
        ("PioneerP3DX-v0", {"action_type": "twist", "laser_num_rays": 36}, "trained for another"),
    ],
)
def test_a_bare_zip_is_checked_against_the_env(bare_twist_zip, env_id, kwargs, refused) -> None:
    from policies.loading import load_policy
    from policies.observations import PolicyEnvMismatchError
    from policies.sb3_policy import UncheckedPolicyWarning

    env = gym.make(env_id, **kwargs)
    if refused in (None, "unchecked"):  # wheels and twist share the action space: said, not caught
        with pytest.warns(UncheckedPolicyWarning, match="not its action_type"):
            load_policy(str(bare_twist_zip), env)
        return
    with pytest.raises(PolicyEnvMismatchError, match=refused) as raised, warnings.catch_warnings():
        warnings.simplefilter("ignore", UncheckedPolicyWarning)
        load_policy(str(bare_twist_zip), env)
    assert "\n" not in str(raised.value)
