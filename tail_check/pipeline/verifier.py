"""Stage 3: the learned verifier, a gradient-boosted tree ensemble stored as JSON.

Trained with scikit-learn (:func:`fit`), exported as plain arrays (feature, threshold,
children, leaf value per node) and evaluated here with numpy, so a model file is data,
never code: no pickle is ever loaded. :func:`fit` checks that the exported trees give
the same probabilities as scikit-learn before returning.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .features import FEATURE_NAMES

__all__ = ["TreeModel", "VerifierParams", "fit"]

FORMAT = "depot-tail-verifier/1"


@dataclass(frozen=True)
class VerifierParams:
    """Hyper-parameters of the gradient-boosted verifier (scikit-learn names).

    Shallow trees, subsampling and a minimum leaf size keep the model from learning
    one generator's rendering details.
    """

    n_estimators: int = 150
    max_depth: int = 3
    learning_rate: float = 0.08
    subsample: float = 0.8
    min_samples_leaf: int = 8


@dataclass(frozen=True)
class _Tree:
    feature: NDArray[np.int64]
    threshold: NDArray[np.float64]
    left: NDArray[np.int64]
    right: NDArray[np.int64]
    value: NDArray[np.float64]

    def predict(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        node = np.zeros(x.shape[0], np.int64)
        for _ in range(64):  # depth bound; leaves have left == -1
            inner = self.left[node] >= 0
            if not inner.any():
                break
            f = self.feature[node[inner]]
            go_left = x[inner, f] <= self.threshold[node[inner]]
            node[inner] = np.where(go_left, self.left[node[inner]], self.right[node[inner]])
        return self.value[node]


@dataclass(frozen=True)
class TreeModel:
    """A binary gradient-boosting model: ``p = sigmoid(base + rate * sum(trees))``.

    Attributes
    ----------
    features : feature names, must equal :data:`FEATURE_NAMES`.
    base, rate : the initial log-odds and the learning rate.
    trees : the regression trees.
    meta : training description, thresholds and scores (free JSON).
    """

    features: tuple[str, ...]
    base: float
    rate: float
    trees: tuple[_Tree, ...]
    meta: dict[str, Any]

    @cached_property
    def _packed(self) -> tuple[NDArray[np.int64], ...]:
        """All trees as (trees, nodes) arrays, padded with leaves, to walk them at once."""
        size = max((len(t.left) for t in self.trees), default=1)
        n = len(self.trees)
        feature = np.zeros((n, size), np.int64)
        left = np.full((n, size), -1, np.int64)
        right = np.full((n, size), -1, np.int64)
        for i, t in enumerate(self.trees):
            k = len(t.left)
            feature[i, :k], left[i, :k], right[i, :k] = t.feature, t.left, t.right
        return feature, left, right

    @cached_property
    def _values(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        size = max((len(t.left) for t in self.trees), default=1)
        threshold = np.zeros((len(self.trees), size))
        value = np.zeros((len(self.trees), size))
        for i, t in enumerate(self.trees):
            threshold[i, : len(t.left)], value[i, : len(t.left)] = t.threshold, t.value
        return threshold, value

    def probability(self, x: NDArray[np.float64]) -> NDArray[np.float64]:
        """Disc probability per row of ``x`` (shape (n, len(features)))."""
        # scikit-learn compares float32 features with the thresholds; do the same.
        x = np.atleast_2d(np.asarray(x, np.float32)).astype(np.float64)
        feature, left, right = self._packed
        threshold, value = self._values
        trees = np.arange(len(self.trees))[None, :]
        rows = np.arange(x.shape[0])[:, None]
        node = np.zeros((x.shape[0], len(self.trees)), np.int64)
        for _ in range(64):  # depth bound; leaves have left == -1
            nxt = left[trees, node]
            inner = nxt >= 0
            if not inner.any():
                break
            go_left = x[rows, feature[trees, node]] <= threshold[trees, node]
            node = np.where(inner, np.where(go_left, nxt, right[trees, node]), node)
        raw = self.base + self.rate * value[trees, node].sum(axis=1)
        return np.asarray(1.0 / (1.0 + np.exp(-raw)))

    def to_json(self) -> str:
        """The model as JSON text."""
        trees = [
            {
                "feature": t.feature.tolist(),
                "threshold": [round(float(v), 9) for v in t.threshold],
                "left": t.left.tolist(),
                "right": t.right.tolist(),
                "value": [round(float(v), 9) for v in t.value],
            }
            for t in self.trees
        ]
        doc = {
            "format": FORMAT,
            "features": list(self.features),
            "base": self.base,
            "rate": self.rate,
            "trees": trees,
            "meta": self.meta,
        }
        return json.dumps(doc, indent=None, separators=(",", ":"))

    @classmethod
    def from_json(cls, text: str) -> TreeModel:
        """Read a model written by :meth:`to_json`.

        Raises
        ------
        ValueError
            Not a verifier model, or trained on other features.
        """
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"verifier model is not JSON: {exc}") from None
        if not isinstance(doc, dict) or doc.get("format") != FORMAT:
            raise ValueError(f"not a tail verifier model (expected format {FORMAT})")
        if "present_threshold" not in doc.get("meta", {}):
            raise ValueError("verifier model lacks its calibrated thresholds; retrain it")
        if tuple(doc["features"]) != FEATURE_NAMES:
            raise ValueError("verifier model was trained on other features; retrain it")
        trees = tuple(
            _Tree(
                np.asarray(t["feature"], np.int64),
                np.asarray(t["threshold"], np.float64),
                np.asarray(t["left"], np.int64),
                np.asarray(t["right"], np.int64),
                np.asarray(t["value"], np.float64),
            )
            for t in doc["trees"]
        )
        return cls(
            FEATURE_NAMES, float(doc["base"]), float(doc["rate"]), trees, dict(doc.get("meta", {}))
        )

    @classmethod
    def load(cls, path: str | Path) -> TreeModel:
        """Read a model file."""
        return cls.from_json(Path(path).read_text(encoding="utf-8"))


def fit(
    x: NDArray[np.float64],
    y: NDArray[np.int64],
    *,
    seed: int,
    params: VerifierParams = VerifierParams(),
) -> TreeModel:
    """Train the verifier on candidate features ``x`` (n, k) and labels ``y`` (n,) of 0/1.

    Raises
    ------
    ValueError
        When one class is missing.
    """
    from sklearn.ensemble import GradientBoostingClassifier

    if len(set(y.tolist())) < 2:
        raise ValueError("training needs both disc and non-disc candidates")
    clf = GradientBoostingClassifier(
        n_estimators=params.n_estimators,
        max_depth=params.max_depth,
        learning_rate=params.learning_rate,
        subsample=params.subsample,
        min_samples_leaf=params.min_samples_leaf,
        random_state=seed,
    )
    clf.fit(x, y)
    prior = float(np.clip(y.mean(), 1e-6, 1 - 1e-6))
    trees = []
    for est in clf.estimators_[:, 0]:
        t = est.tree_
        trees.append(
            _Tree(
                np.asarray(t.feature, np.int64).clip(min=0),
                np.asarray(t.threshold, np.float64),
                np.asarray(t.children_left, np.int64),
                np.asarray(t.children_right, np.int64),
                np.asarray(t.value[:, 0, 0], np.float64),
            )
        )
    model = TreeModel(
        FEATURE_NAMES,
        float(np.log(prior / (1 - prior))),
        float(params.learning_rate),
        tuple(trees),
        {},
    )
    expected = clf.predict_proba(x)[:, 1]
    if not np.allclose(model.probability(x), expected, atol=1e-6):
        raise RuntimeError("exported trees disagree with scikit-learn; export is broken")
    return model
