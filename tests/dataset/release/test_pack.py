"""pack_release: a build packed into a release folder, its files, names, failures and
reproducible bytes; a release of other measures than the paper's four."""

from __future__ import annotations

import json
import re
import shutil
import textwrap
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from fixtures.paths import TESTS
from fixtures.releases import (
    CATEGORIES,
    FAILURES,
    MINI_CREATED,
    PARQUET_FILES,
    STEM,
    source_records,
    write_build_to_pack,
)
from vptoolkit.cli import main
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.dataset.store.schema import STRING_ARRAYS, string_values
from vptoolkit.errors import InputError
from vptoolkit.samples import sample_path


def test_release_holds_every_file(release) -> None:
    names = sorted(p.relative_to(release.path).as_posix() for p in release.path.rglob("*")
                   if p.is_file())
    assert names == sorted([
        "README.md", "SCHEMA.md", "SHA256SUMS", "croissant.json", "dataset_info.json",
        f"{STEM}.h5", f"{STEM}.zarr.zip", *PARQUET_FILES,
    ])
    assert release.zarr_zip.is_file() and release.hdf5.is_file()
    assert release.n_models == sum(CATEGORIES.values())
    assert release.n_failures == len(FAILURES)
    # no staging folder left beside the release
    assert [p.name for p in release.path.parent.iterdir()] == ["out"]


@pytest.mark.parametrize("archive", ["zarr_zip", "hdf5"])
def test_archive_holds_the_source_content(build: Path, release, archive: str) -> None:
    from vptoolkit.dataset.store.reader import open_store

    with open_store(build / "dataset.zarr") as source, \
            open_store(getattr(release, archive)) as packed:
        assert packed.kind == ("zarr-zip" if archive == "zarr_zip" else "hdf5")
        assert packed.array_names() == source.array_names()
        for name in source.array_names():
            if name == "models_json":  # the release publishes split "val" as "validation"
                continue
            expected, actual = source.array(name), packed.array(name)
            if name in STRING_ARRAYS:  # zarr's and h5py's string types differ
                assert string_values(actual) == string_values(expected), name
            else:
                assert actual.dtype == expected.dtype, name
                np.testing.assert_array_equal(actual[...], expected[...], err_msg=name)
            assert packed.stored_sha256(name) == source.stored_sha256(name), name
        assert packed.models() == source_records(build)
        assert packed.failures() == source.failures() == FAILURES
        assert packed.attrs == {**source.attrs, "dataset_version": "1.0.0"}


def test_pack_reads_each_file_once_to_hash_it(build: Path, tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    from vptoolkit.dataset.release import descriptions, manifest
    from vptoolkit.dataset.release import pack as release_module
    from vptoolkit.dataset.release.options import FORMATS

    hashed: Counter[str] = Counter()
    real = manifest.sha256_file

    def counted(path, **kwargs) -> str:
        hashed[Path(path).name] += 1
        return real(path, **kwargs)

    for module in (manifest, descriptions, release_module):
        monkeypatch.setattr(module, "sha256_file", counted)
    result = release_module.pack_release(build, tmp_path / "rel", ReleaseOptions(formats=FORMATS))
    released = [Path(name).name for name in result.files]
    assert {name: hashed[name] for name in released} == dict.fromkeys(released, 1)
    listed = (result.path / "SHA256SUMS").read_text(encoding="utf-8")
    assert listed == manifest.format_sha256sums(manifest.hash_folder(result.path))


def test_pack_into_a_non_empty_folder_is_an_input_error(build: Path, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    target = tmp_path / "mine"
    target.mkdir()
    (target / "notes.txt").write_text("keep me")
    with pytest.raises(InputError, match="not empty"):
        pack_release(build, target)
    assert [p.name for p in target.iterdir()] == ["notes.txt"]
    assert (target / "notes.txt").read_text() == "keep me"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["mine"]


def test_pack_onto_a_file_is_an_input_error(build: Path, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    target = tmp_path / "release"
    target.write_text("a file")
    with pytest.raises(InputError, match="not a folder"):
        pack_release(build, target)
    assert target.read_text() == "a file"


@pytest.mark.parametrize("name", ["", "../escape", ".hidden", "a/b", "two words"])
def test_pack_rejects_a_name_that_is_not_a_plain_file_name(build: Path, tmp_path: Path,
                                                           name: str) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    with pytest.raises(InputError, match="name"):
        pack_release(build, tmp_path / "release", ReleaseOptions(name=name))
    assert list(tmp_path.iterdir()) == []


def test_failed_pack_leaves_no_release_and_no_staging(build: Path, tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    from vptoolkit.dataset.release import pack as release_module

    def broken(*args: object, **kwargs: object) -> str:
        raise RuntimeError("card template broke")

    monkeypatch.setattr(release_module, "render_card", broken)
    with pytest.raises(RuntimeError, match="card template broke"):
        release_module.pack_release(build, tmp_path / "release")
    assert list(tmp_path.iterdir()) == []


def test_a_full_disk_while_packing_names_the_release(build: Path, tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    import errno

    from vptoolkit.dataset.release import pack as release_module

    def full(folder: Path, known: dict) -> dict:
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(release_module, "write_sha256sums", full)
    with pytest.raises(OSError) as caught:
        release_module.pack_release(build, tmp_path / "release")
    assert caught.value.filename == str(tmp_path / "release")
    assert list(tmp_path.iterdir()) == []


_UNDER_FILE_SIZE_LIMIT = textwrap.dedent("""
    import json, resource, signal, sys
    from pathlib import Path
    from click.testing import CliRunner
    from vptoolkit.cli import main

    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG
    resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]),) * 2)
    if sys.argv[2] == "pack":
        outcome = CliRunner().invoke(main, ["pack", *sys.argv[3:]])
        print(json.dumps([outcome.exit_code, outcome.output]))
    else:
        sys.path.insert(0, sys.argv[2])
        from fixtures.stores import write_synthetic
        try:
            write_synthetic(Path(sys.argv[3]))
        except OSError as err:
            print(json.dumps([err.errno, err.filename]))
""")


def _under_file_size_limit(limit: int, *args: str) -> list:
    """Run pack (``"pack", *options``) or write a synthetic store (``tests_folder, path``) in
    a child whose files may not pass ``limit`` bytes; return what it printed (decoded)."""
    import os
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-c", _UNDER_FILE_SIZE_LIMIT, str(limit), *args],
                          capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout)


@pytest.mark.parametrize("limit_kb", [1, 40, 90])
def test_a_file_size_limit_while_writing_the_hdf5_archive_is_one_line(
        build: Path, tmp_path: Path, limit_kb: int) -> None:
    # HDF5 used to raise RuntimeError on close and crash the interpreter at exit.
    code, output = _under_file_size_limit(limit_kb * 1024, "pack", str(build),
                                          str(tmp_path / "rel"), "--formats", "hdf5")
    errors = [line for line in output.splitlines() if line.startswith("vptool: error:")]
    assert code == 2, output
    assert errors == [f"vptool: error: {tmp_path / 'rel'}: File too large"], output
    assert "Traceback" not in output
    assert list(tmp_path.iterdir()) == []


def test_a_file_size_limit_while_writing_an_hdf5_store_names_the_store(tmp_path: Path) -> None:
    import errno

    require_package("h5py")
    target = tmp_path / "dataset.h5"
    number, filename = _under_file_size_limit(
        20 * 1024, str(TESTS), str(target))
    assert (number, filename) == (errno.EFBIG, str(target))
    assert list(tmp_path.iterdir()) == []


def test_pack_removes_only_its_own_stale_staging_folders(build: Path, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release
    from vptoolkit.files import held

    stale = tmp_path / ".rel.ab12cd34.partial"       # a killed pack into rel
    other = tmp_path / ".rel.v2.ef56gh78.partial"    # a stale one of rel.v2, not of rel
    live = tmp_path / ".rel.ij90kl12.partial"        # a pack into rel still running
    for folder in (stale, other, live):
        folder.mkdir()
        (folder / "part.h5").write_bytes(b"x")
    with held(live):
        pack_release(build, tmp_path / "rel", ReleaseOptions(formats=["hdf5"]))
        assert not stale.exists()
        assert (other / "part.h5").exists() and (live / "part.h5").exists()


def test_the_loser_of_two_packs_says_the_folder_was_filled(build: Path, tmp_path: Path,
                                                           monkeypatch: pytest.MonkeyPatch) -> None:
    from vptoolkit.dataset.release import pack as release_module

    target = tmp_path / "rel"
    real = release_module.write_sha256sums

    def meanwhile(folder: Path, known: dict) -> dict:
        target.mkdir(exist_ok=True)
        (target / "README.md").write_text("another pack's card\n")
        return real(folder, known)

    monkeypatch.setattr(release_module, "write_sha256sums", meanwhile)
    with pytest.raises(InputError, match="rel: folder was filled while packing"):
        release_module.pack_release(build, target, ReleaseOptions(formats=["hdf5"]))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rel"]


def test_pack_uses_the_given_name_and_licence(build: Path, tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    options = ReleaseOptions(name="mini-v1", license="cc-by-4.0", version="2.3.4",
                             force_license=True)  # the source is ModelNet-named
    result = pack_release(build, tmp_path / "nested" / "rel", options)
    assert result.zarr_zip is None  # by default Parquet and one archive, HDF5
    assert result.hdf5.name == "mini-v1.h5"  # the version is not in file names
    card = result.card.read_text(encoding="utf-8")
    assert re.search(r'^license: "cc-by-4.0"$', card, re.MULTILINE)
    assert json.loads(result.croissant.read_text())["license"] == "cc-by-4.0"


def test_a_read_only_parent_folder_names_the_release(build: Path, tmp_path: Path,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    import errno

    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.dataset.release import pack as release_module

    def refused(*args: object, prefix: str = "", suffix: str = "", dir: object = None) -> str:
        raise PermissionError(errno.EACCES, "Permission denied",
                              str(Path(str(dir)) / f"{prefix}abcd1234{suffix}"))

    monkeypatch.setattr(release_module.tempfile, "mkdtemp", refused)
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release")])
    assert result.exit_code == 2
    message = result.output.strip().splitlines()[-1]
    assert f"{tmp_path / 'release'}: Permission denied" in message
    assert ".partial" not in result.output
    assert "Traceback" not in result.output


def test_a_name_too_long_for_a_file_name_names_the_release(build: Path,
                                                           tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"),
                                       "--name", "n" * 253])
    assert result.exit_code == 2
    assert f"{tmp_path / 'release'}: file name" in result.output
    assert "longer than 255 bytes" in result.output
    assert ".partial" not in result.output
    assert list(tmp_path.iterdir()) == []


def test_version_goes_into_attributes_card_and_croissant_not_names(mini_release) -> None:
    from vptoolkit.dataset.store.reader import open_store

    assert mini_release.zarr_zip.name == "mini.zarr.zip" and mini_release.hdf5.name == "mini.h5"
    assert not [name for name in mini_release.files if "2.1.0" in name]
    with open_store(mini_release.hdf5) as reader:
        assert reader.attrs["dataset_version"] == "2.1.0"
        assert reader.attrs["created"] == MINI_CREATED
    card = mini_release.card.read_text(encoding="utf-8")
    assert f"Version\n2.1.0, released {MINI_CREATED}" in card


def test_schema_ships_inside_the_release(mini_release) -> None:
    schema = (mini_release.path / "SCHEMA.md").read_text(encoding="utf-8")
    assert "models_json" in schema
    assert "SCHEMA.md" in mini_release.files


def test_an_empty_split_is_a_loud_warning(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    entries_split = {f"{c}_{i:04d}": "train" for c, n in CATEGORIES.items() for i in range(n)}
    build = write_build_to_pack(tmp_path / "build", splits=entries_split)
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release")])
    assert result.exit_code == 0, result.output
    assert "vptool: warning: split 'validation' is empty" in result.stderr
    assert "vptool: warning: split 'test' is empty" in result.stderr
    card = (tmp_path / "release" / "README.md").read_text(encoding="utf-8")
    assert "> **Warning.** split 'test' is empty" in card
    assert "data/test-" not in card  # no config for a split without rows


def test_parquet_only_release(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    build = write_build_to_pack(tmp_path / "build")
    result = pack_release(build, tmp_path / "release", ReleaseOptions(formats=["parquet"]))
    assert result.zarr_zip is None and result.hdf5 is None
    names = sorted(p.name for p in result.path.iterdir())
    assert not [n for n in names if n.endswith((".h5", ".zip"))] and "data" in names
    assert not [p for p in result.path.rglob(".*")]  # the describing copy is gone


def test_two_independent_builds_pack_to_identical_sha256sums(tmp_path: Path,
                                                             monkeypatch) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    first = write_build_to_pack(tmp_path / "a" / "build", created="2025-01-01T00:00:00Z")
    second = write_build_to_pack(tmp_path / "b" / "build", created="2025-06-30T12:00:00Z")
    one = pack_release(first, tmp_path / "a" / "release", ReleaseOptions(created=MINI_CREATED))
    two = pack_release(second, tmp_path / "b" / "release", ReleaseOptions(created=MINI_CREATED))
    manifest = (one.path / "SHA256SUMS").read_text()
    assert manifest == (two.path / "SHA256SUMS").read_text()
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1772600767")  # 2026-03-04T05:06:07Z
    three = pack_release(second, tmp_path / "c" / "release")
    assert three.created == MINI_CREATED
    assert (three.path / "SHA256SUMS").read_text() == manifest


def test_cli_pack_options_reach_the_release(tmp_path: Path, licenses_csv: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = write_build_to_pack(tmp_path / "build")
    release = tmp_path / "release"
    result = CliRunner().invoke(main, [
        "pack", str(build), str(release), "--formats", "parquet,hdf5", "--version", "0.2.0",
        "--created", "2026-03-04T06:06:07+01:00", "--licenses", str(licenses_csv),
        "--pretty-name", "CLI viewpoints", "--source-url", "https://example.org/src",
        "--license-name", "mixed", "--license-link", "https://example.org/terms"])
    assert result.exit_code == 0, result.output
    assert f"version 0.2.0, created {MINI_CREATED}" in result.stdout
    assert (release / "vptoolkit-viewpoints.h5").is_file()
    assert not list(release.glob("*.zarr.zip"))
    card = (release / "README.md").read_text(encoding="utf-8")
    assert 'license_name: "mixed"' in card and 'license_link: "https://example.org/terms"' in card
    assert card.startswith('---\npretty_name: "CLI viewpoints"\n')
    bad = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "r2"), "--version", "v1"])
    assert bad.exit_code == 2
    assert bad.stderr == "vptool: error: version: 'v1' is not MAJOR.MINOR.PATCH (e.g. 1.0.0)\n"


# --- a release of other measures than the paper's four ------------------------------------


THREE = ("VE", "NVT", "SL")
N_VIEWS = 60
CREATED = "2026-02-03T04:05:06Z"


@pytest.fixture(scope="module")
def three_release(tmp_path_factory: pytest.TempPathFactory):
    """Four bundled samples built with three measures, packed in every format."""
    from vptoolkit.dataset.release.options import FORMATS, ReleaseOptions
    from vptoolkit.dataset.release.pack import pack_release

    root = tmp_path_factory.mktemp("measures-release")
    for category, sample in (("bottle", "bottle.obj"), ("mug", "mug.obj"),
                             ("table", "table.obj"), ("toy", "lego.obj")):
        (root / "src" / category).mkdir(parents=True)
        shutil.copy(sample_path(sample), root / "src" / category / sample)
    built = CliRunner().invoke(main, [
        "build-dataset", str(root / "src"), str(root / "build"), "--views", str(N_VIEWS),
        "--resolution", "48", "--points", "150", "--no-clean", "--measures", ",".join(THREE)])
    assert built.exit_code == 0, built.output
    return pack_release(root / "build", root / "release",
                        ReleaseOptions(formats=FORMATS, created=CREATED))


def test_the_card_describes_the_three_measures(three_release) -> None:
    import yaml

    card = three_release.card.read_text(encoding="utf-8")
    assert "the three\nviewpoint quality measures VE, NVT, SL evaluated for" in card
    assert "Columns of every last axis of size 3, in this order: VE, NVT, SL." in card
    assert "Raw values are in each measure's own unit" in card
    assert "VR is a fraction" not in card
    assert "# (views, 3) of model 0, columns VE, NVT, SL" in card
    assert "| VE | viewpoint entropy | higher | bits |" in card
    assert "| NVT | number of visible triangles | higher | - |" in card
    assert "| SL | silhouette length | higher | - |" in card
    assert "VKL" not in card and "VMI" not in card
    header = yaml.safe_load(card.split("---\n")[1])
    default = next(c for c in header["dataset_info"] if c["config_name"] == "default")
    features = {f["name"]: f for f in default["features"]}
    assert features["quality"]["dtype"]["array2_d"]["shape"] == [N_VIEWS, 3]
    assert features["best_index"] == {"name": "best_index", "list": "int64", "length": 3}
    assert ("| `quality` | float32 | (60, 3) | normalised quality per view, columns VE, NVT, "
            "SL, 1 = best |") in card


def test_croissant_fields_name_the_columns_and_have_their_shapes(three_release) -> None:
    document = json.loads(three_release.croissant.read_text(encoding="utf-8"))
    assert "quality measures VE, NVT, SL for 60 views" in document["description"]
    models = next(r for r in document["recordSet"] if r["@id"] == "models")
    fields = {f["name"]: f for f in models["field"]}
    assert fields["quality"]["arrayShape"] == f"{N_VIEWS},3"
    assert fields["quality_raw"]["description"] == (
        "raw measures per view, columns VE, NVT, SL, NaN where nothing is seen")
    assert fields["worst_value"]["arrayShape"] == "3"


def test_parquet_shards_hold_the_store_columns_with_their_features(three_release) -> None:
    import pyarrow.parquet as pq

    from vptoolkit.data import open_dataset

    rows = {}
    for shard in three_release.parquet:
        if shard.parent.name != "data":
            continue
        features = json.loads(pq.read_schema(shard).metadata[b"huggingface"])["info"]["features"]
        assert features["quality"] == {"_type": "Array2D", "dtype": "float32",
                                       "shape": [N_VIEWS, 3]}
        assert features["best_value"] == {"_type": "List", "length": 3,
                                          "feature": {"_type": "Value", "dtype": "float32"}}
        table = pq.read_table(shard).to_pylist()
        rows.update({row["name"]: row for row in table})
    with open_dataset(three_release.path) as dataset:
        assert sorted(rows) == sorted(dataset.names)
        for name, row in rows.items():
            item = dataset[name]
            np.testing.assert_array_equal(np.array(row["quality_raw"], np.float32),
                                          item["quality_raw"])
            assert row["best_index"] == item["best_index"].tolist()


def test_datasets_loads_the_three_columns_offline(three_release, tmp_path: Path,
                                                  monkeypatch) -> None:
    require_package("datasets")
    monkeypatch.setenv("HF_DATASETS_OFFLINE", "1")
    monkeypatch.setenv("HF_HUB_OFFLINE", "1")
    import datasets

    from vptoolkit.data import open_dataset

    loaded = datasets.load_dataset(str(three_release.path), cache_dir=str(tmp_path / "cache"))
    with open_dataset(three_release.path) as reference:
        for split, rows in loaded.items():
            first = rows.with_format("numpy")[0]
            expected = reference.split(split)[0]
            assert first["quality"].shape == (N_VIEWS, 3)
            np.testing.assert_array_equal(first["quality"], expected["quality"])
            np.testing.assert_array_equal(first["worst_index"],
                                          reference.array("worst_index")[
                                              reference.names.index(first["name"])])


def test_verify_passes_and_every_archive_holds_the_measures(three_release) -> None:
    from vptoolkit.dataset.store.reader import open_store

    result = CliRunner().invoke(main, ["verify", str(three_release.path)])
    assert result.exit_code == 0, result.output
    for archive in (three_release.path / f"{three_release.name}.h5", three_release.zarr_zip):
        with open_store(archive) as store:
            assert store.measures == THREE and store.attrs["higher_is_better"] == [True] * 3


# rdflib and pandas, under mlcroissant, warn about their own APIs; not ours.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:ConjunctiveGraph is deprecated:DeprecationWarning")
@pytest.mark.filterwarnings("ignore:The inplace keyword in DataFrame.reset_index")
def test_mlcroissant_reads_a_record_of_three_columns(three_release) -> None:
    require_package("mlcroissant")
    import mlcroissant

    dataset = mlcroissant.Dataset(jsonld=str(three_release.croissant))
    model = next(iter(dataset.records(record_set="models")))
    assert np.asarray(model["models/quality"]).shape == (N_VIEWS, 3)
    assert np.asarray(model["models/best_index"]).shape == (3,)


def test_a_store_with_a_measure_the_registry_does_not_know_is_not_packed(three_release,
                                                                         tmp_path: Path) -> None:
    import h5py

    store = Path(shutil.copy(three_release.path / f"{three_release.name}.h5",
                             tmp_path / "dataset.h5"))
    with h5py.File(store, "a") as handle:
        handle.attrs["measures"] = np.array(["VE", "NVT", "FUTURE"], dtype=h5py.string_dtype())
    info = CliRunner().invoke(main, ["info", str(store)])
    assert info.exit_code == 0 and "FUTURE (higher is better)" in info.output
    packed = CliRunner().invoke(main, ["pack", str(store), str(tmp_path / "release")])
    assert packed.exit_code == 2
    assert "measure 'FUTURE'" in packed.stderr and packed.stderr.count("\n") == 1
