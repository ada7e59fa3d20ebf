"""The kernel reads mjData at offsets computed from mujoco.introspect: checked against the bindings.

A mujoco release that moves ``ncon``, ``time`` or the contact array fails here, not in a user's
run (pyproject.toml caps mujoco at the tested minor release for the same reason).
"""

from __future__ import annotations

import ctypes

import gymnasium as gym
import mujoco
import numpy as np

import bubblerob_env  # noqa: F401
from bubblerob_env.core.mjabi import data_layout


def _int(address: int) -> int:
    return ctypes.c_int.from_address(address).value


def test_offsets_match_the_bindings_in_states_with_and_without_contacts():
    layout = data_layout()
    env = gym.make("BubbleRob-v0", terminate_on_collision=False, max_episode_steps=None)
    data = env.unwrapped.data
    rng = np.random.default_rng(0)
    seen = set()
    for seed in range(3):
        env.reset(seed=seed)
        for _ in range(150):
            env.step(rng.uniform(-1, 1, 2).astype(np.float32))
            base = data._address
            assert _int(base + layout.ncon) == data.ncon
            assert ctypes.c_double.from_address(base + layout.time).value == data.time
            seen.add(data.ncon)
            if data.ncon:
                contacts = ctypes.c_uint64.from_address(base + layout.contact).value
                geoms = data.contact.geom
                assert contacts + layout.contact_geom == geoms.ctypes.data
                if data.ncon > 1:
                    assert geoms.strides[0] == layout.contact_size
                for k in range(data.ncon):
                    row = contacts + k * layout.contact_size + layout.contact_geom
                    assert [_int(row), _int(row + 4)] == geoms[k].tolist()
    assert len(seen) >= 3  # states with different contact counts were checked


def test_mujoco_version_is_the_tested_one():
    major, minor = (int(part) for part in mujoco.__version__.split(".")[:2])
    assert (major, minor) == (4, 0), "update bubblerob_env/core/mjabi.py's checks, then the cap"
