"""Options and parameter types that several ``vptool`` commands share.

One definition per option, in the manner of rasterio's ``rio/options.py``: a
command takes ``@views_option()`` instead of repeating the type, range and
default. Defaults are the library's named constants (:mod:`vptoolkit.conventions`,
``N_SURFACE_POINTS`` of :mod:`vptoolkit.points`, ``MAX_FACES`` of
:mod:`vptoolkit.clean.simplify`), so the command line and the library agree on
``N_VIEWS``, ``RESOLUTION``, ``SEED``, the points, the face budget and the measure
order. An option whose help depends on the command takes it as an argument.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import click

from vptoolkit.conventions import N_VIEWS, RESOLUTION, SEED, SPLITS
from vptoolkit.errors import InputError
from vptoolkit.settings import MAX_RESOLUTION
from vptoolkit.sphere import as_directions

__all__ = [
    "Direction",
    "ElevationBand",
    "UpAxis",
    "ExistingPath",
    "MESH",
    "EXISTING",
    "DATASET",
    "cache_dir_option",
    "comma_list",
    "split_option",
    "MEASURE_NAME",
    "MeasureName",
    "measures_option",
    "parse_measures",
    "MODEL_HELP",
    "PREDICT_MODEL_HELP",
    "views_option",
    "resolution_option",
    "points_option",
    "max_faces_option",
    "max_points_option",
    "budget_option",
    "search_resolution_option",
    "seed_option",
    "workers_option",
    "scheduler_option",
    "face_limit_option",
    "timeout_option",
    "up_option",
    "elevation_option",
    "engine_option",
    "device_option",
    "size_option",
]

Decorated = TypeVar("Decorated", bound=Callable[..., Any])


class ExistingPath(click.Path):
    """click.Path that names a symlink loop and refuses what is neither a file nor a folder.

    A named pipe, socket or device would block the command or feed it a
    stream read more than once; it is refused with an
    :class:`~vptoolkit.errors.InputError`, ``<path>: not a regular file``.
    """

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        """Check ``value`` as click.Path does, after naming a symbolic link loop or a pipe."""
        try:
            mode = os.stat(os.fspath(value)).st_mode
        except OSError as err:
            if err.errno == errno.ELOOP:
                self.fail(f"{os.fsdecode(value)}: symbolic link loop ({err.strerror})", param, ctx)
        else:
            if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
                raise InputError(f"{os.fsdecode(value)}: not a regular file")
        return super().convert(value, param, ctx)


# ParamType takes type arguments at run time only in recent click releases
class Direction(click.ParamType):  # type: ignore[type-arg]
    """A direction typed as ``x,y,z``: three finite numbers, not all zero.

    Converts to a ``tuple[float, float, float]`` as typed (not normalised).
    Bad text raises an :class:`~vptoolkit.errors.InputError` naming the option,
    so the command line prints it as the one line of every other bad input and
    exits with status 2.
    """

    name = "x,y,z"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> tuple[float, float, float]:
        """Parse ``value`` (text, or an already parsed triple) and check it."""
        option = param.opts[0] if param is not None and param.opts else "direction"
        parts = value if isinstance(value, tuple) else str(value).split(",")
        try:
            x, y, z = (float(part) for part in parts)
        except (TypeError, ValueError):
            raise InputError(f"{option}: expected three numbers x,y,z, got {value!r}") from None
        try:
            as_directions((x, y, z), name=option)
        except InputError:
            raise InputError(f"{option}: expected a finite, non-zero direction x,y,z, "
                             f"got {value!r}") from None
        return x, y, z


class UpAxis(Direction):
    """An up axis typed as ``x,y,z`` (a :class:`Direction`) or ``auto`` (where the command
    allows it: :func:`vptoolkit.upright.auto_up` decides per model)."""

    name = "x,y,z|auto"

    def __init__(self, *, allow_auto: bool) -> None:
        self.allow_auto = allow_auto

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        """``"auto"`` where allowed, else the parsed direction."""
        if self.allow_auto and isinstance(value, str) and value.strip().lower() == "auto":
            return "auto"
        return super().convert(value, param, ctx)


class ElevationBand(click.ParamType):  # type: ignore[type-arg]
    """An elevation band typed as ``MIN,MAX`` degrees, or ``full`` (None: the whole sphere);
    the search checks the range (:class:`vptoolkit.best_view.search.SearchSettings`)."""

    name = "min,max|full"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> tuple[float, float] | None:
        """Parse ``value`` (text, a parsed pair or None)."""
        if value is None or isinstance(value, tuple):
            return value
        if str(value).strip().lower() == "full":
            return None
        option = param.opts[0] if param is not None and param.opts else "elevation"
        try:
            low, high = (float(part) for part in str(value).split(","))
        except ValueError:
            raise InputError(f"{option}: expected two numbers MIN,MAX in degrees or full, "
                             f"got {value!r}") from None
        return low, high


def comma_list(text: str | None) -> list[str] | None:
    """The non-empty, stripped items of a comma-separated option (None when not given)."""
    if not text:
        return None
    return [item.strip() for item in text.split(",") if item.strip()]


MESH = ExistingPath(exists=True, dir_okay=False, path_type=Path)
"""An existing file (a mesh, or another single input file)."""

EXISTING = ExistingPath(exists=True, path_type=Path)
"""An existing file or folder."""

class DatasetSource(ExistingPath):
    """An existing file or folder, or the URL of a release, which is kept as text."""

    name = "path_or_url"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> Any:
        """Pass a URL (``scheme://...``) through; check a local path as :class:`ExistingPath`."""
        from vptoolkit.data.remote import is_remote

        if is_remote(value):
            return value
        return super().convert(value, param, ctx)


DATASET = DatasetSource(exists=True, path_type=Path)
"""A dataset: an existing store or folder, or a release's URL (``https://``, ``hf://``, ...)."""


def cache_dir_option() -> Callable[[Decorated], Decorated]:
    """``--cache-dir``: the ``cache_dir`` of :func:`vptoolkit.data.open_dataset` for a URL."""
    return click.option(
        "--cache-dir", type=click.Path(file_okay=False, path_type=Path),
        help="Where a dataset given as a URL is cached and verified "
             "(default: $XDG_CACHE_HOME/vptoolkit, else ~/.cache/vptoolkit).")


def split_option(help: str, *, default: str = "test") -> Callable[[Decorated], Decorated]:
    """``--split train|validation|val|test|all``: which models of a dataset.

    The one place the command line's ``all`` becomes the library's None (every
    model, :data:`vptoolkit.conventions.Split`); the command receives the
    library's value.
    """

    def library_split(ctx: click.Context, param: click.Parameter, value: str) -> str | None:
        return None if value == "all" else value

    return click.option("--split", default=default, show_default=True,
                        type=click.Choice([*SPLITS, "val", "all"]), callback=library_split,
                        help=help)


# ParamType takes type arguments at run time only in recent click releases
class MeasureName(click.ParamType):  # type: ignore[type-arg]
    """One registered measure name (:mod:`vptoolkit.measures.registry`), in any case.

    Converts to the registry's spelling (``vkl`` to ``VKL``); an unknown name
    raises an :class:`~vptoolkit.errors.InputError` naming the option, so it
    is one line and exit status 2. Whether a file or dataset records the
    measure is for the command to check.
    """

    name = "measure"

    def convert(self, value: Any, param: click.Parameter | None,
                ctx: click.Context | None) -> str:
        """The registry's spelling of ``value``."""
        from vptoolkit.measures.registry import canonical_name

        option = param.opts[0] if param is not None and param.opts else "measure"
        return canonical_name(str(value).strip(), option)


MEASURE_NAME = MeasureName()
"""One registered measure name, in any case (:class:`MeasureName`)."""


def parse_measures(value: str,
                   resolve: Callable[[str], tuple[str, ...]] | None = None) -> tuple[str, ...]:
    """The measure names of a ``--measures`` value; a refusal is one line naming the option.

    ``resolve`` turns the text into names (default:
    :func:`vptoolkit.measures.registry.resolve_measures`: ``all``, ``paper``
    or ``NAME,...``).
    """
    from vptoolkit.measures.registry import resolve_measures

    try:
        return (resolve or resolve_measures)(value)
    except InputError as err:
        raise InputError(f"--measures: {str(err).removeprefix('measures: ')}") from None


def parse_point_features(value: str) -> tuple[str, ...]:
    """The feature names of a ``--point-features`` value (``NAME,...`` or ``none``,
    :func:`vptoolkit.point_features.check_feature_names`); a refusal is one line naming the
    option."""
    from vptoolkit.point_features import check_feature_names

    try:
        return check_feature_names(value, text=True)
    except InputError as err:
        raise InputError(f"--point-features: {str(err).removeprefix('point_features: ')}"
                         ) from None


def measures_option(help: str, *, default: str | None = "paper",
                    resolve: Callable[[str], tuple[str, ...]] | None = None,
                    dest: str = "measures") -> Callable[[Decorated], Decorated]:
    """``--measures all|paper|NAME,...``: measure names, checked before any work.

    The value goes through :func:`parse_measures` with ``resolve`` and reaches
    the command as its parameter ``dest``. Without the option the value is
    ``default`` resolved, or None for ``default=None`` (the command decides).
    """

    def check(ctx: click.Context, param: click.Parameter,
              value: str | None) -> tuple[str, ...] | None:
        return None if value is None else parse_measures(value, resolve)

    return click.option("--measures", dest, default=default,
                        show_default=default is not None, callback=check, help=help)

MODEL_HELP = ("Checkpoint (folder or .safetensors), or a bundled network: 'default' (reads "
              "face areas: meshes, datasets) or 'points' (coordinates alone: also point files); "
              "./default for a checkpoint of that name.")
PREDICT_MODEL_HELP = (MODEL_HELP[:-1] + "; 'unoccluded' for the closed form from normals, "
                      "no network.")

_ENGINE_HELP = ("software: the measures' rasteriser, fast on any CPU; open3d: Filament's "
                "shading via Vulkan (erratic frame times on software Vulkan).")


def views_option(help: str | None = "Number of Fibonacci-sphere view directions.",
                 ) -> Callable[[Decorated], Decorated]:
    """``--views N``: sampled view directions, at least 1 (default ``N_VIEWS``)."""
    return click.option("--views", "n_views", default=N_VIEWS, show_default=True,
                        type=click.IntRange(1), help=help)


def resolution_option(help: str | None = "Side of the triangle-ID image in pixels.",
                      ) -> Callable[[Decorated], Decorated]:
    """``--resolution PX``: triangle-ID image side, 1 to ``MAX_RESOLUTION`` pixels.

    The default is ``RESOLUTION``.
    """
    return click.option("--resolution", default=RESOLUTION, show_default=True,
                        type=click.IntRange(1, MAX_RESOLUTION), help=help)


def points_option(help: str | None = "Number of points.") -> Callable[[Decorated], Decorated]:
    """``--points N``: surface points per mesh, 1 to ``MAX_SURFACE_POINTS`` (default
    ``N_SURFACE_POINTS``)."""
    from vptoolkit.points import MAX_SURFACE_POINTS, N_SURFACE_POINTS

    return click.option("--points", "n_points", default=N_SURFACE_POINTS, show_default=True,
                        type=click.IntRange(1, MAX_SURFACE_POINTS), help=help)


def max_faces_option(help: str | None) -> Callable[[Decorated], Decorated]:
    """``--max-faces N``: the cleaning's face budget, at least 4 (default ``MAX_FACES``)."""
    from vptoolkit.clean.simplify import MAX_FACES

    return click.option("--max-faces", default=MAX_FACES, show_default=True,
                        type=click.IntRange(4), help=help)


def max_points_option() -> Callable[[Decorated], Decorated]:
    """``--max-points N``: the most points a point cloud file keeps on reading, at least 1
    (default ``MAX_POINTS`` of :mod:`vptoolkit.point_cloud`; :func:`vptoolkit.io.load`)."""
    from vptoolkit.point_cloud import MAX_POINTS

    return click.option("--max-points", default=MAX_POINTS, show_default=True,
                        type=click.IntRange(1), metavar="N",
                        help="A point cloud file of more points is thinned on reading to the "
                             "first point of each occupied voxel, the finest voxels of side "
                             "extent/N^(1/3)*1.25^k with at most N occupied "
                             "(vptoolkit.point_cloud.voxel_subset); a thinned file prints one "
                             "warning line on stderr naming it and the counts before and "
                             "after. Meshes are never thinned.")


def budget_option() -> Callable[[Decorated], Decorated]:
    """``--views N``: a best-view search's budget of drawn views (default ``BUDGET``)."""
    from vptoolkit.best_view.search import BUDGET, MAX_BUDGET

    return click.option("--views", "budget", default=BUDGET, show_default=True,
                        type=click.IntRange(1, MAX_BUDGET),
                        help="Budget: views drawn per mesh over all stages.")


def search_resolution_option() -> Callable[[Decorated], Decorated]:
    """``--resolution PX``: the image side that decides a search (default ``SEARCH_RESOLUTION``)."""
    from vptoolkit.best_view.search import SEARCH_RESOLUTION

    return click.option("--resolution", default=SEARCH_RESOLUTION, show_default=True,
                        type=click.IntRange(1, MAX_RESOLUTION),
                        help="Side in pixels of the views that decide the answer.")


def seed_option(help: str | None = "Random seed.", *,
                minimum: int | None = None) -> Callable[[Decorated], Decorated]:
    """``--seed N``: the seed of the command's random choices (default ``SEED``).

    ``minimum`` bounds it from below where the library refuses smaller seeds.
    """
    return click.option("--seed", default=SEED, show_default=True,
                        type=int if minimum is None else click.IntRange(minimum), help=help)


def workers_option(help: str, *, default: int | None = None,
                   ) -> Callable[[Decorated], Decorated]:
    """``--workers N``: worker processes, at least 1."""
    return click.option("--workers", default=default, show_default=default is not None,
                        type=click.IntRange(1), help=help)


def scheduler_option() -> Callable[[Decorated], Decorated]:
    """``--scheduler ADDR``: a running Dask scheduler that does the work instead of
    ``--workers`` (checked by :func:`vptoolkit.parallel.check_scheduler_address`)."""
    return click.option("--scheduler", help="Address of a running Dask distributed scheduler.")


def face_limit_option() -> Callable[[Decorated], Decorated]:
    """``--max-faces N``: refuse a model with more faces before drawing it (default
    ``MAX_MODEL_FACES`` of :mod:`vptoolkit.collection.runner`)."""
    from vptoolkit.collection.runner import MAX_MODEL_FACES

    return click.option("--max-faces", default=MAX_MODEL_FACES, show_default=True,
                        type=click.IntRange(1),
                        help="Record a model with more faces as failed, unread further.")


def timeout_option() -> Callable[[Decorated], Decorated]:
    """``--timeout S``: seconds one file may take (default ``TIMEOUT_S`` of
    :mod:`vptoolkit.collection.runner`)."""
    from vptoolkit.collection.runner import TIMEOUT_S

    return click.option("--timeout", default=TIMEOUT_S, show_default=True,
                        type=click.FloatRange(0, min_open=True),
                        help="Seconds one file may take; a slower one is recorded as failed "
                             "and tried again by the next run.")


def up_option(*, allow_auto: bool = False) -> Callable[[Decorated], Decorated]:
    """``--up x,y,z``: the model's up axis, drawn upwards in pictures and exported poses and
    the pole of ``--elevation`` (an :class:`UpAxis`; ``auto`` where ``allow_auto``)."""
    auto = (" auto: glTF's +y, else +y or +z, the side the model stands on more broadly "
            "(docs/conventions.md).") if allow_auto else ""
    return click.option("--up", default="0,1,0", show_default=True,
                        type=UpAxis(allow_auto=allow_auto),
                        help="The model's up axis x,y,z, shown upwards (0,0,1 for z-up "
                             "models)." + auto)


def elevation_option(default: str | None) -> Callable[[Decorated], Decorated]:
    """``--elevation MIN,MAX``: the band of camera elevations above the horizon of ``--up``
    that the search keeps to (an :class:`ElevationBand`; ``full``: the whole sphere)."""
    return click.option("--elevation", default=default or "full", show_default=True,
                        type=ElevationBand(),
                        help="Camera elevation band MIN,MAX in degrees above the horizon of "
                             "--up that every searched view keeps to, or full (the sphere).")


def margin_option() -> Callable[[Decorated], Decorated]:
    """``--margin F``: the free border around a framed model, a fraction of the picture's side."""
    from vptoolkit.pictures.shading import MARGIN

    return click.option("--margin", default=MARGIN, show_default=True,
                        type=click.FloatRange(0.0, 0.45),
                        help="Border left free around the model, as a fraction of the picture's "
                             "side: each picture is magnified until the model touches it.")


def engine_option() -> Callable[[Decorated], Decorated]:
    """``--engine``: the picture engine, ``software`` (default) or ``open3d``."""
    return click.option("--engine", default="software", show_default=True,
                        type=click.Choice(["software", "open3d"]), help=_ENGINE_HELP)


def device_option() -> Callable[[Decorated], Decorated]:
    """``--device``: where torch runs, ``auto`` (default), ``cpu`` or ``cuda``."""
    return click.option("--device", default="auto", show_default=True,
                        type=click.Choice(["auto", "cpu", "cuda"]),
                        help="auto: CUDA when torch sees it, else the CPU.")


def size_option(default: int | None = None) -> Callable[[Decorated], Decorated]:
    """``--size PX``: the side of a picture, ``MIN_PICTURE_SIZE`` to ``MAX_PICTURE_SIZE``
    pixels (default ``PICTURE_SIZE``)."""
    from vptoolkit.pictures.shading import MAX_PICTURE_SIZE, MIN_PICTURE_SIZE, PICTURE_SIZE

    return click.option("--size", default=PICTURE_SIZE if default is None else default,
                        show_default=True, type=click.IntRange(MIN_PICTURE_SIZE, MAX_PICTURE_SIZE),
                        help="Picture side in pixels.")
