"""Licences of a release: SPDX expressions, the per-mesh licence table, a blanket licence
against the sources' terms, and the hub's licence fields."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from click.testing import CliRunner

from fixtures.environment import require_package
from fixtures.releases import (
    MINI_CREATED,
    N_MODELS,
    release_attrs,
    release_models,
    write_build_to_pack,
    write_release_build,
)
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


def test_provenance_is_stored_per_model_tabled_and_shipped(mini_release) -> None:
    from vptoolkit.data import open_dataset

    with open_dataset(mini_release.path) as dataset:
        assert dataset.record("airplane_0000")["provenance"] == {
            "license": "cc-by-4.0", "author": "Ada, L.", "url": "https://example.org/a0"}
        assert "provenance" not in dataset.record("airplane_0001")
    card = mini_release.card.read_text(encoding="utf-8")
    assert "| `chair_0001` | mit | Bob | https://example.org/c1 |" in card
    shipped = (mini_release.path / "LICENSES.csv").read_text(encoding="utf-8").splitlines()
    assert shipped[0] == "name,license,author,url" and len(shipped) == 1 + N_MODELS
    assert 'airplane_0000,cc-by-4.0,"Ada, L.",https://example.org/a0' in shipped
    assert any("no row in the licence table" in line for line in mini_release.warnings)
    require_package("pyarrow")
    import pyarrow.parquet as pq

    table = pq.read_table(mini_release.path / "data" / "train-00000-of-00001.parquet")
    row = table.to_pylist()[0]
    assert row["name"] == "airplane_0000" and row["license"] == "cc-by-4.0"


def test_a_licence_table_given_as_a_mapping_is_read_as_its_csv_file(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.licenses import read_licenses

    table = tmp_path / "table.csv"
    table.write_text("name,license,author,url,note\n airplane_0000 , MIT , Ada ,,x\n",
                     encoding="utf-8")
    given = {" airplane_0000 ": {"license": " MIT ", "author": " Ada ", "url": "", "note": "x"}}
    assert ReleaseOptions(licenses=given).license_table() == read_licenses(table) == {
        "airplane_0000": {"license": "MIT", "author": "Ada"}}


def test_a_licence_table_without_its_columns_names_the_file(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.licenses import read_licenses

    (tmp_path / "l.csv").write_text("name,licence\nx,mit\n", encoding="utf-8")
    with pytest.raises(InputError, match="l.csv: header lacks the column"):
        read_licenses(tmp_path / "l.csv")
    (tmp_path / "l.csv").write_text("name,license,author,url\nx,mit,,\nx,mit,,\n")
    with pytest.raises(InputError, match="l.csv: line 3 repeats the model 'x'"):
        read_licenses(tmp_path / "l.csv")


@pytest.mark.parametrize(("options", "message"), [
    (["--license", "CC BY"], "--license: 'CC BY' is not an SPDX licence identifier"),
    (["--licenses", "TABLE"], "licenses.csv: line 3: 'free for all' is not an SPDX licence"),
])
def test_licences_must_be_spdx_identifiers_or_urls(tmp_path: Path, options: list[str],
                                                    message: str) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = write_build_to_pack(tmp_path / "build")
    table = tmp_path / "licenses.csv"
    table.write_text("name,license,author,url\nairplane_0000,CC-BY-4.0,,\n"
                     "chair_0001,free for all,,\nchair_0002,https://example.org/terms,,\n",
                     encoding="utf-8")
    options = [str(table) if part == "TABLE" else part for part in options]
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release"), *options])
    assert result.exit_code == 2
    assert result.output.startswith(f"vptool: error: {message}")
    assert len(result.output.strip().splitlines()) == 1
    assert not (tmp_path / "release").exists()


def test_one_licence_for_every_model_fills_records_shards_and_card(tmp_path: Path) -> None:
    import pyarrow.parquet as pq
    from click.testing import CliRunner

    from vptoolkit.cli import main
    from vptoolkit.data import open_dataset

    build = write_build_to_pack(tmp_path / "build")
    release = tmp_path / "release"
    result = CliRunner().invoke(main, ["pack", str(build), str(release), "--license",
                                       "CC-BY-4.0", "--force-license", "--creator", "Jane Doe",
                                       "--created", MINI_CREATED])
    assert result.exit_code == 0, result.output
    assert "warning" not in result.stderr
    with open_dataset(release) as dataset:
        assert {r["provenance"]["license"] for r in dataset.records} == {"CC-BY-4.0"}
    licences = pq.read_table(release / "data/train-00000-of-00001.parquet").column("license")
    assert set(licences.to_pylist()) == {"CC-BY-4.0"}
    card = (release / "README.md").read_text(encoding="utf-8")
    assert re.search(r'^license: "CC-BY-4.0"$', card, re.MULTILINE)
    assert "Every source mesh is under `CC-BY-4.0`" in card
    assert "*Who created it?* Jane Doe, with vptoolkit" in card
    assert "@misc{viewpoint_quality_of_modelnet40_mini_models_2026," in card
    assert "  author  = {Jane Doe}," in card and "  version = {1.0.0}," in card
    document = json.loads((release / "croissant.json").read_text(encoding="utf-8"))
    assert document["creator"]["name"] == "Jane Doe"
    assert document["license"] == "CC-BY-4.0"


def test_pack_without_a_licence_warns_on_stderr(tmp_path: Path) -> None:
    from click.testing import CliRunner

    from vptoolkit.cli import main

    build = write_build_to_pack(tmp_path / "build")
    result = CliRunner().invoke(main, ["pack", str(build), str(tmp_path / "release")])
    assert result.exit_code == 0, result.output
    assert "vptool: warning: no licence given for the source meshes" in result.stderr
    card = (tmp_path / "release/README.md").read_text(encoding="utf-8")
    assert "no licence given" not in card  # the card's licence note says it in its words
    assert "vptoolkit was given no licence for them" in card


def test_a_licence_given_by_url_is_other_on_the_hub_with_its_link(tmp_path: Path) -> None:
    from vptoolkit.dataset.release.pack import pack_release

    url = "https://example.org/terms"
    result = pack_release(write_build_to_pack(tmp_path / "build"), tmp_path / "release",
                          ReleaseOptions(license=url, formats=["hdf5"], force_license=True))
    header = result.card.read_text(encoding="utf-8").split("\n---\n")[0]
    assert 'license: "other"\nlicense_name: "custom"\nlicense_link: "https://example.org/terms"' \
        in header
    assert json.loads(result.croissant.read_text(encoding="utf-8"))["license"] == url
