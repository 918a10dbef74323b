"""The exception tree of vptoolkit.

Every error the toolkit raises on purpose derives from :class:`VptoolkitError`.
Messages are one line: the file or argument first, then the problem, e.g.
``chair_0001.off: face 12 refers to vertex 1200, mesh has 1187 vertices``.

This module imports nothing else from the package, so catching an error never
loads the heavy parts of the stack.

The command line maps the tree onto exit codes by class alone:
:class:`InputError` (with its subclasses :class:`ArgumentError`,
:class:`MeshLoadError`, :class:`CheckpointError` and
:class:`ExistingRunError`) and
:class:`MissingDependencyError` exit with 2, :class:`MeasurementError` and
:class:`VerificationError` with 1.
"""

from __future__ import annotations

__all__ = [
    "VptoolkitError",
    "InputError",
    "ArgumentError",
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


class ArgumentError(InputError):
    """A bad value of one named argument, whose message names it wherever it is said.

    The message is a template in which ``{argument}`` stands for the
    argument's name: ``ArgumentError("{argument}: split 'test' of
    dataset.zarr has no models; choose another with {argument}",
    "val_split")`` reads ``val_split: split 'test' ...; choose another with
    val_split`` from Python, and :meth:`named` says the same with another
    name for the argument, such as the command line's ``--val-split``.

    Parameters
    ----------
    template : str
        The one-line message, ``{argument}`` where the argument is named
        (nothing else in it is a placeholder).
    argument : str
        The argument's name (``val_split``; ``category=`` where Python
        passes it by keyword).
    """

    def __init__(self, template: str, argument: str) -> None:
        super().__init__(template.replace("{argument}", argument))
        self.template = template
        self.argument = argument

    def __reduce__(self) -> tuple[type[ArgumentError], tuple[str, str]]:
        """Pickled with its template, so a worker process's error reaches the caller whole."""
        return type(self), (self.template, self.argument)

    def named(self, name: str) -> ArgumentError:
        """The same error with the argument called ``name`` (its class kept)."""
        return type(self)(self.template, name)


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
