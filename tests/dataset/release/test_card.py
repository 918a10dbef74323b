"""The release's README.md card: its hub YAML header, datasheet sections, numbers from the
data and the reading instructions of the formats shipped."""

from __future__ import annotations

import re
from collections import Counter
from pathlib import Path

import numpy as np

from fixtures.environment import require_package
from fixtures.releases import CATEGORIES, FAILURES, N_MODELS, source_records, write_build_to_pack
from fixtures.stores import N_POINTS, N_VIEWS
from vptoolkit.dataset.release.options import ReleaseOptions

DATASHEET_SECTIONS = (
    "Motivation", "Composition", "Collection process", "Preprocessing, cleaning and labeling",
    "Uses", "Distribution", "Maintenance",
)


def _front_matter(card: str) -> str:
    match = re.match(r"---\n(.*?)\n---\n", card, re.DOTALL)
    assert match, "no YAML front matter"
    return match[1]


def test_card_yaml_header(build: Path, release) -> None:
    header = _front_matter(release.card.read_text(encoding="utf-8"))
    records = source_records(build)
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
    records = source_records(build)
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


def test_card_dataset_info_has_features_and_sizes(mini_release) -> None:
    require_package("datasets")
    import yaml
    from datasets import DatasetInfo, Features

    card = mini_release.card.read_text(encoding="utf-8")
    header = yaml.safe_load(card.split("---\n")[1])
    default = next(c for c in header["dataset_info"] if c["config_name"] == "default")
    features = Features._from_yaml_list(default["features"])
    assert features["points"].shape == (N_POINTS, 3) and features["points"].dtype == "float32"
    assert features["mesh_faces"].shape == (None, 3)
    assert all(split["num_bytes"] > 0 for split in default["splits"])
    assert sum(split["num_examples"] for split in default["splits"]) == N_MODELS
    DatasetInfo._from_yaml_dict(default)  # the hub's own parser accepts it
    assert header["license_name"] and header["license_link"] == "LICENSES.csv"
    assert header["pretty_name"] == "Mini viewpoints"


def test_hdf5_only_card_promises_no_datasets_loading(tmp_path: Path) -> None:
    import yaml

    from vptoolkit.dataset.release.pack import pack_release

    build = write_build_to_pack(tmp_path / "build")
    result = pack_release(build, tmp_path / "release", ReleaseOptions(formats=["hdf5"]))
    card = result.card.read_text(encoding="utf-8")
    header = yaml.safe_load(card.split("---\n")[1])
    assert "configs" not in header and "dataset_info" not in header
    body = card.split("---\n", 2)[2]
    assert "load_dataset" not in body and "Parquet shards hold" not in body
    assert f"`datasets` cannot load it; read `{result.hdf5.name}`" in body
    assert f'h5py.File("{result.hdf5.name}"' in body
    assert "zarr" not in body.split("## Counts")[0]  # no Zarr zip to name


def test_card_shows_zarr_reading_only_with_a_zarr_zip(mini_release) -> None:
    body = mini_release.card.read_text(encoding="utf-8").split("## Counts")[0]
    assert f'ZipStore("{mini_release.zarr_zip.name}"' in body
    assert f'h5py.File("{mini_release.hdf5.name}"' in body


def test_card_states_modelnet_terms_lists_the_loaded_columns_and_names_mlcroissant(
        mini_release) -> None:
    from vptoolkit.dataset.release.card import MODELNET_TERMS, _terms_block

    card = mini_release.card.read_text(encoding="utf-8")
    assert MODELNET_TERMS in card  # the source, ModelNet40-mini, is recognised
    assert _terms_block("my-scans") == ""
    assert "| `points` | float32 | (200, 3) | points sampled by area on the cleaned mesh |" in card
    assert "| `mesh_faces` | int32 | (n, 3) |" in card
    assert ("| `label` | int64 | scalar | class label: the category's index in the sorted "
            "category names |") in card
    assert "pip install 'mlcroissant[parquet]'" in card
    assert 'records(record_set="models")' in card
