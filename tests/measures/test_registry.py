"""The measure registry, measures chosen by name, and the paper's four through the general path."""

import importlib
import json
import pkgutil

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.measures import catalog
from vptoolkit.measures.quality import compute_view_quality, normalize_quality, ranked_views
from vptoolkit.measures.measure import FAMILIES, NEEDS, Measure
from vptoolkit.measures.registry import (
    PAPER_MEASURES,
    all_measures,
    canonical_name,
    get_measure,
    measure_index,
    resolve_measures,
)
from vptoolkit.samples import sample_path
from vptoolkit.settings import MeasureSettings
from vptoolkit.sphere import fibonacci_sphere


def catalog_modules() -> list[str]:
    return [module.name for module in pkgutil.iter_modules(catalog.__path__)
            if not module.name.startswith("_")]


def test_every_catalog_module_declares_one_measure_and_names_are_unique():
    names = []
    for name in catalog_modules():
        module = importlib.import_module(f"{catalog.__name__}.{name}")
        assert isinstance(module.MEASURE, Measure), name
        assert module.MEASURE.family in FAMILIES and module.MEASURE.needs <= NEEDS
        assert module.__doc__ and module.MEASURE.source, name  # formula, direction, source
        assert module.MEASURE in catalog.CATALOG, f"{name} is not listed in CATALOG"
        names.append(module.MEASURE.name)
    assert len(names) == len(set(names)) == len(catalog.CATALOG)
    assert sorted(all_measures()) == sorted(names)


def test_all_lists_by_family_in_the_catalog_order():
    order = [FAMILIES.index(m.family) for m in all_measures().values()]
    assert order == sorted(order)
    assert tuple(all_measures().values()) == catalog.CATALOG
    assert resolve_measures("all") == (
        "NVT", "PA", "HM", "VR", "VE", "VKL", "VMI", "I2", "I3", "SL", "SE", "SC", "SCE",
        "MD", "DD", "SS", "INS", "DVS", "CE", "SAL", "EVMI", "MS")
    assert resolve_measures("all") == tuple(all_measures())
    assert resolve_measures(" ALL ") == tuple(all_measures())
    area = [name for name, m in all_measures().items() if m.family == "area"]
    assert area == ["NVT", "PA", "HM", "VR", "VE", "VKL"]
    information = [name for name, m in all_measures().items() if m.family == "information"]
    assert information == ["VMI", "I2", "I3"]
    stability = [name for name, m in all_measures().items() if m.family == "stability"]
    assert stability == ["INS", "DVS"]


def test_paper_and_none_give_the_four_in_their_order():
    assert resolve_measures(None) == resolve_measures("paper") == PAPER_MEASURES
    assert tuple(get_measure(name).higher_is_better for name in PAPER_MEASURES) == (
        True, True, False, False)


def test_names_keep_the_order_given():
    assert resolve_measures("I3, NVT,VE") == ("I3", "NVT", "VE")
    assert resolve_measures(["INS", "PA"]) == ("INS", "PA")


def test_names_are_taken_in_any_case_and_given_in_the_registry_spelling():
    assert resolve_measures("ve, sl,Vkl") == ("VE", "SL", "VKL")
    assert resolve_measures("PAPER") == resolve_measures("Paper") == PAPER_MEASURES
    assert canonical_name("evmi") == "EVMI" and get_measure("nvt").name == "NVT"
    assert measure_index("vmi") == 3 and measure_index("sl", ("NVT", "SL")) == 1
    with pytest.raises(InputError, match=r"^measure: SL is not among the measures here"):
        measure_index("SL")


@pytest.mark.parametrize("spec, message", [
    ("VE,NOPE", "unknown measure 'NOPE'"),
    ("ve,VE", "VE named twice"),
    (",", "no measure named"),
    ("NVT,PA,NVT", "NVT named twice"),
])
def test_bad_names_are_input_errors_naming_them(spec, message):
    with pytest.raises(InputError, match=message):
        resolve_measures(spec)


def test_the_four_are_unchanged_through_the_general_path(bunny):
    settings = MeasureSettings(resolution=96)
    views = fibonacci_sphere(60)
    paper = compute_view_quality(bunny, settings, view_directions=views)
    more = compute_view_quality(bunny, settings, view_directions=views,
                                measures="VE,VR,VKL,VMI,NVT")
    assert more.measures == ("VE", "VR", "VKL", "VMI", "NVT")
    assert more.raw.shape == more.normalized.shape == (60, 5)
    np.testing.assert_array_equal(more.raw[:, :4], paper.raw)
    np.testing.assert_array_equal(more.normalized[:, :4], paper.normalized)
    np.testing.assert_array_equal(more.best_index[:4], paper.best_index)
    reordered = compute_view_quality(bunny, settings, view_directions=views, measures="VMI,VE")
    np.testing.assert_array_equal(reordered.raw, paper.raw[:, [3, 0]])


def test_only_the_requested_columns_and_directions_follow_the_names(cube):
    quality = compute_view_quality(cube, MeasureSettings(views=50, resolution=64),
                                   measures="I2,NVT")
    assert quality.measures == ("I2", "NVT")
    assert quality.higher_is_better == (False, True)
    assert quality.best_index.shape == quality.worst_index.shape == (2,)
    assert quality.best_views.shape == (2, 3)
    i2, nvt = quality.raw.T
    assert i2[quality.best_index[0]] == np.nanmin(i2)
    assert nvt[quality.best_index[1]] == nvt.max()
    assert list(quality.summary()["best"]) == ["I2", "NVT"]
    assert quality.summary()["best"]["I2"]["higher_is_better"] is False


def test_normalisation_and_ranking_take_any_directions():
    raw = np.array([[1.0, 5.0, 2.0], [3.0, 1.0, np.nan], [2.0, 3.0, 4.0]])
    normalized = normalize_quality(raw, [True, False, False])
    np.testing.assert_allclose(normalized, [[0, 0, 1], [1, 1, 0], [0.5, 0.5, 0]])
    np.testing.assert_array_equal(ranked_views(raw, 1, [True, False, True]), [1, 2, 0])
    np.testing.assert_array_equal(ranked_views(raw, 2, [True, True, True]), [2, 0, 1])
    with pytest.raises(InputError, match=r"expected shape \(n_views, 4\)"):
        normalize_quality(raw)  # the paper's four by default
    four = np.array([[1.0, 0.2, 5.0, 3.0], [3.0, 0.6, 1.0, 1.0]])
    np.testing.assert_array_equal(ranked_views(four, 2), [1, 0])  # VKL: lower is better


def test_npz_stores_the_names_and_directions(tmp_path, cube):
    quality = compute_view_quality(cube, MeasureSettings(views=40, resolution=64),
                                   measures="PA,VMI,I3")
    path = quality.save_npz(tmp_path / "cube.npz")
    with np.load(path, allow_pickle=False) as stored:
        assert tuple(stored["measures"]) == ("PA", "VMI", "I3")
        np.testing.assert_array_equal(stored["higher_is_better"], [True, False, True])
        np.testing.assert_array_equal(stored["raw"], quality.raw)
        np.testing.assert_array_equal(stored["best_index"], quality.best_index)


@pytest.fixture
def runner() -> CliRunner:
    return CliRunner()


def test_cli_measures_by_name_in_table_json_and_npz(runner, tmp_path):
    mesh = str(sample_path("suzanne.ply"))
    table = runner.invoke(main, ["measures", mesh, "--views", "60", "--resolution", "96",
                                 "--measures", "NVT,I2,INS"])
    assert table.exit_code == 0, table.output
    rows = [line.split() for line in table.stdout.splitlines()[2:5]]
    assert [(row[0], row[-1]) for row in rows] == [("NVT", "max"), ("I2", "min"), ("INS", "min")]
    out = tmp_path / "suzanne.npz"
    result = runner.invoke(main, ["measures", mesh, "--views", "60", "--resolution", "96",
                                  "--measures", "PA,VE", "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout)
    assert list(summary["best"]) == ["PA", "VE"]
    with np.load(out, allow_pickle=False) as stored:
        assert tuple(stored["measures"]) == ("PA", "VE")
        assert [summary["best"][m]["view_index"] for m in ("PA", "VE")] == list(
            stored["best_index"])


@pytest.mark.parametrize("spec, message", [
    ("VE,XYZ", "--measures: unknown measure 'XYZ'; known: NVT, PA"),
    ("VE,VE", "--measures: VE named twice"),
    (" , ", "--measures: no measure named"),
])
def test_cli_bad_measure_names_are_one_line_and_exit_2(runner, spec, message):
    result = runner.invoke(main, ["measures", str(sample_path("teapot.stl")),
                                  "--measures", spec])
    assert result.exit_code == 2
    assert result.stderr.count("\n") == 1 and "Traceback" not in result.output
    assert result.stderr.startswith(f"vptool: error: {message}")


def test_cli_help_shows_a_measures_example(runner):
    result = runner.invoke(main, ["measures", "--help"])
    assert result.exit_code == 0
    assert "--measures NVT,PA,I3,INS" in result.output and "'all'" in result.output
