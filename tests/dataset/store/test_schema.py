"""The data contract's helpers: array digests and JSON bytes."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest

from vptoolkit.dataset.store.schema import array_sha256, from_json_bytes, json_bytes
from vptoolkit.errors import InputError


def test_sha256_is_of_little_endian_c_order_bytes() -> None:
    array = np.arange(12, dtype=">i4").reshape(3, 4).T  # big-endian, not C-contiguous
    expected = hashlib.sha256(np.ascontiguousarray(array, "<i4").tobytes()).hexdigest()
    assert array_sha256(array) == expected
    assert array_sha256(np.zeros((0, 3), np.float32)) == hashlib.sha256(b"").hexdigest()


def test_json_bytes_round_trip() -> None:
    value = {"name": "chaise_longue_ü", "n": [1, 2.5, None, True]}
    encoded = json_bytes(value)
    assert encoded.dtype == np.uint8 and encoded.ndim == 1
    assert from_json_bytes(encoded) == value
    with pytest.raises(InputError, match="not JSON-serialisable"):
        json_bytes({"x": float("nan")})
    with pytest.raises(InputError, match="not UTF-8 JSON"):
        from_json_bytes(np.frombuffer(b"{oops", dtype=np.uint8))
