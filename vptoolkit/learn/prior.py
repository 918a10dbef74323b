"""A network as the prior of the best-view search: where to look first.

:func:`vptoolkit.best_view.search.search_best_views` draws a prior's candidate
directions first and keeps what the drawing says is best, so a prior only
has to put a good direction among a few candidates, not to be right.
:class:`NetworkPrior` is a :class:`~vptoolkit.best_view.prior.Prior` that
asks a checkpoint for them (``resolve_prior("default")`` or a checkpoint's
path, :func:`vptoolkit.best_view.prior.resolve_prior`):

Only the heads of the measures the search looks for count (``measures``;
default: every head): a searched measure the network has no head for gets no
candidate, and a search none of whose measures it has gets none at all, so
it runs as without a prior.

1. the network's answer per measure to one input (``n_inputs=1`` of
   :func:`vptoolkit.learn.predict.predict`: the search, not a consensus,
   settles between the answers that input noise moves between) in its
   canonical frame (:mod:`vptoolkit.learn.frame`);
2. the answers in the frames that differ from it by the sign of an
   ambiguous axis (``|mu_3| < SIGN_AMBIGUITY sigma^3``: a mirror-symmetric
   model, whose frame sign is decided by sampling noise), one frame after
   the other;
3. for a network with a DLDL head, which predicts a quality map over the
   sphere per measure, the next ``modes - 1`` modes of each map too: the
   highest cells at least ``mode_angle_deg`` from every higher one kept.

Directions closer than ``min_angle_deg`` to an earlier candidate are
dropped; the order is by mode rank, then frame, then measure (the
network's head order).
Directions point from the bounding-box centre towards the camera, in the
mesh's own coordinates.

A point cloud (:class:`~vptoolkit.point_cloud.PointCloud`) is answered by
the network that reads what it carries: a bundled network that reads what a
cloud does not (``"default"``, face areas) hands clouds to its stand-in of
:data:`vptoolkit.learn.checkpoint.CLOUD_MODELS` (``"points"``, coordinates
alone), the cloud's own points drawn as they are; any other checkpoint
answers a cloud itself where the cloud carries its point features
(``normal``, with normals) and refuses it in one line otherwise.
:meth:`NetworkPrior.label` names the network that answers a model.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from vptoolkit.errors import InputError
from vptoolkit.io.objects import model_of
from vptoolkit.learn.checkpoint import CLOUD_MODELS, DEFAULT_MODEL, is_bundled_model
from vptoolkit.learn.config import check_measure_names
from vptoolkit.learn.frame import SIGN_AMBIGUITY, canonical_frame
from vptoolkit.learn.model import torch_threads
from vptoolkit.learn.predict import MeshPredictor, predict_directions
from vptoolkit.mesh import MeshLike
from vptoolkit.optional import require
from vptoolkit.point_cloud import PointCloud
from vptoolkit.sphere import distinct_directions, fibonacci_sphere

if TYPE_CHECKING:
    import torch
else:
    torch = require("torch", extra="learn")

__all__ = ["NetworkPrior", "map_modes"]


class NetworkPrior:
    """A checkpoint that proposes candidate view directions of a mesh (module docstring).

    Parameters
    ----------
    model_path : path-like
        A checkpoint, or ``"default"`` for the bundled network.
    seed : int
        Seed of the surface sampling (default: 0).
    min_angle_deg : float
        Candidates closer than this to an earlier one are dropped (default: 5).
    modes : int
        Modes per quality map of a DLDL network (default: 3; ignored for other heads).
    mode_angle_deg : float
        Smallest angle between two modes of one map (default: 30).
    threads : int, optional
        Torch threads during each call (default: torch's setting).
    measures : sequence of str or str, optional
        The measures the search looks for (registered names, or one
        comma-separated string: :func:`vptoolkit.measures.registry.resolve_measures`);
        only the network's heads for these propose candidates (default:
        every head).

    Attributes
    ----------
    heads : tuple of str
        The network's measures that propose candidates, in head order
        (empty: the prior proposes nothing).
    predictor : MeshPredictor
        The network of meshes (``model_path``).
    cloud_predictor : MeshPredictor
        The network of point clouds: the bundled stand-in for ``"default"``
        (:data:`vptoolkit.learn.checkpoint.CLOUD_MODELS`), else ``predictor``.

    Raises
    ------
    InputError
        If ``model_path`` does not exist, is not a checkpoint or is a
        per-category folder, ``measures`` names an unknown measure, or if
        the network's weights are broken (it
        answers no direction for the points of a sphere); a call raises it
        for a mesh the network answers no direction for.

    Examples
    --------
    >>> prior = NetworkPrior("default")                       # doctest: +SKIP
    >>> search_best_views(mesh, SearchSettings(budget=8), prior=prior(mesh))  # doctest: +SKIP
    >>> NetworkPrior("net/", measures="NVT,SL").heads          # doctest: +SKIP
    ('NVT', 'SL')
    """

    def __init__(self, model_path: str | os.PathLike[str] = DEFAULT_MODEL, *, seed: int = 0,
                 min_angle_deg: float = 5.0, modes: int = 3, mode_angle_deg: float = 30.0,
                 threads: int | None = None,
                 measures: Sequence[str] | str | None = None) -> None:
        for name, angle in (("min_angle_deg", min_angle_deg), ("mode_angle_deg", mode_angle_deg)):
            if not 0.0 <= float(angle) < 180.0:
                raise InputError(f"{name}: expected an angle in [0, 180), got {angle!r}")
        if isinstance(modes, bool) or not isinstance(modes, int) or modes < 1:
            raise InputError(f"modes: expected a positive integer, got {modes!r}")
        if not is_bundled_model(model_path) and (Path(model_path) / "categories.json").is_file():
            raise InputError(f"{model_path}: holds one network per category, and a prior is one "
                             "network for every mesh (best-view has no --category); give the "
                             "folder of one category's network inside it")
        searched = None if measures is None else check_measure_names(measures, text=True)
        self.predictor = MeshPredictor(model_path, seed=seed, threads=threads, n_inputs=1)
        self.cloud_predictor = self.predictor
        if is_bundled_model(model_path) and str(model_path) in CLOUD_MODELS:
            self.cloud_predictor = MeshPredictor(CLOUD_MODELS[str(model_path)], seed=seed,
                                                 threads=threads, n_inputs=1)
        own = self.predictor.measures
        self.heads = own if searched is None else tuple(name for name in own if name in searched)
        for predictor in dict.fromkeys((self.predictor, self.cloud_predictor)):
            probe = np.zeros((predictor.n_points, predictor.model.config.input_channels),
                             np.float32)  # a sphere, its point features 0
            probe[:, :3] = fibonacci_sphere(predictor.n_points)
            with torch_threads(threads):  # broken weights answer no direction: say so once
                predict_directions(predictor.model, probe[None], checkpoint=predictor.checkpoint)
        self.min_angle_deg = float(min_angle_deg)
        self.modes = modes
        self.mode_angle_deg = float(mode_angle_deg)

    def frames(self, points: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """The canonical frame first, then those with ambiguous axis signs flipped.

        Returns
        -------
        frames : (F, 3, 3) float, centre : (1, 1, 3) float
        """
        frame, centre = canonical_frame(points[None])
        centred = (points[None] - centre).to(torch.float64)
        axes = frame[0].to(torch.float64)
        projected = centred[0] @ axes.T
        variance = projected.pow(2).mean(dim=0)
        third = projected.pow(3).mean(dim=0)
        ambiguous = [int(i) for i in torch.nonzero(
            third.abs() < SIGN_AMBIGUITY * variance.pow(1.5).clamp_min(1e-300)).flatten()]
        choices = []
        for flips in itertools.product((1.0, -1.0), repeat=len(ambiguous)):
            signs = torch.ones(3, dtype=torch.float64)
            signs[ambiguous] = torch.tensor(flips, dtype=torch.float64)
            choices.append(axes * signs[:, None])
        return torch.stack(choices).to(points.dtype), centre

    def network_of(self, mesh: MeshLike | PointCloud) -> MeshPredictor:
        """The network that answers ``mesh``: :attr:`cloud_predictor` for a point cloud."""
        return (self.cloud_predictor if isinstance(model_of(mesh), PointCloud)
                else self.predictor)

    def label(self, mesh: MeshLike | PointCloud) -> str:
        """What proposes the candidates of ``mesh``, for outputs: ``"network default"`` for a
        mesh, ``"network points"`` for a point cloud with the bundled ``default``."""
        return f"network {self.network_of(mesh).checkpoint}"

    def __call__(self, mesh: MeshLike | PointCloud) -> NDArray[np.float64]:
        """Candidate unit directions ``(k, 3)``, most promising first; ``(0, 3)`` without heads.

        A point cloud is answered by :meth:`network_of` it (module docstring);
        one whose checkpoint reads point features it does not carry is
        refused in one line."""
        mesh = model_of(mesh)
        if not self.heads:
            return np.zeros((0, 3))
        predictor = self.network_of(mesh)
        model = predictor.model
        columns = [predictor.measures.index(name) for name in self.heads
                   if name in predictor.measures]
        points = torch.as_tensor(predictor.inputs(mesh)[0])
        with torch_threads(predictor.threads), torch.inference_mode():
            model.eval()
            if model.config.input_frame != "pca":
                frames = torch.eye(3, dtype=points.dtype)[None]
                centre = torch.zeros((1, 1, 3), dtype=points.dtype)
            else:
                frames, centre = self.frames(points[:, :3])
            outputs = model.forward_in_frames(points, frames, centre)
        # (F, M, 3), the searched measures' heads: rank 1
        ranked = [outputs["directions"][:, columns].to(torch.float64).numpy()]
        if "maps" in outputs and self.modes > 1:
            ranked += map_modes(outputs["maps"][:, columns], frames, self.modes,
                                self.mode_angle_deg)[1:]
        candidates = np.concatenate([rank.reshape(-1, 3) for rank in ranked])
        lengths = np.linalg.norm(candidates, axis=1, keepdims=True)
        if not (np.isfinite(lengths) & (lengths > 0.0)).all():
            raise InputError(f"{predictor.checkpoint}: the network answers a zero or "
                             f"non-finite vector for {mesh.name}, not a direction; its weights "
                             "are broken")
        return distinct_directions(candidates / lengths, self.min_angle_deg)


def map_modes(maps: torch.Tensor, frames: torch.Tensor, modes: int,
              min_angle_deg: float) -> list[NDArray[np.float64]]:
    """The ``modes`` highest cells of every quality map, each ``min_angle_deg`` from higher ones.

    Parameters
    ----------
    maps : (F, M, R, R) float
        Octahedral quality maps (:mod:`vptoolkit.learn.octahedral`), one per
        frame and measure, in the frame's coordinates.
    frames : (F, 3, 3) float
        The frames; a cell's direction ``d`` goes back to the input as ``d C_f``.

    Returns
    -------
    list of (F, M, 3) float64
        One array per mode rank, best first; a map with fewer modes repeats its last.
    """
    from vptoolkit.learn.octahedral import sphere_map_directions

    cells = sphere_map_directions(maps.shape[-1], dtype=torch.float64).reshape(-1, 3).numpy()
    values = maps.flatten(start_dim=2).to(torch.float64).numpy()  # (F, M, R*R)
    limit = math.cos(math.radians(min_angle_deg))
    found = np.zeros((modes, *values.shape[:2], 3))
    for f, m in itertools.product(range(values.shape[0]), range(values.shape[1])):
        kept: list[int] = []
        for cell in np.argsort(-values[f, m], kind="stable"):
            if all(float(cells[cell] @ cells[other]) < limit for other in kept):
                kept.append(int(cell))
                if len(kept) == modes:
                    break
        kept += kept[-1:] * (modes - len(kept))
        found[:, f, m] = cells[kept] @ frames[f].to(torch.float64).numpy()
    return list(found)
