"""Building, storing, verifying and describing the viewpoint-quality dataset.

Modules, one concept each (import them directly, e.g.
``from vptoolkit.dataset.reader import open_store``):

- ``schema``: the data contract of ``vptoolkit/dataset_card/SCHEMA.md`` (numpy only).
- ``containers``: which container (Zarr v3 directory or zip, HDF5) a path
  names; ``writer``: ``write_dataset``, atomic writing; ``reader``:
  ``open_store`` and ``StoreReader``, lazy reading; ``_zarr`` and ``_hdf5``:
  one container each.
- ``build``: the resumable build from a folder of meshes, with a failure
  log, over ``sources`` (mesh files, ids, splits, seeds), ``staging`` (the
  resumable staging folder) and ``compute`` (one model's task);
  ``build_options``: ``BuildOptions``, what defines a built dataset, checked
  when made; ``plan``: the models a build would take, per category and
  split, and an estimate from a few calibration models; ``split_files``:
  published splits read from a ``name,split`` CSV or the paper's ``small.txt``.
- ``manifest``: the SHA-256 manifest of a store and its verification.
- ``info``, ``card``, ``croissant``: the summary of a store, the dataset
  card and the Croissant metadata, all computed from the store.
- ``release``: packing a build into release files, with ``parquet``,
  ``licenses`` and ``descriptions``; ``release_options``: ``ReleaseOptions``,
  what a publisher says about a release, checked when made.
- ``authors``, ``authors_check``, ``authors_export``: the paper authors'
  released tree: importing it into a store, comparing our measures with the
  stored ones, and writing a store in that tree.

Nothing is imported here, so ``import vptoolkit.dataset`` stays cheap.
"""
