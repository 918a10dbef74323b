"""The paper authors' released tree (``../notes/authors-data-layout.md``).

Modules:

- ``importer``: importing their tree into a store, with their split.
- ``check``: comparing our measures with the ones they stored.
- ``export``: writing a store in their tree.
"""
