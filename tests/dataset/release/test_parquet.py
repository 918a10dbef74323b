"""The Parquet shards of a release: byte-for-byte repeatable, cut to a bounded size with the
hub's names, and compared row by row with the store by verify."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.releases import MINI_CREATED, PARQUET_FILES, STEM, forge_shard, write_build_to_pack
from vptoolkit.dataset.release.options import ReleaseOptions


def test_parquet_shards_repeat_byte_for_byte_with_sorted_json_features(mini_release,
                                                                       tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    from vptoolkit.dataset.release.parquet import write_parquet_shards
    from vptoolkit.dataset.store.reader import open_store

    with open_store(next(mini_release.path.glob("*.h5"))) as reader:
        first = write_parquet_shards(reader, tmp_path / "a")
        second = write_parquet_shards(reader, tmp_path / "b")
    assert [s.path for s in first] == [s.path for s in second]
    for shard in first:
        written = (tmp_path / "a" / shard.path).read_bytes()
        assert written == (tmp_path / "b" / shard.path).read_bytes(), shard.path
        assert written == (mini_release.path / shard.path).read_bytes(), shard.path
        text = pq.read_schema(tmp_path / "a" / shard.path).metadata[b"huggingface"].decode()
        assert text == json.dumps(json.loads(text), sort_keys=True)


@pytest.fixture(scope="module")
def sharded(tmp_path_factory: pytest.TempPathFactory):
    """The release cut into Parquet shards of at most 30 kB of rows (several per split)."""
    from vptoolkit.dataset.release.pack import pack_release

    base = tmp_path_factory.mktemp("sharded")
    return pack_release(write_build_to_pack(base / "build"), base / "release",
                        ReleaseOptions(created=MINI_CREATED, shard_size="30KB"))


def test_a_small_shard_size_gives_several_hub_named_shards_that_datasets_loads(
        sharded, tmp_path: Path, monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    train = sorted(p.name for p in (sharded.path / "data").glob("train-*.parquet"))
    assert len(train) >= 2
    assert train == [f"train-{i:05d}-of-{len(train):05d}.parquet" for i in range(len(train))]
    import pyarrow.parquet as pq

    for shard in sharded.parquet:  # the rows' Arrow size is bounded, as the hub measures it
        assert pq.read_table(shard).nbytes <= 30_000
        assert shard.stat().st_size <= 30_000 + pq.ParquetFile(shard).metadata.serialized_size
    card = sharded.card.read_text(encoding="utf-8")
    for name in train:
        assert f"    - data/{name}\n" in card  # the configs list every shard
    loaded = datasets.load_dataset(str(sharded.path), cache_dir=str(tmp_path / "cache"))
    from vptoolkit.data import open_dataset

    with open_dataset(sharded.path) as reference:
        for split, rows in loaded.items():
            assert rows["name"] == reference.split(split).names  # every shard, in store order
            assert rows["label"] == reference.split(split).labels.tolist()
        first = loaded["train"].with_format("numpy")[len(loaded["train"]) - 1]
        np.testing.assert_array_equal(first["quality"], reference.split("train")[-1]["quality"])


def test_verify_compares_every_shard_of_a_split(sharded, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    assert verify(sharded.path).ok
    copy = Path(shutil.copytree(sharded.path, tmp_path / "release"))
    second = "data/train-00001-of-" + next(
        (copy / "data").glob("train-00001-of-*.parquet")).name.rsplit("-of-", 1)[1]
    name = forge_shard(copy, second, "quality")
    forge_shard(copy, second, "label")  # compared with the store's labels array
    report = verify(copy)
    # the forged shard's size no longer matches croissant.json's contentSize either
    assert [p.target for p in report.problems] == [second, f"{second}:{name}:label",
                                                   f"{second}:{name}:quality"]
    assert report.problems[0].kind == "size"


@pytest.mark.parametrize(("text", "expected"), [("200KB", 200_000), ("500MB", 500_000_000),
                                                ("1.5GB", 1_500_000_000), ("64MiB", 64 << 20),
                                                ("4096", 4096), (" 2 kb ", 2000)])
def test_shard_sizes_read_as_bytes(text: str, expected: int) -> None:
    from vptoolkit.dataset.release.parquet import parse_size

    assert parse_size(text) == expected


def test_a_bad_shard_size_is_one_line_and_exit_2(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = write_build_to_pack(tmp_path / "build")
    for bad in ("lots", "0KB", "5 parsecs"):
        result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"),
                                           "--shard-size", bad])
        assert result.exit_code == 2, result.output
        assert result.output.startswith("vptool: error: --shard-size: ")
        assert not (tmp_path / "release").exists()


def test_the_same_build_and_shard_size_pack_to_the_same_bytes(sharded, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    again = pack_release(write_build_to_pack(tmp_path / "build"), tmp_path / "release",
                         ReleaseOptions(created=MINI_CREATED, shard_size="30KB"))
    assert again.files == sharded.files


def test_verify_names_a_forged_parquet_shard_with_re_hashed_sums(release_copy: Path) -> None:
    require_package("pyarrow")
    from click.testing import CliRunner

    from vptoolkit.cli import main

    shard = "data/train-00000-of-00001.parquet"
    name = forge_shard(release_copy, shard, "points")
    result = CliRunner().invoke(main, ["verify", str(release_copy)])
    assert result.exit_code == 1, result.output
    assert f"{shard}:{name}:points: differs from the archive ({STEM}.h5)" in result.output
    assert "Traceback" not in result.output


def test_verify_says_it_skipped_the_shards_without_pyarrow(
        release_copy: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from vptoolkit.dataset.release import parquet
    from vptoolkit.dataset.release.manifest import verify
    from vptoolkit.errors import MissingDependencyError

    def absent(module: str, extra: str | None = None) -> None:
        raise MissingDependencyError(f"{module} is not installed: pip install 'vptoolkit[{extra}]'")

    monkeypatch.setattr(parquet, "require", absent)
    report = verify(release_copy)
    assert not report.problems
    assert [p.target for p in report.skipped] == [", ".join(PARQUET_FILES)]
    assert "contents not compared with" in report.summary()
