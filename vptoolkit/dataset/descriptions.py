"""The description files of a release: the card, ``croissant.json`` and ``dataset_info.json``.

:func:`pack_release <vptoolkit.dataset.release.pack_release>` writes the
card (``README.md``) and then ``croissant.json`` from it
(:func:`write_descriptions`: the card's SHA-256, size and ``rai:`` fields
go into the JSON-LD). A person may edit the card of a packed release later;
:func:`update_card` then rewrites ``croissant.json`` and ``SHA256SUMS`` to
match, after checking that nothing else changed. The options a publisher
gave at packing are kept in ``croissant.json`` (:class:`ReleaseOptions`) so
the rewrite says the same.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vptoolkit.dataset.croissant import croissant_jsonld, rai_fields
from vptoolkit.dataset.manifest import (
    MANIFEST_NAME,
    read_sha256sums,
    sha256_file,
    write_sha256sums,
)
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import read_json_file, write_text_atomic

if TYPE_CHECKING:
    from vptoolkit.dataset.parquet import ParquetShard
    from vptoolkit.dataset.reader import StoreReader

__all__ = ["CARD_NAME", "CROISSANT_NAME", "INFO_NAME", "ReleaseOptions", "update_card",
           "write_descriptions", "write_json"]

CARD_NAME = "README.md"
CROISSANT_NAME = "croissant.json"
INFO_NAME = "dataset_info.json"


@dataclass(frozen=True)
class ReleaseOptions:
    """What a publisher said about a release, kept in ``croissant.json`` for later rewrites."""

    license: str
    version: str
    created: str
    pretty_name: str | None = None
    source_url: str | None = None
    url: str | None = None
    creator: str | None = None
    license_name: str | None = None
    license_link: str | None = None

    def card_arguments(self) -> dict[str, Any]:
        return {"license": self.license, "pretty_name": self.pretty_name,
                "version": self.version, "created": self.created,
                "source_url": self.source_url, "license_name": self.license_name,
                "license_link": self.license_link}


def write_descriptions(folder: Path, reader: StoreReader, digests: Mapping[str, str],
                        sizes: Mapping[str, int], shards: Sequence[ParquetShard],
                        options: ReleaseOptions) -> None:
    """Write croissant.json from the card in ``folder`` (which it lists with its digest)."""
    card = (folder / CARD_NAME).read_text(encoding="utf-8")
    described = dict(digests)
    described[CARD_NAME] = sha256_file(folder / CARD_NAME)
    all_sizes = dict(sizes)
    all_sizes[CARD_NAME] = (folder / CARD_NAME).stat().st_size
    croissant = croissant_jsonld(
        reader, described, license=options.license, name=options.pretty_name,
        file_sizes=all_sizes, shards=shards, card=card,
        version=options.version, date_published=options.created, url=options.url,
        source_url=options.source_url, creator=options.creator,
    )
    write_json(folder / CROISSANT_NAME, croissant)


def write_json(path: Path, value: Any) -> None:
    text = json.dumps(value, indent=2, ensure_ascii=False, allow_nan=False)
    write_text_atomic(path, text + "\n")


def update_card(release_dir: Path | str) -> list[str]:
    """Bring ``croissant.json`` and ``SHA256SUMS`` in line with an edited card.

    A person may edit a release's ``README.md`` (wording, a contact, a
    correction). This rewrites what depends on it: in ``croissant.json`` the
    card's SHA-256 and size and the ``rai:`` fields taken from the datasheet
    text, then ``SHA256SUMS``. Archives, shards and every other file are
    checked against the manifest first and never written.

    Parameters
    ----------
    release_dir : Path or str
        A release folder written by :func:`pack_release`.

    Returns
    -------
    list of str
        The files rewritten: ``["croissant.json", "SHA256SUMS"]``.

    Raises
    ------
    InputError
        If the folder lacks ``README.md``, ``croissant.json`` or
        ``SHA256SUMS``, or ``croissant.json`` is not JSON.
    VerificationError
        If a file other than the card and the files derived from it differs
        from the manifest: only the card may be edited.
    """
    folder = Path(release_dir)
    for required in (CARD_NAME, CROISSANT_NAME, MANIFEST_NAME):
        if not (folder / required).is_file():
            raise InputError(f"{folder / required}: missing; --update-card needs a packed release")
    derived = {CARD_NAME, CROISSANT_NAME}
    for relative, digest in read_sha256sums(folder / MANIFEST_NAME).items():
        if relative in derived:
            continue
        if not (folder / relative).is_file() or sha256_file(folder / relative) != digest:
            raise VerificationError(
                f"{relative}: differs from SHA256SUMS; only {CARD_NAME} may be edited "
                "(run vptool verify to see what changed)"
            )
    document = read_json_file(folder / CROISSANT_NAME)
    if not isinstance(document, dict):
        raise InputError(f"{CROISSANT_NAME}: not a JSON object")
    card = (folder / CARD_NAME).read_text(encoding="utf-8")
    for key in [key for key in document if key.startswith("rai:")]:
        del document[key]
    rai = rai_fields(card)
    distribution = document.pop("distribution", [])
    record_sets = document.pop("recordSet", [])
    document.update(rai)
    for item in distribution:
        if isinstance(item, dict) and item.get("contentUrl") == CARD_NAME:
            item["sha256"] = sha256_file(folder / CARD_NAME)
            item["contentSize"] = f"{(folder / CARD_NAME).stat().st_size} B"
    document["distribution"] = distribution
    document["recordSet"] = record_sets
    write_json(folder / CROISSANT_NAME, document)
    write_sha256sums(folder)
    return [CROISSANT_NAME, MANIFEST_NAME]
