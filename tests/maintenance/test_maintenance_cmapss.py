"""Real data: NASA C-MAPSS FD001 remaining-life estimate from the quality index."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from maintenance.cmapss import PUBLISHED_RMSE, evaluate, evaluate_fd001, load_split, pseudo_split

# /work/shared beside the main checkout, or two levels up from a worktree (/work/wt/NAME)
DATA = next(
    (
        p / "shared" / "data" / "real" / "cmapss_fd001"
        for p in Path(__file__).resolve().parents
        if (p / "shared" / "data" / "real").is_dir()
    ),
    Path("shared/data/real/cmapss_fd001"),
)
needs_fd001 = pytest.mark.skipif(
    not (DATA / "train_FD001.txt").exists(), reason=f"C-MAPSS FD001 not found at {DATA}"
)


def _write_subset(folder: Path, *, n_train: int, n_test: int, seed: int) -> None:
    """A C-MAPSS-format subset (one operating condition) never seen by the project.

    Five sensors wear exponentially (three rising, two falling) under noise,
    the rest are constant or pure noise; lives 130–330 cycles; test engines
    stop 5–140 cycles before failure.
    """
    rng = np.random.default_rng(seed)
    drift = np.zeros(21)
    drift[[1, 3, 6, 10, 14]] = [1.5, 20.0, -3.0, 0.8, -0.1]
    noise = np.full(21, 0.3)
    noise[[0, 4, 9, 15, 17, 18]] = 0.0  # constant sensors, as in FD001
    noise[[3, 14]] = [6.0, 0.03]
    base = rng.uniform(10.0, 2000.0, 21)

    def engine(life: int) -> np.ndarray:
        t = np.arange(life, dtype=np.float64)
        wear = np.exp(rng.uniform(3.0, 5.0) * (t / life - 1.0))
        offset = base + rng.normal(0.0, 0.2, 21) * noise
        out: np.ndarray = offset + np.outer(wear, drift) + rng.normal(0.0, 1.0, (life, 21)) * noise
        return out

    def rows(units: list[np.ndarray]) -> str:
        lines = []
        for u, sensors in enumerate(units, start=1):
            for c, values in enumerate(sensors, start=1):
                fields = [str(u), str(c), "0.0001", "-0.0002", "100.0"]
                lines.append(" ".join(fields + [f"{v:.4f}" for v in values]))
        return "\n".join(lines) + "\n"

    train = [engine(int(rng.integers(130, 330))) for _ in range(n_train)]
    test_full = [engine(int(rng.integers(150, 330))) for _ in range(n_test)]
    remaining = [int(rng.integers(5, 140)) for _ in range(n_test)]
    test = [s[: s.shape[0] - r] for s, r in zip(test_full, remaining, strict=True)]
    (folder / "train_FDX.txt").write_text(rows(train))
    (folder / "test_FDX.txt").write_text(rows(test))
    (folder / "RUL_FDX.txt").write_text("\n".join(str(r) for r in remaining) + "\n")


def test_evaluate_runs_unchanged_on_an_unseen_subset(tmp_path: Path) -> None:
    """Measured on this synthetic subset: RMSE 9.9 cycles against a no-skill 38.4."""
    _write_subset(tmp_path, n_train=60, n_test=40, seed=5)
    r = evaluate(tmp_path / "train_FDX.txt", tmp_path / "test_FDX.txt", tmp_path / "RUL_FDX.txt")
    assert r.predicted_rul.shape == (40,)
    assert r.rmse < 0.5 * r.baseline_rmse
    kept = {w.sensor for w in r.weights}
    assert not kept & {1, 5, 10, 16, 18, 19}  # constant sensors dropped
    wearing = {2, 4, 7, 11, 15}
    share = sum(abs(w.weight) for w in r.weights if w.sensor in wearing)
    assert share > 0.5 * sum(abs(w.weight) for w in r.weights)


def test_evaluate_rejects_a_rul_file_of_the_wrong_length(tmp_path: Path) -> None:
    _write_subset(tmp_path, n_train=10, n_test=5, seed=2)
    (tmp_path / "RUL_FDX.txt").write_text("10\n20\n")
    with pytest.raises(ValueError, match="one RUL per test engine"):
        evaluate(tmp_path / "train_FDX.txt", tmp_path / "test_FDX.txt", tmp_path / "RUL_FDX.txt")


def test_evaluate_rejects_unknown_option(tmp_path: Path) -> None:
    _write_subset(tmp_path, n_train=10, n_test=5, seed=2)
    with pytest.raises(ValueError, match="unknown options"):
        evaluate(
            tmp_path / "train_FDX.txt",
            tmp_path / "test_FDX.txt",
            tmp_path / "RUL_FDX.txt",
            window=3,
        )


@needs_fd001
def test_load_split_shapes() -> None:
    train = load_split(DATA / "train_FD001.txt")
    assert len(train.units) == 100
    assert sum(s.shape[0] for s in train.sensors) == 20631
    assert all(s.shape[1] == 21 for s in train.sensors)


@needs_fd001
def test_fd001_evaluate_matches_deep_networks() -> None:
    """Measured: RMSE 15.5 cycles, PHM08 score 443 (deep LSTM 16.14, 1D-CNN 16.97)."""
    r = evaluate(DATA / "train_FD001.txt", DATA / "test_FD001.txt", DATA / "RUL_FD001.txt")
    assert r.predicted_rul.shape == (100,)
    assert np.all((r.predicted_rul >= 0) & (r.predicted_rul <= r.options.cap))
    assert r.rmse <= 16.0
    assert r.rmse < PUBLISHED_RMSE["deep LSTM (Zheng et al. 2017)"]
    assert r.score < 600.0
    assert {w.sensor for w in r.weights} == {2, 3, 4, 7, 8, 9, 11, 12, 13, 14, 15, 17, 20, 21}
    assert all(w.weight > 0 for w in r.weights)  # each worn sensor pushes the index up


@needs_fd001
def test_fd001_pseudo_split_of_training_engines() -> None:
    """Measured: 30 held-out training engines, 4 cuts each: RMSE 16.6 (no-skill 35)."""
    r = pseudo_split(DATA / "train_FD001.txt")
    assert r.predicted_rul.shape[0] >= 100
    assert r.rmse < 18.0
    assert r.rmse < 0.55 * r.baseline_rmse


@needs_fd001
def test_fd001_rul_from_prediction_index() -> None:
    """Earlier AR-trend forecast: RMSE 24.1 cycles (no-skill 35.3), Spearman 0.84."""
    r = evaluate_fd001(DATA, method="prediction")
    assert r.predicted_rul.shape == (100,)
    assert r.rmse < 26.0
    assert r.rmse < r.baseline_rmse - 8.0
    assert r.rank_correlation > 0.8


def test_fd001_rejects_missing_folder(tmp_path: Path) -> None:
    with pytest.raises(OSError):
        evaluate_fd001(tmp_path)
