"""Scoring detections against the ground truth: precision, recall, class accuracy, bearing error.

Per frame, detections and true objects are paired greedily by the overlap of their boxes
(intersection over union, at least ``min_iou``), largest overlap first, whatever their classes.
Only objects of at least ``min_pixels`` pixels count: a true object that small is neither missed
nor found, and a detection that small, or paired with one, is neither right nor wrong. A paired
detection is a true positive, whose class is right or wrong; the others are false positives, and
the true objects left over are missed. Bearing and distance errors are over the paired obstacles
(a wall's bearing is to its nearest point, often outside the view, so the image cannot give it).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from bubblerob_env.vision.ground_truth import LabelledObject
from bubblerob_env.vision.recognise import Detection

__all__ = ["MIN_PIXELS", "Score", "box_iou"]

MIN_PIXELS = 50
"""Objects smaller than this many pixels do not count (issue #28)."""


def box_iou(a: tuple[int, int, int, int], b: tuple[int, int, int, int]) -> float:
    """Intersection over union of two inclusive pixel boxes ``(u_min, v_min, u_max, v_max)``."""
    width = min(a[2], b[2]) - max(a[0], b[0]) + 1
    height = min(a[3], b[3]) - max(a[1], b[1]) + 1
    if width <= 0 or height <= 0:
        return 0.0
    inter = width * height
    area_a = (a[2] - a[0] + 1) * (a[3] - a[1] + 1)
    area_b = (b[2] - b[0] + 1) * (b[3] - b[1] + 1)
    return inter / (area_a + area_b - inter)


@dataclass
class Score:
    """Counts over the frames added so far."""

    min_pixels: int = MIN_PIXELS
    min_iou: float = 0.5
    images: int = 0
    true_positives: int = 0
    false_positives: int = 0
    missed: int = 0
    class_correct: int = 0
    bearing_errors: list[float] = field(default_factory=list)
    bearing_errors_in_view: list[float] = field(default_factory=list)
    distance_errors: list[float] = field(default_factory=list)

    def add(self, detections: Sequence[Detection], truths: Sequence[LabelledObject]) -> None:
        """Score one frame."""
        self.images += 1
        pairs = sorted(
            (
                (box_iou(d.box, t.box), i, j)
                for i, d in enumerate(detections)
                for j, t in enumerate(truths)
            ),
            reverse=True,
        )
        paired_detections: set[int] = set()
        paired_truths: set[int] = set()
        for iou, i, j in pairs:
            if iou < self.min_iou or i in paired_detections or j in paired_truths:
                continue
            paired_detections.add(i)
            paired_truths.add(j)
            self._pair(detections[i], truths[j])
        self.false_positives += sum(
            1
            for i, d in enumerate(detections)
            if i not in paired_detections and d.pixels >= self.min_pixels
        )
        self.missed += sum(
            1
            for j, t in enumerate(truths)
            if j not in paired_truths and t.pixels >= self.min_pixels
        )

    def _pair(self, detection: Detection, truth: LabelledObject) -> None:
        if truth.pixels < self.min_pixels or detection.pixels < self.min_pixels:
            return
        self.true_positives += 1
        self.class_correct += detection.kind == truth.kind
        if truth.kind != "wall" and detection.kind != "wall":
            error = math.atan2(
                math.sin(detection.bearing - truth.bearing),
                math.cos(detection.bearing - truth.bearing),
            )
            self.bearing_errors.append(abs(math.degrees(error)))
            if not detection.truncated:
                self.bearing_errors_in_view.append(abs(math.degrees(error)))
            if math.isfinite(detection.distance):
                relative = abs(detection.distance - truth.distance) / truth.distance
                self.distance_errors.append(relative)

    @property
    def precision(self) -> float:
        """Paired detections over all counted detections (1 when there are none)."""
        found = self.true_positives + self.false_positives
        return self.true_positives / found if found else 1.0

    @property
    def recall(self) -> float:
        """Paired true objects over all counted true objects (1 when there are none)."""
        present = self.true_positives + self.missed
        return self.true_positives / present if present else 1.0

    def summary(self) -> dict[str, Any]:
        """The numbers as one JSON-ready dict."""
        bearings, distances = self.bearing_errors, self.distance_errors
        in_view = self.bearing_errors_in_view
        return {
            "images": self.images,
            "objects": self.true_positives + self.missed,
            "detections": self.true_positives + self.false_positives,
            "precision": self.precision,
            "recall": self.recall,
            "class_accuracy": self.class_correct / self.true_positives
            if self.true_positives
            else 1.0,
            "bearing_error_mean_deg": sum(bearings) / len(bearings) if bearings else 0.0,
            "bearing_error_max_deg": max(bearings, default=0.0),
            "bearing_error_mean_deg_in_view": sum(in_view) / len(in_view) if in_view else 0.0,
            "obstacles_in_view": len(in_view),
            "distance_error_mean_relative": sum(distances) / len(distances) if distances else 0.0,
        }
