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
  resumable staging folder) and ``compute`` (one model's task).
- ``manifest``: the SHA-256 manifest of a store and its verification.
- ``info``, ``card``, ``croissant``: the summary of a store, the dataset
  card and the Croissant metadata, all computed from the store.
- ``release``: packing a build into release files, with ``parquet``,
  ``licenses`` and ``descriptions``; ``release_options``: ``ReleaseOptions``,
  what a publisher says about a release, checked when made.

Nothing is imported here, so ``import vptoolkit.dataset`` stays cheap.
"""
