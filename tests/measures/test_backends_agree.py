"""The raster and raycast backends rank the views alike for every measure.

Both backends sample the same pixel centres, so they differ only where a pixel
centre lies on a triangle edge at the silhouette, or where the ray caster,
stepping past a back face it hit first, also steps past a front face in the
same plane (bunny.ply holds one triangle three times, once reversed: the
raster draws it, the ray caster sees through it). The measures that
read only the pixel counts and the per-view depth and silhouette statistics
must rank the views alike: Spearman's rank correlation between the two
backends' raw values over 1000 views at least :data:`BAR` (issue 31).

The silhouette measures that histogram turning angles react to those few edge
pixels: one pixel more or less on a contour changes the turning angles near it.
Where a mesh's views differ little in such a measure, that noise reorders them;
:data:`BELOW_BAR` holds the known cases with their measured correlation.
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.typing import NDArray
from scipy.stats import spearmanr

from fixtures.environment import require_package
from vptoolkit.io import load_mesh
from vptoolkit.measures.quality import ViewQuality, compute_view_quality
from vptoolkit.measures.registry import all_measures
from vptoolkit.samples import sample_names, sample_path
from vptoolkit.settings import Backend, MeasureSettings

BAR = 0.97
"""The issue's bar on the rank correlation between the backends."""

IMAGE_MEASURES = ("NVT", "PA", "HM", "VR", "VE", "VKL", "VMI", "I2", "I3",
                  "SL", "SE", "SC", "SCE", "MD", "DD", "SS")
"""The area and information families, the silhouette and depth measures: what reads only
the pixel counts and each view's depth and silhouette statistics."""

BELOW_BAR = {
    # bunny.ply, 16k faces, 1000 views at 128 px: SE 0.966 (SCE 0.977, SC 0.990); its views'
    # silhouette entropies lie within 0.5 bit (standard deviation 0.096), and 163 of the
    # 1000 views have a turning histogram that differs between the backends, by 0.007 bit
    # on average. At 256 px more views differ and SE falls to 0.941, SCE to 0.965.
    "bunny.ply": {"SE"},
}
"""Measures known to fall below :data:`BAR` on a mesh, with the evidence."""

BACKENDS: tuple[Backend, Backend] = ("raster", "raycast")


def rank_correlation(first: NDArray[np.float64], second: NDArray[np.float64]) -> float:
    """Spearman's rho of two columns; 1 where both are the same constant (no ranking)."""
    if np.ptp(first) == 0 and np.ptp(second) == 0:
        np.testing.assert_allclose(first, second)
        return 1.0
    return float(spearmanr(first, second).statistic)


def both_backends(mesh_name: str, views: int, resolution: int,
                  measures: str) -> tuple[ViewQuality, ViewQuality]:
    require_package("open3d")
    mesh = load_mesh(sample_path(mesh_name))
    raster, raycast = (
        compute_view_quality(mesh, MeasureSettings(views=views, resolution=resolution,
                                                   backend=backend), measures=measures)
        for backend in BACKENDS)
    assert np.array_equal(np.isnan(raster.raw), np.isnan(raycast.raw))
    return raster, raycast


def correlations(raster: ViewQuality, raycast: ViewQuality) -> dict[str, float]:
    return {name: rank_correlation(raster.raw[:, i], raycast.raw[:, i])
            for i, name in enumerate(raster.measures)}


def test_every_measure_ranks_the_views_of_a_teapot_alike_with_either_backend() -> None:
    raster, raycast = both_backends("teapot.stl", 200, 64, "all")
    assert raster.measures == tuple(all_measures())
    rho = correlations(raster, raycast)
    assert min(rho.values()) >= BAR, rho


@pytest.mark.slow
@pytest.mark.parametrize("mesh_name", sample_names())
def test_image_measures_rank_1000_views_alike_with_either_backend(mesh_name: str) -> None:
    raster, raycast = both_backends(mesh_name, 1000, 128, ",".join(IMAGE_MEASURES))
    rho = correlations(raster, raycast)
    below = {name for name, value in rho.items() if value < BAR}
    assert below == BELOW_BAR.get(mesh_name, set()), rho
