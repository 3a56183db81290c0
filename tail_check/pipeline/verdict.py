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
        In ``guarded`` mode, a hand-tuned ``present`` whose best learned probability is
        below this is downgraded to ``uncertain``.
    combine : {"learned", "guarded"}
        ``learned``: the verifier alone. ``guarded``: the hand-tuned verdict, with the
        verifier allowed to *downgrade* ``present`` to ``uncertain`` (veto) and to raise
        ``absent`` to ``uncertain`` (a possible disc a person should see), and to give
        ``present`` only where both agree or the verifier alone is above its
        calibrated threshold and the hand-tuned detector saw a red region there.
    """

    present_threshold: float | None = None
    uncertain_threshold: float | None = None
    veto_threshold: float = 0.2
    combine: Combine = "guarded"


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
    """Final verdict and the reason, from the hand-tuned and the learned verdicts."""
    if params.combine == "learned":
        return learned, f"learned verifier: disc probability {prob:.2f}"
    if hand == "present":
        if prob < params.veto_threshold:
            return "uncertain", f"disc-shaped, but the verifier doubts it (p={prob:.2f})"
        return "present", f"disc-shaped red region, verifier agrees (p={prob:.2f})"
    if learned == "present" or (hand == "absent" and learned == "uncertain"):
        return "uncertain", f"the verifier sees a possible disc (p={prob:.2f}); look"
    return hand, f"verifier disc probability {prob:.2f}"
