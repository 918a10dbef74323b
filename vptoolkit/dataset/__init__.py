"""Building, storing, verifying and describing the viewpoint-quality dataset.

Modules, one concept each (import them directly, e.g.
``from vptoolkit.dataset.store import open_store``):

- ``store``: the on-disk layout of ``dataset_card/SCHEMA.md`` in Zarr v3
  (directory or zip) and HDF5; atomic writing and lazy reading.
- ``build``: the resumable build from a folder of meshes, with a failure log.
- ``manifest``: the SHA-256 manifest of a store and its verification.
- ``card``: the dataset card filled in from a store.
- ``release``: packing a build into release files.

Nothing is imported here, so ``import vptoolkit.dataset`` stays cheap.
"""
