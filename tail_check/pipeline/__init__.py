"""The tail check as a pipeline of named stages.

1. :mod:`.proposals` — illumination-robust colour maps (red-hue saturation,
   chromaticity, auto-exposed value) and multi-scale proposals: centre-surround blobs,
   bright spots (lit reflectors) and colour regions at several strictness levels,
   together with the paper's band ``c_ref ± c_Δ``;
2. :mod:`.features` — per candidate: local segmentation, shape, colour inside vs rim vs
   ring (also per sector), scale, scene; :mod:`.candidates` joins 1 and 2;
3. :mod:`.verifier` — a gradient-boosted tree ensemble trained by ``depot tail-train``,
   shipped as JSON (``tail_check/models/verifier_*.json``);
4. :mod:`.verdict` — calibrated verdict with abstention.

:func:`run_pipeline` keeps the :class:`~tail_check.detect.DetectionResult` contract.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..detect import DetectionResult, Verdict, check_image, detect
from ..profile import DEFAULT_PROFILE, CameraProfile
from .candidates import FEATURE_NAMES, Candidate, CandidateParams, find_candidates
from .verdict import VerdictParams, combine, learned_verdict
from .verifier import TreeModel, VerifierParams

__all__ = [
    "FEATURE_NAMES",
    "MODEL_DIR",
    "PIPELINE_PROFILE",
    "Candidate",
    "CandidateParams",
    "TreeModel",
    "VerdictParams",
    "VerifierParams",
    "best_candidate",
    "find_candidates",
    "judge",
    "load_model",
    "run_pipeline",
]

MODEL_DIR = Path(__file__).resolve().parent.parent / "models"
"""Shipped models: ``verifier_AB.json`` (both generators, the default), ``verifier_A.json``
and ``verifier_B.json`` (one generator each, for the cross-generator evaluation)."""

PIPELINE_PROFILE = replace(DEFAULT_PROFILE, name="default-whole-frame", search_region=(0, 0, 1, 1))
"""Profile used without one: the standard signal red, searched in the whole frame (an
uncalibrated camera says nothing about where the disc will be)."""


@lru_cache(maxsize=8)
def load_model(name: str = "AB") -> TreeModel:
    """A shipped verifier model by training set name (``AB``, ``A`` or ``B``) or a path."""
    path = Path(name) if name.endswith(".json") else MODEL_DIR / f"verifier_{name}.json"
    if not path.is_file():
        raise ValueError(f"verifier model {path} not found; run `depot tail-train --out {path}`")
    return TreeModel.load(path)


def best_candidate(candidates: list[Candidate], model: TreeModel) -> tuple[Candidate | None, float]:
    """The candidate with the highest disc probability, and that probability."""
    if not candidates:
        return None, 0.0
    probs = model.probability(np.stack([c.features for c in candidates]))
    i = int(np.argmax(probs))
    return candidates[i], float(probs[i])


def judge(
    candidates: list[Candidate],
    model: TreeModel,
    params: VerdictParams = VerdictParams(),
    hand: Verdict | None = None,
) -> tuple[Verdict, str, Candidate | None, float]:
    """Verdict, reason, best candidate and its probability for one snapshot's candidates.

    ``hand`` is the hand-tuned detector's verdict (needed unless ``params.combine`` is
    ``learned``). One set of candidates can be judged by several models.
    """
    best, prob = best_candidate(candidates, model)
    present_at = params.present_threshold or float(model.meta["present_threshold"])
    uncertain_at = params.uncertain_threshold or float(model.meta["uncertain_threshold"])
    learned = learned_verdict(prob, present_at, uncertain_at)
    if params.combine != "learned" and hand is None:
        raise ValueError(f"combine={params.combine!r} needs the hand-tuned verdict")
    verdict, reason = combine(hand or learned, learned, prob, params)
    return verdict, reason, best, prob


def run_pipeline(
    image_bgr: NDArray[np.uint8],
    profile: CameraProfile | None = None,
    *,
    model: TreeModel | None = None,
    params: VerdictParams = VerdictParams(),
) -> DetectionResult:
    """Detect the tail disc with the staged pipeline.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8, BGR
    profile : camera profile (default: :data:`PIPELINE_PROFILE` for the learned stages,
        :data:`~tail_check.profile.DEFAULT_PROFILE` for the hand-tuned detector)
    model : verifier (default: the shipped ``AB`` model)
    params : thresholds and whether the hand-tuned detector is consulted

    Returns
    -------
    DetectionResult
        As :func:`~tail_check.detect.detect`; ``score`` is the disc probability for
        ``present``/``uncertain`` and one minus it for ``absent``.
    """
    image = check_image(image_bgr)
    p = profile if profile is not None else PIPELINE_PROFILE
    m = model if model is not None else load_model()
    cands, maps = find_candidates(image, p)
    # The hand-tuned detector keeps its own default (its search region) when no profile
    # is given: it was tuned with it.
    hand = detect(image, profile) if params.combine != "learned" else None
    verdict, reason, best, prob = judge(cands, m, params, hand.verdict if hand else None)
    bbox = best.bbox if best is not None and verdict != "absent" else None
    if hand is not None and hand.verdict == verdict and hand.bbox is not None:
        bbox = hand.bbox
    score = 1.0 - prob if verdict == "absent" else prob
    height, width = image.shape[:2]
    return DetectionResult(
        verdict=verdict,
        score=float(np.clip(score, 0.0, 1.0)),
        bbox=bbox,
        pixel_fraction=float(maps.band.sum()) / (maps.work_side**2),
        disc_score=prob,
        quality=hand.quality if hand else 1.0,
        search_region=hand.search_region if hand else _region(p, width, height),
        image_size=(width, height),
        candidates=hand.candidates if hand else (),
        reasons=(reason, *(hand.reasons if hand else ())),
    )


def _region(p: CameraProfile, width: int, height: int) -> tuple[int, int, int, int]:
    from .proposals import region_box

    return region_box(p, width, height)
