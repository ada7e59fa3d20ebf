"""Which topic of a recorded bag is which input: one answer for ``map``, ``localize``, ``detect``.

A bag recorded with ``--topics vrep`` or ``--namespace robot2`` holds ``/vrep/scan`` or
``/robot2/scan`` where a default bag holds ``/scan``. The episodes' metadata names every topic the
recorder wrote (:meth:`Topics.to_dict`), so those names are read first; a bag without metadata (a
``rosbag record`` of a live node) is read by the last part of each name, as ``amcl`` users
remap: ``/robot2/scan`` is the scan. Two topics that both look like one input are refused rather
than one picked.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from bubblerob_env.ros.messages.topics import Topics

__all__ = ["BagTopicsError", "bag_topic_names"]

_BY_LAST_PART = {
    "scan": "scan",
    "odom": "odom",
    "map": "map",
    "base_pose_ground_truth": "base_pose_ground_truth",
    "image_raw": "image",
    "image": "image",
}
"""The last part of a topic's name and the input key it is, for bags without metadata."""


class BagTopicsError(ValueError):
    """Two topics of a bag both look like one input."""


def _from_metadata(metadata: Sequence[Mapping[str, Any]]) -> dict[str, str] | None:
    for meta in metadata:
        names = meta.get("topics")
        if isinstance(names, Mapping) and names:
            return Topics.from_dict(names).resolved()
    return None


def bag_topic_names(
    present: Iterable[str], metadata: Sequence[Mapping[str, Any]] = ()
) -> dict[str, str]:
    """The name of each input key (``scan``, ``tf``, ``map``, ...) among the bag's topics.

    ``present``: the bag's topic names; ``metadata``: its episodes' metadata (may be empty). Only
    keys whose topic the bag holds are returned.

    Raises:
        BagTopicsError: Without metadata, two topics end alike (``/a/scan`` and ``/b/scan``).
    """
    topics = set(present)
    recorded = _from_metadata(metadata)
    if recorded is not None:
        return {key: name for key, name in recorded.items() if name in topics}
    names = {key: key_name for key, key_name in (("tf", "/tf"), ("tf_static", "/tf_static"))}
    names = {key: name for key, name in names.items() if name in topics}
    for topic in sorted(topics):
        key = _BY_LAST_PART.get(topic.rsplit("/", 1)[-1])
        if key is None:
            continue
        if key in names:
            raise BagTopicsError(
                f"both {names[key]} and {topic} look like the {key} topic and the bag has no "
                "bubblerob metadata to tell them apart: record one robot per bag"
            )
        names[key] = topic
    return names
