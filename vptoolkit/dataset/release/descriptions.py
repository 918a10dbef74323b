"""The description files of a release: the card, ``croissant.json`` and ``dataset_info.json``.

:func:`pack_release <vptoolkit.dataset.release.pack.pack_release>` writes the
card (``README.md``) and then ``croissant.json`` from it
(:func:`write_descriptions`: the card's SHA-256, size and ``rai:`` fields
go into the JSON-LD). A person may edit the card of a packed release later;
:func:`update_card` then rewrites ``croissant.json`` and ``SHA256SUMS`` to
match, after checking that nothing else changed, nothing was added and no
file is a symbolic link. What a publisher gave at packing
(:class:`~vptoolkit.dataset.release.options.ReleaseOptions`) stays in
``croissant.json``, so the rewrite says the same.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path
from typing import TYPE_CHECKING, Any

from vptoolkit.dataset.release.croissant import croissant_jsonld, rai_field_sources, rai_fields
from vptoolkit.dataset.release.manifest import (
    CARD_NAME,
    MANIFEST_NAME,
    format_sha256sums,
    read_sha256sums,
)
from vptoolkit.errors import InputError, VerificationError
from vptoolkit.files import (
    json_text,
    parse_json,
    sha256_file,
    write_bytes_atomic,
    write_json_atomic,
)

if TYPE_CHECKING:
    from vptoolkit.dataset.release.contents import ReleaseFiles
    from vptoolkit.dataset.release.options import ReleaseOptions
    from vptoolkit.dataset.store.reader import StoreReader

__all__ = ["CROISSANT_NAME", "INFO_NAME", "update_card", "write_descriptions", "write_json"]

CROISSANT_NAME = "croissant.json"
INFO_NAME = "dataset_info.json"


def write_descriptions(folder: Path, reader: StoreReader, files: ReleaseFiles,
                       options: ReleaseOptions) -> str:
    """Write croissant.json from the card in ``folder``, listing ``files`` and the card.

    Returns
    -------
    str
        The SHA-256 of the card, so that the manifest need not read it again.
    """
    card_path = folder / CARD_NAME
    card_digest = sha256_file(card_path)
    described = files.with_file(CARD_NAME, card_digest, card_path.stat().st_size)
    croissant = croissant_jsonld(reader, described, options,
                                 card=card_path.read_text(encoding="utf-8"))
    write_json(folder / CROISSANT_NAME, croissant)
    return card_digest


def write_json(path: Path, value: Any) -> None:
    """Write ``value`` as indented UTF-8 JSON (keys in their order, no NaN) atomically."""
    write_json_atomic(path, value, sort_keys=False, ensure_ascii=False, allow_nan=False)


def _release_files(folder: Path) -> list[str]:
    """Every file below ``folder`` as sorted POSIX paths; a symbolic link is refused."""
    found: list[str] = []
    for root, dirs, files in os.walk(folder):
        dirs.sort()
        for name in [*dirs, *files]:
            path = Path(root) / name
            if path.is_symlink():
                raise VerificationError(
                    f"{path.relative_to(folder).as_posix()}: a symbolic link; a release holds "
                    f"plain files only, so {CARD_NAME} must be edited in place"
                )
        found.extend((Path(root) / name).relative_to(folder).as_posix() for name in files)
    return sorted(found)


def update_card(release_dir: Path | str) -> list[str]:
    """Bring ``croissant.json`` and ``SHA256SUMS`` in line with an edited card.

    A person may edit a release's ``README.md`` (wording, a contact, a
    correction). This rewrites what depends on it: in ``croissant.json`` the
    card's SHA-256 and size and the ``rai:`` fields taken from the datasheet
    text, then ``SHA256SUMS``. The datasheet's headings and bullets are where
    the RAI fields live (:func:`~vptoolkit.dataset.release.croissant.rai_field_sources`):
    a card that lost one that ``croissant.json`` holds is refused rather than
    the field silently dropped. Every other file, ``croissant.json`` included,
    must be what the manifest lists, so the rewrite starts from the metadata
    written at packing; no file may be added and none may be a symbolic link.
    ``croissant.json`` is written first and put back if ``SHA256SUMS`` cannot
    be written, so the two never disagree after a failure.

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
        ``SHA256SUMS``, ``croissant.json`` is not a JSON object, the card
        is not UTF-8 text or it lost the heading or bullet of an RAI field.
    VerificationError
        If a file other than the card differs from the manifest, is missing,
        is not listed in it or is a symbolic link, or the manifest is
        malformed: only the card may be edited.
    """
    folder = Path(release_dir)
    present = _release_files(folder) if folder.is_dir() else []
    for required in (CARD_NAME, CROISSANT_NAME, MANIFEST_NAME):
        if not (folder / required).is_file():
            raise InputError(f"{folder / required}: missing; --update-card needs a packed release")
    listed = read_sha256sums(folder / MANIFEST_NAME)
    for relative in present:
        if relative != MANIFEST_NAME and relative not in listed:
            raise VerificationError(
                f"{relative}: not listed in SHA256SUMS; only {CARD_NAME} may be edited, "
                "no file added (run vptool verify to see what changed)"
            )
    old_croissant = (folder / CROISSANT_NAME).read_bytes()
    document = parse_json(old_croissant, CROISSANT_NAME)
    if not isinstance(document, dict):
        raise InputError(f"{CROISSANT_NAME}: not a JSON object")
    for relative, digest in listed.items():
        if relative == CARD_NAME:
            continue
        if not (folder / relative).is_file() or sha256_file(folder / relative) != digest:
            raise VerificationError(
                f"{relative}: differs from SHA256SUMS; only {CARD_NAME} may be edited "
                "(run vptool verify to see what changed)"
            )
    card_bytes = (folder / CARD_NAME).read_bytes()
    try:
        card = card_bytes.decode("utf-8")
    except UnicodeDecodeError as err:
        raise InputError(f"{folder / CARD_NAME}: not UTF-8 text (byte {err.start}); "
                         "save the card as UTF-8") from err
    card_digest = hashlib.sha256(card_bytes).hexdigest()
    rai = rai_fields(card)
    lost = [key for key in document if key.startswith("rai:") and key not in rai]
    if lost:
        sources = rai_field_sources()
        more = f" (and {len(lost) - 1} more field(s))" if len(lost) > 1 else ""
        raise InputError(
            f"{folder / CARD_NAME}: {lost[0]} is read from the card's "
            f"{sources.get(lost[0], 'datasheet')}, which is gone{more}; restore the heading "
            "so that croissant.json keeps the field (nothing rewritten)"
        )
    for key in [key for key in document if key.startswith("rai:")]:
        del document[key]
    distribution = document.pop("distribution", [])
    record_sets = document.pop("recordSet", [])
    document.update(rai)
    for item in distribution:
        if isinstance(item, dict) and item.get("contentUrl") == CARD_NAME:
            item["sha256"] = card_digest
            item["contentSize"] = f"{len(card_bytes)} B"
    document["distribution"] = distribution
    document["recordSet"] = record_sets
    croissant = json_text(document, sort_keys=False, ensure_ascii=False,
                          allow_nan=False).encode("utf-8")
    sums = dict(listed)
    sums[CARD_NAME] = card_digest
    sums[CROISSANT_NAME] = hashlib.sha256(croissant).hexdigest()
    manifest = format_sha256sums(sums).encode("utf-8")
    write_bytes_atomic(folder / CROISSANT_NAME, croissant)
    try:
        write_bytes_atomic(folder / MANIFEST_NAME, manifest)
    except BaseException:
        write_bytes_atomic(folder / CROISSANT_NAME, old_croissant)
        raise
    return [CROISSANT_NAME, MANIFEST_NAME]
