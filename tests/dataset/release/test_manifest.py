"""SHA-256 manifests and verify: a release, a store or an archive checked file by file and
array by array."""

from __future__ import annotations

import hashlib
import re
import shutil
from pathlib import Path

import pytest

from fixtures.releases import STEM
from vptoolkit.dataset.store.schema import ARRAY_NAMES
from vptoolkit.errors import InputError, MissingDependencyError, VerificationError


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


@pytest.mark.parametrize("recorded", ["+1", "1000000", "9999999999999999999", "abc"])
def test_verify_names_a_content_size_that_differs_from_the_file(release_copy: Path,
                                                                recorded: str) -> None:
    import json

    from vptoolkit.dataset.release.manifest import verify, write_sha256sums

    archive = release_copy / f"{STEM}.h5"
    size = archive.stat().st_size
    croissant = release_copy / "croissant.json"
    document = json.loads(croissant.read_text(encoding="utf-8"))
    for item in document["distribution"]:
        if item.get("contentUrl") == archive.name:
            item["contentSize"] = f"{size + 1 if recorded == '+1' else recorded} B"
    croissant.write_text(json.dumps(document), encoding="utf-8")
    write_sha256sums(release_copy)  # the manifest agrees: only the recorded size lies
    report = verify(release_copy)
    assert [(p.kind, p.target) for p in report.problems] == [("size", archive.name)]
    expected = ("not '<bytes> B'" if recorded == "abc" else
                f"croissant.json records {size + 1 if recorded == '+1' else recorded} bytes, "
                f"the file has {size}")
    assert expected in report.problems[0].detail


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


def test_verify_without_manifest_and_croissant_checks_every_archive_and_fails(
        mini_release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    (mini_release_copy / "SHA256SUMS").unlink()
    (mini_release_copy / "croissant.json").unlink()
    report = verify(mini_release_copy)
    assert not report.ok and report.kind == "release"
    assert ("missing", "SHA256SUMS") in [(p.kind, p.target) for p in report.problems]
    assert report.arrays_checked == 2 * len(ARRAY_NAMES)  # the .h5 is checked too


def test_verify_names_every_unlisted_file(mini_release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    (mini_release_copy / "notes.txt").write_text("added")
    (mini_release_copy / "data" / "extra.parquet").write_bytes(b"x")
    summary = verify(mini_release_copy).summary()
    assert "OK" in summary and "2 warnings" in summary
    assert "notes.txt" in summary and "data/extra.parquet" in summary


def test_verify_blames_the_manifest_for_a_bad_digest_line(mini_release_copy: Path) -> None:
    from vptoolkit.dataset.release.manifest import verify

    manifest = mini_release_copy / "SHA256SUMS"
    lines = manifest.read_text().splitlines()
    index = next(i for i, line in enumerate(lines) if line.endswith("  README.md"))
    lines[index] = "0" * 64 + "  README.md"
    manifest.write_text("\n".join(lines) + "\n")
    report = verify(mini_release_copy)
    assert [(p.kind, p.target) for p in report.problems] == [("manifest", "SHA256SUMS")]
    assert "README.md" in report.problems[0].detail


def test_verify_skips_an_archive_it_cannot_open_for_lack_of_a_package(
        mini_release_copy: Path, monkeypatch) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.dataset.store import reader

    def no_zarr() -> None:
        raise MissingDependencyError("zarr: not importable; install it with pip install "
                                     "'vptoolkit[dataset]'")

    monkeypatch.setattr(reader, "require_zarr", no_zarr)
    from vptoolkit.dataset.release.manifest import verify

    report = verify(mini_release_copy)
    assert report.problems == [] and report.ok  # the files and the HDF5 arrays were verified
    assert [p.target for p in report.skipped] == ["mini.zarr.zip"]
    report.raise_if_failed()
    result = CliRunner().invoke(main, ["verify", str(mini_release_copy)])
    assert result.exit_code == 0, result.output
    assert ": OK (" in result.stdout and "skipped mini.zarr.zip: arrays not checked" in (
        result.stdout) and "vptoolkit[dataset]" in result.stdout
    # A damaged file still fails, the skipped archive aside.
    (mini_release_copy / "README.md").write_text("edited\n")
    assert CliRunner().invoke(main, ["verify", str(mini_release_copy)]).exit_code == 1
    # A lone Zarr archive: nothing could be verified at all.
    report = verify(mini_release_copy / "mini.zarr.zip")
    assert not report.ok and report.nothing_verified
    with pytest.raises(MissingDependencyError, match="vptoolkit\\[dataset\\]"):
        report.raise_if_failed()
    result = CliRunner().invoke(main, ["verify", str(mini_release_copy / "mini.zarr.zip")])
    assert result.exit_code == 2 and "NOT VERIFIED" in result.stderr and result.stdout == ""


def test_verify_prints_its_summary_once(mini_release_copy: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    (mini_release_copy / "README.md").write_text("edited\n")
    result = CliRunner().invoke(main, ["verify", str(mini_release_copy)])
    assert result.exit_code == 1
    assert result.stdout == "" and result.stderr.count("README.md") == 1
    assert len(result.stderr.splitlines()) == 1


def test_a_parquet_only_release_verifies_by_its_hashes(parquet_release: Path,
                                                       tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    result = CliRunner().invoke(main, ["verify", str(parquet_release)])
    assert result.exit_code == 0, result.output
    assert "OK" in result.output
    copy = Path(shutil.copytree(parquet_release, tmp_path / "release"))
    shard = next(iter(sorted((copy / "data").glob("*.parquet"))))
    data = bytearray(shard.read_bytes())
    data[len(data) // 2] ^= 0x5A
    shard.write_bytes(bytes(data))
    result = CliRunner().invoke(main, ["verify", str(copy)])
    assert result.exit_code == 1, result.output
    assert shard.name in result.output
