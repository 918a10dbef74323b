"""The version of vptoolkit: the one place it is written.

``pyproject.toml`` reads it for the package metadata
(``[tool.setuptools.dynamic]``), ``vptoolkit.__version__`` re-exports it, and
stores, training records and checkpoints record it.
"""

__version__ = "0.1.0"
