"""Small licensed sample meshes shipped with vptoolkit, for demos and tests.

The files and their sources, licences and SHA-256 sums are listed in
``README.md`` beside them; :data:`SAMPLE_SPLITS` places them in the three
splits (``build-dataset --splits``)::

    from vptoolkit.io import load_mesh
    from vptoolkit.samples import sample_path

    bunny = load_mesh(sample_path("bunny.ply"))
"""

from __future__ import annotations

from pathlib import Path

from vptoolkit.errors import InputError
from vptoolkit.io import SUPPORTED_SUFFIXES

__all__ = ["SAMPLE_SPLITS", "sample_names", "sample_path"]

_SAMPLES_DIR = Path(__file__).resolve().parent

SAMPLE_SPLITS = _SAMPLES_DIR / "splits.csv"
"""The samples' split file (``name,split``): 8 train, 2 validation and 2 test
meshes, so a sample build has every split."""


def sample_names() -> list[str]:
    """Return the file names of the sample meshes, sorted (e.g. ``"bunny.ply"``)."""
    return sorted(
        path.name
        for path in _SAMPLES_DIR.iterdir()
        if path.is_file() and path.suffix.lower() in SUPPORTED_SUFFIXES
    )


def sample_path(name: str) -> Path:
    """Return the path of the sample mesh ``name``.

    Parameters
    ----------
    name : str
        A file name from :func:`sample_names` (``"bunny.ply"``) or its stem
        (``"bunny"``).

    Raises
    ------
    InputError
        If no sample has that name; the message lists the available names.
    """
    names = sample_names()
    if name not in names:
        by_stem = [candidate for candidate in names if Path(candidate).stem == name]
        if len(by_stem) != 1:
            raise InputError(f"{name}: no such sample mesh; available: {', '.join(names)}")
        name = by_stem[0]
    return _SAMPLES_DIR / name
