"""Which container a path names, find_store, and whether the installed zarr can read it."""

from __future__ import annotations

from pathlib import Path

import pytest

from fixtures.stores import write_synthetic
from vptoolkit.dataset.store.containers import find_store
from vptoolkit.errors import InputError, MissingDependencyError


def test_find_store(tmp_path: Path, stores: dict[str, Path]) -> None:
    assert find_store(stores["zarr"]) == stores["zarr"]
    assert find_store(stores["hdf5"]) == stores["hdf5"]

    build = tmp_path / "build"
    build.mkdir()
    (build / "failures.json").write_text("[]")
    write_synthetic(build / "dataset.zarr")
    assert find_store(build) == build / "dataset.zarr"
    write_synthetic(build / "dataset.h5")
    with pytest.raises(InputError, match="both dataset.zarr and dataset.h5"):
        find_store(build)

    release = tmp_path / "release"
    release.mkdir()
    with pytest.raises(InputError, match="no dataset.zarr, dataset.h5"):
        find_store(release)
    write_synthetic(release / "vp-1.0.h5")
    assert find_store(release) == release / "vp-1.0.h5"
    write_synthetic(release / "vp-1.0.zarr.zip")
    (release / ".vp-2.0.zarr.zip.abc.partial").write_bytes(b"")
    (release / "MANIFEST.json").write_text("{}")
    assert find_store(release) == release / "vp-1.0.zarr.zip"  # zip preferred
    write_synthetic(release / "vp-2.0.zarr.zip")
    with pytest.raises(InputError, match="holds 2 stores"):
        find_store(release)

    with pytest.raises(InputError, match="no such file or directory"):
        find_store(tmp_path / "nowhere")
    (tmp_path / "notes.txt").write_text("x")
    with pytest.raises(InputError, match="not a dataset store"):
        find_store(tmp_path / "notes.txt")


def test_an_old_zarr_says_what_to_install(monkeypatch, mini_release) -> None:
    import types

    from vptoolkit.dataset.store import containers, reader

    old = types.SimpleNamespace(__version__="2.18.3")
    monkeypatch.setattr(containers, "require", lambda module, extra=None: old)
    with pytest.raises(MissingDependencyError, match=r"zarr 2.18.3: .*pip install 'zarr>=3'"):
        reader.open_store(mini_release.zarr_zip)
