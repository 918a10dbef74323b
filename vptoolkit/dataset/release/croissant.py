"""Croissant 1.1 JSON-LD metadata of a release, with its Responsible-AI fields.

:func:`croissant_jsonld` describes a release for dataset search engines and
loaders (mlcommons.org/croissant): one FileObject per file with its SHA-256,
the record sets of the Parquet configurations with their columns, and the
``rai:`` fields, which :func:`rai_fields` takes from the sections of the
dataset card (:func:`card_sections`), so the card stays the one place they
are written. Every number comes from the store's summary
(:func:`vptoolkit.dataset.store.info.info_from_reader`), every file from
what packing wrote (:class:`~vptoolkit.dataset.release.contents.ReleaseFiles`)
and every name, link and licence from what the publisher said
(:class:`~vptoolkit.dataset.release.options.ReleaseOptions`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from vptoolkit.conventions import SPLITS
from vptoolkit.dataset.release.contents import ReleaseFiles, check_described
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.dataset.release.parquet import VIEWS_CONFIG, Column, model_columns, view_columns
from vptoolkit.dataset.store.info import CITATION, info_from_reader, plural, source_name

if TYPE_CHECKING:
    from vptoolkit.dataset.store.reader import StoreReader

__all__ = ["card_sections", "croissant_jsonld", "rai_field_sources", "rai_fields"]

_CROISSANT_CONTEXT: dict[str, Any] = {
    "@language": "en",
    "@vocab": "https://schema.org/",
    "arrayShape": "cr:arrayShape",
    "citeAs": "cr:citeAs",
    "column": "cr:column",
    "conformsTo": "dct:conformsTo",
    "containedIn": "cr:containedIn",
    "cr": "http://mlcommons.org/croissant/",
    "rai": "http://mlcommons.org/croissant/RAI/",
    "data": {"@id": "cr:data", "@type": "@json"},
    "dataType": {"@id": "cr:dataType", "@type": "@vocab"},
    "dct": "http://purl.org/dc/terms/",
    "equivalentProperty": "cr:equivalentProperty",
    "examples": {"@id": "cr:examples", "@type": "@json"},
    "extract": "cr:extract",
    "field": "cr:field",
    "fileProperty": "cr:fileProperty",
    "fileObject": "cr:fileObject",
    "fileSet": "cr:fileSet",
    "format": "cr:format",
    "includes": "cr:includes",
    "isArray": "cr:isArray",
    "isLiveDataset": "cr:isLiveDataset",
    "jsonPath": "cr:jsonPath",
    "key": "cr:key",
    "md5": "cr:md5",
    "parentField": "cr:parentField",
    "path": "cr:path",
    "recordSet": "cr:recordSet",
    "references": "cr:references",
    "regex": "cr:regex",
    "repeated": "cr:repeated",
    "replace": "cr:replace",
    "samplingRate": "cr:samplingRate",
    "sc": "https://schema.org/",
    "separator": "cr:separator",
    "source": "cr:source",
    "subField": "cr:subField",
    "transform": "cr:transform",
}


_ENCODINGS = (
    (".zarr.zip", "application/zip", "Zarr v3 store in a zip file"),
    (".parquet", "application/x-parquet", "Parquet shard"),
    (".csv", "text/csv", "CSV table"),
    (".h5", "application/x-hdf5", "HDF5 file"),
    (".hdf5", "application/x-hdf5", "HDF5 file"),
    (".md", "text/markdown", "dataset card"),
    (".json", "application/json", "JSON metadata"),
)


_CROISSANT_TYPES = {
    "string": "sc:Text",
    "float32": "cr:Float32",
    "float64": "cr:Float64",
    "int32": "cr:Int32",
    "int64": "cr:Int64",
}


_RAI_SECTIONS = (
    # (rai property, card section, bullet prefix or None for the whole section)
    ("rai:dataCollection", "Collection process", None),
    ("rai:dataCollectionType", "Collection process", "- The source meshes"),
    ("rai:dataPreprocessingProtocol", "Preprocessing, cleaning and labeling", None),
    ("rai:dataAnnotationProtocol", "Preprocessing, cleaning and labeling", "- Labels are"),
    ("rai:dataUseCases", "Uses", None),
    ("rai:dataLimitations", "Uses", "- Not suitable"),
    ("rai:dataBiases", "Uses", "- Results depend"),
    ("rai:personalSensitiveInformation", "Composition", "- *Confidential or personal data?*"),
    ("rai:dataReleaseMaintenancePlan", "Maintenance", None),
)


def croissant_jsonld(
    reader: StoreReader,
    files: ReleaseFiles,
    options: ReleaseOptions | None = None,
    *,
    card: str | None = None,
) -> dict[str, Any]:
    """Return Croissant 1.1 JSON-LD metadata of a release.

    Written from the same three values as the card
    (:func:`~vptoolkit.dataset.release.card.render_card`): the store's
    summary, what packing wrote and what the publisher said.

    Parameters
    ----------
    reader : StoreReader
        The store the metadata describes.
    files : ReleaseFiles
        Each listed file becomes a ``cr:FileObject`` with ``contentUrl``
        (relative to the metadata file), ``encodingFormat``, ``sha256`` and
        ``contentSize`` where its size is known. Record sets are read from
        the Parquet shards (mlcroissant reads Parquet, not HDF5 or Zarr):
        ``models`` (one record per model, the columns of
        :func:`~vptoolkit.dataset.release.parquet.model_columns` for the store's
        measures, arrays with ``isArray``/``arrayShape``, the measure arrays'
        descriptions naming their columns) from the FileSet ``model-shards``, and
        ``views`` from the FileObject of the views shard; beside them, given
        inline, ``splits`` (``cr:Split``, which the ``split`` field
        references) and ``categories`` (the class labels, which the
        ``label`` field references). Without shards there are no record sets.
    options : ReleaseOptions, optional
        What the publisher said (default: ``ReleaseOptions()``). Croissant
        uses ``license``, ``pretty_name`` (``name``; default from the source
        name), ``version``, ``created`` (``datePublished``; default the
        store's ``created``), ``url`` (default: ``source_url``),
        ``source_url`` (``isBasedOn``) and ``creator`` (default
        ``"vptoolkit"``).
    card : str, optional
        The release's ``README.md``; the ``rai:`` fields are taken from its
        datasheet sections.

    Returns
    -------
    dict
        JSON types only; ``mlcroissant validate`` reports no error.

    Raises
    ------
    InputError
        If ``files`` or ``options`` is of another type.
    """
    files, options = check_described(files, options)
    info = info_from_reader(reader)
    source = source_name(info)
    sizes = files.sizes
    distribution: list[dict[str, Any]] = []
    for file_name, digest in sorted(files.digests.items()):
        mime, description = _encoding(file_name)
        entry: dict[str, Any] = {
            "@type": "cr:FileObject",
            "@id": file_name,
            "name": file_name,
            "description": description,
            "contentUrl": file_name,
            "encodingFormat": mime,
            "sha256": digest,
        }
        if file_name in sizes:
            entry["contentSize"] = f"{int(sizes[file_name])} B"
        distribution.append(entry)
    record_sets: list[dict[str, Any]] = []
    model_shards = [s for s in files.shards if s.split != VIEWS_CONFIG]
    view_shards = [s for s in files.shards if s.split == VIEWS_CONFIG]
    n_views, n_points = info["n_views"], info["n_points"]
    if model_shards:
        folder = model_shards[0].path.rsplit("/", 1)[0]
        distribution.append({
            "@type": "cr:FileSet",
            "@id": "model-shards",
            "name": "model-shards",
            "description": ("Parquet shards of the splits "
                            f"({', '.join(dict.fromkeys(s.split for s in model_shards))}), "
                            "one row per model"),
            "encodingFormat": "application/x-parquet",
            "includes": f"{folder}/*.parquet",
        })
        columns = model_columns(int(n_points or 0), int(n_views),
                                measures=info["measures"]["order"])
        record_sets.append(_split_record_set())
        record_sets.append(_category_record_set(info["class_names"]))
        record_sets.append({
            "@type": "cr:RecordSet",
            "@id": "models",
            "name": "models",
            "description": (f"One record per model, {info['n_models']} in all; the split of each "
                            f"is one of {', '.join(SPLITS)}"),
            "key": {"@id": "models/name"},
            "field": [_croissant_field("models", c, {"fileSet": {"@id": "model-shards"}})
                      for c in columns],
        })
        for field in record_sets[-1]["field"]:
            if field["name"] == "split":
                field["dataType"] = ["sc:Text", "cr:Split"]
                field["references"] = {"field": {"@id": f"{SPLITS_RECORD_SET}/name"}}
    for shard in view_shards:
        record_sets.append({
            "@type": "cr:RecordSet",
            "@id": VIEWS_CONFIG,
            "name": VIEWS_CONFIG,
            "description": f"The {n_views} view directions shared by every model",
            "key": {"@id": f"{VIEWS_CONFIG}/view_index"},
            "field": [_croissant_field(VIEWS_CONFIG, c, {"fileObject": {"@id": shard.path}})
                      for c in view_columns()],
        })
    title = options.pretty_name or f"Viewpoint quality of {source} models"
    document: dict[str, Any] = {
        "@context": dict(_CROISSANT_CONTEXT),
        "@type": "sc:Dataset",
        "conformsTo": "http://mlcommons.org/croissant/1.1",
        "name": title,
        "description": (
            f"{plural(info['n_models'], 'model')} from {len(info['categories'])} categories of "
            f"{source}, each with {n_points} surface points and normals and the viewpoint "
            f"quality measures {', '.join(info['measures']['order'])} for {n_views} views on "
            f"a Fibonacci sphere (rendered at {info['resolution']} px). Records come from the "
            "Parquet shards; the Zarr v3 zip and the HDF5 file hold the same arrays with the "
            "layout of SCHEMA.md."
        ),
        "license": options.license,
        "citeAs": CITATION,
        "version": options.version,
        "datePublished": options.created or info.get("created"),
        "dateCreated": info.get("created"),
        "creator": {"@type": "sc:Organization", "name": options.creator or "vptoolkit"},
        "keywords": ["3D", "point cloud", "mesh", "viewpoint selection", "viewpoint quality",
                     *info["categories"]],
        "isAccessibleForFree": True,
    }
    if options.url or options.source_url:
        document["url"] = options.url or options.source_url
    if options.source_url:
        document["isBasedOn"] = options.source_url
    if card:
        document.update(rai_fields(card))
    document["distribution"] = distribution
    document["recordSet"] = record_sets
    return document


SPLITS_RECORD_SET = "splits"
"""The ``cr:Split`` record set naming the splits of the ``models`` record set."""

_SPLIT_URLS = {"train": "cr:TrainingSplit", "validation": "cr:ValidationSplit",
               "test": "cr:TestSplit"}


def _split_record_set() -> dict[str, Any]:
    """The splits as a ``cr:Split`` record set: each name and Croissant's split URL."""
    return {
        "@type": "cr:RecordSet",
        "@id": SPLITS_RECORD_SET,
        "name": SPLITS_RECORD_SET,
        "description": "The splits of the models record set",
        "dataType": "cr:Split",
        "key": {"@id": f"{SPLITS_RECORD_SET}/name"},
        "field": [
            {"@type": "cr:Field", "@id": f"{SPLITS_RECORD_SET}/name",
             "name": f"{SPLITS_RECORD_SET}/name", "dataType": "sc:Text"},
            {"@type": "cr:Field", "@id": f"{SPLITS_RECORD_SET}/url",
             "name": f"{SPLITS_RECORD_SET}/url", "dataType": "sc:URL"},
        ],
        "data": [{f"{SPLITS_RECORD_SET}/name": split,
                  f"{SPLITS_RECORD_SET}/url": _SPLIT_URLS[split]} for split in SPLITS],
    }


def card_sections(card: str) -> dict[str, str]:
    """The ``## `` sections of a card's Markdown body, heading -> text.

    Text is joined into single spaces, with Markdown emphasis and code marks
    kept; the YAML header is skipped.
    """
    body = card.split("\n---\n", 1)[1] if card.startswith("---\n") else card
    sections: dict[str, list[str]] = {}
    current: list[str] | None = None
    for line in body.splitlines():
        if line.startswith("## "):
            current = sections.setdefault(line[3:].strip(), [])
        elif line.startswith("# "):
            current = None
        elif current is not None:
            current.append(line)
    return {heading: "\n".join(lines).strip() for heading, lines in sections.items()}


def rai_fields(card: str) -> dict[str, str]:
    """The Croissant RAI fields, each taken from a section (or one bullet) of the datasheet."""
    sections = card_sections(card)
    fields = {}
    for key, heading, prefix in _RAI_SECTIONS:
        bullets = _bullets(sections.get(heading, ""))
        if prefix is not None:
            bullets = [item for item in bullets if item.startswith(prefix)]
        text = " ".join(item[2:] for item in bullets)
        if text:
            fields[key] = text
    return fields


def rai_field_sources() -> dict[str, str]:
    """Where the card holds each RAI field: ``"section '## Uses', bullet '- Not suitable'"``."""
    return {key: f"section '## {heading}'" + (f", bullet '{prefix}'" if prefix else "")
            for key, heading, prefix in _RAI_SECTIONS}


def _bullets(text: str) -> list[str]:
    """The bullets of a section, each joined onto one line."""
    items: list[str] = []
    for line in text.splitlines():
        if line.startswith("- "):
            items.append(line.strip())
        elif items and line.startswith("  ") and line.strip():
            items[-1] += " " + line.strip()
    return items


_CATEGORIES = "categories"
"""The record set of the class labels: one record (label, category) per category."""


def _category_record_set(class_names: Sequence[str]) -> dict[str, Any]:
    """The enumeration of the categories: label ``i`` is ``class_names[i]``, given inline."""
    return {
        "@type": "cr:RecordSet",
        "@id": _CATEGORIES,
        "name": _CATEGORIES,
        "description": ("The class labels: a model's label is the index of its category in "
                        "the sorted category names"),
        "key": {"@id": f"{_CATEGORIES}/label"},
        "field": [
            {"@type": "cr:Field", "@id": f"{_CATEGORIES}/label", "name": "label",
             "description": "class label", "dataType": _CROISSANT_TYPES["int64"]},
            {"@type": "cr:Field", "@id": f"{_CATEGORIES}/category", "name": "category",
             "description": "category name", "dataType": _CROISSANT_TYPES["string"]},
        ],
        "data": [{f"{_CATEGORIES}/label": label, f"{_CATEGORIES}/category": name}
                 for label, name in enumerate(class_names)],
    }


def _croissant_field(record_set: str, column: Column, source: dict[str, Any]) -> dict[str, Any]:
    spec: dict[str, Any] = {
        "@type": "cr:Field",
        "@id": f"{record_set}/{column.name}",
        "name": column.name,
        "description": column.description,
        "dataType": _CROISSANT_TYPES[column.dtype],
        "source": {**source, "extract": {"column": column.name}},
    }
    if column.name == "label":
        spec["references"] = {"field": {"@id": f"{_CATEGORIES}/label"}}
    if column.shape:
        spec["isArray"] = True
        spec["arrayShape"] = ",".join("-1" if d is None else str(d) for d in column.shape)
    return spec


def _encoding(name: str) -> tuple[str, str]:
    for suffix, mime, description in _ENCODINGS:
        if name.endswith(suffix):
            return mime, description
    return "application/octet-stream", "file"
