"""Property-based tests (Hypothesis) of issue #23: a correct result or one clear error, never a
traceback, a hang, NaN in an observation, or exit 0 on something not done.

Over env keyword arguments, actions (every shape and value), and CLI arguments. CI runs a fixed,
small, derandomised budget (the same examples every run); ``BUBBLEROB_FUZZ_SCALE=N`` multiplies
every budget, with fresh random examples (``bench/fuzz.py`` runs it).
"""

from __future__ import annotations

import math
import os
from typing import Any

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)

SCALE = int(os.environ.get("BUBBLEROB_FUZZ_SCALE", "1"))


def budget(examples: int) -> settings:
    """``examples`` derandomised examples in CI; ``SCALE`` times as many random ones in bench."""
    return settings(
        max_examples=examples * SCALE,
        derandomize=SCALE == 1,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


# Values a hostile caller passes for a number: the valid, the edges and the absurd.
ODD = st.sampled_from(
    [
        0,
        -1,
        -1.0,
        1e-300,
        1e6,
        1e12,
        1e300,
        1e308,
        math.nan,
        math.inf,
        -math.inf,
        True,
        False,
        None,
        "1",
        "no",
        [1.0],
        (0.1, 0.2),
    ]
)
NUMBER = st.one_of(
    ODD, st.floats(allow_nan=True, allow_infinity=True), st.integers(-(10**6), 10**6)
)
KWARG_VALUES: dict[str, st.SearchStrategy[Any]] = {
    "control_timestep": st.one_of(NUMBER, st.floats(0.005, 0.2)),
    "physics_substeps": st.one_of(NUMBER, st.integers(1, 8)),
    "max_wheel_speed": st.one_of(NUMBER, st.floats(0.1, 100)),
    "max_linear_speed": st.one_of(NUMBER, st.floats(0.01, 10)),
    "max_angular_speed": st.one_of(NUMBER, st.floats(0.01, 20)),
    "laser_num_rays": st.one_of(NUMBER, st.integers(0, 64)),
    "laser_fov": st.one_of(NUMBER, st.floats(0.1, 2 * math.pi)),
    "laser_range_max": st.one_of(NUMBER, st.floats(0.5, 50)),
    "laser_noise_std": st.one_of(NUMBER, st.floats(0, 0.1)),
    "proximity_range_max": st.one_of(NUMBER, st.floats(0.4, 2)),
    "camera": st.one_of(ODD, st.booleans()),
    "camera_width": st.one_of(NUMBER, st.integers(1, 32)),
    "arena_size": st.one_of(NUMBER, st.floats(0.5, 20)),
    "num_obstacles": st.one_of(ODD, st.tuples(st.integers(-2, 6), st.integers(-2, 6))),
    "obstacle_size": st.one_of(ODD, st.tuples(st.floats(-0.1, 0.4), st.floats(-0.1, 0.4))),
    "start_clearance": st.one_of(NUMBER, st.floats(0, 1)),
    "start_pose": st.one_of(ODD, st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(-4, 4))),
    "forward_reward_weight": NUMBER,
    "collision_penalty": NUMBER,
    "clearance_distance": st.one_of(NUMBER, st.floats(0.05, 1)),
    "terminate_on_collision": st.one_of(ODD, st.booleans()),
    "action_type": st.sampled_from(["wheels", "twist", "Wheels", "", None, 1]),
}


def _names(kwarg: str) -> tuple[str, ...]:
    """How an error may name ``kwarg``: itself, or the field a sensor spec checks."""
    for prefix in ("laser_", "proximity_", "camera_"):
        if kwarg.startswith(prefix):
            return (kwarg, kwarg[len(prefix) :])
    return (kwarg,)


@budget(40)
@given(
    kwargs=st.dictionaries(st.sampled_from(sorted(KWARG_VALUES)), st.none(), max_size=3).flatmap(
        lambda keys: st.fixed_dictionaries({k: KWARG_VALUES[k] for k in keys})
    )
)
def test_env_kwargs_make_a_working_env_or_one_line_naming_one_of_them(kwargs):
    try:
        env = gym.make("BubbleRob-v0", max_episode_steps=6, **kwargs)
    except (ValueError, TypeError) as error:
        text = str(error)
        assert text and "\n" not in text, text
        assert any(name in text for key in kwargs for name in _names(key)), text
        return
    try:
        obs, _ = env.reset(seed=0)
        for _ in range(5):
            _assert_finite(obs)
            assert env.observation_space.contains(obs)
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            assert math.isfinite(reward) and not info.get("physics_diverged")
            if terminated or truncated:
                break
        _assert_finite(obs)
    finally:
        env.close()


def _assert_finite(obs: Any) -> None:
    for key, value in obs.items():
        assert np.all(np.isfinite(value)), (key, value)


ACTION_VALUES = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(-(10**400), 10**400),
    st.sampled_from([True, False, None, "1", "x", 1 + 2j, b"\x00"]),
)
ACTIONS = st.one_of(
    st.lists(ACTION_VALUES, min_size=0, max_size=4),
    st.tuples(ACTION_VALUES, ACTION_VALUES),
    st.lists(st.lists(st.floats(-2, 2), min_size=2, max_size=2), min_size=1, max_size=2),
    st.builds(
        lambda values, dtype: np.array(values).astype(dtype),
        st.lists(st.floats(-1e3, 1e3), min_size=2, max_size=2),
        st.sampled_from([np.float16, np.float32, np.float64, np.int64, np.uint8, np.bool_]),
    ),
    ACTION_VALUES,
)


@pytest.fixture(scope="module", params=["wheels", "twist"])
def stepping_env(request):
    env = gym.make("BubbleRob-v0", action_type=request.param, num_obstacles=(0, 0))
    env.reset(seed=0)
    yield env
    env.close()


@budget(150)
@given(action=ACTIONS)
def test_any_action_steps_or_is_refused_in_one_line_and_the_env_goes_on(stepping_env, action):
    env = stepping_env
    try:
        obs, reward, terminated, truncated, _ = env.step(action)
    except ValueError as error:
        text = str(error)
        assert text and "\n" not in text, text  # the shape error too (a summary, not a repr)
    else:
        _assert_finite(obs)
        assert math.isfinite(reward)
        if terminated or truncated:
            env.reset(seed=0)
    obs, reward, terminated, truncated, _ = env.step(np.zeros(2, np.float32))  # still usable
    _assert_finite(obs)
    if terminated or truncated:
        env.reset(seed=0)


# CLI arguments: each option is drawn valid or invalid; the oracle says which, independently.
GOOD_COUNT, BAD_COUNT = st.integers(1, 3), st.integers(-(2**70), 0)
GOOD_SEED, BAD_SEED = st.integers(0, 1000), st.integers(-(2**70), -1)
OPTIONS: dict[str, dict[str, tuple[st.SearchStrategy[int], st.SearchStrategy[int]]]] = {
    "train": {
        "--timesteps": (GOOD_COUNT, BAD_COUNT),
        "--n-envs": (GOOD_COUNT, BAD_COUNT),
        "--torch-threads": (GOOD_COUNT, BAD_COUNT),
        "--eval-freq": (GOOD_COUNT, BAD_COUNT),
        "--eval-episodes": (GOOD_COUNT, BAD_COUNT),
        "--seed": (GOOD_SEED, st.one_of(BAD_SEED, st.integers(2**32, 2**70))),
    },
    "evaluate": {"--episodes": (GOOD_COUNT, BAD_COUNT), "--seed": (GOOD_SEED, BAD_SEED)},
    "demo": {"--episodes": (GOOD_COUNT, BAD_COUNT), "--seed": (GOOD_SEED, BAD_SEED)},
    "record": {
        "--episodes": (GOOD_COUNT, BAD_COUNT),
        "--seed": (GOOD_SEED, BAD_SEED),
        "--max-steps": (GOOD_COUNT, BAD_COUNT),
    },
    "node": {
        "--seed": (GOOD_SEED, BAD_SEED),
        "--steps": (GOOD_COUNT, BAD_COUNT),
        "--max-steps": (GOOD_COUNT, BAD_COUNT),
    },
}
FIXED = {
    "train": ["--out", "OUT"],
    "evaluate": ["--policy", "reactive", "--env-kwargs", '{"max_episode_steps": 3}'],
    "demo": ["--policy", "reactive", "--no-video", "--out", "OUT"],
    "record": ["--policy", "reactive", "--no-progress", "--out", "OUT"],
    "node": [],
}


@st.composite
def cli_arguments(draw: st.DrawFn) -> tuple[str, list[str], list[str]]:
    """``(command, argv, the options drawn invalid)`` with at least one invalid."""
    command = draw(st.sampled_from(sorted(OPTIONS)))
    argv, invalid = [command, *FIXED[command]], []
    for option, (good, bad) in OPTIONS[command].items():
        if draw(st.booleans()):
            argv += [option, str(draw(bad))]
            invalid.append(option)
        elif draw(st.booleans()):
            argv += [option, str(draw(good))]
    assume(invalid)  # all-valid runs would train, drive or start ROS: the usage tests cover them
    return command, argv, invalid


@budget(60)
@given(drawn=cli_arguments())
def test_an_invalid_option_is_refused_in_one_line_naming_an_invalid_one(
    drawn, tmp_path_factory, capsys
):
    from cli_usage import run

    command, argv, invalid = drawn
    out = tmp_path_factory.mktemp("cli") / "out"
    done = run([str(out) if arg == "OUT" else arg for arg in argv], capsys)
    line = done.one_line()
    assert done.code == 2, (argv, done.err)
    assert line.startswith(f"bubblerob {command}: ") and any(o in line for o in invalid), line
    assert not out.exists()


@pytest.mark.parametrize("action", [np.zeros((2, 2)), np.array([0.0, 0.0, 0.0, -4.955523405e122])])
def test_a_wrong_shape_action_is_refused_in_one_line(stepping_env, action):
    with pytest.raises(ValueError) as raised:
        stepping_env.step(action)
    assert "\n" not in str(raised.value)
