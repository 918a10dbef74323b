"""Nothing corrupt is ever packed, and no reader takes a lost chunk for zeros.

``pack`` re-hashes every array it copies, so without this check a flipped byte or a
deleted chunk of ``OUT/dataset.zarr`` would ship with a fresh, matching checksum and
``verify`` would say OK on the release.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from vptoolkit.cli import main
from vptoolkit.errors import VerificationError

CHUNK = Path("dataset.zarr") / "quality" / "c" / "0" / "0" / "0"


def _flip_one_byte(path: Path) -> None:
    content = bytearray(path.read_bytes())
    content[len(content) // 2] ^= 0x01
    path.write_bytes(bytes(content))


@pytest.mark.parametrize("damage", ["flipped byte", "deleted chunk"])
def test_pack_refuses_a_damaged_store_and_writes_nothing(small_build: Path, tmp_path: Path,
                                                         damage: str) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    if damage == "flipped byte":
        _flip_one_byte(small_build / CHUNK)
    else:
        (small_build / CHUNK).unlink()
    release = tmp_path / "release"
    with pytest.raises(VerificationError, match=r"dataset\.zarr:quality.*nothing packed"):
        pack_release(small_build, release)
    assert not release.exists()
    assert [p.name for p in tmp_path.iterdir()] == ["out"]  # no temporary folder left

    outcome = CliRunner().invoke(main, ["pack", str(small_build), str(release)])
    assert outcome.exit_code == 1
    assert outcome.output.count("\n") == 1 and "vptool: error:" in outcome.output
    assert not release.exists()


def test_readers_refuse_a_missing_chunk_naming_array_and_models(small_build: Path) -> None:
    from vptoolkit.data import open_dataset
    from vptoolkit.dataset.store.reader import open_store

    (small_build / CHUNK).unlink()
    expected = re.escape("array 'quality' chunk c/0/0/0 is missing, models airplane_0000")
    with pytest.raises(VerificationError, match=expected):
        open_store(small_build / "dataset.zarr")
    with pytest.raises(VerificationError, match=expected):
        open_dataset(small_build)
    predictions = small_build.parent / "p.npy"
    np.save(predictions, np.tile([0.0, 0.0, 1.0], (9, 4, 1)))
    outcome = CliRunner().invoke(main, ["evaluate", str(predictions), "--dataset", str(small_build),
                                        "--split", "all"])
    assert outcome.exit_code == 1
    assert "quality" in outcome.output and outcome.output.count("\n") == 1


def _garble(path: Path) -> None:
    """Damage a chunk past its header, so that blosc cannot decompress it."""
    content = bytearray(path.read_bytes())
    for position in range(16, len(content)):
        content[position] ^= 0x5A
    path.write_bytes(bytes(content))


@pytest.mark.parametrize("command", ["evaluate", "predict", "report"])
def test_readers_name_array_and_models_of_a_chunk_that_does_not_decompress(
    small_build: Path, tmp_path: Path, command: str
) -> None:
    _garble(small_build / CHUNK)
    predictions = tmp_path / "p.npy"
    np.save(predictions, np.tile([0.0, 0.0, 1.0], (9, 4, 1)))
    if command == "predict":
        require_package("torch")
        points = small_build / "dataset.zarr" / "points" / "c" / "0" / "0" / "0"
        _garble(points)
        arguments = ["predict", "--dataset", str(small_build), "--split", "all"]
        array = "points"
    elif command == "evaluate":
        arguments = ["evaluate", str(predictions), "--dataset", str(small_build), "--split", "all"]
        array = "quality"
    else:
        arguments = ["report", str(small_build), "-o", str(tmp_path / "report")]
        array = "quality"
    outcome = CliRunner().invoke(main, arguments)
    assert outcome.exit_code == 1, outcome.output
    last = outcome.output.split("\r")[-1].splitlines()[-1]
    assert last.startswith("vptool: error: dataset.zarr: "), outcome.output
    assert f"array {array!r} cannot be decoded, models airplane_0000" in last
    assert "Traceback" not in outcome.output


def test_a_missing_mesh_chunk_names_the_models_whose_rows_it_held(small_build: Path) -> None:
    from vptoolkit.dataset.store.reader import open_store

    (small_build / "dataset.zarr" / "mesh_faces" / "c" / "0" / "0").unlink()
    with pytest.raises(VerificationError, match=r"'mesh_faces' chunk c/0/0 .*airplane_0000, "):
        open_store(small_build / "dataset.zarr")


def test_every_chunk_is_written_even_all_zeros_and_an_old_empty_chunk_still_reads(
    small_build: Path, tmp_path: Path
) -> None:
    import zarr

    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.schema import array_sha256

    # A chunk of zeros is stored (zarr would skip it by default) ...
    source = small_build / "dataset.zarr"
    with open_store(source) as reader:
        assert reader.array("quality").nchunks_initialized == reader.array("quality").nchunks
    # ... and one that an older writer skipped reads as zeros, because the hash agrees.
    old = Path(shutil.copytree(source, tmp_path / "old.zarr"))
    array = zarr.open_array(old / "best_index", mode="r+")
    array[...] = 0  # zarr's default, as the older writer did: the all-zero chunk is dropped
    array.attrs["sha256"] = array_sha256(np.zeros(array.shape, array.dtype))
    assert not (old / "best_index" / "c" / "0" / "0").exists()
    with open_store(old) as reader:
        assert not np.asarray(reader.array("best_index")[...]).any()
