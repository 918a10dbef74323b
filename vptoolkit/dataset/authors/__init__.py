"""The paper authors' released tree (``../notes/authors-data-layout.md``).

Modules:

- ``importer``: importing their tree into a store, with their split.
- ``check``: comparing our measures with the ones they stored.
- ``export``: writing a store in their tree.
"""

from vptoolkit.deprecation import moved_module

# The names of ``vptoolkit.dataset.authors`` when it was one module (now ``importer``).
__getattr__ = moved_module(__name__, "vptoolkit.dataset.authors.importer")
