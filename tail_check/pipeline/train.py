"""Training of the verifier: candidates of generated scenes, labelled by the truth box.

A candidate is a disc (label 1) when its centre lies in the true disc box (grown by
``TrainParams.match_margin``) and its box area is within ``TrainParams.area_ratio`` of
the true box's; every other candidate, on every scene, is a hard negative. The
thresholds are chosen on the generators' *validation* seeds (never the training
seeds, never the held-out ones the benchmark reports).
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..dataset import Generator, Sample, scenes
from ..detect import detect
from ..profile import DEFAULT_PROFILE
from . import best_candidate
from .candidates import Candidate, find_candidates
from .verifier import TreeModel, VerifierParams, fit

__all__ = ["TrainParams", "train"]


@dataclass(frozen=True)
class TrainParams:
    """What the verifier is trained and calibrated on.

    Attributes
    ----------
    train_count, validation_count : scenes per generator from each split.
    match_margin : growth of the true box (fraction of its size) for a match.
    area_ratio : a matching candidate's box area is within this factor of the truth's.
    present_margin : added to the highest validation no-disc probability.
    present_floor : the ``present`` threshold is never below this.
    uncertain_quantile : the abstention band starts at this quantile of the
        validation no-disc probabilities (so few plain scenes go to a person).
    uncertain_floor : ... and never below this.
    """

    train_count: int = 200
    validation_count: int = 100
    match_margin: float = 0.25
    area_ratio: float = 3.0
    present_margin: float = 0.02
    present_floor: float = 0.6
    uncertain_quantile: float = 0.95
    uncertain_floor: float = 0.2


def _matches(c: Candidate, truth: tuple[int, int, int, int] | None, tp: TrainParams) -> bool:
    if truth is None:
        return False
    x, y, w, h = truth
    cx, cy = c.bbox[0] + c.bbox[2] / 2, c.bbox[1] + c.bbox[3] / 2
    mx, my = w * tp.match_margin, h * tp.match_margin
    inside = x - mx <= cx <= x + w + mx and y - my <= cy <= y + h + my
    ratio = (c.bbox[2] * c.bbox[3]) / max(1.0, float(w * h))
    return inside and 1.0 / tp.area_ratio <= ratio <= tp.area_ratio


Rows = tuple[list[NDArray[np.float64]], list[int]]


def _rows(samples: Iterable[Sample], tp: TrainParams) -> Rows:
    x: list[NDArray[np.float64]] = []
    y: list[int] = []
    for s in samples:
        cands, _ = find_candidates(s.image, DEFAULT_PROFILE, hand=detect(s.image).candidates)
        for c in cands:
            x.append(c.features)
            y.append(int(s.disc and _matches(c, s.bbox, tp)))
    return x, y


def _image_probs(samples: list[Sample], model: TreeModel) -> NDArray[np.float64]:
    out = []
    for s in samples:
        cands, _ = find_candidates(s.image, DEFAULT_PROFILE, hand=detect(s.image).candidates)
        out.append(best_candidate(cands, model)[1])
    return np.asarray(out)


def _calibrate(
    probs: NDArray[np.float64], discs: NDArray[np.bool_], tp: TrainParams
) -> dict[str, Any]:
    neg = probs[~discs]
    top = float(neg.max()) if neg.size else 0.0
    present = min(0.999, max(tp.present_floor, top + tp.present_margin))
    q = float(np.quantile(neg, tp.uncertain_quantile)) if neg.size else 0.0
    uncertain = min(present - 1e-3, max(tp.uncertain_floor, q))
    pos = probs[discs]
    return {
        "present_threshold": round(present, 4),
        "uncertain_threshold": round(uncertain, 4),
        "validation_no_disc": int(neg.size),
        "validation_false_present": int((neg >= present).sum()),
        # 0 of n observed: the one-sided 95 % upper bound of the rate is about 3 / n.
        "false_present_rate_upper95": round(3.0 / max(1, neg.size), 4),
        "validation_disc": int(pos.size),
        "validation_recall_present": round(float((pos >= present).mean()) if pos.size else 0, 4),
        "validation_recall_uncertain": round(
            float((pos >= uncertain).mean()) if pos.size else 0, 4
        ),
    }


def train(
    generators: tuple[Generator, ...],
    *,
    seed: int,
    params: TrainParams = TrainParams(),
    verifier: VerifierParams = VerifierParams(),
) -> TreeModel:
    """Train and calibrate a verifier on the given generators' training seeds."""
    t0 = time.perf_counter()
    xs: list[NDArray[np.float64]] = []
    ys: list[int] = []
    for g in generators:
        x, y = _rows(scenes(g, "train", params.train_count), params)
        xs += x
        ys += y
    model = fit(np.stack(xs), np.asarray(ys, np.int64), seed=seed, params=verifier)
    val = [s for g in generators for s in scenes(g, "validation", params.validation_count)]
    probs = _image_probs(val, model)
    meta: dict[str, Any] = {
        "trained_on": list(generators),
        "seed": seed,
        "train_scenes_per_generator": params.train_count,
        "train_candidates": len(ys),
        "train_disc_candidates": int(sum(ys)),
        "validation_scenes_per_generator": params.validation_count,
        "train_params": asdict(params),
        "verifier_params": asdict(verifier),
        "seconds": round(time.perf_counter() - t0, 1),
        **_calibrate(probs, np.asarray([s.disc for s in val]), params),
    }
    if not math.isfinite(meta["present_threshold"]):  # pragma: no cover - guarded above
        raise RuntimeError("threshold calibration failed")
    return TreeModel(model.features, model.base, model.rate, model.trees, meta)
