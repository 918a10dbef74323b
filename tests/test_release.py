"""Release packing, SHA-256 manifest, verification, dataset card, Croissant and info."""

from __future__ import annotations

import hashlib
import json
import re
import shutil
import textwrap
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.releases import CATEGORIES, FAILURES, forge_shard, write_release_build
from fixtures.stores import N_POINTS, N_VIEWS
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.dataset.store.schema import ARRAY_NAMES, STRING_ARRAYS, string_values
from vptoolkit.errors import InputError, VerificationError

STEM = "vptoolkit-viewpoints"
PARQUET_FILES = ["data/test-00000-of-00001.parquet", "data/train-00000-of-00001.parquet",
                 "data/validation-00000-of-00001.parquet", "views/views-00000-of-00001.parquet"]
DATASHEET_SECTIONS = (
    "Motivation", "Composition", "Collection process", "Preprocessing, cleaning and labeling",
    "Uses", "Distribution", "Maintenance",
)


@pytest.fixture(scope="session")
def build(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A build output folder holding a small synthetic ``dataset.zarr``."""
    require_package("h5py")
    return write_release_build(tmp_path_factory.mktemp("build"))


@pytest.fixture(scope="session")
def release(build: Path, tmp_path_factory: pytest.TempPathFactory):
    """The release of ``build`` in every format, packed into an existing empty folder."""
    from vptoolkit.dataset.release.pack import pack_release
    from vptoolkit.dataset.release.options import FORMATS

    folder = tmp_path_factory.mktemp("release") / "out"
    folder.mkdir()
    return pack_release(build, folder, ReleaseOptions(formats=FORMATS))


@pytest.fixture()
def release_copy(release, tmp_path: Path) -> Path:
    """A private copy of the release to tamper with."""
    return Path(shutil.copytree(release.path, tmp_path / "release"))


def _source_records(build: Path) -> list[dict]:
    from vptoolkit.dataset.store.reader import open_store
    from vptoolkit.dataset.store.schema import published_split

    with open_store(build / "dataset.zarr") as reader:
        return [{**r, "split": published_split(r["split"])} for r in reader.models()]


# --------------------------------------------------------------------------- pack


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
        assert packed.models() == _source_records(build)
        assert packed.failures() == source.failures() == FAILURES
        assert packed.attrs == {**source.attrs, "dataset_version": "1.0.0"}


def test_sha256sums_match_hashlib(release) -> None:
    lines = (release.path / "SHA256SUMS").read_text(encoding="utf-8").splitlines()
    listed = {}
    for line in lines:
        match = re.fullmatch(r"([0-9a-f]{64})  (\S+)", line)
        assert match, line
        listed[match[2]] = match[1]
    paths = [line.split("  ", 1)[1] for line in lines]
    assert paths == sorted(paths)
    others = sorted(p.relative_to(release.path).as_posix() for p in release.path.rglob("*")
                    if p.is_file() and p.name != "SHA256SUMS")
    assert sorted(listed) == others
    for name, digest in listed.items():
        assert hashlib.sha256((release.path / name).read_bytes()).hexdigest() == digest, name
    assert listed == release.files


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
        20 * 1024, str(Path(__file__).parent), str(target))
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


# --------------------------------------------------------------------------- verify


def test_verify_passes_on_a_fresh_release(release) -> None:
    from vptoolkit.dataset.release.manifest import verify

    report = verify(release.path)
    assert report.ok, report.summary()
    assert report.kind == "release"
    assert report.files_checked == 10
    assert report.arrays_checked == 2 * len(ARRAY_NAMES)
    assert report.warnings == []
    report.raise_if_failed()
    assert "OK" in report.summary()


@pytest.mark.parametrize("path", ["store", "build folder", "release archive"])
def test_verify_passes_on_a_single_store(build: Path, release, path: str) -> None:
    from vptoolkit.dataset.release.manifest import verify

    target = {"store": build / "dataset.zarr", "build folder": build,
              "release archive": release.hdf5}[path]
    report = verify(target)
    assert report.ok, report.summary()
    assert report.kind == "store" and report.arrays_checked == len(ARRAY_NAMES)
    assert report.files_checked == 0


@pytest.mark.parametrize("suffix", [".h5", ".zarr.zip"])
def test_verify_names_a_file_with_a_flipped_byte(release_copy: Path, suffix: str) -> None:
    from vptoolkit.cli.group import exit_code as _exit_code
    from vptoolkit.dataset.release.manifest import verify

    archive = release_copy / f"{STEM}{suffix}"
    content = bytearray(archive.read_bytes())
    content[len(content) // 2] ^= 0xFF
    archive.write_bytes(bytes(content))

    report = verify(release_copy)
    assert not report.ok
    assert any(p.kind == "checksum" and p.target == archive.name for p in report.problems)
    with pytest.raises(VerificationError, match=re.escape(archive.name)) as caught:
        report.raise_if_failed()
    assert "\n" not in str(caught.value)
    assert _exit_code(caught.value) == 1


def test_verify_names_a_tampered_array_in_a_zarr_directory(build: Path, tmp_path: Path) -> None:
    import zarr

    from vptoolkit.dataset.release.manifest import verify

    folder = Path(shutil.copytree(build, tmp_path / "build"))
    points = zarr.open_array(folder / "dataset.zarr" / "points", mode="r+")
    points[1] = points[1] + 1.0  # rewrites one chunk; the sha256 attribute stays stale

    for target, label in [(folder, "dataset.zarr:points"),
                          (folder / "dataset.zarr", "dataset.zarr:points")]:
        report = verify(target)
        assert [(p.kind, p.target) for p in report.problems] == [("array", label)]
        with pytest.raises(VerificationError, match="dataset.zarr:points"):
            report.raise_if_failed()


def test_verify_names_a_missing_file(release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    (release_copy / f"{STEM}.h5").unlink()
    report = verify(release_copy)
    assert [(p.kind, p.target) for p in report.problems] == [("missing", f"{STEM}.h5")]
    with pytest.raises(VerificationError, match=f"{STEM}.h5"):
        report.raise_if_failed()


def test_verify_warns_about_an_unlisted_file(release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    (release_copy / "notes.txt").write_text("added later")
    report = verify(release_copy)
    assert report.ok
    assert [(p.kind, p.target) for p in report.warnings] == [("extra", "notes.txt")]


def test_verify_names_an_edited_card(release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    card = release_copy / "README.md"
    card.write_text(card.read_text(encoding="utf-8") + "\nedited\n", encoding="utf-8")
    report = verify(release_copy)
    assert [(p.kind, p.target) for p in report.problems] == [("checksum", "README.md")]


def test_verify_reports_a_malformed_or_missing_manifest(release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    manifest = release_copy / "SHA256SUMS"
    manifest.write_text(manifest.read_text() + "not a checksum line\n")
    assert [p.kind for p in verify(release_copy).problems] == ["manifest"]
    manifest.unlink()
    report = verify(release_copy)
    assert [(p.kind, p.target) for p in report.problems] == [("missing", "SHA256SUMS")]
    assert report.arrays_checked == 2 * len(ARRAY_NAMES)  # the archives are still checked


def test_verify_of_a_missing_path_is_an_input_error(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    with pytest.raises(InputError, match="no such"):
        verify(tmp_path / "absent")


def test_summary_names_the_first_mismatches_and_counts_the_rest() -> None:
    from vptoolkit.dataset.release.manifest import Problem, VerifyReport

    report = VerifyReport(path=Path("rel"), kind="release", files_checked=5)
    report.problems = [Problem("checksum", f"file{i}.bin", "checksum mismatch") for i in range(5)]
    with pytest.raises(VerificationError) as caught:
        report.raise_if_failed()
    message = str(caught.value)
    assert message.startswith("rel: 5 mismatches: file0.bin: checksum mismatch; file1.bin")
    assert "file2.bin" in message and "file3.bin" not in message
    assert message.endswith("and 2 more")


# --------------------------------------------------------------------------- manifest helpers


def test_sha256sums_round_trip_through_a_folder(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.manifest import read_sha256sums, write_sha256sums
    from vptoolkit.files import sha256_file

    (tmp_path / "sub").mkdir()
    (tmp_path / "b.txt").write_bytes(b"b" * (3 << 20))  # several 1 MiB blocks
    (tmp_path / "sub" / "a.txt").write_bytes(b"")
    sums = write_sha256sums(tmp_path)
    assert list(sums) == ["b.txt", "sub/a.txt"]
    assert sums["b.txt"] == hashlib.sha256(b"b" * (3 << 20)).hexdigest() == sha256_file(
        tmp_path / "b.txt")
    assert read_sha256sums(tmp_path / "SHA256SUMS") == sums


@pytest.mark.parametrize("line", [f"{'0' * 64}  ../outside", f"{'0' * 64}  /etc/passwd",
                                  "xyz  file", f"{'0' * 63}  short"])
def test_read_sha256sums_rejects_bad_lines(tmp_path: Path, line: str) -> None:
    from vptoolkit.dataset.release.manifest import read_sha256sums

    (tmp_path / "SHA256SUMS").write_text(line + "\n")
    with pytest.raises(VerificationError, match="line 1"):
        read_sha256sums(tmp_path / "SHA256SUMS")


# --------------------------------------------------------------------------- card


def _front_matter(card: str) -> str:
    match = re.match(r"---\n(.*?)\n---\n", card, re.DOTALL)
    assert match, "no YAML front matter"
    return match[1]


def test_card_yaml_header(build: Path, release) -> None:
    header = _front_matter(release.card.read_text(encoding="utf-8"))
    records = _source_records(build)
    for pattern in [r'^pretty_name: ".+"$', r'^license: "other"$',
                    r"^annotations_creators:\n- machine-generated$",
                    r'^size_categories:\n- "n<1K"$',
                    r'^license_name: "source-mesh-licenses"$', r'^license_link: "README.md"$',
                    r"^task_categories:\n- \S+$", r"^tags:\n(- \S+\n)+",
                    r"^configs:\n- config_name: default\n",
                    r"^dataset_info:\n- config_name: default$"]:
        assert re.search(pattern, header, re.MULTILINE), pattern
    # derived from another data set; a local folder name is no hub dataset id to add
    assert re.search(r"^source_datasets:\n- extended$", header, re.MULTILINE)
    default_info = header.split("dataset_info:")[1].split("- config_name: views")[0]
    splits = dict(re.findall(r"- name: (\w+)\n\s+num_bytes: \d+\n\s+num_examples: (\d+)",
                             default_info))
    expected = Counter(record["split"] for record in records)
    assert {k: int(v) for k, v in splits.items()} == dict(expected)


def test_card_has_every_datasheet_section_and_the_licence_note(release) -> None:
    card = release.card.read_text(encoding="utf-8")
    headings = re.findall(r"^## (.+)$", card, re.MULTILINE)
    for section in DATASHEET_SECTIONS:
        assert section in headings, section
    for section in ("Counts per category and split", "Measures", "Schema", "Quality statistics"):
        assert section in headings, section
    assert "source meshes apply" in card
    assert "${" not in card  # every placeholder filled


def test_card_numbers_come_from_the_data(build: Path, release) -> None:
    from vptoolkit.dataset.store.reader import open_store

    card = release.card.read_text(encoding="utf-8")
    records = _source_records(build)
    counts = Counter((r["category"], r["split"]) for r in records)
    for category in CATEGORIES:
        row = [counts[(category, s)] for s in ("train", "validation", "test")]
        line = f"| {category} | {row[0]} | {row[1]} | {row[2]} | {sum(row)} |"
        assert line in card, line
    assert f"{len(records)} models from {len(CATEGORIES)} categories" in card
    assert f"for {N_VIEWS} views" in card and f"each with {N_POINTS} surface points" in card
    with open_store(build / "dataset.zarr") as reader:
        best = reader.array("best_value")[...].astype(np.float64)
    ve = best[:, 0]
    assert f"| VE | viewpoint entropy | higher | bits | {ve.mean():.4g} | {ve.min():.4g} | " in card
    mean_faces = np.mean([r["n_faces"] for r in records])
    assert f"mean {mean_faces:.4g}" in card
    assert f"Inputs that could not be processed: {len(FAILURES)}" in card
    for failure in FAILURES:
        assert failure["reason"] in card
    for name, digest in release.files.items():
        if name.endswith((".zarr.zip", ".h5")):
            assert digest in card


@pytest.mark.parametrize(("n_models", "label"), [
    (0, "n<1K"), (999, "n<1K"), (1000, "1K<n<10K"), (16000, "10K<n<100K"),
    (250_000, "100K<n<1M"), (10**6, "1M<n<10M"),
])
def test_size_category(n_models: int, label: str) -> None:
    from vptoolkit.dataset.store.info import size_category

    assert size_category(n_models) == label


def test_croissant_is_json_ld_with_the_manifest_sums(release) -> None:
    document = json.loads(release.croissant.read_text(encoding="utf-8"))
    context = document["@context"]
    assert context["@vocab"] == "https://schema.org/"
    assert context["cr"] == "http://mlcommons.org/croissant/"
    for key in ("sc", "dct", "recordSet", "field", "source", "extract", "fileObject"):
        assert key in context, key
    assert document["@type"] == "sc:Dataset"
    assert document["conformsTo"] == "http://mlcommons.org/croissant/1.1"
    assert document["name"] and document["description"] and document["license"] == "other"
    assert document["version"] == "1.0.0" and document["datePublished"] == "2025-01-02T03:04:05Z"
    assert document["creator"]["name"]
    assert document["rai:dataCollection"] and document["rai:dataLimitations"]
    files = {obj["contentUrl"]: obj for obj in document["distribution"]
             if obj["@type"] == "cr:FileObject"}
    assert {f"{STEM}.zarr.zip", f"{STEM}.h5", *PARQUET_FILES} <= set(files)
    for url, obj in files.items():
        assert obj["encodingFormat"]
        assert obj["sha256"] == release.files[url], url
    ids = {obj["@id"] for obj in document["distribution"]}
    record_sets = {record_set["@id"]: record_set for record_set in document["recordSet"]}
    assert list(record_sets) == ["splits", "categories", "models", "views"]
    splits = record_sets["splits"]
    assert splits["dataType"] == "cr:Split"
    assert [row["splits/name"] for row in splits["data"]] == ["train", "validation", "test"]
    assert record_sets["categories"]["data"] == [
        {"categories/label": label, "categories/category": name}
        for label, name in enumerate(sorted(CATEGORIES))]  # given inline, no file
    names = [field["name"] for field in record_sets["models"]["field"]]
    assert names[:4] == ["name", "category", "label", "split"] and "points" in names
    label, split = record_sets["models"]["field"][2:4]
    assert label["references"] == {"field": {"@id": "categories/label"}}
    assert split["references"] == {"field": {"@id": "splits/name"}}
    for record_set in (record_sets["models"], record_sets["views"]):
        for field in record_set["field"]:
            source = field["source"]
            (reference,) = [source[k]["@id"] for k in ("fileObject", "fileSet") if k in source]
            assert reference in ids
            assert list(source["extract"]) == ["column"]  # one extract per field
            assert "repeated" not in field
    points = next(f for f in record_sets["models"]["field"] if f["name"] == "points")
    assert points["isArray"] and points["arrayShape"] == f"{N_POINTS},3"
    assert points["dataType"] == "cr:Float32"


# --------------------------------------------------------------------------- info


def test_dataset_info_counts_per_category_and_split(build: Path, release) -> None:
    from vptoolkit.dataset.store.info import dataset_info, format_info

    records = _source_records(build)
    for path in (build, release.path, release.hdf5):
        info = dataset_info(path)
        json.dumps(info, allow_nan=False)  # JSON-safe
        assert info["n_models"] == len(records)
        assert info["n_views"] == N_VIEWS and info["n_points"] == N_POINTS
        assert info["resolution"] == 64 and info["backend"] == "raster"
        assert info["categories"] == sorted(CATEGORIES)
        assert info["splits"] == ["train", "validation", "test"]
        for category in CATEGORIES:
            for split in info["splits"]:
                expected = sum(r["category"] == category and r["split"] == split for r in records)
                assert info["counts"][category][split] == expected
        assert info["split_totals"] == dict(Counter(r["split"] for r in records))
        assert info["measures"]["order"] == ["VE", "VR", "VKL", "VMI"]
        assert info["measures"]["higher_is_better"] == [True, True, False, False]
        assert info["measures"]["log_base"] == 2
        assert info["camera"]["fov_deg"] == 45.0
        assert info["toolkit_version"] == "0.1.0" and info["created"] == "2025-01-02T03:04:05Z"
        assert info["n_failures"] == len(FAILURES) and info["failures"] == FAILURES
    text = format_info(info)
    assert re.search(r"^airplane\s+\d+\s+\d+\s+\d+\s+5$", text, re.MULTILINE)
    assert re.search(rf"^total\s+\d+\s+\d+\s+\d+\s+{len(records)}$", text, re.MULTILINE)
    assert "no view sees the model" in text


def test_release_info_json_matches_dataset_info(release) -> None:
    from vptoolkit.dataset.store.info import dataset_info

    stored = json.loads((release.path / "dataset_info.json").read_text(encoding="utf-8"))
    live = dataset_info(release.zarr_zip)
    live.pop("path")
    assert stored == live


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
