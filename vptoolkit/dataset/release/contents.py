"""What packing wrote, as one value: :class:`ReleaseFiles`.

The dataset card (:func:`~vptoolkit.dataset.release.card.render_card`) and
the Croissant metadata
(:func:`~vptoolkit.dataset.release.croissant.croissant_jsonld`) describe a
release from two values: what the publisher said
(:class:`~vptoolkit.dataset.release.options.ReleaseOptions`) and what packing
computed, the files' SHA-256 digests and sizes and the Parquet shards, held
here. Nothing in it is typed by hand: it is made by
:func:`~vptoolkit.dataset.release.pack.pack_release` from the files it wrote,
so only its type is checked (:func:`check_described`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.errors import InputError

if TYPE_CHECKING:
    from vptoolkit.dataset.release.parquet import ParquetShard

__all__ = ["ReleaseFiles", "check_described"]


@dataclass(frozen=True)
class ReleaseFiles:
    """The files of a release that the card and Croissant list, with their digests and sizes.

    Attributes
    ----------
    digests : mapping of str to str
        Release-relative POSIX path -> SHA-256 hex digest of each listed file;
        which suffixes appear (``.parquet``, ``.h5``, ``.zarr.zip``,
        ``LICENSES.csv``) also says which formats the release holds.
    sizes : mapping of str to int
        Path -> size in bytes; a listed file without one is shown without a
        size (``-`` in the card, no ``contentSize`` in Croissant). Default:
        none.
    shards : tuple of ParquetShard
        The Parquet shards
        (:func:`~vptoolkit.dataset.release.parquet.write_parquet_shards`);
        empty without the ``parquet`` format, and then the card has no hub
        configurations and Croissant no record sets. Any sequence is kept as
        a tuple.

    Examples
    --------
    >>> files = ReleaseFiles({"a.h5": "00" * 32}, {"a.h5": 10})
    >>> sorted(files.with_file("README.md", "11" * 32, 5).sizes.items())
    [('README.md', 5), ('a.h5', 10)]
    """

    digests: Mapping[str, str]
    sizes: Mapping[str, int] = field(default_factory=dict)
    shards: Sequence[ParquetShard] = ()

    def __post_init__(self) -> None:
        # frozen: copies, so that the caller's later changes do not show through
        object.__setattr__(self, "digests", dict(self.digests))
        object.__setattr__(self, "sizes", dict(self.sizes))
        object.__setattr__(self, "shards", tuple(self.shards))

    def with_file(self, name: str, digest: str, size: int) -> ReleaseFiles:
        """These files and one more (or ``name`` replaced), e.g. the card for Croissant."""
        return dataclasses.replace(self, digests={**self.digests, name: digest},
                                   sizes={**self.sizes, name: size})


def check_described(files: object, options: object) -> tuple[ReleaseFiles, ReleaseOptions]:
    """The two values a card or Croissant is written from, ``options`` None as ``ReleaseOptions()``.

    Raises
    ------
    InputError
        If ``files`` is not a :class:`ReleaseFiles` (a mapping of digests
        alone is named, with what to pass instead) or ``options`` is neither
        None nor a :class:`~vptoolkit.dataset.release.options.ReleaseOptions`.
    """
    if not isinstance(files, ReleaseFiles):
        hint = " (pass ReleaseFiles(digests, sizes, shards))" if isinstance(files, Mapping) else ""
        raise InputError(f"files: expected ReleaseFiles, got {type(files).__name__}{hint}")
    if options is None:
        return files, ReleaseOptions()
    if not isinstance(options, ReleaseOptions):
        raise InputError(f"options: expected ReleaseOptions, got {type(options).__name__}")
    return files, options
