"""The exception tree of vptoolkit.

Every error the toolkit raises on purpose derives from :class:`VptoolkitError`.
Messages are one line: the file or argument first, then the problem, e.g.
``chair_0001.off: face 12 refers to vertex 1200, mesh has 1187 vertices``.

This module imports nothing else from the package, so catching an error never
loads the heavy parts of the stack.

The command line maps the tree onto exit codes by class alone:
:class:`InputError` (with its subclasses :class:`MeshLoadError`,
:class:`CheckpointError` and :class:`ExistingRunError`) and
:class:`MissingDependencyError` exit with 2, :class:`MeasurementError` and
:class:`VerificationError` with 1.
"""

from __future__ import annotations

__all__ = [
    "VptoolkitError",
    "InputError",
    "MeshLoadError",
    "CheckpointError",
    "ExistingRunError",
    "MissingDependencyError",
    "MeasurementError",
    "VerificationError",
]


class VptoolkitError(Exception):
    """Root of every error raised on purpose by vptoolkit."""


class InputError(VptoolkitError, ValueError):
    """A bad file, array or option given by the caller."""


class MeshLoadError(InputError):
    """A model file cannot be read into a valid mesh or point cloud, or is not the one needed.

    The message names the file and the problem: unreadable, unknown format,
    empty, non-finite coordinates, a face index out of range, or a point cloud
    where a surface is needed.
    """


class CheckpointError(InputError):
    """A checkpoint's weights do not match the architecture its configuration declares.

    Raised for a network checkpoint and for a training state; the message
    names the weights file. The file is damaged or belongs to another
    configuration, so the caller must give another one.
    """


class ExistingRunError(InputError):
    """A training output already holds a run that the call would overwrite.

    The message names the folder and says how to continue or replace the run.
    """


class MissingDependencyError(VptoolkitError, ImportError):
    """An optional package needed for the requested work is not installed."""


class MeasurementError(VptoolkitError, RuntimeError):
    """A measurement could not be made (ray casting or rendering failed)."""


class VerificationError(VptoolkitError):
    """Stored data disagrees with what it claims (checksum, measure order)."""
