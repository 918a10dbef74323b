"""tools/reproduce_paper.py: its helpers against closed forms, and a tiny end-to-end run."""

from __future__ import annotations

import importlib
import math
import re
from dataclasses import replace
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from fixtures.environment import require_package
from vptoolkit.geometry import face_areas
from vptoolkit.mesh import Mesh


@pytest.fixture(scope="module")
def tool() -> ModuleType:
    """``tools/reproduce_paper.py`` (tools/ is on the tests' path, see pyproject.toml)."""
    for module in ("torch", "safetensors", "matplotlib", "open3d", "pymeshlab", "zarr", "scipy",
                   "trimesh"):
        require_package(module)
    return importlib.import_module("reproduce_paper")


def _square() -> Mesh:
    vertices = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float64)
    return Mesh(vertices, np.array([[0, 1, 2], [0, 2, 3]]), name="square")


def test_subdivide_keeps_surface_and_shares_midpoints(tool: ModuleType) -> None:
    square = _square()
    once, is_new = tool.subdivide(square)
    assert once.n_faces == 8 and is_new.all()
    assert once.n_vertices == 4 + 5  # four outer edges and the shared diagonal
    assert math.isclose(face_areas(once).sum(), 1.0)
    assert np.allclose(face_areas(once), 1.0 / 8.0)
    edges = once.vertices[once.faces[:, 1:]] - once.vertices[once.faces[:, :1]]
    normals = np.cross(*edges.transpose(1, 0, 2))
    assert (normals[:, 2] > 0).all()  # winding kept


def test_subdivide_selected_faces_only(tool: ModuleType) -> None:
    partly, is_new = tool.subdivide(_square(), np.array([True, False]))
    assert partly.n_faces == 5 and is_new.tolist() == [False, True, True, True, True]
    assert math.isclose(face_areas(partly).sum(), 1.0)


def test_mesh_with_faces_hits_the_target(tool: ModuleType) -> None:
    mesh = tool.mesh_with_faces(_square(), 100)
    assert 100 <= mesh.n_faces <= 102
    assert math.isclose(face_areas(mesh).sum(), 1.0)


def test_flat_part_finds_the_seat(tool: ModuleType) -> None:
    from vptoolkit.synthetic import make_shape

    chair = make_shape("chair", seed=47)
    is_seat = tool.flat_part(chair)
    assert is_seat.sum() == 2
    seat_height = chair.vertices[chair.faces[is_seat]][..., 2]
    assert np.ptp(seat_height) < 1e-9


def test_spearman_matches_closed_forms(tool: ModuleType) -> None:
    values = np.array([3.0, 1.0, 2.0, 5.0, 4.0])
    assert math.isclose(tool.spearman(values, values**3), 1.0)
    assert math.isclose(tool.spearman(values, -values), -1.0)
    # 1 - 6 sum d^2 / (n (n^2 - 1)) without ties: ranks (2,0,1,4,3) vs (0,1,2,3,4)
    other = np.array([1.0, 2.0, 3.0, 4.0, 5.0])
    assert math.isclose(tool.spearman(values, other), 1 - 6 * 8 / (5 * 24))
    assert math.isclose(tool.spearman(np.array([1.0, 1.0, 2.0]), np.array([1.0, 2.0, 3.0])),
                        math.sqrt(3) / 2)  # tied ranks (0.5, 0.5, 2) against (0, 1, 2)
    assert math.isnan(tool.spearman(np.array([1.0, np.nan]), np.array([1.0, 2.0])))


def test_quick_options_stay_out_of_docs(tool: ModuleType, tmp_path: Path) -> None:
    options = tool.parse_args(["--quick", "--out", str(tmp_path)])
    assert options.results == tmp_path / "results.md"
    assert options.figures == tmp_path / "figures"
    assert options.labels_out == tmp_path / "labels"
    assert options.sizes == tool.QUICK
    full = tool.parse_args(["--skip-labels"])
    assert full.results == Path("docs/results.md") and "labels" not in full.sections
    assert full.labels_out == Path("reproduction/labels")


def _tiny(tool: ModuleType) -> object:
    labels = replace(tool.reproduce_labels.QUICK, epochs=1, n_views=40, resolution=32, n_points=600,
                     point_features=())
    return replace(
        tool.QUICK, labels=labels, label_methods=("ml+gl",),
        timing_faces=(2000, 10_000), timing_views=(20, 250), timing_resolution=64,
        timing_batches=(1, 4), timing_points=512, timing_fps=128, network_repeats=1,
        sample_meshes=("bottle.obj", "mug.obj", "teapot.stl"),
        subdivision_levels=2, subdivision_views=40, subdivision_resolution=64,
        resolution_meshes=("teapot.stl",), resolutions=(32, 64, 128), resolution_views=40,
    )


def _is_non_blank_png(path: Path) -> bool:
    import matplotlib.image

    pixels = matplotlib.image.imread(path)
    return bool(pixels.ndim == 3 and float(pixels[..., :3].var()) > 1e-4)


@pytest.mark.slow
def test_tiny_run_writes_every_section_and_figure(tool: ModuleType, tmp_path: Path) -> None:
    results = tmp_path / "results.md"
    results.write_text("# Results\n\nkept text\n")
    options = tool.RunOptions(
        out=tmp_path / "out", labels_out=tmp_path / "labels", results=results,
        figures=tmp_path / "figures", sizes=_tiny(tool), workers=1,
        command="python tools/reproduce_paper.py --quick",
    )
    sections = tool.run(options)
    assert list(sections) == list(tool.SECTIONS)

    text = results.read_text()
    assert "kept text" in text
    for name in tool.SECTIONS:
        block = text[text.index(f"<!-- {name}:start -->"): text.index(f"<!-- {name}:end -->")]
        assert "wall time" in block and "CPUs" in block, name
        assert re.search(r"\| \d+(\.\d+)? ", block), name  # a table row with numbers
    assert "Table 2" in text and "Table 3" in text and "Table 4" in text and "Figure 8" in text
    assert "(0.263 s)" in text and "(20 s)" in text  # the paper's 10k-face times beside ours
    assert "Recommendation:" in text
    for figure in ("fig8_subdivision.png", "resolution_study.png"):
        assert _is_non_blank_png(tmp_path / "figures" / figure), figure
    assert "](figures/fig8_subdivision.png)" in text
    assert (tmp_path / "out" / "paper.json").is_file()

    # sections regenerate independently: rerunning one keeps the others
    again = tool.run(replace(options, sections=("timings",)))
    assert list(again) == ["timings"]
    rerun = results.read_text()
    assert rerun.count("<!-- timings:start -->") == 1
    assert "Figure 8" in rerun and "kept text" in rerun
