"""Releases: a build packed into files others can download, verify and load.

Modules:

- ``pack``: ``pack_release``, packing a store into release files.
- ``options``: ``ReleaseOptions``, what a publisher says about a release.
- ``manifest``: the SHA-256 manifest of a store or release and its verification.
- ``contents``: ``ReleaseFiles``, what packing wrote (digests, sizes, Parquet
  shards) that the card and Croissant describe.
- ``parquet``: the Parquet shards; ``card``: the dataset card;
  ``hub``: the card's dataset-hub YAML header; ``croissant``:
  the Croissant metadata; ``licenses``: per-model licences; ``descriptions``:
  the card and Croissant rewritten after a release changes.
"""
