"""Building, storing, releasing and importing the viewpoint-quality dataset.

One subpackage per stage, each importing only from the stages below it:

- ``store``: the data contract (``schema``), the containers, ``writer`` and
  ``reader``, and ``info``; it imports no other stage.
- ``builder``: the resumable build from a folder of meshes (``run``), its
  ``options``, ``sources``, ``staging``, ``compute``, ``plan`` and
  ``split_files``; imports ``store``.
- ``release``: packing a build into release files (``pack``), its
  ``options``, ``manifest``, ``parquet``, ``card``, ``croissant``,
  ``licenses`` and ``descriptions``; imports ``store``.
- ``authors``: the paper authors' released tree: ``importer``, ``check``
  and ``export``; imports ``store`` and ``builder.split_files``.

Import the modules directly (``from vptoolkit.dataset.store.reader import
open_store``). Neither this package nor a stage's ``__init__`` imports
anything, so ``import vptoolkit.dataset`` stays cheap.
"""
