"""Predicted view directions: :class:`Predictions` and its ``.npz`` file, read and written here.

Every predictor returns a :class:`Predictions` (a network's
:func:`vptoolkit.learn.predict.predict`, the occlusion-free
:func:`vptoolkit.predictors.predict_unoccluded`, the best-view search's
:attr:`vptoolkit.best_view.run.SearchRun.predictions`), and
:func:`write_predictions` is the one writer of the file.

Format (``*.npz``, nothing pickled):

``names`` : (n_models,) unicode
    Model names, unique, in any order.
``directions`` : (n_models, n_measures, 3) float64
    One direction per model and measure, from the model centre towards the
    camera (need not be unit length).
``measures`` : (n_measures,) unicode
    Registered measure names (:mod:`vptoolkit.measures.registry`), each
    once: by default the paper's four, ``PAPER_MEASURES`` (``["VE", "VR", "VKL",
    "VMI"]``); any others in any order, e.g. ``["NVT", "SL", "VE"]``. Where a
    file names several of the paper's four, they keep their order VE, VR,
    VKL, VMI among themselves (the order every file has had), so a file of
    the four reads as it always has.

Other keys are ignored. :func:`write_predictions` writes the file atomically
(:func:`vptoolkit.files.atomic_write`); :func:`read_predictions` reads it back
with ``allow_pickle=False`` and closes the file on every path.
:func:`read_arrays` is the safe reader under both: a ``.npy`` array or every
member of a ``.npz`` archive. Scoring against a dataset (which names, which
split) lives in :mod:`vptoolkit.evaluate`.

Numpy, and the measure registry for the known names (which loads the
catalog's small modules, numpy only).
"""

from __future__ import annotations

import os
import zipfile
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from vptoolkit.checks import check_npy_header, one_line
from vptoolkit.errors import InputError
from vptoolkit.files import atomic_write
from vptoolkit.measures.registry import PAPER_MEASURES, all_measures

__all__ = [
    "PREDICTION_KEYS",
    "Predictions",
    "check_prediction_measures",
    "read_arrays",
    "read_predictions",
    "parse_predictions",
    "unicode_vector",
    "write_predictions",
]

PREDICTION_KEYS = ("names", "directions", "measures")
"""The arrays every predictions ``.npz`` holds."""

_NPY_MAGIC = b"\x93NUMPY"
_ZIP_MAGIC = (b"PK\x03\x04", b"PK\x05\x06")  # a zip entry, or an empty zip archive


@dataclass(frozen=True)
class Predictions:
    """Predicted view directions of several models, checked when made.

    Attributes
    ----------
    names : tuple of str
        Model names (file stems, or dataset names), unique.
    directions : (n_models, n_measures, 3) float64
        One direction per model and measure, from the model centre towards
        the camera (a predictor's are unit length; a file's need not be).
    measures : tuple of str
        The measure of each direction: registered names, each once (the
        paper's four, where several are given, in their order); default
        ``PAPER_MEASURES``. See :func:`check_prediction_measures`.

    Raises
    ------
    InputError
        If ``directions`` is not of shape ``(n_names, n_measures, 3)``, two
        names are the same, or ``measures`` break
        :func:`check_prediction_measures`.

    Examples
    --------
    >>> found = Predictions(("chair",), np.zeros((1, 4, 3)))
    >>> names, directions, measures = found   # unpacks like a tuple
    >>> len(found), directions.shape
    (1, (1, 4, 3))
    """

    names: tuple[str, ...]
    directions: NDArray[np.float64]
    measures: tuple[str, ...] = PAPER_MEASURES

    def __post_init__(self) -> None:
        directions = np.asarray(self.directions, dtype=np.float64)
        if directions.shape != (len(self.names), len(self.measures), 3):
            raise InputError(
                f"directions: expected shape ({len(self.names)}, {len(self.measures)}, 3), "
                f"got {directions.shape}"
            )
        if len(set(self.names)) != len(self.names):
            raise InputError("names: model names must be unique")
        object.__setattr__(self, "names", tuple(str(name) for name in self.names))
        object.__setattr__(self, "measures", check_prediction_measures(self.measures))
        object.__setattr__(self, "directions", directions)

    def __len__(self) -> int:
        return len(self.names)

    def __iter__(self) -> Iterator[Any]:
        """``names, directions, measures = predictions``."""
        return iter((self.names, self.directions, self.measures))

    def save_npz(self, path: str | os.PathLike[str]) -> Path:
        """Write the predictions to an ``.npz`` file, atomically (:func:`write_predictions`).

        The arrays are ``names (n_models,) unicode``, ``directions
        (n_models, n_measures, 3) float64`` and ``measures (n_measures,)
        unicode``; nothing is pickled (read back with :meth:`load_npz`).

        Raises
        ------
        InputError
            If ``path`` does not end in ``.npz`` or its folder does not exist.
        """
        return write_predictions(path, self.names, self.directions, measures=self.measures)

    @classmethod
    def load_npz(cls, path: str | os.PathLike[str]) -> Predictions:
        """Read predictions written by :meth:`save_npz` (:func:`read_predictions`)."""
        return read_predictions(path)


def read_arrays(path: str | os.PathLike[str]) -> NDArray[Any] | dict[str, NDArray[Any]]:
    """Read a ``.npy`` array or every member of a ``.npz`` archive, no pickles.

    Returns
    -------
    arrays : ndarray or dict of str to ndarray
        The array of a ``.npy`` file, or each member of a ``.npz`` by key.

    Raises
    ------
    InputError
        One line naming the file: wrong suffix, missing, no numpy or zip
        header, a suffix that disagrees with the content, a member that is not
        an ``.npy`` array, or unreadable with ``allow_pickle=False``.
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".npy", ".npz"):
        raise InputError(f"{path.name}: predictions must be a .npy or .npz file")
    if not path.is_file():
        raise InputError(f"{path.name}: no such file")
    # The file is opened here, not by np.load, so that it is closed even when
    # numpy fails half-way through a damaged zip archive.
    with path.open("rb") as handle:
        magic = handle.read(len(_NPY_MAGIC))
        if not (magic.startswith(_NPY_MAGIC) or magic.startswith(_ZIP_MAGIC)):
            raise InputError(f"{path.name}: not a numpy .npy or .npz file "
                             "(no numpy or zip header)")
        handle.seek(0)
        if magic.startswith(_NPY_MAGIC):
            check_npy_header(handle, path.name, path.stat().st_size)
        try:
            loaded = np.load(handle, allow_pickle=False)
            if isinstance(loaded, np.ndarray):
                if suffix != ".npy":
                    raise InputError(f"{path.name}: holds a single .npy array, "
                                     "not an .npz archive")
                return loaded
            with loaded:
                if suffix != ".npz":
                    raise InputError(f"{path.name}: is an .npz archive, not a .npy array")
                for info in loaded.zip.infolist():
                    if not info.filename.endswith(".npy"):
                        raise InputError(f"{path.name}: member {info.filename!r} is not a "
                                         ".npy array")
                    with loaded.zip.open(info) as member:
                        check_npy_header(member, f"{path.name}: member {info.filename}",
                                         info.file_size)
                return {key: loaded[key] for key in loaded.files}
        except InputError:
            raise
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
            raise InputError(f"{path.name}: cannot be read with allow_pickle=False "
                             f"({one_line(err)})") from err


def unicode_vector(file_name: str, key: str, array: NDArray[Any]) -> list[str]:
    """The strings of a 1-D unicode array, or an :class:`InputError` naming ``key``."""
    if array.ndim != 1 or array.dtype.kind != "U":
        raise InputError(f"{file_name}: {key!r} must be a 1-D unicode array, "
                         f"got shape {array.shape} dtype {array.dtype}")
    return [str(value) for value in array]


def check_prediction_measures(measures: Sequence[str], where: str = "measures",
                              ) -> tuple[str, ...]:
    """The measure names of predictions, checked.

    Parameters
    ----------
    measures : sequence of str
        The names, one per direction of a model.
    where : str
        What the error messages name first (default: ``"measures"``; a
        file's name when reading one).

    Returns
    -------
    tuple of str
        The names, as given.

    Raises
    ------
    InputError
        No name, a name the registry does not know
        (:func:`vptoolkit.measures.registry.all_measures`) or a name given
        twice. Any order is allowed: scoring matches measures by name.
    """
    names = [str(name) for name in measures]
    known = all_measures()
    unknown = [name for name in names if name not in known]
    if unknown:
        listed = ", ".join(repr(name) for name in unknown[:3])
        listed += ", ..." if len(unknown) > 3 else ""
        raise InputError(f"{where}: unknown measure(s) {listed}, expected registered names "
                         f"({', '.join(known)})")
    if not names:
        raise InputError(f"{where}: no measure named")
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise InputError(f"{where}: measures {names} name {', '.join(repeated)} twice")
    return tuple(names)


def parse_predictions(file_name: str, arrays: dict[str, NDArray[Any]],
                      ) -> tuple[tuple[str, ...], NDArray[Any], tuple[str, ...]]:
    """Check the members of a predictions ``.npz`` against the format.

    Parameters
    ----------
    file_name : str
        Named in error messages.
    arrays : dict of str to ndarray
        The archive's members (:func:`read_arrays`).

    Returns
    -------
    names : tuple of str
        As stored (not yet checked for duplicates).
    directions : (n_names, n_measures, 3) ndarray
        As stored (dtype not yet checked).
    measures : tuple of str
        Registered names, as :func:`check_prediction_measures` accepts them.

    Raises
    ------
    InputError
        A missing key, ``names`` or ``measures`` not a 1-D unicode array,
        measures :func:`check_prediction_measures` refuses, or ``directions``
        not of shape ``(n_names, n_measures, 3)``.
    """
    missing_keys = [key for key in PREDICTION_KEYS if key not in arrays]
    if missing_keys:
        raise InputError(f"{file_name}: missing key(s) {', '.join(missing_keys)} "
                         f"(has {', '.join(sorted(arrays)) or 'none'})")
    names = unicode_vector(file_name, "names", arrays["names"])
    file_measures = check_prediction_measures(
        unicode_vector(file_name, "measures", arrays["measures"]), file_name)
    raw = arrays["directions"]
    if raw.shape != (len(names), len(file_measures), 3):
        raise InputError(f"{file_name}: directions must have shape ({len(names)}, "
                         f"{len(file_measures)}, 3) for {len(names)} names and "
                         f"{len(file_measures)} measures, got {raw.shape}")
    return tuple(names), raw, file_measures


def read_predictions(path: str | os.PathLike[str]) -> Predictions:
    """Read a predictions ``.npz`` (``allow_pickle=False``; the file is closed on return).

    Returns
    -------
    predictions : Predictions
        ``names``, ``directions (n_models, n_measures, 3) float64`` and
        ``measures``.

    Raises
    ------
    InputError
        As :func:`read_arrays` and :func:`parse_predictions`, or if the file is
        a ``.npy``, ``directions`` is not numeric or two names are the same.
    """
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise InputError(f"{path.name}: predictions must be a .npz file")
    arrays = read_arrays(path)
    if not isinstance(arrays, dict):  # read_arrays already refuses a .npy named .npz
        raise InputError(f"{path.name}: holds a single .npy array, not an .npz archive")
    names, raw, measures = parse_predictions(path.name, arrays)
    if raw.dtype.kind not in "fiu":
        raise InputError(f"{path.name}: directions must be numeric, got dtype {raw.dtype}")
    if len(set(names)) != len(names):
        raise InputError(f"{path.name}: model names must be unique")
    return Predictions(names, raw.astype(np.float64), measures)


def write_predictions(
    path: str | os.PathLike[str],
    names: Sequence[str] | NDArray[np.str_],
    directions: ArrayLike,
    *,
    measures: Sequence[str] = PAPER_MEASURES,
) -> Path:
    """Write predictions as a ``.npz``, atomically.

    Parameters
    ----------
    path : path-like
        Target file; must end in ``.npz``.
    names : sequence of str, or (n_models,) unicode array
        Model names, unique. A unicode array (e.g. millions of keys of a
        collection's table) is written as it is, without a Python string per
        name; it must have the width of its longest name, as a sequence's
        array gets, for the same bytes.
    directions : (n_models, n_measures, 3) array_like
        One direction per model and measure, stored as float64.
    measures : sequence of str
        The predicted measures: registered names, each once, the paper's
        four in their order among themselves (default: ``PAPER_MEASURES``, the
        four; see :func:`check_prediction_measures`).

    Returns
    -------
    path : pathlib.Path
        The written file.

    Raises
    ------
    InputError
        If the suffix is not ``.npz``, or the shapes, names or measures do not
        fit together.
    """
    path = Path(path)
    if path.suffix.lower() != ".npz":
        raise InputError(f"{path.name}: predictions must be saved as .npz")
    name_array = (names if isinstance(names, np.ndarray) and names.dtype.kind == "U"
                  and names.ndim == 1 else np.array([str(name) for name in names], dtype=str))
    ordered = np.sort(name_array)
    if (ordered[1:] == ordered[:-1]).any():
        raise InputError("names: model names must be unique")
    measure_list = check_prediction_measures(measures)
    values = np.asarray(directions, dtype=np.float64)
    if values.shape != (len(name_array), len(measure_list), 3):
        raise InputError(f"directions: expected shape ({len(name_array)}, {len(measure_list)}, 3), "
                         f"got {values.shape}")
    with atomic_write(path) as handle:
        np.savez(handle, names=name_array, directions=values,
                 measures=np.array(measure_list, dtype=str))
    return path
