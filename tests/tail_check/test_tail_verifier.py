"""The learned verifier: JSON export equals scikit-learn, shipped models are data, the
pipeline keeps the detector's contract."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from tail_check.pipeline import FEATURE_NAMES, MODEL_DIR, TreeModel, load_model, run_pipeline
from tail_check.pipeline.verifier import VerifierParams, fit
from tests.tail_check.tailkit import plain_disc_scene

THRESHOLDS = {"present_threshold": 0.9, "uncertain_threshold": 0.3}


def _toy(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(300, len(FEATURE_NAMES)))
    y = (x[:, 0] + 0.5 * x[:, 3] - x[:, 7] > 0.2).astype(np.int64)
    return x, y


def test_json_trees_give_scikit_learns_probabilities() -> None:
    from sklearn.ensemble import GradientBoostingClassifier

    x, y = _toy(1)
    params = VerifierParams(n_estimators=20)
    fitted = replace(fit(x, y, seed=3, params=params), meta=THRESHOLDS)
    model = TreeModel.from_json(fitted.to_json())
    clf = GradientBoostingClassifier(
        n_estimators=20,
        max_depth=params.max_depth,
        learning_rate=params.learning_rate,
        subsample=params.subsample,
        min_samples_leaf=params.min_samples_leaf,
        random_state=3,
    ).fit(x, y)
    other = np.random.default_rng(9).normal(size=(200, len(FEATURE_NAMES)))
    assert np.allclose(model.probability(other), clf.predict_proba(other)[:, 1], atol=1e-6)


def test_training_is_reproducible_for_a_seed() -> None:
    x, y = _toy(2)
    a = fit(x, y, seed=5, params=VerifierParams(n_estimators=10)).to_json()
    b = fit(x, y, seed=5, params=VerifierParams(n_estimators=10)).to_json()
    assert a == b


def test_fit_needs_both_classes() -> None:
    x, _ = _toy(3)
    with pytest.raises(ValueError, match="both"):
        fit(x, np.zeros(len(x), np.int64), seed=0)


def test_model_file_must_be_a_verifier_json() -> None:
    with pytest.raises(ValueError, match="not JSON"):
        TreeModel.from_json("\x80\x04pickle")
    with pytest.raises(ValueError, match="not a tail verifier"):
        TreeModel.from_json(json.dumps({"format": "other"}))
    x, y = _toy(4)
    with pytest.raises(ValueError, match="thresholds"):
        TreeModel.from_json(fit(x, y, seed=0, params=VerifierParams(n_estimators=2)).to_json())
    doc = json.loads(load_model("A").to_json())
    doc["features"] = doc["features"][:-1]
    with pytest.raises(ValueError, match="other features"):
        TreeModel.from_json(json.dumps(doc))
    with pytest.raises(ValueError, match="not found"):
        load_model("nowhere.json")


def test_shipped_models_are_json_with_their_training_description() -> None:
    assert not [p for p in MODEL_DIR.iterdir() if p.suffix in (".pkl", ".pickle", ".joblib")]
    for name in ("A", "B", "AB"):
        model = load_model(name)
        meta = json.loads((MODEL_DIR / f"verifier_{name}.training.json").read_text("utf-8"))
        assert meta == model.meta
        assert meta["trained_on"] == list(name)
        assert 0 < meta["uncertain_threshold"] < meta["present_threshold"] < 1
        assert meta["validation_false_present"] == 0


def test_pipeline_keeps_the_detect_contract() -> None:
    image, label = plain_disc_scene()
    result = run_pipeline(image)
    record = result.to_dict()
    assert {"verdict", "score", "bbox", "pixel_fraction", "reasons"} <= set(record)
    assert result.verdict == "present" and result.bbox is not None and label.bbox is not None
    x, y, w, h = result.bbox
    lx, ly, lw, lh = label.bbox
    assert abs((x + w / 2) - (lx + lw / 2)) < lw and abs((y + h / 2) - (ly + lh / 2)) < lh
    assert 0 <= result.score <= 1 and result.reasons
    with pytest.raises(ValueError):
        run_pipeline(np.zeros((8, 8, 3), np.uint8))
