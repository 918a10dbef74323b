"""The store: a built dataset's arrays and attributes in one container.

Modules:

- ``schema``: the data contract of ``vptoolkit/dataset_card/SCHEMA.md`` (numpy only).
- ``containers``: which container (Zarr v3 directory or zip, HDF5) a path names.
- ``writer``: ``write_dataset``, atomic writing; ``reader``: ``open_store`` and
  ``StoreReader``, lazy reading; ``_zarr`` and ``_hdf5``: one container each.
- ``entries``: ``LazyEntries``, models made on access, none kept.
- ``info``: the summary of a store (``vptool info``).

Nothing here imports from the other stages (``builder``, ``release``, ``authors``).
"""
