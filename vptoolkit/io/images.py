"""Texture images decoded into RGBA arrays, through Pillow imported on first use."""

from __future__ import annotations

import io as _bytes_io
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import one_line
from vptoolkit.io._polygons import FormatError
from vptoolkit.optional import require

__all__ = ["image_rgba", "read_image"]


def read_image(source: Path | bytes) -> NDArray[np.uint8]:
    """Decode a PNG, JPEG or other Pillow-readable image file into RGBA.

    Parameters
    ----------
    source : Path or bytes
        The image file, or its content (an image embedded in a GLB).

    Returns
    -------
    (height, width, 4) uint8
        RGBA, the first row the top of the image.

    Raises
    ------
    FormatError
        If the file is missing or not an image Pillow can read.
    MissingDependencyError
        If Pillow is not installed (the ``pictures`` extra).
    """
    image_module = require("PIL.Image", extra="pictures")
    label = source.name if isinstance(source, Path) else "embedded image"
    try:
        stream = source.open("rb") if isinstance(source, Path) else _bytes_io.BytesIO(source)
        with stream, image_module.open(stream) as image:
            return image_rgba(image)
    except (OSError, ValueError) as err:
        raise FormatError(f"texture {label} cannot be read ({one_line(err)})") from err


def image_rgba(image: Any) -> NDArray[np.uint8]:
    """A Pillow image (any mode) as ``(height, width, 4) uint8`` RGBA."""
    return np.array(image.convert("RGBA"), dtype=np.uint8)
