"""The recogniser over a recorded bag's images, scored against the truth (``bubblerob detect BAG``).

The recogniser (:class:`~bubblerob_env.vision.recognise.Recogniser`) runs on every image the bag
holds (``/camera/image_raw``, as recorded). The ground truth of each image comes from the episode
re-simulated from its metadata, as ``bubblerob replay`` does (the env made again from the recorded
id and kwargs, reset with the recorded seed or generator state, stepped with the recorded
actions): MuJoCo's segmentation rendering of the same camera at the same pose
(:mod:`~bubblerob_env.vision.ground_truth`). ``vision_msgs`` has no pixel count, so a recorded
``Detection2DArray`` could not say which objects have >= 50 pixels: the truth is rendered again.

Scoring (:class:`~bubblerob_env.vision.scoring.Score`): detections and true objects paired by box
overlap, objects of fewer than 50 pixels not counted, bearing errors over the paired obstacles.
Images that the re-simulation renders differently (another OpenGL build) are still scored (the
pose is exact) and counted in ``images_rendered_differently``.

A figure over nothing (precision with no detection, recall with no object of ``min_pixels``,
class accuracy with nothing paired, errors with no obstacle paired) is ``None`` and its reason is
in :meth:`DetectReport.missing`: never the 1.000 or 0.00 of an empty ratio.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.ros.bag_topics import bag_topic_names
from bubblerob_env.ros.readback.episode_env import make_episode_env
from bubblerob_env.ros.readback.layout import bag_root
from bubblerob_env.ros.readback.summary import find_episodes, open_reader
from bubblerob_env.vision.ground_truth import GroundTruthCamera, label_segmentation
from bubblerob_env.vision.recognise import Recogniser
from bubblerob_env.vision.scoring import Score

__all__ = ["DetectError", "DetectReport", "detect_bag"]


class DetectError(RuntimeError):
    """The bag cannot be scored (no episodes, no camera, an env that cannot be made again)."""


@dataclass
class DetectReport:
    """What :func:`detect_bag` measured."""

    bag: Path
    episodes: int
    score: Score
    images_rendered_differently: int = 0

    def missing(self) -> dict[str, str]:
        """Each figure that has nothing to be computed over, and why (empty: none)."""
        score, small = self.score, f"of >= {self.score.min_pixels} pixels"
        whys = {
            "precision": (score.true_positives + score.false_positives, f"no detection {small}"),
            "recall": (score.true_positives + score.missed, f"no object {small} in any image"),
            "class_accuracy": (score.true_positives, "no detection paired with an object"),
            "bearing_error": (len(score.bearing_errors), "no obstacle paired"),
            "distance_error": (len(score.distance_errors), "no obstacle paired at a distance"),
        }
        return {name: why for name, (count, why) in whys.items() if count == 0}

    @property
    def headline_missing(self) -> bool:
        """Whether precision, recall or class accuracy is missing: no score to report."""
        return bool({"precision", "recall", "class_accuracy"} & set(self.missing()))

    def to_dict(self) -> dict[str, Any]:
        """One JSON-ready object: the score's summary, the bag and its episodes.

        A figure over nothing is ``None``, and ``"n/a"`` says why.
        """
        summary = self.score.summary()
        missing = self.missing()
        for name, keys in _FIGURE_KEYS.items():
            if name in missing:
                summary.update(dict.fromkeys(keys))
        return {
            "bag": str(self.bag),
            "episodes": self.episodes,
            **summary,
            "min_pixels": self.score.min_pixels,
            "images_rendered_differently": self.images_rendered_differently,
            "n/a": missing,
        }

    def __str__(self) -> str:
        s, missing = self.score.summary(), self.missing()

        def shown(name: str, text: str) -> str:
            return f"n/a ({missing[name]})" if name in missing else text

        figures = {
            "precision": f"{s['precision']:.3f}",
            "recall": f"{s['recall']:.3f}",
            "class_accuracy": f"{s['class_accuracy']:.3f}",
            "bearing_error": f"{s['bearing_error_mean_deg']:.2f} deg "
            f"(max {s['bearing_error_max_deg']:.2f})",
            "distance_error": f"{100 * s['distance_error_mean_relative']:.1f}%",
        }
        text = {name: shown(name, value) for name, value in figures.items()}
        return (
            f"{self.bag}: {s['images']} image(s) of {self.episodes} episode(s), "
            f"{s['objects']} object(s) of >= {self.score.min_pixels} pixels\n"
            f"precision {text['precision']}, recall {text['recall']}, "
            f"class accuracy {text['class_accuracy']}, "
            f"bearing error mean {text['bearing_error']}, "
            f"distance error mean {text['distance_error']}"
        )


_FIGURE_KEYS = {
    "precision": ("precision",),
    "recall": ("recall",),
    "class_accuracy": ("class_accuracy",),
    "bearing_error": (
        "bearing_error_mean_deg",
        "bearing_error_max_deg",
        "bearing_error_mean_deg_in_view",
    ),
    "distance_error": ("distance_error_mean_relative",),
}
"""The summary's keys of each figure :meth:`DetectReport.missing` can name."""


def _make_env(meta: dict[str, Any]) -> gym.Env[Any, Any]:
    return make_episode_env(meta, DetectError)


def _recorded(reader: Any, topic: str, start: int, stop: int | None) -> list[Any]:
    """The decoded messages of ``topic`` from ``start`` (ns) to before ``stop``, in time order."""
    connections = [c for c in reader.connections if c.topic == topic]
    return [
        reader.deserialize(raw, connection.msgtype)
        for connection, _, raw in reader.messages(connections=connections, start=start, stop=stop)
    ]


def _image(message: Any) -> NDArray[np.uint8]:
    data = np.asarray(message.data, dtype=np.uint8)
    return data.reshape(int(message.height), int(message.width), 3)


def _resimulated(env: gym.Env[Any, Any], meta: dict[str, Any], actions: list[Any]) -> Iterator[Any]:
    """The env after the episode's reset and after each recorded action (its unwrapped core)."""
    core = env.unwrapped
    if meta.get("seed") is None and meta.get("rng_state") is not None:
        state = meta["rng_state"]
        generator = np.random.Generator(getattr(np.random, state["bit_generator"])())
        generator.bit_generator.state = state
        core.np_random = generator
    obs, _ = env.reset(seed=meta.get("seed"), options=meta.get("options"))
    yield obs
    for action in actions:
        obs, *_ = env.step(np.asarray(action.data, dtype=np.float64))
        yield obs


def _score_episode(
    reader: Any,
    meta: dict[str, Any],
    stop: int | None,
    env: gym.Env[Any, Any],
    report: DetectReport,
) -> None:
    """Add the scores of episode ``meta``'s images (up to ``stop`` ns) to ``report``."""
    names = bag_topic_names((c.topic for c in reader.connections), [meta])
    start = meta["start_time_ns"]
    images = _recorded(reader, names["image"], start, stop) if "image" in names else []
    if not images:
        raise DetectError(
            f"{report.bag}: episode {meta['episode']} has no camera images on "
            f"{names.get('image', 'its image topic')}: record with the camera on "
            "(bubblerob record --camera)"
        )
    actions = _recorded(reader, names["action"], start, stop)
    core: Any = env.unwrapped
    truth = GroundTruthCamera(core.model, core.camera_spec)
    recogniser = Recogniser.for_env(core)
    try:
        for image_message, obs in zip(images, _resimulated(env, meta, actions), strict=False):
            image = _image(image_message)
            report.images_rendered_differently += not np.array_equal(image, obs["camera"])
            segmentation = truth.segment(core.data)
            truths = label_segmentation(segmentation, core.model, core.data, core.layout)
            report.score.add(recogniser(image), truths)
    finally:
        truth.close()


def detect_bag(path: str | Path, min_pixels: int = 50) -> DetectReport:
    """Score the recogniser on every image of the bag at ``path`` (see the module docstring).

    Raises:
        DetectError: The bag holds no episodes or no images, or its env cannot be made again.
        OSError: Not a bag, or a damaged one.
    """
    root = bag_root(path)
    report = DetectReport(root, 0, Score(min_pixels=min_pixels))
    with open_reader(root) as reader:
        _, episodes = find_episodes(reader)
        if not episodes:
            raise DetectError(f"{root} holds no bubblerob episode metadata: nothing to score")
        for index, meta in enumerate(episodes):
            if meta.get("env_kwargs") is None or not meta.get("env_id"):
                raise DetectError(f"{root}: episode {meta['episode']} names no env to re-simulate")
            stop = episodes[index + 1]["start_time_ns"] if index + 1 < len(episodes) else None
            env = _make_env(meta)
            try:
                if getattr(env.unwrapped, "camera_spec", None) is None:
                    raise DetectError(
                        f"{root}: episode {meta['episode']}'s env has no camera: record with "
                        "the camera on (bubblerob record --camera)"
                    )
                _score_episode(reader, meta, stop, env, report)
            finally:
                env.close()
            report.episodes += 1
    return report
