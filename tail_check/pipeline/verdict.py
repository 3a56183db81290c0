"""Stage 4: the calibrated verdict with abstention, and its combination with the
hand-tuned detector.

``present`` needs the verifier's probability at or above a threshold chosen on
validation scenes so that no validation scene without a disc reaches it (target
false-``present`` rate below 1e-3); a band below it answers ``uncertain`` (a person
must look); below the band ``absent``. The combination with the hand-tuned detector
only ever leans towards safety: see :class:`VerdictParams`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

__all__ = ["Combine", "VerdictParams", "combine", "learned_verdict"]

Verdict = Literal["present", "absent", "uncertain"]
Combine = Literal["learned", "guarded"]


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
    veto_threshold : float
        In ``guarded`` mode, a hand-tuned ``present`` whose own region's learned
        probability is below this is downgraded to ``uncertain``.
    combine : {"learned", "guarded"}
        ``learned``: the verifier alone. ``guarded``: the hand-tuned verdict, with the
        verifier allowed to *downgrade* ``present`` to ``uncertain`` (veto) and to raise
        ``absent`` to ``uncertain`` (a possible disc a person should see); it never
        makes a ``present`` on its own.
    """

    present_threshold: float | None = None
    uncertain_threshold: float | None = None
    veto_threshold: float = 0.05
    combine: Combine = "guarded"


def learned_verdict(prob: float, present_at: float, uncertain_at: float) -> Verdict:
    """The verifier's own verdict for the best candidate's probability."""
    if prob >= present_at:
        return "present"
    if prob >= uncertain_at:
        return "uncertain"
    return "absent"


def combine(
    hand: Verdict, learned: Verdict, prob: float, at_hand: float, params: VerdictParams
) -> tuple[Verdict, str]:
    """Final verdict and the reason.

    Parameters
    ----------
    hand, learned : the hand-tuned and the learned verdicts
    prob : the best candidate's disc probability
    at_hand : the probability of the hand-tuned detector's own best region
    """
    if params.combine == "learned":
        return learned, f"learned verifier: disc probability {prob:.2f}"
    if hand == "present":
        if at_hand < params.veto_threshold:
            return "uncertain", f"disc-shaped, but the verifier doubts it (p={at_hand:.2f})"
        return "present", f"disc-shaped red region, verifier agrees (p={at_hand:.2f})"
    if learned == "present" or (hand == "absent" and learned == "uncertain"):
        return "uncertain", f"the verifier sees a possible disc (p={prob:.2f}); look"
    return hand, f"verifier disc probability {prob:.2f}"
