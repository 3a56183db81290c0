"""Real data: NASA C-MAPSS FD001 remaining-life estimate from the quality index."""

from __future__ import annotations

from pathlib import Path

import pytest

from maintenance.cmapss import PUBLISHED_RMSE, evaluate_fd001, load_split

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "real" / "cmapss_fd001"
pytestmark = pytest.mark.skipif(
    not (DATA / "train_FD001.txt").exists(), reason=f"C-MAPSS FD001 not found at {DATA}"
)


def test_load_split_shapes() -> None:
    train = load_split(DATA / "train_FD001.txt")
    assert len(train.units) == 100
    assert sum(s.shape[0] for s in train.sensors) == 20631
    assert all(s.shape[1] == 21 for s in train.sensors)


def test_fd001_rul_from_prediction_index() -> None:
    """Measured: RMSE 24.1 cycles (no-skill 35.3; published deep nets 14.9–17.0), Spearman 0.84."""
    r = evaluate_fd001(DATA, method="prediction")
    assert r.predicted_rul.shape == (100,)
    assert r.rmse < 26.0
    assert r.rmse < r.baseline_rmse - 8.0
    assert r.rank_correlation > 0.8
    assert r.rmse > min(PUBLISHED_RMSE.values())  # honest: deep nets still do better


def test_fd001_rejects_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(OSError):
        evaluate_fd001(tmp_path)
