"""The measure registry: the catalog's measures by name, the presets, names in any case."""

import importlib
import pkgutil

import pytest

from vptoolkit.errors import InputError
from vptoolkit.measures import catalog
from vptoolkit.measures.measure import FAMILIES, NEEDS, Measure
from vptoolkit.measures.registry import (
    PAPER_MEASURES,
    all_measures,
    canonical_name,
    get_measure,
    measure_index,
    resolve_measures,
)


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


def test_the_measures_defined_on_points_are_those_of_pixel_counts_and_view_saliency():
    from vptoolkit.measures.registry import point_measures

    on_points = [name for name, measure in all_measures().items() if measure.on_points]
    assert on_points == ["NVT", "PA", "HM", "VR", "VE", "VKL", "VMI", "I2", "I3", "INS", "SAL",
                         "EVMI"]
    assert point_measures("vkl,ins", "scan") == ("VKL", "INS")
    with pytest.raises(InputError) as caught:
        point_measures("all", "scan")
    message = str(caught.value)
    assert message.startswith("scan: SL, SE, SC, SCE, MD, DD, SS, DVS, CE, MS are not defined on "
                              "a point cloud (reading silhouettes, depth or a face curvature); "
                              "on points: NVT, PA, HM, VR, VE, VKL, VMI, I2, I3, INS, SAL, EVMI")
    assert "\n" not in message and len(message) <= 200
    with pytest.raises(InputError, match=r"^scan: CE is not defined on a point cloud "
                                         r"\(reading a face curvature\)"):
        point_measures("VE,CE", "scan")
