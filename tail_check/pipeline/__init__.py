"""The tail check as a pipeline of named stages.

1. :mod:`.candidates` — the paper's colour method (Gaussian low-pass, per-channel band
   ``c_ref ± c_Δ``) plus a chromaticity band, connected regions;
2. features per candidate (shape, colour inside vs ring, position, scene), same module;
3. :mod:`.verifier` — a gradient-boosted tree ensemble trained by ``depot tail-train``,
   shipped as JSON (``tail_check/models/verifier_*.json``);
4. :mod:`.verdict` — calibrated verdict with abstention, combined with the hand-tuned
   detector (:func:`tail_check.detect.detect`) so that it only leans towards safety.

:func:`run_pipeline` keeps the :class:`~tail_check.detect.DetectionResult` contract.
"""

from __future__ import annotations

from dataclasses import replace
from functools import lru_cache
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ..detect import DetectionResult, check_image, detect
from ..profile import DEFAULT_PROFILE, CameraProfile
from .candidates import FEATURE_NAMES, Candidate, CandidateParams, find_candidates
from .verdict import VerdictParams, combine, learned_verdict
from .verifier import TreeModel, VerifierParams

__all__ = [
    "FEATURE_NAMES",
    "MODEL_DIR",
    "Candidate",
    "CandidateParams",
    "TreeModel",
    "VerdictParams",
    "VerifierParams",
    "best_candidate",
    "load_model",
    "run_pipeline",
]

MODEL_DIR = Path(__file__).resolve().parent.parent / "models"
"""Shipped models: ``verifier_AB.json`` (both generators, the default), ``verifier_A.json``
and ``verifier_B.json`` (one generator each, for the cross-generator evaluation)."""


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


def run_pipeline(
    image_bgr: NDArray[np.uint8],
    profile: CameraProfile | None = None,
    *,
    model: TreeModel | None = None,
    params: VerdictParams = VerdictParams(),
) -> DetectionResult:
    """Detect the tail disc with the hand-tuned detector and the learned verifier.

    Parameters
    ----------
    image_bgr : ndarray, shape (H, W, 3), uint8, BGR
    profile : camera profile (default :data:`~tail_check.profile.DEFAULT_PROFILE`)
    model : verifier (default: the shipped ``AB`` model)
    params : thresholds and the combination rule

    Returns
    -------
    DetectionResult
        As :func:`~tail_check.detect.detect`; ``score`` is the learned probability for
        a learned ``present``/``uncertain``, and reasons name both opinions.
    """
    image = check_image(image_bgr)
    p = profile if profile is not None else DEFAULT_PROFILE
    m = model if model is not None else load_model()
    hand = detect(image, p)
    cands, _ = find_candidates(image, p, hand=hand.candidates)
    best, prob = best_candidate(cands, m)
    # The hand-tuned best region comes first when there is one (see find_candidates).
    first = hand.candidates[0].bbox if hand.candidates else None
    own = cands[0] if cands and cands[0].bbox == first else None
    at_hand = float(m.probability(own.features[None, :])[0]) if own is not None else 0.0
    present_at = params.present_threshold or float(m.meta["present_threshold"])
    uncertain_at = params.uncertain_threshold or float(m.meta["uncertain_threshold"])
    learned = learned_verdict(prob, present_at, uncertain_at)
    verdict, reason = combine(hand.verdict, learned, prob, at_hand, params)
    bbox = hand.bbox
    if verdict != "absent" and (bbox is None or hand.verdict != verdict) and best is not None:
        bbox = best.bbox
    score = hand.score if verdict == hand.verdict else prob
    if verdict == "absent":
        bbox, score = None, min(hand.score, 1.0 - prob)
    return replace(
        hand,
        verdict=verdict,
        score=float(np.clip(score, 0.0, 1.0)),
        bbox=bbox,
        reasons=(reason, *hand.reasons),
    )
