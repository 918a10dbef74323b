"""tools/bench_train.py --quick: the training benchmark runs end to end and prints its ratios."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import require_package

require_package("torch")
require_package("zarr")

TOOL = Path(__file__).resolve().parents[1] / "tools" / "bench_train.py"


@pytest.mark.slow
def test_quick_bench_prints_every_row_with_a_rate():
    result = subprocess.run([sys.executable, str(TOOL), "--quick"], capture_output=True, text=True,
                            timeout=600, check=False)
    assert result.returncode == 0, result.stderr[-2000:]
    rows = [line for line in result.stdout.splitlines() if line.startswith("  ")]
    assert [row.split("  ")[1].strip() for row in rows][:3] == [
        "bare step, plain Adam", "bare step, fused Adam", "train_model, FPS per item"]
    assert len(rows) == 5 and all(re.search(r"\d+\.\d", row) for row in rows)
