"""The resumable staging folder of a build: one file per finished or failed model.

Each finished model is first written to ``OUT/.staging/`` as one ``.npz``
file (arrays plus a JSON ``meta`` member as ``uint8``; nothing pickled),
and each failed one as one ``.failed.json``, both atomically (temporary
file in the same folder, fsync, :func:`os.replace`). ``build.json`` there
holds the options (:meth:`BuildOptions.to_dict
<vptoolkit.dataset.builder.options.BuildOptions.to_dict>`), the toolkit version
and the time the build was first started, and ``lock``
keeps a second build out. A build killed at any point (even ``kill -9``) is
resumed by running the same command again (:func:`scan_staging`): staged
models whose source file is unchanged (same size and modification time,
:func:`source_signature`) are kept, left-over temporary files are deleted,
and a staged file that cannot be read in full is computed again after one
warning. The staging folder is kept after the store is written, so
rerunning (e.g. after adding models to the source) computes only what is
new; delete ``OUT/.staging`` to reclaim its space, after which OUT can no
longer be resumed. :func:`staged_entries` reads the staged models back as
the entries of :func:`vptoolkit.dataset.store.writer.write_dataset`.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import re
from collections.abc import Iterator, Mapping, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from vptoolkit.checks import changed_values, one_line
from vptoolkit.dataset.builder.compute import FailedModel, MeasuredModel
from vptoolkit.dataset.builder.options import BuildOptions
from vptoolkit.dataset.builder.sources import SourceModel
from vptoolkit.dataset.store.entries import LazyEntries
from vptoolkit.dataset.store.schema import (
    ENTRY_ARRAYS,
    FAILURE_KEYS,
    ModelEntry,
    from_json_bytes,
    json_bytes,
)
from vptoolkit.errors import InputError
from vptoolkit.files import atomic_write, exclusive_lock, read_json_file

__all__ = [
    "STAGING_DIR",
    "staged_entries",
    "build_lock",
    "prepare_out",
    "resume_or_start",
    "scan_staging",
    "source_signature",
    "stage_failure",
    "stage_key",
    "stage_model",
    "warn_about_models_left_out",
]

_log = logging.getLogger(__name__)

STAGING_DIR = ".staging"
"""Folder inside OUT that holds the finished models of a build in progress."""

_STAGING_VERSION = 2
_BUILD_FILE = "build.json"
_LOCK_FILE = "lock"
_TEMP_SUFFIX = ".partial"  # temporary files of vptoolkit.files.atomic_write
_MODEL_SUFFIX = ".npz"
_FAILURE_SUFFIX = ".failed.json"
_MEMBERS = tuple(spec.field for spec in ENTRY_ARRAYS)  # a staged model's arrays, by field name
# Fields of a staged meta's record that staged_entries reads.
_RECORD_KEYS = ("name", "category", "source", "source_sha256", "cleaning")


def prepare_out(out_dir: Path) -> Path:
    """Create OUT and its staging folder, or check that an existing OUT is ours."""
    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(f"{out_dir}: output exists and is not a folder")
    staging = out_dir / STAGING_DIR
    if out_dir.is_dir() and not staging.is_dir() and any(out_dir.iterdir()):
        raise InputError(
            f"{out_dir}: folder is not empty and is not a vptoolkit build folder "
            f"(no {STAGING_DIR}/); choose a new or empty folder"
        )
    staging.mkdir(parents=True, exist_ok=True)
    return staging


@contextlib.contextmanager
def build_lock(staging: Path) -> Iterator[None]:
    """Hold an exclusive lock on the staging folder (released by the OS if we are killed)."""
    with exclusive_lock(staging / _LOCK_FILE,
                        f"{staging.parent}: another build is running in this folder"):
        yield


def resume_or_start(staging: Path, options: BuildOptions, root: Path) -> str:
    """Check the staged options against ``options`` or record them; return the creation time.

    A build resumes only with equal options made by the same toolkit version
    (``BuildOptions.from_dict(recorded) == options``); anything else would
    mix models computed two ways in one store.
    """
    from vptoolkit._version import __version__

    build_file = staging / _BUILD_FILE
    version = __version__
    if build_file.exists():
        try:
            recorded = read_json_file(build_file, str(build_file))
            if recorded.get("staging_version") != _STAGING_VERSION:
                raise ValueError(f"staging_version {recorded.get('staging_version')!r}, "
                                 f"expected {_STAGING_VERSION}")
            staged = BuildOptions.from_dict(recorded["options"])
            staged_version = recorded["toolkit_version"]
            created = str(recorded["created"])
        except (ValueError, KeyError, TypeError, AttributeError, InputError) as err:
            raise InputError(f"{build_file}: unreadable build record ({one_line(err)})") from err
        changed = [f"{key}={old!r} (now {new!r})" for key, (old, new)
                   in changed_values(staged.to_dict(), options.to_dict()).items()]
        if staged_version != version:
            changed.append(f"toolkit_version={staged_version!r} (now {version!r})")
        if changed:
            raise InputError(
                f"{staging.parent}: holds a build made with {'; '.join(changed)}; "
                "use a new OUT folder or the same options"
            )
        return created
    created = datetime.now(timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ")
    record = {
        "staging_version": _STAGING_VERSION,
        "created": created,
        "source": str(root),
        "toolkit_version": version,
        "options": options.to_dict(),
    }
    _write_atomic(build_file, json.dumps(record, indent=2, sort_keys=True).encode("utf-8"))
    return created


def stage_key(model_id: str) -> str:
    """File stem of a model in the staging folder: readable, safe and unique."""
    readable = re.sub(r"[^A-Za-z0-9_.-]+", "_", model_id.replace("/", "__"))[:80]
    digest = hashlib.sha256(model_id.encode("utf-8")).hexdigest()[:16]
    return f"m-{readable}-{digest}"


def scan_staging(
    staging: Path, models: Sequence[SourceModel]
) -> tuple[dict[str, Path], dict[str, dict[str, str]], list[SourceModel]]:
    """Sort models into staged results, staged failures and work still to do.

    Temporary files of an interrupted write are deleted. A staged result is
    kept only when its model id and source file (path, size, modification
    time) still match; otherwise it is deleted and the model is redone.
    """
    names = sorted(os.listdir(staging))
    for name in names:
        if name.endswith(_TEMP_SUFFIX):
            (staging / name).unlink(missing_ok=True)
    present = set(names)
    done: dict[str, Path] = {}
    failed: dict[str, dict[str, str]] = {}
    todo: list[SourceModel] = []
    for model in models:
        key = stage_key(model.model_id)
        model_file = staging / f"{key}{_MODEL_SUFFIX}"
        failure_file = staging / f"{key}{_FAILURE_SUFFIX}"
        has_model = model_file.name in present
        has_failure = failure_file.name in present
        signature = source_signature(model)
        if has_model and not has_failure and _staged_meta_matches(model_file, signature):
            done[model.model_id] = model_file
            continue
        if has_failure and not has_model:
            record = _read_failure(failure_file)
            if record is not None and record.get("signature") == signature:
                failed[model.model_id] = record["failure"]
                continue
        model_file.unlink(missing_ok=True)
        failure_file.unlink(missing_ok=True)
        todo.append(model)
    return done, failed, todo


def warn_about_models_left_out(
    staging: Path, models: Sequence[SourceModel], out_dir: Path
) -> None:
    """Say so when this run's store will hold fewer models than the folder has staged.

    A rerun with other ``categories`` (or with models removed from the source)
    writes a store of this run's models only; the other staged models are
    kept, and a later run that includes them again takes them from there.
    """
    wanted = {f"{stage_key(model.model_id)}{_MODEL_SUFFIX}" for model in models}
    others = [
        name for name in sorted(os.listdir(staging))
        if name.startswith("m-") and name.endswith(_MODEL_SUFFIX) and name not in wanted
    ]
    if others:
        _log.warning(
            "%s: %d staged models are not part of this run (other --categories or removed "
            "sources); the store will hold only this run's %d models (the staged ones are "
            "kept for a later run)", out_dir, len(others), len(models),
        )


def source_signature(model: SourceModel) -> dict[str, Any]:
    """What identifies the staged result of a source file: id, path, size and mtime."""
    try:
        info = model.path.stat()
        size, mtime_ns = int(info.st_size), int(info.st_mtime_ns)
    except OSError:
        size, mtime_ns = -1, -1
    return {"model_id": model.model_id, "source": model.source, "size": size, "mtime_ns": mtime_ns}


def _staged_meta_matches(path: Path, signature: Mapping[str, Any]) -> bool:
    """Whether a staged model is whole and was made from the same source file.

    Every member is read in full, so a bad CRC, a damaged deflate stream or a
    truncated member anywhere in the file (not just in ``meta``) counts as
    unreadable, and so does a ``meta`` that is not the object
    :func:`stage_model` writes: the model is computed again after one
    warning, instead of failing the final write or every resumed run.
    """
    try:
        # np.load leaks its file handle when the zip is broken, so open the file here.
        with open(path, "rb") as stream, np.load(stream, allow_pickle=False) as staged:
            meta = _check_meta(from_json_bytes(staged["meta"]))
            missing = [name for name in _MEMBERS if name not in staged.files]
            if missing:
                raise KeyError(f"no member {missing[0]!r}")
            for name in _MEMBERS:
                staged[name]  # reads the member in full and checks its CRC
    # Any failure to decode (zlib.error, BadZipFile, a wrong meta, ...) means unreadable.
    except Exception as err:  # the file is redone, never trusted
        _log.warning("%s: staged model unreadable (%s); computing it again", path.name,
                     one_line(err))
        return False
    return bool(meta["signature"] == signature)


def _check_meta(meta: Any) -> dict[str, Any]:
    """Return a staged ``meta`` if it has the fields :func:`staged_entries` reads, else raise."""
    if not isinstance(meta, dict) or not isinstance(meta.get("record"), dict):
        raise ValueError("meta is not an object with a record")
    missing = [key for key in _RECORD_KEYS if key not in meta["record"]]
    if missing:
        raise ValueError(f"meta record has no {missing[0]!r}")
    if "signature" not in meta:
        raise ValueError("meta has no signature")
    return meta


def _read_failure(path: Path) -> dict[str, Any] | None:
    """A staged failure record, or None (the model is redone) if it is unreadable or malformed."""
    try:
        record = read_json_file(path)
    except InputError:
        return None
    if not isinstance(record, dict):
        return None
    failure = record.get("failure")
    if not isinstance(failure, dict) or not all(
        isinstance(failure.get(key), str) for key in FAILURE_KEYS
    ):
        return None
    return record


def stage_model(staging: Path, result: MeasuredModel) -> Path:
    """Write a finished model's arrays and meta to the staging folder atomically."""
    key = stage_key(result.model_id)
    path = staging / f"{key}{_MODEL_SUFFIX}"
    meta = {"signature": result.signature, "record": result.record}
    _write_atomic(path, {**result.arrays, "meta": json_bytes(meta, sort_keys=True)})
    (staging / f"{key}{_FAILURE_SUFFIX}").unlink(missing_ok=True)
    return path


def stage_failure(staging: Path, result: FailedModel) -> None:
    """Write a failed model's reason and source signature to the staging folder atomically."""
    key = stage_key(result.model_id)
    record = {"signature": result.signature, "failure": result.failure}
    _write_atomic(
        staging / f"{key}{_FAILURE_SUFFIX}", json.dumps(record, sort_keys=True).encode("utf-8")
    )
    (staging / f"{key}{_MODEL_SUFFIX}").unlink(missing_ok=True)


def _write_atomic(path: Path, payload: bytes | Mapping[str, NDArray[Any]]) -> None:
    """Write bytes, or arrays as a compressed ``.npz``, to ``path`` atomically.

    :func:`vptoolkit.files.atomic_write`: a reader (or a resumed build) sees
    the old file or the whole new one, never a part.
    """
    with atomic_write(path) as stream:
        if isinstance(payload, bytes):
            stream.write(payload)
        else:
            # the stub reads ** as if it could hold allow_pickle; the keys are array names
            np.savez_compressed(stream, **payload)  # type: ignore[arg-type]
    _fsync_folder(path.parent)


def _fsync_folder(folder: Path) -> None:
    """Make a rename durable; a no-op where folders cannot be opened (Windows)."""
    try:
        handle = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - Windows
        return
    try:
        os.fsync(handle)
    except OSError:  # pragma: no cover - some file systems refuse fsync on folders
        pass
    finally:
        os.close(handle)


def staged_entries(items: Sequence[tuple[Path, str]]) -> LazyEntries:
    """The staged models as a lazy sequence of :class:`ModelEntry`, one file read per item.

    Parameters
    ----------
    items : sequence of (Path, str)
        Each model's staged ``.npz`` file (:func:`stage_model`) and its
        split, in store order.

    Returns
    -------
    entries : LazyEntries
        Item ``i`` read from ``items[i]``'s file each time it is read, its
        arrays the members named by the fields of
        :data:`~vptoolkit.dataset.store.schema.ENTRY_ARRAYS`.
    """
    listed = list(items)

    def read(index: int) -> ModelEntry:
        path, split = listed[index]
        with open(path, "rb") as stream, np.load(stream, allow_pickle=False) as staged:
            arrays = {name: staged[name] for name in _MEMBERS}
            meta = from_json_bytes(staged["meta"])
        record = meta["record"]
        return ModelEntry(
            name=record["name"],
            category=record["category"],
            split=split,
            source=record["source"],
            source_sha256=record["source_sha256"],
            cleaning=record["cleaning"],
            view_set=record.get("view_set"),
            **arrays,
        )

    return LazyEntries(len(listed), read)
