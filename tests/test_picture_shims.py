"""The old module paths of ``vptoolkit.pictures`` keep working for one release.

Each old module is a shim: a docstring saying where its names moved, imports
and ``__all__``, no logic; every name it exported is the very object of the
new module.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

import vptoolkit

MOVED = {
    "vptoolkit.render": {
        "RenderStyle": "vptoolkit.pictures.shading",
        "Renderer": "vptoolkit.pictures.open3d_engine",
        "RenderedView": "vptoolkit.pictures.views",
        "DirectionSource": "vptoolkit.pictures.views",
        "render_view": "vptoolkit.pictures.views",
        "render_views": "vptoolkit.pictures.views",
        "render_best": "vptoolkit.pictures.views",
        "render_predicted": "vptoolkit.pictures.views",
        "resolve_direction": "vptoolkit.pictures.views",
        "check_renderer": "vptoolkit.pictures.open3d_engine",
        "ENGINES": "vptoolkit.pictures.engine",
        "open_renderer": "vptoolkit.pictures.engine",
        "png_bytes": "vptoolkit.pictures.png",
        "save_png": "vptoolkit.pictures.png",
    },
    "vptoolkit.software_render": {"SoftwareRenderer": "vptoolkit.pictures.software_engine"},
    "vptoolkit.shading": dict.fromkeys(
        ["RenderStyle", "CreaseNormals", "crease_normals", "picture_camera", "light_direction",
         "srgb_to_linear", "linear_to_srgb"], "vptoolkit.pictures.shading"),
    "vptoolkit.sphere_map": dict.fromkeys(
        ["BEST_COLOR", "PREDICTED_COLOR", "VIEW_SET_COLOR", "view_coordinates", "mercator_y",
         "sphere_grid", "sphere_map", "sphere_maps", "save_figure", "sphere_map_file"],
        "vptoolkit.pictures.sphere_map"),
    "vptoolkit.thumbnails": dict.fromkeys(
        ["ThumbnailFailure", "ThumbnailResult", "render_thumbnails"],
        "vptoolkit.pictures.thumbnails"),
    "vptoolkit.contact_sheet": dict.fromkeys(
        ["contact_sheet", "view_set_captions", "view_set_sheet"],
        "vptoolkit.pictures.contact_sheet"),
    "vptoolkit.report": {"write_report": "vptoolkit.pictures.report"},
}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_names_are_the_new_objects(old):
    shim = importlib.import_module(old)
    assert sorted(shim.__all__) == sorted(MOVED[old])
    for name, new in MOVED[old].items():
        assert getattr(shim, name) is getattr(importlib.import_module(new), name), name


def test_any_renderer_is_the_engine_protocol():
    from vptoolkit.pictures.engine import Engine
    from vptoolkit.render import AnyRenderer

    assert AnyRenderer is Engine


@pytest.mark.parametrize("old", sorted(MOVED))
def test_a_shim_holds_no_logic(old):
    path = Path(vptoolkit.__file__).parent / f"{old.split('.')[1]}.py"
    body = ast.parse(path.read_text()).body
    docstring = ast.get_docstring(ast.Module(body=body, type_ignores=[]))
    assert docstring is not None and "vptoolkit.pictures" in docstring.splitlines()[0]
    for node in body[1:]:
        is_all = isinstance(node, ast.Assign) and [getattr(t, "id", "") for t in node.targets] == [
            "__all__"]
        assert isinstance(node, ast.ImportFrom) or is_all, ast.dump(node)[:80]
