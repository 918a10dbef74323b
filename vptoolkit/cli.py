"""The ``vptool`` command line.

Each command parses its options, calls one library function and prints a
short result. Errors become one line on stderr and an exit code:
0 success, 1 a measurement or verification failure, 2 bad input or a missing
dependency. Heavy packages are imported inside the commands, so ``--help``
stays fast.
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path
from typing import Any

import click

from vptoolkit.errors import (
    InputError,
    MeasurementError,
    MissingDependencyError,
    VerificationError,
    VptoolkitError,
)

EXIT_FAILURE = 1
EXIT_BAD_INPUT = 2


def _exit_code(error: BaseException) -> int:
    if isinstance(error, (InputError, MissingDependencyError)):
        return EXIT_BAD_INPUT
    if isinstance(error, (MeasurementError, VerificationError)):
        return EXIT_FAILURE
    return EXIT_FAILURE


class _Group(click.Group):
    """A click group that turns toolkit errors into one line and an exit code."""

    def invoke(self, context: click.Context) -> Any:
        try:
            return super().invoke(context)
        except VptoolkitError as error:
            click.echo(f"vptool: error: {error}", err=True)
            sys.exit(_exit_code(error))
        except OSError as error:
            where = f"{error.filename}: " if error.filename else ""
            click.echo(f"vptool: error: {where}{error.strerror or error}", err=True)
            sys.exit(EXIT_BAD_INPUT)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="vptoolkit")
def main() -> None:
    """Find good viewpoints on 3D models.

    \b
    Example:
      vptool measures bunny.ply --views 1000 --resolution 1024 -o bunny.npz
    """


_MESH = click.Path(exists=True, dir_okay=False, path_type=Path)


@main.command()
@click.argument("mesh", type=_MESH)
@click.option("--views", "n_views", default=1000, show_default=True, type=click.IntRange(1),
              help="Number of Fibonacci-sphere view directions.")
@click.option("--resolution", default=1024, show_default=True, type=click.IntRange(1, 16384),
              help="Side of the triangle-ID image in pixels.")
@click.option("--backend", type=click.Choice(["raster", "raycast"]), default="raster",
              show_default=True, help="raster: fast numba z-buffer; raycast: Open3D reference.")
@click.option("-o", "--output", type=click.Path(dir_okay=False, path_type=Path),
              help="Write views, raw and normalised measures and the camera to this .npz.")
@click.option("--json", "as_json", is_flag=True, help="Print the result as JSON.")
def measures(mesh: Path, n_views: int, resolution: int, backend: str,
             output: Path | None, as_json: bool) -> None:
    """Compute VE, VR, VKL and VMI of MESH for every view; print the best views.

    VE and VR: higher is better; VKL and VMI: lower is better. Directions point
    from the model centre to the camera, in the mesh's own coordinates.

    \b
    Example:
      vptool measures bunny.ply --views 1000 --resolution 512 -o bunny.npz
    """
    from vptoolkit.io import load_mesh
    from vptoolkit.measures import compute_view_quality

    if output is not None and output.suffix != ".npz":
        raise InputError(f"{output.name}: output must end in .npz")
    loaded = load_mesh(mesh)
    started = time.perf_counter()
    quality = compute_view_quality(
        loaded, n_views=n_views, resolution=resolution, backend=backend,  # type: ignore[arg-type]
        progress=True,
    )
    seconds = time.perf_counter() - started
    if output is not None:
        quality.save_npz(output)
    summary = quality.summary()
    summary["seconds"] = round(seconds, 3)
    if as_json:
        click.echo(json.dumps(summary, indent=2))
        return
    click.echo(
        f"{quality.name}: {quality.n_faces} faces, {len(quality.views)} views at "
        f"{quality.resolution} px ({quality.backend}, {seconds:.2f} s)"
    )
    click.echo(f"{'measure':<8} {'view':>5}  {'direction (x, y, z)':<26} {'raw':>9}")
    for name, best in summary["best"].items():
        x, y, z = best["direction"]
        click.echo(f"{name:<8} {best['view_index']:>5}  ({x:+.3f}, {y:+.3f}, {z:+.3f})     "
                   f"{best['raw']:>9.4f}")
    if output is not None:
        click.echo(f"wrote {output}")
