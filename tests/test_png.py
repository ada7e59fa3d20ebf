"""``write_png`` against an independent PNG reader (imageio, through Pillow)."""

from __future__ import annotations

import imageio.v3 as iio
import numpy as np
import pytest

from bubblerob_env.png import write_png


@pytest.mark.parametrize("shape", [(7, 5), (4, 9, 3), (1, 1)])
def test_pixels_read_back_unchanged(tmp_path, shape) -> None:
    image = np.random.default_rng(0).integers(0, 256, size=shape, dtype=np.uint8)
    path = write_png(tmp_path / "image.png", image)
    assert np.array_equal(iio.imread(path), image)


@pytest.mark.parametrize(
    ("name", "image", "message"),
    [
        ("image.jpg", np.zeros((2, 2), np.uint8), "name a .png file, got image.jpg"),
        ("image.png", np.zeros((2, 2), np.float32), "got float32 of shape (2, 2)"),
        ("image.png", np.zeros((2, 2, 4), np.uint8), "RGB pixels (3 channels)"),
        ("image.png", np.zeros((0, 2), np.uint8), "of shape (0, 2)"),
    ],
)
def test_refuses_what_it_cannot_write(tmp_path, name, image, message) -> None:
    with pytest.raises(ValueError, match=message.replace("(", r"\(").replace(")", r"\)")):
        write_png(tmp_path / name, image)
    assert not (tmp_path / name).exists()
