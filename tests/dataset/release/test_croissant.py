"""Croissant JSON-LD of a release: the manifest's sums, its metadata and Responsible-AI fields,
and mlcroissant's own validation."""

from __future__ import annotations

import json
import re
import subprocess
import sys

import numpy as np
import pytest

from fixtures.environment import require_package
from fixtures.releases import CATEGORIES, MINI_CREATED, PARQUET_FILES, STEM
from fixtures.stores import N_POINTS, N_VIEWS


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


# rdflib and pandas, under mlcroissant, warn about their own APIs; not ours.
@pytest.mark.slow
@pytest.mark.filterwarnings("ignore:ConjunctiveGraph is deprecated:DeprecationWarning")
@pytest.mark.filterwarnings("ignore:The inplace keyword in DataFrame.reset_index")
def test_mlcroissant_validates_and_loads_a_record_of_each_record_set(mini_release) -> None:
    require_package("mlcroissant")
    croissant = mini_release.path / "croissant.json"
    checked = subprocess.run(
        [sys.executable, "-m", "mlcroissant.scripts.validate", "--jsonld", str(croissant)],
        capture_output=True, text=True, cwd=mini_release.path,
    )  # what `mlcroissant validate --jsonld croissant.json` runs
    assert checked.returncode == 0, checked.stderr[-2000:]
    assert "Done." in checked.stderr
    logged = re.findall(r"^([EW])\d{4} .*$", checked.stderr, re.MULTILINE)
    assert logged == [], checked.stderr[-2000:]  # no error and no warning
    import mlcroissant

    dataset = mlcroissant.Dataset(jsonld=str(croissant))
    model = next(iter(dataset.records(record_set="models")))
    assert np.asarray(model["models/points"]).shape == (N_POINTS, 3)
    assert np.asarray(model["models/quality"]).shape == (N_VIEWS, 4)
    assert model["models/split"] in (b"train", b"validation", b"test")
    view = next(iter(dataset.records(record_set="views")))
    assert np.asarray(view["views/direction"]).shape == (3,)


def test_croissant_carries_version_dates_creator_and_rai(mini_release) -> None:
    document = json.loads(mini_release.croissant.read_text(encoding="utf-8"))
    assert document["version"] == "2.1.0"
    assert document["datePublished"] == MINI_CREATED
    assert document["url"] == "https://example.org/src"
    assert document["creator"]["name"] == "Tester"
    card = mini_release.card.read_text(encoding="utf-8")
    for key in ("rai:dataCollection", "rai:dataPreprocessingProtocol", "rai:dataUseCases",
                "rai:dataLimitations", "rai:personalSensitiveInformation",
                "rai:dataReleaseMaintenancePlan"):
        assert document[key], key
    assert "geometric proxies" in document["rai:dataLimitations"]
    assert "geometric proxies" in card
