"""The single env's fast step (issue #40 item 4): the kernel bound to a table of addresses,
MuJoCo's sensors off in the substeps before the last, and MuJoCo's timers off in the step.

Oracles: numba's own dispatch of the same kernel, MuJoCo's Python API stepping a copy of the
robot's ``mjData`` substep by substep with every sensor on, and ``model.opt`` as the bindings
read it.
"""

from __future__ import annotations

import copy
import ctypes

import gymnasium as gym
import mujoco
import numpy as np
import pytest

from bubblerob_env import BubbleRobEnv
from bubblerob_env.core.batch import step_table
from bubblerob_env.core.kernel import OUT
from bubblerob_env.core.mjabi import disableflags_address, load_mujoco_library


def _env(seed: int) -> BubbleRobEnv:
    env = gym.make("BubbleRob-v0")
    env.reset(seed=seed)
    assert isinstance(env.unwrapped, BubbleRobEnv)
    return env.unwrapped


def test_the_bound_step_equals_numbas_dispatch_and_mujocos_own_substeps() -> None:
    fast, slow = _env(3), _env(3)
    reference = copy.copy(fast.scene.data)  # stepped by MuJoCo's Python API, sensors always on
    model = fast.scene.model
    flags = model.opt.disableflags
    actions = np.random.default_rng(3).uniform(-1.2, 1.2, (150, 2)).astype(np.float32)
    for action in actions:
        fast.step(action)
        slow._core.actions[0] = action  # the dispatcher's path: numba types every argument
        slow._core.step(slow._one_robot)
        reference.ctrl[:] = fast._core.out[0, OUT.WHEEL_COMMAND : OUT.WHEEL_COMMAND + 2]
        for _ in range(fast.physics_substeps):
            mujoco.mj_step2(model, reference)
            mujoco.mj_step1(model, reference)
        for name in ("out", "laser", "proximity", "velocity"):
            assert getattr(fast._core, name).tobytes() == getattr(slow._core, name).tobytes()
        for name in ("qpos", "qvel", "sensordata", "act"):
            assert getattr(reference, name).tobytes() == getattr(fast.scene.data, name).tobytes()
        assert model.opt.disableflags == flags  # restored after every step


def test_mujocos_timers_are_off_in_the_step_and_as_they_were_after() -> None:
    env = _env(1)
    model, data = env.scene.model, env.scene.data
    callback = ctypes.c_void_p.in_dll(ctypes.CDLL(load_mujoco_library()), "mjcb_time")
    clock = callback.value
    assert clock, "the bindings set a steady clock as MuJoCo's timer"
    position = data.timer[mujoco.mjtTimer.mjTIMER_POSITION]
    calls, duration = int(position.number), float(position.duration)
    env.step(np.array([1.0, 0.5], dtype=np.float32))
    assert int(position.number) == calls + env.physics_substeps  # the stages ran ...
    assert float(position.duration) == duration  # ... untimed
    assert callback.value == clock  # and the clock is back for MuJoCo called from Python
    mujoco.mj_step1(model, data)
    assert float(position.duration) > duration
    try:
        callback.value = None  # turned off by someone else: a step leaves it off
        env.step(np.array([1.0, 0.5], dtype=np.float32))
        assert callback.value is None
    finally:
        callback.value = clock


def test_disableflags_address_is_where_the_bindings_read_it() -> None:
    model = _env(0).scene.model
    flag = ctypes.c_int.from_address(disableflags_address(model))
    for value in (0, int(mujoco.mjtDisableBit.mjDSBL_SENSOR), 1 << 19 | 1 << 3):
        model.opt.disableflags = value
        assert flag.value == value


def test_step_table_refuses_arrays_it_cannot_address() -> None:
    core = _env(0)._core
    robots = np.array([0], dtype=np.int64)
    rest = (core.settings, core.tables, core.state, core.outputs)
    assert step_table(robots, core.ptrs, core.actions, *rest)[0] == robots.ctypes.data
    wrong = np.zeros((1, 2), np.float32)
    with pytest.raises(ValueError, match="actions: expected a C-contiguous float64 array"):
        step_table(robots, core.ptrs, wrong, *rest)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"robots must be indices below 1, got \[1\]"):
        step_table(np.array([1]), core.ptrs, core.actions, *rest)
