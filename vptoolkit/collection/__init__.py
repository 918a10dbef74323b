"""A whole collection of model files: best views and thumbnails of every one, resumable.

``discover`` finds the entries (a folder walked recursively, a glob, or a list
file), streamed and keyed by their path relative to the root given;
``methods`` are what each entry gets (the search, every view measured, a
view set); ``runner`` runs one method over the entries through
:mod:`vptoolkit.parallel`, staged entry by entry so that a rerun does only
what is missing; ``table`` writes the staged answers as one Parquet table
whose bytes do not depend on the worker count, the scheduler, the order of
completion or a resume; ``plan`` sizes a run before it runs. ``vptool
best-view`` and ``vptool thumbnails`` run collections through
:func:`vptoolkit.collection.runner.run_collection`.
"""
