"""The maintenance package keeps modules with one job, none over 400 lines (issue 16), and the
C-MAPSS API keeps its one import path after the split into data, reference and evaluation."""

from __future__ import annotations

from pathlib import Path

import maintenance
from maintenance import cmapss, cmapss_data, cmapss_reference

MAX_LINES = 400


def test_no_maintenance_module_is_over_400_lines() -> None:
    package = Path(maintenance.__file__).parent
    long = {
        p.name: n
        for p in package.glob("*.py")
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_LINES
    }
    assert not long, f"split these modules: {long}"


def test_cmapss_names_stay_importable_from_one_place() -> None:
    assert cmapss.evaluate_fd001 is cmapss_reference.evaluate_fd001
    assert cmapss.load_split is cmapss_data.load_split
    assert cmapss.PUBLISHED_RMSE is cmapss_data.PUBLISHED_RMSE
    assert set(cmapss.__all__) <= set(dir(cmapss))
