"""ReleaseOptions: what a publisher says about a release, checked when made, and the release
time."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from fixtures.releases import write_build_to_pack
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.errors import InputError


@pytest.mark.parametrize("bad, message", [
    ({"version": "1.0"}, "version: '1.0' is not MAJOR.MINOR.PATCH"),
    ({"created": "yesterday"}, "created: 'yesterday' is not an ISO 8601 time"),
    ({"formats": ["parquet", "csv"]}, "formats: expected one or more of"),
], ids=["version", "created", "formats"])
def test_bad_release_options_are_input_errors(tmp_path: Path, bad: dict, message: str) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    build = write_build_to_pack(tmp_path / "build")
    with pytest.raises(InputError, match=re.escape(message)):
        pack_release(build, tmp_path / "release", ReleaseOptions(**bad))
    assert not (tmp_path / "release").exists()


@pytest.mark.parametrize("bad, message", [
    ({"name": "../up"}, "name: '../up' must start with a letter or digit"),
    ({"license": "my own"}, "license: 'my own' is not an SPDX licence identifier"),
    ({"formats": "parquet"}, "formats: expected a sequence of format names"),
    ({"formats": []}, "formats: expected one or more of parquet, zarr, hdf5, got none"),
    ({"shard_size": "big"}, "shard_size:"),
    ({"licenses": {"chair_0001": {"license": "mine"}}}, "licenses: chair_0001: 'mine' is not"),
    ({"licenses": {"chair_0001": {"license": "MIT", "author": "Ada\x1b[2J"}}},
     "licenses: chair_0001: the author cell holds the control character U+001B; remove it"),
    ({"licenses": {"chair_0001": {"license": " "}}},
     "licenses: chair_0001 needs a name and a license"),
    ({"licenses": {"chair_0001": {"license": "MIT", "url": 7}}},
     "licenses: chair_0001: the url cell: expected text, got int"),
    ({"licenses": {"chair_0001": {"license": "MIT"}, " chair_0001": {"license": "MIT"}}},
     "licenses:  chair_0001 repeats the model 'chair_0001'"),
    ({"creator": 7}, "creator: expected text, got 7"),
], ids=["name", "license", "formats-text", "no-formats", "shard-size", "table", "table-control",
        "table-empty", "table-cell-type", "table-repeat", "creator"])
def test_release_options_are_checked_when_made(bad: dict, message: str) -> None:
    with pytest.raises(InputError, match=re.escape(message)):
        ReleaseOptions(**bad)


def test_release_options_keep_their_checked_values() -> None:
    from vptoolkit.conventions import DATASET_VERSION
    from vptoolkit.dataset.release.options import DEFAULT_FORMATS, DEFAULT_LICENSE, DEFAULT_NAME
    from vptoolkit.dataset.release.parquet import DEFAULT_SHARD_BYTES

    default = ReleaseOptions()
    assert (default.name, default.license, default.formats, default.version) == (
        DEFAULT_NAME, DEFAULT_LICENSE, DEFAULT_FORMATS, DATASET_VERSION)
    assert default.shard_bytes == DEFAULT_SHARD_BYTES and default.created is None
    assert default.default_license is None and default.license_table() is None
    given = ReleaseOptions(license=" CC-BY-4.0 ", formats=("zarr", "zarr", "hdf5"),
                           shard_size="2KiB", created="2026-03-04T06:06:07+01:00",
                           licenses="table.csv")
    assert given.license == given.default_license == "CC-BY-4.0"
    assert given.formats == ("zarr", "hdf5") and given.shard_bytes == 2048
    assert given.created == "2026-03-04T05:06:07Z" and given.licenses == Path("table.csv")
    assert ReleaseOptions(created=given.created) == ReleaseOptions(created="2026-03-04T05:06:07")


@pytest.mark.parametrize(("created", "epoch", "needle"), [
    ("9999-12-31T23:59:59-01:00", None, "created: '9999-12-31T23:59:59-01:00' is outside"),
    ("0001-01-01T00:00:00+01:00", None, "created: '0001-01-01T00:00:00+01:00' is outside"),
    (None, "99999999999999999999", "SOURCE_DATE_EPOCH: 99999999999999999999 seconds is beyond"),
    (None, "\u00b2", "SOURCE_DATE_EPOCH: '\u00b2' is not a whole number"),
    (None, "9" * 5000, "SOURCE_DATE_EPOCH: 999"),
], ids=["after-9999", "before-year-1", "huge-epoch", "superscript-two", "5000-digits"])
def test_release_times_beyond_the_calendar_are_one_line(monkeypatch, created, epoch,
                                                        needle) -> None:
    from vptoolkit.dataset.release.options import release_created

    if epoch is None:
        monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    else:
        monkeypatch.setenv("SOURCE_DATE_EPOCH", epoch)
    with pytest.raises(InputError, match=re.escape(needle)) as caught:
        release_created(created, None)
    assert "\n" not in str(caught.value) and len(str(caught.value)) < 300


def test_release_times_before_the_year_1000_keep_four_digits(monkeypatch) -> None:
    from vptoolkit.dataset.release.options import release_created

    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    assert release_created("1000-01-01T00:00:00+01:00", None) == "0999-12-31T23:00:00Z"
    assert release_created("0042-03-04T05:06:07", None) == "0042-03-04T05:06:07Z"


def test_cli_pack_refuses_a_created_beyond_9999_in_one_line(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = write_build_to_pack(tmp_path / "build")
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"),
                                       "--created", "9999-12-31T23:59:59-01:00"])
    assert result.exit_code == 2, result.output
    assert result.output.startswith("vptool: error: created: ") and result.output.count("\n") == 1
    assert not (tmp_path / "release").exists()
