"""Stage 4: the calibrated verdict with abstention.

``present`` needs the verifier's probability of the best candidate at or above a
threshold chosen on validation scenes so that no validation scene without a disc
reaches it, with a margin in log-odds (:func:`calibrate`); a band below it answers
``uncertain`` (a person must look); below the band ``absent``. With ``n`` validation
scenes without a disc and none above the threshold, the false-``present`` rate is below
``3 / n`` with 95 % confidence; the model file states ``n`` and that bound.

:func:`combine` optionally joins the hand-tuned detector's opinion; it only ever
leans towards safety.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

__all__ = [
    "CalibrationParams",
    "Combine",
    "VerdictParams",
    "calibrate",
    "combine",
    "learned_verdict",
]

Verdict = Literal["present", "absent", "uncertain"]
Combine = Literal["learned", "guarded", "agree"]


@dataclass(frozen=True)
class CalibrationParams:
    """How the thresholds are chosen on validation scenes.

    Attributes
    ----------
    present_margin : log-odds added to the highest no-disc probability.
    present_floor, present_cap : bounds of the ``present`` threshold.
    uncertain_quantile : the abstention band starts at this quantile of the no-disc
        probabilities (few plain scenes go to a person) ...
    uncertain_floor : ... and never below this.
    """

    present_margin: float = 1.0
    present_floor: float = 0.6
    present_cap: float = 0.9999
    uncertain_quantile: float = 0.95
    uncertain_floor: float = 0.2


def _logit(p: float) -> float:
    p = min(max(p, 1e-9), 1 - 1e-9)
    return math.log(p / (1 - p))


def calibrate(
    probs: NDArray[np.float64],
    discs: NDArray[np.bool_],
    c: CalibrationParams = CalibrationParams(),
) -> dict[str, Any]:
    """Thresholds and their validation figures from per-scene best probabilities."""
    neg, pos = probs[~discs], probs[discs]
    top = float(neg.max()) if neg.size else 0.0
    present = 1 / (1 + math.exp(-(_logit(top) + c.present_margin)))
    present = min(c.present_cap, max(c.present_floor, present))
    q = float(np.quantile(neg, c.uncertain_quantile)) if neg.size else 0.0
    uncertain = min(present - 1e-4, max(c.uncertain_floor, q))
    return {
        "present_threshold": round(present, 6),
        "uncertain_threshold": round(uncertain, 6),
        "calibration_params": {k: getattr(c, k) for k in c.__dataclass_fields__},
        "validation_no_disc": int(neg.size),
        "validation_false_present": int((neg >= present).sum()),
        # 0 of n observed: the one-sided 95 % upper bound of the rate is about 3 / n.
        "false_present_rate_upper95": round(3.0 / max(1, neg.size), 4),
        "validation_no_disc_uncertain": int((neg >= uncertain).sum()),
        "validation_disc": int(pos.size),
        "validation_recall_present": round(float((pos >= present).mean()) if pos.size else 0, 4),
        "validation_recall_uncertain": round(
            float((pos >= uncertain).mean()) if pos.size else 0, 4
        ),
    }


@dataclass(frozen=True)
class VerdictParams:
    """How probabilities become verdicts.

    Attributes
    ----------
    present_threshold : float or None
        Probability for ``present``; None takes the one stored in the model (chosen on
        validation data by ``depot tail-train``).
    uncertain_threshold : float or None
        Lower edge of the abstention band; None takes the model's.
    combine : {"learned", "guarded", "agree"}
        ``learned``: the verifier alone (the default). ``guarded``: the hand-tuned
        verdict, which the verifier may only question: a hand-tuned ``present`` the
        verifier calls ``absent`` becomes ``uncertain``, and a learned ``present`` the
        hand-tuned detector does not share becomes ``uncertain`` (the verifier never
        makes a ``present`` on its own). ``agree``: a verdict only when both give it,
        else ``uncertain``.
    """

    present_threshold: float | None = None
    uncertain_threshold: float | None = None
    combine: Combine = "learned"


def learned_verdict(prob: float, present_at: float, uncertain_at: float) -> Verdict:
    """The verifier's own verdict for the best candidate's probability."""
    if prob >= present_at:
        return "present"
    if prob >= uncertain_at:
        return "uncertain"
    return "absent"


def combine(
    hand: Verdict, learned: Verdict, prob: float, params: VerdictParams
) -> tuple[Verdict, str]:
    """Final verdict and the reason (``prob``: the best candidate's disc probability)."""
    said = f"verifier disc probability {prob:.2f}"
    if params.combine == "learned" or hand == learned:
        return learned, f"learned verifier: disc probability {prob:.2f}"
    if params.combine == "agree":
        return "uncertain", f"hand-tuned detector says {hand}, {said}; look"
    if hand == "present":
        if learned == "absent":
            return "uncertain", f"disc-shaped, but the verifier doubts it ({said}); look"
        return "present", f"disc-shaped red region, the verifier does not object ({said})"
    if learned == "present":
        return "uncertain", f"the verifier sees a possible disc ({said}); look"
    return hand, said
