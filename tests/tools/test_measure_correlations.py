"""tools/measure_correlations.py: rank correlations of every two measures over the views, and
``--quick`` writing its section."""

from __future__ import annotations

import re
from pathlib import Path

import measure_correlations
import numpy as np

from fixtures.scripts import RunTool, assert_section_holds
from vptoolkit.measures.registry import all_measures


def test_rank_correlations_are_spearman_with_undefined_rows_for_a_constant_column() -> None:
    x = np.array([3.0, 1.0, 4.0, 1.5, 5.0, 9.0])
    values = np.column_stack([x, x**3, -x, np.full_like(x, 2.0), [1, 2, 3, 4, 5, 6]])
    rho = measure_correlations.rank_correlations(values)
    np.testing.assert_allclose(rho[0, :3], [1.0, 1.0, -1.0])  # any increasing map ranks alike
    assert np.isnan(rho[3, :3]).all() and np.isnan(rho[:3, 3]).all()
    np.testing.assert_array_equal(np.diag(rho), 1.0)
    np.testing.assert_allclose(rho, rho.T)
    # ranks of x: 3, 1, 4, 2, 5, 6 against 1..6: d^2 sums to 4 + 1 + 1 + 4 = 10
    np.testing.assert_allclose(rho[0, 4], 1 - 6 * 10 / (6 * 35))


def test_tied_values_share_their_mean_rank_as_scipy_ranks_them() -> None:
    from scipy.stats import spearmanr

    np.testing.assert_array_equal(measure_correlations.mean_ranks(np.array([2.0, 1, 2, 3, 2])),
                                  [3, 1, 3, 5, 3])
    values = np.random.default_rng(0).integers(0, 5, size=(60, 4)).astype(np.float64)
    np.testing.assert_allclose(measure_correlations.rank_correlations(values),
                               spearmanr(values).statistic, atol=1e-12)


def test_quick_run_prints_the_matrix_of_every_measure_and_writes_its_section(
        tmp_path: Path, run_tool: RunTool) -> None:
    results = tmp_path / "results.md"
    results.write_text("# Results\n\nkept\n")
    result = run_tool("measure_correlations.py", "--quick", "--results", str(results))
    assert result.returncode == 0, result.stderr[-2000:]
    assert_section_holds(results, "measure_correlations", result.stdout)
    assert results.read_text().startswith("# Results\n\nkept\n")
    names = list(all_measures())
    tables = [[cell.strip() for cell in line.strip().strip("|").split("|")]
              for line in result.stdout.splitlines() if line.startswith("| ")]
    rows = {cells[0]: cells[1:] for cells in tables}
    assert rows[""] == names  # the header
    for i, name in enumerate(names):
        cells = rows[name]
        assert len(cells) == len(names) and cells[i] == "+1.00"
        values = [float(c) for c in cells if c != "–"]
        assert all(-1.0 <= v <= 1.0 for v in values)
    assert "100 Fibonacci views at 64 px" in result.stdout
    assert re.search(r"teapot\.stl \(\d+ faces\), rabbit\.obj \(\d+ faces\)", result.stdout)
    # VE and I2 = H(Z) - VE order the views alike, one higher-is-better, the other lower
    assert rows["VE"][names.index("I2")] == "+1.00"
