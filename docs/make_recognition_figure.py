"""README's recognition picture: a camera frame, the recogniser's boxes and the ground truth.

Usage: ``python docs/make_recognition_figure.py [OUT.png]`` (default: docs/images/recognition.png).

Three panels, each the 128x128 frame of seed 8003 (held out) at step 0, scaled 3x: the frame as
the camera gives it; the recogniser's boxes (white: cylinder, black: box, orange: wall) with a tick
under each box at the bearing it estimates; MuJoCo's segmentation (each geom a flat grey, the sky
darkest) with the ground truth's boxes in the same colours and ticks at the true bearings.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

import bubblerob_env  # noqa: F401  (registers BubbleRob-v0)
from bubblerob_env.png import write_png
from bubblerob_env.vision.evaluation import labelled_frames
from bubblerob_env.vision.geometry import bearing_to_column

SEED, SIZE, SCALE = 8003, 128, 3
KIND_COLOURS = {"cylinder": (255, 255, 255), "box": (0, 0, 0), "wall": (255, 150, 0)}


def _draw_box(
    image: NDArray[np.uint8], box: tuple[int, int, int, int], colour: tuple[int, int, int]
) -> None:
    u_min, v_min, u_max, v_max = (c * SCALE for c in box)
    u_max, v_max = u_max + SCALE - 1, v_max + SCALE - 1
    image[v_min : v_max + 1, [u_min, u_max]] = colour
    image[[v_min, v_max], u_min : u_max + 1] = colour


def _draw_tick(
    image: NDArray[np.uint8], column: float, row: int, colour: tuple[int, int, int]
) -> None:
    u = int(round((column + 0.5) * SCALE))
    if 0 <= u < image.shape[1]:
        image[row * SCALE : row * SCALE + 2 * SCALE, max(u - 1, 0) : u + 2] = colour


def main(out: Path) -> None:
    """Render the frame, recognise it and write the three panels to ``out``."""
    frame, recogniser = next(iter(labelled_frames([SEED], SIZE, SIZE, steps=0)))
    focal = recogniser.spec.focal_length
    big = np.kron(frame.image, np.ones((SCALE, SCALE, 1), np.uint8))
    found = big.copy()
    for detection in recogniser(frame.image):
        colour = KIND_COLOURS[detection.kind]
        _draw_box(found, detection.box, colour)
        if detection.kind != "wall":
            _draw_tick(
                found,
                bearing_to_column(detection.bearing, SIZE, focal),
                detection.box[3] + 2,
                colour,
            )
    segmentation = np.kron(frame.segmentation, np.ones((SCALE, SCALE), np.int32))
    truth = np.full_like(big, 40)
    for geom in np.unique(segmentation):
        if geom >= 0:
            truth[segmentation == geom] = 90 + (int(geom) * 37) % 150
    for obj in frame.truths:
        _draw_box(truth, obj.box, KIND_COLOURS[obj.kind])
        if obj.kind != "wall":
            _draw_tick(
                truth,
                bearing_to_column(obj.bearing, SIZE, focal),
                obj.box[3] + 2,
                KIND_COLOURS[obj.kind],
            )
    gap = np.full((SIZE * SCALE, 6, 3), 255, np.uint8)
    write_png(out, np.concatenate([big, gap, found, gap, truth], axis=1))
    print(f"wrote {out}: {len(frame.truths)} true objects, seed {SEED}")


if __name__ == "__main__":
    main(
        Path(sys.argv[1])
        if len(sys.argv) > 1
        else Path(__file__).parent / "images" / "recognition.png"
    )
