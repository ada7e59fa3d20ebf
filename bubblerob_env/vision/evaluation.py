"""Labelled camera frames from seeded episodes, and a recogniser's score on them.

Each seed is one episode with coloured obstacles, driven by a seeded wander (a forward speed and
a turn redrawn every few steps), with a frame and its ground truth taken every ``every`` steps
until the episode ends or ``steps`` have run. The frames depend only on the seeds and sizes.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from bubblerob_env.vision.ground_truth import (
    GroundTruthCamera,
    LabelledObject,
    label_segmentation,
)
from bubblerob_env.vision.recognise import Recogniser
from bubblerob_env.vision.scoring import Score

__all__ = ["LabelledFrame", "labelled_frames", "score_recogniser"]

_HOLD_STEPS = 10  # steps between the wander's redraws


@dataclass(frozen=True)
class LabelledFrame:
    """A camera frame, its ground truth and where it came from."""

    seed: int
    step: int
    image: NDArray[np.uint8]
    truths: list[LabelledObject]
    segmentation: NDArray[np.int32]
    """The geom id each pixel shows (-1: none), from MuJoCo's segmentation rendering."""


def labelled_frames(
    seeds: Iterable[int],
    width: int = 64,
    height: int = 64,
    steps: int = 60,
    every: int = 10,
    env_id: str = "BubbleRob-v0",
) -> Iterator[tuple[LabelledFrame, Recogniser]]:
    """Frames of each seed's episode with their ground truth, and a recogniser for the camera.

    ``env_id``: the robot's env (``PioneerP3DX-v0``: the Pioneer in its arena).
    """
    env = gym.make(env_id, camera_width=width, camera_height=height, obstacle_colours=True)
    core = env.unwrapped
    truth_camera = GroundTruthCamera(core.model, core.camera_spec)  # type: ignore[attr-defined]
    try:
        for seed in seeds:
            obs, _ = env.reset(seed=seed)
            recogniser = Recogniser.for_env(core)
            wander = np.random.default_rng(seed)
            action = np.zeros(2, dtype=np.float32)
            for step in range(steps + 1):
                if step % every == 0:
                    segmentation = truth_camera.segment(core.data)  # type: ignore[attr-defined]
                    truths = label_segmentation(
                        segmentation,
                        core.model,  # type: ignore[attr-defined]
                        core.data,  # type: ignore[attr-defined]
                        core.layout,  # type: ignore[attr-defined]
                    )
                    frame = LabelledFrame(seed, step, obs["camera"], truths, segmentation)
                    yield frame, recogniser
                if step % _HOLD_STEPS == 0:
                    forward, turn = wander.uniform(0.2, 0.8), wander.uniform(-0.4, 0.4)
                    action[:] = (forward - turn, forward + turn)
                obs, _, terminated, truncated, _ = env.step(action)
                if terminated or truncated:
                    break
    finally:
        truth_camera.close()
        env.close()


def score_recogniser(
    seeds: Iterable[int], width: int = 64, height: int = 64, steps: int = 60, every: int = 10
) -> Score:
    """The recogniser's score on the frames :func:`labelled_frames` gives."""
    score = Score()
    for frame, recogniser in labelled_frames(seeds, width, height, steps, every):
        score.add(recogniser(frame.image), frame.truths)
    return score
