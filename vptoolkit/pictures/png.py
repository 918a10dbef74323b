"""PNG files from 8-bit images, written with zlib alone (no imaging library).

:func:`png_bytes` encodes grey, RGB or RGBA ``uint8`` arrays (8 bits per
channel, filter 0 on every row, zlib level 6), so the same pixels always
give the same bytes; :func:`save_png` writes them atomically.
"""

from __future__ import annotations

import os
import struct
import zlib
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from vptoolkit.checks import as_path, check_suffix
from vptoolkit.errors import InputError
from vptoolkit.files import write_bytes_atomic

__all__ = ["png_bytes", "save_png"]


def _png_chunk(tag: bytes, body: bytes) -> bytes:
    return (struct.pack(">I", len(body)) + tag + body
            + struct.pack(">I", zlib.crc32(tag + body) & 0xFFFFFFFF))


def png_bytes(image: ArrayLike) -> bytes:
    """Encode an 8-bit image as PNG (zlib only, no imaging library).

    Parameters
    ----------
    image : (height, width), (height, width, 3) or (height, width, 4) uint8
        Grey, RGB or RGBA; row 0 at the top.

    Returns
    -------
    png : bytes
    """
    array = np.asarray(image)
    if array.dtype != np.uint8:
        raise InputError(f"image: expected dtype uint8, got {array.dtype}")
    if array.ndim == 2:
        array = array[:, :, None]
    if array.ndim != 3 or array.shape[2] not in (1, 3, 4) or 0 in array.shape:
        raise InputError(
            f"image: expected shape (h, w), (h, w, 3) or (h, w, 4), got {np.shape(image)}"
        )
    height, width, channels = array.shape
    color_type = {1: 0, 3: 2, 4: 6}[channels]
    rows = np.zeros((height, 1 + width * channels), dtype=np.uint8)  # filter byte 0 per row
    rows[:, 1:] = array.reshape(height, -1)
    header = struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + _png_chunk(b"IHDR", header)
            + _png_chunk(b"IDAT", zlib.compress(rows.tobytes(), 6)) + _png_chunk(b"IEND", b""))


def save_png(image: ArrayLike, path: str | os.PathLike[str]) -> Path:
    """Write an 8-bit image to a PNG file atomically.

    Parameters
    ----------
    image : (height, width), (height, width, 3) or (height, width, 4) uint8
        E.g. from :func:`vptoolkit.pictures.views.render_view`.
    path : path-like
        Target ending in ``.png``; its folder must exist.

    Returns
    -------
    path : pathlib.Path
        The written file.

    Raises
    ------
    InputError
        On a wrong suffix, a missing folder, or a wrong shape or dtype.
    """
    target = check_suffix(as_path(path, "path"), ".png")
    if not target.parent.is_dir():
        raise InputError(f"{target}: folder {target.parent} does not exist")
    return write_bytes_atomic(target, png_bytes(image))
