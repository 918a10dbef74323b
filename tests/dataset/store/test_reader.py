"""open_store: what it refuses to open, and a closed reader."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from fixtures.stores import write_synthetic
from vptoolkit.dataset.store.reader import open_store
from vptoolkit.errors import InputError, VerificationError


def _edit_root_attributes(store: Path, **changes: Any) -> None:
    metadata_path = store / "zarr.json"
    metadata = json.loads(metadata_path.read_text())
    metadata["attributes"].update(changes)
    metadata_path.write_text(json.dumps(metadata))


@pytest.fixture()
def zarr_copy(tmp_path: Path) -> Path:
    return write_synthetic(tmp_path / "d.zarr")


def test_open_missing_store(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="missing.h5: no such file"):
        open_store(tmp_path / "missing.h5")


@pytest.mark.parametrize("name", ["junk.zarr.zip", "junk.h5"])
def test_open_random_file(tmp_path: Path, name: str) -> None:
    (tmp_path / name).write_bytes(np.random.default_rng(0).bytes(4096))
    with pytest.raises(InputError, match=f"{name}: not a readable dataset store"):
        open_store(tmp_path / name)


def test_open_folder_that_is_not_a_store(tmp_path: Path) -> None:
    (tmp_path / "empty.zarr").mkdir()
    with pytest.raises(InputError, match="empty.zarr: not a readable dataset store"):
        open_store(tmp_path / "empty.zarr")


def test_open_other_zarr_group(tmp_path: Path) -> None:
    import zarr

    zarr.create_group(store=str(tmp_path / "other.zarr"), attributes={"title": "x"})
    with pytest.raises(InputError, match="other.zarr: not a vptoolkit viewpoint dataset"):
        open_store(tmp_path / "other.zarr")


def test_open_rejects_other_schema_version(zarr_copy: Path) -> None:
    _edit_root_attributes(zarr_copy, schema_version=2)
    with pytest.raises(InputError, match="d.zarr: schema_version 2 is not supported"):
        open_store(zarr_copy)


def test_open_rejects_measures_whose_directions_contradict_the_registry(zarr_copy: Path) -> None:
    _edit_root_attributes(zarr_copy, measures=["VKL", "VR", "VE", "VMI"])  # VKL: lower is better
    with pytest.raises(VerificationError, match="d.zarr: measures .*VKL is lower is better"):
        open_store(zarr_copy)


def test_open_rejects_measures_whose_directions_contradict_the_registry_in_hdf5(
        tmp_path: Path) -> None:
    import h5py

    target = write_synthetic(tmp_path / "d.h5")
    with h5py.File(target, "a") as handle:
        handle.attrs["measures"] = np.array(["VMI", "VR", "VKL", "VE"],
                                            dtype=h5py.string_dtype())
    with pytest.raises(VerificationError, match="d.h5: measures .*VMI is lower is better"):
        open_store(target)


def test_open_rejects_missing_array(zarr_copy: Path) -> None:
    import shutil

    shutil.rmtree(zarr_copy / "normals")
    with pytest.raises(InputError, match="missing arrays \\['normals'\\]"):
        open_store(zarr_copy)


def test_closed_reader_refuses_access(stores: dict[str, Path]) -> None:
    reader = open_store(stores["hdf5"])
    reader.close()
    reader.close()
    with pytest.raises(InputError, match="store is closed"):
        reader.array("points")


@pytest.mark.parametrize("block", [b"FRHP", b"BTLF"])  # the attribute heap, a link B-tree leaf
def test_damaged_hdf5_metadata_is_one_line_exit_1(tmp_path: Path, block: bytes) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    target = write_synthetic(tmp_path / "d.h5")
    data = bytearray(target.read_bytes())
    assert block in data
    data[data.index(block) + 12] ^= 1  # inside the block, under its metadata checksum
    target.write_bytes(bytes(data))
    with pytest.raises(VerificationError, match=r"d.h5: the HDF5 metadata cannot be read "
                                                r"\(.*checksum.*\); the store is damaged"):
        open_store(target)
    for command in (["info", str(target)], ["verify", str(target)]):
        result = CliRunner().invoke(main, command)
        assert result.exit_code == 1, result.output
        assert "Traceback" not in result.output
        assert len(result.output.strip().splitlines()) == 1, result.output
