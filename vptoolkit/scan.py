"""A virtual range scanner: partial, noisy point clouds of a mesh, as a scan sees it.

A scan is one range image of the mesh taken with the camera of
:mod:`vptoolkit.camera` from a scanner direction: the rasteriser's
triangle-ID image (:func:`vptoolkit.visibility.face_id_images`, back faces
culled, nearest face per pixel) tells which face the ray through each pixel
centre hits, and the point is where the ray meets that face's plane,

.. math::

    x = e + t d, \\qquad t = \\frac{n \\cdot a - n \\cdot e}{n \\cdot d},

with ``e`` the scanner (the camera's eye), ``d = forward + u right - w up``
the ray through the pixel centre (``u``, ``w`` its offsets from the image
centre over the focal length), ``n`` the face normal and ``a`` a corner of
the face. Range noise then moves each point along its ray by a Gaussian
distance of standard deviation ``noise * diagonal`` (the bounding-box
diagonal). So a scan sees only the sides that face its scanner and are not
hidden, and, like a real scanner, samples them densely where they are near
and face it and sparsely where they are far or oblique. The directions of
the scanners and the noise come from one seeded generator.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from vptoolkit.camera import Camera
from vptoolkit.checks import check_float, check_int
from vptoolkit.geometry import bounding_frame, face_cross_products
from vptoolkit.mesh import MeshLike, as_mesh
from vptoolkit.settings import MAX_RESOLUTION, MeasureSettings
from vptoolkit.visibility import face_id_images

__all__ = ["SCAN_RESOLUTION", "SCAN_NOISE", "scanner_directions", "virtual_scan"]

SCAN_RESOLUTION = 128
"""Default side of a range image in pixels (about 5000 to 8000 points a scan of a compact model)."""

SCAN_NOISE = 0.005
"""Default standard deviation of the range noise, as a fraction of the bounding-box diagonal."""


def scanner_directions(n_scans: int, *, seed: int = 0) -> NDArray[np.float64]:
    """The unit directions from the model centre to the scanners of :func:`virtual_scan`.

    Parameters
    ----------
    n_scans : int
        Number of scanners (>= 1).
    seed : int
        Seed (>= 0) of the generator; the first draws of :func:`virtual_scan`'s
        generator (default: 0).

    Returns
    -------
    directions : (n_scans, 3) float64
        Independent, uniform on the unit sphere (normalised Gaussian vectors).
    """
    n_scans = check_int(n_scans, "n_scans", minimum=1)
    seed = check_int(seed, "seed", minimum=0)
    return _directions(np.random.default_rng(seed), n_scans)


def _directions(rng: np.random.Generator, n_scans: int) -> NDArray[np.float64]:
    vectors = rng.normal(size=(n_scans, 3))
    return vectors / np.linalg.norm(vectors, axis=1, keepdims=True)


def virtual_scan(
    mesh: MeshLike,
    n_scans: int = 3,
    *,
    resolution: int = SCAN_RESOLUTION,
    noise: float = SCAN_NOISE,
    seed: int = 0,
    camera: Camera | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Scan a mesh from ``n_scans`` seeded directions into one partial, noisy point cloud.

    Parameters
    ----------
    mesh : MeshLike
        The model, in its own coordinates.
    n_scans : int
        Number of range images (default: 3).
    resolution : int
        Side of each range image in pixels (default: :data:`SCAN_RESOLUTION`).
    noise : float
        Standard deviation of the range noise along each ray, as a fraction of
        the bounding-box diagonal, >= 0 (default: :data:`SCAN_NOISE`).
    seed : int
        Seed (>= 0) of the scanner directions (:func:`scanner_directions`) and
        of the noise; the same arguments always give the same cloud (default: 0).
    camera : Camera, optional
        The scanner's camera (default: ``Camera()``, the measures' camera: it
        sees the whole model from ``distance_factor`` diagonals).

    Returns
    -------
    points : (n, 3) float64
        One point per pixel that sees the model in any scan, scan by scan, row
        by row; model units.
    normals : (n, 3) float64
        Unit normal of the face under each point, facing its scanner (the
        true normal, without noise).

    Raises
    ------
    InputError
        If the mesh has no extent or an argument is out of range.
    """
    mesh = as_mesh(mesh)
    n_scans = check_int(n_scans, "n_scans", minimum=1)
    resolution = check_int(resolution, "resolution", minimum=1, maximum=MAX_RESOLUTION)
    noise = check_float(noise, "noise", expected="a number >= 0", minimum=0.0)
    seed = check_int(seed, "seed", minimum=0)
    settings = MeasureSettings(views=n_scans, resolution=resolution, camera=camera or Camera())
    rng = np.random.default_rng(seed)
    directions = _directions(rng, n_scans)
    images = face_id_images(mesh, settings, view_directions=directions)
    centre, diagonal = bounding_frame(mesh)
    poses = settings.camera.poses(directions, centre=centre, diagonal=diagonal,
                                  resolution=resolution)
    cross = face_cross_products(mesh)
    unit_normals = cross / np.maximum(np.linalg.norm(cross, axis=1, keepdims=True), 1e-300)
    offsets = np.einsum("ij,ij->i", unit_normals, mesh.vertices[mesh.faces[:, 0]])
    centres = (np.arange(resolution) + 0.5 - resolution / 2.0) / poses.focal_px
    points, normals = [], []
    for scan in range(n_scans):
        rows, columns = np.nonzero(images[scan] >= 0)
        faces = images[scan][rows, columns]
        rays = (poses.forward[scan] + centres[columns, None] * poses.right[scan]
                - centres[rows, None] * poses.up[scan])
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        eye = poses.eyes[scan]
        normal = unit_normals[faces]
        distance = (offsets[faces] - normal @ eye) / np.einsum("ij,ij->i", normal, rays)
        distance += rng.normal(scale=noise * diagonal, size=len(faces))
        points.append(eye + distance[:, None] * rays)
        normals.append(normal)
    return np.concatenate(points), np.concatenate(normals)
