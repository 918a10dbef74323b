"""PNG encoding with zlib alone, and atomic writing."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.pictures import decode_png
from vptoolkit.errors import InputError
from vptoolkit.pictures.png import png_bytes, save_png


@pytest.mark.parametrize("shape", [(5, 7), (5, 7, 3), (5, 7, 4)], ids=["grey", "rgb", "rgba"])
def test_png_round_trip(tmp_path: Path, shape: tuple[int, ...]):
    image = np.random.default_rng(1).integers(0, 256, size=shape, dtype=np.uint8)
    path = save_png(image, tmp_path / "image.png")
    decoded = decode_png(path.read_bytes())
    np.testing.assert_array_equal(decoded.reshape(shape), image)
    assert list(tmp_path.iterdir()) == [path]  # no partial file left behind


def test_png_opens_in_pillow(tmp_path: Path):
    require_package("PIL")
    from PIL import Image

    image = np.zeros((4, 6, 3), np.uint8)
    image[1, 2] = (255, 0, 10)
    with Image.open(save_png(image, tmp_path / "dot.png")) as opened:
        np.testing.assert_array_equal(np.asarray(opened), image)


@pytest.mark.parametrize(
    ("image", "name", "message"),
    [
        (np.zeros((4, 4, 3), np.float32), "a.png", "dtype uint8"),
        (np.zeros((4, 4, 2), np.uint8), "a.png", "expected shape"),
        (np.zeros((0, 4, 3), np.uint8), "a.png", "expected shape"),
        (np.zeros((4, 4, 3), np.uint8), "a.jpg", "must end in .png"),
    ],
    ids=["float", "two-channels", "empty", "suffix"],
)
def test_save_png_rejects_bad_input(tmp_path: Path, image, name, message):
    with pytest.raises(InputError, match=message):
        save_png(image, tmp_path / name)


def test_png_bytes_is_deterministic():
    image = np.arange(48, dtype=np.uint8).reshape(4, 4, 3)
    assert png_bytes(image) == png_bytes(image.copy())
