"""The dataset card: the ``README.md`` of a release and its dataset-hub YAML header.

:func:`render_card` fills ``vptoolkit/dataset_card/template.md`` with numbers computed
from the store (nothing is typed by hand), in the sections of "Datasheets for
Datasets" (Gebru et al.), under the YAML header of
:func:`~vptoolkit.dataset.release.hub.hub_yaml` in the style of dataset hubs
(configurations, features, size category).

A card is a function of three values, as Hugging Face ``datasets`` derives a
card's data from one ``DatasetInfo``: the store (its summary,
:func:`~vptoolkit.dataset.store.info.info_from_reader`), what packing wrote
(:class:`~vptoolkit.dataset.release.contents.ReleaseFiles`) and what the
publisher said (:class:`~vptoolkit.dataset.release.options.ReleaseOptions`).
Each part of the card (header, summary, licence, files, reading, counts,
measures, schema, statistics, datasheet, citation) is one small function
returning the template placeholders it fills.

The summary the card is written from lives in :mod:`vptoolkit.dataset.store.info`
and the Croissant metadata in :mod:`vptoolkit.dataset.release.croissant`.

"""

from __future__ import annotations

import importlib.resources
import json
import re
import string
from collections import Counter
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from vptoolkit.dataset.release.contents import ReleaseFiles, check_described
from vptoolkit.dataset.release.hub import hub_yaml, yaml_str
from vptoolkit.dataset.release.licenses import LICENSES_NAME, hub_license, license_conflicts
from vptoolkit.dataset.release.options import ReleaseOptions
from vptoolkit.dataset.release.parquet import model_columns
from vptoolkit.dataset.store.info import (
    CITATION,
    camera_sentence,
    format_number,
    info_from_reader,
    plural,
    size_category,
    source_name,
    split_count_rows,
)
from vptoolkit.dataset.store.schema import ARRAY_SPECS, registered_measures
from vptoolkit.errors import InputError
from vptoolkit.measures.registry import PAPER_MEASURES

if TYPE_CHECKING:
    from vptoolkit.dataset.store.reader import StoreReader
    from vptoolkit.measures.measure import Measure

__all__ = [
    "render_card",
]

_ARRAY_MEANINGS = {name: spec.description for name, spec in ARRAY_SPECS.items()}
"""What each stored array holds, as the card's schema table says it."""

_PAPER_RAW_VALUES = ("Raw values use logarithms base {log_base} (bits; VR is a fraction of "
                     "the surface\narea) and are NaN where a view sees nothing.")
"""The card's sentence on the raw values of the paper's four measures."""

_RAW_VALUES = ("Raw values are in each measure's own unit (logarithms base {log_base}, bits, "
               "for the\ninformation measures) and are NaN where a measure is undefined for "
               "a view (most\nmeasures, for a view that sees nothing).")
"""The card's sentence on the raw values of any other choice of measures."""

_COUNT_WORDS = ("no", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine",
                "ten", "eleven", "twelve")
"""The counts the card's prose writes as words (:func:`_count_word`)."""


def render_card(
    reader: StoreReader,
    files: ReleaseFiles,
    options: ReleaseOptions | None = None,
    *,
    warnings: Sequence[str] = (),
) -> str:
    """Fill ``vptoolkit/dataset_card/template.md`` into a release ``README.md``.

    Parameters
    ----------
    reader : StoreReader
        The store the card describes.
    files : ReleaseFiles
        Release file name -> SHA-256 digest and size, listed in the card
        (the suffixes present name the formats; ``LICENSES.csv`` among them
        points the licence fields at it), and the Parquet shards: with
        shards the YAML header carries the hub's ``configs`` and a full
        ``dataset_info`` (:func:`~vptoolkit.dataset.release.hub.hub_yaml`) and the card shows how
        ``datasets`` and ``mlcroissant`` load them.
    options : ReleaseOptions, optional
        What the publisher said (default: ``ReleaseOptions()``). The card
        uses ``license`` (with ``license_name`` and ``license_link``, the
        hub's fields of it,
        :func:`~vptoolkit.dataset.release.licenses.hub_license`),
        ``pretty_name`` (the title; default from the source folder name),
        ``version``, ``created`` (default: the store's ``created``),
        ``source_url``, ``creator`` (default ``"vptoolkit"``) and ``url``
        (in the citation), and ``force_license``: the licence note then
        records the publisher's decision and every term it contradicts
        (:func:`~vptoolkit.dataset.release.licenses.license_conflicts`).
    warnings : sequence of str
        Lines shown in a warning block under the summary (an empty split, say).

    Returns
    -------
    str
        Markdown with a YAML front matter block. Each model record's
        ``provenance`` (licence, author, url) is tabled under the licence
        note.

    Raises
    ------
    InputError
        If ``files`` or ``options`` is of another type, the store records a
        measure the registry does not know (its title and direction are
        unknown), or the template holds a placeholder no part fills.
    """
    files, options = check_described(files, options)
    measures = registered_measures(reader.measures, reader.path.name)
    info = info_from_reader(reader)
    title = options.pretty_name or f"Viewpoint quality of {source_name(info)} models"
    values = {
        **_header(info, files, options, title),
        **_summary(info, options, title, warnings),
        **_licence(reader, info, options),
        **_files(files),
        **_reading(info, files),
        **_counts(info),
        **_measures(info, measures),
        **_schema(reader),
        **_statistics(info),
        **_datasheet(info, files, options),
        **_citation(info, options, title),
    }
    template = string.Template(_load_template("template.md"))
    try:
        return template.substitute({key: str(value) for key, value in values.items()})
    except (KeyError, ValueError) as err:
        raise InputError(f"template.md: cannot fill placeholder ({err})") from err


def _header(info: dict[str, Any], files: ReleaseFiles, options: ReleaseOptions,
            title: str) -> dict[str, Any]:
    """The YAML header: title, the hub's licence fields, size category and, with shards,
    the hub's configurations (:func:`~vptoolkit.dataset.release.hub.hub_yaml`; without
    shards ``datasets`` has nothing to load: no configs, no splits)."""
    hub = hub_license(options.license, options.license_name, options.license_link,
                      table=LICENSES_NAME in files.digests)
    yaml_license = hub.pop("license")
    return {
        "yaml_pretty_name": yaml_str(title),
        "yaml_license": yaml_str(yaml_license),
        "yaml_license_extra": "".join(f"\n{key}: {yaml_str(value)}"
                                      for key, value in hub.items()),
        "yaml_size_category": yaml_str(size_category(info["n_models"])),
        "yaml_hub": (hub_yaml(files.shards, n_points=int(info["n_points"] or 0),
                              n_views=int(info["n_views"]), class_names=info["class_names"],
                              measures=info["measures"]["order"])
                     if files.shards else ""),
    }


def _summary(info: dict[str, Any], options: ReleaseOptions, title: str,
             warnings: Sequence[str]) -> dict[str, Any]:
    """The title and first paragraph: models, categories, points, measures, views,
    resolution, version and release time, then the warning block."""
    return {
        "title": title,
        "models_phrase": plural(info["n_models"], "model"),
        "n_categories": len(info["categories"]),
        "source": source_name(info),
        "categories": ", ".join(f"`{c}`" for c in info["categories"]) or "none",
        "n_points": info["n_points"],
        "n_views": info["n_views"],
        "resolution": info["resolution"],
        "measure_order": ", ".join(info["measures"]["order"]),
        "measure_count": _count_word(len(info["measures"]["order"])),
        "version": options.version,
        "created": options.created or info.get("created"),
        "toolkit_version": info.get("toolkit_version"),
        "source_url_sentence": (f" Source meshes: <{options.source_url}>."
                                if options.source_url else ""),
        "warnings_block": "".join(f"\n> **Warning.** {line}.\n" for line in warnings),
    }


def _licence(reader: StoreReader, info: dict[str, Any],
             options: ReleaseOptions) -> dict[str, Any]:
    """The licence note: the release's licence, the source meshes' provenance (one
    sentence when every mesh shares one licence, else a table), ModelNet's terms and
    a forced licence's conflicts."""
    release_licence = options.license
    records = reader.models()
    licensed = [r for r in records if r.get("provenance")]
    provenance_rows = [
        [f"`{r['name']}`", r["provenance"].get("license", "-"),
         r["provenance"].get("author", "-"), r["provenance"].get("url", "-")]
        for r in licensed
    ]
    shared = {json.dumps(r["provenance"], sort_keys=True) for r in licensed}
    one_licence = (len(licensed) == len(records) > 0 and len(shared) == 1
                   and set(licensed[0]["provenance"]) == {"license"})
    if one_licence:
        provenance_sentence = (
            f"Every source mesh is under `{licensed[0]['provenance']['license']}`, as the "
            "publisher stated (`provenance` in each model record and the `license` column "
            "of the Parquet shards)."
        )
        provenance_rows = []
    elif licensed:
        provenance_sentence = (
            f"The licence and attribution of {plural(len(licensed), 'source mesh')}"
            f"{'' if len(licensed) == len(records) else f' (of {len(records)})'} are "
            "recorded per model (`provenance` in each model record, the `license`, `author` "
            "and `url` columns of the Parquet shards, and `LICENSES.csv`):"
        )
    else:
        provenance_sentence = ("vptoolkit was given no licence for them "
                               "(`vptool pack --license ID` or `--licenses FILE.csv`); check "
                               "them before redistributing.")
    forced = (_forced_licence_block(release_licence,
                                    license_conflicts(release_licence, reader.attrs, records))
              if options.force_license else "")
    return {
        "license": release_licence,
        "provenance_sentence": provenance_sentence,
        "provenance_table": (_markdown_table(["model", "licence", "author", "url"],
                                             provenance_rows, ["l", "l", "l", "l"])
                             if provenance_rows else ""),
        "terms_block": _terms_block(source_name(info)) + forced,
    }


def _files(files: ReleaseFiles) -> dict[str, Any]:
    """The files table (name, bytes, SHA-256) and which formats hold the same data."""
    rows = [[f"`{name}`", str(files.sizes[name]) if name in files.sizes else "-", f"`{digest}`"]
            for name, digest in sorted(files.digests.items())]
    return {
        "files_table": _markdown_table(["file", "bytes", "sha256"], rows, ["l", "r", "l"]),
        "same_data_sentence": _same_data_sentence(files.digests),
    }


def _reading(info: dict[str, Any], files: ReleaseFiles) -> dict[str, Any]:
    """How to load the release: ``datasets`` and ``mlcroissant`` over the Parquet shards
    (or why not), then the archives with vptoolkit and with ``h5py`` or ``zarr`` alone."""
    archives = [name for name in sorted(files.digests) if name.endswith(".zarr.zip")]
    hdf5_files = [name for name in sorted(files.digests) if name.endswith((".h5", ".hdf5"))]
    if files.shards:
        split_names = ", ".join(f"`{s}`" for s in info["splits"])
        columns = model_columns(int(info["n_points"] or 0), int(info["n_views"]),
                                measures=info["measures"]["order"])
        datasets_block = (
            f"With Hugging Face `datasets` (the Parquet shards, splits {split_names}):\n\n"
            "```python\nfrom datasets import load_dataset\n\n"
            'data = load_dataset("path/to/this/folder")            # or streaming=True\n'
            'points = data["train"].with_format("numpy")[0]["points"]   '
            f"# ({info['n_points']}, 3) float32\n"
            'views = load_dataset("path/to/this/folder", "views")["train"]  '
            f"# the {info['n_views']} view directions\n```"
            "\n\nThe columns of a row (one model):\n\n"
            + _markdown_table(["column", "type", "shape", "meaning"],
                              [[f"`{c.name}`", c.dtype, _shape_text(c.shape), c.description]
                               for c in columns], ["l", "l", "l", "l"])
            + "\n\nWith `mlcroissant` (`pip install 'mlcroissant[parquet]'`), the records "
            "`croissant.json` describes:\n\n"
            "```python\nimport mlcroissant as mlc\n\n"
            'records = mlc.Dataset(jsonld="croissant.json").records(record_set="models")\n'
            'first = next(iter(records))    # "models/name", "models/points", ...\n```'
        )
    else:
        readable = " or ".join(f"`{name}`" for name in [*hdf5_files, *archives]) or "the archive"
        tools = ", ".join(["vptoolkit", *(["`h5py`"] if hdf5_files else []),
                           *(["`zarr>=3`"] if archives else [])])
        datasets_block = (
            "This release has no Parquet shards, so Hugging Face `datasets` cannot load it; "
            f"read {readable} with {tools} as shown below."
        )
    return {
        "datasets_block": datasets_block,
        "store_name": (hdf5_files or archives or ["dataset.h5"])[0],
        "raw_readers": " and ".join(["`h5py`"] * bool(hdf5_files or not archives)
                                    + ["`zarr>=3`"] * bool(archives)) + " read",
        "raw_example": _raw_example(hdf5_files[0] if hdf5_files else None,
                                    archives[0] if archives else None),
    }


def _counts(info: dict[str, Any]) -> dict[str, Any]:
    """The models per category and split, and the class label of each category."""
    count_header, count_rows = split_count_rows(info)
    return {
        "count_table": _markdown_table(count_header, count_rows),
        "class_table": _markdown_table(
            ["label", "category"], [[label, f"`{name}`"] for label, name in
                                    enumerate(info["class_names"])], ["r", "l"]),
    }


def _measures(info: dict[str, Any], registered: Sequence[Measure]) -> dict[str, Any]:
    """The measures: how many, the raw values' units, normalisation, and per measure its
    name, which way is better (both from the registry), raw unit and the mean, min and max
    of its best raw value."""
    measures, stats = info["measures"], info["statistics"]
    rows = [
        [m.name, m.title, "higher" if m.higher_is_better else "lower", measures["units"][m.name],
         format_number(stats["best_value"][m.name]["mean"]),
         format_number(stats["best_value"][m.name]["min"]),
         format_number(stats["best_value"][m.name]["max"])]
        for m in registered
    ]
    names = tuple(m.name for m in registered)
    raw_values = _PAPER_RAW_VALUES if names == PAPER_MEASURES else _RAW_VALUES
    return {
        "n_measures": len(names),
        "raw_values_sentence": raw_values.format(log_base=measures["log_base"]),
        "normalisation": measures["normalisation"],
        "measure_table": _markdown_table(
            ["measure", "name", "best", "raw unit", "best raw mean", "best raw min",
             "best raw max"], rows, ["l", "l", "l", "l", "r", "r", "r"]),
    }


def _schema(reader: StoreReader) -> dict[str, Any]:
    """The arrays of the store: shape, dtype and meaning of each."""
    return {"schema_table": _markdown_table(["array", "shape", "dtype", "meaning"],
                                            _array_rows(reader), ["l", "l", "l", "l"])}


def _statistics(info: dict[str, Any]) -> dict[str, Any]:
    """Faces and vertices per mesh, before and after cleaning, and the failures by reason."""
    stats = info["statistics"]
    reasons = Counter(str(r.get("reason")) for r in info["failures"])
    return {
        "mean_faces": format_number(stats["faces"]["mean"]),
        "min_faces": format_number(stats["faces"]["min"]),
        "max_faces": format_number(stats["faces"]["max"]),
        "mean_vertices": format_number(stats["vertices"]["mean"]),
        "n_cleaned": stats["n_cleaned"],
        "mean_faces_before": format_number(stats["faces_before_cleaning"]["mean"]),
        "n_failures": info["n_failures"],
        "failure_reasons": (
            "; ".join(f"{reason} ({n})" for reason, n in sorted(reasons.items()))
            or "none"
        ),
    }


def _datasheet(info: dict[str, Any], files: ReleaseFiles,
               options: ReleaseOptions) -> dict[str, Any]:
    """The datasheet's own sentences (Gebru et al.): creator, splits, failures, collection,
    cleaning and the formats distributed."""
    n_failures = info["n_failures"]
    fractions = info.get("split_fractions") or {}
    split_sentence = ", ".join(f"{name} {format_number(value)}"
                               for name, value in fractions.items())
    splits_sentence, collection_sentence, cleaning_sentence = _method_sentences(
        info, split_sentence, info.get("cleaning") or {})
    failure_rows = [[f"`{r.get('source')}`", r.get("category") or "-", r.get("reason") or "-"]
                    for r in info["failures"]]
    formats = [label for suffix, label in ((".zarr.zip", "a Zarr v3 zip store"),
                                           (".h5", "an HDF5 file"),
                                           (".parquet", "Parquet shards per split"))
               if any(name.endswith(suffix) for name in files.digests)]
    return {
        "creator": options.creator or "vptoolkit",
        "splits_sentence": splits_sentence,
        "failures_phrase": (
            f"{plural(n_failures, 'input')} could not be processed; "
            f"{'it is' if n_failures == 1 else 'they are'} listed below and in the "
            "`failures_json` array." if n_failures else "No input failed."
        ),
        "failures_table": (_markdown_table(["source", "category", "reason"], failure_rows,
                                           ["l", "l", "l"])
                           if failure_rows else ""),
        "collection_sentence": collection_sentence,
        "cleaning_sentence": cleaning_sentence,
        "formats_sentence": " and ".join(formats) or "no archive",
    }


def _citation(info: dict[str, Any], options: ReleaseOptions, title: str) -> dict[str, Any]:
    """The BibTeX entries: the release itself (:func:`dataset_citation`), then the paper."""
    when = str(options.created or info.get("created") or "")
    return {
        "dataset_citation": dataset_citation(
            title, creator=options.creator or "vptoolkit", year=when[:4],
            version=options.version, url=options.url, source=source_name(info),
            toolkit_version=info.get("toolkit_version")),
        "citation": CITATION,
    }


MODELNET_TERMS = (
    "**ModelNet terms of use.** The source is recognised as ModelNet "
    "(<https://modelnet.cs.princeton.edu/>). Its CAD models were collected from the "
    "Internet and their original authors hold the copyright; the ModelNet team provides "
    "the data for the convenience of academic research only. Those terms apply to the "
    "meshes, points and normals here: use this dataset for academic research, and cite "
    "Wu et al., *3D ShapeNets: A Deep Representation for Volumetric Shapes*, CVPR 2015, "
    "beside this dataset."
)
"""The paragraph a card gains when its source is recognised as ModelNet (ModelNet10/40)."""


def _terms_block(source: str) -> str:
    """ModelNet's terms of use for a ModelNet source, else nothing."""
    return f"\n{MODELNET_TERMS}\n" if re.match(r"modelnet", source, re.IGNORECASE) else ""


def _forced_licence_block(license: str, conflicts: Sequence[str]) -> str:  # noqa: A002
    """The publisher's forced licence and what it contradicts, else nothing."""
    if not conflicts:
        return ""
    return (f"\n**Licence decision.** The publisher released this dataset under `{license}` "
            f"with `vptool pack --force-license`, although that licence contradicts "
            f"{'; and '.join(conflicts)}. This is the publisher's decision, recorded here; "
            "check those terms before you use or redistribute the data.\n")


def dataset_citation(title: str, *, creator: str, year: str, version: str, url: str | None,
                     source: str, toolkit_version: Any) -> str:
    """A BibTeX ``@misc`` entry citing the release itself.

    The key is the title in lower case, its runs of letters and digits
    joined by ``_``, then the year.
    """
    key = re.sub(r"[^a-z0-9]+", "_", title.lower()).strip("_") or "dataset"
    lines = [f"@misc{{{key}_{year},", f"  title   = {{{title}}},", f"  author  = {{{creator}}},",
             f"  year    = {{{year}}},", f"  version = {{{version}}},"]
    if url:
        lines.append(f"  url     = {{{url}}},")
    lines.append(f"  note    = {{Viewpoint quality measures of {source} models, generated "
                 f"with vptoolkit {toolkit_version}}}")
    return "\n".join(lines) + "\n}"


def _raw_example(hdf5_name: str | None, zarr_zip_name: str | None) -> str:
    """Python lines reading model 0's quality and the model names with h5py and/or zarr alone."""
    lines = []
    if hdf5_name or not zarr_zip_name:
        lines += ["import h5py", "",
                  f'with h5py.File("{hdf5_name or "dataset.h5"}", "r") as handle:',
                  '    quality = handle["quality"][0]',
                  '    names = handle["names"].asstr()[...]  # also categories, splits, labels']
    if zarr_zip_name:
        lines += [*([""] if lines else []), "import zarr", "",
                  f'store = zarr.storage.ZipStore("{zarr_zip_name}", mode="r")',
                  'root = zarr.open_group(store, mode="r")',
                  'quality = root["quality"][0]',
                  'names = root["names"][...]  # also categories, splits, labels']
    return "\n".join(lines)


def _shape_text(shape: tuple[int | None, ...]) -> str:
    """``scalar``, ``(4,)`` or ``(n, 3)`` for a column shape (``n`` varies per row)."""
    if not shape:
        return "scalar"
    cells = ["n" if d is None else str(d) for d in shape]
    return "(" + ", ".join(cells) + ("," if len(cells) == 1 else "") + ")"


def _same_data_sentence(files: Mapping[str, str]) -> str:
    """`` The Zarr zip and the HDF5 file hold the same data; ...`` for two or more formats."""
    held = [label for suffix, label in ((".zarr.zip", "the Zarr zip"), (".h5", "the HDF5 file"),
                                        (".parquet", "the Parquet shards"))
            if any(name.endswith(suffix) for name in files)]
    if len(held) < 2:
        return ""
    listed = ", ".join(held[:-1]) + " and " + held[-1]
    return f" {listed[0].upper()}{listed[1:]} hold the same data; use whichever your tools read."


def _load_template(name: str) -> str:
    resource = importlib.resources.files("vptoolkit.dataset_card").joinpath(name)
    return resource.read_text(encoding="utf-8")


def _count_word(count: int) -> str:
    """``four`` for 4: a count as the card's prose says it (digits from 13 on)."""
    return _COUNT_WORDS[count] if count < len(_COUNT_WORDS) else str(count)


def _markdown_table(header: Sequence[str], rows: Sequence[Sequence[Any]],
                    align: Sequence[str] | None = None) -> str:
    align = align or ["l"] + ["r"] * (len(header) - 1)
    rule = ["---:" if a == "r" else "---" for a in align]
    lines = ["| " + " | ".join(_cell(h) for h in header) + " |",
             "| " + " | ".join(rule) + " |"]
    lines += ["| " + " | ".join(_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)


def _array_rows(reader: StoreReader) -> list[list[str]]:
    rows = []
    for name in sorted(reader.array_names()):
        array = reader.array(name)
        shape = ("(" + ", ".join(str(int(n)) for n in array.shape)
                 + ("," if len(array.shape) == 1 else "") + ")")
        dtype = "string" if np.dtype(array.dtype).kind in "OT" else str(np.dtype(array.dtype))
        rows.append([f"`{name}`", shape, dtype,
                     _ARRAY_MEANINGS.get(name, "")])
    return rows


def _cell(text: Any) -> str:
    """Escape a value for a Markdown table cell."""
    return str(text).replace("|", "\\|").replace("\n", " ")


def _method_sentences(info: dict[str, Any], split_sentence: str,
                      cleaning: dict[str, Any]) -> tuple[str, str, str]:
    """The card's sentences on the split, the rendering and the cleaning.

    A store imported from the paper authors' tree (root attribute
    ``provenance``) says so instead: their split rule and their files' digests.
    """
    provenance = info.get("provenance") or {}
    splits_sentence = (
        f"Fractions {split_sentence or 'not recorded'}, decided per model from seed "
        f"{info.get('split_seed')}\n  and `category/name` alone, so adding a model never "
        "moves another; in a\n  ModelNet-style source tree a model under `test/` stays in test."
    )
    collection_sentence = (
        "For every view direction the cleaned mesh was rendered into a triangle-ID image\n"
        f"  of {info['resolution']} x {info['resolution']} pixels (`{info['backend']}` backend). "
        f"Camera: {camera_sentence(info.get('camera'))}.\n"
        "  The per-face pixel counts give the measures in the notation of Bonaventura et\n"
        "  al., as defined in the paper."
    )
    split_file = info.get("split_file")
    if isinstance(split_file, dict):
        splits_sentence = (f"Read from the split file `{split_file.get('name')}` "
                           f"(SHA-256 `{split_file.get('sha256')}`), a published split.")
    if provenance.get("measures") == "imported, not computed":
        splits_sentence = f"The paper's own: {provenance.get('split_rule')}."
        collection_sentence = (
            f"The measures were imported, not computed: they are the paper authors' released "
            f"values for the `{provenance.get('tree')}` data set (small.txt SHA-256 "
            f"`{provenance.get('small_txt_sha256')}`, SHA-256 over the {provenance.get('n_files')} "
            f"files read `{provenance.get('files_sha256')}`), rendered by the authors at "
            f"{info['resolution']} x {info['resolution']} pixels."
        )
    if provenance.get("measures") == "imported, not computed":
        cleaning_sentence = ("The meshes and points are the authors' own, as released "
                             "(cleaned by them, not by `vptoolkit.clean`).")
    elif cleaning.get("enabled"):
        cleaning_sentence = (
            "Every mesh went through the toolkit's cleaning pipeline (`vptoolkit.clean`): "
            "self-intersections resolved, faces hidden from every view removed, then "
            f"simplified to at most {cleaning.get('max_faces')} faces. Each model record "
            "keeps the cleaning report (`cleaning`)."
        )
    else:
        cleaning_sentence = ("The meshes were not cleaned (built with `--no-clean`); "
                             "the measures are computed on the source meshes as read.")
    return splits_sentence, collection_sentence, cleaning_sentence
