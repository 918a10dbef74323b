"""Priors of the search: the occlusion-free one, and every prior found by name."""

import json

import numpy as np
import pytest
from click.testing import CliRunner

from vptoolkit.best_view.prior import Prior, UnoccludedPrior, resolve_prior
from vptoolkit.best_view.run import search_inputs
from vptoolkit.best_view.search import SearchSettings, search_best_views
from vptoolkit.cli import main
from vptoolkit.errors import InputError
from vptoolkit.io import load_mesh
from vptoolkit.measures.unoccluded import mesh_elements, unoccluded_quality
from vptoolkit.mesh import Mesh
from vptoolkit.rotations import fixed_rotations
from vptoolkit.samples import sample_path
from vptoolkit.sphere import coarse_directions

SIXTEEN = SearchSettings(budget=16, resolution=64)
EIGHT = SearchSettings(budget=8, resolution=32)


@pytest.fixture(scope="module")
def teapot() -> Mesh:
    return load_mesh(sample_path("teapot.stl"))


def test_the_prior_turns_with_the_mesh(teapot):
    """The sphere turns with the mesh up to its axes' signs: the candidates stay as good."""
    prior = UnoccludedPrior()
    elements = mesh_elements(teapot)
    upright = unoccluded_quality(*elements, prior(teapot))
    for turn in fixed_rotations("teapot", 3):
        turned = prior(Mesh(teapot.vertices @ turn.T, teapot.faces, name="teapot")) @ turn
        again = unoccluded_quality(*elements, turned)
        assert np.nanmax(again[:, 0]) > 0.99 * np.nanmax(upright[:, 0])  # VE
        assert np.nanmin(again[:, 2]) < 1.05 * np.nanmin(upright[:, 2])  # VKL


def test_as_a_search_prior_its_first_candidate_is_drawn_at_full_resolution(teapot):
    candidates = UnoccludedPrior()(teapot)
    found = search_best_views(teapot, SIXTEEN, prior=candidates)
    assert [(s.name, s.n_views) for s in found.stages][:2] == [("coarse", 7), ("prior", 2)]
    again = search_best_views(teapot, SIXTEEN, prior=UnoccludedPrior()(teapot))
    np.testing.assert_array_equal(found.directions, again.directions)


def test_command_with_the_unoccluded_prior(tmp_path):
    out = tmp_path / "best.npz"
    result = CliRunner().invoke(main, ["best-view", str(sample_path("teapot.stl")), "--views",
                                       "8", "--resolution", "48", "--prior", "unoccluded",
                                       "--json", "-o", str(out)])
    assert result.exit_code == 0, result.output
    entry = json.loads(result.stdout)["results"][0]
    assert [stage["stage"] for stage in entry["stages"]] == ["coarse", "prior (unoccluded)"]
    assert entry["views"] == 8 and out.exists()


def test_the_sphere_of_the_prior_is_the_search_sphere(teapot):
    prior = UnoccludedPrior(n_directions=64, per_measure=1)
    assert all(np.isclose(np.abs(coarse_directions(teapot, 64) @ c).max(), 1.0)
               for c in prior(teapot))


def test_bad_prior_options_are_one_line_errors():
    with pytest.raises(InputError, match="n_directions"):
        UnoccludedPrior(0)
    with pytest.raises(InputError, match="min_angle_deg"):
        UnoccludedPrior(min_angle_deg=180.0)


def test_resolve_prior_by_name_and_as_given(teapot):
    assert resolve_prior("none") is None and resolve_prior(None) is None
    unoccluded = resolve_prior("unoccluded")
    assert isinstance(unoccluded, UnoccludedPrior) and isinstance(unoccluded, Prior)
    np.testing.assert_array_equal(unoccluded(teapot), UnoccludedPrior()(teapot))

    def upwards(mesh: Mesh) -> np.ndarray:
        return np.array([[0.0, 1.0, 0.0]])

    assert resolve_prior(upwards) is upwards
    with pytest.raises(InputError) as refused:
        resolve_prior(3)  # type: ignore[arg-type]
    assert str(refused.value) == ("prior: expected one of 'none', 'unoccluded', 'default', a "
                                  "checkpoint path or a callable, got 3")


def test_the_unoccluded_prior_proposes_only_for_the_measures_it_estimates(teapot):
    assert resolve_prior("unoccluded", measures="paper").proposing == ("VE", "VR", "VKL")
    assert UnoccludedPrior(measures="VMI,SL").proposing == ("VKL",)
    np.testing.assert_array_equal(UnoccludedPrior(measures="VMI").proposing, ("VKL",))
    assert resolve_prior("unoccluded", measures="NVT,SL")(teapot).shape == (0, 3)
    with pytest.raises(InputError, match="unknown measure 'XYZ'"):
        UnoccludedPrior(measures="XYZ")


def test_search_inputs_takes_a_prior_by_name_or_as_a_callable():
    mug = sample_path("mug.obj")
    named = search_inputs([mug], settings=EIGHT, prior="unoccluded")
    given = search_inputs([mug], settings=EIGHT, prior=UnoccludedPrior())
    np.testing.assert_array_equal(named.results[0].directions, given.results[0].directions)
    assert [stage.name for stage in named.results[0].stages] == ["coarse", "prior (unoccluded)"]
    plain = search_inputs([mug], settings=EIGHT, prior=lambda mesh: UnoccludedPrior()(mesh))
    assert [stage.name for stage in plain.results[0].stages] == ["coarse", "prior"]
    with pytest.raises(InputError, match="prior: expected one of"):
        search_inputs([mug], settings=EIGHT, prior=3.5)  # type: ignore[arg-type]


def test_a_cloud_with_normals_proposes_as_its_mesh_and_one_without_is_refused(teapot):
    from vptoolkit.point_cloud import PointCloud
    from vptoolkit.points import sample_surface

    sample = sample_surface(teapot, 20000, seed=0)
    from_points = UnoccludedPrior()(PointCloud(sample.points, sample.normals, name="teapot"))
    elements = mesh_elements(teapot)
    on_mesh = unoccluded_quality(*elements, UnoccludedPrior()(teapot))
    on_points = unoccluded_quality(*elements, from_points)
    assert np.nanmax(on_points[:, 0]) > 0.99 * np.nanmax(on_mesh[:, 0])  # VE
    assert np.nanmin(on_points[:, 2]) < 1.05 * np.nanmin(on_mesh[:, 2])  # VKL
    with pytest.raises(InputError, match=r"^scan: a point cloud without normals; the "
                                         "occlusion-free estimate reads"):
        UnoccludedPrior()(PointCloud(sample.points, name="scan"))
