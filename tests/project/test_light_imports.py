"""The loader, the CLI and the picture modules must not drag in the heavy packages."""

import subprocess
import sys

import pytest

HEAVY = ("torch", "open3d", "pymeshlab", "numba")


@pytest.mark.parametrize("module", ["vptoolkit", "vptoolkit.cli", "vptoolkit.measures",
                                    "vptoolkit.io", "vptoolkit.data",
                                    "vptoolkit.dataset.release.pack",
                                    "vptoolkit.pictures._open3d_child",
                                    "vptoolkit.pictures.views",
                                    "vptoolkit.pictures.software_engine",
                                    "vptoolkit.pictures.report"])
def test_import_loads_no_heavy_package(module):
    code = f"import sys, {module}; print(','.join(m for m in {HEAVY!r} if m in sys.modules))"
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == "", f"{module} imported {loaded}"


def test_the_reader_imports_no_container_or_table_library_until_used():
    code = ("import sys, vptoolkit.data, vptoolkit.dataset.release.pack; "
            "print(','.join(m for m in ('zarr', 'h5py', 'pyarrow', 'pandas') if m in sys.modules))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == "", loaded
