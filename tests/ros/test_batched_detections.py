"""Recordings recognise a batch of images at once (issue #40): the same detections, frame by frame.

The bags' side (each frame's record, then its detections, chunk boundaries included) is in
``tests/ros/test_packed_frames.py``; here, the recogniser's: ``Recogniser.many`` against its own
frame-by-frame call on rendered frames, and the pixel codes against numpy's reading of their rule.
"""

from __future__ import annotations

import colorsys

import gymnasium as gym
import numpy as np
import pytest

from bubblerob_env.arena import OBSTACLE_PALETTE
from bubblerob_env.vision.recognise import Recogniser
from bubblerob_env.vision.segment import (
    MIN_OBSTACLE_SATURATION,
    MIN_VALUE,
    WALL_HUE,
    WALL_SATURATION,
    pixel_codes,
)


@pytest.fixture(scope="module")
def rendered() -> tuple[Recogniser, np.ndarray]:
    """120 camera frames of coloured obstacles, the robot turning on the spot and driving."""
    env = gym.make("BubbleRob-v0", camera=True, obstacle_colours=True)
    recogniser = Recogniser.for_env(env.unwrapped)
    frames = []
    for seed in range(100, 110):
        obs, _ = env.reset(seed=seed)
        frames.append(obs["camera"])
        for step in range(11):  # turn, so that obstacles cross the frame's edges
            action = [0.6, -0.6] if step < 8 else [0.8, 0.8]
            obs, *_ = env.step(np.array(action, np.float32))
            frames.append(obs["camera"])
    env.close()
    return recogniser, np.array(frames)


def test_a_batch_finds_what_each_frame_finds(rendered: tuple[Recogniser, np.ndarray]) -> None:
    recogniser, frames = rendered
    one_by_one = [recogniser(frame) for frame in frames]
    # Batches of 1, 7 and the rest: the scratch arrays carry nothing from frame to frame.
    batched = recogniser.many(frames[:1]) + recogniser.many(frames[1:8])
    batched += recogniser.many(frames[8:])
    assert batched == one_by_one  # every field, floats bit for bit
    found = [d for frame in one_by_one for d in frame]
    assert {d.kind for d in found} == {"box", "cylinder", "wall"}
    # Cylinders cut by the frame's edge take the shading path (their brightest column).
    assert sum(d.kind == "cylinder" and d.truncated for d in found) >= 3
    assert recogniser.many(frames[:0]) == []
    with pytest.raises(ValueError, match=r"frames shape \(2, 64, 32, 3\) is not \(n, 64, 64, 3\)"):
        recogniser.many(frames[:2, :, :32])


def _codes_by_numpy(frame: np.ndarray, hues: np.ndarray) -> np.ndarray:
    """The pixel codes as the segment module's docstring and thresholds define them."""
    rgb = frame.astype(np.float64)
    high, low = rgb.max(axis=2), rgb.min(axis=2)
    spread = high - low
    with np.errstate(divide="ignore", invalid="ignore"):
        saturation = spread / high
        r, g, b = rgb[..., 0], rgb[..., 1], rgb[..., 2]
        hue = np.where(
            high == r,
            60.0 * ((g - b) / spread),
            np.where(high == g, 60.0 * ((b - r) / spread + 2.0), 60.0 * ((r - g) / spread + 4.0)),
        )
    hue = np.where(hue < 0.0, hue + 360.0, hue)
    gaps = np.abs(hue[..., None] - hues)
    nearest = np.argmin(np.minimum(gaps, 360.0 - gaps), axis=-1) + 1
    wall = (
        (WALL_SATURATION[0] <= saturation)
        & (saturation <= WALL_SATURATION[1])
        & (WALL_HUE[0] <= hue)
        & (hue <= WALL_HUE[1])
    )
    coded = (high >= MIN_VALUE) & (spread > 0)
    codes = np.where(
        saturation >= MIN_OBSTACLE_SATURATION, nearest, np.where(wall, len(hues) + 1, 0)
    )
    return np.where(coded, codes, 0).astype(np.uint8)


def test_pixel_codes_follow_their_rule(rendered: tuple[Recogniser, np.ndarray]) -> None:
    _, frames = rendered
    hues = np.array([360.0 * colorsys.rgb_to_hsv(*rgb)[0] for rgb in OBSTACLE_PALETTE.values()])
    # Every grey level, the walls' brown, the palette at several brightnesses, and near misses.
    grey = np.repeat(np.arange(256, dtype=np.uint8), 3).reshape(16, 16, 3)
    rng = np.random.default_rng(0)
    noise = rng.integers(0, 256, size=(64, 64, 3), dtype=np.uint8)
    # Browns at the floor's edge, saturation 1/4 exactly and either side, every hue between.
    edge = [
        (red, red - spread + rise, red - spread)
        for red in range(MIN_VALUE - 1, 256)
        for spread in range((red - 2) // 4, (red + 2) // 4 + 1)
        for rise in range(spread + 1)
    ]
    brown = np.array(edge[: len(edge) // 64 * 64], np.uint8).reshape(64, -1, 3)
    for frame in [*frames[::7], grey, noise, brown]:
        codes, value = pixel_codes(np.ascontiguousarray(frame), hues)
        np.testing.assert_array_equal(codes, _codes_by_numpy(frame, hues))
        np.testing.assert_array_equal(value, frame.max(axis=2))
