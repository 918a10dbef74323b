"""Licences of a release: SPDX expressions, and a blanket licence against the sources' terms."""

from __future__ import annotations

from pathlib import Path

import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from fixtures.releases import release_attrs, release_models, write_release_build
from fixtures.stores import synthetic_entries, write_synthetic
from vptoolkit.cli import main
from vptoolkit.dataset.release.licenses import (
    AUTHORS_SOURCE,
    MODELNET_SOURCE,
    SHAPENET_SOURCE,
    check_license,
    hub_license,
    license_conflicts,
    same_license,
    source_terms,
)
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.errors import InputError


@pytest.mark.parametrize("value", [
    "BSL-1.0", "OFL-1.1", "MIT OR Apache-2.0", "(MIT OR Apache-2.0) AND BSD-3-Clause",
    "Apache-2.0 WITH LLVM-exception", "cc-by-4.0", "LicenseRef-My-Scans",
    "https://example.org/terms",
], ids=["bsl", "ofl", "or", "and-parentheses", "with-exception", "hub-case", "licenseref", "url"])
def test_spdx_identifiers_expressions_and_urls_are_accepted_as_written(value: str) -> None:
    assert check_license(f" {value} ", "license") == value
    assert ReleaseOptions(license=value).license == value


@pytest.mark.parametrize("value", ["CC BY", "MIT OR", "free for all", "other", "GPL-9.0"],
                         ids=["space", "dangling-operator", "prose", "other", "unknown-id"])
def test_anything_else_is_one_line_naming_the_argument(value: str) -> None:
    with pytest.raises(InputError, match=r"^license: .* is not an SPDX licence identifier or "
                                         r"expression \(e\.g\. CC-BY-4\.0, MIT OR Apache-2\.0"):
        check_license(value, "license")


def test_an_expression_of_several_licences_is_other_on_the_hub_named_after_it() -> None:
    assert hub_license("MIT OR Apache-2.0") == {
        "license": "other", "license_name": "mit-or-apache-2.0", "license_link": "README.md"}
    assert hub_license("BSL-1.0") == {"license": "BSL-1.0"}


def test_the_same_licence_is_compared_in_its_canonical_spelling() -> None:
    assert same_license("mit", "MIT")
    assert same_license("apache-2.0 or mit", "Apache-2.0 OR MIT")
    assert not same_license("MIT", "MIT-0")
    assert not same_license("https://example.org/a", "https://example.org/b")


@pytest.mark.parametrize(("attrs", "expected"), [
    ({"source": "ModelNet40"}, [MODELNET_SOURCE]),
    ({"source": "shapenetcore.v2"}, [SHAPENET_SOURCE]),
    ({"source": "ModelNet40", "backend": "imported"}, [MODELNET_SOURCE, AUTHORS_SOURCE]),
    ({"source": "my-scans", "backend": "raster"}, []),
], ids=["modelnet", "shapenet", "authors", "unknown"])
def test_the_sources_terms_are_known_from_the_store_attributes(attrs: dict,
                                                              expected: list) -> None:
    assert source_terms(attrs) == expected


def test_a_licence_contradicts_known_terms_and_other_per_model_licences() -> None:
    records = [{"name": "a"}, {"name": "b", "provenance": {"license": "MIT"}}, {"name": "c"}]
    table = {"a": {"license": "zlib"}, "c": {"license": "CC-BY-4.0"}}
    modelnet = {"source": "ModelNet40"}
    assert license_conflicts("other", modelnet, records, table) == []
    assert license_conflicts(MODELNET_SOURCE.url, modelnet, [], None) == []
    assert license_conflicts("cc-by-4.0", {"source": "scans"}, records[2:], table) == []
    assert license_conflicts("MIT", modelnet, records, table) == [
        f"the terms of ModelNet ({MODELNET_SOURCE.terms}; {MODELNET_SOURCE.url})",
        "the licence zlib of 1 model in LICENSES.csv (a)",
        "the licence CC-BY-4.0 of 1 model in LICENSES.csv (c)",
    ]


def _scans_build(folder: Path) -> Path:
    """A build of the release fixture's models whose source states no terms ("my-scans")."""
    require_package("zarr")
    require_package("h5py")
    folder.mkdir(parents=True)
    write_synthetic(folder / "dataset.zarr", synthetic_entries(release_models(), seed=3),
                    attrs={**release_attrs(), "source": "my-scans"}, failures=[])
    return folder


def _pack(*args: object):
    return CliRunner().invoke(main, ["pack", *map(str, args), "--formats", "hdf5"])


def test_pack_refuses_a_licence_that_contradicts_modelnet_in_one_line(tmp_path: Path) -> None:
    require_package("zarr")
    build = write_release_build(tmp_path / "build")  # its source is "ModelNet40-mini"
    result = _pack(build, tmp_path / "release", "--license", "CC-BY-4.0")
    assert result.exit_code == 2
    assert result.output == (
        f"vptool: error: {build / 'dataset.zarr'}: --license CC-BY-4.0 contradicts the terms of "
        f"ModelNet ({MODELNET_SOURCE.terms}; {MODELNET_SOURCE.url}); pack with --license other "
        "(the sources' terms apply) or add --force-license to record your decision in the "
        "card\n")
    assert not (tmp_path / "release").exists()
    assert _pack(build, tmp_path / "other", "--license", "other").exit_code == 0


def test_pack_refuses_a_licence_that_contradicts_a_licence_table_row(tmp_path: Path) -> None:
    build = _scans_build(tmp_path / "build")
    table = tmp_path / "licenses.csv"
    table.write_text("name,license,author,url\nairplane_0000,mit,Ada,\n", encoding="utf-8")
    refused = _pack(build, tmp_path / "r1", "--license", "CC-BY-4.0", "--licenses", table)
    assert refused.exit_code == 2
    assert len(refused.output.splitlines()) == 1
    assert "contradicts the licence mit of 1 model in LICENSES.csv (airplane_0000)" \
        in refused.output
    same = _pack(build, tmp_path / "r2", "--license", "MIT", "--licenses", table)
    assert same.exit_code == 0, same.output
    assert "Licence decision" not in (tmp_path / "r2/README.md").read_text(encoding="utf-8")


def test_a_forced_licence_is_recorded_in_the_card_with_what_it_contradicts(
        tmp_path: Path) -> None:
    require_package("zarr")
    build = write_release_build(tmp_path / "build")
    result = _pack(build, tmp_path / "release", "--license", "MIT OR Apache-2.0",
                   "--force-license")
    assert result.exit_code == 0, result.output
    card = (tmp_path / "release/README.md").read_text(encoding="utf-8")
    assert ("**Licence decision.** The publisher released this dataset under `MIT OR "
            "Apache-2.0` with `vptool pack --force-license`, although that licence contradicts "
            f"the terms of ModelNet ({MODELNET_SOURCE.terms}; {MODELNET_SOURCE.url}).") in card
    assert 'license: "other"\nlicense_name: "mit-or-apache-2.0"' in card


def test_force_license_without_a_contradiction_adds_nothing_to_the_card(tmp_path: Path) -> None:
    build = _scans_build(tmp_path / "build")
    result = _pack(build, tmp_path / "release", "--license", "BSL-1.0", "--force-license")
    assert result.exit_code == 0, result.output
    card = (tmp_path / "release/README.md").read_text(encoding="utf-8")
    assert "Licence decision" not in card
    assert 'license: "BSL-1.0"' in card


def test_force_license_must_be_a_bool() -> None:
    with pytest.raises(InputError, match="^force_license: expected True or False, got 'yes'$"):
        ReleaseOptions(force_license="yes")  # type: ignore[arg-type]
