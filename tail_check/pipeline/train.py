"""Training of the verifier: candidates of generated scenes, labelled by the truth box.

A candidate is a disc (label 1) when its centre lies in the true disc box (grown by
``TrainParams.match_margin``) and its box area is within ``TrainParams.area_ratio`` of
the true box's (a lit reflector's bright spot is smaller than its disc); every other
candidate, on every scene, is a hard negative, and so is every candidate on the real
photos of the ``train`` part (:func:`tail_check.dataset.real_photos`). The thresholds
are chosen on the generators' *validation* seeds (never the training seeds, never the
held-out ones the benchmark reports, never a real photo).
"""

from __future__ import annotations

import time
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..dataset import TRAINABLE, Generator, Sample, real_photos, scenes
from ..profile import CameraProfile
from .candidates import Candidate, find_candidates
from .verdict import calibrate
from .verifier import TreeModel, VerifierParams, fit

__all__ = ["TrainParams", "collect", "train"]


@dataclass(frozen=True)
class TrainParams:
    """What the verifier is trained and calibrated on.

    Attributes
    ----------
    train_count, validation_count : scenes per generator from each split.
    real_negatives : also learn from the ``train`` part of the real photos.
    match_margin : growth of the true box (fraction of its size) for a match.
    area_ratio : a matching candidate's box area is within this factor of the truth's.
    ignore_ratio : a candidate on the disc whose area is off by more than ``area_ratio``
        but within this factor (a reflector's spot, a region grown into the body) is
        neither a disc nor a non-disc: it is left out of training.
    """

    train_count: int = 200
    validation_count: int = 100
    real_negatives: bool = True
    match_margin: float = 0.25
    area_ratio: float = 2.5
    ignore_ratio: float = 6.0


def matches(
    c: Candidate, truth: tuple[int, int, int, int] | None, tp: TrainParams, ratio_max: float = 0.0
) -> bool:
    """Whether a candidate is the true disc (box area within ``ratio_max`` or the
    training parameters' ``area_ratio``)."""
    if truth is None:
        return False
    x, y, w, h = truth
    cx, cy = c.bbox[0] + c.bbox[2] / 2, c.bbox[1] + c.bbox[3] / 2
    mx, my = w * tp.match_margin, h * tp.match_margin
    inside = x - mx <= cx <= x + w + mx and y - my <= cy <= y + h + my
    ratio = (c.bbox[2] * c.bbox[3]) / max(1.0, float(w * h))
    limit = ratio_max or tp.area_ratio
    return inside and 1.0 / limit <= ratio <= limit


@dataclass(frozen=True)
class Rows:
    """Feature rows of many scenes: ``x`` (n, k), label ``y`` (n,) of 1 disc, 0 not,
    -1 ambiguous (left out of training), scene index (n,)."""

    x: NDArray[np.float64]
    y: NDArray[np.int64]
    scene: NDArray[np.int64]
    discs: NDArray[np.bool_]
    """Per scene: a disc is on it."""


def collect(samples: Iterable[Sample], profile: CameraProfile, tp: TrainParams) -> Rows:
    """Candidates of every sample, labelled."""
    from . import FEATURE_NAMES

    x: list[NDArray[np.float64]] = []
    y: list[int] = []
    idx: list[int] = []
    discs: list[bool] = []
    for i, s in enumerate(samples):
        discs.append(s.disc)
        for c in find_candidates(s.image, profile)[0]:
            x.append(c.features)
            label = 0
            if s.disc and matches(c, s.bbox, tp):
                label = 1
            elif s.disc and matches(c, s.bbox, tp, tp.ignore_ratio):
                label = -1
            y.append(label)
            idx.append(i)
    xa = np.stack(x) if x else np.zeros((0, len(FEATURE_NAMES)))
    return Rows(xa, np.asarray(y, np.int64), np.asarray(idx, np.int64), np.asarray(discs))


def scene_probs(rows: Rows, model: TreeModel) -> NDArray[np.float64]:
    """Highest candidate probability per scene (0 for a scene without candidates)."""
    out = np.zeros(len(rows.discs))
    if len(rows.y):
        np.maximum.at(out, rows.scene, model.probability(rows.x))
    return out


def train(
    generators: tuple[Generator, ...],
    *,
    seed: int,
    params: TrainParams = TrainParams(),
    verifier: VerifierParams = VerifierParams(),
) -> TreeModel:
    """Train and calibrate a verifier on the given generators' training seeds."""
    from . import PIPELINE_PROFILE

    if not generators or any(g not in TRAINABLE for g in generators):
        raise ValueError(
            f"a verifier is trained on generators {TRAINABLE} only, got {generators}: "
            "generator C is kept for evaluation"
        )
    t0 = time.perf_counter()
    parts = [
        collect(scenes(g, "train", params.train_count), PIPELINE_PROFILE, params)
        for g in generators
    ]
    if params.real_negatives:
        parts.append(collect(real_photos("train"), PIPELINE_PROFILE, params))
    x = np.concatenate([r.x for r in parts])
    y = np.concatenate([r.y for r in parts])
    model = fit(x[y >= 0], y[y >= 0], seed=seed, params=verifier)
    val = collect(
        (s for g in generators for s in scenes(g, "validation", params.validation_count)),
        PIPELINE_PROFILE,
        params,
    )
    meta: dict[str, Any] = {
        "trained_on": list(generators),
        "real_negatives": "train part (1st, 3rd, ... photo of each folder)"
        if params.real_negatives
        else "none",
        "seed": seed,
        "train_scenes_per_generator": params.train_count,
        "train_candidates": int((y >= 0).sum()),
        "train_disc_candidates": int((y == 1).sum()),
        "validation_scenes_per_generator": params.validation_count,
        "train_params": asdict(params),
        "verifier_params": asdict(verifier),
        "seconds": round(time.perf_counter() - t0, 1),
        **calibrate(scene_probs(val, model), val.discs),
    }
    return TreeModel(model.features, model.base, model.rate, model.trees, meta)
