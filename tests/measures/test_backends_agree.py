"""The raster and raycast backends rank the views alike for every measure.

Both backends sample the same pixel centres and draw the nearest front face
there, so they differ only at pixel centres within a fraction of a subpixel of
a triangle edge (the raster snaps vertices to 1/4096 pixel, the ray caster
intersects in float32) and in which of two identical front faces takes a
pixel. The measures that read only the pixel counts and the per-view depth
and silhouette statistics must rank the views alike: Spearman's rank
correlation between the two backends' raw values over 1000 views at least
:data:`BAR`.

The silhouette measures that histogram turning angles react most to those
few edge pixels: one pixel more or less on a contour changes the turning
angles near it, and where a mesh's views differ little in such a measure that
noise reorders them. :data:`BELOW_BAR` holds the known cases with their
measured correlation.
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
"""The least rank correlation between the backends' raw values that every measure must reach."""

IMAGE_MEASURES = ("NVT", "PA", "HM", "VR", "VE", "VKL", "VMI", "I2", "I3",
                  "SL", "SE", "SC", "SCE", "MD", "DD", "SS")
"""The area and information families, the silhouette and depth measures: what reads only
the pixel counts and each view's depth and silhouette statistics."""

BELOW_BAR: dict[str, set[str]] = {}
"""Measures known to fall below :data:`BAR` on a mesh, with the evidence: none.

bunny.ply (16k faces, 1000 views at 128 px) was the one case, SE at 0.966, while the
ray caster, stepping past a culled face it met first, skipped the front faces at the
same distance (the front one of the 81 triangles the mesh holds twice, once reversed,
and front faces across a silhouette edge from the back face the ray met on it). Since
it casts those rays again against the view's front faces alone, the bunny's lowest
correlations are SCE 0.9997, SE 0.9998 and SC 0.9998.
"""

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
