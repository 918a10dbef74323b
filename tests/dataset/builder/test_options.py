"""BuildOptions: defaults from named constants, one-line checks, the staging record's round trip."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from vptoolkit.clean.simplify import MAX_FACES
from vptoolkit.conventions import SEED
from vptoolkit.dataset.builder.options import DEFAULT_FORMAT, BuildOptions, SplitFile
from vptoolkit.dataset.builder.staging import resume_or_start
from vptoolkit.errors import InputError
from vptoolkit.points import N_SURFACE_POINTS
from vptoolkit.samples import SAMPLE_SPLITS
from vptoolkit.settings import MeasureSettings


def test_defaults_come_from_named_constants():
    options = BuildOptions()
    assert options.measure == MeasureSettings()
    assert (options.n_points, options.max_faces, options.split_seed) == (
        N_SURFACE_POINTS, MAX_FACES, SEED)
    assert (options.clean, options.remesh, options.splits, options.max_models) == (
        True, False, None, None)
    assert options.format == DEFAULT_FORMAT and options.store_name == "dataset.zarr"


@pytest.mark.parametrize(("fields", "message"), [
    ({"n_points": 0}, "n_points: must be at least 1, got 0"),
    ({"max_faces": 3}, "max_faces: must be at least 4, got 3"),
    ({"format": "npz"}, "format: expected one of zarr, hdf5, got 'npz'"),
    ({"clean": "yes"}, "clean: expected True or False, got 'yes'"),
    ({"split_seed": 1.5}, "split_seed: expected an integer, got 1.5"),
    ({"max_models": 0}, "max_models: must be at least 1, got 0"),
    ({"clean": False, "remesh": True}, "remesh: remeshing is a cleaning step; it needs clean=True"),
    ({"measure": {"views": 10}}, "measure: expected MeasureSettings, got dict"),
    ({"splits": "splits.csv"}, "splits: expected a SplitFile (SplitFile.read(path)), got str"),
])
def test_bad_fields_raise_one_line_input_errors(fields, message):
    with pytest.raises(InputError) as info:
        BuildOptions(**fields)
    assert str(info.value) == message


def test_the_staging_record_gives_back_equal_options():
    splits = SplitFile.read(SAMPLE_SPLITS)
    options = BuildOptions(MeasureSettings(views=40, resolution=48), n_points=200, clean=False,
                           split_seed=3, splits=splits, max_models=5, format="hdf5")
    record = json.loads(json.dumps(options.to_dict()))
    assert record["measure"]["views"] == 40 and record["splits_sha256"] == splits.sha256
    again = BuildOptions.from_dict(record)
    assert again == options and again.splits is not None and again.splits.path is None
    assert BuildOptions.from_dict(record) != replace(options, n_points=201)


def test_max_points_is_recorded_and_an_older_record_read_the_default():
    options = BuildOptions(max_points=5000)
    assert BuildOptions.from_dict(options.to_dict()) == options != BuildOptions()
    record = BuildOptions().to_dict()
    del record["max_points"]  # a build.json written before the option
    assert BuildOptions.from_dict(record) == BuildOptions()
    with pytest.raises(InputError, match="^max_points: must be at least 1, got 0$"):
        BuildOptions(max_points=0)


def test_sampling_is_recorded_and_an_older_record_reads_uniform():
    options = BuildOptions(sampling="scan")
    assert BuildOptions.from_dict(options.to_dict()) == options != BuildOptions()
    assert options.store_attrs()["sampling"] == "scan"
    assert "sampling" not in BuildOptions().store_attrs()  # default builds keep their bytes
    record = BuildOptions().to_dict()
    del record["sampling"]  # a build.json written before the option
    assert BuildOptions.from_dict(record) == BuildOptions()
    with pytest.raises(InputError, match="^sampling: expected one of uniform, scan, got 'x'$"):
        BuildOptions(sampling="x")


def test_a_record_with_missing_or_unknown_keys_is_refused():
    record = BuildOptions().to_dict()
    del record["n_points"]
    record["n_views"] = 1000
    with pytest.raises(InputError, match="^build options: missing n_points; unknown n_views$"):
        BuildOptions.from_dict(record)


def test_split_files_are_the_same_when_their_bytes_are(tmp_path):
    first, second = tmp_path / "a.csv", tmp_path / "b.csv"
    first.write_text("name,split\nmug,train\n")
    second.write_text("name,split\nmug,train\n")
    assert SplitFile.read(first) == SplitFile.read(second)
    second.write_text("name,split\nmug,test\n")
    assert SplitFile.read(first) != SplitFile.read(second)
    with pytest.raises(InputError, match="missing.csv: cannot read the split file"):
        SplitFile.read(tmp_path / "missing.csv")


def test_store_attributes_keep_the_schema_layout():
    splits = SplitFile.read(SAMPLE_SPLITS)
    options = BuildOptions(MeasureSettings(resolution=64), max_faces=2000, splits=splits)
    attrs = options.store_attrs()
    assert attrs["resolution"] == 64 and attrs["backend"] == "raster"
    assert attrs["camera"]["fov_deg"] == 45.0
    assert attrs["cleaning"] == {"enabled": True, "max_faces": 2000, "remesh": False}
    assert attrs["split_file"] == {"name": "splits.csv", "sha256": splits.sha256}


def test_a_build_folder_resumes_only_with_equal_options_and_toolkit(tmp_path):
    options = BuildOptions(MeasureSettings(views=40), n_points=100)
    created = resume_or_start(tmp_path, options, tmp_path)
    record = json.loads((tmp_path / "build.json").read_text())
    assert BuildOptions.from_dict(record["options"]) == options
    assert resume_or_start(tmp_path, replace(options), tmp_path) == created
    other = replace(options, measure=MeasureSettings(views=50), n_points=200)
    with pytest.raises(InputError, match=r"measure\.views=40 \(now 50\); n_points=100 \(now 200\)"):
        resume_or_start(tmp_path, other, tmp_path)
    (tmp_path / "build.json").write_text(json.dumps({**record, "toolkit_version": "0.0.1"}))
    with pytest.raises(InputError, match=r"toolkit_version='0\.0\.1' \(now '"):
        resume_or_start(tmp_path, options, tmp_path)
    del record["options"]["measure"]
    (tmp_path / "build.json").write_text(json.dumps(record))
    with pytest.raises(InputError, match="unreadable build record .*missing measure"):
        resume_or_start(tmp_path, options, tmp_path)
